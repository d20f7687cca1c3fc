//! Whether a camera can make an image: a size the renderers handle, every parameter finite and
//! within a range where f64 rays keep their digits, and (for mirrors) some pixel that sees the
//! mirror. Library callers get the same refusals as the command line.

use glam::dvec2;

use super::{Camera, Catadioptric, LensCamera, LensModel, MirrorShape, Pinhole, StereoRig};
use crate::input::shown_number as number;

/// Most pixels one image may have (a frame holds about 40 bytes a pixel in memory).
pub const MAX_PIXELS: u64 = 100_000_000;
/// Lengths of a camera rig (mirror sizes, rim, camera distance, misalignment), metres.
const RIG_LENGTH: (f64, f64) = (1e-6, 1e3);
/// Focal lengths, pixels (or pixels per metre for the orthographic camera of a paraboloid).
const FOCAL: (f64, f64) = (1e-6, 1e12);
/// Principal points and pixel radii, pixels.
const PIXELS: (f64, f64) = (-1e9, 1e9);
/// Angles of a misaligned camera, radians (a full turn either way).
const TURN: (f64, f64) = (-std::f64::consts::TAU, std::f64::consts::TAU);
/// Stereo baseline and lens positions, metres: the scene's own limit.
const BASELINE: (f64, f64) = (1e-6, crate::scene::MAX_COORDINATE);

/// Why a camera cannot make an image; every message states the valid range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// Image size outside 1 pixel to [`MAX_PIXELS`].
    #[error(
        "the image is {width}x{height} = {} pixels ({} megapixels); omnisim renders images of 1 to {MAX_PIXELS} pixels (100 megapixels), each side at least 1",
        u64::from(*width) * u64::from(*height),
        (u64::from(*width) * u64::from(*height)) as f64 / 1e6
    )]
    Size {
        /// Width asked for, pixels.
        width: u32,
        /// Height asked for, pixels.
        height: u32,
    },
    /// A parameter outside the range where the model makes sense.

    #[error("{name} = {} {unit} is outside its valid range, {} to {} {unit}", number(*value), number(range.0), number(range.1))]
    Range {
        /// Which parameter.
        name: &'static str,
        /// The value given.
        value: f64,
        /// Smallest and largest valid values.
        range: (f64, f64),
        /// Unit of the three numbers.
        unit: &'static str,
    },
    /// Every parameter is in range, but no pixel has a ray (e.g. a rim smaller than a pixel).
    #[error("no pixel of the image sees the scene: {0}")]
    NoImage(String),
    /// A ray method the camera cannot use (the paper's shortcut on a non-central mirror).
    #[error("{0}")]
    Method(&'static str),
}

pub(super) fn within(name: &'static str, value: f64, range: (f64, f64), unit: &'static str) -> Result<(), CameraError> {
    if value >= range.0 && value <= range.1 {
        Ok(())
    } else {
        Err(CameraError::Range {
            name,
            value,
            range,
            unit,
        })
    }
}

fn check_size(width: u32, height: u32) -> Result<(), CameraError> {
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(CameraError::Size { width, height });
    }
    Ok(())
}

impl Camera {
    /// Why this camera cannot make an image, if it cannot. Cheap (a few thousand rays at most):
    /// renderers call it before every image.
    pub fn validate(&self) -> Result<(), CameraError> {
        let (width, height) = self.size();
        check_size(width, height)?;
        match self {
            Camera::Pinhole(c) => c.validate(),
            Camera::Equirectangular(_) => Ok(()),
            Camera::Cylindrical(c) => {
                within("cylindrical fy", c.fy, FOCAL, "px")?;
                within("cylindrical cy", c.cy, PIXELS, "px")
            }
            Camera::Catadioptric(c) => c.validate(),
            Camera::Lens(c) => c.validate(),
        }
    }
}

impl Pinhole {
    /// Checks size, focal lengths, principal point and position.
    pub fn validate(&self) -> Result<(), CameraError> {
        check_size(self.width, self.height)?;
        within("pinhole fx", self.fx, FOCAL, "px")?;
        within("pinhole fy", self.fy, FOCAL, "px")?;
        within("pinhole cx", self.cx, PIXELS, "px")?;
        within("pinhole cy", self.cy, PIXELS, "px")?;
        for value in self.position.to_array() {
            within("pinhole position", value, (-BASELINE.1, BASELINE.1), "m")?;
        }
        Ok(())
    }
}

