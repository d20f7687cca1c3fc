//! Camera options shared by `render`, `bench` and the vision commands, mapped onto the one rig
//! description ([`RigSpec`]) that data-set specs and `render --rig` files hold too.

use std::path::PathBuf;

use anyhow::bail;
use clap::{Args, ValueEnum};
use glam::{DVec3, dvec3};
use omnisim::Rig;
use omnisim::camera::spec::defaults;
use omnisim::camera::{
    FisheyeSpec, LensSpec, MirrorRaysSpec, MirrorSpec, MountSpec, OmniSpec, PinholeSpec, RigSpec, StereoSpec,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum CameraKind {
    /// Perspective camera looking along body +x (OpenCV optical frame).
    Pinhole,
    /// Two cameras --baseline apart on body y (left at +y): rectified pinholes with ground-truth
    /// disparity, or both with --distortion or a --lens (then no disparity: each camera's
    /// calibration and the extrinsics R, T describe the pair).
    Stereo,
    /// Full-sphere equirectangular panorama.
    Equirect,
    /// 360° cylindrical panorama (--vfov).
    Cylindrical,
    /// Catadioptric omnidirectional camera: a camera looking at a --mirror (the ideal pinhole, or
    /// with --distortion or a --lens).
    Omni,
    /// Fisheye or other central lens (--lens), looking along body +x; pixels beyond the lens's
    /// field of view are background, and render says how many.
    Fisheye,
}

/// `--lens`: the fisheye's model (docs/cameras.md gives the equations and sources).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum LensKind {
    /// OpenCV fisheye / Kalibr pinhole-equi: θd = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸), r = f·θd (--k); past 90° where θd still rises.
    KannalaBrandt,
    /// r = f·θ, to 180° off axis.
    Equidistant,
    /// r = 2f·sin(θ/2), to 180° off axis.
    Equisolid,
    /// r = 2f·tan(θ/2), below 180° off axis.
    Stereographic,
    /// r = f·sin θ, a hemisphere.
    Orthographic,
    /// Double sphere (Usenko et al. 2018; Kalibr ds): --xi in [-1, 1], --alpha in [0, 1).
    DoubleSphere,
    /// Extended unified (Khomenko et al. 2016; Kalibr eucm): --alpha in [0, 1), --beta > 0.
    Eucm,
    /// Mei's unified model with radtan (Kalibr omni-radtan, cv::omnidir): --xi ≥ 0, --dist k1,k2,p1,p2.
    Unified,
    /// Scaramuzza's OCamCalib polynomial: --poly a0,a1,... (pixels, a0 < 0), --affine c,d,e; writes calib_results.txt.
    Scaramuzza,
}

/// `--distortion`: Brown–Conrady distortion on the pinhole, exactly as OpenCV's projectPoints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum DistortionKind {
    /// --dist k1,k2,p1,p2[,k3] (Kalibr pinhole-radtan with four).
    Radtan,
    /// --dist k1,k2,p1,p2,k3,k4,k5,k6: radial (1 + k1r² + k2r⁴ + k3r⁶)/(1 + k4r² + k5r⁴ + k6r⁶).
    Rational,
    /// --dist k1,k2,p1,p2,k3,k4,k5,k6,s1,s2,s3,s4: rational plus thin prism.
    ThinPrism,
}

