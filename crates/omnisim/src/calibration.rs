//! Calibration files in the formats robotics tools read: `OpenCV` `FileStorage` YAML (pinhole
//! with distortion, stereo, `cv::fisheye`, `cv::omnidir`), Kalibr camchains (`pinhole-none`,
//! `pinhole-radtan`, `pinhole-equi`, `omni-none`, `omni-radtan`, `ds`, `eucm`), `OCamCalib`'s
//! `calib_results.txt` and Basalt's calibration JSON (`kb4`, `ds`, `eucm`, `ucm`). Every file states its conventions in comments: pixel centres at integer
//! coordinates, metres, and for mirrors the frame flip.

use std::fmt::Write;

use glam::{DMat3, DVec3};

use crate::camera::{Camera, Catadioptric, LensCamera, LensModel, Pinhole, StereoRig, pinhole::BODY_FROM_OPTICAL};

mod basalt;
mod ocamcalib;

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

fn opencv_body_from_camera(position: DVec3) -> String {
    opencv_matrix("body_from_camera", 3, 3, &rows(BODY_FROM_OPTICAL))
        + &opencv_matrix("camera_position_in_body", 3, 1, &position.to_array())
}

const OPENCV_FRAME_NOTE: &str = "OpenCV conventions: pixel centres at integer coordinates, (0,0) the\n\
# top-left pixel's centre; optical frame x right, y down, z forward. body_from_camera is the rotation\n\
# taking optical-frame vectors to the body frame (x forward, y left, z up); camera_position_in_body in\n\
# metres.\n";

/// `OpenCV` YAML of a camera with K (`camera_matrix`): `intro`, the conventions,
/// `distortion_coefficients`, `xi` where the model has it, and `body_from_camera`.
fn opencv_camera(intro: &str, camera: &Pinhole, distortion: &[f64], xi: Option<f64>) -> String {
    let mut out = String::from(HEADER);
    out += intro;
    out += OPENCV_FRAME_NOTE;
    let _ = writeln!(out, "image_width: {}\nimage_height: {}", camera.width, camera.height);
    out += &opencv_matrix(
        "camera_matrix",
        3,
        3,
        &k_matrix(camera.fx, camera.fy, camera.cx, camera.cy),
    );
    out += &opencv_matrix("distortion_coefficients", 1, distortion.len(), distortion);
    if let Some(xi) = xi {
        let _ = writeln!(out, "xi: {xi:?}");
    }
    out += &opencv_body_from_camera(camera.position);
    out
}

const PERSPECTIVE_INTRO: &str = "# omnisim pinhole camera; cv2.projectPoints with camera_matrix and distortion_coefficients\n\
# (OpenCV's order k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]) gives its pixels. ";

/// `OpenCV` YAML of one pinhole: `camera_matrix`, zero distortion, and `body_from_camera`.
pub fn opencv_pinhole(camera: &Pinhole) -> String {
    opencv_camera(PERSPECTIVE_INTRO, camera, &[0.0; 5], None)
}

/// `OpenCV` stereo YAML (stereoCalibrate names): M1, D1, M2, D2 (and xi1, xi2 for
/// `cv::omnidir`) where `OpenCV` has the cameras' model, and R, T with
/// `X_right` = `R·X_left` + T, metres.
pub fn opencv_stereo(rig: &StereoRig) -> String {
    let c = &rig.camera;
    let mut out = String::from(HEADER);
    let cameras = match &rig.lens {
        None => {
            out += "# omnisim stereo rig, rectified by construction. OpenCV conventions (pixel centres at integer\n\
                    # coordinates; optical frames x right, y down, z forward). X_right = R * X_left + T, metres.\n";
            Some((vec![0.0; 5], None))
        }
        Some(model) => {
            let opencv = opencv_lens(model);
            let _ = writeln!(
                out,
                "# omnisim stereo pair, both cameras with the {} lens: the right camera is the left one moved\n\
                 # by the baseline along its optical x, so R = I, but the images are not rectified (each has the\n\
                 # lens; there is no disparity file). {}\n\
                 # OpenCV conventions (pixel centres at integer coordinates; optical frames x right, y down,\n\
                 # z forward). X_right = R * X_left + T, metres.",
                model.name(),
                match &opencv {
                    Some(form) => form.stereo_note,
                    None =>
                        "OpenCV has no model for this lens: M1, D1, M2, D2 are left out; the\n\
                             # cameras are in calibration-kalibr.yaml where Kalibr has the model, render.json and the\n\
                             # ray maps (raymap-left-*.exr, raymap-right-*.exr).",
                }
            );
            opencv.map(|form| (form.coefficients, form.xi))
        }
    };
    out += "# body_from_camera (rotation, optical frame to body frame x forward, y left, z up) and\n\
            # camera_position_in_body (metres) place the left camera on the robot.\n";
    let _ = writeln!(
        out,
        "image_width: {}\nimage_height: {}\nbaseline: {:?}",
        c.width, c.height, rig.baseline
    );
    if let Some((distortion, xi)) = cameras {
        let k = k_matrix(c.fx, c.fy, c.cx, c.cy);
        for index in ["1", "2"] {
            out += &opencv_matrix(&format!("M{index}"), 3, 3, &k);
            out += &opencv_matrix(&format!("D{index}"), 1, distortion.len(), &distortion);
            if let Some(xi) = xi {
                let _ = writeln!(out, "xi{index}: {xi:?}");
            }
        }
    }
    out += &opencv_matrix("R", 3, 3, &rows(DMat3::IDENTITY));
    out += &opencv_matrix("T", 3, 1, &[-rig.baseline, 0.0, 0.0]);
    out += &opencv_body_from_camera(DVec3::new(0.0, rig.baseline / 2.0, 0.0));
    out
}

