//! The one description of a vision system: a serde type with the options of `omnisim render`
//! as typed fields, which `render --rig FILE.ron`, a data-set spec's `rig:` and the files
//! that record a run (`render.json`, `manifest.json`) all hold verbatim, and [`RigSpec::build`],
//! the one place that turns it into a [`Rig`]. The command-line flags map onto it; a camera
//! model added later is added here.

use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{
    BrownConrady, Camera, CameraError, Catadioptric, Cylindrical, Equirectangular, KannalaBrandt, LensCamera,
    LensModel, MirrorRays, MirrorShape, Misalignment, Mount, Pinhole, Rig, Scaramuzza, StereoRig,
};
use crate::input::{InputError, locate, read_text, ron_options, without_bom};

/// The defaults every reader of a [`RigSpec`] shares (the command line, spec files, the
/// vision commands): angles in degrees, lengths in metres, sizes in pixels.
pub mod defaults {
    /// Pinhole and stereo image size.
    pub const PINHOLE_SIZE: (u32, u32) = (640, 480);
    /// Equirectangular panorama size.
    pub const EQUIRECT_SIZE: (u32, u32) = (1024, 512);
    /// Cylindrical panorama size.
    pub const CYLINDRICAL_SIZE: (u32, u32) = (1024, 256);
    /// Omnidirectional image size (the reference paper's).
    pub const OMNI_SIZE: (u32, u32) = (250, 250);
    /// Pinhole horizontal field of view.
    pub const HFOV: f64 = 60.0;
    /// Cylindrical vertical field of view.
    pub const VFOV: f64 = 90.0;
    /// Stereo baseline.
    pub const BASELINE: f64 = 0.12;
    /// Highest elevation an omnidirectional image shows.
    pub const MAX_ELEVATION: f64 = 20.0;
    /// The reference paper's hyperbolic mirror, a.
    pub const HYPERBOLIC_A: f64 = 0.04;
    /// The reference paper's hyperbolic mirror, b.
    pub const HYPERBOLIC_B: f64 = 0.16;
    /// Parabolic mirror a.
    pub const PARABOLIC_A: f64 = 0.04;
    /// Parabolic mirror height h.
    pub const PARABOLIC_H: f64 = 0.02;
    /// Spherical mirror radius.
    pub const SPHERE_RADIUS: f64 = 0.05;
    /// Spherical mirror: sphere centre to pinhole.
    pub const CAMERA_DISTANCE: f64 = 0.25;
    /// Fisheye image size.
    pub const FISHEYE_SIZE: (u32, u32) = (640, 640);
    /// Fisheye image circle's field of view (the circle inscribed in the image), degrees.
    pub const FISHEYE_FOV: f64 = 180.0;
    /// Double sphere ξ and α: a typical 190° lens of Usenko et al.'s data sets.
    pub const DOUBLE_SPHERE: (f64, f64) = (-0.2, 0.6);
    /// EUCM α and β.
    pub const EUCM: (f64, f64) = (0.6, 1.1);
    /// Unified ξ (1: the parabolic mirror's model).
    pub const UNIFIED_XI: f64 = 1.0;

    pub(super) fn hfov() -> f64 {
        HFOV
    }
    pub(super) fn vfov() -> f64 {
        VFOV
    }
    pub(super) fn baseline() -> f64 {
        BASELINE
    }
    #[expect(clippy::unnecessary_wraps, reason = "serde's default of an optional field")]
    pub(super) fn max_elevation() -> Option<f64> {
        Some(MAX_ELEVATION)
    }
    pub(super) fn omni_size() -> (u32, u32) {
        OMNI_SIZE
    }
}

/// The camera or stereo rig, with the options of `omnisim render` as typed fields (angles in
/// degrees, lengths in metres, sizes in pixels).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum RigSpec {
    /// Perspective camera looking along body +x.
    Pinhole(PinholeSpec),
    /// Two pinholes `baseline` apart on body y (left at +y), rectified.
    Stereo(StereoSpec),
    /// Full-sphere equirectangular panorama.
    Equirect {
        /// (width, height), pixels.
        size: (u32, u32),
    },
    /// 360° cylindrical panorama.
    Cylindrical {
        /// (width, height), pixels.
        size: (u32, u32),
        /// Vertical field of view, degrees.
        #[serde(default = "defaults::vfov")]
        vfov: f64,
    },
    /// Catadioptric camera: a camera looking at a mirror.
    Omni(OmniSpec),
    /// A fisheye or other central lens model, looking along body +x.
    Fisheye(FisheyeSpec),
}

