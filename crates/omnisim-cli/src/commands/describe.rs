//! `omnisim describe`: global and local descriptors of a data set's images or a folder of
//! images, one `.npy` per descriptor per set with a JSON sidecar; optional PCA.

use std::path::{Path, PathBuf};
use std::time::Instant;

use std::io::Write;

use anyhow::{Context, bail};
use clap::Args;
use omnisim::Camera;
use omnisim::atomic_file::write_atomically;
use omnisim::output::folder::create_real_folder;
use omnisim_vision::fourier::{FourierParams, FourierSignature};
use omnisim_vision::gist::{Blocks, GistParams, gist};
use omnisim_vision::hog::{
    BlockHogParams, Orientations, PanoramicHogParams, VerticalHogParams, block_hog, panoramic_hog, vertical_hog,
};
use omnisim_vision::keypoints::Features;
use omnisim_vision::lmgist::{LmGist, LmGistParams};
use omnisim_vision::pca::Pca;
use omnisim_vision::radon::{Radon, RadonParams};
use omnisim_vision::sift::{SiftParams, sift};
use omnisim_vision::surf::{SurfParams, surf};
use omnisim_vision::{Interpolation, Raster, Remap, RemapTaps, View, VisionError, npy};
use serde_json::{Value, json};

use super::project::{InterpolationArg, parse_degrees_range, parse_size};
use super::vision_input::{Input, InputArgs, NamedSettings, read_image};

/// Describe images with the reference paper's descriptors (docs/vision.md gives each one's
/// paper and equations).
///
/// Each --descriptor NAME[:KEY=VALUE,...] writes OUT/<set>/NAME.npy (float32, one row per
/// image in the set's frame order) and OUT/<set>/NAME.json (parameters, shape, frame order,
/// seconds per image). SIFT and SURF write NAME-keypoints.npy (rows: image index, x, y,
/// σ, angle in degrees, response) and NAME-descriptors.npy (one row per keypoint).
///
/// Descriptors and their settings [defaults]:
///   fourier    Fourier signature of the panorama, magnitudes (NAME-phases.npy: phases) [k=16]
///   hog        panoramic HOG, horizontal cells of the full width [cells=16, bins=8, signed=false]
///   vertical-hog  HOG of overlapping vertical cells of the panorama, for orientation [width=32, column-step=1, bins=8, signed=false]
///   block-hog  block HOG in Dalal & Triggs' layout (cells, overlapping blocks, L2-Hys) with linear
///              orientation votes but without their trilinear spatial votes and Gaussian block window
///              (as scikit-image's hog) [cell=8, block=2, stride=1, bins=9, signed=false, clip=0.2, on=image]
///   gist       omnisim's panoramic gist: LMgist's Gabor bank over horizontal blocks, circular in x,
///              without LMgist's prefilter and resize [scales=4, orientations=8, blocks=16]
///   grid-gist  omnisim's gist on a grid (as gist, not LMgist) [scales=4, orientations=8, grid=4, on=image]
///   lmgist     Oliva & Torralba's LMgist exactly: channel mean, resize + centred crop to size², whitening
///              prefilter (fc cycles/image), 32-px mirrored border, blocks at fix(linspace(0, size, n+1)),
///              LMgist's column-major order [size=256, scales=4, orientations=8, blocks=4, fc=4, on=image]
///   radon      Radon transform of the image about the camera's principal point (omni) or the image centre
///              [angles=360, radial-samples=0 (0: every p strictly inside the disc reaching the nearest image edge), radial-step=1, line-step=0.5 (pixels)]
///   sift       Lowe 2004 [sigma=1.6, input-sigma=0.5, scales=3, contrast=0.04, edge=10, bins=36, peak=0.8,
///              descriptor-width=4 (cells per side), descriptor-bins=8, clamp=0.2, border=5, upsample=true, on=image]
///   surf       Bay et al. 2006 [threshold=100, octaves=4, intervals=4, sample-step=1, hessian-weight=0.9,
///              window=60, window-step=5 (orientation window, degrees), upright=false, on=image]
/// `on=panorama` describes the panorama instead of the image. Panoramas are resampled from
/// omnidirectional images through the camera's model (--panorama, --elevation); images of a
/// cylindrical or equirectangular camera are used as they are.
#[derive(Debug, Clone, Args)]
#[command(
    verbatim_doc_comment,
    after_help = "Examples:\n  \
omnisim dataset scenes/env1-dataset.ron --out data/env1\n  \
omnisim describe data/env1 --set map -d fourier:k=32 -d hog -d sift --out desc/map\n  \
omnisim describe data/env1 -d gist -d radon:angles=180 --pca-fit 20 --map map --out desc/all\n  \
omnisim describe data/env1 --set test-day -d gist --pca-basis desc/all --out desc/test\n  \
omnisim describe out/ --camera omni --mirror-a 0.04 --mirror-b 0.16 -d surf:upright=true --out desc/images"
)]
pub(crate) struct DescribeArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// A descriptor and its settings, NAME[:KEY=VALUE,...] (list above); repeat for several.
    #[arg(long = "descriptor", short = 'd', required = true, value_parser = NamedSettings::parse)]
    pub descriptors: Vec<NamedSettings>,
    /// Output folder (created if missing); one sub-folder per set.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub view: PanoramaArgs,
    /// Fit a PCA of K components to each global descriptor of the map set (--map) and project
    /// every set with it (NAME-pca.npy); the basis goes to OUT/pca/NAME/ (mean.npy, axes.npy,
    /// variances.npy, and pca.json with the total variance).
    #[arg(long, value_name = "K", conflicts_with = "pca_basis")]
    pub pca_fit: Option<usize>,
    /// The set the PCA is fitted to [default: the first set].
    #[arg(long, requires = "pca_fit")]
    pub map: Option<String>,
    /// Project every set with the bases an earlier --pca-fit run saved (its --out folder).
    #[arg(long, value_name = "DIR")]
    pub pca_basis: Option<PathBuf>,
}

