//! Writing one rendered frame: its files, noisy copies and layouts, then its entry (the
//! frame is done once the entry exists).

use std::path::Path;

use serde::Serialize;

use super::appearance::AppearanceRecord;
use super::layout::{self, Image};
use super::manifest::{FileKind, FrameEntry, PoseEntry, file_entry, to_json};
use super::occluders::Occluder;
use super::rng::{Purpose, stream};
use super::{Dataset, DatasetError, noise};
use crate::files::{entry_path, write_file};
use omnisim::Rig;
use omnisim::frame::Frame;
use omnisim::output::{self, FrameTarget, PlainFolder, SegmentObject};

impl Dataset {
    /// Writes a rendered frame's files (ground truth, noisy copies, layouts), then its entry;
    /// returns the bytes written. Runs on a writer thread while later frames render.
    pub(crate) fn write_frame(&self, out: &Path, rendered: RenderedFrame) -> Result<u64, DatasetError> {
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
        let mut files = Vec::new();
        let written =
            (self.spec.outputs).write_frame_files(&mut PlainFolder(set_dir.clone()), &target, &self.rig, &frames)?;
        for path in written {
            files.push(file_entry(out, &path, FileKind::GroundTruth)?);
        }
        // Noisy copies, each view's colour then depth, then disparity: one stream, fixed order.
        let mut rng = stream(seed, &set.name, Some(index), Purpose::Noise);
        let mut sensor_colour = Vec::with_capacity(views.len());
        let mut sensor_depth = None;
        let mut noisy = Vec::new();
        for (view, frame) in views.iter().zip(&frames) {
            let (suffix, camera) = (view.suffix, &view.camera);
            let size = (frame.width, frame.height);
            let colour = match (noisy_colour, frame.linear_colour()) {
                (true, Some(linear)) => {
                    let colour = noise::colour(linear, &set.noise.colour, &mut rng);
                    let path = set_dir.join(format!("{stem}{suffix}-noisy.png"));
                    output::write_png(&path, &Frame::from_colour(size.0, size.1, colour.clone()))?;
                    noisy.push(path);
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
                    output::write_tum_depth_png(&png, size, &values)?;
                    let exr = set_dir.join(format!("{stem}{suffix}-depth-noisy.exr"));
                    output::write_axial_depth_exr(&exr, size, values.clone(), self.spec.outputs.exr_compression)?;
                    noisy.extend([png, exr]);
                    sensor_depth.get_or_insert(values);
                } else {
                    let ranges: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
                    let values = noise::depth(&ranges, model, &mut rng);
                    let hits = frame
                        .pixels()
                        .iter()
                        .zip(values)
                        .map(|(p, range)| omnisim::advanced::Pixel { range, ..*p })
                        .collect();
                    let exr = set_dir.join(format!("{stem}{suffix}-range-noisy.exr"));
                    output::write_range_exr(
                        &exr,
                        &Frame::from_hits(size.0, size.1, hits),
                        camera,
                        self.spec.outputs.exr_compression,
                    )?;
                    noisy.push(exr);
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
                &path,
                (frames[0].width, frames[0].height),
                values,
                self.spec.outputs.exr_compression,
            )?;
            noisy.push(path);
        }
        for path in noisy {
            files.push(file_entry(out, &path, FileKind::Noisy)?);
        }
        let size = (frames[0].width, frames[0].height);
        for layout in &set.layouts {
            for (image, path) in layout::frame_files(layout, &set_dir, index, views.len()) {
                match image {
                    Image::Colour(k) => {
                        let mut colour = sensor_colour[k].clone();
                        if layout::euroc_rows_flipped(&views[k].camera) {
                            flip_rows(&mut colour, size.0 as usize);
                        }
                        output::write_png(&path, &Frame::from_colour(size.0, size.1, colour))?;
                    }
                    Image::Depth => {
                        output::write_tum_depth_png(&path, size, sensor_depth.as_deref().unwrap_or_default())?;
                    }
                }
                files.push(file_entry(out, &path, FileKind::Layout)?);
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
            files,
        };
        write_file(&entry_path(&set_dir, index), &to_json(&entry))?;
        Ok(entry.files.iter().map(|f| f.bytes).sum())
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
