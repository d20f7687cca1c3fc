//! `omnisim project`: panoramic, equirectangular, perspective and bird's-eye views resampled
//! from omnidirectional images through their camera's model.

use std::path::PathBuf;
use std::time::Instant;

use std::io::Write;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use omnisim::Camera;
use omnisim::atomic_file::write_atomically;
use omnisim::output::folder::create_real_folder;
use omnisim_vision::{Interpolation, Raster, Remap, View};
use serde_json::{Value, json};

pub(crate) use crate::camera_args::parse_size;

use super::vision_input::{InputArgs, InputSet, NamedSettings, check_image_sizes, read_image};

/// Resample omnidirectional images into other views (docs/vision.md, "Projections").
///
/// Each --view NAME[:KEY=VALUE,...] writes OUT/<set>/<stem>-NAME.png for every image, and
/// OUT/<set>/NAME-valid.png (white where the mirror sees the view's pixel; the views are
/// black elsewhere). OUT/<set>/project.json records the views, their models and the frames.
/// Views and their settings [defaults]:
///   panorama     cylindrical, rows uniform in tan(elevation) [width=1024, height=256, low=-45, high=15 (degrees)]
///   equirect     unit sphere, full turn × half turn [width=1024, height=512]
///   perspective  pinhole looking at azimuth yaw, elevation pitch [width=640, height=480, hfov=90, yaw=0, pitch=0 (degrees)]
///   birds-eye    orthographic view of the plane z = plane (metres, body frame) [width=400, height=400, scale=0.01 (m/px), plane=-0.7]
/// Ranges: a view up to 4096×4096 pixels; low and high −89 to 89, hfov 0 to 179 (exclusive),
/// yaw −360 to 360, pitch −90 to 90 (degrees); scale and |plane| 1e-6 to 1000 m.
/// Only central mirrors (hyperbolic, parabolic with a = b, aligned) have the closed-form
/// projection this needs.
#[derive(Debug, Clone, Args)]
#[command(
    verbatim_doc_comment,
    after_help = "Examples:\n  \
omnisim render scenes/env1.ron --camera omni --size 500x500 --pose 0.5,0.2,0.4 --out out/omni\n  \
omnisim project out/omni --size 500x500 --view panorama --view birds-eye:scale=0.02 --out out/views\n  \
omnisim project data/env1 --set map --view perspective:yaw=90,hfov=70 --interpolation bilinear --out out/map-views"
)]
pub(crate) struct ProjectArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// A view and its settings, NAME[:KEY=VALUE,...] (list above); repeat for several.
    #[arg(long = "view", required = true, value_parser = NamedSettings::parse)]
    pub views: Vec<NamedSettings>,
    #[arg(long, value_enum, default_value = "bicubic")]
    pub interpolation: InterpolationArg,
    /// Output folder (created if missing); one sub-folder per set.
    #[arg(long)]
    pub out: PathBuf,
}

/// How values between pixel centres are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum InterpolationArg {
    /// Linear in x and y (2 × 2 pixels).
    Bilinear,
    /// Keys' cubic convolution, a = −0.5 (4 × 4 pixels).
    #[default]
    Bicubic,
}

impl InterpolationArg {
    pub fn name(self) -> &'static str {
        match self {
            InterpolationArg::Bilinear => "bilinear",
            InterpolationArg::Bicubic => "bicubic",
        }
    }
}

impl From<InterpolationArg> for Interpolation {
    fn from(value: InterpolationArg) -> Self {
        match value {
            InterpolationArg::Bilinear => Interpolation::Bilinear,
            InterpolationArg::Bicubic => Interpolation::Bicubic,
        }
    }
}

/// `LOW:HIGH` in degrees.
pub(crate) fn parse_degrees_range(text: &str) -> Result<(f64, f64), String> {
    let parse = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
    match text.split_once(':').map(|(a, b)| (parse(a), parse(b))) {
        Some((Some(low), Some(high))) if low < high => Ok((low, high)),
        _ => Err(format!(
            "'{text}' is not LOW:HIGH in degrees with LOW < HIGH, e.g. -45:15"
        )),
    }
}

/// A view as chosen, with its settings for the sidecar.
fn view_of(spec: &NamedSettings) -> anyhow::Result<(View, Value)> {
    let size = |w: u32, h: u32| -> anyhow::Result<(u32, u32)> {
        let (w, h) = (spec.get("width", w)?, spec.get("height", h)?);
        if !(1..=32768).contains(&w) || !(1..=32768).contains(&h) {
            bail!("{}: width and height must be 1 to 32768 pixels", spec.name);
        }
        Ok((w, h))
    };
    Ok(match spec.name.as_str() {
        "panorama" => {
            spec.check_keys(&["width", "height", "low", "high"])?;
            let (w, h) = size(1024, 256)?;
            let (low, high) = (spec.get("low", -45.0f64)?, spec.get("high", 15.0f64)?);
            let view = View::panorama(w, h, low.to_radians(), high.to_radians()).context("panorama")?;
            let model = "cylindrical: column u at azimuth π − 2π(u + ½)/W (from body +x towards +y), rows uniform in tan(elevation)";
            (
                view,
                json!({ "width": w, "height": h, "elevation_deg": [low, high], "model": model }),
            )
        }
        "equirect" => {
            spec.check_keys(&["width", "height"])?;
            let (w, h) = size(1024, 512)?;
            let model = "equirectangular: column u at azimuth π − 2π(u + ½)/W, row v at elevation π/2 − π(v + ½)/H";
            (
                View::equirectangular(w, h),
                json!({ "width": w, "height": h, "model": model }),
            )
        }
        "perspective" => {
            spec.check_keys(&["width", "height", "hfov", "yaw", "pitch"])?;
            let (w, h) = size(640, 480)?;
            let (hfov, yaw, pitch) = (
                spec.get("hfov", 90.0f64)?,
                spec.get("yaw", 0.0f64)?,
                spec.get("pitch", 0.0f64)?,
            );
            let view = View::perspective(w, h, hfov.to_radians(), yaw.to_radians(), pitch.to_radians())
                .context("perspective")?;
            let model = "pinhole, OpenCV optical frame, principal point at the centre, looking at azimuth yaw (from body +x towards +y) and elevation pitch";
            (
                view,
                json!({ "width": w, "height": h, "hfov_deg": hfov, "yaw_deg": yaw, "pitch_deg": pitch, "model": model }),
            )
        }
        "birds-eye" => {
            spec.check_keys(&["width", "height", "scale", "plane"])?;
            let (w, h) = size(400, 400)?;
            let (scale, plane) = (spec.get("scale", 0.01f64)?, spec.get("plane", -0.7f64)?);
            let view = View::birds_eye(w, h, scale, plane).context("birds-eye")?;
            let model = "orthographic view of the plane z = plane_z (body frame), centred under the viewpoint; image up = body +x, right = body −y";
            (
                view,
                json!({ "width": w, "height": h, "metres_per_pixel": scale, "plane_z_m": plane, "model": model }),
            )
        }
        other => bail!("unknown view '{other}': give panorama, equirect, perspective or birds-eye"),
    })
}