/// The panorama that descriptors reading one are given (shared with `localize`).
#[derive(Debug, Clone, Args)]
pub(crate) struct PanoramaArgs {
    /// Size of the panorama resampled from omnidirectional images, WIDTHxHEIGHT.
    #[arg(long, default_value = "512x128", value_parser = parse_size)]
    pub panorama: (u32, u32),
    /// Elevations the panorama spans, degrees, LOW:HIGH.
    #[arg(long, default_value = "-45:15", value_parser = parse_degrees_range, allow_hyphen_values = true)]
    pub elevation: (f64, f64),
    #[arg(long, value_enum, default_value = "bicubic")]
    pub interpolation: InterpolationArg,
}

/// The folder of OUT that holds the PCA bases (a set of that name is refused with --pca-fit).
const PCA_FOLDER: &str = "pca";

/// Which image a descriptor reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Reads {
    Image,
    Panorama,
}

impl Reads {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Reads::Image => "image",
            Reads::Panorama => "panorama",
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) enum Method {
    Fourier(FourierParams),
    Hog(PanoramicHogParams),
    VerticalHog(VerticalHogParams),
    BlockHog(BlockHogParams),
    Gist(GistParams),
    LmGist(LmGist),
    Radon(RadonParams),
    Sift(SiftParams),
    Surf(SurfParams),
}

impl Method {
    /// Checks the settings; with `size`, also for an image of that size (width, height).
    pub(crate) fn fits(&self, size: Option<(usize, usize)>) -> Result<(), omnisim_vision::VisionError> {
        let Some((w, h)) = size else {
            return match self {
                Method::Fourier(p) => p.validate(),
                Method::Hog(p) => p.validate(),
                Method::VerticalHog(p) => p.validate(),
                Method::BlockHog(p) => p.validate(),
                Method::Gist(p) => p.validate(),
                Method::LmGist(g) => g.params().validate(),
                Method::Radon(p) => p.validate(),
                Method::Sift(p) => p.validate(),
                Method::Surf(p) => p.validate(),
            };
        };
        match self {
            Method::Fourier(p) => p.fits(w, h),
            Method::Hog(p) => p.fits(w, h),
            Method::VerticalHog(p) => p.fits(w, h),
            Method::BlockHog(p) => p.fits(w, h),
            Method::Gist(p) => p.fits(w, h),
            Method::Radon(p) => p.fits(w, h),
            // Any size: it is resized to its own.
            Method::LmGist(g) => g.params().validate(),
            // Any size: an image too small gives no keypoints.
            Method::Sift(p) => p.validate(),
            Method::Surf(p) => p.validate(),
        }
    }
}

/// One descriptor as chosen: what it computes, what it reads, and its settings for the sidecar.
#[derive(Debug, Clone)]
pub(crate) struct Choice {
    pub name: String,
    pub method: Method,
    pub reads: Reads,
    pub parameters: Value,
}

