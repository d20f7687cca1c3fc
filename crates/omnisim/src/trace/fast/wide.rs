//! The two walks of the 8-wide BVH (`accel/wide.rs`): one ray at a time
//! ([`WideBvh::traverse`]) and a packet of rays by interval arithmetic
//! ([`WideBvh::traverse_interval`]).

use glam::{DVec3, Vec4};

use super::groups::{RayLanes, filter};
use super::lanes::Wide;
use super::rays::{BATCHES, LaneRay, PacketBounds, PacketRays};
use crate::accel::wide::{HALVES, LEAF, TriangleGroup, TriangleLanes, WIDTH, WideBvh, WideNode, leaf_triangles};
use crate::trace::counts::Counter;
use crate::trace::triangle::Visit;

impl WideBvh {
    /// Walks the BVH along `ray`, nearest child first, calling `visit` for every triangle
    /// (leaf order) the f32 test cannot reject between `t_lo` and the current bound (`t_hi`
    /// at first, then what `visit` returns; with `AVX`, a paired leaf's triangles
    /// against the bound from before its neighbour's hits, and a leaf's second group against
    /// the bound from before its first group's hits: supersets). `AVX` tests a node's
    /// eight boxes with AVX instructions (only where the caller was compiled with them:
    /// `fast/mod.rs`); the results are bit for bit those of the portable test. `corners` are the f64 corners
    /// `visit` reads (leaf order), fetched ahead as the walk enters a leaf.
    #[inline(always)]
    pub(crate) fn traverse<const AVX: bool, C: Counter>(
        &self,
        ray: &LaneRay,
        t_lo: f32,
        t_hi: f32,
        corners: &[[DVec3; 3]],
        counter: &mut C,
        visit: impl FnMut(usize) -> Visit,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // Every node visit pops one entry and pushes at most `WIDTH`: `WIDTH − 1` per level.
        // A stack on the stack for the usual depths (zeroing it is part of every ray's cost).
        match (WIDTH - 1) * self.depth + WIDTH {
            n if n <= 32 => self.walk::<AVX, C>(&mut [(0, 0.0); 32], 0, ray, t_lo, t_hi, corners, counter, visit),
            n if n <= 96 => self.walk::<AVX, C>(&mut [(0, 0.0); 96], 0, ray, t_lo, t_hi, corners, counter, visit),
            n => self.walk::<AVX, C>(&mut vec![(0, 0.0); n], 0, ray, t_lo, t_hi, corners, counter, visit),
        }
    }

    /// The walk of [`WideBvh::traverse`] from inner node `root` down.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk<const AVX: bool, C: Counter>(
        &self,
        stack: &mut [(u32, f32)],
        root: u32,
        ray: &LaneRay,
        t_lo: f32,
        mut t_hi: f32,
        corners: &[[DVec3; 3]],
        counter: &mut C,
        mut visit: impl FnMut(usize) -> Visit,
    ) {
        // The entry visited next (the nearest child entered) stays out of the stack.
        let mut current = (root, f32::NEG_INFINITY);
        let mut len = 0;
        loop {
            let (entry, t_enter) = current;
            if t_enter <= t_hi {
                if entry & LEAF != 0 {
                    let (first, count) = leaf_triangles(entry);
                    let (low, run) = leaf_lanes(first, count);
                    // With AVX one eight-lane test: groups `lower` (lanes 0–3) and `upper`
                    // (4–7). The leaf takes the next entry along where that is a leaf the ray
                    // may reach too (a ray's two nearest children at the bottom of the tree
                    // often are) and the two leaves' triangles lie in at most two groups
                    // (siblings' triangles are adjacent in leaf order). Without AVX, a
                    // four-lane test for each of the leaf's groups.
                    let (mut lower, mut upper) = (low, if AVX { last_group(low, run) } else { low + 1 });
                    let mut own = run;
                    let mut partner = None;
                    if AVX && len > 0 {
                        let (next, next_enter) = stack[len - 1];
                        if next & LEAF != 0 && next_enter <= t_hi {
                            let (other, other_count) = leaf_triangles(next);
                            let (other_low, other_run) = leaf_lanes(other, other_count);
                            let other_upper = last_group(other_low, other_run);
                            let (below, above) = (lower.min(other_low), upper.max(other_upper));
                            let window = if above - below <= 1 {
                                Some((below, above))
                            } else if lower == upper && other_low == other_upper {
                                Some((lower, other_low))
                            } else {
                                None
                            };
                            if let Some(window) = window {
                                (lower, upper) = window;
                                if lower != low {
                                    own <<= 4;
                                }
                                let lanes = if other_low == lower { other_run } else { other_run << 4 };
                                len -= 1;
                                partner = Some((lanes, next_enter));
                                prefetch_corners(corners, other, other + other_count);
                            }
                        }
                    }
                    prefetch_corners(corners, first, first + count);
                    let mut candidates = if AVX {
                        pair_candidates::<AVX>(ray, [&self.groups[lower], &self.groups[upper]], t_lo, t_hi)
                    } else {
                        0
                    };
                    for set in 0..2 {
                        let lanes = if AVX {
                            if set == 0 {
                                own
                            } else {
                                // The partner's triangles only while the ray still reaches its
                                // box, as its own visit would see them (and count them: as the
                                // portable walk counts).
                                match partner {
                                    Some((lanes, next_enter)) if next_enter <= t_hi => lanes,
                                    _ => break,
                                }
                            }
                        } else {
                            let lanes = run >> (4 * set) & 0xf;
                            if lanes == 0 {
                                break;
                            }
                            candidates = self.groups[low + set].candidates(&ray.lanes, t_lo, t_hi) << (4 * set);
                            lanes << (4 * set)
                        };
                        counter.primitive_tests(lanes);
                        let mut lanes = lanes & candidates;
                        while lanes != 0 {
                            let lane = lanes.trailing_zeros() as usize;
                            lanes &= lanes - 1;
                            counter.exact_test();
                            let triangle = if lane < 4 {
                                4 * lower + lane
                            } else {
                                4 * upper + lane - 4
                            };
                            match visit(triangle) {
                                Visit::Stop => return,
                                answer => t_hi = narrowed(t_hi, &answer),
                            }
                        }
                    }
                } else {
                    let node = &self.nodes[entry as usize];
                    counter.node_tests(node.lanes);
                    let (hits, near) = if AVX {
                        enter_avx(node, ray, t_hi)
                    } else {
                        enter(node, ray, t_hi)
                    };
                    if hits != 0 {
                        // The nearest child entered is visited next without a push. One or two
                        // children (most nodes of a single ray's walk) are ordered by one compare,
                        // as Embree does, in the order the insertion sort gives: a lower lane
                        // first only where it is strictly nearer.
                        let first = hits.trailing_zeros() as usize;
                        let rest = hits & (hits - 1);
                        if rest == 0 {
                            current = (node.child[first], near[first]);
                            continue;
                        }
                        if rest & (rest - 1) == 0 {
                            let second = rest.trailing_zeros() as usize;
                            let (a, b) = ((node.child[first], near[first]), (node.child[second], near[second]));
                            let (next, later) = if a.1 < b.1 { (a, b) } else { (b, a) };
                            prefetch_node(&self.nodes, later.0);
                            stack[len] = later;
                            len += 1;
                            current = next;
                            continue;
                        }
                        len = push_children(stack, len, &self.nodes, node, hits, &near) - 1;
                        current = stack[len];
                        continue;
                    }
                }
            }
            if len == 0 {
                return;
            }
            len -= 1;
            current = stack[len];
        }
    }
}

