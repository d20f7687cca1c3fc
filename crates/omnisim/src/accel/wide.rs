//! The 8-wide BVH the fast tracer walks (`trace/fast/wide.rs`), collapsed from the BVH2.
//!
//! A node holds up to eight children, each an inner node or a leaf of one or more
//! [`TriangleGroup`]s. It is stored compressed ([`PackedNode`], 80 bytes): the children's boxes
//! quantised to 8 bits a plane on a per-axis power-of-two grid from the node's own corner,
//! rounded outward, and its children addressed from two base indices. The walks read the boxes
//! as f32 planes ([`WideNode`], 240 bytes: [`PackedNode::decode`], or decoded lane by lane in the
//! single-ray walk). Each decoded box contains the BVH2's box, padded as `accel/mod.rs` pads it,
//! so culling stays at least as conservative as the reference tracer's.

use glam::{DVec3, Vec4};
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;

/// Marks a child index as a leaf (the rest is its first triangle group).
pub(crate) const LEAF: u32 = 1 << 31;

/// A leaf's first group, below its group count.
pub(crate) const GROUP_INDEX: u32 = (1 << 28) - 1;
/// A leaf's group count minus one sits in bits 28–30.
pub(crate) const GROUP_COUNT_SHIFT: u32 = 28;
/// Groups a leaf may span (BVH2 leaves of up to 16 triangles; `accel/mod.rs` makes at most two),
/// so that a node's leaf groups lie within [`PACKED_GROUP_OFFSET`] of its first.
const MAX_LEAF_GROUPS: usize = 4;

/// Children per node: `HALVES` four-lane vectors per box coordinate. Eight children (two
/// halves) against four: room −6 %, clutter −1 % instructions (callgrind), 5–40 % faster on
/// the clock in three interleaved rounds (docs/benchmarks.md).
pub(crate) const HALVES: usize = 2;
pub(crate) const WIDTH: usize = 4 * HALVES;

/// Subtrees of at most this many triangles become one leaf (one group of four lanes).
const LEAF_TRIANGLES: u32 = 4;

/// Eight children's boxes as f32 planes, lane i = child i: a [`PackedNode`] decoded.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WideNode {
    pub(crate) min: [[Vec4; HALVES]; 3],
    pub(crate) max: [[Vec4; HALVES]; 3],
    /// Node index, or `LEAF` | (group count − 1) << `GROUP_COUNT_SHIFT` | first group.
    pub(crate) child: [u32; WIDTH],
    /// Bit i set where child i exists.
    pub(crate) lanes: u32,
}

/// The wide BVH and its triangles, four to a group.
#[derive(Debug, Clone, Default)]
pub(crate) struct WideBvh {
    pub(crate) nodes: Vec<PackedNode>,
    pub(crate) groups: Vec<TriangleGroup>,
    /// Deepest level below the root, which sizes the traversal stack.
    pub(crate) depth: usize,
    /// Largest absolute coordinate of any triangle (scene-local), for the f32 error bound.
    pub(crate) extent: f32,
}