pub(crate) fn choose(spec: &NamedSettings) -> anyhow::Result<Choice> {
    let on = |default: Reads| -> anyhow::Result<Reads> {
        match spec.settings.get("on").map(String::as_str) {
            None => Ok(default),
            Some("image") => Ok(Reads::Image),
            Some("panorama") => Ok(Reads::Panorama),
            Some(other) => bail!("{}: on={other}: give on=image or on=panorama", spec.name),
        }
    };
    let orientations = |bins: usize| -> anyhow::Result<Orientations> {
        Ok(Orientations {
            bins: spec.get("bins", bins)?,
            signed: spec.get("signed", false)?,
        })
    };
    let (method, reads, parameters) = match spec.name.as_str() {
        "fourier" => {
            spec.check_keys(&["k"])?;
            let p = FourierParams {
                coefficients: spec.get("k", 16)?,
            };
            (Method::Fourier(p), Reads::Panorama, json!({ "k": p.coefficients }))
        }
        "hog" => {
            spec.check_keys(&["cells", "bins", "signed"])?;
            let p = PanoramicHogParams {
                orientations: orientations(8)?,
                cells: spec.get("cells", 16)?,
                normalise: true,
            };
            let parameters = json!({ "cells": p.cells, "bins": p.orientations.bins, "signed": p.orientations.signed, "cell_normalisation": "L2" });
            (Method::Hog(p), Reads::Panorama, parameters)
        }
        "vertical-hog" => {
            spec.check_keys(&["width", "column-step", "bins", "signed"])?;
            let p = VerticalHogParams {
                orientations: orientations(8)?,
                width: spec.get("width", 32)?,
                step: spec.get("column-step", 1)?,
            };
            let parameters = json!({ "cell_width": p.width, "column_step": p.step, "bins": p.orientations.bins, "signed": p.orientations.signed, "cell_normalisation": "L2" });
            (Method::VerticalHog(p), Reads::Panorama, parameters)
        }
        "block-hog" => {
            spec.check_keys(&["cell", "block", "stride", "bins", "signed", "clip", "on"])?;
            let p = BlockHogParams {
                orientations: orientations(9)?,
                cell: spec.get("cell", 8)?,
                block: spec.get("block", 2)?,
                stride: spec.get("stride", 1)?,
                clip: spec.get("clip", 0.2)?,
            };
            let parameters = json!({
                "cell": p.cell, "block": p.block, "stride": p.stride, "bins": p.orientations.bins,
                "signed": p.orientations.signed, "clip": decimal(p.clip), "block_normalisation": "L2-Hys"
            });
            (Method::BlockHog(p), on(Reads::Image)?, parameters)
        }
        "gist" => {
            spec.check_keys(&["scales", "orientations", "blocks"])?;
            let blocks = spec.get("blocks", 16)?;
            let p = GistParams {
                scales: spec.get("scales", 4)?,
                orientations: spec.get("orientations", 8)?,
                blocks: Blocks::Horizontal(blocks),
            };
            let parameters = json!({ "scales": p.scales, "orientations": p.orientations, "horizontal_blocks": blocks });
            (Method::Gist(p), Reads::Panorama, parameters)
        }
        "grid-gist" => {
            spec.check_keys(&["scales", "orientations", "grid", "on"])?;
            let grid = spec.get("grid", 4)?;
            let p = GistParams {
                scales: spec.get("scales", 4)?,
                orientations: spec.get("orientations", 8)?,
                blocks: Blocks::Grid(grid),
            };
            let parameters = json!({ "scales": p.scales, "orientations": p.orientations, "grid": grid });
            (Method::Gist(p), on(Reads::Image)?, parameters)
        }
        "lmgist" => {
            spec.check_keys(&["size", "scales", "orientations", "blocks", "fc", "on"])?;
            let d = LmGistParams::default();
            let p = LmGistParams {
                image_size: spec.get("size", d.image_size)?,
                scales: spec.get("scales", d.scales)?,
                orientations: spec.get("orientations", d.orientations)?,
                blocks: spec.get("blocks", d.blocks)?,
                prefilter_cycles: spec.get("fc", d.prefilter_cycles)?,
            };
            let parameters = json!({
                "image_size": p.image_size, "scales": p.scales, "orientations": p.orientations, "blocks": p.blocks,
                "prefilter_cycles_per_image": p.prefilter_cycles, "boundary_extension_px": omnisim_vision::lmgist::BOUNDARY,
                "block_order": "LMgist's: filter by filter, blocks column-major", "grey": "mean of the colour channels"
            });
            let lmgist = LmGist::new(p).with_context(|| format!("--descriptor {}", spec.name))?;
            (Method::LmGist(lmgist), on(Reads::Image)?, parameters)
        }
        "radon" => {
            spec.check_keys(&["angles", "radial-samples", "radial-step", "line-step"])?;
            let d = RadonParams::default();
            let p = RadonParams {
                angles: spec.get("angles", d.angles)?,
                radial_samples: spec.get("radial-samples", 0usize).map(|n| (n != 0).then_some(n))?,
                radial_step: spec.get("radial-step", d.radial_step)?,
                line_step: spec.get("line-step", d.line_step)?,
                centre: None,
            };
            // The centre is the camera's principal point, set once the input is read.
            let parameters = json!({
                "angles": p.angles, "radial_samples": p.radial_samples, "radial_step_px": p.radial_step, "line_step_px": p.line_step
            });
            (Method::Radon(p), Reads::Image, parameters)
        }
        "sift" => {
            spec.check_keys(&[
                "sigma",
                "input-sigma",
                "scales",
                "contrast",
                "edge",
                "bins",
                "peak",
                "descriptor-width",
                "descriptor-bins",
                "clamp",
                "border",
                "upsample",
                "on",
            ])?;
            let d = SiftParams::default();
            let p = SiftParams {
                sigma: spec.get("sigma", d.sigma)?,
                scales_per_octave: spec.get("scales", d.scales_per_octave)?,
                contrast_threshold: spec.get("contrast", d.contrast_threshold)?,
                edge_ratio: spec.get("edge", d.edge_ratio)?,
                orientation_bins: spec.get("bins", d.orientation_bins)?,
                peak_ratio: spec.get("peak", d.peak_ratio)?,
                upsample: spec.get("upsample", d.upsample)?,
                input_sigma: spec.get("input-sigma", d.input_sigma)?,
                descriptor_width: spec.get("descriptor-width", d.descriptor_width)?,
                descriptor_bins: spec.get("descriptor-bins", d.descriptor_bins)?,
                magnitude_clamp: spec.get("clamp", d.magnitude_clamp)?,
                border: spec.get("border", d.border)?,
            };
            let parameters = json!({
                "sigma": decimal(p.sigma), "scales_per_octave": p.scales_per_octave, "contrast_threshold": decimal(p.contrast_threshold),
                "edge_ratio": decimal(p.edge_ratio), "orientation_bins": p.orientation_bins, "peak_ratio": decimal(p.peak_ratio),
                "upsample": p.upsample, "descriptor": [p.descriptor_width, p.descriptor_width, p.descriptor_bins],
                "magnitude_clamp": decimal(p.magnitude_clamp), "input_sigma": decimal(p.input_sigma), "border": p.border
            });
            (Method::Sift(p), on(Reads::Image)?, parameters)
        }
        "surf" => {
            spec.check_keys(&[
                "threshold",
                "octaves",
                "intervals",
                "sample-step",
                "hessian-weight",
                "window",
                "window-step",
                "upright",
                "on",
            ])?;
            let d = SurfParams::default();
            let p = SurfParams {
                hessian_threshold: spec.get("threshold", d.hessian_threshold)?,
                octaves: spec.get("octaves", d.octaves)?,
                intervals: spec.get("intervals", d.intervals)?,
                initial_step: spec.get("sample-step", d.initial_step)?,
                hessian_weight: spec.get("hessian-weight", d.hessian_weight)?,
                upright: spec.get("upright", d.upright)?,
                orientation_window: spec.get("window", d.orientation_window)?,
                orientation_step: spec.get("window-step", d.orientation_step)?,
            };
            let parameters = json!({
                "hessian_threshold": decimal(p.hessian_threshold), "octaves": p.octaves, "intervals": p.intervals,
                "initial_step": p.initial_step, "upright": p.upright, "hessian_weight": decimal(p.hessian_weight),
                "orientation_window_deg": decimal(p.orientation_window), "orientation_step_deg": decimal(p.orientation_step)
            });
            (Method::Surf(p), on(Reads::Image)?, parameters)
        }
        other => bail!(
            "unknown descriptor '{other}': give fourier, hog, vertical-hog, block-hog, gist, grid-gist, lmgist, radon, sift or surf"
        ),
    };
    // Every setting that does not depend on the images is checked here; the limits the
    // images' size sets are checked in `run` once the camera is known, before any image is
    // read. Nothing is written before every image is described.
    method
        .fits(None)
        .with_context(|| format!("--descriptor {}", spec.name))?;
    Ok(Choice {
        name: spec.name.clone(),
        method,
        reads,
        parameters,
    })
}

