//! Which files a render writes, and writing them: per view of every frame (colour, range,
//! depth, point cloud, segmentation, normals, linear colour), per frame of a stereo rig
//! (disparity), and once per set of frames (calibration, ray maps, segmentation legend; a
//! render's `poses.txt` and `render.json` come from its record, `metadata.rs`). Files are named
//! `<scene>-<index>` + the view's suffix + the kind's suffix.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::folder::RunFolder;
use super::store::{FileStore, Sink};
use super::{ExrCompression, MAX_SEGMENT_ID, OutputError, OutputProblem, failed, write_json};
use crate::calibration;
use crate::camera::{Camera, Rig, View};
use crate::frame::{Frame, Plane, Planes};
use crate::pose::Pose;
use crate::scene::Scene;

/// Which files a render writes. [`OutputSet::default`] is what `omnisim render` writes without
/// options: colour, range, depth, point cloud and disparity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSet {
    /// `<stem>.png`: 8-bit sRGB colour.
    pub colour: bool,
    /// `<stem>-range.exr`: metres from each ray's origin.
    pub range: bool,
    /// Pinhole views: `<stem>-depth.png` (TUM, z × 5000) and `<stem>-depth.exr` (z, metres).
    pub depth: bool,
    /// `<stem>.ply`: coloured point cloud of every hit pixel.
    pub point_cloud: bool,
    /// `<stem>-object.png`, `<stem>-face.png` (16-bit ids) and, once, `segmentation.json`.
    pub segmentation: bool,
    /// `<stem>-normal.exr`: world-frame unit normals.
    pub normals: bool,
    /// `<stem>-linear.exr`: linear colour before sRGB encoding.
    pub linear: bool,
    /// Stereo rigs: `<stem>-disparity.exr` of the left image.
    pub disparity: bool,
    /// How every per-frame EXR is compressed (all lossless): `Zip` (default, smallest),
    /// `Rle` or `None` (faster to write).
    pub exr_compression: ExrCompression,
}

impl Default for OutputSet {
    fn default() -> Self {
        Self {
            colour: true,
            range: true,
            depth: true,
            point_cloud: true,
            segmentation: false,
            normals: false,
            linear: false,
            disparity: true,
            exr_compression: ExrCompression::Zip,
        }
    }
}

impl OutputSet {
    /// Why these outputs cannot be written for `scene`, found before any frame is: segmentation
    /// images hold object and face ids in 16 bits.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), TooManyIds> {
        let most = MAX_SEGMENT_ID as usize;
        if self.segmentation && (scene.faces.len() > most || scene.objects.len() > most) {
            return Err(TooManyIds {
                faces: scene.faces.len(),
                objects: scene.objects.len(),
            });
        }
        Ok(())
    }
}

/// A scene with more faces or objects than a 16-bit segmentation image has ids for.
#[derive(Debug, thiserror::Error)]
#[error(
    "the scene has {faces} faces and {objects} objects; segmentation images hold ids up to {MAX_SEGMENT_ID} (16 \
     bits): leave segmentation out, or split the scene"
)]
pub struct TooManyIds {
    /// Faces in the scene.
    pub faces: usize,
    /// Objects in the scene.
    pub objects: usize,
}

/// What one frame's files show, for their names and comments.
#[derive(Debug, Clone, Copy)]
pub struct FrameTarget<'a> {
    /// The scene's file stem (`Scene::file_stem`): the first part of every file name.
    pub scene: &'a str,
    /// Position of the pose in the run, from 0.
    pub index: usize,
    /// The pose the frame was rendered from.
    pub pose: &'a Pose,
}

impl FrameTarget<'_> {
    /// `<scene>-<index>`, the part of the file names shared by every file of the frame.
    pub fn stem(&self) -> String {
        format!("{}-{:04}", self.scene, self.index)
    }

    /// The frame's file with `suffix`, claimed in `folder`.
    fn path(&self, folder: &mut impl Destination, suffix: &str) -> Result<PathBuf, OutputError> {
        folder.claim(format!("{}{suffix}", self.stem()))
    }
}

/// Where an output set writes: a render's [`RunFolder`], which records each file before it is
/// written and syncs it as it writes it, or a [`PlainFolder`] whose store keeps its own
/// records (a data set's set files: unchanged ones left alone, a batch synced at once). A
/// data set's frames go to a destination of its own (hashing each file as it is written,
/// syncing a batch of frames at once).
pub trait Destination: FileStore {
    /// The folder the files go to.
    fn dir(&self) -> &Path;
    /// The path to write the file `name` to.
    fn claim(&mut self, name: String) -> Result<PathBuf, OutputError>;
}

