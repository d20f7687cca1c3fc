//! Rays as the fast tracer's f32 stages read them: one ray broadcast to four lanes
//! ([`LaneRay`]), or a packet of up to [`PACKET`] rays eight to a batch with the bounds of its
//! origins and inverse directions ([`PacketRays`]).

use glam::{DVec3, Vec3, Vec3A, Vec4};
use obvhs::ray::safe_inverse;

use super::PACKET;
use super::groups::{RayLanes, position_error, position_errors};
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
    (t_min * T_LO_FACTOR) as f32
}

/// [`t_lo`]'s factor (shared with its four-lane twin, `StagedRays::set_four`).
const T_LO_FACTOR: f64 = 1.0 - 1e-6;

/// The f32 inverse of a direction, finite everywhere: obvhs's `safe_inverse` on each axis
/// (±2²³ for components within `f32::EPSILON` of zero, ±0 included), three lanes at once.
/// Keep in step with its eight-ray twin [`inverses`]: a packet's rays must be the single
/// rays' own, bit for bit (tested by `a_ray_taken_from_the_packet_is_the_single_rays_own`).
fn inverse(direction: Vec3) -> Vec3 {
    let d = Vec3A::from(direction);
    let tiny = d.abs().cmple(Vec3A::splat(f32::EPSILON));
    Vec3::from(Vec3A::select(tiny, d.signum() / f32::EPSILON, Vec3A::ONE / d))
}

/// [`inverse`] of eight direction components at once (the same operations lane by lane; keep
/// the two in step).
#[inline(always)]
fn inverses<W: Wide>(d: W) -> W {
    let tiny = d.abs().not_greater(W::splat(f32::EPSILON));
    (d.signum() / W::splat(f32::EPSILON)).keep(tiny, W::splat(1.0) / d)
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
    /// Per axis, the rays given to [`PacketRays::fill`] whose f32 direction has its sign bit
    /// set (−0 included), bit r for ray r.
    negative_rays: [u64; 3],
    /// The rays given to [`PacketRays::fill`] (the other lanes hold zero origins and
    /// directions).
    given: u64,
    /// The rays `bounds`, `origin_radius`, `spread` and `negative` are those of, set by
    /// [`PacketRays::narrow_to`] (none before): the rays a walk of the packet takes part in
    /// (`WideBvh::traverse_interval` reads them here, so bounds and walk cannot disagree).
    bounded: u64,
    pub(crate) bounds: PacketBounds,
}

/// A packet's rays converted to f32 axis by axis, as [`PacketRays::fill`] reads them: ray r
/// at index r, a zero ray where there is none. The tile loop converts each ray here as it
/// turns it (read back from the f64 rays and converted in `fill`, a ray cost ~10 instructions
/// more: docs/benchmarks.md, "2026-11-27 (walk)").
pub(crate) struct StagedRays {
    origin: [[f32; PACKET]; 3],
    direction: [[f32; PACKET]; 3],
    t_lo: [f32; PACKET],
}

impl Default for StagedRays {
    /// Zero rays only.
    fn default() -> Self {
        Self {
            origin: [[0.0; PACKET]; 3],
            direction: [[0.0; PACKET]; 3],
            t_lo: [0.0; PACKET],
        }
    }
}

impl StagedRays {
    /// The rays of `active` (scene-local origin, unit direction, `t_min`), zero rays for the
    /// others.
    #[inline(always)]
    pub(crate) fn of(rays: &[(DVec3, DVec3, f64); PACKET], active: u64) -> Self {
        let mut staged = Self::default();
        let mut rest = active;
        while rest != 0 {
            let r = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let (origin, direction, t_min) = rays[r];
            staged.set(r, origin, direction, t_min);
        }
        staged
    }

