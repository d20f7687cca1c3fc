//! `manifest.json` and the per-frame entries it is assembled from, as typed `Serialize` types.
//!
//! A frame is done when its entry (`<set>/.frames/<index>.json`) exists: it is written
//! atomically after every file it lists, with each file's size and SHA-256. The manifest is
//! assembled from the entries by `merge` (also the last step of an unsharded run), so a
//! resumed, a sharded and an uninterrupted run end with the same bytes.

use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::DatasetError;
use super::SkippedPose;
use super::spec::{LayoutSpec, NoiseSpec};
use omnisim::camera::RigSpec;
use omnisim::output::OutputSet;

/// What a file is, for readers that must not confuse noisy data with ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FileKind {
    /// Noise-free, exact.
    GroundTruth,
    /// With the set's sensor noise (`*-noisy.*`).
    Noisy,
    /// What a SLAM layout's sensor sees (noisy where the set has noise); under `tum/` or `mav0/`.
    Layout,
    /// Per-set calibration and legends.
    Set,
    /// Index files of a layout (rgb.txt, data.csv, ...).
    Index,
    /// Pictures of the set for people to look at (`contact-sheet.png`).
    Overview,
}

/// One file, relative to the data-set folder with `/` separators.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// Path inside the data-set folder.
    pub path: String,
    /// What it is.
    pub kind: FileKind,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256 of its bytes, lowercase hex.
    pub sha256: String,
}

/// A pose in every form a reader may want.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseEntry {
    /// Viewpoint, world metres.
    pub position: [f64; 3],
    /// (θx, θy, θz) degrees, `world_from_body` = Rx·Ry·Rz.
    pub angles_deg: [f64; 3],
    /// `world_from_body` as a unit quaternion (x, y, z, w), w ≥ 0.
    pub quaternion_xyzw: [f64; 4],
}

impl PoseEntry {
    /// The entry of `pose`.
    pub fn of(pose: &omnisim::Pose) -> Self {
        Self {
            position: pose.position.to_array(),
            angles_deg: pose.angles_degrees().to_array(),
            quaternion_xyzw: pose.quaternion_xyzw(),
        }
    }

    /// The pose back, exactly (angles from the radians the entry was made from are not kept,
    /// so layouts use the quaternion and position).
    pub fn rotation(&self) -> glam::DMat3 {
        let [x, y, z, w] = self.quaternion_xyzw;
        glam::DMat3::from_quat(glam::DQuat::from_xyzw(x, y, z, w))
    }
}

/// One frame's manifest entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameEntry {
    /// Position in its set, from 0.
    pub index: usize,
    /// Shared start of its files' names.
    pub stem: String,
    /// Pose of the rig.
    pub pose: PoseEntry,
    /// Lights, colour shifts and occluders of the frame.
    pub perturbations: serde_json::Value,
    /// Every file of the frame.
    pub files: Vec<FileEntry>,
}

/// What a set is: its frames and files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetEntry {
    /// Folder name.
    pub name: String,
    /// Frames in the set.
    pub frames: usize,
    /// Poses the set left out, and why.
    pub skipped: Vec<SkippedPose>,
    /// Sensor noise of the set's `*-noisy.*` files.
    pub noise: NoiseSpec,
    /// Layouts written.
    pub layouts: Vec<LayoutSpec>,
    /// Calibration, ray maps, legends; then, after merge, layout index files.
    pub files: Vec<FileEntry>,
}