impl LensCamera {
    /// Checks focal lengths, principal point, position and the lens's parameters, then that
    /// a grid of at most 64×64 pixels finds one inside the lens's field of view.
    pub fn validate(&self) -> Result<(), CameraError> {
        self.intrinsics.validate()?;
        self.model.check()?;
        let (width, height) = self.size();
        // The principal point first: it has a ray in every lens that sees anything there, so
        // the check made before every image usually costs one ray.
        let principal = (self.intrinsics.cx, self.intrinsics.cy);
        let inside = |(u, v): &(f64, f64)| (0.0..f64::from(width)).contains(u) && (0.0..f64::from(height)).contains(v);
        if std::iter::once(principal)
            .filter(inside)
            .chain(sampled_pixels(width, height))
            .any(|(u, v)| self.ray(dvec2(u, v)).is_some())
        {
            Ok(())
        } else {
            Err(CameraError::NoImage(format!(
                "no pixel is inside the {} lens's field of view ({:.1}° off axis at most); the focal length or \
                 principal point put it outside the image",
                self.model.name(),
                self.model.max_angle().to_degrees()
            )))
        }
    }
}

/// The spacing of a grid of at most 64×64 pixels over the image.
fn grid_step(width: u32, height: u32) -> f64 {
    (f64::from(width.max(height)) / 64.0).max(1.0)
}

/// Pixel centres on a grid of at most 64×64 over the image.
fn sampled_pixels(width: u32, height: u32) -> impl Iterator<Item = (f64, f64)> {
    let step = grid_step(width, height);
    let samples = move |size: u32| {
        (0..)
            .map(move |k| f64::from(k) * step)
            .take_while(move |&p| p < f64::from(size))
    };
    samples(height).flat_map(move |v| samples(width).map(move |u| (u, v)))
}

impl StereoRig {
    /// Checks the baseline and both cameras.
    pub fn validate(&self) -> Result<(), CameraError> {
        within("stereo baseline", self.baseline, BASELINE, "m")?;
        self.cameras().iter().try_for_each(Camera::validate)
    }
}

impl Catadioptric {
    /// Parameter ranges, then a grid of at most 64×64 pixels must find one that sees the
    /// mirror (a rim of a nanometre, a camera turned away or a hidden centre larger than the
    /// image leave none).
    pub fn validate(&self) -> Result<(), CameraError> {
        check_size(self.width, self.height)?;
        match self.mirror {
            MirrorShape::Hyperbolic { a, b } => {
                within("mirror a", a, RIG_LENGTH, "m")?;
                within("mirror b", b, RIG_LENGTH, "m")?;
            }
            MirrorShape::Parabolic { a, b, h } => {
                within("mirror a", a, RIG_LENGTH, "m")?;
                within("mirror b", b, RIG_LENGTH, "m")?;
                within("mirror h", h, RIG_LENGTH, "m")?;
            }
            MirrorShape::Spherical {
                radius,
                camera_distance,
            } => {
                within("sphere radius", radius, RIG_LENGTH, "m")?;
                // The camera must be outside the sphere: more than the radius away.
                let range = (radius, RIG_LENGTH.1);
                within("camera distance (outside the sphere)", camera_distance, range, "m")?;
                if camera_distance == radius {
                    return Err(CameraError::Range {
                        name: "camera distance (outside the sphere)",
                        value: camera_distance,
                        range,
                        unit: "m",
                    });
                }
            }
        }
        within("focal", self.focal, FOCAL, "px")?;
        within("cx", self.cx, PIXELS, "px")?;
        within("cy", self.cy, PIXELS, "px")?;
        if let Some(lens) = self.lens.as_deref() {
            if !self.is_perspective() {
                return Err(CameraError::Method(
                    "a lens model applies to the perspective camera of a hyperbolic or spherical mirror; the \
                     parabolic mirror's camera is orthographic (telecentric): remove the lens",
                ));
            }
            if let LensModel::Scaramuzza(_) = lens {
                return Err(CameraError::Method(
                    "the scaramuzza lens sets its own scale in pixels, and the mirror's camera takes its focal \
                     length from the mirror's fit (or focal): give the mirror's camera another lens model",
                ));
            }
            lens.check()?;
        }
        if let Some(rim) = self.rim_radius {
            within("rim radius", rim, RIG_LENGTH, "m")?;
        }
        within("hidden centre", self.hidden_centre_px, (0.0, PIXELS.1), "px")?;
        for value in self.misalignment.offset.to_array() {
            within("misalignment offset", value, (-RIG_LENGTH.1, RIG_LENGTH.1), "m")?;
        }
        for value in self.misalignment.tilt.to_array() {
            within("misalignment tilt", value, TURN, "rad")?;
        }
        let sees = sampled_pixels(self.width, self.height).any(|(u, v)| {
            self.ray(dvec2(u, v))
                .is_some_and(|r| r.direction.is_finite() && r.origin.is_finite() && r.t_min.is_finite())
        });
        if sees {
            Ok(())
        } else {
            Err(CameraError::NoImage(format!(
                "no pixel (sampled every {:.0} px) sees the mirror; the rim, focal length, hidden centre or \
                 misalignment put it outside the image",
                grid_step(self.width, self.height)
            )))
        }
    }

