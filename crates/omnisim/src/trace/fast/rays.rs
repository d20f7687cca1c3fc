//! Rays as the fast tracer's f32 stages read them: one ray broadcast to four lanes
//! ([`LaneRay`]), or a packet of up to [`PACKET`] rays eight to a batch with the bounds of its
//! origins and inverse directions ([`PacketRays`]).

use glam::{DVec3, Vec3, Vec4};
use obvhs::ray::safe_inverse;

use super::PACKET;
use super::groups::{RayLanes, position_error};
use super::lanes::Wide;

/// A ray broadcast to four lanes, for the single-ray walk.
pub(crate) struct LaneRay {
    pub(crate) lanes: RayLanes<Vec4>,
    pub(crate) inv_direction: [Vec4; 3],
}

impl LaneRay {
    /// `scene_extent` is the largest absolute coordinate of any triangle (scene-local).
    pub(crate) fn new(origin: DVec3, direction: DVec3, scene_extent: f32) -> Self {
        let o = origin.as_vec3();
        let d = direction.as_vec3();
        let splat = |v: Vec3| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Self {
            lanes: RayLanes {
                origin: splat(o),
                direction: splat(d),
                position_error: Vec4::splat(position_error(o, scene_extent)),
            },
            inv_direction: splat(inverse(d)),
        }
    }
}

/// A ray's `t_min` as the f32 filter's lower bound, rounded down so that the filter never
/// drops a triangle just beyond it.
pub(crate) fn t_lo(t_min: f64) -> f32 {
    (t_min * (1.0 - 1e-6)) as f32
}

/// The f32 inverse of a direction, finite everywhere (obvhs's `safe_inverse`: ±2²³ for ±0).
fn inverse(direction: Vec3) -> Vec3 {
    Vec3::new(
        safe_inverse(direction.x),
        safe_inverse(direction.y),
        safe_inverse(direction.z),
    )
}

/// Batches of eight rays in a packet.
pub(crate) const BATCHES: usize = PACKET / 8;

/// A packet of rays, rays 8b to 8b + 7 in batch b of eight `W` lanes, with its interval
/// bounds.
pub(crate) struct PacketRays<W> {
    pub(crate) batches: [RayLanes<W>; BATCHES],
    /// Each ray's [`t_lo`].
    pub(crate) t_lo: [W; BATCHES],
    pub(crate) bounds: PacketBounds,
}

/// Per axis, bounds of the f32 origin coordinates and inverse directions of a packet's rays:
/// what the interval box test (`wide.rs`) needs to admit a box any of them enters. The origin
/// bounds are the extremes; the inverse bounds are too where the directions share a sign on
/// that axis, and ±2²³ (every inverse obvhs returns) where they do not.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PacketBounds {
    pub(crate) origin_min: Vec3,
    pub(crate) origin_max: Vec3,
    pub(crate) inverse_min: Vec3,
    pub(crate) inverse_max: Vec3,
}

impl PacketBounds {
    /// Whether every ray's direction has the same sign as the others' on each axis. Only
    /// then is the interval test tight: a sign change puts both infinities in the range.
    pub(crate) fn same_signs(&self) -> bool {
        (self.inverse_min.cmpgt(Vec3::ZERO) | self.inverse_max.cmplt(Vec3::ZERO)).all()
    }
}

impl<W: Wide> PacketRays<W> {
    /// The rays (scene-local origin, unit direction, `t_min`) whose bit is set in `active`
    /// (the others are zero and must stay masked); `scene_extent` as for [`LaneRay::new`].
    pub(crate) fn new(rays: &[(DVec3, DVec3, f64); PACKET], active: u64, scene_extent: f32) -> Self {
        let mut origin = [[0.0f32; PACKET]; 3];
        let mut direction = [[0.0f32; PACKET]; 3];
        let mut error = [0.0f32; PACKET];
        let mut t_lo = [0.0f32; PACKET];
        let (mut origin_min, mut origin_max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut direction_min, mut direction_max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        // Per axis, whether some direction has its sign bit set, and whether some has it clear.
        let (mut negative, mut positive) = ([false; 3], [false; 3]);
        let mut rest = active;
        while rest != 0 {
            let r = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let (o, d, t_min) = rays[r];
            let (o, d) = (o.as_vec3(), d.as_vec3());
            for axis in 0..3 {
                origin[axis][r] = o[axis];
                direction[axis][r] = d[axis];
            }
            error[r] = position_error(o, scene_extent);
            t_lo[r] = self::t_lo(t_min);
            origin_min = origin_min.min(o);
            origin_max = origin_max.max(o);
            direction_min = direction_min.min(d);
            direction_max = direction_max.max(d);
            for axis in 0..3 {
                negative[axis] |= d[axis].is_sign_negative();
                positive[axis] |= !d[axis].is_sign_negative();
            }
        }
        // `safe_inverse` does not increase over either sign's directions (±0 included), so on
        // an axis where all share a sign the extreme directions give the extreme inverses
        // without a division per ray; with both signs, every inverse obvhs can return.
        let largest = 1.0 / f32::EPSILON;
        let (mut inverse_min, mut inverse_max) = (Vec3::splat(-largest), Vec3::splat(largest));
        for axis in 0..3 {
            if !(negative[axis] && positive[axis]) {
                inverse_min[axis] = safe_inverse(direction_max[axis]);
                inverse_max[axis] = safe_inverse(direction_min[axis]);
            }
        }
        let batch = |values: &[f32; PACKET], b: usize| W::load(&values[8 * b..]);
        Self {
            batches: std::array::from_fn(|b| RayLanes {
                origin: std::array::from_fn(|axis| batch(&origin[axis], b)),
                direction: std::array::from_fn(|axis| batch(&direction[axis], b)),
                position_error: batch(&error, b),
            }),
            t_lo: std::array::from_fn(|b| batch(&t_lo, b)),
            bounds: PacketBounds {
                origin_min,
                origin_max,
                inverse_min,
                inverse_max,
            },
        }
    }
}
