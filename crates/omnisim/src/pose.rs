//! Rigid poses: where a camera's viewpoint is and how it is turned.
//!
//! Rotations follow the reference paper: `R = Rx(θx)·Ry(θy)·Rz(θz)`, applied to body-frame
//! vectors to give world-frame vectors (`world_from_body`). Body frame: x forward, y left, z up.

use glam::{DMat3, DMat4, DQuat, DVec3};

/// `Rx(θx)·Ry(θy)·Rz(θz)` of the reference paper (eqs. 8–11), angles in radians.
pub fn rotation_xyz(angles: DVec3) -> DMat3 {
    DMat3::from_rotation_x(angles.x) * DMat3::from_rotation_y(angles.y) * DMat3::from_rotation_z(angles.z)
}

/// A 6-DoF pose of the camera viewpoint (optical centre, or effective viewpoint F' of a
/// central mirror) in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Viewpoint position, world metres.
    pub position: DVec3,
    /// (θx, θy, θz) in radians, as typed by the user; kept so exports can repeat them.
    pub angles: DVec3,
}

impl Pose {
    /// A pose from a position (metres) and angles (radians).
    pub fn new(position: DVec3, angles: DVec3) -> Self {
        Self { position, angles }
    }

    /// Position in metres and angles in degrees, the way people type poses.
    pub fn from_degrees(position: DVec3, angles_deg: DVec3) -> Self {
        Self::new(position, angles_deg * (std::f64::consts::PI / 180.0))
    }

    /// The rotation `Rx(θx)·Ry(θy)·Rz(θz)` taking body-frame vectors to the world frame.
    pub fn world_from_body_rotation(&self) -> DMat3 {
        rotation_xyz(self.angles)
    }

    /// 4×4 homogeneous `world_from_body` transform.
    pub fn world_from_body(&self) -> DMat4 {
        DMat4::from_mat3_translation(self.world_from_body_rotation(), self.position)
    }

    /// Unit quaternion of `world_from_body`, (x, y, z, w) as in TUM trajectory files, w ≥ 0.
    pub fn quaternion_xyzw(&self) -> [f64; 4] {
        let q = DQuat::from_mat3(&self.world_from_body_rotation()).normalize();
        let q = if q.w < 0.0 { -q } else { q };
        [q.x, q.y, q.z, q.w]
    }

    /// Angles in degrees, rounded to 1e-9° (far below any meaning) so that 30° typed reads
    /// back as 30 in every file, not 29.999999999999996.
    pub fn angles_degrees(&self) -> DVec3 {
        (self.angles * (180.0 / std::f64::consts::PI)).map(|a| rounded(a, 1e9))
    }
}

/// `value` rounded to 1/`per_unit` (e.g. 1e6: micrometres of metres), −0 made 0: derived
/// numbers printed for people without float noise (2.3, not 2.3000000000000003).
pub fn rounded(value: f64, per_unit: f64) -> f64 {
    // Dividing by the exact integer `per_unit` (not multiplying by its inexact inverse) gives
    // the nearest float to the decimal, which prints as the decimal.
    (value * per_unit).round() / per_unit + 0.0
}

/// Positions are derived (grid steps, trajectories, random draws) to the micrometre.
pub const MICROMETRES: f64 = 1e6;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_numbers_print_without_noise() {
        assert_eq!(format!("{}", rounded(0.1 + 0.2, MICROMETRES)), "0.3");
        assert_eq!(format!("{}", rounded(-1e-17, MICROMETRES)), "0");
        let pose = Pose::new(DVec3::ZERO, glam::dvec3(0.0, 0.0, 30f64.to_radians() - 4e-16));
        assert_eq!(pose.angles_degrees().z.to_string(), "30");
    }
}
