//! What `describe` and `project` read: a data set written by `omnisim dataset` (its
//! manifest.json gives the sets, the frame order and the camera) or a folder of images (the
//! camera from `render`'s options), and their `NAME:KEY=VALUE,...` option values.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Take};
use std::path::{Component, Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Parser};
use omnisim::camera::RigSpec;
use omnisim::{Camera, Rig};
use omnisim_dataset::manifest::{FileKind, FrameEntry};
use omnisim_vision::Raster;
use serde::Deserialize;

use crate::camera_args::CameraArgs;

/// Why describe and project refuse a path that is not UTF-8 ([`super::recordable`]); a lossy
/// name could also give two images the same outputs.
pub(crate) const SIDECARS_RECORD: &str = "describe and project record the files they read in JSON sidecars";

/// The input folder and how to read it.
#[derive(Debug, Clone, Args)]
pub(crate) struct InputArgs {
    /// A data-set folder written by `omnisim dataset` (with manifest.json), or a folder of
    /// PNG images (read in name order; camera from the options below, which must match the
    /// camera an `omnisim render` folder's render.json records). Of a render folder, the
    /// colour images its render.json lists are read (not its depth or id PNGs).
    pub input: PathBuf,
    /// Data sets: only this set (repeat for several) [default: every set].
    #[arg(long = "set")]
    pub sets: Vec<String>,
    /// Data sets: read the noisy copies (*-noisy.png) instead of the ground truth.
    #[arg(long)]
    pub noisy: bool,
    /// Image folders: the camera that took the images, as `omnisim render` gives it
    /// (--size defaults to the images' size). A render folder's render.json gives it when no
    /// camera option is given; data sets take it from their manifest.
    #[command(flatten)]
    pub camera: CameraArgs,
}

/// One image of a set.
#[derive(Debug, Clone)]
pub(crate) struct InputFrame {
    /// Position in the set, from 0.
    pub index: usize,
    /// Name without extension (the data set's frame stem).
    pub stem: String,
    /// The image file.
    pub path: PathBuf,
}

/// Images described together: a data set's set, or the image folder.
#[derive(Debug, Clone)]
pub(crate) struct InputSet {
    pub name: String,
    pub frames: Vec<InputFrame>,
}

/// The sets to read and the camera that took them.
#[derive(Debug, Clone)]
pub(crate) struct Input {
    /// "dataset" or "images", for the sidecars.
    pub kind: &'static str,
    pub sets: Vec<InputSet>,
    /// For stereo data sets, the left camera.
    pub camera: Camera,
}

/// The part of manifest.json read here (the library's `Manifest` is write-only; its frame
/// entries and rig are the library's own types).
#[derive(Deserialize)]
struct ManifestView {
    rig: RigSpec,
    sets: Vec<ManifestSetView>,
}

#[derive(Deserialize)]
struct ManifestSetView {
    name: String,
    frame_entries: Vec<FrameEntry>,
}

const MANIFEST_LIMIT: u64 = 1 << 30;

impl InputArgs {
    /// The sets `sets` of the data set in `folder`, ground truth or their noisy copies.
    pub(crate) fn dataset(folder: PathBuf, sets: Vec<String>, noisy: bool) -> Self {
        Self {
            input: folder,
            sets,
            noisy,
            camera: default_camera_args(),
        }
    }

    pub(crate) fn read(&self) -> anyhow::Result<Input> {
        super::recordable(&self.input, SIDECARS_RECORD)?;
        let manifest = self.input.join("manifest.json");
        if manifest.is_file() {
            if self.camera_given() {
                bail!(
                    "{} is a data set: its manifest gives the camera, so camera options are refused",
                    self.input.display()
                );
            }
            self.read_dataset(&manifest)
        } else if self.input.is_dir() {
            if !self.sets.is_empty() || self.noisy {
                bail!(
                    "--set and --noisy apply to data sets; {} has no manifest.json",
                    self.input.display()
                );
            }
            self.read_folder()
        } else {
            bail!(
                "{} is neither a data-set folder (with manifest.json) nor a folder of images",
                self.input.display()
            )
        }
    }