/// An f32 setting as the decimal it was typed as (0.04, not 0.03999999910593033).
fn decimal(value: f32) -> f64 {
    value.to_string().parse().unwrap_or(f64::from(value))
}

/// What one descriptor gives for one image.
pub(crate) enum Described {
    /// A fixed-shape array (and, for the Fourier signature, the phases beside it).
    Values {
        shape: Vec<usize>,
        values: Vec<f32>,
        phases: Option<Vec<f32>>,
    },
    Features(Features),
}

impl Choice {
    pub(crate) fn describe(&self, grey: &Raster) -> anyhow::Result<Described> {
        let values = |d: omnisim_vision::Descriptor| Described::Values {
            shape: d.shape,
            values: d.values,
            phases: None,
        };
        Ok(match &self.method {
            Method::Fourier(p) => {
                let signature = FourierSignature::new(grey, *p)?;
                Described::Values {
                    shape: vec![signature.rows, signature.coefficients],
                    values: signature.magnitudes(),
                    phases: Some(signature.phases()),
                }
            }
            Method::Hog(p) => values(panoramic_hog(grey, *p)?),
            Method::VerticalHog(p) => values(vertical_hog(grey, *p)?),
            Method::BlockHog(p) => values(block_hog(grey, *p)?),
            Method::Gist(p) => values(gist(grey, *p)?),
            Method::LmGist(g) => values(g.describe(grey)?),
            Method::Radon(p) => {
                let radon = Radon::new(grey, *p)?;
                Described::Values {
                    shape: vec![radon.values.height, radon.values.width],
                    values: radon.values.data,
                    phases: None,
                }
            }
            Method::Sift(p) => Described::Features(sift(grey, p)?),
            Method::Surf(p) => Described::Features(surf(grey, p)?),
        })
    }

