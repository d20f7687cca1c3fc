//! Warnings about renders that succeed but are probably not what was meant: poses outside the
//! scene or inside furniture, and images that see nothing.

use omnisim::advanced::SceneBvh;
use omnisim::pose_sets::{Misplaced, misplaced};
use omnisim::{Frame, Pose, Scene};

/// Most poses named one by one in a warning; the rest are counted.
const LISTED: usize = 5;

/// Warns (on stderr) about poses outside the scene's bounds or inside one of its boxes.
pub(crate) fn misplaced_poses(scene: &Scene, geometry: &SceneBvh, poses: &[Pose]) -> anyhow::Result<()> {
    let found: Vec<(usize, Misplaced)> = poses
        .iter()
        .enumerate()
        .filter_map(|(index, pose)| Some((index, misplaced(scene, geometry, pose.position)?)))
        .collect();
    for (index, place) in found.iter().take(LISTED) {
        let p = poses[*index].position;
        let what = match place {
            Misplaced::OutsideBounds => "is outside the scene's bounds".to_string(),
            Misplaced::Inside(object) => format!("is inside '{object}'"),
        };
        crate::streams::stderr(format_args!(
            "warning: pose {index} at ({}, {}, {}) {what}",
            p.x, p.y, p.z
        ))?;
    }
    if found.len() > LISTED {
        crate::streams::stderr(format_args!(
            "warning: {} more poses are outside the scene or inside an object",
            found.len() - LISTED
        ))?;
    }
    Ok(())
}

/// Warns when a rendered image sees nothing (its point cloud would be empty).
pub(crate) fn empty_frame(index: usize, view: &str, frame: &Frame) -> anyhow::Result<()> {
    if !frame.pixels().iter().any(omnisim::advanced::Pixel::is_hit) {
        crate::streams::stderr(format_args!(
            "warning: pose {index}{view} sees nothing: the image is black and the point cloud empty"
        ))?;
    }
    Ok(())
}
