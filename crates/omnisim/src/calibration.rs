//! Calibration files in the formats robotics tools read: OpenCV FileStorage YAML (pinhole,
//! stereo, omnidir) and Kalibr camchains (pinhole, omni). Every file states its conventions
//! in comments: pixel centres at integer coordinates, metres, and for mirrors the frame flip.

use std::fmt::Write;

use glam::DMat3;

use crate::camera::{Catadioptric, Pinhole, StereoRig, pinhole::BODY_FROM_OPTICAL};

const HEADER: &str = "%YAML:1.0\n---\n";

fn opencv_matrix(name: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let values: Vec<String> = data.iter().map(|v| format!("{v:?}")).collect();
    format!(
        "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        values.join(", ")
    )
}

fn k_matrix(fx: f64, fy: f64, cx: f64, cy: f64) -> [f64; 9] {
    [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
}

fn rows(m: DMat3) -> [f64; 9] {
    m.transpose().to_cols_array()
}

/// OpenCV YAML of one pinhole: camera_matrix, zero distortion, and body_from_camera.
pub fn opencv_pinhole(camera: &Pinhole) -> String {
    let mut out = String::from(HEADER);
    out += "# omnisim pinhole camera. OpenCV conventions: pixel centres at integer coordinates, (0,0) the\n\
            # top-left pixel's centre; optical frame x right, y down, z forward. Ideal lens: no distortion.\n\
            # body_from_camera is the rotation taking optical-frame vectors to the body frame (x forward,\n\
            # y left, z up); camera_position_in_body in metres.\n";
    let _ = writeln!(out, "image_width: {}\nimage_height: {}", camera.width, camera.height);
    out += &opencv_matrix(
        "camera_matrix",
        3,
        3,
        &k_matrix(camera.fx, camera.fy, camera.cx, camera.cy),
    );
    out += &opencv_matrix("distortion_coefficients", 1, 5, &[0.0; 5]);
    out += &opencv_matrix("body_from_camera", 3, 3, &rows(BODY_FROM_OPTICAL));
    out += &opencv_matrix("camera_position_in_body", 3, 1, &camera.position.to_array());
    out
}

/// OpenCV stereo YAML (stereoCalibrate names): M1, D1, M2, D2, R, T with
/// X_right = R·X_left + T, metres.
pub fn opencv_stereo(rig: &StereoRig) -> String {
    let c = &rig.camera;
    let mut out = String::from(HEADER);
    out += "# omnisim stereo rig, rectified by construction. OpenCV conventions (pixel centres at integer\n\
            # coordinates; optical frames x right, y down, z forward). X_right = R * X_left + T, metres.\n";
    let _ = writeln!(
        out,
        "image_width: {}\nimage_height: {}\nbaseline: {:?}",
        c.width, c.height, rig.baseline
    );
    let k = k_matrix(c.fx, c.fy, c.cx, c.cy);
    out += &opencv_matrix("M1", 3, 3, &k);
    out += &opencv_matrix("D1", 1, 5, &[0.0; 5]);
    out += &opencv_matrix("M2", 3, 3, &k);
    out += &opencv_matrix("D2", 1, 5, &[0.0; 5]);
    out += &opencv_matrix("R", 3, 3, &rows(DMat3::IDENTITY));
    out += &opencv_matrix("T", 3, 1, &[-rig.baseline, 0.0, 0.0]);
    out
}

fn kalibr_camera(out: &mut String, index: usize, model: &str, intrinsics: &[f64], size: (u32, u32)) {
    let values: Vec<String> = intrinsics.iter().map(|v| format!("{v:?}")).collect();
    let _ = write!(
        out,
        "  camera_model: {model}\n  intrinsics: [{}]\n  distortion_model: none\n  distortion_coeffs: []\n  \
         resolution: [{}, {}]\n  rostopic: /cam{index}/image_raw\n",
        values.join(", "),
        size.0,
        size.1
    );
}

/// Kalibr camchain of a pinhole (one camera) or a stereo rig (two, with T_cn_cnm1).
pub fn kalibr_pinhole(camera: &Pinhole, stereo_baseline: Option<f64>) -> String {
    let mut out = String::from("# omnisim camchain (Kalibr). Pixel centres at integer coordinates; metres.\ncam0:\n");
    let intrinsics = [camera.fx, camera.fy, camera.cx, camera.cy];
    kalibr_camera(&mut out, 0, "pinhole", &intrinsics, (camera.width, camera.height));
    if let Some(baseline) = stereo_baseline {
        let _ = write!(
            out,
            "cam1:\n  T_cn_cnm1:\n  - [1.0, 0.0, 0.0, {:?}]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n",
            -baseline
        );
        kalibr_camera(&mut out, 1, "pinhole", &intrinsics, (camera.width, camera.height));
    }
    out
}

const OMNI_FRAME_NOTE: &str = "# Frames: the unified model's camera frame is the mirror frame M (origin at the viewpoint F',\n\
# +z from the camera towards the mirror) with z reversed: X_model = (x_M, y_M, -z_M). That is a\n\
# reflection, as the mirror is: with positive focal lengths below, u = cx + gx*x/(z + xi*|X|),\n\
# v = cy + gy*y/(z + xi*|X|) for X = X_model. Tools that need a proper rotation can instead use\n\
# R_model_from_M = Rx(pi) (rvec = (pi, 0, 0)) with fy negated, or keep K and flip rows: v' = 2*cy - v.\n\
# body_from_mirror gives M in the robot body frame (x forward, y left, z up): a point at body azimuth\n\
# phi appears at image angle atan2(v - cy, u - cx) = phi with the mirror mounted up, -phi mounted down.\n\
# Pixel centres at integer coordinates. Ideal mirror and lens: no distortion.\n";

/// OpenCV omnidir YAML (cv::omnidir): camera_matrix, distortion (k1 k2 p1 p2 = 0), xi.
/// `None` for non-central cameras, which no unified model describes (use the ray map).
pub fn opencv_omnidir(camera: &Catadioptric) -> Option<String> {
    let model = camera.unified_model()?;
    let mut out = String::from(HEADER);
    out += "# omnisim catadioptric camera as Mei's unified model (exact for this aligned central mirror).\n";
    out += OMNI_FRAME_NOTE;
    let _ = writeln!(out, "image_width: {}\nimage_height: {}", camera.width, camera.height);
    out += &opencv_matrix(
        "camera_matrix",
        3,
        3,
        &k_matrix(model.gamma_x, model.gamma_y, model.cx, model.cy),
    );
    out += &opencv_matrix("distortion_coefficients", 1, 4, &[0.0; 4]);
    out += &opencv_matrix("xi", 1, 1, &[model.xi]);
    out += &opencv_matrix("body_from_mirror", 3, 3, &rows(camera.body_from_mirror()));
    Some(out)
}

/// Kalibr camchain with the `omni` model (intrinsics xi fu fv pu pv); `None` if non-central.
pub fn kalibr_omni(camera: &Catadioptric) -> Option<String> {
    let model = camera.unified_model()?;
    let mut out = String::from("# omnisim camchain (Kalibr omni model).\n");
    out += OMNI_FRAME_NOTE;
    out += "cam0:\n";
    kalibr_camera(
        &mut out,
        0,
        "omni",
        &[model.xi, model.gamma_x, model.gamma_y, model.cx, model.cy],
        (camera.width, camera.height),
    );
    Some(out)
}