/// A fisheye camera's options: the lens and how large its image circle is.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FisheyeSpec {
    /// (width, height), pixels.
    pub size: (u32, u32),
    /// The lens model and its parameters.
    pub lens: LensSpec,
    /// Field of view of the circle inscribed in the image, degrees (sets the focal length);
    /// [`defaults::FISHEYE_FOV`] unless `focal` is given.
    #[serde(default)]
    pub fov: Option<f64>,
    /// Focal length in pixels (square pixels); instead of `fov`.
    #[serde(default)]
    pub focal: Option<f64>,
}

/// A lens model with its parameters (docs/cameras.md gives each one's equations).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum LensSpec {
    /// Kannala–Brandt (`OpenCV` fisheye, Kalibr `pinhole-equi`): `θ_d = θ(1 + k1θ² + … + k4θ⁸)`.
    KannalaBrandt {
        /// k1, k2, k3, k4.
        k: [f64; 4],
    },
    /// r = f·θ.
    Equidistant,
    /// r = 2f·sin(θ/2).
    Equisolid,
    /// r = 2f·tan(θ/2).
    Stereographic,
    /// r = f·sin θ.
    Orthographic,
    /// Double sphere (Usenko et al. 2018).
    DoubleSphere {
        /// ξ, −1 to 1.
        xi: f64,
        /// α, 0 to 1.
        alpha: f64,
    },
    /// Extended unified (Khomenko et al. 2016).
    Eucm {
        /// α, 0 to 1.
        alpha: f64,
        /// β > 0.
        beta: f64,
    },
    /// Mei's unified model with radtan distortion (Kalibr `omni-radtan`, `cv::omnidir`).
    Unified {
        /// ξ ≥ 0.
        xi: f64,
        /// k1, k2, p1, p2.
        #[serde(default)]
        distortion: [f64; 4],
    },
    /// Scaramuzza's polynomial (`OCamCalib`): its own focal length, so `fov` and `focal` do
    /// not apply.
    Scaramuzza {
        /// a0, a1, … of the direct polynomial (`OCamCalib`'s ss; a0 < 0), pixels.
        poly: Vec<f64>,
        /// The affine c, d, e.
        #[serde(default = "identity_affine")]
        affine: (f64, f64, f64),
    },
}

fn identity_affine() -> (f64, f64, f64) {
    (1.0, 0.0, 0.0)
}

impl LensSpec {
    /// The model these parameters describe; `reach` is the largest pixel distance from the
    /// image centre (where Scaramuzza's valid radius is looked for).
    fn model(&self, reach: f64) -> Result<LensModel, CameraError> {
        let model = match self {
            LensSpec::KannalaBrandt { k } => LensModel::KannalaBrandt(KannalaBrandt::new(*k)?),
            LensSpec::Equidistant => LensModel::Equidistant,
            LensSpec::Equisolid => LensModel::Equisolid,
            LensSpec::Stereographic => LensModel::Stereographic,
            LensSpec::Orthographic => LensModel::Orthographic,
            LensSpec::DoubleSphere { xi, alpha } => LensModel::DoubleSphere { xi: *xi, alpha: *alpha },
            LensSpec::Eucm { alpha, beta } => LensModel::ExtendedUnified {
                alpha: *alpha,
                beta: *beta,
            },
            LensSpec::Unified { xi, distortion } => LensModel::Unified {
                xi: *xi,
                distortion: BrownConrady::new(distortion)?,
            },
            LensSpec::Scaramuzza { poly, affine } => LensModel::Scaramuzza(Scaramuzza::new(poly, *affine, reach)?),
        };
        model.check()?;
        Ok(model)
    }
}

/// A pinhole's options.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PinholeSpec {
    /// (width, height), pixels.
    pub size: (u32, u32),
    /// Horizontal field of view, degrees (square pixels, centred principal point).
    #[serde(default = "defaults::hfov")]
    pub hfov: f64,
    /// Focal length in pixels; overrides `hfov`.
    #[serde(default)]
    pub focal: Option<f64>,
    /// Brown–Conrady distortion in `OpenCV`'s order: k1 k2 p1 p2 (radtan; + k3), + k4 k5 k6
    /// (rational), + s1 s2 s3 s4 (thin prism): 4, 5, 8 or 12 numbers. `hfov` and `focal`
    /// give K, as without distortion.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distortion: Option<Vec<f64>>,
}