impl DistortionKind {
    /// How many coefficients `--dist` takes.
    fn counts(self) -> &'static [usize] {
        match self {
            DistortionKind::Radtan => &[4, 5],
            DistortionKind::Rational => &[8],
            DistortionKind::ThinPrism => &[12],
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum MirrorKind {
    /// (x²+y²)/a² − z²/b² = −1, pinhole at the outer focus (central).
    Hyperbolic,
    /// z = h·(x²/a² + y²/b²), orthographic camera (central when a = b).
    Parabolic,
    /// Sphere of --sphere-radius, pinhole --camera-distance from its centre (non-central).
    Spherical,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum MountArg {
    /// Mirror above the camera: mirror axis along body +z.
    Up,
    /// Mirror below the camera: mirror axis along body −z.
    Down,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum MirrorRaysArg {
    /// Law of reflection at the mirror surface: exact for every mirror and misalignment.
    Reflect,
    /// The reference paper's rays from the viewpoint F' through the mirror point (aligned central mirrors only).
    Shortcut,
}

#[derive(Debug, Clone, PartialEq, Args)]
pub(crate) struct CameraArgs {
    /// The camera or stereo rig from a RON file, written as a data-set spec's rig: field
    /// (README, "Data sets"), e.g. Omni(size: (250, 250), mirror: Hyperbolic(a: 0.04, b: 0.16)),
    /// instead of the camera options below. render.json records the rig either way.
    #[arg(long, value_name = "FILE.ron", conflicts_with_all = [
        "camera", "size", "hfov", "baseline", "vfov", "focal", "mirror", "mirror_a", "mirror_b", "mirror_h",
        "sphere_radius", "camera_distance", "rim", "max_elevation", "mount", "hidden_centre",
        "misalign_offset", "misalign_tilt", "mirror_rays", "lens", "fov", "k", "xi", "alpha", "beta", "poly",
        "affine", "distortion", "dist",
    ])]
    pub rig: Option<PathBuf>,
    /// Vision system to simulate. Options that do not apply to it are refused, and so is a
    /// camera that cannot make an image (the message gives the valid range).
    #[arg(long, value_enum, default_value = "omni")]
    pub camera: CameraKind,
    /// Image size WIDTHxHEIGHT in pixels [default: pinhole/stereo 640x480, equirect 1024x512, cylindrical 1024x256, omni 250x250, fisheye 640x640].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Pinhole/stereo: horizontal field of view in degrees (square pixels, centred principal
    /// point) [default: 60]; or give --focal.
    #[arg(long, conflicts_with = "focal")]
    pub hfov: Option<f64>,
    /// Stereo: distance between the two optical centres, metres [default: 0.12].
    #[arg(long)]
    pub baseline: Option<f64>,
    /// Cylindrical: vertical field of view in degrees, symmetric about the horizon [default: 90].
    #[arg(long)]
    pub vfov: Option<f64>,
    /// Focal length in pixels (pinhole, stereo, hyperbolic, spherical, fisheye) or pixels per
    /// metre (parabolic); instead of --hfov or --fov, and overrides the omni fit.
    #[arg(long)]
    pub focal: Option<f64>,
    /// Omni: mirror shape [default: hyperbolic].
    #[arg(long, value_enum)]
    pub mirror: Option<MirrorKind>,
    /// Omni: mirror parameter a in metres [default: hyperbolic 0.04 (the paper's 40 mm), parabolic 0.04].
    #[arg(long)]
    pub mirror_a: Option<f64>,
    /// Omni: mirror parameter b in metres [default: hyperbolic 0.16 (the paper's 160 mm); parabolic = a].
    #[arg(long)]
    pub mirror_b: Option<f64>,
    /// Omni, parabolic: height h in z = h·(x²/a² + y²/b²), metres [default: 0.02].
    #[arg(long)]
    pub mirror_h: Option<f64>,
    /// Omni, spherical: sphere radius in metres [default: 0.05].
    #[arg(long)]
    pub sphere_radius: Option<f64>,
    /// Omni, spherical: distance from the sphere's centre to the pinhole in metres [default: 0.25].
    #[arg(long)]
    pub camera_distance: Option<f64>,
    /// Omni: radius of the mirror rim in metres [default: where the mirror sees --max-elevation].
    #[arg(long, conflicts_with = "max_elevation")]
    pub rim: Option<f64>,
    /// Omni (hyperbolic, parabolic): highest elevation above the mirror's horizon shown, in
    /// degrees; places the rim there and fits it to the image. "none" (hyperbolic): the mirror
    /// reaches its asymptote, asin(b/c).
    /// [default: 20]
    #[arg(long, value_parser = parse_elevation)]
    pub max_elevation: Option<MaxElevation>,
    /// Omni: which way the mirror axis points in the body frame [default: up].
    #[arg(long, value_enum)]
    pub mount: Option<MountArg>,
    /// Omni: radius in pixels of the image centre hidden by the camera's own body [default: 0].
    #[arg(long)]
    pub hidden_centre: Option<f64>,
    /// Omni: camera displaced from its nominal place by x,y,z metres (mirror frame); the image
    /// becomes non-central and is still traced exactly.
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub misalign_offset: Option<DVec3>,
    /// Omni: camera axes tilted by θx,θy,θz degrees (R = Rx·Ry·Rz).
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub misalign_tilt: Option<DVec3>,
    /// Omni: how mirror rays are found [default: reflect].
    #[arg(long, value_enum)]
    pub mirror_rays: Option<MirrorRaysArg>,
    /// Fisheye [default: equidistant], stereo (both cameras) and omni (the camera that looks at a
    /// hyperbolic or spherical mirror; not scaramuzza): the lens model. Every model is traced exactly to the
    /// edge of its valid field of view (past 180° where it reaches), and writes the calibration
    /// files its tools read (OpenCV fisheye/omnidir, Kalibr, OCamCalib).
    #[arg(long, value_enum)]
    pub lens: Option<LensKind>,
    /// Fisheye and stereo --lens: field of view of the circle inscribed in the image, degrees:
    /// sets the focal length [default: 180]; or give --focal.
    #[arg(long, conflicts_with = "focal")]
    pub fov: Option<f64>,
    /// Fisheye kannala-brandt: k1,k2,k3,k4 [default: 0,0,0,0, the equidistant lens].
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    pub k: Option<Numbers>,
    /// Fisheye double-sphere [default: -0.2] and unified [default: 1]: ξ.
    #[arg(long, allow_hyphen_values = true)]
    pub xi: Option<f64>,
    /// Fisheye double-sphere and eucm: α [default: 0.6].
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Fisheye eucm: β [default: 1.1].
    #[arg(long)]
    pub beta: Option<f64>,
    /// Fisheye scaramuzza: OCamCalib's direct polynomial a0,a1,a2,... in pixels (a0 < 0), as
    /// the first numbers of calib_results.txt.
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    pub poly: Option<Numbers>,
    /// Fisheye scaramuzza: OCamCalib's affine c,d,e [default: 1,0,0].
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    pub affine: Option<Numbers>,
    /// Pinhole, stereo (both cameras) and omni (the camera that looks at a hyperbolic or
    /// spherical mirror): Brown–Conrady lens distortion; give its coefficients with --dist.
    #[arg(long, value_enum, requires = "dist")]
    pub distortion: Option<DistortionKind>,
    /// Pinhole and stereo --distortion, or the unified lens: distortion coefficients in OpenCV's order,
    /// k1,k2,p1,p2[,k3[,k4,k5,k6[,s1,s2,s3,s4]]] (unified: k1,k2,p1,p2).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    pub dist: Option<Numbers>,
}

/// A list of numbers given as one comma-separated argument (clap would take a bare `Vec`
/// as an option given many times).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Numbers(pub Vec<f64>);

/// Comma-separated finite numbers.
fn parse_numbers(text: &str) -> Result<Numbers, String> {
    text.split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<Vec<f64>>>()
        .map(Numbers)
        .ok_or_else(|| format!("'{text}' is not comma-separated numbers, e.g. 0.1,-0.02,0.001,0"))
}

/// `--max-elevation`: degrees, or `None` for a mirror without rim.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MaxElevation(pub Option<f64>);

fn parse_elevation(text: &str) -> Result<MaxElevation, String> {
    if text == "none" {
        return Ok(MaxElevation(None));
    }
    text.parse::<f64>()
        .ok()
        .filter(|d| d.is_finite() && *d > -90.0 && *d < 90.0)
        .map(|d| MaxElevation(Some(d)))
        .ok_or_else(|| format!("'{text}' is not an elevation in degrees between -90 and 90, or 'none'"))
}

fn parse_vector(text: &str) -> Result<DVec3, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("'{text}' is not three comma-separated numbers"))?;
    match values[..] {
        [x, y, z] => Ok(dvec3(x, y, z)),
        _ => Err(format!("'{text}' has {} numbers; give x,y,z", values.len())),
    }
}

