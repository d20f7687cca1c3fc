//! Writing one rendered frame: its files, noisy copies and layouts, and the entry that makes
//! it done once the run has made its files durable (`run.rs` does so for a batch of frames,
//! then writes their entries).

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::appearance::AppearanceRecord;
use super::layout::{self, Image};
use super::manifest::{FileEntry, FileKind, FrameEntry, PoseEntry, hex, relative, to_json};
use super::occluders::Occluder;
use super::rng::{Purpose, stream};
use super::sha256;
use super::{Dataset, DatasetError, noise};
use crate::files::entry_path;
use omnisim::Rig;
use omnisim::atomic_file::{Durability, write_bytes_atomically};
use omnisim::frame::Frame;
use omnisim::output::store::{EncodeBuffer, FileStore, Sink};
use omnisim::output::{self, Destination, FrameTarget, OutputError, SegmentObject};

impl Dataset {
    /// Writes a rendered frame's files (ground truth, noisy copies, layouts), not yet
    /// durable, and returns them with their entry, yet to be hashed ([`WrittenFrame::hashed`]).
    /// Runs on a writer thread while later frames render.
    pub(crate) fn write_frame(&self, out: &Path, rendered: RenderedFrame) -> Result<UnhashedFrame, DatasetError> {
        let RenderedFrame {
            set: s,
            index,
            frames,
            placed,
            record,
        } = rendered;
        let plan = &self.sets[s];
        let set = &plan.spec;
        let set_dir = out.join(&set.name);
        let pose = &plan.poses[index];
        let seed = self.spec.seed;
        let noisy_colour = !set.noise.colour.is_empty();
        let views = self.rig.views();
        let scene_stem = self.scene.file_stem();
        let target = FrameTarget {
            scene: &scene_stem,
            index,
            pose,
        };
        let stem = target.stem();
        let mut folder = FrameFiles::new(out, &set_dir);
        (self.spec.outputs).write_frame_files(&mut folder, &target, &self.rig, &frames)?;
        folder.kind = FileKind::Noisy;
        // Noisy copies, each view's colour then depth, then disparity: one stream, fixed order.
        let mut rng = stream(seed, &set.name, Some(index), Purpose::Noise);
        let mut sensor_colour = Vec::with_capacity(views.len());
        let mut sensor_depth = None;
        for (view, frame) in views.iter().zip(&frames) {
            let (suffix, camera) = (view.suffix, &view.camera);
            let size = (frame.width, frame.height);
            let colour = match (noisy_colour, frame.linear_colour()) {
                (true, Some(linear)) => {
                    let colour = noise::colour(linear, &set.noise.colour, &mut rng);
                    let path = set_dir.join(format!("{stem}{suffix}-noisy.png"));
                    output::write_png(&mut folder, &path, &Frame::from_colour(size.0, size.1, colour.clone()))?;
                    colour
                }
                _ => frame.colour().map(<[_]>::to_vec).unwrap_or_default(),
            };
            sensor_colour.push(colour);
            let depth = camera.depth_frame().map(|pinhole| pinhole.axial_depth(frame, pose));
            if let Some(model) = &set.noise.depth {
                if let Some(depth) = &depth {
                    let values = noise::depth(depth, model, &mut rng);
                    let png = set_dir.join(format!("{stem}{suffix}-depth-noisy.png"));
                    output::write_tum_depth_png(&mut folder, &png, size, &values)?;
                    let exr = set_dir.join(format!("{stem}{suffix}-depth-noisy.exr"));
                    let compression = self.spec.outputs.exr_compression;
                    output::write_axial_depth_exr(&mut folder, &exr, size, &values, compression)?;
                    sensor_depth.get_or_insert(values);
                } else {
                    let ranges: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
                    let values = noise::depth(&ranges, model, &mut rng);
                    let exr = set_dir.join(format!("{stem}{suffix}-range-noisy.exr"));
                    let compression = self.spec.outputs.exr_compression;
                    output::write_ranges_exr(&mut folder, &exr, size, &values, camera, compression)?;
                }
            }
            if sensor_depth.is_none() {
                sensor_depth = depth;
            }
        }
        if let (Some(model), Rig::Stereo(stereo)) = (&set.noise.disparity, &self.rig)
            && let Some(disparity) = stereo.disparity(&frames[0], pose)
        {
            let values = noise::disparity(&disparity, model, &mut rng);
            let path = set_dir.join(format!("{stem}-disparity-noisy.exr"));
            output::write_disparity_exr(
                &mut folder,
                &path,
                (frames[0].width, frames[0].height),
                &values,
                self.spec.outputs.exr_compression,
            )?;
        }
        folder.kind = FileKind::Layout;
        let size = (frames[0].width, frames[0].height);
        for layout in &set.layouts {
            for (image, path) in layout::frame_files(layout, &set_dir, index, views.len()) {
                match image {
                    Image::Colour(k) => {
                        let mut colour = sensor_colour[k].clone();
                        if layout::euroc_rows_flipped(&views[k].camera) {
                            flip_rows(&mut colour, size.0 as usize);
                        }
                        output::write_png(&mut folder, &path, &Frame::from_colour(size.0, size.1, colour))?;
                    }
                    Image::Depth => {
                        let depth = sensor_depth.as_deref().unwrap_or_default();
                        output::write_tum_depth_png(&mut folder, &path, size, depth)?;
                    }
                }
            }
        }
        let perturbations = Perturbations {
            appearance: record,
            occluders: (plan.occluders.iter().map(|occluder| OccluderRecord {
                occluder,
                segment: None,
            }))
            .chain(placed.iter().map(|(occluder, segment)| OccluderRecord {
                occluder,
                segment: segment.as_ref(),
            }))
            .collect(),
        };
        let entry = FrameEntry {
            index,
            stem,
            pose: PoseEntry::of(pose),
            perturbations: serde_json::to_value(&perturbations).unwrap_or_default(),
            files: folder.files,
        };
        Ok(UnhashedFrame {
            set: s,
            index,
            files: folder.paths,
            contents: folder.contents,
            entry_path: entry_path(&set_dir, index),
            entry,
        })
    }
}

