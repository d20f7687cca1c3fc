//! Camera models: for every pixel, the ray the camera sees along, in the body frame.
//!
//! Each model has an f64 implementation here (the accuracy reference and the CPU backend) and a
//! WGSL twin in `shaders/camera_*.wgsl`; `Camera::gpu_kind` ties the two together. Pixel
//! coordinates follow OpenCV: u = column, v = row, pixel centres at integer coordinates.

mod equirect;
mod hyperbolic;
mod pinhole;

use glam::{DVec2, DVec3};

pub use equirect::Equirectangular;
pub use hyperbolic::HyperbolicMirror;
pub use pinhole::Pinhole;

/// A ray of a camera in its body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraRay {
    /// Where range is measured from: the viewpoint for central cameras.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// Tracing starts this far along the ray (at the mirror for catadioptric cameras), so
    /// nothing between the viewpoint and the mirror surface is seen.
    pub t_min: f64,
}

/// Every supported vision system.
#[derive(Debug, Clone, PartialEq)]
pub enum Camera {
    Pinhole(Pinhole),
    Equirectangular(Equirectangular),
    Hyperbolic(HyperbolicMirror),
}

impl Camera {
    /// Image size (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        match self {
            Camera::Pinhole(c) => (c.width, c.height),
            Camera::Equirectangular(c) => (c.width, c.height),
            Camera::Hyperbolic(c) => (c.width, c.height),
        }
    }

    /// The ray seen at pixel (u, v), or `None` where the pixel sees nothing of the scene
    /// (outside the mirror).
    pub fn ray(&self, pixel: DVec2) -> Option<CameraRay> {
        match self {
            Camera::Pinhole(c) => Some(c.ray(pixel)),
            Camera::Equirectangular(c) => Some(c.ray(pixel)),
            Camera::Hyperbolic(c) => c.ray(pixel),
        }
    }

    /// Closed-form projection of a body-frame point seen from the viewpoint, where one exists.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        match self {
            Camera::Pinhole(c) => c.project(point),
            Camera::Equirectangular(c) => c.project(point),
            Camera::Hyperbolic(c) => c.project(point),
        }
    }

    /// Short name used in file metadata and messages.
    pub fn model_name(&self) -> &'static str {
        match self {
            Camera::Pinhole(_) => "pinhole",
            Camera::Equirectangular(_) => "equirectangular",
            Camera::Hyperbolic(_) => "hyperbolic-catadioptric",
        }
    }

    /// Which ray generator of `shaders/` implements this model (`CAMERA_*` constants there).
    pub(crate) fn gpu_kind(&self) -> u32 {
        match self {
            Camera::Pinhole(_) => 0,
            Camera::Equirectangular(_) => 1,
            Camera::Hyperbolic(_) => 2,
        }
    }
}