pub(crate) fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT, e.g. 640x480"))?;
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&n| (1..=32768).contains(&n));
    match (parse(w), parse(h)) {
        // The pixel count (at most 100 megapixels) is the library's check, `Camera::validate`.
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!(
            "'{text}': width and height must be whole numbers from 1 to 32768"
        )),
    }
}

/// Options given that the chosen camera does not use: ignoring them silently would render
/// something other than what was asked for.
fn check_applicable(args: &CameraArgs) -> anyhow::Result<()> {
    use CameraKind::{Cylindrical, Fisheye, Omni, Pinhole, Stereo};
    let omni = args.camera == Omni;
    let stereo = args.camera == Stereo;
    // A camera with a lens model: the fisheye, or a stereo pair or a mirror's camera given --lens.
    let fisheye = args.camera == Fisheye || ((stereo || omni) && args.lens.is_some());
    let lens = |kinds: &[LensKind]| fisheye && kinds.contains(&args.lens.unwrap_or(LensKind::Equidistant));
    let mirror = args.mirror.unwrap_or(MirrorKind::Hyperbolic);
    let pinhole = args.camera == Pinhole || (stereo && !fisheye);
    let spherical = mirror == MirrorKind::Spherical;
    let options = [
        ("--hfov", args.hfov.is_some(), pinhole),
        ("--baseline", args.baseline.is_some(), stereo),
        ("--vfov", args.vfov.is_some(), args.camera == Cylindrical),
        (
            "--focal",
            args.focal.is_some(),
            pinhole || omni || (fisheye && !lens(&[LensKind::Scaramuzza])),
        ),
        ("--mirror", args.mirror.is_some(), omni),
        ("--mirror-a", args.mirror_a.is_some(), omni && !spherical),
        ("--mirror-b", args.mirror_b.is_some(), omni && !spherical),
        (
            "--mirror-h",
            args.mirror_h.is_some(),
            omni && mirror == MirrorKind::Parabolic,
        ),
        ("--sphere-radius", args.sphere_radius.is_some(), omni && spherical),
        ("--camera-distance", args.camera_distance.is_some(), omni && spherical),
        ("--rim", args.rim.is_some(), omni),
        ("--max-elevation", args.max_elevation.is_some(), omni && !spherical),
        ("--mount", args.mount.is_some(), omni),
        ("--hidden-centre", args.hidden_centre.is_some(), omni),
        ("--misalign-offset", args.misalign_offset.is_some(), omni),
        ("--misalign-tilt", args.misalign_tilt.is_some(), omni),
        ("--mirror-rays", args.mirror_rays.is_some(), omni),
        ("--lens", args.lens.is_some(), fisheye),
        (
            "--fov",
            args.fov.is_some(),
            fisheye && !omni && !lens(&[LensKind::Scaramuzza]),
        ),
        ("--k", args.k.is_some(), lens(&[LensKind::KannalaBrandt])),
        (
            "--xi",
            args.xi.is_some(),
            lens(&[LensKind::DoubleSphere, LensKind::Unified]),
        ),
        (
            "--alpha",
            args.alpha.is_some(),
            lens(&[LensKind::DoubleSphere, LensKind::Eucm]),
        ),
        ("--beta", args.beta.is_some(), lens(&[LensKind::Eucm])),
        ("--poly", args.poly.is_some(), lens(&[LensKind::Scaramuzza])),
        ("--affine", args.affine.is_some(), lens(&[LensKind::Scaramuzza])),
        ("--distortion", args.distortion.is_some(), pinhole || (omni && !fisheye)),
        (
            "--dist",
            args.dist.is_some(),
            args.distortion.is_some() || lens(&[LensKind::Unified]),
        ),
    ];
    if let Some((option, ..)) = options.iter().find(|(_, given, applies)| *given && !applies) {
        let name =
            |value: Option<clap::builder::PossibleValue>| value.map(|v| v.get_name().to_owned()).unwrap_or_default();
        let mut camera = name(args.camera.to_possible_value());
        if omni {
            camera += &format!(" --mirror {}", name(mirror.to_possible_value()));
        }
        if fisheye {
            camera += &format!(
                " --lens {}",
                name(args.lens.unwrap_or(LensKind::Equidistant).to_possible_value())
            );
        }
        bail!("{option} does not apply to --camera {camera}; remove it (see omnisim render --help)");
    }
    Ok(())
}

