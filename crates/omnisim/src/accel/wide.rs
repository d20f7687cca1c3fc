//! The 8-wide BVH the fast tracer walks (`trace/fast/wide.rs`), collapsed from the BVH2.
//!
//! Each node holds the boxes of up to eight children as two `Vec4`s per coordinate (one lane per
//! child), so a node visit is two four-lane slab tests (one eight-lane test with AVX). A child
//! is an inner node or a leaf of one or more [`TriangleGroup`]s. The boxes are the BVH2's,
//! padded as `accel/mod.rs` pads them, so culling is as conservative as the reference tracer's.

use glam::{DVec3, Vec4};
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;
use smallvec::{SmallVec, smallvec};

/// Marks a child index as a leaf (the rest is its first triangle, in leaf order, and count).
pub(crate) const LEAF: u32 = 1 << 31;

/// A leaf's first triangle (leaf order), below its triangle count.
pub(crate) const FIRST_TRIANGLE: u32 = (1 << 29) - 1;
/// A leaf's triangle count minus one sits in bits 29–30.
pub(crate) const TRIANGLE_COUNT_SHIFT: u32 = 29;
/// Triangles a leaf may hold (BVH2 leaves of up to four; `accel/mod.rs` makes at most two): so
/// a leaf's triangles lie in one group or two adjacent ones, which the walks rely on.
pub(super) const MAX_LEAF_TRIANGLES: usize = 1 << (31 - TRIANGLE_COUNT_SHIFT);

/// Children per node: `HALVES` four-lane vectors per box coordinate. Eight children (two
/// halves) against four: room −6 %, clutter −1 % instructions (callgrind), 5–40 % faster on
/// the clock in three interleaved rounds (docs/benchmarks.md).
pub(crate) const HALVES: usize = 2;
pub(crate) const WIDTH: usize = 4 * HALVES;

/// Subtrees of at most this many triangles become one leaf (one run of triangles). Two, not
/// four: the packet walk tests a leaf's boxes once a packet but its triangles once a ray, so
/// tighter leaves cut the (ray, triangle) pairs it filters; callgrind, env1 omni 250², one
/// frame 28.45 → 22.50 M (packet walk 19.52 → 13.57 M), env1-lit 135.3 → 107.9 M
/// (docs/benchmarks.md, "2026-11-26 evening (small)").
const LEAF_TRIANGLES: u32 = 2;

// A BVH2 with its leaf pairs collapsed has no inner node of `LEAF_TRIANGLES` or fewer.
const _: () = assert!(super::collapse::MAX_LEAF >= LEAF_TRIANGLES);

/// Eight children's boxes, lane i = child i.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WideNode {
    pub(crate) min: [[Vec4; HALVES]; 3],
    pub(crate) max: [[Vec4; HALVES]; 3],
    /// Node index, or `LEAF` | (triangle count − 1) << `TRIANGLE_COUNT_SHIFT` | first triangle.
    pub(crate) child: [u32; WIDTH],
    /// Bit i set where child i exists.
    pub(crate) lanes: u32,
}

/// The wide BVH and its triangles, four to a group in leaf order (group k holds triangles
/// 4k to 4k + 3): a leaf's triangles are a run of leaf order, so its lanes are found from its
/// first triangle and count, and no lane is left empty but the last group's.
#[derive(Debug, Clone, Default)]
pub(crate) struct WideBvh {
    pub(crate) nodes: Vec<WideNode>,
    pub(crate) groups: Vec<TriangleGroup>,
    /// Deepest level below the root, which sizes the traversal stack.
    pub(crate) depth: usize,
    /// Largest absolute coordinate of any triangle (scene-local), for the f32 error bound.
    pub(crate) extent: f32,
}

