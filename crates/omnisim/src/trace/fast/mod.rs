//! The fast CPU tracer: f32 traversal of an 8-wide BVH and a conservative f32 triangle filter,
//! with every hit decided and measured by the reference's f64 triangle test.
//!
//! The f32 stages only discard work: boxes are padded (`accel/mod.rs`) and the four-lane triangle
//! test (`groups.rs`) rejects a triangle only with a margin above its rounding error, so the
//! f64 test sees every triangle the reference tracer would accept. Faces, ranges and points
//! therefore equal the reference's; where two triangles lie at exactly the same f64 distance
//! (a ray along a shared edge) both apply the same rule (`triangle::wins`: lower face id,
//! then lower triangle), so the hit does not depend on the order the walk met them in.

mod groups;
mod lanes;
mod rays;
mod wide;

use glam::DVec3;

pub(crate) use wide::PACKET;

use crate::accel::SceneBvh;
use crate::trace::counts::Counter;
use crate::trace::triangle::{self, Hit, Visit};
use lanes::{Lanes8, Wide};
use rays::{LaneRay, PacketRays, StagedRays};

/// `avx` (a call of a build compiled with AVX2) where [`use_avx2`], else `plain`: the
/// dispatch of every walk here, an expression (`portable` read once). Its calls take plain
/// variables, so the `unsafe` covers the AVX2 call alone.
#[cfg(target_arch = "x86_64")]
macro_rules! by_cpu {
    ($portable:expr, $avx:expr, $plain:expr) => {
        if use_avx2($portable) {
            // SAFETY: `use_avx2` is true only where the CPU has AVX2, POPCNT and BMI1.
            unsafe { $avx }
        } else {
            $plain
        }
    };
}

/// [`by_cpu`] where no AVX2 build exists: always `plain`.
#[cfg(not(target_arch = "x86_64"))]
macro_rules! by_cpu {
    ($portable:expr, $avx:expr, $plain:expr) => {{
        let _: bool = $portable;
        $plain
    }};
}

/// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`: the same hit as
/// [`crate::trace::reference::closest_hit`], found faster. `portable` keeps to the portable box test even where
/// the CPU has AVX2 (the path of other machines, which tests exercise).
pub(crate) fn closest_hit<C: Counter>(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    counter: &mut C,
    portable: bool,
) -> Option<Hit> {
    by_cpu!(
        portable,
        closest_hit_avx2(bvh, origin, direction, t_min, counter),
        closest_hit_in::<false, C>(bvh, origin, direction, t_min, counter)
    )
}

/// Whether to run the AVX2 build of a walk: the CPU has AVX2 (and the bit instructions every
/// AVX2 CPU has, which the walks' builds also use: `popcnt`, `bmi1`) and the portable path was
/// not asked for (`CpuTracer::FastPortable`).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn use_avx2(portable: bool) -> bool {
    !portable
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("popcnt")
        && std::arch::is_x86_feature_detected!("bmi1")
}

/// [`closest_hit_in`] compiled with AVX2 (its box tests eight lanes wide, the rest in VEX
/// encoding). Callgrind, closest-hit search: see docs/benchmarks.md.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn closest_hit_avx2<C: Counter>(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    counter: &mut C,
) -> Option<Hit> {
    closest_hit_in::<true, C>(bvh, origin, direction, t_min, counter)
}

#[inline(always)]
fn closest_hit_in<const AVX: bool, C: Counter>(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    counter: &mut C,
) -> Option<Hit> {
    let ray = LaneRay::new(origin, direction, bvh.wide.extent);
    let mut best = None;
    let t_lo = rays::t_lo(t_min);
    bvh.wide
        .traverse::<AVX, C>(&ray, t_lo, f32::INFINITY, &bvh.triangles, counter, |triangle| {
            triangle::nearer(bvh, origin, direction, t_min, &mut best, triangle)
        });
    best
}

