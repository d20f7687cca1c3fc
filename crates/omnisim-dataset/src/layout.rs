//! The layouts SLAM tools read: TUM RGB-D (`tum/`) and EuRoC/ASL (`mav0/`), inside a set's
//! folder. Per frame they hold what the sensor sees (noisy where the set has noise); their
//! index files are written from the frame entries when the set is complete.
//!
//! Frame i has the time i / rate seconds: TUM writes it with six decimals, `EuRoC` in integer
//! nanoseconds.

use std::fmt::Write;
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};

use super::manifest::FrameEntry;
use super::spec::LayoutSpec;
use omnisim::Rig;
use omnisim::camera::BODY_FROM_OPTICAL;
use omnisim::camera::Camera;

/// Which sensor image a layout file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Image {
    /// The colour image of view `k`.
    Colour(usize),
    /// The 16-bit TUM depth image (z × 5000) of the first view.
    Depth,
}

/// TUM timestamp of frame `index`, seconds with six decimals.
pub(crate) fn tum_time(index: usize, rate: f64) -> String {
    format!("{:.6}", index as f64 / rate)
}

/// `EuRoC` timestamp of frame `index`, nanoseconds.
pub(crate) fn euroc_time(index: usize, rate: f64) -> u64 {
    (index as f64 * 1e9 / rate).round() as u64
}

/// The layout files of frame `index`, under the set folder `set_dir`.
pub(crate) fn frame_files(layout: &LayoutSpec, set_dir: &Path, index: usize, views: usize) -> Vec<(Image, PathBuf)> {
    match *layout {
        LayoutSpec::Tum { rate } => {
            let t = tum_time(index, rate);
            vec![
                (Image::Colour(0), set_dir.join(format!("tum/rgb/{t}.png"))),
                (Image::Depth, set_dir.join(format!("tum/depth/{t}.png"))),
            ]
        }
        LayoutSpec::Euroc { rate } => {
            let t = euroc_time(index, rate);
            (0..views)
                .map(|k| (Image::Colour(k), set_dir.join(format!("mav0/cam{k}/data/{t}.png"))))
                .collect()
        }
    }
}

/// (x y z, qx qy qz qw) of a rotation and translation, quaternion with w ≥ 0.
fn pose_text(rotation: DMat3, position: DVec3) -> String {
    let q = DQuat::from_mat3(&rotation).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    format!(
        "{} {} {} {} {} {} {}",
        position.x, position.y, position.z, q.x, q.y, q.z, q.w
    )
}

/// `body_from_optical` (rotation, translation) of view `k`, for pinhole views.
fn body_from_optical(rig: &Rig, k: usize) -> Option<(DMat3, DVec3)> {
    match &rig.views().get(k)?.camera {
        Camera::Pinhole(pinhole) => Some((BODY_FROM_OPTICAL, pinhole.position)),
        _ => None,
    }
}

/// The index files of `layout` for a complete set: (path under the set folder, text).
pub(crate) fn index_files(layout: &LayoutSpec, rig: &Rig, frames: &[FrameEntry]) -> Vec<(String, String)> {
    match *layout {
        LayoutSpec::Tum { rate } => tum_index(rig, frames, rate),
        LayoutSpec::Euroc { rate } => euroc_index(rig, frames, rate),
    }
}

fn tum_index(rig: &Rig, frames: &[FrameEntry], rate: f64) -> Vec<(String, String)> {
    let header = |what: &str, columns: &str| format!("# {what}\n# file: 'omnisim'\n# {columns}\n");
    let mut rgb = header("color images", "timestamp filename");
    let mut depth = header(
        "depth maps (16-bit PNG, value = z x 5000, 0 = no data)",
        "timestamp filename",
    );
    let mut optical = header(
        "ground truth trajectory of the colour camera's optical frame (x right, y down, z forward), world_from_camera",
        "timestamp tx ty tz qx qy qz qw",
    );
    let mut body = header(
        "ground truth trajectory of the body frame (x forward, y left, z up), world_from_body",
        "timestamp tx ty tz qx qy qz qw",
    );
    // Checked on load: TUM sets have pinhole views.
    let (rotation, offset) = body_from_optical(rig, 0).unwrap_or((DMat3::IDENTITY, DVec3::ZERO));
    for frame in frames {
        let t = tum_time(frame.index, rate);
        let (r, p) = (frame.pose.rotation(), DVec3::from(frame.pose.position));
        let _ = writeln!(rgb, "{t} rgb/{t}.png");
        let _ = writeln!(depth, "{t} depth/{t}.png");
        let _ = writeln!(optical, "{t} {}", pose_text(r * rotation, p + r * offset));
        let _ = writeln!(body, "{t} {}", pose_text(r, p));
    }
    vec![
        ("tum/rgb.txt".into(), rgb),
        ("tum/depth.txt".into(), depth),
        ("tum/groundtruth.txt".into(), optical),
        ("tum/groundtruth-body.txt".into(), body),
    ]
}