impl WideBvh {
    /// Collapses `bvh` (whose leaves address `triangles`, in leaf order) into eight-wide nodes.
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
        if bvh.nodes.is_empty() {
            return wide;
        }
        let counts = subtree_triangles(&bvh.nodes);
        let builder = Builder {
            nodes: &bvh.nodes,
            counts: &counts,
        };
        // A root that is (or fits) one leaf is the single child of a node of its own.
        let root = if bvh.nodes[0].is_leaf() || counts[0] <= LEAF_TRIANGLES {
            vec![0]
        } else {
            builder.open(0)
        };
        wide.nodes.push(PackedNode::EMPTY);
        let mut leaves = Vec::new();
        builder.fill(&mut wide, &mut leaves, 0, &root, 0);
        // The groups' f32 lanes on all threads, once the tree has placed them.
        wide.groups = super::map_indices(leaves.len(), |k| {
            let (indices, count) = &leaves[k];
            TriangleGroup::new(triangles, &indices[..*count])
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

/// Up to four triangles, one per lane, with each lane's triangle index in leaf order.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleGroup {
    pub(crate) lanes4: TriangleLanes<Vec4>,
    /// Triangle index (leaf order) of each lane.
    pub(crate) triangle: [u32; 4],
    /// Bit i set where lane i holds a triangle.
    pub(crate) lanes: u32,
}

impl TriangleGroup {
    /// The group of `indices` (at most four, leaf order) among `triangles`.
    pub(crate) fn new(triangles: &[[DVec3; 3]], indices: &[u32]) -> Self {
        debug_assert!(!indices.is_empty() && indices.len() <= 4);
        let mut lanes = [[0.0f32; 10]; 4];
        let mut triangle = [0u32; 4];
        for (lane, &index) in indices.iter().enumerate() {
            let [a, b, c] = triangles[index as usize];
            let (e1, e2) = (b - a, c - a);
            let longest = e1.length().max(e2.length()) as f32;
            let [a, e1, e2] = [a, e1, e2].map(glam::DVec3::as_vec3);
            lanes[lane] = [a.x, a.y, a.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, longest];
            triangle[lane] = index;
        }
        let column = |k: usize| Vec4::new(lanes[0][k], lanes[1][k], lanes[2][k], lanes[3][k]);
        Self {
            lanes4: TriangleLanes {
                corner: [column(0), column(1), column(2)],
                edge1: [column(3), column(4), column(5)],
                edge2: [column(6), column(7), column(8)],
                longest_edge: column(9),
            },
            triangle,
            lanes: (1u32 << indices.len()) - 1,
        }
    }
}

/// Bit of a [`PackedNode`] child's byte that marks a leaf.
const PACKED_LEAF: u8 = 1 << 7;
/// A leaf child's group count minus one sits in bits 5–6 of its byte.
const PACKED_COUNT_SHIFT: u8 = 5;
/// A leaf child's first group, as an offset from the node's first group, in bits 0–4.
const PACKED_GROUP_OFFSET: u8 = (1 << PACKED_COUNT_SHIFT) - 1;

/// A [`WideNode`] in 80 bytes instead of 240, so that a node visit reads two cache lines rather
/// than four (the single-ray walk of 100k–1M triangle scenes waits on memory: docs/benchmarks.md).
/// As tinybvh's CWBVH and Embree's compressed BVH8 store nodes: each child's box as 8-bit steps
/// of `2^exponent` from `origin` per axis, the lower plane rounded down and the upper one up, so
/// that the f32 plane `origin + step × 2^exponent` (one rounding: the product is exact) lies
/// outside the child's f32 box; checked plane by plane when the node is made. Inner children
/// are consecutive in the node list and a node's leaf groups follow each other in the group
/// list, so two base indices and a byte per child address them.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct PackedNode {
    /// Corner the steps count from: the least of the children's lower planes, per axis.
    pub(crate) origin: [f32; 3],
    /// Per axis, the exponent of the step (`2^exponent`, a normal f32).
    pub(crate) exponent: [i8; 3],
    /// Bit i set where child i exists.
    pub(crate) lanes: u8,
    /// Per axis, each child's lower plane in steps above `origin` (rounded down).
    pub(crate) low: [[u8; WIDTH]; 3],
    /// Per axis, each child's upper plane in steps above `origin` (rounded up).
    pub(crate) high: [[u8; WIDTH]; 3],
    /// Index of the node's first inner child.
    pub(crate) first_node: u32,
    /// Index of the node's first leaf group.
    pub(crate) first_group: u32,
    /// Per child: an inner child's place after `first_node` (`PACKED_LEAF` clear), or
    /// `PACKED_LEAF` | (group count − 1) << `PACKED_COUNT_SHIFT` | first group − `first_group`.
    pub(crate) child: [u8; WIDTH],
}

impl PackedNode {
    /// A node without children (a placeholder until the builder fills it).
    const EMPTY: Self = Self {
        origin: [0.0; 3],
        exponent: [0; 3],
        lanes: 0,
        low: [[0; WIDTH]; 3],
        high: [[0; WIDTH]; 3],
        first_node: 0,
        first_group: 0,
        child: [0; WIDTH],
    };

