//! Camera options shared by `render` and `bench`, turned into an `omnisim::Camera`.

use anyhow::bail;
use clap::{Args, ValueEnum};
use omnisim::{Camera, Equirectangular, HyperbolicMirror, Pinhole};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CameraKind {
    /// Perspective camera looking along body +x (OpenCV optical frame).
    Pinhole,
    /// Full-sphere equirectangular panorama.
    Equirect,
    /// Pinhole at the outer focus of a hyperbolic mirror above it (catadioptric omnidirectional).
    Omni,
}

#[derive(Debug, Clone, Args)]
pub struct CameraArgs {
    /// Vision system to simulate.
    #[arg(long, value_enum, default_value = "omni")]
    pub camera: CameraKind,
    /// Image size WIDTHxHEIGHT in pixels [default: pinhole 640x480, equirect 1024x512, omni 250x250].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Pinhole: horizontal field of view in degrees (square pixels, centred principal point).
    #[arg(long, default_value_t = 60.0)]
    pub hfov: f64,
    /// Pinhole or omni: focal length in pixels (overrides --hfov; omni default fits the mirror to the image).
    #[arg(long)]
    pub focal: Option<f64>,
    /// Omni: hyperbolic mirror parameter a in metres ((x²+y²)/a² − z²/b² = −1; paper: 40 mm).
    #[arg(long, default_value_t = 0.04)]
    pub mirror_a: f64,
    /// Omni: hyperbolic mirror parameter b in metres (paper: 160 mm).
    #[arg(long, default_value_t = 0.16)]
    pub mirror_b: f64,
    /// Omni: radius of the mirror rim in metres [default: where the mirror sees --max-elevation].
    #[arg(long, conflicts_with = "max_elevation")]
    pub rim: Option<f64>,
    /// Omni: highest elevation above the horizon the mirror shows, in degrees; places the rim
    /// there and fits it to the image. "none": the mirror reaches its asymptote, asin(b/c).
    #[arg(long, default_value = "20", value_parser = parse_elevation)]
    pub max_elevation: MaxElevation,
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

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT, e.g. 640x480"))?;
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&n| (1..=32768).contains(&n));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("'{text}': width and height must be whole numbers from 1 to 32768")),
    }
}

impl CameraArgs {
    pub fn build(&self) -> anyhow::Result<Camera> {
        let positive = |name: &str, v: f64| -> anyhow::Result<f64> {
            if v.is_finite() && v > 0.0 { Ok(v) } else { bail!("--{name} must be a positive number, not {v}") }
        };
        Ok(match self.camera {
            CameraKind::Pinhole => {
                let (w, h) = self.size.unwrap_or((640, 480));
                let hfov = self.hfov;
                if !(hfov > 0.0 && hfov < 180.0) {
                    bail!("--hfov must be between 0 and 180 degrees (exclusive), not {hfov}");
                }
                let mut pinhole = Pinhole::with_horizontal_fov(w, h, hfov.to_radians());
                if let Some(f) = self.focal {
                    let f = positive("focal", f)?;
                    (pinhole.fx, pinhole.fy) = (f, f);
                }
                Camera::Pinhole(pinhole)
            }
            CameraKind::Equirect => {
                let (width, height) = self.size.unwrap_or((1024, 512));
                Camera::Equirectangular(Equirectangular { width, height })
            }
            CameraKind::Omni => {
                let (w, h) = self.size.unwrap_or((250, 250));
                let a = positive("mirror-a", self.mirror_a)?;
                let b = positive("mirror-b", self.mirror_b)?;
                let max_elevation = if self.rim.is_some() { None } else { self.max_elevation.0 };
                let mut mirror = HyperbolicMirror::fitted(w, h, a, b, max_elevation.map(f64::to_radians));
                if let Some(elevation) = max_elevation
                    && elevation.to_radians() >= mirror.asymptote_elevation()
                {
                    bail!(
                        "--max-elevation {elevation}° is beyond what this mirror can see: at most {:.2}° (asin(b/c)); use less, or 'none'",
                        mirror.asymptote_elevation().to_degrees()
                    );
                }
                if let Some(rim) = self.rim {
                    mirror.rim_radius = Some(positive("rim", rim)?);
                }
                if let Some(f) = self.focal {
                    mirror.focal = positive("focal", f)?;
                }
                Camera::Hyperbolic(mirror)
            }
        })
    }
}