fn euroc_index(rig: &Rig, frames: &[FrameEntry], rate: f64) -> Vec<(String, String)> {
    let mut files = Vec::new();
    for (k, camera) in rig.views().iter().map(|view| &view.camera).enumerate() {
        let mut csv = String::from("#timestamp [ns],filename\n");
        for frame in frames {
            let t = euroc_time(frame.index, rate);
            let _ = writeln!(csv, "{t},{t}.png");
        }
        files.push((format!("mav0/cam{k}/data.csv"), csv));
        files.push((format!("mav0/cam{k}/sensor.yaml"), sensor_yaml(rig, k, camera, rate)));
    }
    let mut truth = String::from(
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], \
         v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], \
         b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n",
    );
    for (i, frame) in frames.iter().enumerate() {
        // Velocity by finite differences between neighbouring frames (meaningful along
        // trajectories); no IMU, so zero biases.
        let at = |j: usize| DVec3::from(frames[j].pose.position);
        let (a, b) = (i.saturating_sub(1), (i + 1).min(frames.len() - 1));
        let velocity = if b > a {
            (at(b) - at(a)) * rate / (b - a) as f64
        } else {
            DVec3::ZERO
        };
        let p = frame.pose.position;
        let [qx, qy, qz, qw] = frame.pose.quaternion_xyzw;
        let _ = writeln!(
            truth,
            "{},{},{},{},{qw},{qx},{qy},{qz},{},{},{},0,0,0,0,0,0",
            euroc_time(frame.index, rate),
            p[0],
            p[1],
            p[2],
            velocity.x,
            velocity.y,
            velocity.z
        );
    }
    files.push(("mav0/state_groundtruth_estimate0/data.csv".into(), truth));
    files
}

fn sensor_yaml(rig: &Rig, k: usize, camera: &Camera, rate: f64) -> String {
    let (w, h) = camera.size();
    let mut out = format!(
        "# omnisim camera {k}. T_BS: body_from_sensor (body x forward, y left, z up; metres).\n\
         sensor_type: camera\ncomment: omnisim {} camera {k}\n",
        camera.model_name()
    );
    let (rotation, translation) = body_from_optical(rig, k).unwrap_or((DMat3::IDENTITY, DVec3::ZERO));
    let r = rotation.transpose().to_cols_array();
    let t = translation.to_array();
    let data: Vec<String> = (0..3)
        .flat_map(|row| (0..3).map(move |col| r[row * 3 + col]).chain([t[row]]))
        .chain([0.0, 0.0, 0.0, 1.0])
        .map(|v| format!("{v:?}"))
        .collect();
    let _ = writeln!(out, "T_BS:\n  cols: 4\n  rows: 4\n  data: [{}]", data.join(", "));
    let _ = writeln!(out, "rate_hz: {rate}\nresolution: [{w}, {h}]");
    if let Camera::Pinhole(p) = camera {
        let _ = writeln!(
            out,
            "camera_model: pinhole\nintrinsics: [{:?}, {:?}, {:?}, {:?}] # fu, fv, cu, cv\n\
             distortion_model: radial-tangential\ndistortion_coefficients: [0.0, 0.0, 0.0, 0.0]",
            p.fx, p.fy, p.cx, p.cy
        );
    } else {
        out += "# Not a pinhole: T_BS is the body frame itself; every pixel's ray is in raymap-origin.exr and raymap-direction.exr of the set folder";
        out += match camera {
            Camera::Catadioptric(mirror) if omnisim::calibration::kalibr_omni(mirror).is_some() => {
                ",\n# the unified model in its calibration-kalibr.yaml.\n"
            }
            _ => ".\n",
        };
        let _ = writeln!(out, "camera_model: omnisim-{}", camera.model_name());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_follow_the_rate() {
        assert_eq!(tum_time(0, 30.0), "0.000000");
        assert_eq!(tum_time(31, 30.0), "1.033333");
        assert_eq!(euroc_time(3, 20.0), 150_000_000);
    }
}