const KALIBR_BODY_NOTE: &str = "# T_cam_imu of each camera is camera_from_body: it maps points in the robot body frame\n\
# (x forward, y left, z up; the frame of poses.txt), which stands in for the IMU frame, to the\n\
# camera frame. Metres.\n";

/// One camera as a Kalibr camchain and a `EuRoC` `sensor.yaml` describe it: both files are
/// written from this, so they state one frame and one model.
#[derive(Debug, Clone, PartialEq)]
pub struct KalibrCamera {
    /// `camera_model`: pinhole, omni, ds or eucm.
    pub camera_model: &'static str,
    /// `intrinsics`, in Kalibr's order for the model; focal lengths positive.
    pub intrinsics: Vec<f64>,
    /// `distortion_model`: none, radtan or equidistant.
    pub distortion_model: &'static str,
    /// `distortion_coeffs`.
    pub distortion_coeffs: Vec<f64>,
    /// `resolution`: width, height.
    pub resolution: (u32, u32),
    /// `T_cam_imu`: `camera_from_body`, rotation then translation (metres).
    pub camera_from_body: (DMat3, DVec3),
    /// Whether the image this describes is the rendered one flipped top to bottom (row v
    /// becomes H−1−v): a mirror reverses the image's handedness, which Kalibr's models with
    /// positive focal lengths and a proper rotation cannot express otherwise.
    pub rows_flipped: bool,
}

/// Kalibr's camera-config rules (`kalibr_common/ConfigReader.py`): intrinsics per camera model
/// and coefficients per distortion model.
pub const KALIBR_INTRINSICS: [(&str, usize); 4] = [("pinhole", 4), ("omni", 5), ("ds", 6), ("eucm", 6)];

impl KalibrCamera {
    /// Kalibr's description of `camera`; `None` where Kalibr has no model for it (panoramas,
    /// non-central mirrors, Scaramuzza's polynomial, the ideal fisheyes other than
    /// equidistant, distortion beyond k1 k2 p1 p2).
    pub fn of(camera: &Camera) -> Option<Self> {
        let optical = |position: DVec3| {
            let camera_from_body = BODY_FROM_OPTICAL.transpose();
            (camera_from_body, -(camera_from_body * position))
        };
        match camera {
            Camera::Pinhole(c) => Some(Self {
                camera_model: "pinhole",
                intrinsics: vec![c.fx, c.fy, c.cx, c.cy],
                distortion_model: "none",
                distortion_coeffs: Vec::new(),
                resolution: (c.width, c.height),
                camera_from_body: optical(c.position),
                rows_flipped: false,
            }),
            Camera::Lens(c) => {
                let (camera_model, distortion_model, distortion_coeffs) = kalibr_lens(&c.model)?;
                let k = &c.intrinsics;
                let focal = [k.fx, k.fy, k.cx, k.cy];
                let intrinsics = match &c.model {
                    LensModel::DoubleSphere { xi, alpha } => [&[*xi, *alpha][..], &focal].concat(),
                    LensModel::ExtendedUnified { alpha, beta } => [&[*alpha, *beta][..], &focal].concat(),
                    LensModel::Unified { xi, .. } => [&[*xi][..], &focal].concat(),
                    _ => focal.to_vec(),
                };
                Some(Self {
                    camera_model,
                    intrinsics,
                    distortion_model,
                    distortion_coeffs,
                    resolution: c.size(),
                    camera_from_body: optical(k.position),
                    rows_flipped: false,
                })
            }
            Camera::Catadioptric(c) => {
                let model = c.unified_model()?;
                let [k1, k2, p1, p2] = c.unified_distortion()?;
                // The model frame turned half a turn about x: a proper rotation; with the rows
                // flipped, both focal lengths are positive.
                let camera_from_mirror = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
                let last_row = f64::from(c.height) - 1.0;
                Some(Self {
                    camera_model: "omni",
                    intrinsics: vec![model.xi, model.gamma_x, model.gamma_y, model.cx, last_row - model.cy],
                    // The rows flipped turn the tangential p1 over (y → −y).
                    distortion_model: if c.lens.is_some() { "radtan" } else { "none" },
                    distortion_coeffs: if c.lens.is_some() {
                        vec![k1, k2, -p1, p2]
                    } else {
                        Vec::new()
                    },
                    resolution: (c.width, c.height),
                    // The viewpoint F' is the body origin of a central camera.
                    camera_from_body: (camera_from_mirror * c.body_from_mirror().transpose(), DVec3::ZERO),
                    rows_flipped: true,
                })
            }
            Camera::Equirectangular(_) | Camera::Cylindrical(_) => None,
        }
    }