/// A packet of up to [`PACKET`] rays (bit r of `active` where ray r exists): each ray's
/// [`closest_hit`] written to `found[r]` (`None` for rays outside `active`), found by interval
/// walks of the packet (`portable` as there). Written into the caller's array, not returned:
/// the returned array was copied once a packet (docs/benchmarks.md, "2026-11-26 night (small)").
/// The rays are those [`PacketRoom::set`] put in `room`.
pub(crate) fn closest_hits(
    bvh: &SceneBvh,
    active: u64,
    portable: bool,
    found: &mut [Option<Hit>; PACKET],
    room: &mut PacketRoom,
) {
    by_cpu!(
        portable,
        closest_hits_avx2(bvh, active, found, room),
        closest_hits_in::<Lanes8>(
            bvh,
            &room.rays,
            active,
            found,
            room.portable.get_or_insert_with(PacketRays::empty),
            &room.staged
        )
    );
}

/// Room for the packets of [`closest_hits`], made once (a thread's, kept between its bands
/// of tiles) and refilled for each packet: a packet made anew each time was copied whole
/// (~400 instructions a packet; docs/benchmarks.md, "2026-11-27 (walk)"). The caller sets the
/// next packet's rays as it makes them ([`PacketRoom::set`], [`PacketRoom::clear`], four at a
/// time [`PacketRoom::set_four`]): each in f64, which decides hits, and in f32 (`staged`),
/// which the walk takes nodes by, written together so that they are the same rays. Each lane
/// type's packet is made on first use, in the walk compiled for it.
pub(crate) struct PacketRoom {
    /// The packet's rays in f64; entries of pixels without a ray are never read.
    pub(crate) rays: ExactRays,
    staged: StagedRays,
    #[cfg(target_arch = "x86_64")]
    avx: Option<PacketRays<lanes::Avx8>>,
    portable: Option<PacketRays<Lanes8>>,
}

impl Default for PacketRoom {
    fn default() -> Self {
        Self {
            rays: ExactRays {
                origin: [DVec3::ZERO; PACKET],
                along: [Along {
                    direction: DVec3::X,
                    t_min: 0.0,
                }; PACKET],
            },
            staged: StagedRays::default(),
            #[cfg(target_arch = "x86_64")]
            avx: None,
            portable: None,
        }
    }
}

impl PacketRoom {
    /// Ray r of the next packet.
    #[inline(always)]
    pub(crate) fn set(&mut self, r: usize, origin: DVec3, direction: DVec3, t_min: f64) {
        self.rays.origin[r] = origin;
        self.rays.along[r] = Along { direction, t_min };
        self.staged.set(r, origin, direction, t_min);
    }

    /// Rays r to r + 3 of the next packet, [`PacketRoom::set`] lane by lane (the same bits),
    /// from `origin` along `rays`' directions: those whose `t_min` is NaN (pixels without a
    /// ray in a central table) [`PacketRoom::clear`]ed. Returns the rays set, bit k for ray
    /// r + k.
    ///
    /// # Safety
    /// The CPU has AVX2 (this is compiled into the tile loop's AVX2 build).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn set_four(&mut self, r: usize, origin: DVec3, rays: &crate::trace::ray_table::FourRays) -> u32 {
        use std::arch::x86_64::{
            _CMP_UNORD_Q, _mm256_cmp_pd, _mm256_movemask_pd, _mm256_permute2f128_pd, _mm256_store_pd,
            _mm256_unpackhi_pd, _mm256_unpacklo_pd,
        };
        let [x, y, z] = rays.direction;
        let along = self.rays.along[r..r + 4].as_mut_ptr();
        // SAFETY: each store writes one `Along` of the four checked above (`row(k)`, k < 4), 32
        // bytes aligned to 32 (`repr(C)`: direction x, y, z, then `t_min`); AVX2 as the caller
        // promises.
        unsafe {
            let row = |k: usize| along.add(k).cast::<f64>();
            // [x0 y0 x2 y2], [x1 y1 x3 y3], [z0 t0 z2 t2], [z1 t1 z3 t3]: back to one ray a row.
            let (xy02, xy13) = (_mm256_unpacklo_pd(x, y), _mm256_unpackhi_pd(x, y));
            let (zt02, zt13) = (_mm256_unpacklo_pd(z, rays.t_min), _mm256_unpackhi_pd(z, rays.t_min));
            _mm256_store_pd(row(0), _mm256_permute2f128_pd::<0x20>(xy02, zt02));
            _mm256_store_pd(row(1), _mm256_permute2f128_pd::<0x20>(xy13, zt13));
            _mm256_store_pd(row(2), _mm256_permute2f128_pd::<0x31>(xy02, zt02));
            _mm256_store_pd(row(3), _mm256_permute2f128_pd::<0x31>(xy13, zt13));
        }
        self.rays.origin[r..r + 4].fill(origin);
        // SAFETY: AVX2 as the caller promises.
        unsafe { self.staged.set_four(r, origin, rays.direction, rays.t_min) };
        // SAFETY: AVX2 as the caller promises.
        let missing = unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(rays.t_min, rays.t_min)) } as u32;
        let mut rest = missing;
        while rest != 0 {
            self.clear(r + rest.trailing_zeros() as usize);
            rest &= rest - 1;
        }
        !missing & 0xf
    }

    /// Ray r as set: its f64 origin, direction and `t_min`, then its f32 staging, as bits.
    #[cfg(test)]
    pub(crate) fn bits(&self, r: usize) -> ([u64; 7], [u32; 7]) {
        let ([ox, oy, oz], [dx, dy, dz], t_min) = {
            let (origin, direction, t_min) = self.rays.ray(r);
            (origin.to_array(), direction.to_array(), t_min)
        };
        ([ox, oy, oz, dx, dy, dz, t_min].map(f64::to_bits), self.staged.bits(r))
    }

    /// No ray r in the next packet (a pixel without a ray, a lane past a tile's edge).
    #[inline(always)]
    pub(crate) fn clear(&mut self, r: usize) {
        self.staged.clear(r);
    }
}