    /// Ray r: its origin and direction as f32 and its [`t_lo`]. Origins and directions must
    /// be finite (as ray tables and shadow rays make them): the eight-lane minima and maxima
    /// keep or drop a NaN by lane order, unlike `f32::min`.
    #[inline(always)]
    pub(crate) fn set(&mut self, r: usize, origin: DVec3, direction: DVec3, t_min: f64) {
        debug_assert!(
            origin.is_finite() && direction.is_finite(),
            "ray {r} is not finite: {origin}, {direction}"
        );
        let (o, d) = (origin.as_vec3(), direction.as_vec3());
        for axis in 0..3 {
            self.origin[axis][r] = o[axis];
            self.direction[axis][r] = d[axis];
        }
        self.t_lo[r] = t_lo(t_min);
    }

    /// Rays r to r + 3: [`StagedRays::set`] of each from `origin` along `direction` (axis by
    /// axis, ray r + k in lane k) with `t_min`, lane by lane the same conversions (the same
    /// bits).
    ///
    /// # Safety
    /// The CPU has AVX2 (this is compiled into the tile loop's AVX2 build).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn set_four(
        &mut self,
        r: usize,
        origin: DVec3,
        direction: [std::arch::x86_64::__m256d; 3],
        t_min: std::arch::x86_64::__m256d,
    ) {
        use std::arch::x86_64::{_mm_set1_ps, _mm_storeu_ps, _mm256_cvtpd_ps, _mm256_mul_pd, _mm256_set1_pd};
        // Slices of four checked, then written whole (loops and plain calls, not closures,
        // which are compiled without AVX).
        let four = r..r + 4;
        let origin = origin.as_vec3();
        for axis in 0..3 {
            let (origins, directions) = (
                &mut self.origin[axis][four.clone()],
                &mut self.direction[axis][four.clone()],
            );
            // SAFETY: each store writes its slice's four f32s; AVX2 as the caller promises (the
            // conversion rounds to nearest, as `as f32` does).
            unsafe {
                _mm_storeu_ps(origins.as_mut_ptr(), _mm_set1_ps(origin[axis]));
                _mm_storeu_ps(directions.as_mut_ptr(), _mm256_cvtpd_ps(direction[axis]));
            }
        }
        let t_los = &mut self.t_lo[four];
        // SAFETY: as above: `t_lo`'s product and conversion, lane by lane.
        unsafe {
            _mm_storeu_ps(
                t_los.as_mut_ptr(),
                _mm256_cvtpd_ps(_mm256_mul_pd(t_min, _mm256_set1_pd(T_LO_FACTOR))),
            );
        }
    }

    /// Ray r's f32 origin, direction and `t_lo`, as bits.
    #[cfg(test)]
    pub(crate) fn bits(&self, r: usize) -> [u32; 7] {
        let axes = |values: &[[f32; PACKET]; 3]| [0, 1, 2].map(|axis| values[axis][r].to_bits());
        let ([ox, oy, oz], [dx, dy, dz]) = (axes(&self.origin), axes(&self.direction));
        [ox, oy, oz, dx, dy, dz, self.t_lo[r].to_bits()]
    }

    /// Whether ray r is a zero ray (what [`PacketRays::fill`] asks of the rays it leaves out).
    fn is_zero(&self, r: usize) -> bool {
        (0..3).all(|axis| self.origin[axis][r] == 0.0 && self.direction[axis][r] == 0.0) && self.t_lo[r] == 0.0
    }

    /// Ray r made a zero ray (a pixel without a ray).
    #[inline(always)]
    pub(crate) fn clear(&mut self, r: usize) {
        for axis in 0..3 {
            self.origin[axis][r] = 0.0;
            self.direction[axis][r] = 0.0;
        }
        self.t_lo[r] = 0.0;
    }
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
    /// A packet of no rays, to be [`PacketRays::fill`]ed: made once and refilled for each
    /// packet, since a packet made anew each time was copied whole out of its constructor
    /// (callgrind, env1 omni 250²: ~400 instructions a packet; docs/benchmarks.md,
    /// "2026-11-27 (walk)").
    #[inline(always)]
    pub(crate) fn empty() -> Self {
        let zero = W::splat(0.0);
        Self {
            batches: [RayLanes {
                origin: [zero; 3],
                direction: [zero; 3],
                position_error: zero,
            }; BATCHES],
            t_lo: [zero; BATCHES],
            inverse: [[zero; 3]; BATCHES],
            negative_rays: [0; 3],
            given: 0,
            bounded: 0,
            origin_radius: 0.0,
            spread: 0.0,
            negative: [false; 3],
            bounds: PacketBounds {
                origin_min: Vec3::ZERO,
                origin_max: Vec3::ZERO,
                inverse_min: Vec3::ZERO,
                inverse_max: Vec3::ZERO,
            },
        }
    }

    /// The packet of `rays` and `active` as [`PacketRays::fill`] makes it from their
    /// [`StagedRays::of`].
    #[cfg(test)]
    pub(crate) fn new(rays: &[(DVec3, DVec3, f64); PACKET], active: u64, scene_extent: f32) -> Self {
        let mut packet = Self::empty();
        packet.fill(&StagedRays::of(rays, active), active, scene_extent);
        packet
    }

    /// Makes the packet that of the rays of `staged` whose bit is set in `active`, at least
    /// one (the other rays of `staged` must be zero rays, and stay masked); `scene_extent` as
    /// for [`LaneRay::new`]. Bounds none of them until [`PacketRays::narrow_to`] picks the rays
    /// a walk takes (an octant of a packet over several is all some walk needs, so `fill` does
    /// not find the whole packet's bounds only to have them replaced).
    /// Always inlined: called from the walk compiled with AVX2, it must be compiled there too
    /// (out of line it is built for the baseline CPU, its lane intrinsics become calls, and an
    /// env1 omni image took 7 % more instructions).
    #[inline(always)]
    pub(crate) fn fill(&mut self, staged: &StagedRays, active: u64, scene_extent: f32) {
        // Every caller skips empty packets (their boxes would be empty: infinite bounds).
        debug_assert!(active != 0, "a packet without rays");
        debug_assert!(
            (0..PACKET).all(|r| active >> r & 1 != 0 || staged.is_zero(r)),
            "a staged ray outside the packet is not a zero ray"
        );
        // Each ray was converted once (`StagedRays::set`), whatever octants the packet spans;
        // all else (inverses, error bounds, and the bounds, signs and octants of `narrow_to`
        // and `octants`) is found eight lanes at a time: per ray and axis it cost more than
        // the conversion (callgrind: docs/benchmarks.md).
        // Loops, not `array::from_fn`, whose closures are compiled outside the AVX2 walk (their
        // loads became calls, and the arrays were copied: callgrind, env1-lit omni). The
        // batches are filled in the packet itself: filled in lists of their own and moved in,
        // they were copied once a packet (docs/benchmarks.md, "2026-11-26 night (small)").
        self.negative_rays = [0; 3];
        for b in 0..BATCHES {
            let batch = |values: &[f32; PACKET]| W::load(&values[8 * b..]);
            let lanes = &mut self.batches[b];
            for axis in 0..3 {
                lanes.origin[axis] = batch(&staged.origin[axis]);
                lanes.direction[axis] = batch(&staged.direction[axis]);
                self.inverse[b][axis] = inverses(lanes.direction[axis]);
                self.negative_rays[axis] |= u64::from(lanes.direction[axis].sign_bits()) << (8 * b);
            }
            lanes.position_error = position_errors(&lanes.origin, scene_extent);
            self.t_lo[b] = batch(&staged.t_lo);
        }
        for bits in &mut self.negative_rays {
            *bits &= active;
        }
        self.given = active;
        // No rays bounded yet: a walk before `narrow_to` walks none.
        self.bounded = 0;
    }

    /// The rays the packet's bounds are those of ([`PacketRays::narrow_to`]'s last `rays_in`;
    /// none before): the rays a walk of the packet takes part in.
    #[inline(always)]
    pub(crate) fn bounded(&self) -> u64 {
        self.bounded
    }

    /// The rays given to [`PacketRays::fill`] by the octant of their f32 direction (sign bits,
    /// −0 negative): bit r of entry k where ray r's x, y, z signs are k's bits 0, 1, 2.
    #[inline(always)]
    pub(crate) fn octants(&self) -> [u64; 8] {
        let [x, y, z] = self.negative_rays;
        let mut octants = [0u64; 8];
        for (k, octant) in octants.iter_mut().enumerate() {
            let side = |negative: u64, bit: usize| if k >> bit & 1 != 0 { negative } else { !negative };
            *octant = self.given & side(x, 0) & side(y, 1) & side(z, 2);
        }
        octants
    }

    /// Sets the packet's bounds, footprint and signs to those of the rays of `rays_in` (some
    /// of those given to [`PacketRays::fill`], at least one): the rays a walk takes part in.
    #[inline(always)]
    pub(crate) fn narrow_to(&mut self, rays_in: u64) {
        debug_assert!(rays_in != 0, "a packet without rays");
        debug_assert_eq!(rays_in & !self.given, 0, "rays not given to the packet");
        let (low, high) = (W::splat(f32::INFINITY), W::splat(f32::NEG_INFINITY));
        let (mut origin_min, mut origin_max) = ([low; 3], [high; 3]);
        let (mut direction_min, mut direction_max) = ([low; 3], [high; 3]);
        for b in 0..BATCHES {
            let lanes = (rays_in >> (8 * b)) as u32 & 0xff;
            if lanes == 0 {
                continue;
            }
            let batch = &self.batches[b];
            for axis in 0..3 {
                let (o, d) = (batch.origin[axis], batch.direction[axis]);
                origin_min[axis] = origin_min[axis].min(o.keep(lanes, low));
                origin_max[axis] = origin_max[axis].max(o.keep(lanes, high));
                direction_min[axis] = direction_min[axis].min(d.keep(lanes, low));
                direction_max[axis] = direction_max[axis].max(d.keep(lanes, high));
            }
        }
        let (origin_min, origin_max) = (across(&origin_min, f32::min), across(&origin_max, f32::max));
        let (direction_min, direction_max) = (across(&direction_min, f32::min), across(&direction_max, f32::max));
        // Per axis, whether some direction has its sign bit set, and whether some has it clear.
        let negative = self.negative_rays.map(|bits| bits & rays_in != 0);
        let positive = self.negative_rays.map(|bits| !bits & rays_in != 0);
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
        self.spread = if chord < 0.99 {
            chord / (1.0 - chord * chord).sqrt()
        } else {
            f32::INFINITY
        };
        self.origin_radius = (origin_max - origin_min).length() / 2.0;
        self.negative = negative;
        self.bounded = rays_in;
        self.bounds = PacketBounds {
            origin_min,
            origin_max,
            inverse_min,
            inverse_max,
        };
    }

    /// Ray r as [`LaneRay::new`] and [`t_lo`] make it, for a single-ray walk of a subtree: the
    /// same f32 values, taken from the packet's lanes instead of converted and inverted again.
    /// r must be one of the rays the packet is narrowed to (the walk's): another lane holds a
    /// zero ray or one of another octant.
    #[inline(always)]
    pub(crate) fn single(&self, r: usize) -> (LaneRay, f32) {
        let (b, k) = (r / 8, r % 8);
        let batch = &self.batches[b];
        debug_assert!(self.bounded >> r & 1 != 0, "ray {r} is not in the walk");
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

/// Per axis, `pick` over the eight lanes in lane order (the minimum or maximum of a packet's
/// rays). Loops, not closures, iterators or `array::map`, for the reason given at
/// [`splat_lane`]; `pick` is a constant at each (always inlined) call.
#[inline(always)]
fn across<W: Wide>(axes: &[W; 3], pick: fn(f32, f32) -> f32) -> Vec3 {
    let mut picked = Vec3::ZERO;
    for axis in 0..3 {
        let lanes = axes[axis].to_array();
        let mut value = lanes[0];
        for &lane in &lanes[1..] {
            value = pick(value, lane);
        }
        picked[axis] = value;
    }
    picked
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

    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// A packet of random rays: directions with signed-zero and tiny components, origins up
    /// to 1,500 from the origin (beyond the extents the tests draw, 1 to 1,000).
    fn random_rays(rng: &mut StdRng) -> [(DVec3, DVec3, f64); PACKET] {
        std::array::from_fn(|_| {
            let mut direction = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
            match rng.random_range(0..8) {
                0 => direction[rng.random_range(0..3)] = 0.0,
                1 => direction[rng.random_range(0..3)] = -0.0,
                2 => direction[rng.random_range(0..3)] = -1e-9,
                3 => direction[rng.random_range(0..3)] = 1e-9,
                _ => {}
            }
            let origin = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1500.0..1500.0)));
            (origin, direction.normalize(), rng.random_range(0.0..0.01))
        })
    }

    /// What a packet narrowed to the rays of `rays_in` says of them: its bounds, footprint,
    /// signs, as bits. Always inlined, so that on AVX lanes it is compiled into the AVX2
    /// function that calls it (`octant_bounds_avx`).
    #[inline(always)]
    fn narrowed_bits<W: Wide>(packet: &mut PacketRays<W>, rays_in: u64) -> Vec<u32> {
        packet.narrow_to(rays_in);
        let b = &packet.bounds;
        [b.origin_min, b.origin_max, b.inverse_min, b.inverse_max]
            .iter()
            .flat_map(Vec3::to_array)
            .chain([packet.spread, packet.origin_radius])
            .map(f32::to_bits)
            .chain(packet.negative.map(u32::from))
            .collect()
    }

    /// A packet's octants and, narrowed to each, its bounds: [`narrowed_bits`] of the packet
    /// made of all of `active`, then of a packet made of the octant's rays alone. The first
    /// is refilled ([`PacketRays::fill`]) after a walk of every ray of `earlier`, as a tile's
    /// packet follows the one before it: nothing of those may remain.
    #[inline(always)]
    fn octant_bounds<W: Wide>(
        rays: &[(DVec3, DVec3, f64); PACKET],
        active: u64,
        earlier: &[(DVec3, DVec3, f64); PACKET],
    ) -> Vec<(u64, Vec<u32>, Vec<u32>)> {
        let mut packet = PacketRays::<W>::new(earlier, u64::MAX, 10.0);
        packet.narrow_to(u64::MAX);
        packet.fill(&StagedRays::of(rays, active), active, 10.0);
        let mut found = Vec::new();
        // A loop, not a closure: every `W` operation stays in the caller (AVX2 where it is).
        for rays_in in packet.octants() {
            if rays_in != 0 {
                let alone = narrowed_bits(&mut PacketRays::<W>::new(rays, rays_in, 10.0), rays_in);
                found.push((rays_in, narrowed_bits(&mut packet, rays_in), alone));
                assert_eq!(packet.bounded(), rays_in);
            }
        }
        found
    }

    /// [`octant_bounds`] on the AVX lanes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn octant_bounds_avx(
        rays: &[(DVec3, DVec3, f64); PACKET],
        active: u64,
        earlier: &[(DVec3, DVec3, f64); PACKET],
    ) -> Vec<(u64, Vec<u32>, Vec<u32>)> {
        octant_bounds::<crate::trace::fast::lanes::Avx8>(rays, active, earlier)
    }

    /// A packet's octants hold each of its rays once, by the sign bits of its f32 direction
    /// (−0 negative); narrowed to an octant, the packet's origin and inverse-direction bounds
    /// are the extremes of those rays' own (`LaneRay::new`'s), its signs theirs, its footprint
    /// (`origin_radius`, `spread`) the half-diagonals of their origins' and directions' boxes,
    /// and all it says is what a packet of those rays alone says, though the packet was
    /// refilled after other rays. Portable lanes and, where the CPU has AVX2, AVX ones (the
    /// same answers).
    #[test]
    fn a_packet_narrowed_to_an_octant_bounds_its_rays_alone() {
        let mut rng = StdRng::seed_from_u64(9);
        let mut split = 0;
        for _ in 0..300 {
            let rays = random_rays(&mut rng);
            let earlier = random_rays(&mut rng);
            let active = rng.random::<u64>() | 1;
            let portable = octant_bounds::<crate::trace::fast::lanes::Lanes8>(&rays, active, &earlier);
            assert_eq!(portable.iter().fold(0, |all, (rays_in, ..)| all | rays_in), active);
            assert_eq!(
                portable.iter().map(|(rays_in, ..)| rays_in.count_ones()).sum::<u32>(),
                active.count_ones()
            );
            split += usize::from(portable.len() > 1);
            for (rays_in, narrowed, alone) in &portable {
                assert_eq!(narrowed, alone, "octant {rays_in:#x}");
                let singles: Vec<_> = (0..PACKET)
                    .filter(|r| rays_in >> r & 1 == 1)
                    .map(|r| {
                        (
                            rays[r].0.as_vec3(),
                            rays[r].1.as_vec3(),
                            LaneRay::new(rays[r].0, rays[r].1, 10.0),
                        )
                    })
                    .collect();
                let inverse = |(_, _, ray): &(Vec3, Vec3, LaneRay)| Vec3::from_array(ray.inv_direction.map(|v| v.x));
                let extreme = |values: Vec<Vec3>| {
                    let low = values.iter().fold(Vec3::INFINITY, |m, &v| m.min(v));
                    let high = values.iter().fold(Vec3::NEG_INFINITY, |m, &v| m.max(v));
                    [low, high].iter().flat_map(Vec3::to_array).collect::<Vec<_>>()
                };
                let origins = extreme(singles.iter().map(|s| s.0).collect());
                let inverses = extreme(singles.iter().map(inverse).collect());
                let directions = extreme(singles.iter().map(|s| s.1).collect());
                let got = |k: usize| f32::from_bits(narrowed[k]);
                // Half-diagonals of the boxes of the rays' origins and directions; the spread is
                // the tangent whose sine is the directions' (∞ from 0.99 on).
                let half_diagonal = |low_high: &[f32]| {
                    (Vec3::from_slice(&low_high[3..]) - Vec3::from_slice(&low_high[..3])).length() / 2.0
                };
                let chord = half_diagonal(&directions);
                let spread = if chord < 0.99 {
                    (chord.asin()).tan()
                } else {
                    f32::INFINITY
                };
                let (got_spread, got_radius) = (got(12), got(13));
                assert_eq!(
                    got_radius,
                    half_diagonal(&origins),
                    "octant {rays_in:#x}: origin radius"
                );
                assert!(
                    got_spread == spread || (got_spread - spread).abs() <= 1e-4 * spread.max(1.0),
                    "octant {rays_in:#x}: spread {got_spread}, want {spread}"
                );
                for axis in 0..3 {
                    let signs: Vec<bool> = singles.iter().map(|s| s.1[axis].is_sign_negative()).collect();
                    assert!(signs.iter().all(|&n| n == signs[0]), "octant {rays_in:#x}: mixed signs");
                    assert_eq!(narrowed[14 + axis], u32::from(signs[0]), "octant {rays_in:#x}: sign");
                    assert_eq!(got(axis), origins[axis], "origin min");
                    assert_eq!(got(3 + axis), origins[3 + axis], "origin max");
                    assert_eq!(got(6 + axis), inverses[axis], "inverse min");
                    assert_eq!(got(9 + axis), inverses[3 + axis], "inverse max");
                }
            }
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: called only where the CPU has AVX2.
                assert_eq!(
                    unsafe { octant_bounds_avx(&rays, active, &earlier) },
                    portable,
                    "AVX lanes"
                );
            }
        }
        assert!(split > 250, "{split} packets over several octants");
    }

    /// Ray r taken from a packet's lanes is the ray `LaneRay::new` and `t_lo` make, bit for
    /// bit: every lane of every batch, rays left out of the packet around it, signed-zero and
    /// tiny direction components, origins beyond the extent, on the portable lanes and (where the CPU has AVX2) the AVX ones.
    #[test]
    fn a_ray_taken_from_the_packet_is_the_single_rays_own() {
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..200 {
            let rays = random_rays(&mut rng);
            let active = rng.random::<u64>() | 1;
            let extent = rng.random_range(1.0..1000.0);
            let mut portable = PacketRays::<crate::trace::fast::lanes::Lanes8>::new(&rays, active, extent);
            portable.narrow_to(active);
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
        let mut packet = PacketRays::<crate::trace::fast::lanes::Avx8>::new(rays, active, extent);
        packet.narrow_to(active);
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