impl CameraArgs {
    /// The rig these options describe, as the one description every command shares: each
    /// option given, the [`defaults`] for the rest.
    pub(crate) fn spec(&self) -> anyhow::Result<RigSpec> {
        if let Some(path) = &self.rig {
            return Ok(RigSpec::load(path)?);
        }
        check_applicable(self)?;
        self.warn_about_radians()?;
        let size = self.size.unwrap_or(defaults::PINHOLE_SIZE);
        let hfov = self.hfov.unwrap_or(defaults::HFOV);
        Ok(match self.camera {
            CameraKind::Pinhole => RigSpec::Pinhole(PinholeSpec {
                size,
                hfov,
                focal: self.focal,
                distortion: self.distortion_coefficients()?,
            }),
            CameraKind::Stereo => RigSpec::Stereo(StereoSpec {
                size,
                hfov,
                focal: self.focal,
                baseline: self.baseline.unwrap_or(defaults::BASELINE),
                distortion: self.distortion_coefficients()?,
                lens: self.given_lens()?,
                fov: self.fov,
            }),
            CameraKind::Equirect => RigSpec::Equirect {
                size: self.size.unwrap_or(defaults::EQUIRECT_SIZE),
            },
            CameraKind::Cylindrical => RigSpec::Cylindrical {
                size: self.size.unwrap_or(defaults::CYLINDRICAL_SIZE),
                vfov: self.vfov.unwrap_or(defaults::VFOV),
            },
            CameraKind::Omni => RigSpec::Omni(self.omni()?),
            CameraKind::Fisheye => RigSpec::Fisheye(FisheyeSpec {
                size: self.size.unwrap_or(defaults::FISHEYE_SIZE),
                lens: self.lens()?,
                fov: self.fov,
                focal: self.focal,
            }),
        })
    }