    /// The compressed form of `node`, whose inner children are consecutive nodes and whose leaf
    /// groups lie within `PACKED_GROUP_OFFSET` of the first (as the builder lays them out).
    pub(crate) fn new(node: &WideNode) -> Self {
        let present = |lane: &usize| node.lanes & (1 << lane) != 0;
        let entries = || (0..WIDTH).filter(present).map(|lane| node.child[lane]);
        let first_node = entries().filter(|c| c & LEAF == 0).min().unwrap_or(0);
        let first_group = entries()
            .filter(|c| c & LEAF != 0)
            .map(|c| c & GROUP_INDEX)
            .min()
            .unwrap_or(0);
        let mut packed = Self {
            lanes: node.lanes as u8,
            first_node,
            first_group,
            ..Self::EMPTY
        };
        for lane in (0..WIDTH).filter(present) {
            let entry = node.child[lane];
            packed.child[lane] = if entry & LEAF == 0 {
                let place = entry - first_node;
                assert!(place < WIDTH as u32, "inner children of a wide node not consecutive");
                place as u8
            } else {
                let offset = (entry & GROUP_INDEX) - first_group;
                let count = (entry & !LEAF) >> GROUP_COUNT_SHIFT;
                assert!(
                    offset <= u32::from(PACKED_GROUP_OFFSET) && count < 4,
                    "leaf groups of a wide node too far apart"
                );
                PACKED_LEAF | (count as u8) << PACKED_COUNT_SHIFT | offset as u8
            };
        }
        for axis in 0..3 {
            let low = |lane: usize| node.min[axis][lane / 4][lane % 4];
            let high = |lane: usize| node.max[axis][lane / 4][lane % 4];
            let origin = (0..WIDTH).filter(present).map(low).fold(f32::INFINITY, f32::min);
            let top = (0..WIDTH).filter(present).map(high).fold(f32::NEG_INFINITY, f32::max);
            packed.origin[axis] = origin;
            // The smallest step whose 255 steps reach the top, then larger ones until every
            // plane, rounded outward, fits in a byte.
            let mut exponent = exponent_at_least((top - origin) / 255.0);
            loop {
                let step = step(exponent as i8);
                let fits = (0..WIDTH).filter(present).all(|lane| {
                    let planes = (
                        quantise_down(origin, step, low(lane)),
                        quantise_up(origin, step, high(lane)),
                    );
                    if let (Some(lo), Some(hi)) = planes {
                        packed.low[axis][lane] = lo;
                        packed.high[axis][lane] = hi;
                    }
                    planes.0.is_some() && planes.1.is_some()
                });
                if fits {
                    break;
                }
                if exponent >= MAX_EXPONENT {
                    // Only boxes beyond f32's range (scene coordinates over about 3e38) get
                    // here: their planes are infinite and no step reaches them. The widest
                    // grid is kept; such boxes are not finite for the f32 walks either way.
                    packed.low[axis] = [0; WIDTH];
                    packed.high[axis] = [u8::MAX; WIDTH];
                    break;
                }
                exponent += 1;
            }
            packed.exponent[axis] = exponent as i8;
        }
        packed
    }

    /// Step between the quantised planes on `axis`.
    #[inline(always)]
    pub(crate) fn step(&self, axis: usize) -> f32 {
        step(self.exponent[axis])
    }