/// What a data-set folder holds, written before any frame (`.omnisim-dataset.json`): a run
/// or a merge refuses a folder whose identity differs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stamp {
    /// SHA-256 over the spec's, the scene's and the geometry's hashes.
    pub identity: String,
    /// omnisim's version that renders the frames (absent in stamps of versions before it).
    #[serde(default)]
    pub version: String,
    /// What renders the frames ([`omnisim::Renderer::renders_with`]); other renderers' bytes
    /// differ, so a resume, a shard or a merge must use this one.
    #[serde(default)]
    pub renderer: String,
    /// SHA-256 of the scene as loaded ([`geometry_sha256`]): covers the mesh files it reads.
    #[serde(default)]
    pub geometry_sha256: String,
    /// Spec file name (without folder) and its text.
    pub spec_file: String,
    /// The spec text.
    pub spec_text: String,
    /// SHA-256 of the spec text.
    pub spec_sha256: String,
    /// Scene file name and the SHA-256 of its text.
    pub scene_file: String,
    /// SHA-256 of the scene text.
    pub scene_sha256: String,
    /// The sets, with their frame counts and skipped poses (layouts and noise from the spec).
    pub sets: Vec<SetEntry>,
}

/// `manifest.json`: everything a reader needs to trust and use the data set; [`Manifest::read`]
/// reads it back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// "omnisim".
    pub tool: String,
    /// omnisim's version.
    pub version: String,
    /// Spec file name.
    pub spec_file: String,
    /// The spec, verbatim.
    pub spec: String,
    /// SHA-256 of the spec text.
    pub spec_sha256: String,
    /// Scene file name.
    pub scene_file: String,
    /// SHA-256 of the scene text.
    pub scene_sha256: String,
    /// SHA-256 of the scene as loaded: every face, object and light, so mesh files too
    /// (empty in manifests of versions before it).
    #[serde(default)]
    pub geometry_sha256: String,
    /// What rendered the frames: the CPU tracer, or the GPU adapter (empty before it was
    /// recorded).
    #[serde(default)]
    pub renderer: String,
    /// The top-level seed.
    pub seed: u64,
    /// The camera or rig of every set, as the spec gives it (calibration files per set).
    pub rig: RigSpec,
    /// Ground-truth files per frame.
    pub outputs: OutputSet,
    /// The sets with their files and frames.
    pub sets: Vec<ManifestSet>,
}

impl Manifest {
    /// Reads a data set's `manifest.json`. README's example, compiled here (the CLI's
    /// `tests/readme.rs` checks that they are the same):
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use omnisim_dataset::manifest::Manifest;
    /// let m = Manifest::read("data/env1/manifest.json".as_ref())?;
    /// for frame in &m.sets[0].frame_entries {
    ///     let stem = format!("data/env1/map/{}", frame.stem);
    ///     let rgb = image::open(format!("{stem}.png"))?.into_rgb8(); // sRGB
    ///     let range = exr::prelude::read_first_flat_layer_from_file(format!("{stem}-range.exr"))?; // metres
    ///     let [qx, qy, qz, qw] = frame.pose.quaternion_xyzw; // world_from_body
    /// #   let _ = (rgb, range, qx, qy, qz, qw);
    /// }
    /// # Ok(())
    /// # }
    /// ```
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        super::files::read_json(path)
    }
}

/// One set of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestSet {
    /// The set.
    #[serde(flatten)]
    pub set: SetEntry,
    /// Every frame.
    pub frame_entries: Vec<FrameEntry>,
}

