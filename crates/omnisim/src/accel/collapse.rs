//! obvhs's leaf collapse for leaves of at most two triangles, as a few passes over the nodes in
//! parts on all threads: the same nodes and leaf order as `obvhs::bvh2::leaf_collapser::collapse`
//! gives with our presets, without its walks up parent links (atomic counters, scattered reads),
//! its node copy on one thread and its parent links made again at the end.
//!
//! With leaves of at most `MAX_LEAF` triangles and a traversal cost of at least `MAX_LEAF`,
//! obvhs's cost test, `area(parent) · (count − traversal cost) <= area(left) · left count +
//! area(right) · right count`, holds whenever both children are leaves whose counts add up to at
//! most `MAX_LEAF` (its left side is then at most zero); and no parent of a collapsed node can
//! collapse too (it would hold more than `MAX_LEAF`). So a node becomes a leaf exactly where its
//! two children are leaves of at most `MAX_LEAF` triangles together, and a sibling pair is
//! dropped exactly where it is such a pair: each node's fate is read from its own pair.

use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;

/// Triangles a collapsed leaf may hold: the presets' `max_prims_per_leaf`.
pub(super) const MAX_LEAF: u32 = 2;

// The passes hold a collapsed leaf as a pair of one-triangle leaves (`pairs`) and each node's
// triangles in a byte: both are right for leaves of two only.
const _: () = assert!(MAX_LEAF == 2);

/// Nodes per part of each pass, from [`super::PARALLEL_FROM`] triangles (one part below).
const PART_NODES: usize = 1 << 16;

/// Whether [`collapse_leaf_pairs`] collapses a BVH2 of `triangles` triangles: obvhs leaves
/// trees of up to `MAX_LEAF + 1` as they are (PLOC's leaves hold one triangle each, so these are
/// its trees of up to `2 · MAX_LEAF + 1` nodes, a root that is a leaf among them). Once
/// collapsed, every inner node holds more than `MAX_LEAF` triangles (two leaves of one would
/// have been collapsed, and a collapsed node is a leaf): the wide BVH's build relies on it.
pub(super) fn collapses(triangles: usize) -> bool {
    triangles > MAX_LEAF as usize + 1
}