impl FileStore for RunFolder {}

impl Destination for RunFolder {
    fn dir(&self) -> &Path {
        RunFolder::dir(self)
    }

    fn claim(&mut self, name: String) -> Result<PathBuf, OutputError> {
        RunFolder::claim(self, name.clone()).map_err(|e| OutputError::at(Path::new(&name), e))
    }
}

/// A folder files are written into as they are named, through `store`.
#[derive(Debug)]
pub struct PlainFolder<S> {
    /// The folder.
    pub dir: PathBuf,
    /// What writes each file (and keeps what its owner records of it).
    pub store: S,
}

impl<S: FileStore> FileStore for PlainFolder<S> {
    fn store(&mut self, path: &Path, fill: impl FnOnce(&mut dyn Sink) -> std::io::Result<()>) -> std::io::Result<()> {
        self.store.store(path, fill)
    }

    fn encodes_in_memory(&self) -> bool {
        self.store.encodes_in_memory()
    }
}

impl<S: FileStore> Destination for PlainFolder<S> {
    fn dir(&self) -> &Path {
        &self.dir
    }

    fn claim(&mut self, name: String) -> Result<PathBuf, OutputError> {
        Ok(self.dir.join(name))
    }
}

/// Bytes a pixel of the largest copy each writer makes of a plane while it encodes, measured
/// (peak resident memory of renders from 4 to 9 Mpx, docs/benchmarks.md "Memory"): the range's
/// f32 values; pinhole depth's f32 plane and its 16-bit PNG; the face ids and their PNG; three
/// f32 channels of normals or linear colour. Colour PNGs and point clouds copy nothing.
const WRITER_BYTES: [(&str, usize); 4] = [
    ("range writer", 4),
    ("depth writers", 8),
    ("segmentation writers", 8),
    ("normal or linear-colour writer", 12),
];

impl OutputSet {
    /// Peak memory of a render writing these files through `rig` on the CPU backend, in bytes
    /// for each pixel of one view, and what makes it up: every view's frame
    /// ([`Planes::bytes_per_pixel`]: a stereo rig holds both) while the writers, one after
    /// another, make their copies, of which the largest counts (`WRITER_BYTES`). The ray
    /// maps (24 bytes a pixel) are written once the frames are gone. Within 0.2 bytes a pixel
    /// of what renders measured; the GPU backend adds its read-back buffers.
    pub fn bytes_per_pixel(&self, rig: &Rig) -> Vec<(&'static str, usize)> {
        let views = rig.views().len();
        let planes = self.planes();
        let hits = Planes::HITS.bytes_per_pixel();
        let mut parts = vec![("hit planes", views * hits)];
        for (name, plane) in [
            ("colour", Plane::Colour),
            ("linear colour", Plane::LinearColour),
            ("object ids", Plane::Object),
        ] {
            if planes.contains(plane) {
                parts.push((name, views * (Planes::HITS.with(plane).bytes_per_pixel() - hits)));
            }
        }
        let pinhole = rig.first_camera().depth_frame().is_some();
        let writers = [
            self.range,
            self.depth && pinhole,
            self.segmentation,
            self.normals || self.linear,
        ];
        if let Some(&(name, bytes)) = WRITER_BYTES
            .iter()
            .zip(writers)
            .filter(|(_, written)| *written)
            .map(|(writer, _)| writer)
            .max_by_key(|(_, bytes)| *bytes)
        {
            parts.push((name, bytes));
        }
        parts
    }

    /// Whether a frame through `rig` gets any file of these: depth is written for pinhole views
    /// only and disparity for stereo rigs only, so a set of outputs may name files and still
    /// write none for a rig.
    pub fn writes_frame_files(&self, rig: &Rig) -> bool {
        self.colour
            || self.range
            || self.point_cloud
            || self.segmentation
            || self.normals
            || self.linear
            || (self.depth && rig.views().iter().any(|view| view.camera.depth_frame().is_some()))
            || (self.disparity && matches!(rig, Rig::Stereo(_)))
    }