    /// `--dist` checked against `--distortion`'s count.
    fn distortion_coefficients(&self) -> anyhow::Result<Option<Vec<f64>>> {
        let (Some(kind), Some(Numbers(coefficients))) = (self.distortion, &self.dist) else {
            return Ok(None);
        };
        if !kind.counts().contains(&coefficients.len()) {
            let name = kind
                .to_possible_value()
                .map(|v| v.get_name().to_owned())
                .unwrap_or_default();
            bail!(
                "--distortion {name} takes {} coefficients in --dist, not {}: k1,k2,p1,p2[,k3] (radtan), \
                 k1,k2,p1,p2,k3,k4,k5,k6 (rational), and s1,s2,s3,s4 after those (thin-prism)",
                kind.counts()
                    .iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(" or "),
                coefficients.len()
            );
        }
        Ok(Some(coefficients.clone()))
    }

    /// [`Self::lens`] where `--lens` is given (a stereo pair's or a mirror's camera), else none.
    fn given_lens(&self) -> anyhow::Result<Option<LensSpec>> {
        self.lens.map(|_| self.lens()).transpose()
    }

    /// The `--lens` (the fisheye's, or a stereo pair's) with its parameters, defaults for those
    /// not given.
    fn lens(&self) -> anyhow::Result<LensSpec> {
        let exactly = |option: &str, values: &Option<Numbers>, count: usize, default: &[f64]| match values {
            None => Ok(default.to_vec()),
            Some(Numbers(values)) if values.len() == count => Ok(values.clone()),
            Some(Numbers(values)) => Err(anyhow::anyhow!("{option} takes {count} numbers, not {}", values.len())),
        };
        Ok(match self.lens.unwrap_or(LensKind::Equidistant) {
            LensKind::KannalaBrandt => {
                let k = exactly("--k (k1,k2,k3,k4)", &self.k, 4, &[0.0; 4])?;
                LensSpec::KannalaBrandt {
                    k: [k[0], k[1], k[2], k[3]],
                }
            }
            LensKind::Equidistant => LensSpec::Equidistant,
            LensKind::Equisolid => LensSpec::Equisolid,
            LensKind::Stereographic => LensSpec::Stereographic,
            LensKind::Orthographic => LensSpec::Orthographic,
            LensKind::DoubleSphere => LensSpec::DoubleSphere {
                xi: self.xi.unwrap_or(defaults::DOUBLE_SPHERE.0),
                alpha: self.alpha.unwrap_or(defaults::DOUBLE_SPHERE.1),
            },
            LensKind::Eucm => LensSpec::Eucm {
                alpha: self.alpha.unwrap_or(defaults::EUCM.0),
                beta: self.beta.unwrap_or(defaults::EUCM.1),
            },
            LensKind::Unified => {
                let d = exactly("--dist for the unified lens (k1,k2,p1,p2)", &self.dist, 4, &[0.0; 4])?;
                LensSpec::Unified {
                    xi: self.xi.unwrap_or(defaults::UNIFIED_XI),
                    distortion: [d[0], d[1], d[2], d[3]],
                }
            }
            LensKind::Scaramuzza => {
                let Some(Numbers(poly)) = self.poly.clone() else {
                    bail!(
                        "--lens scaramuzza needs --poly a0,a1,a2,...: OCamCalib's direct polynomial in pixels (a0 < 0), \
                         e.g. --poly=-200,0,0.0012"
                    );
                };
                let affine = exactly("--affine (c,d,e)", &self.affine, 3, &[1.0, 0.0, 0.0])?;
                LensSpec::Scaramuzza {
                    poly,
                    affine: (affine[0], affine[1], affine[2]),
                }
            }
        })
    }

