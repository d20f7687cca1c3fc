//! Which run a `render --out` folder belongs to: the identity `render` records in the folder's
//! manifest (see `omnisim::output::folder`).

use std::hash::Hasher;
use std::path::Path;

use omnisim::Pose;
use omnisim::camera::RigSpec;
use omnisim::output::folder::RunFolder;

/// What makes two renders the same run: the scene file (where it is: an edited scene renders
/// into its own folder again), rig, poses and `outputs` (the options that choose files); the
/// backend, the output folder and the options that spell the same rig do not count. The
/// record names the scene file and a digest of its full path, not the path itself.
pub(crate) fn identity(scene: &Path, rig: &RigSpec, poses: &[Pose], outputs: &str) -> anyhow::Result<String> {
    let mut scene_digest = Fnv1a::default();
    let full_path = std::fs::canonicalize(scene).unwrap_or_else(|_| scene.to_path_buf());
    scene_digest.write(full_path.as_os_str().as_encoded_bytes());
    let scene_name = scene.file_name().unwrap_or_default().to_string_lossy();
    let mut digest = Fnv1a::default();
    for pose in poses {
        for value in pose.position.to_array().into_iter().chain(pose.angles.to_array()) {
            digest.write_u64(value.to_bits());
        }
    }
    Ok(format!(
        "render scene={}:{:016x} rig={} poses={}:{:016x} {outputs}",
        scene_name,
        scene_digest.finish(),
        ron::to_string(rig)?,
        poses.len(),
        digest.finish(),
    ))
}

/// This process's command line as a record shows it: the program as its name, not the path it
/// was run from (the record is read elsewhere), and arguments that are not UTF-8 (file names)
/// as near as UTF-8 can.
pub(crate) fn command_line() -> Vec<String> {
    std::env::args_os()
        .enumerate()
        .map(|(i, arg)| {
            let arg = std::path::PathBuf::from(arg);
            let shown = if i == 0 {
                arg.file_name().unwrap_or_default().into()
            } else {
                arg.into_os_string()
            };
            shown.to_string_lossy().into_owned()
        })
        .collect()
}

/// Opens `out` for the run `identity`, printing what was cleaned up.
pub(crate) fn open(out: &Path, identity: &str, overwrite: bool) -> anyhow::Result<RunFolder> {
    let folder = RunFolder::open(out, identity, &command_line().join(" "), overwrite)?;
    for note in &folder.notes {
        crate::streams::stderr(format_args!("note: {note}"))?;
    }
    Ok(folder)
}

/// 64-bit FNV-1a: a digest that stays the same across Rust releases (`DefaultHasher` may not).
struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Hasher for Fnv1a {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for byte in bytes {
            self.0 = (self.0 ^ u64::from(*byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }
}