/// A packet's rays in f64: ray r's scene-local origin, and its unit direction and `t_min`
/// side by side (one 256-bit row, so the tile loop writes four rays' in four stores).
pub(crate) struct ExactRays {
    origin: [DVec3; PACKET],
    along: [Along; PACKET],
}

/// A ray's direction and `t_min`: one 256-bit row, the layout of a central ray table's
/// entries (`CentralRay`), which `set_four` stores its rows in.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Along {
    direction: DVec3,
    t_min: f64,
}

const _: () = assert!(size_of::<Along>() == 32 && align_of::<Along>() == 32);

impl ExactRays {
    /// Ray r: origin, direction, `t_min`.
    #[inline(always)]
    pub(crate) fn ray(&self, r: usize) -> (DVec3, DVec3, f64) {
        let Along { direction, t_min } = self.along[r];
        (self.origin[r], direction, t_min)
    }
}

/// [`closest_hits_in`] compiled with AVX2, its leaf filter eight lanes in one register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn closest_hits_avx2(bvh: &SceneBvh, active: u64, found: &mut [Option<Hit>; PACKET], room: &mut PacketRoom) {
    let packet = room.avx.get_or_insert_with(PacketRays::empty);
    closest_hits_in::<lanes::Avx8>(bvh, &room.rays, active, found, packet, &room.staged);
}

#[inline(always)]
fn closest_hits_in<W: Wide>(
    bvh: &SceneBvh,
    rays: &ExactRays,
    active: u64,
    found: &mut [Option<Hit>; PACKET],
    packet: &mut PacketRays<W>,
    staged: &StagedRays,
) {
    let mut t_hi = [f32::INFINITY; PACKET];
    *found = [None; PACKET];
    walk_packet::<W>(
        bvh,
        packet,
        staged,
        active,
        &mut t_hi,
        #[inline(always)]
        |r, triangle| {
            let (origin, direction, t_min) = rays.ray(r);
            triangle::nearer(bvh, origin, direction, t_min, &mut found[r], triangle)
        },
    );
}

/// The interval walk of the rays of `active` (each within its f32 bound `t_hi`, which
/// `visit(r, triangle)`'s answers shrink), one octant of directions at a time.
#[inline(always)]
#[expect(
    clippy::redundant_closure,
    reason = "the closure is inlined into the walk: `&mut visit` is a call (the f64 test's \
              operands through memory; callgrind, env1 omni 250²: 36.81 → 34.79 M a frame)"
)]
fn walk_packet<W: Wide>(
    bvh: &SceneBvh,
    packet: &mut PacketRays<W>,
    staged: &StagedRays,
    active: u64,
    t_hi: &mut [f32; PACKET],
    mut visit: impl FnMut(usize, usize) -> Visit,
) {
    // The interval walk is tight only for rays whose directions share their signs, so a
    // packet that straddles an axis plane is walked once per octant it spans (callgrind, omni
    // images: 13 % fewer instructions than walking such packets ray by ray; docs/benchmarks.md).
    // Each ray was converted once (`staged`); the packet is narrowed to each octant in turn
    // (its bounds found once per walk).
    packet.fill(staged, active, bvh.wide.extent);
    for rays_in in packet.octants().into_iter().filter(|&rays_in| rays_in != 0) {
        packet.narrow_to(rays_in);
        debug_assert!(packet.bounds.same_signs());
        bvh.wide.traverse_interval::<W>(
            packet,
            t_hi,
            &bvh.triangles,
            #[inline(always)]
            |r, triangle| visit(r, triangle),
        );
    }
}