/// A stereo rig's options.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StereoSpec {
    /// (width, height) of each image, pixels.
    pub size: (u32, u32),
    /// Horizontal field of view, degrees.
    #[serde(default = "defaults::hfov")]
    pub hfov: f64,
    /// Focal length in pixels; overrides `hfov`.
    #[serde(default)]
    pub focal: Option<f64>,
    /// Distance between the optical centres, metres.
    #[serde(default = "defaults::baseline")]
    pub baseline: f64,
    /// Brown–Conrady distortion of both cameras, as [`PinholeSpec::distortion`] (`hfov` and
    /// `focal` give K). A pair with distortion writes no disparity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distortion: Option<Vec<f64>>,
    /// A fisheye or other central lens on both cameras, instead of pinholes: `fov` or `focal`
    /// give its focal length as [`FisheyeSpec`]'s do, and `hfov` does not apply. A pair with a
    /// lens writes no disparity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lens: Option<LensSpec>,
    /// With `lens`: the field of view of the circle inscribed in each image, degrees
    /// ([`defaults::FISHEYE_FOV`] unless `focal` is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov: Option<f64>,
}

/// A catadioptric camera's options (README, "Omnidirectional options").
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OmniSpec {
    /// (width, height), pixels.
    #[serde(default = "defaults::omni_size")]
    pub size: (u32, u32),
    /// The mirror.
    #[serde(default)]
    pub mirror: MirrorSpec,
    /// Highest elevation the rim shows, degrees; `None`: a hyperbolic mirror up to its asymptote.
    #[serde(default = "defaults::max_elevation")]
    pub max_elevation: Option<f64>,
    /// Rim radius, metres (instead of `max_elevation`).
    #[serde(default)]
    pub rim: Option<f64>,
    /// Focal length, pixels (pixels per metre for the parabolic mirror); overrides the fit.
    #[serde(default)]
    pub focal: Option<f64>,
    /// Mirror above (`Up`) or below (`Down`) the camera.
    #[serde(default)]
    pub mount: MountSpec,
    /// Radius in pixels hidden by the camera's own body at the image centre.
    #[serde(default)]
    pub hidden_centre: f64,
    /// Camera displaced from its nominal place, metres (mirror frame).
    #[serde(default)]
    pub misalign_offset: (f64, f64, f64),
    /// Camera axes tilted, degrees (R = Rx·Ry·Rz).
    #[serde(default)]
    pub misalign_tilt: (f64, f64, f64),
    /// How mirror rays are found, as `render --mirror-rays`.
    #[serde(default)]
    pub mirror_rays: MirrorRaysSpec,
    /// Brown–Conrady distortion of the camera that looks at the mirror (hyperbolic and
    /// spherical mirrors), as [`PinholeSpec::distortion`]; its K is the mirror fit's (or
    /// `focal`). `None`: the reference paper's ideal pinhole.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distortion: Option<Vec<f64>>,
    /// Or any central lens model on that camera (not scaramuzza, whose polynomial sets its own
    /// scale), with the same K.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lens: Option<LensSpec>,
}

/// How an omnidirectional camera's mirror rays are found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum MirrorRaysSpec {
    /// The law of reflection at the mirror: exact for every mirror and misalignment.
    #[default]
    Reflect,
    /// The reference paper's rays from the viewpoint F' through the mirror point (aligned
    /// central mirrors only).
    Shortcut,
}

/// The mirror of an omnidirectional camera, metres.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum MirrorSpec {
    /// (x²+y²)/a² − z²/b² = −1.
    Hyperbolic {
        /// a, metres.
        a: f64,
        /// b, metres.
        b: f64,
    },
    /// z = h·(x²/a² + y²/b²); b = a unless given.
    Parabolic {
        /// a, metres.
        a: f64,
        /// b, metres (a ≠ b is non-central).
        #[serde(default)]
        b: Option<f64>,
        /// h, metres.
        h: f64,
    },
    /// A sphere seen from a pinhole.
    Spherical {
        /// Sphere radius, metres.
        radius: f64,
        /// Sphere centre to pinhole, metres.
        camera_distance: f64,
    },
}