/// Collapses `bvh`'s sibling leaves into leaves of at most [`MAX_LEAF`] triangles, as obvhs's
/// `collapse(bvh, MAX_LEAF, traversal_cost)` does for any `traversal_cost >= MAX_LEAF`, where
/// [`collapses`] says it does. Drops the parent links (obvhs makes them again; the scene's BVH
/// does not keep them: 4 bytes a BVH2 node, about 5 a triangle).
pub(super) fn collapse_leaf_pairs(bvh: &mut Bvh2) {
    bvh.parents = Vec::new();
    let nodes = &bvh.nodes;
    let count = nodes.len();
    // A BVH2 fresh from PLOC: one triangle a leaf.
    debug_assert_eq!(count, (2 * bvh.primitive_indices.len()).saturating_sub(1));
    if !collapses(bvh.primitive_indices.len()) {
        return;
    }
    let order = &bvh.primitive_indices;
    let parallel = count / 2 >= super::PARALLEL_FROM;
    // Whether each sibling pair (nodes 2p + 1 and 2p + 2) collapses, and if so its two leaves'
    // triangles in order. Read in node order; parents then look their children's pair up in
    // these lists (1 and 8 bytes a pair) instead of in the nodes (two 32-byte nodes across two
    // cache lines, scattered).
    let (pair_collapses, pairs): (Vec<bool>, Vec<[u32; 2]>) = super::map_indices_unzip(count / 2, |p| {
        let (left, right) = (&nodes[2 * p + 1], &nodes[2 * p + 2]);
        if left.is_leaf() && right.is_leaf() && left.prim_count + right.prim_count <= MAX_LEAF {
            // Both leaves hold one triangle: a leaf holds at least one.
            (
                true,
                [order[left.first_index as usize], order[right.first_index as usize]],
            )
        } else {
            (false, [0; 2])
        }
    });
    let pair = |first: usize| pair_collapses[first / 2];
    // Node j's sibling pair is pair (j − 1) / 2.
    let kept = |j: usize| j == 0 || !pair(j - 1);
    // Triangles node j holds once collapsed: its own if a kept leaf, its children's if they pair.
    let held = |j: usize| {
        let node = &nodes[j];
        if node.is_leaf() {
            if kept(j) { node.prim_count } else { 0 }
        } else if pair(node.first_index as usize) {
            MAX_LEAF
        } else {
            0
        }
    };
    let part_nodes = if parallel { PART_NODES } else { count };
    let parts = count.div_ceil(part_nodes);
    let range = |part: usize| part * part_nodes..(count.min((part + 1) * part_nodes));
    // Triangles each node holds (the scattered look-ups once), and the nodes kept and triangles
    // held by each part.
    let mut held_by = vec![0u8; count];
    let totals = |(part, held_part): (usize, &mut [u8])| {
        range(part)
            .zip(held_part)
            .fold((0usize, 0usize), |(kept_nodes, triangles), (j, out)| {
                *out = held(j) as u8;
                (kept_nodes + usize::from(kept(j)), triangles + usize::from(*out))
            })
    };
    let totals: Vec<(usize, usize)> = each_part(parallel, held_by.chunks_mut(part_nodes).enumerate().collect(), totals);
    // Where each part starts in the new lists.
    let (mut node_total, mut triangle_total) = (0, 0);
    let starts: Vec<(usize, usize)> = totals
        .iter()
        .map(|&(kept_nodes, triangles)| {
            let start = (node_total, triangle_total);
            node_total += kept_nodes;
            triangle_total += triangles;
            start
        })
        .collect();
    let mut new_nodes = vec![Bvh2Node::default(); node_total];
    let mut new_order = vec![0u32; triangle_total];
    // Each node's index in the new list (where it is kept).
    let mut new_index = vec![0u32; count];
    // Each part's slices of the new lists.
    let mut jobs = Vec::with_capacity(parts);
    let (mut nodes_left, mut order_left) = (new_nodes.as_mut_slice(), new_order.as_mut_slice());
    for (part, (index_part, &(kept_nodes, triangles))) in new_index.chunks_mut(part_nodes).zip(&totals).enumerate() {
        let (part_nodes_out, rest) = std::mem::take(&mut nodes_left).split_at_mut(kept_nodes);
        nodes_left = rest;
        let (part_order_out, rest) = std::mem::take(&mut order_left).split_at_mut(triangles);
        order_left = rest;
        jobs.push((part, index_part, part_nodes_out, part_order_out));
    }
    // Kept nodes copied in order; a leaf's triangles listed where it now starts, a collapsed
    // node's its left child's then its right child's (obvhs's order); inner nodes' children
    // renumbered once every node's new index is known.
    let copy = |(part, index_part, nodes_out, order_out): (usize, &mut [u32], &mut [Bvh2Node], &mut [u32])| {
        let (node_start, triangle_start) = starts[part];
        let (mut next_node, mut next_triangle) = (0, 0);
        for (j, new) in range(part).zip(index_part) {
            *new = (node_start + next_node) as u32;
            if !kept(j) {
                continue;
            }
            let mut node = nodes[j];
            if node.is_leaf() {
                let (first, triangles) = (node.first_index as usize, node.prim_count as usize);
                order_out[next_triangle..next_triangle + triangles].copy_from_slice(&order[first..first + triangles]);
                node.first_index = (triangle_start + next_triangle) as u32;
                next_triangle += triangles;
            } else if held_by[j] > 0 {
                order_out[next_triangle..next_triangle + 2].copy_from_slice(&pairs[node.first_index as usize / 2]);
                node.first_index = (triangle_start + next_triangle) as u32;
                node.prim_count = MAX_LEAF;
                next_triangle += 2;
            }
            nodes_out[next_node] = node;
            next_node += 1;
        }
    };
    each_part(parallel, jobs, copy);
    let renumber = |part: &mut [Bvh2Node]| {
        for node in part.iter_mut().filter(|node| !node.is_leaf()) {
            node.first_index = new_index[node.first_index as usize];
        }
    };
    each_part(parallel, new_nodes.chunks_mut(part_nodes).collect(), renumber);
    bvh.nodes = new_nodes;
    bvh.primitive_indices = new_order;
}

