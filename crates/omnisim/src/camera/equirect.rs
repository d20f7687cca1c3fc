use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3, dvec2, dvec3};

use super::{CameraRay, cos_sin, panorama_azimuth};

/// A full-sphere equirectangular panorama around the body z axis.
///
/// Column u looks at azimuth φ = π − 2π(u + ½)/W (φ counter-clockwise from body +x, so body
/// forward is the middle column and body left is left of it); row v at elevation
/// ε = π/2 − π(v + ½)/H. Turning the body by 2π/W about z shifts the image by one column.
#[derive(Debug, Clone, PartialEq)]
pub struct Equirectangular {
    /// Image width, pixels (360° of azimuth).
    pub width: u32,
    /// Image height, pixels (180° of elevation).
    pub height: u32,
}

impl Equirectangular {
    /// The ray of pixel (u, v), from the body origin.
    pub fn ray(&self, pixel: DVec2) -> CameraRay {
        Self::ray_between(panorama_azimuth(pixel.x, self.width), self.elevation(pixel.y))
    }

    /// Cosine and sine of the elevation of row `v`.
    #[inline(always)]
    pub(super) fn elevation(&self, v: f64) -> (f64, f64) {
        cos_sin(PI / 2.0 - PI * (v + 0.5) / f64::from(self.height))
    }

    /// The ray at azimuth and elevation given as (cosine, sine).
    #[inline(always)]
    pub(super) fn ray_between(
        (cos_azimuth, sin_azimuth): (f64, f64),
        (cos_elevation, sin_elevation): (f64, f64),
    ) -> CameraRay {
        CameraRay {
            origin: DVec3::ZERO,
            direction: dvec3(cos_elevation * cos_azimuth, cos_elevation * sin_azimuth, sin_elevation),
            t_min: 0.0,
        }
    }

    /// Pixel of a body-frame point; `None` at the origin.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        let horizontal = point.truncate().length();
        if horizontal == 0.0 && point.z == 0.0 {
            return None;
        }
        let azimuth = point.y.atan2(point.x);
        let elevation = point.z.atan2(horizontal);
        // atan2 ∈ (−π, π] puts u in [−½, W − ½): the image's own column range.
        Some(dvec2(
            (PI - azimuth) / TAU * f64::from(self.width) - 0.5,
            (PI / 2.0 - elevation) / PI * f64::from(self.height) - 0.5,
        ))
    }
}
