//! Camera options shared by `render` and `bench`, turned into an `omnisim` camera or rig.

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use glam::{DVec3, dvec3};
use omnisim::camera::{MirrorRays, MirrorShape, Misalignment, Mount};
use omnisim::{Camera, Catadioptric, Cylindrical, Equirectangular, Pinhole, Rig, StereoRig};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CameraKind {
    /// Perspective camera looking along body +x (OpenCV optical frame).
    Pinhole,
    /// Two pinholes --baseline apart on body y (left at +y), with ground-truth disparity.
    Stereo,
    /// Full-sphere equirectangular panorama.
    Equirect,
    /// 360° cylindrical panorama (--vfov).
    Cylindrical,
    /// Catadioptric omnidirectional camera: a camera looking at a --mirror.
    Omni,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MirrorKind {
    /// (x²+y²)/a² − z²/b² = −1, pinhole at the outer focus (central).
    Hyperbolic,
    /// z = h·(x²/a² + y²/b²), orthographic camera (central when a = b).
    Parabolic,
    /// Sphere of --sphere-radius, pinhole --camera-distance from its centre (non-central).
    Spherical,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MountArg {
    /// Mirror above the camera: mirror axis along body +z.
    Up,
    /// Mirror below the camera: mirror axis along body −z.
    Down,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MirrorRaysArg {
    /// Law of reflection at the mirror surface: exact for every mirror and misalignment.
    Reflect,
    /// The reference paper's rays from the viewpoint F' through the mirror point (aligned central mirrors only).
    Shortcut,
}

#[derive(Debug, Clone, Args)]
pub struct CameraArgs {
    /// Vision system to simulate.
    #[arg(long, value_enum, default_value = "omni")]
    pub camera: CameraKind,
    /// Image size WIDTHxHEIGHT in pixels [default: pinhole/stereo 640x480, equirect 1024x512, cylindrical 1024x256, omni 250x250].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Pinhole/stereo: horizontal field of view in degrees (square pixels, centred principal point).
    #[arg(long, default_value_t = 60.0)]
    pub hfov: f64,
    /// Stereo: distance between the two optical centres, metres.
    #[arg(long, default_value_t = 0.12)]
    pub baseline: f64,
    /// Cylindrical: vertical field of view in degrees, symmetric about the horizon.
    #[arg(long, default_value_t = 90.0)]
    pub vfov: f64,
    /// Focal length in pixels (pinhole, stereo, hyperbolic, spherical) or pixels per metre
    /// (parabolic); overrides --hfov and the omni fit.
    #[arg(long)]
    pub focal: Option<f64>,
    /// Omni: mirror shape.
    #[arg(long, value_enum, default_value = "hyperbolic")]
    pub mirror: MirrorKind,
    /// Omni: mirror parameter a in metres [default: hyperbolic 0.04 (the paper's 40 mm), parabolic 0.04].
    #[arg(long)]
    pub mirror_a: Option<f64>,
    /// Omni: mirror parameter b in metres [default: hyperbolic 0.16 (the paper's 160 mm); parabolic = a].
    #[arg(long)]
    pub mirror_b: Option<f64>,
    /// Omni, parabolic: height h in z = h·(x²/a² + y²/b²), metres.
    #[arg(long, default_value_t = 0.02)]
    pub mirror_h: f64,
    /// Omni, spherical: sphere radius in metres.
    #[arg(long, default_value_t = 0.05)]
    pub sphere_radius: f64,
    /// Omni, spherical: distance from the sphere's centre to the pinhole in metres.
    #[arg(long, default_value_t = 0.25)]
    pub camera_distance: f64,
    /// Omni: radius of the mirror rim in metres [default: where the mirror sees --max-elevation].
    #[arg(long, conflicts_with = "max_elevation")]
    pub rim: Option<f64>,
    /// Omni (hyperbolic, parabolic): highest elevation above the mirror's horizon shown, in
    /// degrees; places the rim there and fits it to the image. "none" (hyperbolic): the mirror
    /// reaches its asymptote, asin(b/c).
    /// [default: 20]
    #[arg(long, value_parser = parse_elevation)]
    pub max_elevation: Option<MaxElevation>,
    /// Omni: which way the mirror axis points in the body frame.
    #[arg(long, value_enum, default_value = "up")]
    pub mount: MountArg,
    /// Omni: radius in pixels of the image centre hidden by the camera's own body.
    #[arg(long, default_value_t = 0.0)]
    pub hidden_centre: f64,
    /// Omni: camera displaced from its nominal place by x,y,z metres (mirror frame); the image
    /// becomes non-central and is still traced exactly.
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub misalign_offset: Option<DVec3>,
    /// Omni: camera axes tilted by θx,θy,θz degrees (R = Rx·Ry·Rz).
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub misalign_tilt: Option<DVec3>,
    /// Omni: how mirror rays are found.
    #[arg(long, value_enum, default_value = "reflect")]
    pub mirror_rays: MirrorRaysArg,
}

/// `--max-elevation`: degrees, or `None` for a mirror without rim.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaxElevation(pub Option<f64>);

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

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT, e.g. 640x480"))?;
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&n| (1..=32768).contains(&n));
    match (parse(w), parse(h)) {
        // A frame holds about 40 bytes a pixel in memory (colour, range, face, f64 point).
        (Some(w), Some(h)) if w as u64 * h as u64 > 100_000_000 => Err(format!(
            "'{text}' is {} megapixels; omnisim renders at most 100 megapixels per image",
            w as u64 * h as u64 / 1_000_000
        )),
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!(
            "'{text}': width and height must be whole numbers from 1 to 32768"
        )),
    }
}