/// A frame whose files are written, not yet durable, with their bytes, kept for their
/// SHA-256 that its entry still lacks.
pub(crate) struct UnhashedFrame {
    set: usize,
    index: usize,
    files: Vec<PathBuf>,
    /// Each file's bytes, in the entry's order.
    contents: Vec<Vec<u8>>,
    entry_path: PathBuf,
    entry: FrameEntry,
}

impl WrittenFrame {
    /// `frames` with their entries complete: their files hashed all together, two at a
    /// time where the CPU can ([`sha256::digests`]), so a writer hashes two frames' files
    /// in the time of about one and a half.
    pub(crate) fn hashed(frames: Vec<UnhashedFrame>) -> Vec<WrittenFrame> {
        let messages: Vec<&[u8]> = (frames.iter())
            .flat_map(|frame| frame.contents.iter().map(Vec::as_slice))
            .collect();
        let mut digests = sha256::digests(&messages).into_iter();
        (frames.into_iter())
            .map(|mut frame| {
                // Each frame takes as many digests as it has files' bytes, so one frame's
                // slip cannot shift its hashes into the next frame's entry.
                debug_assert_eq!(frame.entry.files.len(), frame.contents.len());
                let own = digests.by_ref().take(frame.contents.len());
                for (file, digest) in frame.entry.files.iter_mut().zip(own) {
                    file.sha256 = hex(&digest);
                }
                WrittenFrame {
                    set: frame.set,
                    index: frame.index,
                    bytes: frame.entry.files.iter().map(|f| f.bytes).sum(),
                    files: frame.files,
                    entry_path: frame.entry_path,
                    entry: to_json(&frame.entry),
                }
            })
            .collect()
    }
}

/// A frame whose files are written, not yet durable, and the entry that will make it done.
pub(crate) struct WrittenFrame {
    pub(crate) set: usize,
    pub(crate) index: usize,
    /// Bytes of its files.
    pub(crate) bytes: u64,
    /// Its files.
    pub(crate) files: Vec<PathBuf>,
    /// Where its entry goes, and the entry.
    pub(crate) entry_path: PathBuf,
    pub(crate) entry: Vec<u8>,
}

/// A frame's files as a data set writes them: each encoded into memory, written in one call
/// and renamed into place unsynced ([`Durability::Deferred`]); the run makes a batch of
/// frames durable before it writes their entries. Records each file's entry as it goes and
/// keeps its bytes, to be hashed there (not read back) once the frame is written.
struct FrameFiles<'a> {
    /// The data-set folder (entries name files relative to it).
    root: &'a Path,
    /// The set's folder.
    dir: &'a Path,
    /// What the files written next are.
    kind: FileKind,
    /// Their entries, still without SHA-256.
    files: Vec<FileEntry>,
    paths: Vec<PathBuf>,
    contents: Vec<Vec<u8>>,
}

impl<'a> FrameFiles<'a> {
    fn new(root: &'a Path, dir: &'a Path) -> Self {
        Self {
            root,
            dir,
            kind: FileKind::GroundTruth,
            files: Vec::new(),
            paths: Vec::new(),
            contents: Vec::new(),
        }
    }
}