    /// Refuses a camera other than the one an `omnisim render` folder records in its
    /// render.json: its images would be read through the wrong model, silently.
    fn check_render_camera(&self, render: &RenderView, camera: &Camera) -> anyhow::Result<()> {
        let recorded = match &render.camera {
            stereo if stereo["model"] == "stereo" => &stereo["left"],
            single => single,
        };
        let given = serde_json::to_value(omnisim::metadata::CameraMetadata::of(camera))?;
        let (Some(recorded), Some(given)) = (recorded.as_object(), given.as_object()) else {
            return Ok(());
        };
        let differing: Vec<&str> = given
            .iter()
            .filter(|(key, value)| recorded.get(*key).is_some_and(|r| r != *value))
            .map(|(key, _)| key.as_str())
            .collect();
        if !differing.is_empty() {
            bail!(
                "{} records a {} camera whose {} differ from the camera given here ({}); give the camera options it \
                 was rendered with (its omnisim-run.txt holds the command)",
                self.input.join(RENDER_RECORD).display(),
                recorded.get("model").and_then(|m| m.as_str()).unwrap_or("different"),
                differing.join(", "),
                camera.model_name()
            );
        }
        Ok(())
    }

    /// An `omnisim render` folder's render.json, if the folder has one.
    fn render_record(&self) -> anyhow::Result<Option<RenderView>> {
        let path = self.input.join(RENDER_RECORD);
        match std::fs::symlink_metadata(&path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("cannot check {}", path.display())),
            Ok(_) => {}
        }
        let text = omnisim::input::read_text(&path, MANIFEST_LIMIT)?;
        let render = serde_json::from_str(&text).with_context(|| {
            format!(
                "{} is not the render.json of an omnisim render, which says which files are colour images; \
                 move it out of the folder to read every PNG as an image",
                path.display()
            )
        })?;
        Ok(Some(render))
    }

    /// Whether any camera option differs from its default.
    fn camera_given(&self) -> bool {
        self.camera != default_camera_args()
    }

    fn read_dataset(&self, manifest: &Path) -> anyhow::Result<Input> {
        let text = omnisim::input::read_text(manifest, MANIFEST_LIMIT)?;
        let view: ManifestView = serde_json::from_str(&text)
            .with_context(|| format!("{} is not an omnisim data-set manifest", manifest.display()))?;
        for wanted in &self.sets {
            if !view.sets.iter().any(|s| &s.name == wanted) {
                let names: Vec<&str> = view.sets.iter().map(|s| s.name.as_str()).collect();
                bail!("the data set has no set '{wanted}'; it has {names:?}");
            }
        }
        // A stereo set's images are the left camera's.
        let camera = view.rig.build().context("the manifest's camera")?.first_camera();
        let suffixes: &[&str] = if self.noisy {
            &["-noisy", "-left-noisy"]
        } else {
            &["", "-left"]
        };
        let kind = if self.noisy {
            FileKind::Noisy
        } else {
            FileKind::GroundTruth
        };
        let mut sets = Vec::new();
        for set in view
            .sets
            .into_iter()
            .filter(|s| self.sets.is_empty() || self.sets.contains(&s.name))
        {
            plain_name(&set.name).with_context(|| format!("set name '{}' in the manifest", set.name))?;
            let frames = set
                .frame_entries
                .iter()
                .map(|frame| {
                    let wanted: Vec<String> = suffixes
                        .iter()
                        .map(|s| format!("{}/{}{s}.png", set.name, frame.stem))
                        .collect();
                    let file = frame
                        .files
                        .iter()
                        .find(|f| f.kind == kind && wanted.contains(&f.path))
                        .with_context(|| {
                            format!(
                                "set '{}' frame {} has no colour image {}",
                                set.name, frame.index, wanted[0]
                            )
                        })?;
                    Ok(InputFrame {
                        index: frame.index,
                        stem: frame.stem.clone(),
                        path: inside(&self.input, &file.path)?,
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            sets.push(InputSet { name: set.name, frames });
        }
        Ok(Input {
            kind: "dataset",
            sets,
            camera,
        })
    }

    fn read_folder(&self) -> anyhow::Result<Input> {
        let render = self.render_record()?;
        let paths = match &render {
            Some(render) => render.colour_images(&self.input)?,
            None => self.list_images()?,
        };
        let Some(first) = paths.first() else {
            bail!("{} holds no PNG image", self.input.display());
        };
        let recorded_rig = render
            .as_ref()
            .and_then(|r| r.rig.as_ref())
            .filter(|_| !self.camera_given());
        let camera = if let Some(rig) = recorded_rig {
            // The rig render.json records: the camera its colour images (a pair's left) came from.
            rig.build().context("the camera render.json records")?.first_camera()
        } else {
            let mut camera_args = self.camera.clone();
            if camera_args.size.is_none() {
                let (w, h) = image_size(first)?;
                camera_args.size = Some((w, h));
            }
            match camera_args.build()? {
                Rig::Single(camera) => camera,
                Rig::Stereo(_) => bail!("give the images of one camera of a stereo pair as --camera pinhole"),
            }
        };
        // A camera given by options must be the one the render recorded.
        if recorded_rig.is_none()
            && let Some(render) = &render
        {
            self.check_render_camera(render, &camera)?;
        }
        let name = plain_name(
            &self
                .input
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        )
        .map(str::to_string)
        .unwrap_or_else(|_| "images".to_string());
        let frames = paths
            .into_iter()
            .enumerate()
            .map(|(index, path)| InputFrame {
                index,
                stem: path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                path,
            })
            .collect();
        Ok(Input {
            kind: "images",
            sets: vec![InputSet { name, frames }],
            camera,
        })
    }

    /// The folder's PNG files, in name order.
    fn list_images(&self) -> anyhow::Result<Vec<PathBuf>> {
        let mut paths = Vec::new();
        for entry in std::fs::read_dir(&self.input).with_context(|| format!("cannot list {}", self.input.display()))? {
            let path = entry?.path();
            let image = path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("png"));
            if image && path.is_file() {
                super::recordable(&path, SIDECARS_RECORD)?;
                paths.push(path);
            }
        }
        paths.sort();
        Ok(paths)
    }
}

/// The file in which `omnisim render` records its camera and every frame's files.
const RENDER_RECORD: &str = "render.json";

/// The part of render.json read here.
#[derive(Deserialize)]
struct RenderView {
    /// The rig as described, in renders since it was recorded.
    #[serde(default)]
    rig: Option<RigSpec>,
    camera: serde_json::Value,
    frames: Vec<RenderFrameView>,
}

#[derive(Deserialize)]
struct RenderFrameView {
    stem: String,
    files: Vec<String>,
}

impl RenderView {
    /// Each frame's colour image (a stereo rig's left one), in pose order: the render's other
    /// PNGs (depth, object and face ids) are not images of the scene.
    fn colour_images(&self, folder: &Path) -> anyhow::Result<Vec<PathBuf>> {
        self.frames
            .iter()
            .map(|frame| {
                let names = [format!("{}.png", frame.stem), format!("{}-left.png", frame.stem)];
                let name = frame.files.iter().find(|f| names.contains(f)).with_context(|| {
                    format!(
                        "{} lists no colour image {} for frame {}",
                        folder.join(RENDER_RECORD).display(),
                        names[0],
                        frame.stem
                    )
                })?;
                Ok(folder.join(plain_name(name)?))
            })
            .collect()
    }
}

/// Refuses an output folder that is one the images are read from: a second run would read
/// its own outputs as images (and a data set would hold files it did not record).
pub(crate) fn refuse_writing_among_inputs(out: &Path, input: &Input) -> anyhow::Result<()> {
    for set in &input.sets {
        let (Ok(folder), Some(first)) = (out.join(&set.name).canonicalize(), set.frames.first()) else {
            continue;
        };
        if first.path.parent().and_then(|p| p.canonicalize().ok()) == Some(folder.clone()) {
            bail!(
                "--out {} would write set '{}' into {}, where its images are read from; choose another --out",
                out.display(),
                set.name,
                folder.display()
            );
        }
    }
    Ok(())
}

/// `name` if it is one plain folder name (no separator, not `.` or `..`), as set folders must be.
pub(crate) fn plain_name(name: &str) -> anyhow::Result<&str> {
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(_)), None) if !name.contains(['/', '\\']) => Ok(name),
        _ => bail!("'{name}' is not a plain folder name"),
    }
}

