//! Camera models: for every pixel, the ray the camera sees along, in the body frame.
//!
//! Each model has an f64 implementation here (the accuracy reference and the CPU backend) and a
//! WGSL twin in `shaders/camera_*.wgsl`; `gpu/bindings.rs` numbers them for the shader. Pixel
//! coordinates follow `OpenCV`: u = column, v = row, pixel centres at integer coordinates.

pub mod catadioptric;
mod cone;
mod cylindrical;
pub mod distortion;
mod equirect;
pub mod lens;
mod lens_camera;
pub(crate) mod pinhole;
mod solve;
pub mod spec;
mod stereo;
mod validate;

use glam::{DVec2, DVec3};

pub use catadioptric::{Catadioptric, MirrorRays, MirrorShape, Misalignment, Mount, UnifiedModel};
pub(crate) use cone::Cone;
pub use cylindrical::Cylindrical;
pub use distortion::BrownConrady;
pub use equirect::Equirectangular;
pub use lens::{KannalaBrandt, LensModel, Scaramuzza};
pub use lens_camera::LensCamera;
pub use pinhole::{BODY_FROM_OPTICAL, Pinhole};
pub use spec::{
    FisheyeSpec, LensSpec, MirrorRaysSpec, MirrorSpec, MountSpec, OmniSpec, PinholeSpec, RigFileError, RigSpec,
    RigSpecError, StereoSpec,
};
pub use stereo::{NO_DISPARITY, StereoRig};
pub use validate::{CameraError, MAX_PIXELS};

/// A ray of a camera in its body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraRay {
    /// Where range is measured from: the viewpoint for central cameras, the mirror point for
    /// non-central ones.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// Tracing starts this far along the ray (at the mirror for central catadioptric
    /// cameras), so nothing between the viewpoint and the mirror surface is seen.
    pub t_min: f64,
}

/// Every single-image vision system (a stereo rig is two of them, see `StereoRig`).
#[derive(Debug, Clone, PartialEq)]
pub enum Camera {
    /// A perspective camera (also each camera of an ideal stereo rig).
    Pinhole(Pinhole),
    /// A full-sphere equirectangular panorama.
    Equirectangular(Equirectangular),
    /// A 360° cylindrical panorama.
    Cylindrical(Cylindrical),
    /// A camera looking at a mirror.
    Catadioptric(Catadioptric),
    /// A camera with a lens model: fisheye, or a pinhole with distortion (boxed: its model
    /// holds up to 12 coefficients and is larger than the other cameras).
    Lens(Box<LensCamera>),
}

impl Camera {
    /// The camera with `intrinsics` (size, K, place): the ideal pinhole, or with a lens model.
    pub fn with_lens(intrinsics: Pinhole, model: Option<LensModel>) -> Self {
        match model {
            None => Camera::Pinhole(intrinsics),
            Some(model) => Camera::Lens(Box::new(LensCamera { intrinsics, model })),
        }
    }

    /// Image size (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        match self {
            Camera::Pinhole(c) => (c.width, c.height),
            Camera::Equirectangular(c) => (c.width, c.height),
            Camera::Cylindrical(c) => (c.width, c.height),
            Camera::Catadioptric(c) => (c.width, c.height),
            Camera::Lens(c) => c.size(),
        }
    }

    /// The ray through the centre of pixel `index`, counted row by row from the top left:
    /// how whole frames and ray tables enumerate an image.
    pub fn pixel_ray(&self, index: usize) -> Option<CameraRay> {
        let row_length = self.size().0.max(1) as usize;
        self.ray(DVec2::new((index % row_length) as f64, (index / row_length) as f64))
    }

    /// The ray seen at pixel (u, v), or `None` where the pixel sees nothing of the scene
    /// (outside the mirror, the camera body, beyond a lens's field of view).
    pub fn ray(&self, pixel: DVec2) -> Option<CameraRay> {
        match self {
            Camera::Pinhole(c) => Some(c.ray(pixel)),
            Camera::Equirectangular(c) => Some(c.ray(pixel)),
            Camera::Cylindrical(c) => Some(c.ray(pixel)),
            Camera::Catadioptric(c) => c.ray(pixel),
            Camera::Lens(c) => c.ray(pixel),
        }
    }

    /// Closed-form projection of a body-frame point, where one exists (central cameras).
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        match self {
            Camera::Pinhole(c) => c.project(point),
            Camera::Equirectangular(c) => c.project(point),
            Camera::Cylindrical(c) => c.project(point),
            Camera::Catadioptric(c) => c.project(point),
            Camera::Lens(c) => c.project(point),
        }
    }

    /// The perspective frame whose optical z is this camera's depth (z-depth images): a
    /// pinhole's, or a distorted pinhole's K and place; `None` for other cameras.
    pub fn depth_frame(&self) -> Option<&Pinhole> {
        match self {
            Camera::Pinhole(c) => Some(c),
            Camera::Lens(c) if matches!(c.model, LensModel::Perspective(_)) => Some(&c.intrinsics),
            _ => None,
        }
    }

    /// Whether a lens model's f64 inverse gives this camera's rays (a lens camera, or a mirror
    /// seen through a lens): the GPU reads them from a ray table of pixel centres, so edge
    /// samples are traced on the CPU.
    pub fn has_lens_model(&self) -> bool {
        match self {
            Camera::Lens(_) => true,
            Camera::Catadioptric(c) => c.lens.is_some(),
            Camera::Pinhole(_) | Camera::Equirectangular(_) | Camera::Cylindrical(_) => false,
        }
    }

    /// Whether all rays share one origin (the pose position).
    pub fn is_central(&self) -> bool {
        match self {
            Camera::Pinhole(c) => c.position == DVec3::ZERO,
            Camera::Equirectangular(_) | Camera::Cylindrical(_) => true,
            Camera::Catadioptric(c) => c.is_central(),
            Camera::Lens(c) => c.intrinsics.position == DVec3::ZERO,
        }
    }

    /// Short name used in file metadata and messages.
    pub fn model_name(&self) -> &'static str {
        match self {
            Camera::Pinhole(_) => "pinhole",
            Camera::Equirectangular(_) => "equirectangular",
            Camera::Cylindrical(_) => "cylindrical",
            Camera::Catadioptric(c) => match c.mirror {
                MirrorShape::Hyperbolic { .. } => "hyperbolic-catadioptric",
                MirrorShape::Parabolic { .. } => "parabolic-catadioptric",
                MirrorShape::Spherical { .. } => "spherical-catadioptric",
            },
            Camera::Lens(c) => c.model.name(),
        }
    }
}