impl Default for MirrorSpec {
    /// The reference paper's mirror.
    fn default() -> Self {
        MirrorSpec::Hyperbolic {
            a: defaults::HYPERBOLIC_A,
            b: defaults::HYPERBOLIC_B,
        }
    }
}

/// Which way the mirror axis points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize, Serialize)]
pub enum MountSpec {
    /// Mirror axis along body +z.
    #[default]
    Up,
    /// Mirror axis along body −z.
    Down,
}

impl Default for OmniSpec {
    /// The reference paper's camera: its mirror, 250 × 250, the rim at 20° above the horizon.
    fn default() -> Self {
        Self {
            size: defaults::OMNI_SIZE,
            mirror: MirrorSpec::default(),
            max_elevation: defaults::max_elevation(),
            rim: None,
            focal: None,
            mount: MountSpec::default(),
            hidden_centre: 0.0,
            misalign_offset: (0.0, 0.0, 0.0),
            misalign_tilt: (0.0, 0.0, 0.0),
            mirror_rays: MirrorRaysSpec::default(),
            distortion: None,
            lens: None,
        }
    }
}

/// Why a [`RigSpec`] describes no camera; each message names the field and its valid range.
#[derive(Debug, thiserror::Error)]
pub enum RigSpecError {
    /// A field of view outside (0°, 180°).
    #[error("{field} must be between 0 and 180 degrees (exclusive), not {}", crate::input::shown_number(*degrees))]
    FieldOfView {
        /// `hfov` or `vfov`.
        field: &'static str,
        /// What was given.
        degrees: f64,
    },
    /// A hyperbolic mirror's rim placed at or above its asymptote.
    #[error(
        "max_elevation {asked:.2}° is beyond what this mirror can see: at most {limit:.2}° (asin(b/c)); use less, or none"
    )]
    BeyondAsymptote {
        /// What was asked, degrees.
        asked: f64,
        /// The asymptote's elevation, degrees.
        limit: f64,
    },
    /// A paraboloid without `max_elevation` or `rim`.
    #[error("a paraboloid has no asymptote: give max_elevation in degrees or rim")]
    ParaboloidWithoutRim,
    /// The camera the fields describe cannot make an image.
    #[error("the camera cannot make an image: {0}")]
    Camera(#[from] CameraError),
    /// A fisheye's image circle wider than its lens sees.
    #[error(
        "fov {asked}° is beyond what the {lens} lens sees: give fov between 0 and {limit:.2} degrees (twice its {half:.2}° off axis), or focal"
    )]
    LensFieldOfView {
        /// What was asked, degrees.
        asked: f64,
        /// The lens model.
        lens: &'static str,
        /// The widest circle, degrees.
        limit: f64,
        /// Its half-angle, degrees.
        half: f64,
    },
    /// `fov` or `focal` given to a lens whose polynomial fixes its scale.
    #[error("fov and focal do not apply to the scaramuzza lens: its polynomial (poly, in pixels) sets the scale")]
    ScaleOfScaramuzza,
    /// A rig's field that does not apply to the cameras it describes.
    #[error("{rig} {field} does not apply {why}")]
    FieldDoesNotApply {
        /// `stereo` or `omni`.
        rig: &'static str,
        /// The field given.
        field: &'static str,
        /// Why, and what to give instead.
        why: &'static str,
    },
}

/// Why a rig file (`render --rig FILE.ron`) was not read.
#[derive(Debug, thiserror::Error)]
pub enum RigFileError {
    /// Not a readable regular file of at most [`RIG_FILE_LIMIT`] bytes.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Not a rig in RON.
    #[error(
        "{}:{line}:{column}: {message}; the file holds one rig as a data-set spec's `rig:` does, e.g. \
         Omni(size: (250, 250), mirror: Hyperbolic(a: 0.04, b: 0.16))",
        path.display()
    )]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// What is wrong, with the field it falls in.
        message: String,
    },
}

/// Largest rig file read: a rig is a few lines.
pub const RIG_FILE_LIMIT: u64 = 1 << 20;

impl RigSpec {
    /// Reads a rig written in RON, as a data-set spec's `rig:` field holds it.
    pub fn load(path: &Path) -> Result<Self, RigFileError> {
        let text = read_text(path, RIG_FILE_LIMIT)?;
        let text = without_bom(&text);
        ron_options().from_str(text).map_err(|e| {
            let field = locate::field_of_error(text, &e)
                .map(|field| format!("{field}: "))
                .unwrap_or_default();
            RigFileError::Parse {
                path: path.to_path_buf(),
                line: e.span.start.line,
                column: e.span.start.col,
                message: format!("{field}{}", e.code),
            }
        })
    }