/// A manifest path (`/`-separated, relative) inside `root`, refusing any that could leave it
/// (the data-set library's own check).
fn inside(root: &Path, relative: &str) -> anyhow::Result<PathBuf> {
    omnisim_dataset::manifest::inside(root, relative).with_context(|| {
        format!("manifest path '{relative}' is not a path inside the data-set folder (or it goes through a link)")
    })
}

/// `render`'s camera options as they are when none is given.
fn default_camera_args() -> CameraArgs {
    #[derive(Parser)]
    struct Defaults {
        #[command(flatten)]
        camera: CameraArgs,
    }
    Defaults::parse_from(["omnisim"]).camera
}

/// Largest image file read.
const IMAGE_LIMIT: u64 = 1 << 30;

/// A reader of the image file `path`, opened only if it is a regular file (a FIFO would block).
fn open_image(path: &Path) -> anyhow::Result<image::ImageReader<BufReader<Take<File>>>> {
    let file = omnisim::input::open_regular(path, IMAGE_LIMIT)?;
    // Said plainly: the image crate calls an empty file one whose format it cannot determine.
    if file.get_ref().metadata().is_ok_and(|metadata| metadata.len() == 0) {
        bail!("{} is an empty file, not an image", path.display());
    }
    image::ImageReader::new(BufReader::new(file))
        .with_guessed_format()
        .with_context(|| format!("cannot read image {}", path.display()))
}