    /// `body_from_camera` (`EuRoC`'s `T_BS`): rotation and translation.
    pub fn body_from_camera(&self) -> (DMat3, DVec3) {
        let (rotation, translation) = self.camera_from_body;
        // + 0 turns −0 into 0, as files print it.
        (
            rotation.transpose() + DMat3::ZERO,
            -(rotation.transpose() * translation) + 0.0,
        )
    }

    /// The name Kalibr's command line gives this model pair, e.g. `pinhole-radtan`.
    pub fn model_pair(&self) -> String {
        match (self.camera_model, self.distortion_model) {
            (model, "none") => model.to_owned(),
            (model, "equidistant") => format!("{model}-equi"),
            (model, distortion) => format!("{model}-{distortion}"),
        }
    }

    /// This camera's entry under `cam<index>:` of a camchain.
    fn write_entry(&self, out: &mut String, index: usize) {
        let list = |values: &[f64]| values.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(", ");
        let _ = write!(
            out,
            "  camera_model: {}\n  intrinsics: [{}]\n  distortion_model: {}\n  distortion_coeffs: [{}]\n  \
             resolution: [{}, {}]\n  rostopic: /cam{index}/image_raw\n",
            self.camera_model,
            list(&self.intrinsics),
            self.distortion_model,
            list(&self.distortion_coeffs),
            self.resolution.0,
            self.resolution.1
        );
    }
}

/// Kalibr's (camera model, distortion model, coefficients) of a lens model.
fn kalibr_lens(model: &LensModel) -> Option<(&'static str, &'static str, Vec<f64>)> {
    match model {
        LensModel::Perspective(distortion) => Some(("pinhole", "radtan", distortion.radtan()?.to_vec())),
        LensModel::KannalaBrandt(kb) => Some(("pinhole", "equidistant", kb.coefficients().to_vec())),
        LensModel::Equidistant => Some(("pinhole", "equidistant", vec![0.0; 4])),
        LensModel::DoubleSphere { .. } => Some(("ds", "none", Vec::new())),
        LensModel::ExtendedUnified { .. } => Some(("eucm", "none", Vec::new())),
        LensModel::Unified { distortion, .. } => Some(("omni", "radtan", distortion.radtan()?.to_vec())),
        LensModel::Equisolid | LensModel::Stereographic | LensModel::Orthographic | LensModel::Scaramuzza(_) => None,
    }
}

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

/// A Kalibr camchain of `cameras` (each with `T_cam_imu`; with a stereo `baseline`, the
/// right camera's `T_cn_cnm1`), headed by `note`.
fn kalibr_camchain(note: &str, cameras: &[KalibrCamera], baseline: Option<f64>) -> String {
    let mut out = String::from("# omnisim camchain (Kalibr). Pixel centres at integer coordinates; metres.\n");
    out += note;
    out += KALIBR_BODY_NOTE;
    for (index, camera) in cameras.iter().enumerate() {
        let _ = writeln!(out, "cam{index}:");
        let (rotation, translation) = camera.camera_from_body;
        out += &kalibr_transform("T_cam_imu", rotation, translation);
        if let (Some(baseline), 1..) = (baseline, index) {
            out += &kalibr_transform("T_cn_cnm1", DMat3::IDENTITY, DVec3::new(-baseline, 0.0, 0.0));
        }
        camera.write_entry(&mut out, index);
    }
    out
}