    /// Child `lane`'s entry as the walks read it: a node index, or `LEAF` | (group count − 1)
    /// << `GROUP_COUNT_SHIFT` | first group.
    #[inline(always)]
    pub(crate) fn child(&self, lane: usize) -> u32 {
        let byte = self.child[lane];
        if byte & PACKED_LEAF == 0 {
            self.first_node + u32::from(byte)
        } else {
            let count = u32::from((byte & !PACKED_LEAF) >> PACKED_COUNT_SHIFT);
            LEAF | count << GROUP_COUNT_SHIFT | (self.first_group + u32::from(byte & PACKED_GROUP_OFFSET))
        }
    }

    /// The node with its planes as f32 (`origin + steps × step`, as the single-ray walk decodes
    /// them) and its children's entries: what the packet walk reads.
    #[inline(always)]
    pub(crate) fn decode(&self) -> WideNode {
        let planes = |steps: &[[u8; WIDTH]; 3], axis: usize| {
            let (origin, step) = (Vec4::splat(self.origin[axis]), Vec4::splat(self.step(axis)));
            let s = &steps[axis];
            let half = |h: usize| {
                let q = Vec4::new(
                    f32::from(s[4 * h]),
                    f32::from(s[4 * h + 1]),
                    f32::from(s[4 * h + 2]),
                    f32::from(s[4 * h + 3]),
                );
                origin + q * step
            };
            [half(0), half(1)]
        };
        WideNode {
            min: [0, 1, 2].map(|axis| planes(&self.low, axis)),
            max: [0, 1, 2].map(|axis| planes(&self.high, axis)),
            child: std::array::from_fn(|lane| self.child(lane)),
            lanes: u32::from(self.lanes),
        }
    }
}

/// Exponents of the steps: normal f32 powers of two.
const MIN_EXPONENT: i32 = -126;
const MAX_EXPONENT: i32 = 127;

/// `2^exponent` as an f32 (a normal number for `MIN_EXPONENT..=MAX_EXPONENT`).
#[inline(always)]
fn step(exponent: i8) -> f32 {
    f32::from_bits(((i32::from(exponent) + 127) as u32) << 23)
}

/// The least exponent e in `MIN_EXPONENT..=MAX_EXPONENT` with `2^e ≥ value` (the bounds where
/// none is; read from the bits, as a libm `log2` call per axis per node slowed the build).
fn exponent_at_least(value: f32) -> i32 {
    if value.is_nan() || value <= f32::MIN_POSITIVE {
        return MIN_EXPONENT; // zero, subnormal or NaN (an empty or flat axis)
    }
    if !value.is_finite() {
        return MAX_EXPONENT;
    }
    let bits = value.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    let above = i32::from(bits & ((1 << 23) - 1) != 0);
    (exponent + above).clamp(MIN_EXPONENT, MAX_EXPONENT)
}

/// The most steps of `step` from `origin` whose plane lies at or below `value` (f32, one
/// rounding), or `None` beyond 255 steps or where none does.
fn quantise_down(origin: f32, step: f32, value: f32) -> Option<u8> {
    let plane = |q: u8| origin + f32::from(q) * step;
    // A first guess, truncated (`as` saturates: negative or NaN give 0); the loop corrects it.
    let mut q = ((value - origin) / step) as u8;
    while plane(q) > value {
        q = q.checked_sub(1)?;
    }
    (plane(q) <= value).then_some(q)
}

/// The fewest steps of `step` from `origin` whose plane lies at or above `value`, or `None`
/// beyond 255 steps.
fn quantise_up(origin: f32, step: f32, value: f32) -> Option<u8> {
    let plane = |q: u8| origin + f32::from(q) * step;
    let mut q = ((value - origin) / step) as u8;
    while plane(q) < value {
        q = q.checked_add(1)?;
    }
    (plane(q) >= value).then_some(q)
}

pub(crate) fn empty_node() -> WideNode {
    WideNode {
        min: [[Vec4::ZERO; HALVES]; 3],
        max: [[Vec4::ZERO; HALVES]; 3],
        child: [0; WIDTH],
        lanes: 0,
    }
}

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

/// Half the surface area of a BVH2 node's box: which child to open first.
fn half_area(node: &Bvh2Node) -> f32 {
    let size = node.max - node.min;
    size.x * size.y + size.y * size.z + size.z * size.x
}

struct Builder<'a> {
    nodes: &'a [Bvh2Node],
    counts: &'a [u32],
}