/// Shadow rays for [`occluded_rays`]: ray r from `rays[r].0` along `rays[r].1` (its `t_min`,
/// `rays[r].2`, is 0), blocked by anything but face `skip_face[r]` strictly between 0 and
/// `t_max[r]`.
pub(crate) struct ShadowRays {
    pub(crate) rays: [(DVec3, DVec3, f64); PACKET],
    pub(crate) t_max: [f64; PACKET],
    pub(crate) skip_face: [u32; PACKET],
}

/// The rays of `active` that [`occluded`] finds blocked (bit r for ray r), found by interval
/// walks of the packet (`portable` as for [`closest_hit`]): shadow rays of nearby hits
/// towards one light form a coherent packet, and each ray leaves the walk at its first
/// blocker.
pub(crate) fn occluded_rays(bvh: &SceneBvh, shadows: &ShadowRays, active: u64, portable: bool) -> u64 {
    by_cpu!(
        portable,
        occluded_rays_avx2(bvh, shadows, active),
        occluded_rays_in::<Lanes8>(bvh, shadows, active)
    )
}

/// [`occluded_rays_in`] compiled with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn occluded_rays_avx2(bvh: &SceneBvh, shadows: &ShadowRays, active: u64) -> u64 {
    occluded_rays_in::<lanes::Avx8>(bvh, shadows, active)
}

#[inline(always)]
fn occluded_rays_in<W: Wide>(bvh: &SceneBvh, shadows: &ShadowRays, active: u64) -> u64 {
    let mut t_hi = [0.0; PACKET];
    for (t_hi, &t_max) in t_hi.iter_mut().zip(&shadows.t_max) {
        *t_hi = triangle::shadow_bound(t_max);
    }
    debug_assert!(
        (0..PACKET).all(|r| active >> r & 1 == 0 || shadows.rays[r].2 == 0.0),
        "shadow rays start at t = 0"
    );
    let mut blocked = 0u64;
    let mut packet = PacketRays::<W>::empty();
    let staged = StagedRays::of(&shadows.rays, active);
    walk_packet::<W>(bvh, &mut packet, &staged, active, &mut t_hi, |r, triangle| {
        let (origin, direction, _) = shadows.rays[r];
        let mut hit = false;
        triangle::blocks(
            bvh,
            origin,
            direction,
            shadows.t_max[r],
            shadows.skip_face[r],
            &mut hit,
            triangle,
        );
        if !hit {
            return Visit::Miss;
        }
        blocked |= 1 << r;
        // The ray's answer is known: it leaves the walk (which ends once every ray has).
        Visit::Stop
    });
    blocked
}

/// Whether anything but face `skip_face` lies on the ray strictly between 0 and `t_max`:
/// [`crate::trace::reference::occluded`]'s answer, found faster (`portable` as for [`closest_hit`]).
pub(crate) fn occluded(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_max: f64,
    skip_face: u32,
    portable: bool,
) -> bool {
    by_cpu!(
        portable,
        occluded_avx2(bvh, origin, direction, t_max, skip_face),
        occluded_in::<false>(bvh, origin, direction, t_max, skip_face)
    )
}

/// [`occluded_in`] compiled with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn occluded_avx2(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
    occluded_in::<true>(bvh, origin, direction, t_max, skip_face)
}

#[inline(always)]
fn occluded_in<const AVX: bool>(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
    let ray = LaneRay::new(origin, direction, bvh.wide.extent);
    let mut blocked = false;
    bvh.wide.traverse::<AVX, ()>(
        &ray,
        0.0,
        triangle::shadow_bound(t_max),
        &bvh.triangles,
        &mut (),
        |triangle| triangle::blocks(bvh, origin, direction, t_max, skip_face, &mut blocked, triangle),
    );
    blocked
}