/// Kalibr camchain of one pinhole, with its `T_cam_imu`.
pub fn kalibr_pinhole(camera: &Pinhole) -> String {
    let cameras = KalibrCamera::of(&Camera::Pinhole(camera.clone()))
        .into_iter()
        .collect::<Vec<_>>();
    kalibr_camchain("", &cameras, None)
}

/// Kalibr camchain of a stereo rig: left and right, each with `T_cam_imu`, and the right's
/// `T_cn_cnm1`; `None` where Kalibr has no model for the cameras' lens.
pub fn kalibr_stereo(rig: &StereoRig) -> Option<String> {
    let cameras = rig
        .cameras()
        .iter()
        .map(KalibrCamera::of)
        .collect::<Option<Vec<KalibrCamera>>>()?;
    let note = match &rig.lens {
        None => String::new(),
        Some(model) => format!(
            "# Kalibr model {} for both cameras (omnisim lens {}); optical frames x right, y down, z forward.\n",
            cameras[0].model_pair(),
            model.name()
        ),
    };
    Some(kalibr_camchain(&note, &cameras, Some(rig.baseline)))
}

/// The Kalibr camchain of one camera, where Kalibr has its model.
pub fn kalibr_camchain_of(camera: &Camera) -> Option<String> {
    match camera {
        Camera::Pinhole(pinhole) => Some(kalibr_pinhole(pinhole)),
        Camera::Lens(lens) => kalibr_lens_camera(lens),
        Camera::Catadioptric(mirror) => kalibr_omni(mirror),
        Camera::Equirectangular(_) | Camera::Cylindrical(_) => None,
    }
}

/// Kalibr camchain of a lens camera (`pinhole-radtan`, `pinhole-equi`, `ds`, `eucm`,
/// `omni-radtan`); `None` where Kalibr has no model for the lens.
pub fn kalibr_lens_camera(camera: &LensCamera) -> Option<String> {
    let kalibr = KalibrCamera::of(&Camera::Lens(Box::new(camera.clone())))?;
    let note = format!(
        "# Kalibr model {} (omnisim lens {}); optical frame x right, y down, z forward.\n",
        kalibr.model_pair(),
        camera.model.name()
    );
    Some(kalibr_camchain(&note, &[kalibr], None))
}

const OMNI_FRAME_NOTE: &str = "# Frames: the unified model's camera frame is the mirror frame M (origin at the viewpoint F',\n\
# +z from the camera towards the mirror) with z reversed: X_model = (x_M, y_M, -z_M). That is a\n\
# reflection, as the mirror is: with positive focal lengths below, u = cx + gx*x/(z + xi*|X|),\n\
# v = cy + gy*y/(z + xi*|X|) for X = X_model. Tools that need a proper rotation can instead use\n\
# R_model_from_M = Rx(pi) (rvec = (pi, 0, 0)) with fy negated, or keep K and flip rows: v' = 2*cy - v.\n\
# body_from_mirror gives M in the robot body frame (x forward, y left, z up): a point at body azimuth\n\
# phi appears at image angle atan2(v - cy, u - cx) = phi with the mirror mounted up, -phi mounted down.\n\
# Pixel centres at integer coordinates. ";

/// What a mirror's calibration file says about the lens of the camera that looks at it.
fn mirror_lens_note(camera: &Catadioptric) -> String {
    match &camera.lens {
        None => "Ideal mirror and lens: no distortion.\n".to_owned(),
        Some(lens) => {
            let parameters: Vec<String> = lens
                .parameters()
                .into_iter()
                .map(|(name, values)| format!("{name} {values:?}"))
                .collect();
            format!(
                "The camera that looks at the mirror has a lens,\n\
                 # {} ({}): the unified model's radtan distortion below expresses it\n\
                 # exactly (the lens's k1 s^2, k2 s^4, p1 s, p2 s for s = gamma/focal).\n",
                lens.name(),
                parameters.join("; ")
            )
        }
    }
}

