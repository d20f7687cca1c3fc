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
mod ray_source;
mod rig;
mod solve;
pub mod spec;
mod stereo;
mod validate;

use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3};

pub use catadioptric::{Catadioptric, MirrorRays, MirrorShape, Misalignment, Mount, UnifiedModel};
pub(crate) use cone::{Cone, ConePlanes};
pub use cylindrical::Cylindrical;
pub use distortion::BrownConrady;
pub use equirect::Equirectangular;
pub use lens::{KannalaBrandt, LensModel, Scaramuzza};
pub use lens_camera::LensCamera;
pub use pinhole::{BODY_FROM_OPTICAL, Pinhole};
pub(crate) use ray_source::RaySource;
pub use rig::{Rig, View};
pub use spec::{
    FisheyeSpec, LensSpec, MirrorRaysSpec, MirrorSpec, MountSpec, OmniSpec, PinholeSpec, RigFileError, RigSpec,
    RigSpecError, StereoSpec,
};
pub use stereo::{NO_DISPARITY, StereoRig};
pub use validate::{CameraError, MAX_PIXELS};

/// The centre of pixel `index` (row by row) of an image `width` pixels wide.
#[inline(always)]
pub(crate) fn pixel_centre(index: usize, width: u32) -> DVec2 {
    let row_length = width.max(1) as usize;
    DVec2::new((index % row_length) as f64, (index / row_length) as f64)
}

/// Cosine and sine of `angle`: the one place the panoramas take them, so that a ray table's
/// per-column values and a single pixel's ray are the same calls on the same inputs.
#[inline(always)]
fn cos_sin(angle: f64) -> (f64, f64) {
    (angle.cos(), angle.sin())
}

/// Cosine and sine of the azimuth of column `u` of a 360° panorama `width` pixels wide,
/// φ = π − 2π(u + ½)/W: the equirect and cylindrical panoramas' columns.
#[inline(always)]
fn panorama_azimuth(u: f64, width: u32) -> (f64, f64) {
    cos_sin(PI - TAU * (u + 0.5) / f64::from(width))
}

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
        self.ray(pixel_centre(index, self.size().0))
    }

    /// Every pixel centre's ray, bit for bit as [`Camera::pixel_ray`] gives it, with what the
    /// rays share (a panorama's columns and rows, a mirror's constants) worked out once: how
    /// ray tables and frames too large for one get their rays.
    pub(crate) fn ray_source(&self) -> RaySource<'_> {
        RaySource::new(self)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of `ray` as bits, so that `0.0` and `-0.0` differ.
    fn bits(ray: Option<CameraRay>) -> Option<[u64; 7]> {
        ray.map(|ray| {
            let [ox, oy, oz] = ray.origin.to_array().map(f64::to_bits);
            let [dx, dy, dz] = ray.direction.to_array().map(f64::to_bits);
            [ox, oy, oz, dx, dy, dz, ray.t_min.to_bits()]
        })
    }

    /// A camera's ray source gives every pixel's ray bit for bit as `Camera::ray` does, and
    /// its shared origin where it names one is every ray's: the panoramas made from
    /// per-column and per-row values (odd and even sizes, one column, one row, a tall cylinder
    /// with a wide field of view), mirrors with their constants worked out once (central,
    /// non-central, a tilted and shifted camera, one seen through a distorted lens, pixels
    /// without rays), and cameras computed pixel by pixel (a pinhole, a fisheye beyond 180°).
    /// Ray tables, frames too large for one, cone tables and `omnisim bench`'s counting pass
    /// all read rays from it.
    #[test]
    fn ray_sources_equal_each_pixels_own_ray_bit_for_bit() {
        let misaligned = Catadioptric {
            misalignment: Misalignment {
                offset: DVec3::new(0.002, -0.001, 0.003),
                tilt: DVec3::new(0.01, -0.02, 0.3),
            },
            ..Catadioptric::parabolic(72, 60, 0.05, 0.02, 15f64.to_radians())
        };
        let mut lensed = misaligned.clone();
        lensed.lens = Some(Box::new(LensModel::Perspective(
            BrownConrady::new(&[-0.12, 0.03, 1e-3, -2e-3, 0.004]).expect("radtan"),
        )));
        let fisheye = Camera::with_lens(
            Pinhole {
                fx: 10.0,
                fy: 10.0,
                ..Pinhole::with_horizontal_fov(64, 48, 1.0)
            },
            Some(LensModel::KannalaBrandt(
                KannalaBrandt::new([0.0; 4]).expect("equidistant"),
            )),
        );
        let cameras = [
            Camera::Equirectangular(Equirectangular {
                width: 1024,
                height: 512,
            }),
            Camera::Equirectangular(Equirectangular {
                width: 333,
                height: 171,
            }),
            Camera::Equirectangular(Equirectangular { width: 1, height: 7 }),
            Camera::Equirectangular(Equirectangular { width: 9, height: 1 }),
            Camera::Cylindrical(Cylindrical::with_vertical_fov(1024, 256, 90f64.to_radians())),
            Camera::Cylindrical(Cylindrical::with_vertical_fov(77, 301, 170f64.to_radians())),
            Camera::Cylindrical(Cylindrical::with_vertical_fov(1, 1, 1.0)),
            Camera::Pinhole(Pinhole::with_horizontal_fov(41, 29, 1.3)),
            Camera::Catadioptric(Catadioptric::hyperbolic(96, 80, 0.04, 0.16, Some(20f64.to_radians()))),
            Camera::Catadioptric(Catadioptric::spherical(64, 64, 0.05, 0.3)),
            Camera::Catadioptric(misaligned),
            Camera::Catadioptric(lensed),
            fisheye,
        ];
        for camera in &cameras {
            let (width, height) = camera.size();
            let source = camera.ray_source();
            let rays = source.all();
            assert_eq!(rays.len(), width as usize * height as usize, "{camera:?}");
            let mut without = 0;
            for (index, ray) in rays.into_iter().enumerate() {
                let (u, v) = (index % width as usize, index / width as usize);
                let want = camera.ray(DVec2::new(u as f64, v as f64));
                without += usize::from(want.is_none());
                assert_eq!(bits(ray), bits(want), "{camera:?}, pixel ({u}, {v})");
                if let (Some(origin), Some(ray)) = (source.shared_origin(), ray) {
                    assert_eq!(bits(Some(CameraRay { origin, ..ray })), bits(Some(ray)), "{camera:?}");
                }
            }
            if let Camera::Catadioptric(_) | Camera::Lens(_) = camera {
                assert!(without > 0, "{camera:?}: the case has pixels without rays");
            }
        }
    }
}