    /// The image this descriptor reads: the panorama, the colour image (`LMgist` averages
    /// the channels itself, as `mean(img, 3)`) or the grey image.
    pub(crate) fn source<'a>(&self, colour: &'a Raster, grey: &'a Raster, panorama: Option<&'a Raster>) -> &'a Raster {
        match (self.reads, panorama) {
            (Reads::Panorama, Some(panorama)) => panorama,
            _ if matches!(self.method, Method::LmGist(_)) => colour,
            _ => grey,
        }
    }

    pub(crate) fn is_global(&self) -> bool {
        !matches!(self.method, Method::Sift(_) | Method::Surf(_))
    }
}

/// Every image of a set described by one descriptor.
struct SetResult {
    per_image: Vec<Described>,
    seconds: Vec<f64>,
    /// Seconds the panorama of each image took, for descriptors that read it (none where the
    /// images are panoramas).
    panorama_seconds: Vec<f64>,
}

pub(crate) fn run(args: &DescribeArgs) -> anyhow::Result<()> {
    let mut choices: Vec<Choice> = args.descriptors.iter().map(choose).collect::<anyhow::Result<_>>()?;
    for (i, choice) in choices.iter().enumerate() {
        if choices[..i].iter().any(|c| c.name == choice.name) {
            bail!(
                "--descriptor {} is given twice: describe once per run, or use two --out folders",
                choice.name
            );
        }
    }
    if args.pca_fit == Some(0) {
        bail!("--pca-fit needs at least 1 component");
    }
    if let Some(basis) = &args.pca_basis {
        super::recordable(basis, super::vision_input::SIDECARS_RECORD).context("--pca-basis")?;
    }
    let input = args.input.read()?;
    super::vision_input::refuse_writing_among_inputs(&args.out, &input)?;
    // Nothing is written before every image is described (below), but a folder that cannot
    // take the outputs is found now, not after the work.
    omnisim::output::folder::check_writable(&args.out)?;
    if args.pca_fit.is_some() && input.sets.iter().any(|s| s.name == PCA_FOLDER) {
        bail!(
            "a set named '{PCA_FOLDER}' would share OUT/{PCA_FOLDER} with the PCA bases: leave it out (--set) or describe it without --pca-fit"
        );
    }
    if let Camera::Catadioptric(omni) = &input.camera {
        for choice in &mut choices {
            if let Method::Radon(p) = &mut choice.method {
                // The mirror axis: the calibration's principal point.
                p.centre = Some((omni.cx, omni.cy));
            }
        }
    }
    for choice in &mut choices {
        if let Method::Radon(p) = &choice.method {
            choice.parameters["centre_px"] = match p.centre {
                Some((x, y)) => json!({ "u": x, "v": y, "from": "the calibration's principal point (cx, cy)" }),
                None => json!({ "from": "the image centre ((W − 1)/2, (H − 1)/2)" }),
            };
        }
    }
    let map = match (&args.map, args.pca_fit) {
        (Some(map), _) => Some(
            input
                .sets
                .iter()
                .position(|s| &s.name == map)
                .with_context(|| format!("--map {map} is not a described set"))?,
        ),
        (None, Some(_)) => Some(0),
        _ => None,
    };
    let panorama = Panorama::new(
        &input.camera,
        &args.view,
        choices.iter().any(|c| c.reads == Reads::Panorama),
    )?;
    // The limits the images' size sets, from the camera's size, before any image is read.
    let (w, h) = input.camera.size();
    let image_size = (w as usize, h as usize);
    for choice in &choices {
        let size = match (choice.reads, &panorama) {
            (Reads::Panorama, Some(p)) => p.size(image_size),
            _ => image_size,
        };
        choice.method.fits(Some(size)).with_context(|| {
            format!(
                "--descriptor {} on the {}×{} {}",
                choice.name,
                size.0,
                size.1,
                choice.reads.name()
            )
        })?;
    }
    let started = Instant::now();
    let mut results: Vec<Vec<SetResult>> = Vec::new();
    for set in &input.sets {
        crate::streams::stderr(format_args!("set '{}': {} image(s)", set.name, set.frames.len()))?;
        let mut per_choice: Vec<SetResult> = choices
            .iter()
            .map(|_| SetResult {
                per_image: Vec::new(),
                seconds: Vec::new(),
                panorama_seconds: Vec::new(),
            })
            .collect();
        let mut size = None;
        for frame in &set.frames {
            let image = read_image(&frame.path, size)?;
            size = Some((image.width, image.height));
            let grey = image.to_grey();
            let pano = (panorama.as_ref().map(|p| p.of(&grey)).transpose())
                .with_context(|| format!("cannot make the panorama of {}", frame.path.display()))?;
            for (choice, result) in choices.iter().zip(&mut per_choice) {
                if let (Reads::Panorama, Some((_, Some(seconds)))) = (choice.reads, &pano) {
                    result.panorama_seconds.push(*seconds);
                }
                let source = choice.source(&image, &grey, pano.as_ref().map(|p| &p.0));
                let clock = Instant::now();
                let described = choice
                    .describe(source)
                    .with_context(|| format!("{} of {}", choice.name, frame.path.display()))?;
                result.seconds.push(clock.elapsed().as_secs_f64());
                result.per_image.push(described);
            }
        }
        results.push(per_choice);
    }
    let pcas = fit_or_load_pca(args, &choices, &results, map, &input)?;
    // Nothing is written until every image is described and every PCA fitted or loaded, so a
    // request that fails writes nothing (`create_real_folder` makes --out too).
    if args.pca_fit.is_some() {
        for (choice, pca) in choices.iter().zip(&pcas) {
            if let Some((pca, _)) = pca {
                let folder = args.out.join(PCA_FOLDER).join(&choice.name);
                create_real_folder(&args.out, &folder)?;
                pca.save(&folder)?;
            }
        }
    }
    for (set, per_choice) in input.sets.iter().zip(&results) {
        let folder = args.out.join(&set.name);
        create_real_folder(&args.out, &folder)?;
        for ((choice, result), pca) in choices.iter().zip(per_choice).zip(&pcas) {
            write_set(
                &folder,
                &input,
                set,
                choice,
                result,
                pca.as_ref(),
                panorama.as_ref(),
                args,
            )?;
        }
        crate::streams::stderr(format_args!("wrote {}", folder.display()))?;
    }
    crate::streams::stderr(format_args!(
        "{} set(s) described in {:.1} s",
        input.sets.len(),
        started.elapsed().as_secs_f64()
    ))?;
    Ok(())
}

