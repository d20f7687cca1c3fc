//! Calibration files in the formats robotics tools read: `OpenCV` `FileStorage` YAML (pinhole,
//! stereo, omnidir) and Kalibr camchains (pinhole, omni). Every file states its conventions
//! in comments: pixel centres at integer coordinates, metres, and for mirrors the frame flip.

use std::fmt::Write;

use glam::{DMat3, DVec3};

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

fn opencv_body_from_camera(camera: &Pinhole) -> String {
    opencv_matrix("body_from_camera", 3, 3, &rows(BODY_FROM_OPTICAL))
        + &opencv_matrix("camera_position_in_body", 3, 1, &camera.position.to_array())
}

/// `OpenCV` YAML of one pinhole: `camera_matrix`, zero distortion, and `body_from_camera`.
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
    out += &opencv_body_from_camera(camera);
    out
}

/// `OpenCV` stereo YAML (stereoCalibrate names): M1, D1, M2, D2, R, T with
/// `X_right` = `R·X_left` + T, metres.
pub fn opencv_stereo(rig: &StereoRig) -> String {
    let c = &rig.camera;
    let mut out = String::from(HEADER);
    out += "# omnisim stereo rig, rectified by construction. OpenCV conventions (pixel centres at integer\n\
            # coordinates; optical frames x right, y down, z forward). X_right = R * X_left + T, metres.\n\
            # body_from_camera (rotation, optical frame to body frame x forward, y left, z up) and\n\
            # camera_position_in_body (metres) place the left camera on the robot.\n";
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
    out += &opencv_body_from_camera(&rig.cameras()[0]);
    out
}

const KALIBR_BODY_NOTE: &str = "# T_cam_imu of each camera is camera_from_body: it maps points in the robot body frame\n\
# (x forward, y left, z up; the frame of poses.txt), which stands in for the IMU frame, to the\n\
# camera frame. Metres.\n";

/// A Kalibr 4×4 transform entry `name` = [rotation | translation].
fn kalibr_transform(name: &str, rotation: DMat3, translation: DVec3) -> String {
    // + 0.0 turns −0 into 0.
    let r = (rotation.transpose() + DMat3::ZERO).to_cols_array_2d();
    let t = (translation + 0.0).to_array();
    let mut out = format!("  {name}:\n");
    for i in 0..3 {
        let _ = writeln!(out, "  - [{:?}, {:?}, {:?}, {:?}]", r[i][0], r[i][1], r[i][2], t[i]);
    }
    out + "  - [0.0, 0.0, 0.0, 1.0]\n"
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

/// Kalibr camchain of one pinhole, with its `T_cam_imu`.
pub fn kalibr_pinhole(camera: &Pinhole) -> String {
    kalibr_pinholes(std::slice::from_ref(camera), None)
}

/// Kalibr camchain of a stereo rig: left and right, each with `T_cam_imu`, and the right's
/// `T_cn_cnm1`.
pub fn kalibr_stereo(rig: &StereoRig) -> String {
    kalibr_pinholes(&rig.cameras(), Some(rig.baseline))
}

fn kalibr_pinholes(cameras: &[Pinhole], baseline: Option<f64>) -> String {
    let mut out = String::from("# omnisim camchain (Kalibr). Pixel centres at integer coordinates; metres.\n");
    out += KALIBR_BODY_NOTE;
    for (index, camera) in cameras.iter().enumerate() {
        let _ = writeln!(out, "cam{index}:");
        let camera_from_body = BODY_FROM_OPTICAL.transpose();
        out += &kalibr_transform("T_cam_imu", camera_from_body, -(camera_from_body * camera.position));
        if let (Some(baseline), 1..) = (baseline, index) {
            out += &kalibr_transform("T_cn_cnm1", DMat3::IDENTITY, DVec3::new(-baseline, 0.0, 0.0));
        }
        let intrinsics = [camera.fx, camera.fy, camera.cx, camera.cy];
        kalibr_camera(&mut out, index, "pinhole", &intrinsics, (camera.width, camera.height));
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

/// `OpenCV` omnidir YAML (`cv::omnidir)`: `camera_matrix`, distortion (k1 k2 p1 p2 = 0), xi as a
/// real, as `OpenCV`'s own `omni_calibration` sample writes it.
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
    out += "# xi is a real number (as OpenCV's omni_calibration sample writes it): Python\n\
            # fs.getNode('xi').real(), C++ double xi = fs[\"xi\"]; cv::omnidir takes it as a double.\n";
    let _ = writeln!(out, "xi: {:?}", model.xi);
    out += &opencv_matrix("body_from_mirror", 3, 3, &rows(camera.body_from_mirror()));
    Some(out)
}

/// Kalibr camchain with the `omni` model (intrinsics xi fu fv pu pv) and `T_cam_imu`; `None` if
/// non-central. Kalibr needs a proper rotation, so its camera frame is the mirror frame turned
/// by Rx(π) and fv is negated (the `OpenCV` file keeps positive focal lengths and a reflection).
pub fn kalibr_omni(camera: &Catadioptric) -> Option<String> {
    let model = camera.unified_model()?;
    let mut out = String::from("# omnisim camchain (Kalibr omni model), exact for this aligned central mirror.\n");
    out += "# Frames: the camera frame is the mirror frame M (origin at the viewpoint F', +z from the camera\n\
            # towards the mirror) turned half a turn about x: X_cam = (x_M, -y_M, -z_M), a proper rotation.\n\
            # With it fv is negative: u = pu + fu*x/(z + xi*|X|), v = pv + fv*y/(z + xi*|X|) reproduce the\n\
            # rendered pixels (the mirror flips the image's handedness). Pixel centres at integer\n\
            # coordinates. Ideal mirror and lens: no distortion.\n";
    out += KALIBR_BODY_NOTE;
    out += "cam0:\n";
    let camera_from_mirror = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    // The viewpoint F' is the body origin of a central camera.
    let camera_from_body = camera_from_mirror * camera.body_from_mirror().transpose();
    out += &kalibr_transform("T_cam_imu", camera_from_body, DVec3::ZERO);
    kalibr_camera(
        &mut out,
        0,
        "omni",
        &[model.xi, model.gamma_x, -model.gamma_y, model.cx, model.cy],
        (camera.width, camera.height),
    );
    Some(out)
}
