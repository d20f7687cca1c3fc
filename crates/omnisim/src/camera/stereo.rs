use glam::dvec3;

use super::Pinhole;
use crate::frame::Frame;
use crate::pose::Pose;

/// Two identical pinholes side by side, looking along body +x: the left one at +B/2 on body
/// y, the right one at −B/2. The pose is the rig's centre. Rectified by construction: the
/// right camera is the left one moved by B along its own optical x (to the right).
#[derive(Debug, Clone, PartialEq)]
pub struct StereoRig {
    /// Intrinsics shared by both cameras (its `position` is ignored).
    pub camera: Pinhole,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
}

impl StereoRig {
    /// (left, right) cameras with their optical centres placed in the body frame.
    pub fn cameras(&self) -> [Pinhole; 2] {
        let place = |y: f64| Pinhole {
            position: dvec3(0.0, y, 0.0),
            ..self.camera.clone()
        };
        [place(self.baseline / 2.0), place(-self.baseline / 2.0)]
    }

    /// Ground-truth disparity of the left image: `u_left` − `u_right` = fx·B/z, with z the depth of
    /// each hit along the left camera's optical axis; NaN where nothing is hit.
    pub fn disparity(&self, left: &Frame, pose: &Pose) -> Vec<f32> {
        self.cameras()[0]
            .axial_depth(left, pose)
            .into_iter()
            .map(|z| {
                if z.is_finite() {
                    (self.camera.fx * self.baseline / f64::from(z)) as f32
                } else {
                    f32::NAN
                }
            })
            .collect()
    }
}
