use glam::{DMat3, DVec2, DVec3, dvec2, dvec3};

use super::CameraRay;
use crate::frame::Frame;
use crate::pose::Pose;

/// An ideal perspective camera with `OpenCV` intrinsics, mounted looking along body +x.
#[derive(Debug, Clone, PartialEq)]
pub struct Pinhole {
    /// Optical centre in the body frame (zero except for the cameras of a stereo rig).
    pub position: DVec3,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
}

/// `body_from_optical`: optical z (forward) → body x, optical x (right) → body −y,
/// optical y (down) → body −z.
pub const BODY_FROM_OPTICAL: DMat3 = DMat3::from_cols(
    DVec3::new(0.0, -1.0, 0.0),
    DVec3::new(0.0, 0.0, -1.0),
    DVec3::new(1.0, 0.0, 0.0),
);

impl Pinhole {
    /// Square pixels, principal point at the image centre ((W−1)/2, (H−1)/2), horizontal field
    /// of view `hfov` radians across the full image width.
    pub fn with_horizontal_fov(width: u32, height: u32, hfov: f64) -> Self {
        let f = f64::from(width) / 2.0 / (hfov / 2.0).tan();
        Self {
            position: DVec3::ZERO,
            width,
            height,
            fx: f,
            fy: f,
            cx: (f64::from(width) - 1.0) / 2.0,
            cy: (f64::from(height) - 1.0) / 2.0,
        }
    }

    /// The ray of pixel (u, v), from the optical centre, in the body frame.
    pub fn ray(&self, pixel: DVec2) -> CameraRay {
        let optical = dvec3((pixel.x - self.cx) / self.fx, (pixel.y - self.cy) / self.fy, 1.0);
        CameraRay {
            origin: self.position,
            direction: (BODY_FROM_OPTICAL * optical).normalize(),
            t_min: 0.0,
        }
    }

    /// Depth z of every hit of `frame` (rendered by this camera at `pose`) along the optical
    /// axis, metres; +inf where nothing is hit. The `z` of DESIGN.md §2, for RGB-D users.
    pub fn axial_depth(&self, frame: &Frame, pose: &Pose) -> Vec<f32> {
        let world_from_body = pose.world_from_body_rotation();
        let centre = pose.position + world_from_body * self.position;
        let axis = world_from_body * (BODY_FROM_OPTICAL * DVec3::Z);
        frame
            .pixels()
            .iter()
            .map(|p| {
                if p.is_hit() {
                    axis.dot(p.point - centre) as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect()
    }

    /// Pixel of a body-frame point; `None` behind the camera.
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        let optical = BODY_FROM_OPTICAL.transpose() * (point - self.position);
        (optical.z > 0.0).then(|| {
            dvec2(
                self.fx * optical.x / optical.z + self.cx,
                self.fy * optical.y / optical.z + self.cy,
            )
        })
    }
}
