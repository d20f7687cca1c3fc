//! Rigid poses: where a camera's viewpoint is and how it is turned.
//!
//! Rotations follow the reference paper: `R = Rx(θx)·Ry(θy)·Rz(θz)`, applied to body-frame
//! vectors to give world-frame vectors (world_from_body). Body frame: x forward, y left, z up.

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

    /// 4×4 homogeneous world_from_body transform.
    pub fn world_from_body(&self) -> DMat4 {
        DMat4::from_mat3_translation(self.world_from_body_rotation(), self.position)
    }

    /// Unit quaternion of world_from_body, (x, y, z, w) as in TUM trajectory files, w ≥ 0.
    pub fn quaternion_xyzw(&self) -> [f64; 4] {
        let q = DQuat::from_mat3(&self.world_from_body_rotation()).normalize();
        let q = if q.w < 0.0 { -q } else { q };
        [q.x, q.y, q.z, q.w]
    }

    /// (θx, θy, θz) in degrees.
    pub fn angles_degrees(&self) -> DVec3 {
        self.angles * (180.0 / std::f64::consts::PI)
    }
}