/// The image file `path`'s (width, height), from its header.
fn image_size(path: &Path) -> anyhow::Result<(u32, u32)> {
    open_image(path)?
        .into_dimensions()
        .map_err(|error| unreadable(path, error))
}

/// Why the image at `path` cannot be read, said plainly where the image crate's words are not
/// ("Memory limit exceeded" for a header that claims a huge image).
fn unreadable(path: &Path, error: image::ImageError) -> anyhow::Error {
    match error {
        image::ImageError::Limits(_) => anyhow::anyhow!(
            "cannot read image {}: its header claims an image larger than images are read here (at most 512 MiB \
             decoded); is it a camera image?",
            path.display()
        ),
        error => anyhow::Error::new(error).context(format!("cannot read image {}", path.display())),
    }
}

/// An image file as RGB 0..1, checked to be `size` (all images of a set are).
pub(crate) fn read_image(path: &Path, size: Option<(usize, usize)>) -> anyhow::Result<Raster> {
    let image = open_image(path)?.decode().map_err(|error| unreadable(path, error))?;
    let raster = Raster::from_image(&image);
    if let Some(size) = size {
        same_size(path, (raster.width, raster.height), size, "the set's first image")?;
    }
    Ok(raster)
}

/// Checks from the files' headers alone that every image of `sets` is `size` (the camera's),
/// so that a command can refuse a bad set before it writes anything.
pub(crate) fn check_image_sizes(sets: &[InputSet], size: (usize, usize)) -> anyhow::Result<()> {
    for frame in sets.iter().flat_map(|s| &s.frames) {
        let (w, h) = image_size(&frame.path)?;
        same_size(&frame.path, (w as usize, h as usize), size, "the camera's image")?;
    }
    Ok(())
}

