use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3, dvec2, dvec3};

use super::CameraRay;

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
        let azimuth = PI - TAU * (pixel.x + 0.5) / f64::from(self.width);
        let elevation = PI / 2.0 - PI * (pixel.y + 0.5) / f64::from(self.height);
        CameraRay {
            origin: DVec3::ZERO,
            direction: dvec3(
                elevation.cos() * azimuth.cos(),
                elevation.cos() * azimuth.sin(),
                elevation.sin(),
            ),
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