    /// The planes a frame needs for these files (always colour: the point cloud is coloured).
    pub fn planes(&self) -> Planes {
        let mut planes = Planes::COLOUR;
        if self.linear {
            planes = planes.with(Plane::LinearColour);
        }
        if self.segmentation {
            planes = planes.with(Plane::Object);
        }
        planes
    }

    /// Writes the files of one view of a frame; returns their paths.
    pub fn write_view(
        &self,
        folder: &mut impl Destination,
        target: &FrameTarget,
        view: &View,
        frame: &Frame,
    ) -> Result<Vec<PathBuf>, OutputError> {
        let suffix = view.suffix;
        let camera = &view.camera;
        let size = (frame.width, frame.height);
        let mut written = Vec::new();
        if self.colour {
            let png = target.path(folder, &format!("{suffix}.png"))?;
            super::write_png(folder, &png, frame)?;
            written.push(png);
        }
        // Where the range EXR reads the pixels, the point cloud's hits are counted in the same
        // pass, and encoded there too where the store holds the whole file in memory anyway.
        let (mut hits, mut points) = (None, None);
        if self.range {
            let exr = target.path(folder, &format!("{suffix}-range.exr"))?;
            let pass = super::PixelPass::read(frame, self.point_cloud && folder.encodes_in_memory());
            (hits, points) = (Some(pass.hits), pass.points);
            super::write_ranges_exr(folder, &exr, size, &pass.ranges, camera, self.exr_compression)?;
            written.push(exr);
        }
        if let (true, Some(pinhole)) = (self.depth, camera.depth_frame()) {
            let depth = pinhole.axial_depth(frame, target.pose);
            let depth_png = target.path(folder, &format!("{suffix}-depth.png"))?;
            super::write_tum_depth_png(folder, &depth_png, size, &depth)?;
            let depth_exr = target.path(folder, &format!("{suffix}-depth.exr"))?;
            super::write_axial_depth_exr(folder, &depth_exr, size, &depth, self.exr_compression)?;
            written.extend([depth_png, depth_exr]);
        }
        if self.segmentation {
            let object_png = target.path(folder, &format!("{suffix}-object.png"))?;
            let objects = frame.object().ok_or_else(|| {
                OutputError::at(
                    &object_png,
                    OutputProblem::MissingPlane {
                        plane: "object",
                        request: "Plane::Object",
                    },
                )
            })?;
            super::write_id_png(folder, &object_png, size, objects)?;
            let face_png = target.path(folder, &format!("{suffix}-face.png"))?;
            super::write_id_png(folder, &face_png, size, &super::face_ids(frame))?;
            written.extend([object_png, face_png]);
        }
        if self.normals {
            let normal_exr = target.path(folder, &format!("{suffix}-normal.exr"))?;
            super::write_normal_exr(folder, &normal_exr, frame, self.exr_compression)?;
            written.push(normal_exr);
        }
        if self.linear {
            let linear_exr = target.path(folder, &format!("{suffix}-linear.exr"))?;
            super::write_linear_exr(folder, &linear_exr, frame, self.exr_compression)?;
            written.push(linear_exr);
        }
        if self.point_cloud {
            let ply = target.path(folder, &format!("{suffix}.ply"))?;
            let comment = format!(
                "scene {} camera {}{suffix} pose {}",
                target.scene,
                camera.model_name(),
                describe_pose(target.pose)
            );
            let points = match (&points, hits) {
                (Some(encoded), _) => super::PlyPoints::Encoded(encoded),
                (None, hits) => super::PlyPoints::Streamed {
                    frame,
                    hits: hits.unwrap_or_else(|| frame.hit_count()),
                },
            };
            super::write_point_cloud_points(folder, &ply, points, &comment)?;
            written.push(ply);
        }
        Ok(written)
    }

    /// Writes every file of a frame: each view's (`frames` in the order of `rig.views()`)
    /// and the rig's own (stereo disparity). Returns their paths.
    pub fn write_frame_files(
        &self,
        folder: &mut impl Destination,
        target: &FrameTarget,
        rig: &Rig,
        frames: &[Frame],
    ) -> Result<Vec<PathBuf>, OutputError> {
        let views = rig.views();
        assert_eq!(frames.len(), views.len(), "one frame per view of the rig");
        let mut written = Vec::new();
        for (view, frame) in views.iter().zip(frames) {
            written.extend(self.write_view(folder, target, view, frame)?);
        }
        if let (true, Rig::Stereo(stereo)) = (self.disparity, rig)
            && let Some(disparity) = stereo.disparity(&frames[0], target.pose)
        {
            let path = target.path(folder, "-disparity.exr")?;
            super::write_disparity_exr(
                folder,
                &path,
                (frames[0].width, frames[0].height),
                &disparity,
                self.exr_compression,
            )?;
            written.push(path);
        }
        Ok(written)
    }