/// A leaf's first group and its lanes counted from that group's first lane: at most four
/// triangles, so bits 0–3 its group's and bits 4–7 the next group's.
#[inline(always)]
fn leaf_lanes(first: usize, count: usize) -> (usize, u32) {
    (first / 4, ((1u32 << count) - 1) << (first % 4))
}

/// The last group of a leaf that starts in group `low` with lanes `run` ([`leaf_lanes`]).
#[inline(always)]
fn last_group(low: usize, run: u32) -> usize {
    if run > 0xf { low + 1 } else { low }
}

/// The lanes of two triangle groups (`pair[0]` in lanes 0–3, `pair[1]` in 4–7) that
/// [`filter`] keeps for `ray`, eight lanes at once (one AVX register where `AVX`): the same
/// answer per lane as [`TriangleGroup::candidates`] (the same operations), before masking
/// with the lanes of the leaves they hold.
#[inline(always)]
fn pair_candidates<const AVX: bool>(ray: &LaneRay, pair: [&TriangleGroup; 2], t_lo: f32, t_hi: f32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        return candidates_of_pair::<crate::trace::fast::lanes::Avx8>(ray, pair, t_lo, t_hi);
    }
    candidates_of_pair::<crate::trace::fast::lanes::Lanes8>(ray, pair, t_lo, t_hi)
}

/// [`pair_candidates`] on lanes `W`.
#[inline(always)]
fn candidates_of_pair<W: Wide>(ray: &LaneRay, pair: [&TriangleGroup; 2], t_lo: f32, t_hi: f32) -> u32 {
    let (a, b) = (&pair[0].lanes4, &pair[1].lanes4);
    let rays = RayLanes {
        origin: splat_axes::<W>(&ray.lanes.origin),
        direction: splat_axes::<W>(&ray.lanes.direction),
        position_error: W::splat(ray.lanes.position_error.x),
    };
    let triangles = TriangleLanes {
        corner: joined::<W>(&a.corner, &b.corner),
        edge1: joined::<W>(&a.edge1, &b.edge1),
        edge2: joined::<W>(&a.edge2, &b.edge2),
        longest_edge: W::from_halves(&[a.longest_edge, b.longest_edge]),
    };
    filter(&rays, &triangles, W::splat(t_lo), W::splat(t_hi))
}

/// A single ray's three axes (each the same in its four lanes) in all eight lanes.
#[inline(always)]
fn splat_axes<W: Wide>(axes: &[Vec4; 3]) -> [W; 3] {
    [W::splat(axes[0].x), W::splat(axes[1].x), W::splat(axes[2].x)]
}

/// Two groups' three axes, `low`'s in lanes 0–3 and `high`'s in 4–7.
#[inline(always)]
fn joined<W: Wide>(low: &[Vec4; 3], high: &[Vec4; 3]) -> [W; 3] {
    [
        W::from_halves(&[low[0], high[0]]),
        W::from_halves(&[low[1], high[1]]),
        W::from_halves(&[low[2], high[2]]),
    ]
}

/// A child box narrower than this many times the packet's footprint radius where the packet
/// enters it takes per-ray slab tests in the packet walk. Callgrind, clutter (240k triangles),
/// omni 250² from its centre, instructions of the packet walk: factor 1, 2, 4, every box:
/// hyperbolic 180, 142, 134, 146 M per image, spherical mirror 218, 186, 181, 203 M (before
/// the per-ray tests 198 and 388 M; single rays 240 and 212 M). docs/benchmarks.md.
const SMALL_BOX: f32 = 4.0;

/// A subtree that at most this many of a packet's rays may enter is walked ray by ray from its
/// root. Callgrind, omni 250² from the room centre, packet-walk instructions for 10 images, at
/// 0, 4, 8, 16, 24, 32: scan100000 790, 678, 609, 535, 507, 494 M; clutter 1437, 1265, 1196,
/// 1146, 1143, 1176 M; clutter spherical mirror 1956, 1604, 1462, 1347, 1316, 1317 M; env1
/// 260 M throughout (docs/benchmarks.md).
const FEW_RAYS: u32 = 24;

/// A ray's bound once `visit` has answered `answer` for it, in both walks: unchanged by a
/// miss, the nearer of the two after a closer hit, [`STOPPED`] once an any-hit query is
/// answered (the walk then shows the ray nothing more).
#[inline(always)]
fn narrowed(bound: f32, answer: &Visit) -> f32 {
    match answer {
        Visit::Miss => bound,
        Visit::Closer(t) => bound.min(*t),
        Visit::Stop => STOPPED,
    }
}

/// The bound of a ray that takes no further part in a packet walk (outside the packet, or
/// stopped by [`Visit::Stop`]): below every child's entry distance (≥ 0), so [`reaching`]
/// drops it from every entry below the root. When every ray's bound is this, the walk ends at
/// once.
const STOPPED: f32 = f32::NEG_INFINITY;

/// Rays traced together by [`WideBvh::traverse_interval`]: a tile of 8×8 pixels (faster than 4×4 on the clock: docs/benchmarks.md).
pub(crate) const PACKET: usize = 64;

