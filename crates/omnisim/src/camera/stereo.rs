use glam::dvec3;

use super::{Camera, LensModel, Pinhole};
use crate::frame::Frame;
use crate::pose::Pose;

/// Two identical cameras side by side, looking along body +x: the left one at +B/2 on body
/// y, the right one at −B/2. The pose is the rig's centre. Both share K (`camera`) and the
/// lens; the right camera is the left one moved by B along its own optical x (to the right),
/// so ideal pinholes (`lens: None`) are rectified by construction.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoRig {
    /// Size and K shared by both cameras (its `position` is ignored).
    pub camera: Pinhole,
    /// The lens of both cameras (a fisheye model, or a pinhole's distortion); `None`: ideal
    /// pinholes.
    pub lens: Option<LensModel>,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
}

/// Why a stereo rig writes no disparity, where it does not (render.json and the log say it).
pub const NO_DISPARITY: &str = "not written: ground-truth disparity is defined for a rectified pair of ideal \
     pinholes, and this pair has a lens. Each camera's calibration (calibration-*-left/right files, ray maps) \
     and the extrinsics (R, T in calibration-opencv-stereo.yaml; T_cn_cnm1 in calibration-kalibr.yaml) \
     describe it instead";

impl StereoRig {
    /// An ideal rectified pair of pinholes `baseline` metres apart.
    pub fn rectified(camera: Pinhole, baseline: f64) -> Self {
        Self {
            camera,
            lens: None,
            baseline,
        }
    }

    /// (left, right) size, K and optical centre in the body frame: the cameras without their
    /// lens.
    pub fn pinholes(&self) -> [Pinhole; 2] {
        [self.baseline / 2.0, -self.baseline / 2.0].map(|y| Pinhole {
            position: dvec3(0.0, y, 0.0),
            ..self.camera.clone()
        })
    }

    /// (left, right) cameras with their optical centres placed in the body frame.
    pub fn cameras(&self) -> [Camera; 2] {
        self.pinholes()
            .map(|pinhole| Camera::with_lens(pinhole, self.lens.clone()))
    }

    /// Whether the rig has ground-truth disparity: a rectified pair of ideal pinholes.
    pub fn has_disparity(&self) -> bool {
        self.lens.is_none()
    }

    /// Ground-truth disparity of the left image: `u_left` − `u_right` = fx·B/z, with z the depth of
    /// each hit along the left camera's optical axis; NaN where nothing is hit. `None` for a
    /// pair with a lens ([`NO_DISPARITY`]).
    pub fn disparity(&self, left: &Frame, pose: &Pose) -> Option<Vec<f32>> {
        if !self.has_disparity() {
            return None;
        }
        let [left_pinhole, _] = self.pinholes();
        let depths = left_pinhole.axial_depth(left, pose);
        Some(
            depths
                .into_iter()
                .map(|z| {
                    if z.is_finite() {
                        (self.camera.fx * self.baseline / f64::from(z)) as f32
                    } else {
                        f32::NAN
                    }
                })
                .collect(),
        )
    }
}