    /// Writes the files of a set of frames that are not per frame into `folder`: calibration
    /// in the formats robotics tools read, the ray maps of each view (origin, direction,
    /// and both in one file) and the segmentation legend (if asked for).
    /// Returns their paths.
    pub fn write_set_files(
        &self,
        folder: &mut impl Destination,
        scene: &Scene,
        rig: &Rig,
    ) -> Result<Vec<PathBuf>, OutputError> {
        let mut written = Vec::new();
        for (name, text) in calibration_files(rig) {
            let path = folder.claim(name)?;
            folder
                .store(&path, |file| file.write_all(text.as_bytes()))
                .map_err(failed(&path))?;
            written.push(path);
        }
        for view in rig.views() {
            let [origin, direction, all] = super::ray_map_names(view.suffix);
            let paths = [folder.claim(origin)?, folder.claim(direction)?, folder.claim(all)?];
            super::write_ray_map_exrs(folder, paths.each_ref().map(PathBuf::as_path), &view.camera)?;
            written.extend(paths);
        }
        if self.segmentation {
            let legend_path = folder.claim("segmentation.json".into())?;
            write_json(folder, &legend_path, &super::SegmentationLegend::of(scene))?;
            written.push(legend_path);
        }
        Ok(written)
    }
}

/// Calibration files of `rig` where its model has a standard form: (file name, contents).
fn calibration_files(rig: &Rig) -> Vec<(String, String)> {
    let files: Vec<(&str, String)> = match rig {
        Rig::Single(Camera::Pinhole(pinhole)) => vec![
            ("calibration-opencv.yaml", calibration::opencv_pinhole(pinhole)),
            ("calibration-kalibr.yaml", calibration::kalibr_pinhole(pinhole)),
        ],
        Rig::Stereo(stereo) => return calibration::stereo_files(stereo),
        Rig::Single(Camera::Catadioptric(mirror)) => {
            match (calibration::opencv_omnidir(mirror), calibration::kalibr_omni(mirror)) {
                (Some(omnidir), Some(kalibr)) => vec![
                    ("calibration-opencv-omnidir.yaml", omnidir),
                    ("calibration-kalibr.yaml", kalibr),
                ],
                _ => Vec::new(),
            }
        }
        Rig::Single(Camera::Lens(lens)) => return calibration::lens_files(lens),
        Rig::Single(Camera::Equirectangular(_) | Camera::Cylindrical(_)) => Vec::new(),
    };
    files.into_iter().map(|(name, text)| (name.to_owned(), text)).collect()
}