/// The panorama every image is resampled to, when a descriptor reads one.
pub(crate) struct Panorama {
    /// How each omnidirectional image becomes the panorama; `None`: the images are panoramas
    /// already.
    resampling: Option<Resampling>,
    pub sidecar: Value,
}

/// The table an omnidirectional image is resampled through: the same bits either way.
enum Resampling {
    /// Each panorama pixel's taps, worked out once (up to `RemapTaps::PIXELS_MAX` pixels).
    Taps(RemapTaps),
    /// Each pixel's source point, its taps worked out per image (larger panoramas, for which
    /// a table of taps would take 68 bytes a pixel bicubic, 20 bilinear).
    Points(Remap, Interpolation),
}

impl Resampling {
    fn new(remap: Remap, interpolation: Interpolation) -> Self {
        match RemapTaps::new(&remap, interpolation) {
            Some(taps) => Resampling::Taps(taps),
            None => Resampling::Points(remap, interpolation),
        }
    }

    fn size(&self) -> (usize, usize) {
        match self {
            Resampling::Taps(taps) => taps.size(),
            Resampling::Points(remap, _) => (remap.width, remap.height),
        }
    }

    fn apply(&self, grey: &Raster) -> Result<Raster, VisionError> {
        match self {
            Resampling::Taps(taps) => taps.apply(grey),
            Resampling::Points(remap, interpolation) => remap.apply(grey, *interpolation),
        }
    }
}

impl Panorama {
    pub(crate) fn new(camera: &Camera, args: &PanoramaArgs, needed: bool) -> anyhow::Result<Option<Self>> {
        if !needed {
            return Ok(None);
        }
        let (width, height) = args.panorama;
        let (low, high) = args.elevation;
        match camera {
            Camera::Catadioptric(omni) => {
                let view = View::panorama(width, height, low.to_radians(), high.to_radians())?;
                let remap = Remap::new(omni, &view).context("the panorama")?;
                let sidecar = json!({
                    "resampled_from": "omnidirectional image", "width": width, "height": height,
                    "elevation_deg": [low, high], "interpolation": args.interpolation.name(),
                    "model": "cylindrical: column u at azimuth π − 2π(u + ½)/W, rows uniform in tan(elevation)"
                });
                Ok(Some(Self {
                    resampling: Some(Resampling::new(remap, args.interpolation.into())),
                    sidecar,
                }))
            }
            Camera::Cylindrical(_) | Camera::Equirectangular(_) => {
                let sidecar = json!({ "resampled_from": null, "note": "the images are panoramas" });
                Ok(Some(Self {
                    resampling: None,
                    sidecar,
                }))
            }
            Camera::Pinhole(_) | Camera::Lens(_) => bail!(
                "a descriptor reads a panorama, but the images are from a {} camera: use on=image or other descriptors",
                camera.model_name()
            ),
        }
    }

