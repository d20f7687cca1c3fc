//! Rays as the fast tracer's f32 stages read them: one ray broadcast to four lanes
//! ([`LaneRay`]), or a packet of up to [`PACKET`] rays eight to a batch with the bounds of its
//! origins and inverse directions ([`PacketRays`]).

use glam::{DVec3, Vec3, Vec3A, Vec4};
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

/// The f32 inverse of a direction, finite everywhere: obvhs's `safe_inverse` on each axis
/// (±2²³ for components within `f32::EPSILON` of zero, ±0 included), three lanes at once.
fn inverse(direction: Vec3) -> Vec3 {
    let d = Vec3A::from(direction);
    let tiny = d.abs().cmple(Vec3A::splat(f32::EPSILON));
    Vec3::from(Vec3A::select(tiny, d.signum() / f32::EPSILON, Vec3A::ONE / d))
}

/// Batches of eight rays in a packet.
pub(crate) const BATCHES: usize = PACKET / 8;

/// A packet of rays, rays 8b to 8b + 7 in batch b of eight `W` lanes, with its interval
/// bounds.
pub(crate) struct PacketRays<W> {
    pub(crate) batches: [RayLanes<W>; BATCHES],
    /// Each ray's [`t_lo`].
    pub(crate) t_lo: [W; BATCHES],
    /// Each ray's f32 inverse direction per axis (as [`LaneRay`] holds it), for the per-ray
    /// box test of a leaf.
    pub(crate) inverse: [[W; 3]; BATCHES],
    /// Half the largest distance between the rays' origins (bounding-box diagonal).
    pub(crate) origin_radius: f32,
    /// About the tangent of the packet's half-angle (from the box of its directions; ∞ beyond
    /// about 80°): its footprint grows by this much per metre.
    pub(crate) spread: f32,
    /// Per axis, whether some ray's direction has its sign bit set: all of them do where the
    /// packet's rays share their signs, as the walk asks (`PacketBounds::same_signs`).
    pub(crate) negative: [bool; 3],
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
    /// The rays (scene-local origin, unit direction, `t_min`) whose bit is set in `active`, at
    /// least one (the others are zero and must stay masked); `scene_extent` as for [`LaneRay::new`].
    /// Always inlined: called from the walk compiled with AVX2, it must be compiled there too
    /// (out of line it is built for the baseline CPU, its lane intrinsics become calls, and an
    /// env1 omni image took 7 % more instructions).
    #[inline(always)]
    pub(crate) fn new(rays: &[(DVec3, DVec3, f64); PACKET], active: u64, scene_extent: f32) -> Self {
        // Every caller skips empty packets (their boxes would be empty: infinite bounds).
        debug_assert!(active != 0, "a packet without rays");
        let mut origin = [[0.0f32; PACKET]; 3];
        let mut direction = [[0.0f32; PACKET]; 3];
        let mut error = [0.0f32; PACKET];
        let mut t_lo = [0.0f32; PACKET];
        let mut inverse_lanes = [[0.0f32; PACKET]; 3];
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
            let inv = inverse(d);
            for axis in 0..3 {
                origin[axis][r] = o[axis];
                direction[axis][r] = d[axis];
                inverse_lanes[axis][r] = inv[axis];
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
        // The directions' box, half its diagonal: at least the chord from its centre to any
        // direction, so about the sine of the packet's half-angle (only a heuristic reads it).
        let chord = (direction_max - direction_min).length() / 2.0;
        let spread = if chord < 0.99 {
            chord / (1.0 - chord * chord).sqrt()
        } else {
            f32::INFINITY
        };
        // Loops, not `array::from_fn`, whose closures are compiled outside the AVX2 walk (their
        // loads became calls, and the arrays were copied: callgrind, env1-lit omni).
        let zero = W::splat(0.0);
        let mut batches = [RayLanes {
            origin: [zero; 3],
            direction: [zero; 3],
            position_error: zero,
        }; BATCHES];
        let (mut t_lo_lanes, mut inverse) = ([zero; BATCHES], [[zero; 3]; BATCHES]);
        for b in 0..BATCHES {
            let batch = |values: &[f32; PACKET]| W::load(&values[8 * b..]);
            for axis in 0..3 {
                batches[b].origin[axis] = batch(&origin[axis]);
                batches[b].direction[axis] = batch(&direction[axis]);
                inverse[b][axis] = batch(&inverse_lanes[axis]);
            }
            batches[b].position_error = batch(&error);
            t_lo_lanes[b] = batch(&t_lo);
        }
        Self {
            batches,
            t_lo: t_lo_lanes,
            inverse,
            origin_radius: (origin_max - origin_min).length() / 2.0,
            spread,
            negative,
            bounds: PacketBounds {
                origin_min,
                origin_max,
                inverse_min,
                inverse_max,
            },
        }
    }

    /// Ray r as [`LaneRay::new`] and [`t_lo`] make it, for a single-ray walk of a subtree: the
    /// same f32 values, taken from the packet's lanes instead of converted and inverted again.
    /// r must be one of the rays `new` was given in `active`: another lane holds a zero ray.
    #[inline(always)]
    pub(crate) fn single(&self, r: usize) -> (LaneRay, f32) {
        let (b, k) = (r / 8, r % 8);
        let batch = &self.batches[b];
        debug_assert!(self.inverse[b][0].lane(k) != 0.0, "ray {r} is not in the packet");
        let ray = LaneRay {
            lanes: RayLanes {
                origin: splat_lane(&batch.origin, k),
                direction: splat_lane(&batch.direction, k),
                position_error: Vec4::splat(batch.position_error.lane(k)),
            },
            inv_direction: splat_lane(&self.inverse[b], k),
        };
        (ray, self.t_lo[b].lane(k))
    }
}

/// Lane k of each axis, spread over a single ray's four lanes. A function, not a closure or
/// `array::map`: those were compiled outside the AVX2 walk, and their lanes became calls.
#[inline(always)]
fn splat_lane<W: Wide>(axes: &[W; 3], k: usize) -> [Vec4; 3] {
    [
        Vec4::splat(axes[0].lane(k)),
        Vec4::splat(axes[1].lane(k)),
        Vec4::splat(axes[2].lane(k)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a `LaneRay` as bits, lane by lane, and its `t_lo`.
    fn bits((ray, t_lo): &(LaneRay, f32)) -> Vec<u32> {
        let lanes = &ray.lanes;
        [lanes.origin, lanes.direction, ray.inv_direction]
            .iter()
            .flatten()
            .chain([&lanes.position_error])
            .flat_map(Vec4::to_array)
            .chain([*t_lo])
            .map(f32::to_bits)
            .collect()
    }

    /// Ray r taken from a packet's lanes is the ray `LaneRay::new` and `t_lo` make, bit for
    /// bit: every lane of every batch, rays left out of the packet around it, signed-zero and
    /// tiny direction components, origins beyond the extent, on the portable lanes and (where the CPU has AVX2) the AVX ones.
    #[test]
    fn a_ray_taken_from_the_packet_is_the_single_rays_own() {
        use rand::{Rng, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..200 {
            let rays: [(DVec3, DVec3, f64); PACKET] = std::array::from_fn(|_| {
                let mut direction = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
                match rng.random_range(0..8) {
                    0 => direction[rng.random_range(0..3)] = 0.0,
                    1 => direction[rng.random_range(0..3)] = -0.0,
                    2 => direction[rng.random_range(0..3)] = -1e-9,
                    3 => direction[rng.random_range(0..3)] = 1e-9,
                    _ => {}
                }
                // Origins reach 1,500 against extents of 1 to 1,000: some lie beyond the extent.
                let origin = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1500.0..1500.0)));
                (origin, direction.normalize(), rng.random_range(0.0..0.01))
            });
            let active = rng.random::<u64>() | 1;
            let extent = rng.random_range(1.0..1000.0);
            let portable = PacketRays::<crate::trace::fast::lanes::Lanes8>::new(&rays, active, extent);
            #[cfg(target_arch = "x86_64")]
            // SAFETY: called only where the CPU has AVX2.
            let avx =
                std::arch::is_x86_feature_detected!("avx2").then(|| unsafe { avx_singles(&rays, active, extent) });
            for r in (0..PACKET).filter(|r| active >> r & 1 == 1) {
                let want = bits(&(LaneRay::new(rays[r].0, rays[r].1, extent), t_lo(rays[r].2)));
                assert_eq!(bits(&portable.single(r)), want, "ray {r}");
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = &avx {
                    assert_eq!(avx[r], want, "ray {r}, AVX lanes");
                }
            }
        }
    }

    /// Each ray of a packet made on AVX lanes, taken out again, as [`bits`] (empty for a ray
    /// outside `active`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx_singles(rays: &[(DVec3, DVec3, f64); PACKET], active: u64, extent: f32) -> Vec<Vec<u32>> {
        let packet = PacketRays::<crate::trace::fast::lanes::Avx8>::new(rays, active, extent);
        (0..PACKET)
            .map(|r| {
                if active >> r & 1 == 1 {
                    bits(&packet.single(r))
                } else {
                    Vec::new()
                }
            })
            .collect()
    }

    /// The three-lane inverse is obvhs's `safe_inverse` bit for bit, zeros and tiny values
    /// of either sign included.
    #[test]
    fn the_inverse_is_safe_inverse_on_every_axis() {
        let values = [
            0.0,
            -0.0,
            f32::EPSILON,
            -f32::EPSILON,
            f32::EPSILON * 1.5,
            1e-30,
            -1e-30,
            0.3,
            -0.7,
            1.0,
            -1.0,
        ];
        for &x in &values {
            for &y in &values {
                let got = inverse(Vec3::new(x, y, -x));
                let want = [safe_inverse(x), safe_inverse(y), safe_inverse(-x)];
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.map(f32::to_bits),
                    "({x}, {y}, {})",
                    -x
                );
            }
        }
    }
}