fn same_size(path: &Path, got: (usize, usize), expected: (usize, usize), whose: &str) -> anyhow::Result<()> {
    if got != expected {
        bail!(
            "{} is {}×{} pixels, but {whose} is {}×{}",
            path.display(),
            got.0,
            got.1,
            expected.0,
            expected.1
        );
    }
    Ok(())
}

/// A `NAME[:KEY=VALUE,...]` option value: the name and its settings, each key checked against
/// the ones the name accepts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NamedSettings {
    pub name: String,
    pub settings: BTreeMap<String, String>,
}

impl NamedSettings {
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let (name, rest) = text.split_once(':').unwrap_or((text, ""));
        let mut settings = BTreeMap::new();
        for pair in rest.split(',').filter(|p| !p.is_empty()) {
            let (key, value) = pair
                .split_once('=')
                .ok_or_else(|| format!("'{pair}' in '{text}' is not KEY=VALUE"))?;
            if settings
                .insert(key.trim().to_string(), value.trim().to_string())
                .is_some()
            {
                return Err(format!("'{key}' is given twice in '{text}'"));
            }
        }
        Ok(Self {
            name: name.trim().to_string(),
            settings,
        })
    }

    /// Refuses keys other than `accepted`.
    pub(crate) fn check_keys(&self, accepted: &[&str]) -> anyhow::Result<()> {
        for key in self.settings.keys() {
            if !accepted.contains(&key.as_str()) {
                bail!(
                    "{}: unknown setting '{key}'; it takes {}",
                    self.name,
                    accepted.join(", ")
                );
            }
        }
        Ok(())
    }

    /// The setting `key` parsed as `T`, or `default`. Numbers must be finite: `nan`, `inf`
    /// and values that overflow to infinity (`1e999`) are refused for every setting.
    pub(crate) fn get<T: std::str::FromStr>(&self, key: &str, default: T) -> anyhow::Result<T> {
        match self.settings.get(key) {
            None => Ok(default),
            Some(text) => {
                if text.parse::<f64>().is_ok_and(|v| !v.is_finite()) {
                    bail!("{}: {key}={text} is not a finite number", self.name);
                }
                text.parse().map_err(|_| {
                    anyhow::anyhow!(
                        "{}: {key}={text} is not a valid {}",
                        self.name,
                        std::any::type_name::<T>()
                    )
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_settings_parse_and_check() {
        let s = NamedSettings::parse("fourier:k=32, on=panorama").unwrap();
        assert_eq!(s.name, "fourier");
        assert_eq!(s.get("k", 16usize).unwrap(), 32);
        assert_eq!(s.get("missing", 2.5f64).unwrap(), 2.5);
        assert!(s.check_keys(&["k"]).is_err());
        assert!(s.get::<usize>("on", 0).is_err());
        for text in ["nan", "NaN", "inf", "-inf", "infinity", "1e999"] {
            let s = NamedSettings::parse(&format!("radon:radial-step={text}")).unwrap();
            let error = s.get("radial-step", 1.0f64).unwrap_err().to_string();
            assert!(error.contains("not a finite number"), "{text}: {error}");
            assert!(s.get("radial-step", 1.0f32).is_err(), "{text}");
        }
        assert!(NamedSettings::parse("hog:cells").is_err());
        assert!(NamedSettings::parse("hog:k=1,k=2").is_err());
    }

    #[test]
    fn manifest_paths_stay_inside() {
        assert!(inside(Path::new("d"), "map/a.png").is_ok());
        for bad in ["../a.png", "map/../../a", "/etc/passwd", "map//a", ".", "a\\b"] {
            assert!(inside(Path::new("d"), bad).is_err(), "{bad}");
        }
    }
}
