//! Which run a `render --out` folder belongs to: the identity `render` records in the folder's
//! manifest (see `omnisim::output::folder`).

use std::hash::Hasher;

use omnisim::Pose;
use omnisim::output::folder::RunFolder;

use crate::commands::render::RenderArgs;

/// Opens `args.out` for this run, printing what was cleaned up. Two runs are the same run when
/// the scene file, camera, poses and outputs are; the backend and the output path do not count.
pub(crate) fn open(args: &RenderArgs, poses: &[Pose]) -> anyhow::Result<RunFolder> {
    let scene = std::fs::canonicalize(&args.scene).unwrap_or_else(|_| args.scene.clone());
    let mut digest = Fnv1a::default();
    for pose in poses {
        for value in pose.position.to_array().into_iter().chain(pose.angles.to_array()) {
            digest.write_u64(value.to_bits());
        }
    }
    let identity = format!(
        "render scene={} camera={:?} poses={}:{:016x} edge_samples={} ply={} segmentation={} normals={} linear={}",
        scene.display(),
        args.camera,
        poses.len(),
        digest.finish(),
        args.edge_samples,
        !args.no_ply,
        args.segmentation,
        args.normals,
        args.linear
    );
    let command: Vec<String> = std::env::args_os().map(|a| a.to_string_lossy().into_owned()).collect();
    let folder = RunFolder::open(&args.out, &identity, &command.join(" "), args.overwrite)?;
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
