//! Basalt's calibration JSON (`basalt-headers`, `headers_serialization.h`): the cereal archive
//! `value0` with `T_imu_cam` (camera to IMU: translation and unit quaternion), `intrinsics`
//! (`camera_type` and named parameters), `resolution` and the IMU fields, in the order its
//! loader reads them. It adds Basalt's own `ucm` (the unified model with α = ξ/(1+ξ)) beside
//! `kb4`, `ds` and `eucm`, which Kalibr's camchain already carries.

use std::fmt::Write;

use glam::DQuat;

use crate::camera::pinhole::BODY_FROM_OPTICAL;
use crate::camera::{LensCamera, LensModel};

/// Basalt's `camera_type` and its intrinsics by name, in its loader's order; `None` where
/// Basalt has no model for the lens.
fn intrinsics(camera: &LensCamera) -> Option<(&'static str, Vec<(&'static str, f64)>)> {
    let k = &camera.intrinsics;
    let mut values = vec![("fx", k.fx), ("fy", k.fy), ("cx", k.cx), ("cy", k.cy)];
    let name = match &camera.model {
        LensModel::KannalaBrandt(kb) => {
            values.extend(["k1", "k2", "k3", "k4"].into_iter().zip(kb.coefficients()));
            "kb4"
        }
        LensModel::Equidistant => {
            values.extend(["k1", "k2", "k3", "k4"].map(|name| (name, 0.0)));
            "kb4"
        }
        LensModel::DoubleSphere { xi, alpha } => {
            values.extend([("xi", *xi), ("alpha", *alpha)]);
            "ds"
        }
        LensModel::ExtendedUnified { alpha, beta } => {
            values.extend([("alpha", *alpha), ("beta", *beta)]);
            "eucm"
        }
        // Basalt's unified model divides by α·d + (1−α)·z = (z + ξ·d)/(1+ξ): the same camera
        // with α = ξ/(1+ξ) and focal lengths divided by 1+ξ. It has no distortion.
        LensModel::Unified { xi, distortion } if distortion.is_none() => {
            let scale = 1.0 + xi;
            values = vec![
                ("fx", k.fx / scale),
                ("fy", k.fy / scale),
                ("cx", k.cx),
                ("cy", k.cy),
                ("alpha", xi / scale),
            ];
            "ucm"
        }
        _ => return None,
    };
    Some((name, values))
}

/// Basalt's calibration JSON of `cameras` (one, or a stereo pair's left and right), the body
/// frame standing in for the IMU; `None` unless Basalt has every camera's model.
pub(crate) fn calibration(cameras: &[&LensCamera]) -> Option<String> {
    let models = cameras
        .iter()
        .map(|camera| intrinsics(camera))
        .collect::<Option<Vec<_>>>()?;
    let list = |values: &[f64]| values.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(", ");
    let q = DQuat::from_mat3(&BODY_FROM_OPTICAL).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    let poses: Vec<String> = cameras
        .iter()
        .map(|camera| {
            let p = camera.intrinsics.position + 0.0;
            format!(
                "      {{\"px\": {:?}, \"py\": {:?}, \"pz\": {:?}, \"qx\": {:?}, \"qy\": {:?}, \"qz\": {:?}, \"qw\": {:?}}}",
                p.x, p.y, p.z, q.x, q.y, q.z, q.w
            )
        })
        .collect();
    let intrinsics: Vec<String> = models
        .iter()
        .map(|(name, values)| {
            let fields: Vec<String> = values
                .iter()
                .map(|(key, value)| format!("\"{key}\": {value:?}"))
                .collect();
            format!(
                "      {{\"camera_type\": \"{name}\", \"intrinsics\": {{{}}}}}",
                fields.join(", ")
            )
        })
        .collect();
    let resolution: Vec<String> = cameras
        .iter()
        .map(|camera| {
            let (width, height) = camera.size();
            format!("[{width}, {height}]")
        })
        .collect();
    let mut out = String::from("{\n  \"value0\": {\n");
    let _ = writeln!(out, "    \"T_imu_cam\": [\n{}\n    ],", poses.join(",\n"));
    let _ = writeln!(out, "    \"intrinsics\": [\n{}\n    ],", intrinsics.join(",\n"));
    let _ = writeln!(out, "    \"resolution\": [{}],", resolution.join(", "));
    // omnisim simulates no IMU: zero biases and noise (docs/cameras.md), to be replaced by a
    // real IMU's figures before visual-inertial use.
    let _ = writeln!(out, "    \"calib_accel_bias\": [{}],", list(&[0.0; 9]));
    let _ = writeln!(out, "    \"calib_gyro_bias\": [{}],", list(&[0.0; 12]));
    out += "    \"imu_update_rate\": 200.0,\n";
    for name in ["accel_noise_std", "gyro_noise_std", "accel_bias_std", "gyro_bias_std"] {
        let _ = writeln!(out, "    \"{name}\": [{}],", list(&[0.0; 3]));
    }
    out += "    \"cam_time_offset_ns\": 0,\n    \"vignette\": []\n  }\n}\n";
    Some(out)
}
