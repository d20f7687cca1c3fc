//! What a pose is rendered with: one camera, or a stereo pair of two. A rig yields its
//! [`View`]s, the images one pose produces, each with the file-name suffix that tells its
//! files apart.

use super::{Camera, StereoRig};

/// The vision system of a render or data set: one camera, or a rectified stereo pair.
#[derive(Debug, Clone, PartialEq)]
pub enum Rig {
    /// One image per pose.
    Single(Camera),
    /// Two images per pose (left and right), and the left image's disparity where the pair
    /// is rectified ideal pinholes.
    Stereo(StereoRig),
}

/// One image of a pose: the camera that takes it and the suffix of its files.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// File-name suffix after the frame's stem: `""` for a single camera, `"-left"` and
    /// `"-right"` for a stereo pair.
    pub suffix: &'static str,
    /// The camera, placed in the body frame.
    pub camera: Camera,
}

impl Rig {
    /// The images one pose produces, in the order they are rendered and written.
    pub fn views(&self) -> Vec<View> {
        match self {
            Rig::Single(camera) => vec![View {
                suffix: "",
                camera: camera.clone(),
            }],
            Rig::Stereo(stereo) => {
                let [left, right] = stereo.cameras();
                vec![
                    View {
                        suffix: "-left",
                        camera: left,
                    },
                    View {
                        suffix: "-right",
                        camera: right,
                    },
                ]
            }
        }
    }

    /// The first view's camera (the left one of a stereo pair): what a single-image tool,
    /// such as a benchmark, measures.
    pub fn first_camera(&self) -> Camera {
        match self {
            Rig::Single(camera) => camera.clone(),
            Rig::Stereo(stereo) => {
                let [left, _] = stereo.cameras();
                left
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Pinhole;

    #[test]
    fn a_stereo_rig_has_a_left_and_a_right_view_a_baseline_apart() {
        let rig = Rig::Stereo(StereoRig::rectified(Pinhole::with_horizontal_fov(64, 48, 1.0), 0.2));
        let views = rig.views();
        let suffixes: Vec<_> = views.iter().map(|v| v.suffix).collect();
        assert_eq!(suffixes, ["-left", "-right"]);
        let [Camera::Pinhole(left), Camera::Pinhole(right)] = [&views[0].camera, &views[1].camera] else {
            panic!("stereo views are pinholes")
        };
        assert_eq!(left.position.y - right.position.y, 0.2);
        assert_eq!(rig.first_camera(), views[0].camera);
    }
}