/// `f` of each of `parts`, on all threads where `parallel`, else on the calling thread (below
/// [`super::PARALLEL_FROM`] triangles rayon's hand-offs cost more than the passes).
fn each_part<T: Send, R: Send>(parallel: bool, parts: Vec<T>, f: impl Fn(T) -> R + Sync + Send) -> Vec<R> {
    if parallel {
        parts.into_par_iter().map(f).collect()
    } else {
        parts.into_iter().map(f).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::tests::grid_scene;

    /// The same nodes, bit for bit, and the same leaf order as obvhs's collapse, on trees built
    /// below and above `PARALLEL_FROM` (one part, then many), after obvhs's reinsertion as in a
    /// scene's build, and on the smallest trees (1–6 triangles), which obvhs leaves alone (up to
    /// three) or collapses.
    #[test]
    fn the_same_tree_as_obvhs_collapse() {
        for cells in [0, 50, 160] {
            let scene = grid_scene(cells);
            let corners: Vec<crate::accel::Corners> = scene
                .triangle_indices()
                .iter()
                .map(|triangle| crate::accel::Corners(triangle.corners(&scene)))
                .collect();
            let smallest = (1..=6).map(|n| &corners[..n]);
            let sizes: Vec<&[crate::accel::Corners]> = if cells == 0 {
                smallest.chain([&corners[..]]).collect()
            } else {
                vec![&corners[..]]
            };
            for corners in sizes {
                let case = format!("{cells} cells, {} triangles", corners.len());
                for params in [crate::accel::BUILD_PARAMS, crate::accel::LARGE_BUILD_PARAMS] {
                    let mut uncollapsed = crate::accel::build_uncollapsed(corners, params);
                    assert!(uncollapsed.nodes.iter().all(|node| node.prim_count <= 1));
                    let mut ours = uncollapsed.clone();
                    collapse_leaf_pairs(&mut ours);
                    obvhs::bvh2::leaf_collapser::collapse(
                        &mut uncollapsed,
                        params.max_prims_per_leaf,
                        params.collapse_traversal_cost,
                    );
                    let bytes = |nodes: &[Bvh2Node]| bytemuck::cast_slice::<Bvh2Node, u8>(nodes).to_vec();
                    assert_eq!(bytes(&ours.nodes), bytes(&uncollapsed.nodes), "{case}");
                    assert_eq!(ours.primitive_indices, uncollapsed.primitive_indices, "{case}");
                    if collapses(corners.len()) {
                        assert!(
                            ours.nodes.len() < 2 * ours.primitive_indices.len() - 1,
                            "{case}: nothing collapsed"
                        );
                        // No inner node of `MAX_LEAF` triangles or fewer: two leaves as children.
                        let small = |node: &Bvh2Node| {
                            let first = node.first_index as usize;
                            let (left, right) = (&ours.nodes[first], &ours.nodes[first + 1]);
                            left.is_leaf() && right.is_leaf() && left.prim_count + right.prim_count <= MAX_LEAF
                        };
                        assert!(
                            !ours.nodes.iter().filter(|node| !node.is_leaf()).any(small),
                            "{case}: an inner node of {MAX_LEAF} or fewer"
                        );
                    }
                }
            }
        }
    }
}