/// `OpenCV` omnidir YAML (`cv::omnidir)`: `camera_matrix`, distortion (k1 k2 p1 p2 = 0), xi as a
/// real, as `OpenCV`'s own `omni_calibration` sample writes it.
/// `None` for non-central cameras, which no unified model describes (use the ray map).
pub fn opencv_omnidir(camera: &Catadioptric) -> Option<String> {
    let model = camera.unified_model()?;
    let mut out = String::from(HEADER);
    let distortion = camera.unified_distortion()?;
    out += "# omnisim catadioptric camera as Mei's unified model (exact for this aligned central mirror).\n";
    out += OMNI_FRAME_NOTE;
    out += &mirror_lens_note(camera);
    let _ = writeln!(out, "image_width: {}\nimage_height: {}", camera.width, camera.height);
    out += &opencv_matrix(
        "camera_matrix",
        3,
        3,
        &k_matrix(model.gamma_x, model.gamma_y, model.cx, model.cy),
    );
    out += &opencv_matrix("distortion_coefficients", 1, 4, &distortion);
    out += "# xi is a real number (as OpenCV's omni_calibration sample writes it): Python\n\
            # fs.getNode('xi').real(), C++ double xi = fs[\"xi\"]; cv::omnidir takes it as a double.\n";
    let _ = writeln!(out, "xi: {:?}", model.xi);
    out += &opencv_matrix("body_from_mirror", 3, 3, &rows(camera.body_from_mirror()));
    Some(out)
}

/// Kalibr camchain with the `omni` model (intrinsics xi fu fv pu pv) and `T_cam_imu`; `None` if
/// non-central. Kalibr needs positive focal lengths and a proper rotation, and a mirror
/// reverses the image's handedness, so this camchain describes the rendered image flipped top
/// to bottom (row v becomes H−1−v), in the mirror frame turned by Rx(π). The `OpenCV` omnidir
/// file describes the image as rendered, with a reflected frame.
pub fn kalibr_omni(camera: &Catadioptric) -> Option<String> {
    let kalibr = KalibrCamera::of(&Camera::Catadioptric(camera.clone()))?;
    let note = format!(
        "# Kalibr omni model, exact for this aligned central mirror. IMAGE FLIPPED: this camera is the\n\
         # rendered image flipped top to bottom (row v -> {} - v, as cv2.flip(image, 0) does; the EuRoC\n\
         # layout's mav0/cam0 images are stored flipped). A mirror reverses the image's handedness, which\n\
         # no proper rotation with positive focal lengths reproduces; flipped, it is Kalibr's omni model\n\
         # with fu, fv > 0. Frames: the camera frame is the mirror frame M (origin at the viewpoint F',\n\
         # +z from the camera towards the mirror) turned half a turn about x: X_cam = (x_M, -y_M, -z_M).\n\
         # {}",
        camera.height - 1,
        match &camera.lens {
            None => mirror_lens_note(camera),
            Some(_) => mirror_lens_note(camera) + "# Flipped, p1 changes sign.\n",
        }
    );
    Some(kalibr_camchain(&note, &[kalibr], None))
}

const FISHEYE_INTRO: &str = "# omnisim Kannala-Brandt fisheye for cv2.fisheye: cv2.fisheye.projectPoints with camera_matrix and\n\
# distortion_coefficients (k1 k2 k3 k4; theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)) gives\n\
# its pixels for points in front of the camera (cv2.fisheye stops at theta = 90 degrees; this\n\
# lens may reach further: the ray maps hold every pixel's ray). ";

const OMNIDIR_LENS_INTRO: &str = "# omnisim unified (Mei) lens for cv2.omnidir: cv2.omnidir.projectPoints with camera_matrix,\n\
# xi and distortion_coefficients (k1 k2 p1 p2) gives its pixels. xi is a real number: Python\n\
# fs.getNode('xi').real(). ";

/// How `OpenCV` describes a lens: plain `projectPoints`, `cv::fisheye` or `cv::omnidir`.
struct OpenCvLens {
    /// The single camera's file name.
    file: &'static str,
    /// The single camera's file's opening comment.
    intro: &'static str,
    /// What a stereo file's M1, D1 (xi1), M2, D2 (xi2) are for.
    stereo_note: &'static str,
    /// `distortion_coefficients` (D).
    coefficients: Vec<f64>,
    /// `cv::omnidir`'s ξ.
    xi: Option<f64>,
}