pub(crate) fn run(args: &ProjectArgs) -> anyhow::Result<()> {
    let mut views = Vec::new();
    for spec in &args.views {
        if views.iter().any(|(name, _, _): &(String, _, _)| name == &spec.name) {
            bail!("--view {} is given twice", spec.name);
        }
        let (view, sidecar) = view_of(spec)?;
        views.push((spec.name.clone(), view, sidecar));
    }
    let input = args.input.read()?;
    super::vision_input::refuse_writing_among_inputs(&args.out, &input)?;
    for set in &input.sets {
        refuse_shared_stems(set)?;
    }
    let Camera::Catadioptric(omni) = &input.camera else {
        bail!("project resamples omnidirectional images: the images are not from a catadioptric camera");
    };
    let remaps: Vec<Remap> = views
        .iter()
        .map(|(name, view, _)| Remap::new(omni, view).with_context(|| format!("view {name}")))
        .collect::<anyhow::Result<_>>()?;
    let interpolation = Interpolation::from(args.interpolation);
    // Every image's size is checked (headers only) before anything is written.
    check_image_sizes(&input.sets, remap_source(&remaps))?;
    for set in &input.sets {
        let folder = args.out.join(&set.name);
        create_real_folder(&args.out, &folder)?;
        for ((name, _, _), remap) in views.iter().zip(&remaps) {
            let mask = remap.valid().map(|v| if v { 1.0 } else { 0.0 }).collect();
            save(
                &Raster::from_vec(remap.width, remap.height, 1, mask)?,
                &folder.join(format!("{name}-valid.png")),
            )?;
        }
        let mut frames = Vec::new();
        for frame in &set.frames {
            let image = read_image(&frame.path, Some(remap_source(&remaps)))?;
            let mut seconds = serde_json::Map::new();
            let mut files = Vec::new();
            for ((name, _, _), remap) in views.iter().zip(&remaps) {
                let clock = Instant::now();
                let view = remap.apply(&image, interpolation)?;
                seconds.insert(name.clone(), json!(clock.elapsed().as_secs_f64()));
                let file = format!("{}-{name}.png", frame.stem);
                save(&view, &folder.join(&file))?;
                files.push(file);
            }
            frames.push(json!({ "index": frame.index, "stem": frame.stem, "source": frame.path, "files": files, "seconds": seconds }));
        }
        let sidecar = json!({
            "input": { "kind": input.kind, "folder": args.input.input, "set": set.name, "noisy": args.input.noisy },
            "interpolation": args.interpolation.name(),
            "views": views.iter().map(|(name, _, s)| json!({ "name": name, "settings": s, "valid": format!("{name}-valid.png") })).collect::<Vec<_>>(),
            "conventions": "pixel centres at integer coordinates, (0,0) top-left; pixels the mirror does not see are black",
            "frames": frames,
        });
        let path = folder.join("project.json");
        let mut text = serde_json::to_vec_pretty(&sidecar)?;
        text.push(b'\n');
        write_atomically(&path, |out| out.write_all(&text))
            .with_context(|| format!("cannot write {}", path.display()))?;
        crate::streams::stderr(format_args!(
            "set '{}': {} image(s) × {} view(s) written to {}",
            set.name,
            set.frames.len(),
            views.len(),
            folder.display()
        ))?;
    }
    Ok(())
}

/// Refuses a set in which two images have the same stem (`a.png` and `a.PNG`): their views
/// would be written to the same files, and one image's lost.
fn refuse_shared_stems(set: &InputSet) -> anyhow::Result<()> {
    let mut seen = std::collections::HashMap::new();
    for frame in &set.frames {
        if let Some(first) = seen.insert(frame.stem.as_str(), &frame.path) {
            bail!(
                "{} and {} would both give the views {}-NAME.png: project names its outputs after the image's name \
                 without its extension; rename one of them",
                first.display(),
                frame.path.display(),
                frame.stem
            );
        }
    }
    Ok(())
}

/// The omnidirectional image size every table reads (the camera's).
fn remap_source(remaps: &[Remap]) -> (usize, usize) {
    remaps[0].source_size
}

/// A PNG of `raster`, written atomically (never half a file, never through a link).
fn save(raster: &Raster, path: &std::path::Path) -> anyhow::Result<()> {
    let image = raster.to_image()?;
    write_atomically(path, |out| {
        image
            .write_to(out, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("cannot write {}", path.display()))
}