    /// Size of the panorama of an image of `image_size`.
    pub(crate) fn size(&self, image_size: (usize, usize)) -> (usize, usize) {
        self.resampling.as_ref().map_or(image_size, Resampling::size)
    }

    /// The panorama of a grey image and the seconds its resampling took (`None`: the image is
    /// the panorama, nothing was resampled).
    pub(crate) fn of(&self, grey: &Raster) -> anyhow::Result<(Raster, Option<f64>)> {
        let clock = Instant::now();
        let Some(resampling) = &self.resampling else {
            return Ok((grey.clone(), None));
        };
        let panorama = resampling.apply(grey)?;
        Ok((panorama, Some(clock.elapsed().as_secs_f64())))
    }
}

/// The PCA of each global descriptor: fitted on the map set, or loaded; `None` elsewhere.
fn fit_or_load_pca(
    args: &DescribeArgs,
    choices: &[Choice],
    results: &[Vec<SetResult>],
    map: Option<usize>,
    input: &Input,
) -> anyhow::Result<Vec<Option<(Pca, Value)>>> {
    let mut pcas = Vec::new();
    for (c, choice) in choices.iter().enumerate() {
        if !choice.is_global() || (args.pca_fit.is_none() && args.pca_basis.is_none()) {
            pcas.push(None);
            continue;
        }
        let pca = if let (Some(k), Some(map)) = (args.pca_fit, map) {
            let samples: Vec<Vec<f32>> = results[map][c]
                .per_image
                .iter()
                .filter_map(|d| match d {
                    Described::Values { values, .. } => Some(values.clone()),
                    Described::Features(_) => None,
                })
                .collect();
            let pca = Pca::fit(&samples, k)
                .with_context(|| format!("PCA of {} on set '{}'", choice.name, input.sets[map].name))?;
            if pca.components() < k {
                crate::streams::stderr(format_args!(
                    "note: {}: --pca-fit {k} gives {} component(s): {} image(s) of {}-value descriptors span no more",
                    choice.name,
                    pca.components(),
                    samples.len(),
                    samples.first().map_or(0, Vec::len)
                ))?;
            }
            let sidecar = json!({
                "fitted_on": input.sets[map].name, "components": pca.components(),
                "explained_variance_ratio": pca.explained_variance_ratio(), "basis": format!("{PCA_FOLDER}/{}", choice.name)
            });
            (pca, sidecar)
        } else {
            let folder = args
                .pca_basis
                .as_ref()
                .map(|b| b.join(PCA_FOLDER).join(&choice.name))
                .unwrap_or_default();
            let pca = Pca::load(&folder)
                .with_context(|| format!("the PCA basis of {} (from an earlier --pca-fit run)", choice.name))?;
            let sidecar = json!({
                "loaded_from": folder, "components": pca.components(),
                "explained_variance_ratio": pca.explained_variance_ratio()
            });
            (pca, sidecar)
        };
        pcas.push(Some(pca));
    }
    Ok(pcas)
}