/// Lowercase hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// Lowercase hex SHA-256 of `scene` as loaded: its objects (names, kinds), faces (every
/// vertex's f64 bits, colour, object) and lighting (as JSON, whose numbers round-trip
/// exactly). The scene file's hash misses the mesh files it names; this one sees them.
pub fn geometry_sha256(scene: &omnisim::scene::Scene) -> String {
    let mut hash = Sha256::new();
    for object in &scene.objects {
        for text in [object.name.as_str(), object.kind] {
            hash.update((text.len() as u64).to_le_bytes());
            hash.update(text.as_bytes());
        }
    }
    for face in &scene.faces {
        hash.update((face.vertices.len() as u64).to_le_bytes());
        for vertex in face.vertices.iter() {
            for v in vertex.to_array() {
                hash.update(v.to_le_bytes());
            }
        }
        hash.update(face.colour);
        hash.update(face.object.to_le_bytes());
    }
    hash.update(serde_json::to_vec(&scene.lighting).unwrap_or_default());
    // Textures and vertex colours (the finest level of each texture: the mips follow from it);
    // a scene without them hashes as it did before they existed.
    let surfaces = &scene.surfaces;
    if !surfaces.is_empty() {
        for level in surfaces.textures.iter().map(|t| &t.levels[0]) {
            hash.update(level.width.to_le_bytes());
            hash.update(level.height.to_le_bytes());
            level.srgb_texels().for_each(|t| hash.update(t.to_le_bytes()));
        }
        for index in surfaces.of_face() {
            hash.update(index.to_le_bytes());
        }
        for surface in surfaces.list() {
            let mut numbers = surface.anchor.to_array().to_vec();
            if let Some(uv) = &surface.uv {
                hash.update(uv.texture.to_le_bytes());
                hash.update([uv.wrap[0] as u8, uv.wrap[1] as u8]);
                numbers.extend(uv.at_anchor.to_array());
                numbers.extend(uv.gradient.iter().flat_map(omnisim::glam::DVec3::to_array));
            }
            if let Some(colours) = &surface.colours {
                numbers.extend(colours.at_anchor.to_array());
                numbers.extend(colours.gradient.iter().flat_map(omnisim::glam::DVec3::to_array));
            }
            numbers.iter().for_each(|v| hash.update(v.to_le_bytes()));
            hash.update([
                u8::from(surface.uv.is_some()),
                u8::from(surface.colours.is_some()),
                u8::from(surface.unlit),
            ]);
        }
    }
    hex(&hash.finalize())
}

pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .fold(String::with_capacity(2 * bytes.len()), |mut text, b| {
            let _ = write!(text, "{b:02x}");
            text
        })
}

/// Size and SHA-256 of the file at `path`, read in blocks.
pub fn hash_file(path: &Path) -> Result<(u64, String), DatasetError> {
    let io = |source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut hash = Sha256::new();
    let mut buffer = vec![0u8; 1 << 16];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buffer).map_err(io)?;
        if n == 0 {
            break;
        }
        hash.update(&buffer[..n]);
        bytes += n as u64;
    }
    Ok((bytes, hex(&hash.finalize())))
}

/// `path` relative to `root`, `/`-separated.
pub(crate) fn relative(root: &Path, path: &Path) -> String {
    let inside = path.strip_prefix(root).unwrap_or(path);
    inside
        .components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// The path of a manifest file path inside `root`, refusing any that could leave it (entries
/// may have been edited by hand).
pub fn inside(root: &Path, relative: &str) -> Option<PathBuf> {
    let ok = !relative.is_empty()
        && relative
            .split('/')
            .all(|part| !part.is_empty() && part != "." && part != ".." && !part.contains('\\'))
        && !relative.starts_with('/');
    // Nor through a link planted in the folder: it could lead anywhere.
    let mut path = root.to_path_buf();
    for part in relative.split('/').filter(|_| ok) {
        path.push(part);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
            return None;
        }
    }
    ok.then_some(path)
}

/// Checks that a listed file still has its recorded size and hash.
pub(crate) fn verify(root: &Path, file: &FileEntry, entry: &Path) -> Result<(), DatasetError> {
    // Hashed as it is read, nothing kept.
    verified(root, file, entry, |path| {
        hash_file(path).map(|(bytes, sha256)| (bytes, sha256, Vec::new()))
    })
    .map(drop)
}