impl WideBvh {
    /// Collapses `bvh` (whose leaves address `triangles`, in leaf order; its leaf pairs
    /// collapsed by `collapse::collapse_leaf_pairs`) into eight-wide nodes.
    pub(crate) fn build(bvh: &Bvh2, triangles: &[[DVec3; 3]]) -> Self {
        let largest = |t: &[DVec3; 3]| t.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element()));
        let extent = if triangles.len() < super::PARALLEL_FROM {
            triangles.iter().map(largest).fold(0.0, f64::max)
        } else {
            triangles.par_iter().map(largest).reduce(|| 0.0, f64::max)
        } as f32;
        let mut wide = Self {
            extent,
            ..Self::default()
        };
        // `SceneBvh::build`, this build's one caller, refuses more before it gets here.
        assert!(triangles.len() <= FIRST_TRIANGLE as usize + 1, "over 2^29 triangles");
        if bvh.nodes.is_empty() {
            return wide;
        }
        let builder = Builder {
            nodes: &bvh.nodes,
            // Then each inner node gets a wide node of its own without counting.
            inner_nodes_open: super::collapse::collapses(triangles.len()),
        };
        // A root that is (or fits) one leaf is the single child of a node of its own.
        let (root, root_openable_lanes) = if !builder.openable(0) {
            (smallvec![0], 0)
        } else {
            builder.open(0)
        };
        // The top levels on this thread; the subtrees below them, each a part of its own, on
        // all threads; then every part's nodes are copied into place on all threads.
        let parallel = triangles.len() >= super::PARALLEL_FROM;
        let mut top = Part::default();
        top.nodes.push(empty_node());
        let defer_at = if parallel { SPLIT_DEPTH } else { usize::MAX };
        builder.fill(&mut top, 0, &root, root_openable_lanes, 0, defer_at);
        let deferred = std::mem::take(&mut top.deferred);
        let mut parts = vec![top];
        parts.par_extend(deferred.par_iter().map(|&(_, _, index)| {
            let mut part = Part::default();
            part.nodes.push(empty_node());
            let (children, openable_lanes) = builder.open(index);
            builder.fill(&mut part, 0, &children, openable_lanes, SPLIT_DEPTH, usize::MAX);
            part
        }));
        // Where each part's nodes start in the whole list, and the whole list's length.
        let mut total_nodes = 0;
        let node_starts: Vec<usize> = parts
            .iter()
            .map(|part| {
                let start = total_nodes;
                total_nodes += part.nodes.len();
                start
            })
            .collect();
        wide.nodes = super::map_indices(total_nodes, |k| {
            // The part holding node `k` (the last part starting at or before it: an empty part
            // shares its start with the next).
            let p = node_starts.partition_point(|&start| start <= k) - 1;
            let mut node = parts[p].nodes[k - node_starts[p]];
            for child in &mut node.child[..node.lanes.count_ones() as usize] {
                if *child & LEAF == 0 {
                    *child += node_starts[p] as u32;
                }
            }
            node
        });
        for (&(slot, lane, _), &start) in deferred.iter().zip(&node_starts[1..]) {
            wide.nodes[slot].child[lane] = start as u32;
        }
        wide.depth = parts.iter().map(|part| part.depth).max().unwrap_or(0);
        drop(parts);
        // The groups' f32 lanes (on all threads from `PARALLEL_FROM` groups): four triangles of
        // leaf order each.
        wide.groups = super::map_indices(triangles.len().div_ceil(4), |k| {
            TriangleGroup::new(&triangles[4 * k..(4 * k + 4).min(triangles.len())])
        });
        wide
    }
}

/// Triangles as the filter reads them: corner 0 and the two edges from it (f32, rounded from
/// the f64 corners) and the longer edge's length.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleLanes<L> {
    pub(crate) corner: [L; 3],
    pub(crate) edge1: [L; 3],
    pub(crate) edge2: [L; 3],
    pub(crate) longest_edge: L,
}

/// Four consecutive triangles of leaf order, one per lane (the last group's spare lanes zero,
/// never in a leaf's lanes). 160 bytes, aligned to 32 so that each spans three cache lines,
/// never four (a list's start the allocator gives is only 16-byte aligned).
#[derive(Debug, Clone, Copy)]
#[repr(align(32))]
pub(crate) struct TriangleGroup {
    pub(crate) lanes4: TriangleLanes<Vec4>,
}

const _: () = assert!(
    std::mem::size_of::<TriangleGroup>() == 160,
    "a group spans three cache lines"
);

