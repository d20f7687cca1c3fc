//! MERGE SEAM: the only place the data-set machinery writes ground-truth files.
//!
//! The lead is moving the per-view output set (which files a view writes, and writing them)
//! into the core crate as `output::set::OutputSet`. At merge, replace the bodies of
//! [`write_frame`] with `OutputSet::write_frame(&FrameTarget { folder, scene, index, pose },
//! rig, frames)` (its `files` are these paths) and [`write_set_files`] with
//! `OutputSet::write_run_files` minus `poses.txt` and `render.json` (the manifest holds them).
//! Until then they call the existing `output::*` writers, as `omnisim render` does.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::DatasetRig;
use super::spec::Outputs;
use crate::calibration;
use crate::camera::Camera;
use crate::frame::{Frame, Plane, Planes};
use crate::output::{self, OutputError, atomic::write_atomically};
use crate::pose::Pose;
use crate::scene::Scene;

/// The planes a frame needs for `outputs` (colour always: point clouds are coloured).
pub(crate) fn planes(outputs: &Outputs) -> Planes {
    let mut planes = Planes::COLOUR;
    if outputs.linear {
        planes = planes.with(Plane::LinearColour);
    }
    if outputs.segmentation {
        planes = planes.with(Plane::Object);
    }
    planes
}

/// Writes the ground-truth files of one frame (`frames` in the order of `rig.views()`) as
/// `<folder>/<stem><view suffix><kind suffix>`; returns their paths.
pub(crate) fn write_frame(
    folder: &Path,
    stem: &str,
    outputs: &Outputs,
    rig: &DatasetRig,
    pose: &Pose,
    frames: &[Frame],
) -> Result<Vec<PathBuf>, OutputError> {
    let mut written = Vec::new();
    let path = |suffix: String| folder.join(format!("{stem}{suffix}"));
    for ((suffix, camera), frame) in rig.views().iter().zip(frames) {
        let size = (frame.width, frame.height);
        let mut files: Vec<PathBuf> = Vec::new();
        if outputs.colour {
            let p = path(format!("{suffix}.png"));
            output::write_png(&p, frame)?;
            files.push(p);
        }
        if outputs.range {
            let p = path(format!("{suffix}-range.exr"));
            output::write_range_exr(&p, frame, camera)?;
            files.push(p);
        }
        if let (true, Camera::Pinhole(pinhole)) = (outputs.depth, camera) {
            let depth = pinhole.axial_depth(frame, pose);
            let png = path(format!("{suffix}-depth.png"));
            output::write_tum_depth_png(&png, size, &depth)?;
            let exr = path(format!("{suffix}-depth.exr"));
            output::write_axial_depth_exr(&exr, size, depth)?;
            files.extend([png, exr]);
        }
        if let (true, Some(objects)) = (outputs.segmentation, frame.object()) {
            let object_png = path(format!("{suffix}-object.png"));
            output::write_id_png(&object_png, size, objects)?;
            let face_png = path(format!("{suffix}-face.png"));
            output::write_id_png(&face_png, size, &output::face_ids(frame))?;
            files.extend([object_png, face_png]);
        }
        if outputs.normals {
            let p = path(format!("{suffix}-normal.exr"));
            output::write_normal_exr(&p, frame)?;
            files.push(p);
        }
        if outputs.linear {
            let p = path(format!("{suffix}-linear.exr"));
            output::write_linear_exr(&p, frame)?;
            files.push(p);
        }
        if outputs.point_cloud {
            let p = path(format!("{suffix}.ply"));
            output::write_point_cloud_ply(&p, frame, &format!("camera {}{suffix}", camera.model_name()))?;
            files.push(p);
        }
        written.extend(files);
    }
    if let (true, DatasetRig::Stereo(stereo)) = (outputs.disparity, rig) {
        let p = path("-disparity.exr".into());
        output::write_disparity_exr(
            &p,
            (frames[0].width, frames[0].height),
            stereo.disparity(&frames[0], pose),
        )?;
        written.push(p);
    }
    Ok(written)
}

/// Writes a set's files that are not per frame: calibration, a ray map per view and, with
/// segmentation, the legend of the scene's objects (occluders are named per frame in the
/// manifest). Returns their paths.
pub(crate) fn write_set_files(
    folder: &Path,
    outputs: &Outputs,
    rig: &DatasetRig,
    scene: &Scene,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut texts: Vec<(&str, String)> = Vec::new();
    match rig {
        DatasetRig::Single(Camera::Pinhole(pinhole)) => {
            texts.push(("calibration-opencv.yaml", calibration::opencv_pinhole(pinhole)));
            texts.push(("calibration-kalibr.yaml", calibration::kalibr_pinhole(pinhole)));
        }
        DatasetRig::Stereo(stereo) => {
            texts.push(("calibration-opencv-stereo.yaml", calibration::opencv_stereo(stereo)));
            texts.push(("calibration-kalibr.yaml", calibration::kalibr_stereo(stereo)));
        }
        DatasetRig::Single(Camera::Catadioptric(mirror)) => {
            if let (Some(omnidir), Some(kalibr)) =
                (calibration::opencv_omnidir(mirror), calibration::kalibr_omni(mirror))
            {
                texts.push(("calibration-opencv-omnidir.yaml", omnidir));
                texts.push(("calibration-kalibr.yaml", kalibr));
            }
        }
        DatasetRig::Single(_) => {}
    }
    if outputs.segmentation {
        let legend = serde_json::to_string_pretty(&output::SegmentationLegend::of(scene)).map_err(|e| OutputError {
            path: folder.join("segmentation.json"),
            message: e.to_string(),
        })?;
        texts.push(("segmentation.json", legend));
    }
    let mut written = Vec::new();
    for (name, text) in texts {
        let path = folder.join(name);
        write_atomically(&path, |file| file.write_all(text.as_bytes())).map_err(|e| OutputError {
            path: path.clone(),
            message: e.to_string(),
        })?;
        written.push(path);
    }
    for (suffix, camera) in rig.views() {
        let path = folder.join(format!("raymap{suffix}.exr"));
        output::write_ray_map_exr(&path, &camera)?;
        written.push(path);
    }
    Ok(written)
}