    /// The camera or rig this describes, checked by `validate` (what `Renderer::render`
    /// would refuse is refused here, with the same message).
    pub fn build(&self) -> Result<Rig, RigSpecError> {
        let rig =
            match self {
                RigSpec::Pinhole(p) => Rig::Single(Camera::with_lens(
                    pinhole(p.size, p.hfov, p.focal)?,
                    perspective_lens(p.distortion.as_deref())?,
                )),
                RigSpec::Stereo(s) => Rig::Stereo(s.build()?),
                RigSpec::Equirect { size } => Rig::Single(Camera::Equirectangular(Equirectangular {
                    width: size.0,
                    height: size.1,
                })),
                RigSpec::Cylindrical { size, vfov } => Rig::Single(Camera::Cylindrical(
                    Cylindrical::with_vertical_fov(size.0, size.1, field_of_view("vfov", *vfov)?),
                )),
                RigSpec::Omni(o) => Rig::Single(Camera::Catadioptric(o.build()?)),
                RigSpec::Fisheye(f) => Rig::Single(Camera::Lens(Box::new(f.build()?))),
            };
        match &rig {
            Rig::Single(camera) => camera.validate(),
            Rig::Stereo(stereo) => stereo.validate(),
        }?;
        Ok(rig)
    }
}

/// `degrees` in radians, if strictly between 0° and 180°.
fn field_of_view(field: &'static str, degrees: f64) -> Result<f64, RigSpecError> {
    if degrees > 0.0 && degrees < 180.0 {
        Ok(degrees.to_radians())
    } else {
        Err(RigSpecError::FieldOfView { field, degrees })
    }
}

/// A pinhole of `size` with square pixels: `focal` pixels, or the focal that gives `hfov`.
fn pinhole((width, height): (u32, u32), hfov: f64, focal: Option<f64>) -> Result<Pinhole, RigSpecError> {
    let mut camera = Pinhole::with_horizontal_fov(width, height, field_of_view("hfov", hfov)?);
    if let Some(f) = focal {
        (camera.fx, camera.fy) = (f, f);
    }
    Ok(camera)
}

/// The lens of a pinhole with `distortion` (Brown–Conrady coefficients); `None` without.
fn perspective_lens(distortion: Option<&[f64]>) -> Result<Option<LensModel>, RigSpecError> {
    Ok(distortion
        .map(BrownConrady::new)
        .transpose()?
        .map(LensModel::Perspective))
}

impl StereoSpec {
    /// The pair: both cameras built as one [`PinholeSpec`] (with `distortion`) or one
    /// [`FisheyeSpec`] (with `lens`) would be, `baseline` apart.
    fn build(&self) -> Result<StereoRig, RigSpecError> {
        let refuse = |field, why| {
            Err(RigSpecError::FieldDoesNotApply {
                rig: "stereo",
                field,
                why,
            })
        };
        let (camera, lens) = match &self.lens {
            None if self.fov.is_some() => {
                return refuse(
                    "fov",
                    "to pinholes: it is a lens's image circle; give hfov or focal, or a lens",
                );
            }
            None => (
                pinhole(self.size, self.hfov, self.focal)?,
                perspective_lens(self.distortion.as_deref())?,
            ),
            Some(_) if self.distortion.is_some() => {
                return refuse(
                    "distortion",
                    "with a lens: give a pinhole's distortion or a fisheye lens, not both",
                );
            }
            Some(_) if self.hfov != defaults::HFOV => {
                return refuse(
                    "hfov",
                    "to a lens: give fov (the image circle's field of view) or focal",
                );
            }
            Some(lens) => {
                let eye = FisheyeSpec {
                    size: self.size,
                    lens: lens.clone(),
                    fov: self.fov,
                    focal: self.focal,
                }
                .build()?;
                (eye.intrinsics, Some(eye.model))
            }
        };
        Ok(StereoRig {
            camera,
            lens,
            baseline: self.baseline,
        })
    }
}