/// Checks that a listed file still has its recorded size (its hash is taken as recorded: for
/// files the caller itself just wrote and hashed).
pub(crate) fn verify_size(root: &Path, file: &FileEntry, entry: &Path) -> Result<(), DatasetError> {
    verified(root, file, entry, |path| {
        let metadata = std::fs::metadata(path).map_err(|e| DatasetError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        Ok((metadata.len(), file.sha256.clone(), Vec::new()))
    })
    .map(drop)
}

/// The bytes of a listed file, checked against its recorded size and hash in the same read
/// (merge copies what it checks).
pub(crate) fn read_verified(root: &Path, file: &FileEntry, entry: &Path) -> Result<Vec<u8>, DatasetError> {
    verified(root, file, entry, |path| {
        let bytes = std::fs::read(path).map_err(|e| DatasetError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        Ok((bytes.len() as u64, sha256_hex(&bytes), bytes))
    })
}

/// Finds a listed file inside `root`, measures it with `measure` (size, SHA-256, and the
/// bytes where it keeps them) and refuses it where size or hash differ from the entry's.
fn verified(
    root: &Path,
    file: &FileEntry,
    entry: &Path,
    measure: impl FnOnce(&Path) -> Result<(u64, String, Vec<u8>), DatasetError>,
) -> Result<Vec<u8>, DatasetError> {
    let corrupt = |path: PathBuf, problem: String| DatasetError::Corrupt {
        path,
        entry: entry.to_path_buf(),
        problem,
    };
    let path = inside(root, &file.path).ok_or_else(|| {
        corrupt(
            root.join(&file.path),
            "not a path inside the folder, or one through a link".into(),
        )
    })?;
    let (bytes, sha256, content) = match measure(&path) {
        Ok(found) => found,
        Err(DatasetError::Io { source, .. }) => return Err(corrupt(path, source.to_string())),
        Err(e) => return Err(e),
    };
    if bytes != file.bytes || sha256 != file.sha256 {
        return Err(corrupt(
            path,
            format!(
                "{bytes} bytes with SHA-256 {sha256}, but its entry records {} bytes, {}",
                file.bytes, file.sha256
            ),
        ));
    }
    Ok(content)
}

/// Pretty JSON with a final newline.
pub(crate) fn to_json(value: &impl Serialize) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(value).unwrap_or_default();
    bytes.push(b'\n');
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_and_paths() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        // A folder that does not exist: `inside` looks for links on the way.
        let root = Path::new("/nonexistent-omnisim-data");
        assert_eq!(
            inside(root, "map/a.png"),
            Some(PathBuf::from("/nonexistent-omnisim-data/map/a.png"))
        );
        for bad in ["../x", "/etc/passwd", "map/../../x", "", "a//b", "a\\b"] {
            assert_eq!(inside(root, bad), None, "{bad}");
        }
        assert_eq!(
            relative(root, Path::new("/nonexistent-omnisim-data/map/tum/rgb/0.000000.png")),
            "map/tum/rgb/0.000000.png"
        );
    }

    #[cfg(unix)]
    #[test]
    fn no_path_inside_leads_through_a_link() {
        let dir = tempfile::tempdir().unwrap();
        let (root, elsewhere) = (dir.path().join("data"), dir.path().join("elsewhere"));
        std::fs::create_dir_all(root.join("map")).unwrap();
        std::fs::create_dir_all(&elsewhere).unwrap();
        std::os::unix::fs::symlink(&elsewhere, root.join("map/link")).unwrap();
        std::os::unix::fs::symlink(elsewhere.join("f"), root.join("map/file-link")).unwrap();
        assert_eq!(inside(&root, "map/a.png"), Some(root.join("map/a.png")));
        assert_eq!(inside(&root, "map/link/keep.txt"), None);
        assert_eq!(inside(&root, "map/file-link"), None);
    }
}

#[cfg(test)]
mod texture_identity_tests {
    use super::geometry_sha256;
    use omnisim::Scene;

    #[test]
    fn textures_count_in_the_scene_identity() {
        let scene = |pattern: &str| {
            let text = format!(
                r#"Scene(name: "t", objects: [Floor(name: "f", corners: [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], colour: (255, 255, 255){pattern})])"#
            );
            geometry_sha256(&Scene::from_ron(&text, std::path::Path::new("t.ron")).unwrap())
        };
        let seed = |s: u32| {
            format!(", texture: (pattern: Noise(low: (0, 0, 0), high: (255, 255, 255), seed: {s}), texels: 16)")
        };
        assert_ne!(scene(""), scene(&seed(1)));
        assert_ne!(scene(&seed(1)), scene(&seed(2)));
        assert_eq!(scene(&seed(1)), scene(&seed(1)));
    }
}