/// `OpenCV`'s form of `model`; `None` where `OpenCV` has no model for it.
fn opencv_lens(model: &LensModel) -> Option<OpenCvLens> {
    let fisheye = |coefficients: Vec<f64>| OpenCvLens {
        file: "calibration-opencv-fisheye.yaml",
        intro: FISHEYE_INTRO,
        stereo_note: "M1, D1, M2, D2 are\n# cv2.fisheye's K and D (k1 k2 k3 k4), as cv2.fisheye.stereoCalibrate names them.",
        coefficients,
        xi: None,
    };
    match model {
        LensModel::Perspective(distortion) => Some(OpenCvLens {
            file: "calibration-opencv.yaml",
            intro: PERSPECTIVE_INTRO,
            stereo_note: "M1, D1, M2, D2 are\n# cv2.projectPoints's camera matrix and distortion (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]).",
            coefficients: distortion.coefficients().to_vec(),
            xi: None,
        }),
        LensModel::KannalaBrandt(kb) => Some(fisheye(kb.coefficients().to_vec())),
        LensModel::Equidistant => Some(fisheye(vec![0.0; 4])),
        LensModel::Unified { xi, distortion } => Some(OpenCvLens {
            file: "calibration-opencv-omnidir.yaml",
            intro: OMNIDIR_LENS_INTRO,
            stereo_note: "M1, D1, xi1, M2, D2, xi2\n# are cv2.omnidir's K, D (k1 k2 p1 p2) and xi (reals: fs.getNode('xi1').real()).",
            coefficients: distortion.radtan()?.to_vec(),
            xi: Some(*xi),
        }),
        LensModel::Scaramuzza(_)
        | LensModel::Equisolid
        | LensModel::Stereographic
        | LensModel::Orthographic
        | LensModel::DoubleSphere { .. }
        | LensModel::ExtendedUnified { .. } => None,
    }
}

/// The files of one lens camera that describe it alone, (file name, contents): `OpenCV`
/// (plain distortion, `cv::fisheye`, `cv::omnidir`) where it has the model, `OCamCalib` for
/// Scaramuzza's.
fn lens_camera_files(camera: &LensCamera) -> Vec<(&'static str, String)> {
    let mut files = Vec::new();
    if let Some(form) = opencv_lens(&camera.model) {
        files.push((
            form.file,
            opencv_camera(form.intro, &camera.intrinsics, &form.coefficients, form.xi),
        ));
    }
    if let LensModel::Scaramuzza(model) = &camera.model {
        files.push(("calib_results.txt", ocamcalib::calib_results(camera, model)));
    }
    files
}

/// The calibration files of a lens camera, (file name, contents): `OpenCV` (plain distortion,
/// `cv::fisheye`, `cv::omnidir`), Kalibr and Basalt where they have the model, `OCamCalib` for
/// Scaramuzza's.
pub fn lens_files(camera: &LensCamera) -> Vec<(String, String)> {
    let mut files: Vec<(String, String)> = lens_camera_files(camera)
        .into_iter()
        .map(|(name, text)| (name.to_owned(), text))
        .collect();
    if let Some(kalibr) = kalibr_lens_camera(camera) {
        files.push(("calibration-kalibr.yaml".to_owned(), kalibr));
    }
    if let Some(basalt) = basalt::calibration(&[camera]) {
        files.push(("calibration-basalt.json".to_owned(), basalt));
    }
    files
}

/// The calibration files of a stereo rig, (file name, contents): `OpenCV`'s stereo file (R, T
/// and, where `OpenCV` has the model, both cameras), the Kalibr camchain and Basalt's JSON (where
/// they have the model); with a lens, also each camera's own files, named `…-left` and `…-right`.
pub fn stereo_files(rig: &StereoRig) -> Vec<(String, String)> {
    let mut files = vec![("calibration-opencv-stereo.yaml".to_owned(), opencv_stereo(rig))];
    let cameras = rig.cameras();
    for (camera, side) in cameras.iter().zip(["left", "right"]) {
        if let Camera::Lens(lens) = camera {
            for (name, text) in lens_camera_files(lens) {
                let (stem, extension) = name.rsplit_once('.').unwrap_or((name, ""));
                files.push((format!("{stem}-{side}.{extension}"), text));
            }
        }
    }
    if let Some(kalibr) = kalibr_stereo(rig) {
        files.push(("calibration-kalibr.yaml".to_owned(), kalibr));
    }
    let lenses: Vec<&LensCamera> = cameras
        .iter()
        .filter_map(|camera| match camera {
            Camera::Lens(lens) => Some(&**lens),
            _ => None,
        })
        .collect();
    if let [_, _] = lenses[..]
        && let Some(basalt) = basalt::calibration(&lenses)
    {
        files.push(("calibration-basalt.json".to_owned(), basalt));
    }
    files
}