impl FileStore for FrameFiles<'_> {
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        let mut buffer = EncodeBuffer::default();
        write_bytes_atomically(path, Durability::Deferred, buffer.encode(fill)?)?;
        let bytes = buffer.into_bytes();
        self.files.push(FileEntry {
            path: relative(self.root, path),
            kind: self.kind,
            bytes: bytes.len() as u64,
            sha256: String::new(),
        });
        self.paths.push(path.to_path_buf());
        self.contents.push(bytes);
        Ok(())
    }

    fn encodes_in_memory(&self) -> bool {
        true
    }
}

impl Destination for FrameFiles<'_> {
    fn dir(&self) -> &Path {
        self.dir
    }

    fn claim(&mut self, name: String) -> Result<PathBuf, OutputError> {
        Ok(self.dir.join(name))
    }
}

/// Turns an image of rows `width` pixels long upside down.
fn flip_rows(pixels: &mut [[u8; 3]], width: usize) {
    let rows = pixels.len() / width.max(1);
    for row in 0..rows / 2 {
        let (top, bottom) = pixels.split_at_mut((rows - 1 - row) * width);
        top[row * width..(row + 1) * width].swap_with_slice(&mut bottom[..width]);
    }
}

/// A frame rendered and not yet written.
pub(crate) struct RenderedFrame {
    pub(crate) set: usize,
    pub(crate) index: usize,
    /// One per view of the rig.
    pub(crate) frames: Vec<Frame>,
    /// Its per-frame occluders, each with its ids in this frame's segmentation images (where
    /// the data set writes them).
    pub(crate) placed: Vec<(Occluder, Option<SegmentObject>)>,
    pub(crate) record: AppearanceRecord,
}

#[derive(Serialize)]
pub(crate) struct Perturbations<'a> {
    #[serde(flatten)]
    pub(crate) appearance: AppearanceRecord,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub(crate) occluders: Vec<OccluderRecord<'a>>,
}

/// An occluder in a frame's entry.
#[derive(Serialize)]
pub(crate) struct OccluderRecord<'a> {
    #[serde(flatten)]
    pub(crate) occluder: &'a Occluder,
    /// A per-frame occluder's object and face ids in this frame's segmentation images (the
    /// set's `segmentation.json` lists the scene's objects and the set-wide occluders).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) segment: Option<&'a SegmentObject>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::sha256_hex;

    /// A frame of `files` (name, bytes) stored through [`FrameFiles`] in `dir`.
    fn unhashed(dir: &Path, index: usize, files: &[(&str, &[u8])]) -> UnhashedFrame {
        let mut folder = FrameFiles::new(dir, dir);
        for (name, bytes) in files {
            folder.store(&dir.join(name), |sink| sink.write_all(bytes)).unwrap();
        }
        UnhashedFrame {
            set: 0,
            index,
            files: folder.paths,
            contents: folder.contents,
            entry_path: entry_path(dir, index),
            entry: FrameEntry {
                index,
                stem: format!("{index:06}"),
                pose: PoseEntry::of(&omnisim::Pose::new(Default::default(), Default::default())),
                perturbations: serde_json::Value::Null,
                files: folder.files,
            },
        }
    }

    /// Frames hashed together (3 files and 2, one empty, one over a block pair) each get
    /// their own files' SHA-256 and sizes, in order.
    #[test]
    fn frames_hashed_together_get_their_own_files_hashes() {
        let dir = tempfile::tempdir().unwrap();
        let long: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        let first: [(&str, &[u8]); 3] = [("a.png", b"first frame"), ("b.exr", b""), ("c.ply", &long)];
        let second: [(&str, &[u8]); 2] = [("d.png", &long[..200]), ("e.exr", b"second frame")];
        let frames = vec![unhashed(dir.path(), 0, &first), unhashed(dir.path(), 1, &second)];
        let written = WrittenFrame::hashed(frames);
        assert_eq!(written.len(), 2);
        for (frame, files) in written.iter().zip([&first[..], &second[..]]) {
            let entry: FrameEntry = serde_json::from_slice(&frame.entry).unwrap();
            assert_eq!(entry.files.len(), files.len(), "frame {}", frame.index);
            for (file, (name, bytes)) in entry.files.iter().zip(files) {
                assert_eq!(file.path, *name);
                assert_eq!(file.sha256, sha256_hex(bytes), "{name}");
                assert_eq!(file.bytes, bytes.len() as u64, "{name}");
                assert_eq!(std::fs::read(dir.path().join(name)).unwrap(), *bytes, "{name}");
            }
            let total: usize = files.iter().map(|(_, bytes)| bytes.len()).sum();
            assert_eq!(frame.bytes, total as u64, "frame {}", frame.index);
        }
    }
}