impl WideBvh {
    /// [`WideBvh::traverse`] for up to [`PACKET`] rays at once (the rays `rays` is narrowed to,
    /// [`PacketRays::bounded`]: bit r set where ray r takes part), by interval arithmetic: a node's eight boxes are tested once for
    /// the whole packet against the bounds of its origins and inverse directions (admitting
    /// every box some ray enters, maybe more), and each leaf triangle is filtered against
    /// eight rays at a time. `visit(r, triangle)` sees, for each ray, every triangle the
    /// single-ray walk would show it, and perhaps a few more the f64 test then rejects; a ray
    /// whose `visit` answers [`Visit::Stop`] (an any-hit query answered) sees nothing more,
    /// and the walk ends once every ray has stopped (its bound is left at −∞).
    /// The rays must share their directions' signs (`rays.bounds.same_signs()`: the interval
    /// test and the per-ray box tests pick each axis's near plane by that sign); entries of
    /// `bounds` outside the walk's rays are left alone; those inside must not be NaN (the packet's
    /// bound, a maximum of four-lane maxima, may drop a finite bound beside a NaN one: the
    /// SSE maximum returns its second operand on NaN).
    /// `W` is the eight-lane type the leaf filter runs on (the same answers whichever);
    /// subtrees few rays enter (`FEW_RAYS`) are walked by each of them alone
    /// ([`PacketRays::single`]), with `corners` as [`WideBvh::traverse`] takes them.
    #[inline(always)]
    pub(crate) fn traverse_interval<W: Wide>(
        &self,
        rays: &PacketRays<W>,
        bounds: &mut [f32; PACKET],
        corners: &[[DVec3; 3]],
        visit: impl FnMut(usize, usize) -> Visit,
    ) {
        let active = rays.bounded();
        debug_assert!(active != 0, "a packet walk before `PacketRays::narrow_to`");
        debug_assert!(
            (0..PACKET).all(|r| active >> r & 1 == 0 || !bounds[r].is_nan()),
            "a NaN bound in the packet walk"
        );
        if self.nodes.is_empty() || active == 0 {
            return;
        }
        // Stacks on the machine stack for the usual depths (a heap allocation per packet cost
        // more than zeroing them).
        let walk = |packet_stack: &mut [_], single_stack: &mut [_]| {
            self.walk_interval(packet_stack, single_stack, rays, bounds, active, corners, visit);
        };
        match (WIDTH - 1) * self.depth + WIDTH {
            n if n <= 96 => walk(&mut [(0, 0.0, 0); 96], &mut [(0, 0.0); 96]),
            n => walk(&mut vec![(0, 0.0, 0); n], &mut vec![(0, 0.0); n]),
        }
    }

    /// The walk of [`WideBvh::traverse_interval`] on the given stacks (the packet's, and the
    /// single-ray walk's for subtrees few rays enter).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk_interval<W: Wide>(
        &self,
        stack: &mut [(u32, f32, u64)],
        single_stack: &mut [(u32, f32)],
        rays: &PacketRays<W>,
        bounds: &mut [f32; PACKET],
        active: u64,
        corners: &[[DVec3; 3]],
        mut visit: impl FnMut(usize, usize) -> Visit,
    ) {
        // The rays' bounds, −∞ (`STOPPED`) for rays outside the packet, so they count in no
        // maximum.
        let mut t_hi = [STOPPED; PACKET];
        for (r, t_hi) in t_hi.iter_mut().enumerate() {
            if active & (1 << r) != 0 {
                *t_hi = bounds[r];
            }
        }
        let t_hi = &mut t_hi;
        // The packet's bound: the farthest any of its rays may still find a closer hit.
        let farthest = |t_hi: &[f32; PACKET]| {
            t_hi.chunks_exact(4)
                .fold(Vec4::NEG_INFINITY, |a, b| a.max(Vec4::from_slice(b)))
                .max_element()
        };
        let mut far = farthest(t_hi);
        // Entries: child, where the packet may enter it, and the rays that may enter its box
        // before their bounds.
        let mut len = 1;
        stack[0] = (0, f32::NEG_INFINITY, active);
        while len > 0 {
            len -= 1;
            let (entry, t_enter, mask) = stack[len];
            if t_enter > far {
                continue;
            }
            // Of its rays, those whose bound still reaches where the packet enters it: a ray
            // that found a closer hit (or stopped, bound −∞) since the entry was pushed leaves
            // it, and counts towards no subtree's `FEW_RAYS`.
            let mut mask = reaching::<W>(t_hi, t_enter, mask);
            if mask == 0 {
                continue;
            }
            if entry & LEAF == 0 && mask.count_ones() <= FEW_RAYS {
                // Few rays left in this subtree: each walks it alone (the single-ray walk from
                // this node), keeping the bound the packet had found for it.
                let mut rest = mask;
                while rest != 0 {
                    let r = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    let (ray, t_lo) = rays.single(r);
                    let mut bound = t_hi[r];
                    let start = bound;
                    // Handed over by value, inlined into the walk (through `&mut` it was a call
                    // per triangle, the f64 test's operands passed through memory).
                    self.walk_alone::<W>(
                        single_stack,
                        entry,
                        (&ray, t_lo, start),
                        corners,
                        #[inline(always)]
                        |triangle| {
                            let answer = visit(r, triangle);
                            bound = narrowed(bound, &answer);
                            answer
                        },
                    );
                    t_hi[r] = bound;
                }
                far = farthest(t_hi);
                if far == STOPPED {
                    break;
                }
                continue;
            }
            if entry & LEAF == 0 {
                let node = &self.nodes[entry as usize];
                let (mut hits, near_lanes) = enter_interval::<W>(node, &rays.bounds, far);
                // A box small against the packet's footprint where the packet reaches it is
                // missed by most of its rays: each ray's own slab test then drops them from
                // the subtree (the leaf filter runs on the rays left); a larger box passes the
                // packet's rays on untested.
                let small = small_boxes(node, near_lanes, rays);
                let near = near_lanes.to_array();
                let base = len;
                while hits != 0 {
                    let lane = hits.trailing_zeros() as usize;
                    hits &= hits - 1;
                    let child = node.child[lane];
                    let child_mask = if small & (1 << lane) != 0 {
                        rays_entering(rays, t_hi, node, lane, mask)
                    } else {
                        mask
                    };
                    if child_mask == 0 {
                        continue;
                    }
                    prefetch_node(&self.nodes, child);
                    len = insert_by_distance(stack, base, len, (child, near[lane], child_mask), |e| e.1);
                }
                continue;
            }
            // The batches that hold rays of the entry, found once for the leaf's triangles.
            let mut batches_in = 0u32;
            for b in 0..BATCHES {
                batches_in |= u32::from((mask >> (8 * b)) as u8 != 0) << b;
            }
            // Whether a ray's bound moved (else the packet's bound `far` stands).
            let mut moved = false;
            let (first, count) = leaf_triangles(entry);
            for index in first..first + count {
                let triangle = self.groups[index / 4].broadcast::<W>(index % 4);
                let mut batches = batches_in;
                while batches != 0 {
                    let b = batches.trailing_zeros() as usize;
                    batches &= batches - 1;
                    let rays_in = (mask >> (8 * b)) as u32 & 0xff;
                    let bound = W::load(&t_hi[8 * b..]);
                    let mut candidates = filter(&rays.batches[b], &triangle, rays.t_lo[b], bound) & rays_in;
                    while candidates != 0 {
                        let r = 8 * b + candidates.trailing_zeros() as usize;
                        candidates &= candidates - 1;
                        let answer = visit(r, index);
                        if matches!(answer, Visit::Miss) {
                            continue;
                        }
                        t_hi[r] = narrowed(t_hi[r], &answer);
                        moved = true;
                        if matches!(answer, Visit::Stop) {
                            mask &= !(1 << r);
                        }
                    }
                }
            }
            if moved {
                far = farthest(t_hi);
                if far == STOPPED {
                    break;
                }
            }
        }
        for (r, bound) in bounds.iter_mut().enumerate() {
            if active & (1 << r) != 0 {
                *bound = t_hi[r];
            }
        }
    }
}