fn describe_pose(pose: &Pose) -> String {
    let (t, a) = (pose.position, pose.angles_degrees());
    format!(
        "x={} y={} z={} m, theta_x={} theta_y={} theta_z={} deg",
        t.x, t.y, t.z, a.x, a.y, a.z
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Catadioptric, Pinhole, StereoRig};
    use crate::output::tests::Kept;
    use crate::scene::{Face, SceneObject};
    use glam::dvec3;

    /// The memory a render needs, from the plane types: README's "Memory" table and
    /// `render --help` state these figures, which renders measured (docs/benchmarks.md).
    #[test]
    fn bytes_per_pixel_follow_the_plane_types() {
        assert_eq!(
            Planes::HITS.bytes_per_pixel(),
            48,
            "README states 48 bytes of hit planes"
        );
        assert_eq!(Planes::ALL.bytes_per_pixel(), 48 + 3 + 12 + 4);
        let total =
            |outputs: &OutputSet, rig: &Rig| -> usize { outputs.bytes_per_pixel(rig).iter().map(|p| p.1).sum() };
        let omni = Rig::Single(Camera::Catadioptric(Catadioptric::hyperbolic(
            250, 250, 0.04, 0.16, None,
        )));
        let pinhole = Rig::Single(Camera::Pinhole(Pinhole::with_horizontal_fov(64, 48, 1.0)));
        let stereo = Rig::Stereo(StereoRig::rectified(Pinhole::with_horizontal_fov(64, 48, 1.0), 0.1));
        let every = OutputSet {
            segmentation: true,
            normals: true,
            linear: true,
            ..OutputSet::default()
        };
        assert_eq!(
            OutputSet::default().bytes_per_pixel(&omni),
            [("hit planes", 48), ("colour", 3), ("range writer", 4)]
        );
        assert_eq!(total(&OutputSet::default(), &pinhole), 59);
        assert_eq!(total(&OutputSet::default(), &stereo), 110);
        assert_eq!(total(&every, &omni), 79);
        let segmented = OutputSet {
            segmentation: true,
            ..OutputSet::default()
        };
        assert_eq!(total(&segmented, &omni), 63);
    }

    impl Destination for Kept {
        fn dir(&self) -> &Path {
            Path::new("")
        }

        fn claim(&mut self, name: String) -> Result<PathBuf, OutputError> {
            Ok(PathBuf::from(name))
        }
    }

    /// A point cloud encoded in the pass that reads the ranges (a store encoding in memory) is
    /// the one streamed from the pixels, byte for byte, with and without a range EXR beside it;
    /// each point has its own pixel's colour.
    #[test]
    fn point_clouds_encoded_with_the_ranges_are_those_streamed() {
        let mut pixels = vec![crate::frame::Pixel::MISS; 6];
        for (index, face, point) in [(1, 3, dvec3(1.0, -2.0, 0.5)), (4, 7, dvec3(-0.5, 0.25, 3.0))] {
            pixels[index] = crate::frame::Pixel {
                face,
                range: point.length() as f32,
                point,
                normal: glam::Vec3::Z,
            };
        }
        let mut frame = Frame::from_hits(3, 2, pixels);
        let colour = (0..6).map(|i| [i * 40, 7, 255 - i]).collect();
        frame.set_shading(Planes::COLOUR, Vec::new(), colour);
        let view = Rig::Single(Camera::Pinhole(Pinhole::with_horizontal_fov(3, 2, 1.0))).views()[0].clone();
        let pose = Pose::new(glam::DVec3::ZERO, glam::DVec3::ZERO);
        let target = FrameTarget {
            scene: "s",
            index: 0,
            pose: &pose,
        };
        let write = |range: bool, in_memory: bool| {
            let outputs = OutputSet {
                colour: false,
                range,
                depth: false,
                point_cloud: true,
                ..OutputSet::default()
            };
            let mut kept = Kept {
                in_memory,
                files: Vec::new(),
            };
            outputs.write_view(&mut kept, &target, &view, &frame).unwrap();
            kept.files
        };
        let streamed = write(true, false);
        assert_eq!(write(true, true), streamed);
        let (path, ply) = &streamed[1];
        assert_eq!(path, Path::new("s-0000.ply"));
        assert!(ply.windows(16).any(|w| w == b"element vertex 2"));
        assert!(
            ply.ends_with(
                &[
                    &(-0.5f32).to_le_bytes()[..],
                    &0.25f32.to_le_bytes(),
                    &3.0f32.to_le_bytes(),
                    &[160, 7, 251]
                ]
                .concat()
            )
        );
        assert_eq!(write(false, true), streamed[1..]);
    }

    #[test]
    fn segmentation_of_more_faces_than_16_bits_hold_is_refused_before_rendering() {
        let face = Face {
            vertices: [dvec3(0.0, 0.0, 0.0), dvec3(1.0, 0.0, 0.0), dvec3(0.0, 1.0, 0.0)]
                .into_iter()
                .collect(),
            colour: [9, 9, 9],
            object: 0,
        };
        let mut scene = Scene {
            objects: vec![SceneObject {
                name: "mesh".into(),
                kind: "Mesh",
            }],
            faces: vec![face; MAX_SEGMENT_ID as usize],
            ..Scene::default()
        };
        let segmented = OutputSet {
            segmentation: true,
            ..OutputSet::default()
        };
        assert!(segmented.check_scene(&scene).is_ok());
        scene.faces.push(scene.faces[0].clone());
        let message = segmented.check_scene(&scene).unwrap_err().to_string();
        assert!(
            message.contains("65536 faces") && message.contains("leave segmentation out"),
            "{message}"
        );
        assert!(OutputSet::default().check_scene(&scene).is_ok());
    }
}