fn positive(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a positive number, not {v}")
    }
}

impl CameraArgs {
    fn pinhole(&self, default_size: (u32, u32)) -> anyhow::Result<Pinhole> {
        let (w, h) = self.size.unwrap_or(default_size);
        let hfov = self.hfov;
        if !(hfov > 0.0 && hfov < 180.0) {
            bail!("--hfov must be between 0 and 180 degrees (exclusive), not {hfov}");
        }
        let mut pinhole = Pinhole::with_horizontal_fov(w, h, hfov.to_radians());
        if let Some(f) = self.focal {
            let f = positive("focal", f)?;
            (pinhole.fx, pinhole.fy) = (f, f);
        }
        Ok(pinhole)
    }

    pub fn build(&self) -> anyhow::Result<Rig> {
        Ok(match self.camera {
            CameraKind::Pinhole => Rig::Single(Camera::Pinhole(self.pinhole((640, 480))?)),
            CameraKind::Stereo => Rig::Stereo(StereoRig {
                camera: self.pinhole((640, 480))?,
                baseline: positive("baseline", self.baseline)?,
            }),
            CameraKind::Equirect => {
                let (width, height) = self.size.unwrap_or((1024, 512));
                Rig::Single(Camera::Equirectangular(Equirectangular { width, height }))
            }
            CameraKind::Cylindrical => {
                let (w, h) = self.size.unwrap_or((1024, 256));
                if !(self.vfov > 0.0 && self.vfov < 180.0) {
                    bail!(
                        "--vfov must be between 0 and 180 degrees (exclusive), not {}",
                        self.vfov
                    );
                }
                Rig::Single(Camera::Cylindrical(Cylindrical::with_vertical_fov(
                    w,
                    h,
                    self.vfov.to_radians(),
                )))
            }
            CameraKind::Omni => Rig::Single(Camera::Catadioptric(self.catadioptric()?)),
        })
    }

    fn catadioptric(&self) -> anyhow::Result<Catadioptric> {
        let (w, h) = self.size.unwrap_or((250, 250));
        let requested = self.max_elevation.unwrap_or(MaxElevation(Some(20.0)));
        let elevation = if self.rim.is_some() {
            None
        } else {
            requested.0.map(f64::to_radians)
        };
        let mut camera = match self.mirror {
            MirrorKind::Hyperbolic => {
                let a = positive("mirror-a", self.mirror_a.unwrap_or(0.04))?;
                let b = positive("mirror-b", self.mirror_b.unwrap_or(0.16))?;
                let camera = Catadioptric::hyperbolic(w, h, a, b, elevation);
                if let Some(e) = elevation
                    && e >= camera.asymptote_elevation()
                {
                    bail!(
                        "--max-elevation {:.2}° is beyond what this mirror can see: at most {:.2}° (asin(b/c)); use less, or 'none'",
                        e.to_degrees(),
                        camera.asymptote_elevation().to_degrees()
                    );
                }
                camera
            }
            MirrorKind::Parabolic => {
                let a = positive("mirror-a", self.mirror_a.unwrap_or(0.04))?;
                let height = positive("mirror-h", self.mirror_h)?;
                let elevation = match (elevation, self.rim) {
                    (Some(e), _) => e,
                    (None, Some(_)) => 0.0,
                    (None, None) => bail!("a paraboloid has no asymptote: give --max-elevation in degrees or --rim"),
                };
                let mut camera = Catadioptric::parabolic(w, h, a, height, elevation);
                if let Some(b) = self.mirror_b {
                    camera.mirror = MirrorShape::Parabolic {
                        a,
                        b: positive("mirror-b", b)?,
                        h: height,
                    };
                }
                camera
            }
            MirrorKind::Spherical => {
                if self.max_elevation.is_some() {
                    bail!(
                        "--max-elevation is for hyperbolic and parabolic mirrors; limit a spherical mirror with --rim"
                    );
                }
                Catadioptric::spherical(
                    w,
                    h,
                    positive("sphere-radius", self.sphere_radius)?,
                    self.camera_distance,
                )
            }
        };
        if let Some(rim) = self.rim {
            camera.rim_radius = Some(positive("rim", rim)?);
        }
        if let Some(f) = self.focal {
            camera.focal = positive("focal", f)?;
        }
        camera.mount = match self.mount {
            MountArg::Up => Mount::Up,
            MountArg::Down => Mount::Down,
        };
        if self.hidden_centre.is_nan() || self.hidden_centre < 0.0 {
            bail!("--hidden-centre must be a radius in pixels ≥ 0");
        }
        camera.hidden_centre_px = self.hidden_centre;
        camera.misalignment = Misalignment {
            offset: self.misalign_offset.unwrap_or(DVec3::ZERO),
            tilt: self.misalign_tilt.unwrap_or(DVec3::ZERO) * (std::f64::consts::PI / 180.0),
        };
        camera.rays = match self.mirror_rays {
            MirrorRaysArg::Reflect => MirrorRays::Reflect,
            MirrorRaysArg::Shortcut => MirrorRays::Shortcut,
        };
        camera
            .validate()
            .map_err(anyhow::Error::msg)
            .context("the omnidirectional camera cannot be traced")?;
        Ok(camera)
    }
}