    /// Whether the chosen ray method is exact for this mirror: the reference paper's shortcut
    /// is exact only for an aligned central mirror.
    pub fn check_rays(&self) -> Result<(), CameraError> {
        if self.rays == super::MirrorRays::Shortcut && !self.is_central() {
            return Err(CameraError::Method(
                "the shortcut (rays from the viewpoint F' through the mirror point) is only exact for an aligned \
                 central mirror (hyperbolic, or parabolic with a = b, no misalignment); use reflect",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirectangular, Mount};
    use glam::dvec3;

    fn paper() -> Catadioptric {
        Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()))
    }

    fn refusal(camera: Catadioptric) -> String {
        Camera::Catadioptric(camera).validate().unwrap_err().to_string()
    }

    #[test]
    fn sizes_outside_1_to_100_megapixels_are_refused() {
        let camera = |width, height| Camera::Equirectangular(Equirectangular { width, height });
        assert!(camera(0, 10).validate().is_err());
        assert!(camera(10_000, 10_000).validate().is_ok());
        let error = camera(10_001, 10_000).validate().unwrap_err().to_string();
        assert!(
            error.contains("100010000 pixels") && !error.contains(" is 100 megapixels"),
            "{error}"
        );
        let mut pinhole = Pinhole::with_horizontal_fov(640, 480, 1.0);
        assert!(pinhole.validate().is_ok());
        pinhole.width = 0;
        assert!(matches!(pinhole.validate(), Err(CameraError::Size { width: 0, .. })));
    }

    #[test]
    fn nonsense_parameters_are_refused_with_the_valid_range() {
        assert_eq!(Camera::Catadioptric(paper()).validate(), Ok(()));
        let error = refusal(Catadioptric {
            rim_radius: Some(1e-9),
            ..paper()
        });
        assert!(
            error.contains("rim radius = 1e-9 m") && error.contains("1e-6 to 1000 m"),
            "{error}"
        );
        let error = refusal(Catadioptric {
            focal: 1e-300,
            ..paper()
        });
        assert!(
            error.contains("focal = 1e-300") && error.contains("valid range"),
            "{error}"
        );
        let mut turned = paper();
        turned.misalignment.tilt = dvec3(std::f64::consts::PI, 0.0, 0.0);
        assert!(refusal(turned).contains("no pixel"));
        let error = refusal(Catadioptric {
            hidden_centre_px: f64::INFINITY,
            ..paper()
        });
        assert!(error.contains("hidden centre = inf"), "{error}");
        assert!(
            refusal(Catadioptric {
                hidden_centre_px: 1000.0,
                mount: Mount::Down,
                ..paper()
            })
            .contains("no pixel")
        );
        let error = refusal(Catadioptric::spherical(250, 250, 0.05, 1e300));
        assert!(
            error.contains("camera distance (outside the sphere) = 1e300 m"),
            "{error}"
        );
        let rig = StereoRig::rectified(Pinhole::with_horizontal_fov(64, 48, 1.0), 1e300);
        assert!(rig.validate().unwrap_err().to_string().contains("baseline = 1e300 m"));
        let mut pinhole = Pinhole::with_horizontal_fov(64, 48, 1.0);
        pinhole.fx = 1e-300;
        assert!(Camera::Pinhole(pinhole).validate().is_err());
    }
}