/// The rays of `mask` whose bound `t_hi` is not below `t_enter`, eight at a time. The compare
/// is ordered, so a NaN would keep the ray (the test only ever keeps too many), though the
/// walk never holds a NaN bound ([`WideBvh::traverse_interval`] rules them out).
#[inline(always)]
fn reaching<W: Wide>(t_hi: &[f32; PACKET], t_enter: f32, mask: u64) -> u64 {
    let entering = W::splat(t_enter);
    let mut leaving = 0u64;
    // A loop, not an iterator chain, whose closures are compiled outside the AVX2 walk (their
    // lane intrinsics became calls). Every batch is compared, without a branch on whether it
    // holds rays of `mask`: most do (callgrind, clutter omni 250²: 3.45 → 1.80 M a frame).
    for b in 0..BATCHES {
        leaving |= u64::from(entering.greater(W::load(&t_hi[8 * b..]))) << (8 * b);
    }
    mask & !leaving
}

impl WideBvh {
    /// The single-ray walk of `ray` (within `t_lo` and `t_hi`) from inner node `root`, with
    /// the box test of the packet walk's lanes `W`: a packet's subtree few rays enter.
    #[inline(always)]
    fn walk_alone<W: Wide>(
        &self,
        stack: &mut [(u32, f32)],
        root: u32,
        (ray, t_lo, t_hi): (&LaneRay, f32, f32),
        corners: &[[DVec3; 3]],
        visit: impl FnMut(usize) -> Visit,
    ) {
        if W::AVX {
            self.walk::<true, ()>(stack, root, ray, t_lo, t_hi, corners, &mut (), visit);
        } else {
            self.walk::<false, ()>(stack, root, ray, t_lo, t_hi, corners, &mut (), visit);
        }
    }
}

