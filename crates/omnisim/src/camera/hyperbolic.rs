//! A pinhole camera at the outer focus of a hyperbolic mirror, traced by the law of reflection
//! at the mirror surface (DESIGN.md §3).
//!
//! Mirror frame M = body frame: origin at the effective viewpoint F', +z from the camera
//! towards the mirror. In the hyperbola's own frame H (M shifted by c along z) the mirror is
//! the upper sheet of (x²+y²)/a² − z²/b² = −1, F' = (0,0,c) and the camera F = (0,0,−c). The
//! camera's optical axes are M's axes, so a world point at body azimuth φ appears at image
//! angle atan2(v − cy, u − cx) = φ (u right, v down): on screen the image is mirrored.

use glam::{DVec2, DVec3, dvec2, dvec3};

use super::CameraRay;

#[derive(Debug, Clone, PartialEq)]
pub struct HyperbolicMirror {
    pub width: u32,
    pub height: u32,
    /// Mirror parameter a, metres.
    pub a: f64,
    /// Mirror parameter b, metres.
    pub b: f64,
    /// Camera focal length, pixels (square pixels).
    pub focal: f64,
    pub cx: f64,
    pub cy: f64,
    /// Radius of the mirror's rim, metres; `None` for a mirror that reaches its asymptote.
    pub rim_radius: Option<f64>,
}

/// Mei's unified-model parameters of an aligned central catadioptric camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnifiedModel {
    pub xi: f64,
    pub gamma_x: f64,
    pub gamma_y: f64,
    pub cx: f64,
    pub cy: f64,
}

impl HyperbolicMirror {
    /// Mirror (a, b) seen by a `width`×`height` camera whose focal length makes the mirror
    /// fill the shorter image side. With `max_elevation` (radians above the horizon) the rim
    /// is placed where the mirror sees that elevation and the rim circle touches the image
    /// border; without it the mirror reaches its asymptote (elevation asin(b/c)), whose
    /// circle (pixel radius f·a/b) touches the border.
    pub fn fitted(width: u32, height: u32, a: f64, b: f64, max_elevation: Option<f64>) -> Self {
        let radius = width.min(height) as f64 / 2.0;
        let mut mirror = Self {
            width,
            height,
            a,
            b,
            focal: radius * b / a,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
            rim_radius: None,
        };
        if let Some(elevation) = max_elevation {
            let (sin, cos) = elevation.sin_cos();
            // The mirror point seen along s = (cos ε, 0, sin ε) from F' is λ·s, λ = a²/(b − c·sin ε).
            mirror.rim_radius = Some(a * a * cos / (b - mirror.c() * sin));
            // Its pixel radius is f·a²/(b²+c²)·cos ε/(ξ − sin ε); solve for f.
            let unit_focal = Self { focal: 1.0, ..mirror.clone() }.unified_model();
            mirror.focal = radius * (unit_focal.xi - sin) / (unit_focal.gamma_x * cos);
        }
        mirror
    }

    /// Highest elevation above the horizon any mirror of this shape can see: asin(b/c).
    pub fn asymptote_elevation(&self) -> f64 {
        (self.b / self.c()).asin()
    }

    /// Focal distance c = √(a² + b²).
    pub fn c(&self) -> f64 {
        self.a.hypot(self.b)
    }

    pub fn unified_model(&self) -> UnifiedModel {
        let (b, c) = (self.b, self.c());
        let scale = self.a * self.a / (b * b + c * c);
        UnifiedModel {
            xi: 2.0 * b * c / (b * b + c * c),
            gamma_x: self.focal * scale,
            gamma_y: self.focal * scale,
            cx: self.cx,
            cy: self.cy,
        }
    }

    /// Traces pixel (u, v): from the camera at F through the pixel, to the first hit Q on the
    /// mirror, reflected there. `None` where the ray misses the mirror or passes its rim.
    pub fn ray(&self, pixel: DVec2) -> Option<CameraRay> {
        let c = self.c();
        let d = dvec3((pixel.x - self.cx) / self.focal, (pixel.y - self.cy) / self.focal, 1.0).normalize();
        let camera_h = dvec3(0.0, 0.0, -c);
        let t = self.first_mirror_hit(camera_h, d)?;
        let q_h = camera_h + t * d;
        if let Some(rim) = self.rim_radius
            && q_h.x * q_h.x + q_h.y * q_h.y > rim * rim
        {
            return None;
        }
        let (a2, b2) = (self.a * self.a, self.b * self.b);
        let normal = dvec3(q_h.x / a2, q_h.y / a2, -q_h.z / b2).normalize();
        let reflected = d - 2.0 * d.dot(normal) * normal;
        let q_m = q_h - dvec3(0.0, 0.0, c);
        Some(CameraRay {
            origin: DVec3::ZERO,
            direction: reflected.normalize(),
            t_min: q_m.length(),
        })
    }

    /// Smallest t > 0 with `origin + t·d` on the upper sheet (z_H > 0), by the cancellation-free
    /// quadratic roots.
    fn first_mirror_hit(&self, origin: DVec3, d: DVec3) -> Option<f64> {
        let (a2, b2) = (self.a * self.a, self.b * self.b);
        let qa = (d.x * d.x + d.y * d.y) / a2 - d.z * d.z / b2;
        let qb = 2.0 * ((origin.x * d.x + origin.y * d.y) / a2 - origin.z * d.z / b2);
        let qc = (origin.x * origin.x + origin.y * origin.y) / a2 - origin.z * origin.z / b2 + 1.0;
        let roots: [f64; 2] = if qa.abs() <= 1e-15 * (qb.abs() + qc.abs()) {
            // Parallel to an asymptote: the equation is linear.
            if qb == 0.0 {
                return None;
            }
            [-qc / qb, f64::NAN]
        } else {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc < 0.0 {
                return None;
            }
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            [q / qa, qc / q]
        };
        roots
            .into_iter()
            .filter(|&t| t.is_finite() && t > 0.0 && origin.z + t * d.z > 0.0)
            .min_by(f64::total_cmp)
    }

    /// Closed-form (unified model) pixel of a body-frame point, `None` above the mirror's
    /// field of view or past its rim.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        let s = point.try_normalize()?;
        let c = self.c();
        if s.z >= self.b / c {
            return None;
        }
        if let Some(rim) = self.rim_radius {
            let lambda = self.a * self.a / (self.b - c * s.z);
            if (lambda * s).truncate().length() > rim {
                return None;
            }
        }
        let m = self.unified_model();
        Some(dvec2(
            m.cx + m.gamma_x * s.x / (m.xi - s.z),
            m.cy + m.gamma_y * s.y / (m.xi - s.z),
        ))
    }
}
