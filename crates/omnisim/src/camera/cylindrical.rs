use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3, dvec2, dvec3};

use super::{CameraRay, panorama_azimuth};

/// A 360° cylindrical panorama around the body z axis.
///
/// Columns as the equirectangular panorama: azimuth φ = π − 2π(u + ½)/W. Rows are uniform in
/// height on a unit-radius cylinder: a ray at row v rises (cy − v)/fy per unit of horizontal
/// distance, with fy = (H/2)/tan(vfov/2) and cy = (H − 1)/2, so the horizon is the middle row.
#[derive(Debug, Clone, PartialEq)]
pub struct Cylindrical {
    /// Image width, pixels (360°).
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Vertical focal length, pixels per unit of tan(elevation).
    pub fy: f64,
    /// Row of the horizon.
    pub cy: f64,
}

impl Cylindrical {
    /// `vfov`: total vertical field of view in radians (symmetric about the horizon).
    pub fn with_vertical_fov(width: u32, height: u32, vfov: f64) -> Self {
        Self {
            width,
            height,
            fy: f64::from(height) / 2.0 / (vfov / 2.0).tan(),
            cy: (f64::from(height) - 1.0) / 2.0,
        }
    }

    /// The ray of pixel (u, v), from the body origin.
    pub fn ray(&self, pixel: DVec2) -> CameraRay {
        Self::ray_between(panorama_azimuth(pixel.x, self.width), self.rise(pixel.y))
    }

    /// How far the rays of row `v` rise per unit of horizontal distance.
    #[inline(always)]
    pub(super) fn rise(&self, v: f64) -> f64 {
        (self.cy - v) / self.fy
    }

    /// The ray at azimuth (cosine, sine) rising `rise`.
    #[inline(always)]
    pub(super) fn ray_between((cos_azimuth, sin_azimuth): (f64, f64), rise: f64) -> CameraRay {
        CameraRay {
            origin: DVec3::ZERO,
            direction: dvec3(cos_azimuth, sin_azimuth, rise).normalize(),
            t_min: 0.0,
        }
    }

    /// Pixel of a body-frame point; `None` on the body z axis.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        let horizontal = point.truncate().length();
        (horizontal > 0.0).then(|| {
            let azimuth = point.y.atan2(point.x);
            dvec2(
                (PI - azimuth) / TAU * f64::from(self.width) - 0.5,
                self.cy - self.fy * point.z / horizontal,
            )
        })
    }
}
