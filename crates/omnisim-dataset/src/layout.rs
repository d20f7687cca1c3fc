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
use omnisim::calibration::KalibrCamera;
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

/// `body_from_optical` (rotation, translation) of view `k`, for pinhole views (with or
/// without distortion).
fn body_from_optical(rig: &Rig, k: usize) -> Option<(DMat3, DVec3)> {
    let pinhole = rig.views().get(k)?.camera.depth_frame()?.clone();
    Some((BODY_FROM_OPTICAL, pinhole.position))
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
        files.push((format!("mav0/cam{k}/sensor.yaml"), sensor_yaml(k, camera, rate)));
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

/// Whether view `camera`'s `EuRoC` images are stored flipped top to bottom: a mirror's, so that
/// `mav0/` is what its `sensor.yaml` and the Kalibr camchain describe (Kalibr's omni model with
/// positive focal lengths cannot express a mirror's reversed handedness otherwise).
pub(crate) fn euroc_rows_flipped(camera: &Camera) -> bool {
    KalibrCamera::of(camera).is_some_and(|kalibr| kalibr.rows_flipped)
}

/// A `EuRoC` `sensor.yaml`: `T_BS` and the model are those of the Kalibr camchain where Kalibr
/// has the camera's model, so both files state one frame.
fn sensor_yaml(k: usize, camera: &Camera, rate: f64) -> String {
    let (w, h) = camera.size();
    let mut out = format!(
        "# omnisim camera {k}. T_BS: body_from_sensor (body x forward, y left, z up; metres).\n\
         sensor_type: camera\ncomment: omnisim {} camera {k}\n",
        camera.model_name()
    );
    let kalibr = KalibrCamera::of(camera);
    let (rotation, translation) = match (&kalibr, camera) {
        (Some(kalibr), _) => kalibr.body_from_camera(),
        (None, Camera::Lens(lens)) => (BODY_FROM_OPTICAL, lens.intrinsics.position),
        (None, _) => (DMat3::IDENTITY, DVec3::ZERO),
    };
    let r = rotation.transpose().to_cols_array();
    let t = translation.to_array();
    let data: Vec<String> = (0..3)
        .flat_map(|row| (0..3).map(move |col| r[row * 3 + col]).chain([t[row]]))
        .chain([0.0, 0.0, 0.0, 1.0])
        .map(|v| format!("{v:?}"))
        .collect();
    let _ = writeln!(out, "T_BS:\n  cols: 4\n  rows: 4\n  data: [{}]", data.join(", "));
    let _ = writeln!(out, "rate_hz: {rate}\nresolution: [{w}, {h}]");
    let list = |values: &[f64]| values.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(", ");
    if let Some(kalibr) = kalibr {
        if kalibr.rows_flipped {
            out += "# The images in data/ are the rendered images flipped top to bottom (row v -> height-1-v), as\n\
                        # the set's calibration-kalibr.yaml describes them: a mirror reverses the image's handedness.\n";
        }
        // EuRoC's names: radial-tangential for Kalibr's radtan (and for no distortion).
        let (distortion_model, coefficients) = match kalibr.distortion_model {
            "none" => ("radial-tangential", vec![0.0; 4]),
            "radtan" => ("radial-tangential", kalibr.distortion_coeffs.clone()),
            other => (other, kalibr.distortion_coeffs.clone()),
        };
        let names = match kalibr.camera_model {
            "pinhole" => "fu, fv, cu, cv",
            "omni" => "xi, fu, fv, cu, cv",
            "ds" => "xi, alpha, fu, fv, cu, cv",
            _ => "alpha, beta, fu, fv, cu, cv",
        };
        let _ = writeln!(
            out,
            "camera_model: {}\nintrinsics: [{}] # {names}\ndistortion_model: {distortion_model}\n\
                 distortion_coefficients: [{}]",
            kalibr.camera_model,
            list(&kalibr.intrinsics),
            list(&coefficients)
        );
    } else {
        out += match camera {
            Camera::Lens(_) => {
                "# No Kalibr model for this lens: T_BS is its optical frame (x right, y down, z forward); the set's\n\
                     # calibration files and raymap-origin.exr, raymap-direction.exr describe it.\n"
            }
            _ => {
                "# Not a pinhole: T_BS is the body frame itself; every pixel's ray is in raymap-origin.exr and \
                     raymap-direction.exr of the set folder.\n"
            }
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

    use glam::{DVec2, dvec2, dvec3};
    use omnisim::calibration::kalibr_camchain_of;
    use omnisim::camera::{
        BrownConrady, Catadioptric, KannalaBrandt, LensCamera, LensModel, Mount, Pinhole, StereoRig,
    };

    /// The numbers between the brackets after `key` (its first occurrence at or after `from`).
    fn numbers_after(text: &str, key: &str) -> Vec<f64> {
        let start = text.find(key).unwrap_or_else(|| panic!("no {key} in\n{text}")) + key.len();
        let rest = &text[start..];
        let list = &rest[rest.find('[').unwrap() + 1..rest.find(']').unwrap()];
        list.split(',')
            .filter(|v| !v.trim().is_empty())
            .map(|v| v.trim().parse().unwrap())
            .collect()
    }

    /// Kalibr's camera models with radtan or equidistant distortion, written out from Kalibr's
    /// sources (`aslam_cameras`): `model` and `intrinsics` as the files name them.
    fn kalibr_pixel(model: &str, intrinsics: &[f64], distortion: (&str, &[f64]), p: DVec3) -> DVec2 {
        let (shape, focal) = intrinsics.split_at(intrinsics.len() - 4);
        let m = match model {
            "pinhole" => dvec2(p.x / p.z, p.y / p.z),
            "omni" => {
                let d = p.length();
                dvec2(p.x, p.y) / (p.z + shape[0] * d)
            }
            "ds" => {
                let (xi, alpha) = (shape[0], shape[1]);
                let d1 = p.length();
                let d2 = (p.x * p.x + p.y * p.y + (xi * d1 + p.z).powi(2)).sqrt();
                dvec2(p.x, p.y) / (alpha * d2 + (1.0 - alpha) * (xi * d1 + p.z))
            }
            "eucm" => {
                let (alpha, beta) = (shape[0], shape[1]);
                let d = (beta * (p.x * p.x + p.y * p.y) + p.z * p.z).sqrt();
                dvec2(p.x, p.y) / (alpha * d + (1.0 - alpha) * p.z)
            }
            other => panic!("unknown Kalibr model {other}"),
        };
        let m = match distortion {
            ("equidistant", k) => {
                let r = m.length();
                let theta = r.atan();
                let t2 = theta * theta;
                m * (theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) / r)
            }
            ("radtan" | "radial-tangential", k) => {
                let (x, y) = (m.x, m.y);
                let r2 = x * x + y * y;
                let radial = 1.0 + k[0] * r2 + k[1] * r2 * r2;
                dvec2(
                    x * radial + 2.0 * k[2] * x * y + k[3] * (r2 + 2.0 * x * x),
                    y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * x * y,
                )
            }
            _ => m,
        };
        dvec2(focal[0] * m.x + focal[2], focal[1] * m.y + focal[3])
    }

    /// (rotation rows, translation) of a 4×4 given as its 16 numbers row by row.
    fn apply(matrix: &[f64], p: DVec3) -> DVec3 {
        let row =
            |r: usize| matrix[4 * r] * p.x + matrix[4 * r + 1] * p.y + matrix[4 * r + 2] * p.z + matrix[4 * r + 3];
        dvec3(row(0), row(1), row(2))
    }

    fn invert(matrix: &[f64]) -> Vec<f64> {
        // A rigid transform: [R t]⁻¹ = [Rᵀ −Rᵀt].
        let r = |i: usize, j: usize| matrix[4 * i + j];
        let t = [matrix[3], matrix[7], matrix[11]];
        let mut out = vec![0.0; 16];
        for i in 0..3 {
            for j in 0..3 {
                out[4 * i + j] = r(j, i);
            }
            out[4 * i + 3] = -(0..3).map(|j| r(j, i) * t[j]).sum::<f64>();
        }
        out[15] = 1.0;
        out
    }

    #[test]
    fn a_distorted_pinhole_has_the_pinholes_optical_frame_in_tum_ground_truth() {
        let spec = omnisim::camera::RigSpec::Pinhole(omnisim::camera::PinholeSpec {
            size: (64, 48),
            hfov: 80.0,
            focal: None,
            distortion: Some(vec![-0.2, 0.05, 0.001, 0.0]),
        });
        let rig = spec.build().unwrap();
        assert!(matches!(rig.views()[0].camera, Camera::Lens(_)));
        assert_eq!(body_from_optical(&rig, 0), Some((BODY_FROM_OPTICAL, DVec3::ZERO)));
    }

    #[test]
    fn sensor_yaml_and_the_kalibr_camchain_state_one_frame_and_the_rendered_pixels() {
        let mut mirror_down = Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()));
        mirror_down.mount = Mount::Down;
        let pinhole = Pinhole::with_horizontal_fov(320, 240, 1.2);
        let lens = |model| {
            Camera::Lens(Box::new(LensCamera {
                intrinsics: Pinhole::with_horizontal_fov(320, 240, 1.2),
                model,
            }))
        };
        // Both cameras of a fisheye stereo pair: their sensor.yaml files carry the lens and place
        // each eye.
        let [left_eye, right_eye] = StereoRig {
            camera: pinhole.clone(),
            lens: Some(LensModel::KannalaBrandt(
                KannalaBrandt::new([0.01, -0.002, 1e-4, 0.0]).unwrap(),
            )),
            baseline: 0.2,
        }
        .cameras();
        // A mirror seen through a radtan lens: Kalibr's omni-radtan, flipped.
        let mut mirror_radtan = Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()));
        mirror_radtan.lens = Some(Box::new(LensModel::Perspective(
            BrownConrady::new(&[-0.1, 0.02, 1e-3, -2e-3]).unwrap(),
        )));
        let cameras = [
            left_eye,
            right_eye,
            Camera::Catadioptric(mirror_radtan),
            Camera::Catadioptric(Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()))),
            Camera::Catadioptric(mirror_down),
            Camera::Pinhole(Pinhole {
                position: dvec3(0.0, -0.06, 0.0),
                ..pinhole
            }),
            lens(LensModel::Perspective(
                BrownConrady::new(&[-0.2, 0.05, 1e-3, -1e-3]).unwrap(),
            )),
            lens(LensModel::KannalaBrandt(
                KannalaBrandt::new([0.01, -0.002, 1e-4, 0.0]).unwrap(),
            )),
            lens(LensModel::DoubleSphere { xi: -0.2, alpha: 0.6 }),
            lens(LensModel::ExtendedUnified { alpha: 0.6, beta: 1.1 }),
            lens(LensModel::Unified {
                xi: 0.9,
                distortion: BrownConrady::new(&[-0.05, 0.01, 1e-4, -2e-4]).unwrap(),
            }),
        ];
        for camera in cameras {
            let sensor = sensor_yaml(0, &camera, 20.0);
            let kalibr = kalibr_camchain_of(&camera).expect("a Kalibr model");
            let flipped = euroc_rows_flipped(&camera);
            assert_eq!(flipped, kalibr.contains("IMAGE FLIPPED"), "{sensor}");
            let field = |text: &str, key: &str| {
                let line = text.lines().find(|l| l.trim_start().starts_with(key)).unwrap();
                line.split(':').nth(1).unwrap().trim().to_owned()
            };
            let camera_model = |text: &str| field(text, "camera_model:");
            let distortion_model = |text: &str| field(text, "distortion_model:");
            assert_eq!(camera_model(&sensor), camera_model(&kalibr));
            // Kalibr's rules: positive focal lengths.
            let intrinsics = numbers_after(&kalibr, "intrinsics:");
            let n = intrinsics.len();
            assert!(intrinsics[n - 4] > 0.0 && intrinsics[n - 3] > 0.0, "{kalibr}");
            let body_from_sensor = numbers_after(&sensor, "data:");
            let kalibr_rows: Vec<f64> = kalibr[kalibr.find("T_cam_imu:").unwrap()..]
                .lines()
                .skip(1)
                .take(4)
                .flat_map(|line| numbers_after(line, "-"))
                .collect();
            let (width, height) = camera.size();
            let mut checked = 0;
            for i in 0..2000 {
                let point = dvec3(
                    (f64::from(i) * 0.37).sin() * 4.0,
                    (f64::from(i) * 0.91).cos() * 4.0,
                    (f64::from(i) * 0.13).sin() * 2.0,
                );
                let Some(mut rendered) = camera.project(point) else {
                    continue;
                };
                if rendered.x < 0.0
                    || rendered.y < 0.0
                    || rendered.x > f64::from(width)
                    || rendered.y > f64::from(height)
                {
                    continue;
                }
                if flipped {
                    rendered.y = f64::from(height) - 1.0 - rendered.y;
                }
                let from_sensor = kalibr_pixel(
                    &camera_model(&sensor),
                    &numbers_after(&sensor, "intrinsics:"),
                    (
                        &distortion_model(&sensor),
                        &numbers_after(&sensor, "distortion_coefficients:"),
                    ),
                    apply(&invert(&body_from_sensor), point),
                );
                let from_kalibr = kalibr_pixel(
                    &camera_model(&kalibr),
                    &intrinsics,
                    (
                        &distortion_model(&kalibr),
                        &numbers_after(&kalibr, "distortion_coeffs:"),
                    ),
                    apply(&kalibr_rows, point),
                );
                let name = camera.model_name();
                assert!(
                    (from_sensor - rendered).length() < 1e-6,
                    "{name} sensor.yaml: {from_sensor} vs {rendered}"
                );
                assert!(
                    (from_kalibr - rendered).length() < 1e-6,
                    "{name} Kalibr: {from_kalibr} vs {rendered}"
                );
                checked += 1;
            }
            assert!(checked > 40, "{}: {checked} points checked", camera.model_name());
        }
    }
}