impl FisheyeSpec {
    /// The lens camera: principal point at the image centre, square pixels, the focal length
    /// that puts `fov` on the inscribed circle (or `focal`).
    fn build(&self) -> Result<LensCamera, RigSpecError> {
        let (width, height) = self.size;
        let (cx, cy) = ((f64::from(width) - 1.0) / 2.0, (f64::from(height) - 1.0) / 2.0);
        let reach = cx.hypot(cy) + 1.0;
        let model = self.lens.model(reach)?;
        let focal = match (&self.lens, self.focal, self.fov) {
            (LensSpec::Scaramuzza { .. }, None, None) => 1.0,
            (LensSpec::Scaramuzza { .. }, ..) => return Err(RigSpecError::ScaleOfScaramuzza),
            (_, Some(focal), _) => focal,
            (_, None, fov) => {
                let asked = fov.unwrap_or(defaults::FISHEYE_FOV);
                let half = model.max_angle();
                let limit = 2.0 * half.to_degrees();
                let radius = (asked > 0.0 && asked <= limit)
                    .then(|| model.radius_at((asked / 2.0).to_radians()))
                    .flatten()
                    .filter(|r| *r > 0.0 && r.is_finite());
                let Some(radius) = radius else {
                    return Err(RigSpecError::LensFieldOfView {
                        asked,
                        lens: model.name(),
                        limit,
                        half: half.to_degrees(),
                    });
                };
                f64::from(width.min(height)) / 2.0 / radius
            }
        };
        Ok(LensCamera {
            intrinsics: Pinhole {
                position: DVec3::ZERO,
                width,
                height,
                fx: focal,
                fy: focal,
                cx,
                cy,
            },
            model,
        })
    }
}

impl OmniSpec {
    /// The catadioptric camera: the mirror, its rim fitted to the image (or placed by hand),
    /// then mount, hidden centre, misalignment and ray model.
    fn build(&self) -> Result<Catadioptric, RigSpecError> {
        let (w, h) = self.size;
        let elevation = if self.rim.is_some() {
            None
        } else {
            self.max_elevation.map(f64::to_radians)
        };
        let mut camera = match self.mirror {
            MirrorSpec::Hyperbolic { a, b } => {
                let camera = Catadioptric::hyperbolic(w, h, a, b, elevation);
                if let Some(e) = elevation
                    && e >= camera.asymptote_elevation()
                {
                    return Err(RigSpecError::BeyondAsymptote {
                        asked: e.to_degrees(),
                        limit: camera.asymptote_elevation().to_degrees(),
                    });
                }
                camera
            }
            MirrorSpec::Parabolic { a, b, h: height } => {
                let elevation = match (elevation, self.rim) {
                    (Some(e), _) => e,
                    (None, Some(_)) => 0.0,
                    (None, None) => return Err(RigSpecError::ParaboloidWithoutRim),
                };
                let mut camera = Catadioptric::parabolic(w, h, a, height, elevation);
                camera.mirror = MirrorShape::Parabolic {
                    a,
                    b: b.unwrap_or(a),
                    h: height,
                };
                camera
            }
            MirrorSpec::Spherical {
                radius,
                camera_distance,
            } => Catadioptric::spherical(w, h, radius, camera_distance),
        };
        if self.rim.is_some() {
            camera.rim_radius = self.rim;
        }
        if let Some(f) = self.focal {
            camera.focal = f;
        }
        camera.mount = match self.mount {
            MountSpec::Up => Mount::Up,
            MountSpec::Down => Mount::Down,
        };
        camera.hidden_centre_px = self.hidden_centre;
        camera.misalignment = Misalignment {
            offset: self.misalign_offset.into(),
            tilt: DVec3::from(self.misalign_tilt) * (std::f64::consts::PI / 180.0),
        };
        camera.rays = match self.mirror_rays {
            MirrorRaysSpec::Reflect => MirrorRays::Reflect,
            MirrorRaysSpec::Shortcut => MirrorRays::Shortcut,
        };
        camera.lens = match (&self.lens, &self.distortion) {
            (Some(_), Some(_)) => {
                return Err(RigSpecError::FieldDoesNotApply {
                    rig: "omni",
                    field: "distortion",
                    why: "with a lens: give the mirror's camera a pinhole's distortion or a lens, not both",
                });
            }
            (Some(lens), None) => Some(lens.model(f64::from(w).hypot(f64::from(h)))?),
            (None, distortion) => perspective_lens(distortion.as_deref())?,
        }
        .map(Box::new);
        camera.check_rays()?;
        Ok(camera)
    }
}