    /// The camera or rig these options describe, checked by the library (`validate`): the
    /// command line refuses exactly what a library caller would be refused.
    pub(crate) fn build(&self) -> anyhow::Result<Rig> {
        Ok(self.spec()?.build()?)
    }

    /// Warns about an angle that looks like radians (`--hfov 1.047`): it is taken as degrees
    /// and renders, but not the camera meant.
    fn warn_about_radians(&self) -> anyhow::Result<()> {
        use std::f64::consts::{FRAC_PI_2, PI};
        let angles = [
            ("--hfov", self.hfov, PI),
            ("--vfov", self.vfov, PI),
            ("--fov", self.fov, PI),
            ("--max-elevation", self.max_elevation.and_then(|e| e.0), FRAC_PI_2),
        ];
        for (option, value, most) in angles {
            if let Some(value) = value.filter(|v| *v != 0.0 && v.abs() <= most) {
                crate::streams::stderr(format_args!(
                    "warning: {option} {value} is taken in degrees; if it is in radians, give {option} {:.2}",
                    value.to_degrees()
                ))?;
            }
        }
        Ok(())
    }

    fn omni(&self) -> anyhow::Result<OmniSpec> {
        let mirror = match self.mirror.unwrap_or(MirrorKind::Hyperbolic) {
            MirrorKind::Hyperbolic => MirrorSpec::Hyperbolic {
                a: self.mirror_a.unwrap_or(defaults::HYPERBOLIC_A),
                b: self.mirror_b.unwrap_or(defaults::HYPERBOLIC_B),
            },
            MirrorKind::Parabolic => MirrorSpec::Parabolic {
                a: self.mirror_a.unwrap_or(defaults::PARABOLIC_A),
                b: self.mirror_b,
                h: self.mirror_h.unwrap_or(defaults::PARABOLIC_H),
            },
            MirrorKind::Spherical => MirrorSpec::Spherical {
                radius: self.sphere_radius.unwrap_or(defaults::SPHERE_RADIUS),
                camera_distance: self.camera_distance.unwrap_or(defaults::CAMERA_DISTANCE),
            },
        };
        let paper = OmniSpec::default();
        Ok(OmniSpec {
            size: self.size.unwrap_or(paper.size),
            mirror,
            max_elevation: self.max_elevation.map_or(paper.max_elevation, |e| e.0),
            rim: self.rim,
            focal: self.focal,
            mount: match self.mount {
                Some(MountArg::Down) => MountSpec::Down,
                Some(MountArg::Up) | None => MountSpec::Up,
            },
            hidden_centre: self.hidden_centre.unwrap_or(paper.hidden_centre),
            misalign_offset: self.misalign_offset.map_or(paper.misalign_offset, Into::into),
            misalign_tilt: self.misalign_tilt.map_or(paper.misalign_tilt, Into::into),
            mirror_rays: match self.mirror_rays {
                Some(MirrorRaysArg::Shortcut) => MirrorRaysSpec::Shortcut,
                Some(MirrorRaysArg::Reflect) | None => MirrorRaysSpec::Reflect,
            },
            distortion: self.distortion_coefficients()?,
            lens: self.given_lens()?,
        })
    }
}