impl Builder<'_> {
    /// Fills wide node `slot` with the BVH2 nodes `children` (at most `WIDTH`), opening each
    /// child that needs a node of its own; `depth` is the slot's depth.
    /// Groups are listed in `leaves` (triangle indices, count) and made afterwards.
    fn fill(
        &self,
        wide: &mut WideBvh,
        leaves: &mut Vec<([u32; 4], usize)>,
        slot: usize,
        children: &[usize],
        depth: usize,
    ) {
        wide.depth = wide.depth.max(depth);
        let mut node = empty_node();
        for (lane, &index) in children.iter().enumerate() {
            let source = &self.nodes[index];
            for axis in 0..3 {
                node.min[axis][lane / 4][lane % 4] = source.min[axis];
                node.max[axis][lane / 4][lane % 4] = source.max[axis];
            }
            node.lanes |= 1 << lane;
            if self.counts[index] <= LEAF_TRIANGLES || source.is_leaf() {
                let mut leaf = Vec::new();
                self.gather(index, &mut leaf);
                let groups = leaf.len().div_ceil(4);
                assert!(
                    groups <= MAX_LEAF_GROUPS && leaves.len() < GROUP_INDEX as usize,
                    "BVH2 leaf of {} triangles, or over 2^28 groups",
                    leaf.len()
                );
                node.child[lane] = LEAF | ((groups as u32 - 1) << GROUP_COUNT_SHIFT) | leaves.len() as u32;
                leaves.extend(leaf.chunks(4).map(|chunk| {
                    let mut indices = [0; 4];
                    indices[..chunk.len()].copy_from_slice(chunk);
                    (indices, chunk.len())
                }));
            } else {
                node.child[lane] = wide.nodes.len() as u32;
                wide.nodes.push(PackedNode::EMPTY);
            }
        }
        wide.nodes[slot] = PackedNode::new(&node);
        for (lane, &index) in children.iter().enumerate() {
            if node.child[lane] & LEAF == 0 {
                let grandchildren = self.open(index);
                self.fill(wide, leaves, node.child[lane] as usize, &grandchildren, depth + 1);
            }
        }
    }

    /// The up to `WIDTH` BVH2 nodes that replace inner node `index`: its two children, then
    /// repeatedly the two children of the largest inner one among them.
    fn open(&self, index: usize) -> Vec<usize> {
        let first = self.nodes[index].first_index as usize;
        let mut children = vec![first, first + 1];
        while children.len() < WIDTH {
            let openable = children
                .iter()
                .enumerate()
                .filter(|&(_, &c)| !self.nodes[c].is_leaf() && self.counts[c] > LEAF_TRIANGLES)
                .max_by(|a, b| half_area(&self.nodes[*a.1]).total_cmp(&half_area(&self.nodes[*b.1])));
            let Some((position, &chosen)) = openable else {
                break;
            };
            let first = self.nodes[chosen].first_index as usize;
            children[position] = first;
            children.push(first + 1);
        }
        children
    }

    /// Triangle indices (leaf order) below BVH2 node `index`.
    fn gather(&self, index: usize, into: &mut Vec<u32>) {
        let node = &self.nodes[index];
        if node.is_leaf() {
            into.extend(node.first_index..node.first_index + node.prim_count);
        } else {
            self.gather(node.first_index as usize, into);
            self.gather(node.first_index as usize + 1, into);
        }
    }
}