/// Asks the CPU to fetch the f64 corners of triangles `first..end` (the reference test's
/// input, 72 bytes a triangle, two cache lines) while the f32 filter runs on their lanes: in
/// a dense scene the first load of a triangle's corners was the f64 test's costliest
/// instruction (`perf`, scan100000 omni 250²: 60 % of its samples). A hint only: nothing is
/// read; `x86_64` only, a no-op elsewhere.
#[inline(always)]
fn prefetch_corners(corners: &[[DVec3; 3]], first: usize, end: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(run) = corners.get(first..end) {
        for triangle in run {
            let start = std::ptr::from_ref(triangle).cast::<i8>();
            // SAFETY: prefetching reads nothing and cannot fault; both addresses lie within
            // `triangle` (its first and last byte).
            unsafe {
                use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
                _mm_prefetch::<_MM_HINT_T0>(start);
                _mm_prefetch::<_MM_HINT_T0>(start.add(size_of::<[DVec3; 3]>() - 1));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (corners, first, end);
}

/// Pushes the children of `node` in `hits` onto `stack` (whose first `len` entries are taken)
/// farthest first, by their entry distances `near` (an insertion sort of at most eight), so
/// the nearest is popped next; returns the new length. Each inner child's box data is fetched
/// ahead ([`prefetch_node`]) from `nodes`.
#[inline(always)]
fn push_children(
    stack: &mut [(u32, f32)],
    len: usize,
    nodes: &[WideNode],
    node: &WideNode,
    mut hits: u32,
    near: &[f32; WIDTH],
) -> usize {
    let (base, mut len) = (len, len);
    while hits != 0 {
        let lane = hits.trailing_zeros() as usize;
        hits &= hits - 1;
        prefetch_node(nodes, node.child[lane]);
        len = insert_by_distance(stack, base, len, (node.child[lane], near[lane]), |e| e.1);
    }
    len
}

/// Asks the CPU to fetch inner node `child` (all its cache lines) as it is pushed: the walk
/// pops it only after a nearer sibling, so its lines arrive meanwhile instead of stalling its
/// box test (clutter omni 250², one thread, each frame's CPU time, pairs against no prefetch:
/// 2–4 % less, boxes1000000 2–8 %, env1 within noise; fetching pushed leaves' triangle
/// groups as well measured slower: docs/benchmarks.md, "2026-11-27 evening2 (walk)"). Leaf
/// entries are left alone. A hint only: nothing is read; `x86_64` only, a no-op elsewhere.
/// Not bounds-checked on every push: an inner child of a built node indexes `nodes` (the
/// wide build numbers children in the node list), and an address out of range would still
/// read nothing (the addresses are made with `wrapping_add`, which any offset may take).
#[inline(always)]
fn prefetch_node(nodes: &[WideNode], child: u32) {
    #[cfg(target_arch = "x86_64")]
    if child & LEAF == 0 {
        debug_assert!((child as usize) < nodes.len(), "an inner child is a node");
        let start = nodes.as_ptr().wrapping_add(child as usize).cast::<i8>();
        // SAFETY: prefetching reads nothing and cannot fault, whatever the address.
        unsafe {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            for offset in (0..size_of::<WideNode>()).step_by(64) {
                _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset));
            }
            _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(size_of::<WideNode>() - 1));
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (nodes, child);
}

/// Inserts `entry` among `stack[base..len]` (kept farthest first by `distance`, so the nearest
/// is popped next; one step of an insertion sort); returns the new length.
#[inline(always)]
fn insert_by_distance<T: Copy>(
    stack: &mut [T],
    base: usize,
    len: usize,
    entry: T,
    distance: impl Fn(&T) -> f32,
) -> usize {
    let mut at = len;
    while at > base && distance(&stack[at - 1]) < distance(&entry) {
        stack[at] = stack[at - 1];
        at -= 1;
    }
    stack[at] = entry;
    len + 1
}

/// The lanes of `node` whose box is narrower than `SMALL_BOX` times the packet's footprint
/// radius where the packet enters it (`near`), all eight at once.
#[inline(always)]
fn small_boxes<W: Wide>(node: &WideNode, near: W, rays: &PacketRays<W>) -> u32 {
    // A loop, not a fold: its closure would be compiled outside the AVX2 walk.
    let mut extent = W::splat(0.0);
    for axis in 0..3 {
        extent = extent.max(W::from_halves(&node.max[axis]) - W::from_halves(&node.min[axis]));
    }
    let footprint = W::splat(rays.origin_radius) + near.max(W::splat(0.0)) * W::splat(rays.spread);
    extent.less(W::splat(SMALL_BOX) * footprint)
}

/// The rays of `mask` that enter box `lane` of `node` before their bound `t_hi`, by each ray's
/// own slab test (the single-ray walk's operations, eight rays at a time; the rays share their
/// directions' signs, so the near and far planes are the same for all).
#[inline(always)]
fn rays_entering<W: Wide>(rays: &PacketRays<W>, t_hi: &[f32; PACKET], node: &WideNode, lane: usize, mask: u64) -> u64 {
    debug_assert!(rays.bounds.same_signs());
    // Written out, not `array::map` nor a closure: both were compiled outside the AVX2 walk,
    // a call per axis of every small box.
    let planes = [
        box_planes::<W>(node, 0, rays.negative[0], lane),
        box_planes::<W>(node, 1, rays.negative[1], lane),
        box_planes::<W>(node, 2, rays.negative[2], lane),
    ];
    // Every batch is tested, without a branch on whether it holds rays of `mask` (almost all
    // do: the entry holds more than `FEW_RAYS` rays): the loop unrolls, its addresses constant.
    let mut entering = 0u64;
    for b in 0..BATCHES {
        let mut near = W::splat(0.0);
        let mut exit = W::load(&t_hi[8 * b..]);
        for (axis, &(near_plane, far_plane)) in planes.iter().enumerate() {
            let origin = rays.batches[b].origin[axis];
            let inverse = rays.inverse[b][axis];
            near = near.max((near_plane - origin) * inverse);
            exit = exit.min((far_plane - origin) * inverse);
        }
        entering |= u64::from(near.not_greater(exit)) << (8 * b);
    }
    mask & entering
}

/// Interval slab test of a node's eight boxes against a packet whose rays share their
/// directions' signs (`PacketBounds::same_signs`; `closest_hits` walks one octant at a time):
/// the lanes some ray with origin and inverse direction within `bounds` might enter between 0
/// and `far`, and a lower bound of where, eight boxes at once in `W`'s lanes (one AVX
/// register in the AVX2 walk: half the instructions of two SSE halves). Conservative because
/// f32 subtraction and multiplication round monotonically: each ray's slab distances (as
/// [`enter`] computes them) lie between the products of the bounds' corners, so its entry is
/// at least, and its exit at most, what is computed here. With the signs known, the near plane
/// is picked as the single-ray test picks it, and of the four corner products of
/// (plane − origin) × inverse only those of the extreme offset are formed: the lower bound of
/// x × [i₀, i₁] is the lesser of x × i₀ and x × i₁ (one of them, exactly), the upper the
/// greater.
#[inline(always)]
fn enter_interval<W: Wide>(node: &WideNode, bounds: &PacketBounds, far: f32) -> (u32, W) {
    debug_assert!(bounds.same_signs());
    let mut near = W::splat(0.0);
    let mut exit = W::splat(far);
    for axis in 0..3 {
        let negative = bounds.inverse_max[axis] < 0.0;
        let (near_plane, far_plane) = slab_planes(node, axis, negative);
        let (near_plane, far_plane) = (W::from_halves(near_plane), W::from_halves(far_plane));
        let (inverse_min, inverse_max) = (W::splat(bounds.inverse_min[axis]), W::splat(bounds.inverse_max[axis]));
        let (origin_min, origin_max) = (W::splat(bounds.origin_min[axis]), W::splat(bounds.origin_max[axis]));
        // The plane's smallest and largest (plane − origin) over the packet: the one whose
        // product is least is the largest offset for negative inverses, the smallest for
        // positive ones, and the reverse for the greatest product.
        let (least, greatest) = if negative {
            (near_plane - origin_min, far_plane - origin_max)
        } else {
            (near_plane - origin_max, far_plane - origin_min)
        };
        near = near.max((least * inverse_min).min(least * inverse_max));
        exit = exit.min((greatest * inverse_min).max(greatest * inverse_max));
    }
    (near.not_greater(exit) & node.lanes, near)
}

/// Slab test of a node's eight boxes, two `Vec4` halves (SSE on `x86_64`): the lanes entered
/// between 0 and `t_hi`, and where. (Picking each axis's near plane by the direction's sign,
/// as the packet walk does, cost the single-ray walk 7 % more instructions than this minimum
/// and maximum: callgrind, clutter; docs/benchmarks.md.)
#[inline(always)]
fn enter(node: &WideNode, ray: &LaneRay, t_hi: f32) -> (u32, [f32; WIDTH]) {
    let mut near = [Vec4::ZERO; HALVES];
    let mut mask = 0;
    for (half, near) in near.iter_mut().enumerate() {
        let mut far = Vec4::splat(t_hi);
        for axis in 0..3 {
            let t1 = (node.min[axis][half] - ray.lanes.origin[axis]) * ray.inv_direction[axis];
            let t2 = (node.max[axis][half] - ray.lanes.origin[axis]) * ray.inv_direction[axis];
            *near = near.max(t1.min(t2));
            far = far.min(t1.max(t2));
        }
        mask |= near.cmple(far).bitmask() << (4 * half);
    }
    (mask & node.lanes, std::array::from_fn(|lane| near[lane / 4][lane % 4]))
}

/// Box `lane`'s near and far planes of [`slab_planes`], in every lane of `W`.
#[inline(always)]
fn box_planes<W: Wide>(node: &WideNode, axis: usize, negative: bool, lane: usize) -> (W, W) {
    let (near, far) = slab_planes(node, axis, negative);
    let (half, k) = (lane / 4, lane % 4);
    (W::splat(near[half][k]), W::splat(far[half][k]))
}

/// A node's near and far planes on `axis` for rays whose directions there are `negative` or
/// not: (min, max), or (max, min) (f32 subtraction and multiplication round monotonically,
/// so the slab distances order as the planes do).
#[inline(always)]
fn slab_planes(node: &WideNode, axis: usize, negative: bool) -> (&[Vec4; HALVES], &[Vec4; HALVES]) {
    if negative {
        (&node.max[axis], &node.min[axis])
    } else {
        (&node.min[axis], &node.max[axis])
    }
}

/// [`enter`] with the eight lanes in one 256-bit AVX vector: the same operations in the same
/// order (IEEE single precision either way), so the same lanes and distances. Reached only
/// from code compiled with AVX2 enabled (`fast/mod.rs` checks the CPU first); elsewhere the
/// portable test.
#[inline(always)]
fn enter_avx(node: &WideNode, ray: &LaneRay, t_hi: f32) -> (u32, [f32; WIDTH]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _CMP_LE_OQ, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
            _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps,
        };
        const { assert!(WIDTH == 8) };
        let mut near_lanes = [0.0f32; WIDTH];
        // SAFETY: `AVX` traversals run only inside `#[target_feature(enable = "avx2")]`
        // functions called after `is_x86_feature_detected!("avx2")` (`fast/mod.rs`). Each
        // load and the store reads or writes eight f32s: a coordinate's `[Vec4; 2]` (32
        // contiguous bytes; unaligned loads) and `near_lanes`.
        let mask = unsafe {
            let mut near = _mm256_setzero_ps();
            let mut far = _mm256_set1_ps(t_hi);
            for axis in 0..3 {
                let origin = _mm256_set1_ps(ray.lanes.origin[axis].x);
                let inverse = _mm256_set1_ps(ray.inv_direction[axis].x);
                let low = _mm256_loadu_ps(node.min[axis].as_ptr().cast::<f32>());
                let high = _mm256_loadu_ps(node.max[axis].as_ptr().cast::<f32>());
                let t1 = _mm256_mul_ps(_mm256_sub_ps(low, origin), inverse);
                let t2 = _mm256_mul_ps(_mm256_sub_ps(high, origin), inverse);
                near = _mm256_max_ps(near, _mm256_min_ps(t1, t2));
                far = _mm256_min_ps(far, _mm256_max_ps(t1, t2));
            }
            _mm256_storeu_ps(near_lanes.as_mut_ptr(), near);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
        };
        (mask & node.lanes, near_lanes)
    }
    #[cfg(not(target_arch = "x86_64"))]
    enter(node, ray, t_hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::wide::empty_node;
    use glam::{DVec3, Vec3};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn unit(rng: &mut StdRng) -> DVec3 {
        DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0))).normalize()
    }

    /// Eight random boxes (some flat, some thin, some far), every lane present.
    fn random_node(rng: &mut StdRng) -> WideNode {
        let mut node = empty_node();
        for lane in 0..WIDTH {
            let centre = unit(rng) * rng.random_range(0.0..20.0);
            for axis in 0..3 {
                let half = match rng.random_range(0..4) {
                    0 => 0.0,
                    1 => rng.random_range(0.0..0.01),
                    _ => rng.random_range(0.0..3.0),
                };
                node.min[axis][lane / 4][lane % 4] = (centre[axis] - half) as f32;
                node.max[axis][lane / 4][lane % 4] = (centre[axis] + half) as f32;
            }
            node.lanes |= 1 << lane;
        }
        node
    }

    /// The paired filter's promise: each of its eight lanes answers as the four-lane filter of
    /// its own group does (the single-ray walk's leaves, filtered two at a time with AVX), on
    /// the portable lanes and, where the CPU has AVX2, in one AVX register. Groups of one to
    /// four triangles near random rays (hits and near misses), random bounds.
    #[test]
    fn a_pair_of_groups_is_filtered_as_each_group_alone() {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        fn pair_avx(ray: &LaneRay, pair: [&TriangleGroup; 2], t_lo: f32, t_hi: f32) -> u32 {
            pair_candidates::<true>(ray, pair, t_lo, t_hi)
        }
        let mut rng = StdRng::seed_from_u64(17);
        let (mut kept, mut dropped) = (0, 0);
        for _ in 0..20_000 {
            let origin = unit(&mut rng) * rng.random_range(0.0..5.0);
            let direction = unit(&mut rng);
            let triangles: Vec<[DVec3; 3]> = (0..8)
                .map(|_| {
                    let centre =
                        origin + direction * rng.random_range(0.1..10.0) + unit(&mut rng) * rng.random_range(0.0..0.5);
                    std::array::from_fn(|_| centre + unit(&mut rng) * 0.3)
                })
                .collect();
            let (first, second) = (rng.random_range(1..=4), rng.random_range(1..=4));
            let groups = [
                TriangleGroup::new(&triangles[..first]),
                TriangleGroup::new(&triangles[4..4 + second]),
            ];
            let ray = LaneRay::new(origin, direction, 20.0);
            let (t_lo, t_hi) = (rng.random_range(0.0..1.0), rng.random_range(1.0..12.0));
            let lanes = ((1 << first) - 1) | (((1 << second) - 1) << 4);
            let alone = (groups[0].candidates(&ray.lanes, t_lo, t_hi)
                | groups[1].candidates(&ray.lanes, t_lo, t_hi) << 4)
                & lanes;
            let pair = [&groups[0], &groups[1]];
            assert_eq!(
                pair_candidates::<false>(&ray, pair, t_lo, t_hi) & lanes,
                alone,
                "portable lanes"
            );
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: called only where the CPU has AVX2.
                let avx = unsafe { pair_avx(&ray, pair, t_lo, t_hi) };
                assert_eq!(avx & lanes, alone, "AVX lanes");
            }
            kept += alone.count_ones();
            dropped += (lanes & !alone).count_ones();
        }
        assert!(kept > 5_000 && dropped > 5_000, "{kept} kept, {dropped} dropped");
    }

    /// The interval test with all four corner products of (plane − origin) × inverse per
    /// plane and both planes per axis: what [`enter_interval`] computes with the signs known.
    fn enter_interval_by_corners(node: &WideNode, bounds: &PacketBounds, far: f32) -> (u32, [f32; WIDTH]) {
        let mut near = [Vec4::ZERO; HALVES];
        let mut mask = 0;
        for (half, near) in near.iter_mut().enumerate() {
            let mut exit = Vec4::splat(far);
            for axis in 0..3 {
                let splat = |v: Vec3| Vec4::splat(v[axis]);
                let (origin_min, origin_max) = (splat(bounds.origin_min), splat(bounds.origin_max));
                let (inverse_min, inverse_max) = (splat(bounds.inverse_min), splat(bounds.inverse_max));
                let span = |plane: Vec4| {
                    let (a, b) = (plane - origin_max, plane - origin_min);
                    let products = [a * inverse_min, a * inverse_max, b * inverse_min, b * inverse_max];
                    let low = products[0].min(products[1]).min(products[2].min(products[3]));
                    let high = products[0].max(products[1]).max(products[2].max(products[3]));
                    (low, high)
                };
                let (low_min, low_max) = span(node.min[axis][half]);
                let (high_min, high_max) = span(node.max[axis][half]);
                *near = near.max(low_min.min(high_min));
                exit = exit.min(low_max.max(high_max));
            }
            mask |= near.cmple(exit).bitmask() << (4 * half);
        }
        (mask & node.lanes, std::array::from_fn(|lane| near[lane / 4][lane % 4]))
    }

    /// [`enter_interval`] on the AVX lanes the AVX2 packet walk runs.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn enter_interval_avx(node: &WideNode, bounds: &PacketBounds, far: f32) -> (u32, [f32; WIDTH]) {
        let (admitted, near) = enter_interval::<crate::trace::fast::lanes::Avx8>(node, bounds, far);
        (admitted, near.to_array())
    }

    /// The interval test's one promise: every box a ray of the packet enters (by the per-ray
    /// test the other walks use) is admitted, no farther away than that ray enters it. Packets
    /// of one octant (as the walk makes them) from one origin and from spread origins (rays
    /// leaving a mirror), narrow and wide, with zero and negative-zero direction components,
    /// different bounds per ray.
    #[test]
    fn the_interval_test_admits_every_box_a_ray_of_the_packet_enters() {
        let mut rng = StdRng::seed_from_u64(11);
        let (mut entered, mut admitted_extra, mut coherent_packets) = (0usize, 0usize, 0usize);
        for _ in 0..4_000 {
            let node = random_node(&mut rng);
            let centre = unit(&mut rng) * rng.random_range(0.0..10.0);
            let spread_origins = rng.random_bool(0.5);
            // Aimed at one of the boxes, so that most packets enter some.
            let target = rng.random_range(0..WIDTH);
            let aim = DVec3::from_array(std::array::from_fn(|axis| {
                f64::from(node.min[axis][target / 4][target % 4] + node.max[axis][target / 4][target % 4]) / 2.0
            }));
            let axis = (aim - centre + unit(&mut rng) * 0.5).normalize();
            let cone = [1e-4, 0.02, 0.3, 2.0][rng.random_range(0..4)];
            let zeros = rng.random_bool(0.25);
            let rays: Vec<(DVec3, DVec3)> = (0..PACKET)
                .map(|_| {
                    let origin = if spread_origins {
                        centre + unit(&mut rng) * rng.random_range(0.0..0.05)
                    } else {
                        centre
                    };
                    let mut direction = (axis + unit(&mut rng) * cone).normalize();
                    if zeros && rng.random_range(0..8) == 0 {
                        let k = rng.random_range(0..3);
                        direction[k] = if rng.random_bool(0.5) { 0.0 } else { -0.0 };
                    }
                    (origin, direction)
                })
                .collect();
            let packet: [(DVec3, DVec3, f64); PACKET] = std::array::from_fn(|r| (rays[r].0, rays[r].1, 0.0));
            let drawn = if rng.random_bool(0.5) {
                u64::MAX
            } else {
                rng.random::<u64>() | 1
            };
            // The walk takes one octant of directions at a time (`closest_hits`): the most
            // populous one here.
            let active = PacketRays::<crate::trace::fast::lanes::Lanes8>::new(&packet, drawn, 30.0)
                .octants()
                .into_iter()
                .max_by_key(|rays_in| rays_in.count_ones())
                .unwrap_or(0);
            let mut narrowed = PacketRays::<crate::trace::fast::lanes::Lanes8>::new(&packet, active, 30.0);
            narrowed.narrow_to(active);
            let bounds = narrowed.bounds;
            let t_hi: Vec<f32> = (0..PACKET)
                .map(|_| {
                    if rng.random_bool(0.3) {
                        f32::INFINITY
                    } else {
                        rng.random_range(0.0..30.0)
                    }
                })
                .collect();
            let far = (0..PACKET)
                .filter(|r| active & (1 << r) != 0)
                .fold(f32::NEG_INFINITY, |m, r| m.max(t_hi[r]));
            let (admitted, near) = enter_interval::<crate::trace::fast::lanes::Lanes8>(&node, &bounds, far);
            let near = near.to_array();
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: called only where the CPU has AVX2.
                let (avx_admitted, avx_near) = unsafe { enter_interval_avx(&node, &bounds, far) };
                assert_eq!(avx_admitted, admitted, "the AVX lanes admitted other boxes");
                assert_eq!(
                    avx_near.map(f32::to_bits),
                    near.map(f32::to_bits),
                    "the AVX lanes' entries differ"
                );
            }
            let mut any_ray = 0;
            for r in (0..PACKET).filter(|r| active & (1 << r) != 0) {
                let ray = LaneRay::new(rays[r].0, rays[r].1, 30.0);
                let (hits, ray_near) = enter(&node, &ray, t_hi[r]);
                assert_eq!(hits & !admitted, 0, "a box ray {r} enters was not admitted");
                for lane in (0..WIDTH).filter(|lane| hits & (1 << lane) != 0) {
                    assert!(near[lane] <= ray_near[lane], "admitted farther than ray {r} enters");
                }
                any_ray |= hits;
            }
            assert!(bounds.same_signs());
            let (corners, corners_near) = enter_interval_by_corners(&node, &bounds, far);
            assert_eq!(admitted, corners, "not the four-corner test's lanes");
            for lane in (0..WIDTH).filter(|lane| admitted & (1 << lane) != 0) {
                assert_eq!(near[lane], corners_near[lane], "not the four-corner test's entry");
            }
            // Tightness, as before the walk split packets by octant: whole packets that lie
            // in one octant.
            if active == drawn && cone <= 0.02 {
                coherent_packets += 1;
                entered += any_ray.count_ones() as usize;
                admitted_extra += (admitted & !any_ray).count_ones() as usize;
            }
        }
        // Conservative, yet tight enough for the narrow, sign-coherent packets the walk is used
        // for (about one box in five extra here, mostly boxes at a packet's edge or beyond some
        // of its rays' bounds; admitting every box would add several per packet).
        assert!(
            coherent_packets > 500 && entered > 500,
            "{coherent_packets} packets, {entered} boxes"
        );
        assert!(
            admitted_extra * 2 < entered,
            "{admitted_extra} boxes admitted that no ray enters, against {entered} entered"
        );
    }

    /// The packet walk of env1's BVH with the visit of [`stop_walk`], on lanes `W`: each ray's
    /// bound afterwards and how often the visit was called for it (infinite bounds at first).
    #[inline(always)]
    fn stop_walk<W: Wide>(
        bvh: &crate::accel::SceneBvh,
        packet: &[(DVec3, DVec3, f64); PACKET],
        active: u64,
        stopping: u64,
    ) -> ([f32; PACKET], [u32; PACKET]) {
        let mut rays = PacketRays::<W>::new(packet, active, bvh.wide.extent);
        rays.narrow_to(active);
        let mut bounds = [f32::INFINITY; PACKET];
        let mut visits = [0u32; PACKET];
        bvh.wide.traverse_interval(&rays, &mut bounds, &bvh.triangles, |r, _| {
            let stops = stopping >> r & 1 != 0;
            assert!(!stops || visits[r] == 0, "ray {r} visited again after it stopped");
            visits[r] += 1;
            if stops { Visit::Stop } else { Visit::Miss }
        });
        (bounds, visits)
    }

    /// [`stop_walk`] on the AVX lanes the AVX2 packet walk runs.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn stop_walk_avx(
        bvh: &crate::accel::SceneBvh,
        packet: &[(DVec3, DVec3, f64); PACKET],
        active: u64,
        stopping: u64,
    ) -> ([f32; PACKET], [u32; PACKET]) {
        stop_walk::<crate::trace::fast::lanes::Avx8>(bvh, packet, active, stopping)
    }

    /// A ray whose visit answers [`Visit::Stop`] is never shown another triangle and leaves
    /// the walk with bound −∞; the other rays (answering `Miss`) keep theirs; and a packet
    /// whose rays all stop asks one visit of each. Two packets from env1's centre towards a
    /// wall, both in one octant: all 64 rays in a narrow cone (they reach the leaves
    /// together: the packet's leaf loop) and 20 rays in a wide one (at most `FEW_RAYS` from the
    /// root on: each ray's own walk); every third ray stopping, then all. Portable lanes
    /// and, where the CPU has AVX2, the AVX lanes.
    #[test]
    fn a_stopped_ray_leaves_the_packet_walk() {
        let (_, bvh) = crate::trace::test_scene("env1");
        let (low, high) = bvh
            .triangles
            .iter()
            .flatten()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(low, high), &p| {
                (low.min(p), high.max(p))
            });
        let centre = (low + high) / 2.0;
        let mut rng = StdRng::seed_from_u64(3);
        let axis = DVec3::new(1.0, 0.3, 0.2).normalize();
        let few: u64 = (1 << 20) - 1;
        assert!(few.count_ones() <= FEW_RAYS);
        for (active, cone) in [(u64::MAX, 0.01), (few, 0.15)] {
            let packet: [(DVec3, DVec3, f64); PACKET] =
                std::array::from_fn(|_| (centre, (axis + unit(&mut rng) * cone).normalize(), 0.0));
            assert!(
                packet.iter().all(|(_, d, _)| d.min_element() > 0.0),
                "rays of one octant"
            );
            for stopping in [0x4924_9249_2492_4924_u64 & active, active] {
                let mut results = vec![(
                    "portable",
                    stop_walk::<crate::trace::fast::lanes::Lanes8>(&bvh, &packet, active, stopping),
                )];
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: called only where the CPU has AVX2.
                    results.push(("AVX", unsafe { stop_walk_avx(&bvh, &packet, active, stopping) }));
                }
                for (lanes, (bounds, visits)) in results {
                    for r in (0..PACKET).filter(|r| active >> r & 1 != 0) {
                        if stopping >> r & 1 != 0 {
                            assert_eq!(visits[r], 1, "{lanes}: ray {r} never reached a triangle");
                            assert_eq!(
                                bounds[r],
                                f32::NEG_INFINITY,
                                "{lanes}: ray {r} stopped, bound {}",
                                bounds[r]
                            );
                        } else {
                            assert!(visits[r] > 0, "{lanes}: ray {r} never reached a triangle");
                            assert_eq!(bounds[r], f32::INFINITY, "{lanes}: ray {r} only missed");
                        }
                    }
                    if stopping == active {
                        let total: u32 = visits.iter().sum();
                        assert_eq!(total, active.count_ones(), "{lanes}: visits of an all-stopping packet");
                    }
                }
            }
        }
    }

    /// The popped-entry narrowing at an exact tie: a ray whose bound equals where the packet
    /// enters the entry stays in it (a triangle there may tie its best hit and win on a lower
    /// face id), one whose bound is the next f32 below leaves, a NaN bound stays, and rays
    /// outside the mask stay out. Rays in every eight-ray batch, the last lane included; on the
    /// portable lanes and, where the CPU has AVX2, on the AVX lanes the AVX2 walk runs.
    #[test]
    fn narrowing_keeps_rays_whose_bound_ties_the_entry() {
        /// [`reaching`] on eight lanes in one AVX register, as the AVX2 packet walk runs it.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        fn reaching_avx(t_hi: &[f32; PACKET], t_enter: f32, mask: u64) -> u64 {
            reaching::<crate::trace::fast::lanes::Avx8>(t_hi, t_enter, mask)
        }
        let t_enter = 2.5_f32;
        let mut t_hi = [f32::INFINITY; PACKET];
        let (tied, below, not_a_number, blocked, outside) = ([0, 13, 63], [1, 22, 62], [30, 47], [40], [5, 55]);
        for r in tied {
            t_hi[r] = t_enter;
        }
        for r in below {
            t_hi[r] = t_enter.next_down();
        }
        for r in not_a_number {
            t_hi[r] = f32::NAN;
        }
        t_hi[blocked[0]] = f32::NEG_INFINITY;
        let bits = |rays: &[usize]| rays.iter().fold(0u64, |m, &r| m | 1 << r);
        let mask = !bits(&outside);
        let expected = mask & !bits(&below) & !bits(&blocked);
        assert_eq!(expected & bits(&tied), bits(&tied));
        let kept = reaching::<crate::trace::fast::lanes::Lanes8>(&t_hi, t_enter, mask);
        assert_eq!(kept, expected, "portable lanes kept {kept:#x}, expected {expected:#x}");
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: called only where the CPU has AVX2.
            let kept = unsafe { reaching_avx(&t_hi, t_enter, mask) };
            assert_eq!(kept, expected, "AVX lanes kept {kept:#x}, expected {expected:#x}");
        }
    }
}