impl TriangleGroup {
    /// The group of `triangles` (one to four, in lane order).
    pub(crate) fn new(triangles: &[[DVec3; 3]]) -> Self {
        debug_assert!(!triangles.is_empty() && triangles.len() <= 4);
        let mut lanes = [[0.0f32; 10]; 4];
        for (lane, &[a, b, c]) in triangles.iter().enumerate() {
            let (e1, e2) = (b - a, c - a);
            // One square root: it is monotonic and correctly rounded, so this is bitwise the
            // larger of the two lengths.
            let longest = e1.length_squared().max(e2.length_squared()).sqrt() as f32;
            let [a, e1, e2] = [a, e1, e2].map(glam::DVec3::as_vec3);
            lanes[lane] = [a.x, a.y, a.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, longest];
        }
        let column = |k: usize| Vec4::new(lanes[0][k], lanes[1][k], lanes[2][k], lanes[3][k]);
        Self {
            lanes4: TriangleLanes {
                corner: [column(0), column(1), column(2)],
                edge1: [column(3), column(4), column(5)],
                edge2: [column(6), column(7), column(8)],
                longest_edge: column(9),
            },
        }
    }
}

/// The first triangle (leaf order) and triangle count of leaf child `entry`.
#[inline(always)]
pub(crate) fn leaf_triangles(entry: u32) -> (usize, usize) {
    (
        (entry & FIRST_TRIANGLE) as usize,
        ((entry & !LEAF) >> TRIANGLE_COUNT_SHIFT) as usize + 1,
    )
}

pub(crate) fn empty_node() -> WideNode {
    WideNode {
        min: [[Vec4::ZERO; HALVES]; 3],
        max: [[Vec4::ZERO; HALVES]; 3],
        child: [0; WIDTH],
        lanes: 0,
    }
}

/// Half the surface area of a BVH2 node's box: which child to open first.
fn half_area(node: &Bvh2Node) -> f32 {
    let size = node.max - node.min;
    size.x * size.y + size.y * size.z + size.z * size.x
}

/// Up to `WIDTH` BVH2 nodes, the children of one wide node (on the stack: one heap list per
/// node was part of the collapse's cost).
type Children = SmallVec<[usize; WIDTH]>;

/// Wide nodes, with inner child indices counted from the part's first node.
#[derive(Default)]
struct Part {
    nodes: Vec<WideNode>,
    /// Deepest level below the whole tree's root.
    depth: usize,
    /// Inner children left for parts of their own, each `SPLIT_DEPTH` levels below the root:
    /// (node, lane, BVH2 node), in order.
    deferred: Vec<(usize, usize, usize)>,
}

/// Wide levels built on one thread before the subtrees below them are built in parallel
/// (up to 8² subtrees).
const SPLIT_DEPTH: usize = 2;

struct Builder<'a> {
    nodes: &'a [Bvh2Node],
    /// Every inner node holds more than `LEAF_TRIANGLES` triangles: `openable` need not count.
    /// Counting read up to three nodes below each child, scattered (not timed apart from the
    /// leaf collapse it shipped with: docs/benchmarks.md, "2026-11-27 night2 (build)").
    inner_nodes_open: bool,
}