#[allow(clippy::too_many_arguments)]
fn write_set(
    folder: &Path,
    input: &Input,
    set: &super::vision_input::InputSet,
    choice: &Choice,
    result: &SetResult,
    pca: Option<&(Pca, Value)>,
    panorama: Option<&Panorama>,
    args: &DescribeArgs,
) -> anyhow::Result<()> {
    let name = &choice.name;
    let frames: Vec<Value> = set
        .frames
        .iter()
        .zip(&result.seconds)
        .enumerate()
        .map(|(i, (f, s))| {
            let mut frame = json!({ "index": f.index, "stem": f.stem, "file": f.path, "seconds": s });
            // The panorama's resampling is not in `seconds` (it is shared by every descriptor
            // that reads the panorama); each frame's is recorded beside it.
            if let Some(p) = result.panorama_seconds.get(i) {
                frame["panorama_seconds"] = json!(p);
            }
            frame
        })
        .collect();
    let mean_seconds = result.seconds.iter().sum::<f64>() / result.seconds.len().max(1) as f64;
    let mut sidecar = json!({
        "descriptor": name,
        "parameters": choice.parameters,
        "reads": choice.reads.name(),
        "panorama": if choice.reads == Reads::Panorama { panorama.map(|p| p.sidecar.clone()) } else { None },
        "input": { "kind": input.kind, "folder": args.input.input, "set": set.name, "noisy": args.input.noisy },
        "dtype": "<f4",
        "frames": frames,
        "seconds_per_image": mean_seconds,
    });
    if !result.panorama_seconds.is_empty() {
        let mean = result.panorama_seconds.iter().sum::<f64>() / result.panorama_seconds.len() as f64;
        sidecar["panorama_seconds_per_image"] = json!(mean);
    }
    let n = result.per_image.len();
    let write = |file: &str, shape: &[usize], values: &[f32]| -> anyhow::Result<()> {
        npy::write(&folder.join(file), shape, values).map_err(anyhow::Error::from)
    };
    let mut rows: Vec<Vec<f32>> = Vec::new();
    match result.per_image.first() {
        Some(Described::Values { shape, phases, .. }) => {
            let mut values = Vec::new();
            let mut all_phases = Vec::new();
            for d in &result.per_image {
                if let Described::Values {
                    shape: s,
                    values: v,
                    phases: p,
                } = d
                {
                    if s != shape {
                        bail!(
                            "{name}: images of set '{}' gave descriptors of different shapes",
                            set.name
                        );
                    }
                    values.extend_from_slice(v);
                    rows.push(v.clone());
                    all_phases.extend(p.iter().flatten());
                }
            }
            let full: Vec<usize> = std::iter::once(n).chain(shape.iter().copied()).collect();
            write(&format!("{name}.npy"), &full, &values)?;
            sidecar["shape"] = json!(full);
            sidecar["files"] = json!({ "values": format!("{name}.npy") });
            if phases.is_some() {
                write(&format!("{name}-phases.npy"), &full, &all_phases)?;
                sidecar["files"]["phases"] = json!(format!("{name}-phases.npy"));
            }
        }
        Some(Described::Features(first)) => {
            let length = first.length;
            let (mut keypoints, mut descriptors, mut counts) = (Vec::new(), Vec::new(), Vec::new());
            for (image, d) in result.per_image.iter().enumerate() {
                if let Described::Features(f) = d {
                    for k in &f.keypoints {
                        keypoints.extend([image as f32, k.x, k.y, k.sigma, k.angle, k.response]);
                    }
                    descriptors.extend_from_slice(&f.descriptors);
                    counts.push(f.keypoints.len());
                }
            }
            let total = keypoints.len() / 6;
            write(&format!("{name}-keypoints.npy"), &[total, 6], &keypoints)?;
            write(&format!("{name}-descriptors.npy"), &[total, length], &descriptors)?;
            sidecar["files"] = json!({ "keypoints": format!("{name}-keypoints.npy"), "descriptors": format!("{name}-descriptors.npy") });
            sidecar["keypoint_columns"] = json!(["image", "x", "y", "sigma_px", "angle_deg", "response"]);
            sidecar["shape"] = json!({ "keypoints": [total, 6], "descriptors": [total, length] });
            sidecar["keypoints_per_image"] = json!(counts);
            sidecar["conventions"] = json!(
                "pixel centres at integer (x, y), (0,0) top-left; angle from +x towards +y (down), degrees; descriptors unit length"
            );
        }
        None => {}
    }
    if let Some((pca, pca_sidecar)) = pca {
        let projected: Vec<f32> = rows
            .iter()
            .map(|row| pca.project(row, pca.components()))
            .collect::<Result<Vec<_>, _>>()
            .with_context(|| format!("{name}: projecting with the PCA basis"))?
            .concat();
        write(&format!("{name}-pca.npy"), &[n, pca.components()], &projected)?;
        sidecar["pca"] = pca_sidecar.clone();
        sidecar["files"]["pca"] = json!(format!("{name}-pca.npy"));
    }
    let path = folder.join(format!("{name}.json"));
    let mut text = serde_json::to_vec_pretty(&sidecar)?;
    text.push(b'\n');
    write_atomically(&path, |out| out.write_all(&text)).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnisim::camera::Catadioptric;

    /// A panorama of up to `RemapTaps::PIXELS_MAX` pixels is resampled through a table of taps,
    /// a larger one through the source points (a table of taps would take 68 bytes a pixel).
    #[test]
    fn large_panoramas_are_resampled_through_the_points() {
        let camera = Camera::Catadioptric(Catadioptric::hyperbolic(64, 64, 0.04, 0.16, Some(20f64.to_radians())));
        for (size, taps) in [((512, 128), true), ((2048, 1024), false)] {
            let args = PanoramaArgs {
                panorama: size,
                elevation: (-45.0, 15.0),
                interpolation: InterpolationArg::Bicubic,
            };
            let panorama = Panorama::new(&camera, &args, true).unwrap().unwrap();
            let resampling = panorama.resampling.as_ref().unwrap();
            assert_eq!(matches!(resampling, Resampling::Taps(_)), taps, "{size:?}");
            assert_eq!(panorama.size((64, 64)), (size.0 as usize, size.1 as usize));
            let (view, seconds) = panorama.of(&Raster::new(64, 64, 1)).unwrap();
            assert_eq!((view.width, view.height), (size.0 as usize, size.1 as usize));
            assert!(seconds.is_some());
        }
    }
}