impl Builder<'_> {
    /// Whether BVH2 node `index` gets a wide node of its own: it is an inner node holding more
    /// than `LEAF_TRIANGLES` triangles, or whose triangles are not one run of leaf order (a
    /// BVH2 leaf, whatever its size, is one wide leaf).
    fn openable(&self, index: usize) -> bool {
        !self.nodes[index].is_leaf()
            && (self.inner_nodes_open
                || self.triangles_up_to(index, LEAF_TRIANGLES) > LEAF_TRIANGLES
                || self.triangle_run(index).is_none())
    }

    /// Triangles below BVH2 node `index`, or `limit + 1` where there are more: an inner node
    /// holds at least one triangle on each side, so no more than `limit + 1` nodes are read
    /// (a whole count was a walk over every node, on one thread).
    fn triangles_up_to(&self, index: usize, limit: u32) -> u32 {
        let node = &self.nodes[index];
        if node.is_leaf() {
            return node.prim_count;
        }
        if limit < 2 {
            return limit + 1;
        }
        let first = node.first_index as usize;
        let left = self.triangles_up_to(first, limit - 1);
        if left > limit - 1 {
            return limit + 1;
        }
        (left + self.triangles_up_to(first + 1, limit - left)).min(limit + 1)
    }

    /// Fills wide node `slot` of `part` with the BVH2 nodes `children` (at most `WIDTH`),
    /// opening each child that needs a node of its own (bit i of `openable_lanes` set for child
    /// i, as `open` found them); `depth` is the slot's depth. Inner children at depth `defer_at`
    /// are listed in `part.deferred` instead of filled. A leaf child is its run of triangles.
    fn fill(
        &self,
        part: &mut Part,
        slot: usize,
        children: &[usize],
        openable_lanes: u32,
        depth: usize,
        defer_at: usize,
    ) {
        part.depth = part.depth.max(depth);
        let mut node = empty_node();
        for (lane, &index) in children.iter().enumerate() {
            let source = &self.nodes[index];
            for axis in 0..3 {
                node.min[axis][lane / 4][lane % 4] = source.min[axis];
                node.max[axis][lane / 4][lane % 4] = source.max[axis];
            }
            node.lanes |= 1 << lane;
            if openable_lanes & (1 << lane) == 0 {
                let (first, count) = self
                    .triangle_run(index)
                    .expect("`openable` opens every inner node whose triangles are not one run");
                assert!(count <= MAX_LEAF_TRIANGLES, "BVH2 leaf of {count} triangles");
                node.child[lane] = LEAF | ((count as u32 - 1) << TRIANGLE_COUNT_SHIFT) | first;
            } else if depth + 1 == defer_at {
                part.deferred.push((slot, lane, index));
            } else {
                node.child[lane] = part.nodes.len() as u32;
                part.nodes.push(empty_node());
            }
        }
        part.nodes[slot] = node;
        if depth + 1 == defer_at {
            return;
        }
        for (lane, &index) in children.iter().enumerate() {
            if node.child[lane] & LEAF == 0 {
                let (grandchildren, openable_lanes) = self.open(index);
                self.fill(
                    part,
                    node.child[lane] as usize,
                    &grandchildren,
                    openable_lanes,
                    depth + 1,
                    defer_at,
                );
            }
        }
    }

    /// The up to `WIDTH` BVH2 nodes that replace inner node `index`: its two children, then
    /// repeatedly the two children of the largest inner one among them; and which of them are
    /// openable themselves (bit i for child i), so that `fill` need not ask again.
    fn open(&self, index: usize) -> (Children, u32) {
        let first = self.nodes[index].first_index as usize;
        let mut children: Children = smallvec![first, first + 1];
        // Each child's area once (`None` where it cannot be opened), not once per step.
        let openable_area = |c: usize| self.openable(c).then(|| half_area(&self.nodes[c]));
        let mut area = [None; WIDTH];
        area[0] = openable_area(first);
        area[1] = openable_area(first + 1);
        while children.len() < WIDTH {
            // The last of the largest: ties go to the last, as before, so that the tree is unchanged.
            let mut chosen: Option<(usize, f32)> = None;
            for (position, &candidate) in area[..children.len()].iter().enumerate() {
                if let Some(a) = candidate
                    && chosen.is_none_or(|(_, best)| a.total_cmp(&best).is_ge())
                {
                    chosen = Some((position, a));
                }
            }
            let Some((position, _)) = chosen else {
                break;
            };
            let first = self.nodes[children[position]].first_index as usize;
            let last = children.len();
            children[position] = first;
            children.push(first + 1);
            area[position] = openable_area(first);
            area[last] = openable_area(first + 1);
        }
        let openable_lanes = (0..children.len()).fold(0, |bits, lane| bits | u32::from(area[lane].is_some()) << lane);
        (children, openable_lanes)
    }

    /// The triangles below BVH2 node `index` as a run of leaf order (first, count), or `None`
    /// where they are not one. the leaf collapse (`collapse.rs`, obvhs's own as
    /// passes over sibling pairs), the build's last step, places a node's two
    /// children's triangles side by side, the first's before the second's, so small subtrees
    /// are runs; but it skips BVHs of up to three triangles, whose leaves keep the builder's
    /// order: an inner node there may get a wide node of its own (`openable`).
    fn triangle_run(&self, index: usize) -> Option<(u32, usize)> {
        let node = &self.nodes[index];
        if node.is_leaf() {
            return Some((node.first_index, node.prim_count as usize));
        }
        let (first, count) = self.triangle_run(node.first_index as usize)?;
        let (second, more) = self.triangle_run(node.first_index as usize + 1)?;
        (first as usize + count == second as usize).then_some((first, count + more))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::SceneBvh;
    use crate::accel::tests::grid_scene;

    /// Triangles below each BVH2 node.
    fn subtree_triangles(nodes: &[Bvh2Node]) -> Vec<u32> {
        let mut counts = vec![0u32; nodes.len()];
        // Children before parents: a reverse pre-order walk.
        let mut order = Vec::with_capacity(nodes.len());
        let mut pending = vec![0usize];
        while let Some(index) = pending.pop() {
            order.push(index);
            let node = &nodes[index];
            if !node.is_leaf() {
                pending.push(node.first_index as usize);
                pending.push(node.first_index as usize + 1);
            }
        }
        for &index in order.iter().rev() {
            let node = &nodes[index];
            counts[index] = if node.is_leaf() {
                node.prim_count
            } else {
                counts[node.first_index as usize] + counts[node.first_index as usize + 1]
            };
        }
        counts
    }

    /// `open` replaces each openable BVH2 node by a cut of its subtree: every path down from the
    /// node meets exactly one child, the children hold the node's triangles, there are eight of
    /// them unless none can be opened, and no child left unopened is larger than a node opened
    /// below the first level (the largest goes first; a child's box lies in its parent's).
    #[test]
    fn open_replaces_a_node_by_its_largest_full_cut() {
        for cells in [50, 160] {
            let bvh = SceneBvh::build(&grid_scene(cells)).unwrap();
            let nodes = &bvh.bvh.nodes;
            let counts = subtree_triangles(nodes);
            let openable = |index: usize| !nodes[index].is_leaf() && counts[index] > LEAF_TRIANGLES;
            // The count that stops early agrees with the whole count on every node, and every
            // small subtree is a run of leaf order (`triangle_run`): no node is opened for order;
            // and the collapsed leaf pairs left no inner node of `LEAF_TRIANGLES` or fewer.
            for inner_nodes_open in [false, true] {
                let builder = Builder {
                    nodes,
                    inner_nodes_open,
                };
                assert!((0..nodes.len()).all(|index| builder.openable(index) == openable(index)));
            }
            let builder = Builder {
                nodes,
                inner_nodes_open: true,
            };
            let mut opened_nodes = 0;
            for parent in (0..nodes.len()).filter(|&index| openable(index)) {
                let (children, openable_lanes) = builder.open(parent);
                let children = children.as_slice();
                for (lane, &child) in children.iter().enumerate() {
                    assert_eq!(
                        openable_lanes >> lane & 1 == 1,
                        openable(child),
                        "{cells}: node {parent}"
                    );
                }
                assert_eq!(openable_lanes >> children.len(), 0, "{cells}: node {parent}");
                let total: u32 = children.iter().map(|&child| counts[child]).sum();
                assert_eq!(total, counts[parent], "{cells}: node {parent}'s children {children:?}");
                assert!(
                    children.len() == WIDTH || !children.iter().any(|&child| openable(child)),
                    "{cells}: node {parent} stopped at {children:?}"
                );
                // Walk down from the node's children: a node not in the cut was opened.
                let mut opened_areas = Vec::new();
                let first = nodes[parent].first_index as usize;
                let mut pending = vec![first, first + 1];
                while let Some(index) = pending.pop() {
                    if children.contains(&index) {
                        continue;
                    }
                    assert!(openable(index), "{cells}: node {parent}'s cut misses node {index}");
                    opened_areas.push(half_area(&nodes[index]));
                    let below = nodes[index].first_index as usize;
                    pending.extend([below, below + 1]);
                }
                let smallest_opened = opened_areas.iter().copied().fold(f32::INFINITY, f32::min);
                for &child in children.iter().filter(|&&child| openable(child)) {
                    assert!(half_area(&nodes[child]) <= smallest_opened, "{cells}: node {parent}");
                }
                opened_nodes += opened_areas.len();
            }
            assert!(opened_nodes > 0, "{cells}: no node opened below its first level");
        }
    }
}
