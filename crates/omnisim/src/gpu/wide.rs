//! The fast CPU tracer's 8-wide BVH (`accel/wide.rs`) as the GPU walks it (`shaders/bvh.wgsl`):
//! the one place that reads `WideNode` and its leaves for the GPU, so a change of the
//! CPU's node layout is met here alone.
//!
//! The GPU keeps each node's eight boxes as the CPU does (lane i = child i), and its leaves
//! are runs (a first triangle and a count) as the CPU's are, but of its own triangle list,
//! laid out in the order the wide BVH's leaves reach them. Each triangle keeps its index in
//! BVH leaf order for the tie rule (`wins` in `bvh.wgsl`).

use bytemuck::Zeroable;

use super::layout::{GpuWideNode, Triangle};
use crate::accel::SceneBvh;
use crate::accel::wide::{HALVES, LEAF, TRIANGLE_COUNT_SHIFT, WIDTH, WideBvh, leaf_triangles};

/// A GPU child entry with this bit is a leaf (WGSL `LEAF`).
pub(crate) const GPU_LEAF: u32 = 1 << 31;
/// A GPU leaf's triangle count minus one sits in bits 26–30 (WGSL `LEAF_COUNT_SHIFT`).
pub(crate) const GPU_LEAF_COUNT_SHIFT: u32 = 26;
/// Triangles the GPU's leaves can address (a leaf's first triangle fills bits 0–25, WGSL
/// `LEAF_FIRST`); larger scenes are refused before conversion.
pub(crate) const GPU_MAX_TRIANGLES: usize = 1 << GPU_LEAF_COUNT_SHIFT;

// A CPU leaf (at most 2^(31 − TRIANGLE_COUNT_SHIFT) triangles) fits a GPU leaf's count.
const _: () = assert!(1 << (31 - TRIANGLE_COUNT_SHIFT) <= 1 << (31 - GPU_LEAF_COUNT_SHIFT));

/// Nodes the shader's group entries address (node << 8 | one bit per child).
pub(crate) const GPU_MAX_NODES: usize = 1 << 24;

/// The GPU's nodes and triangles for `bvh`. An empty scene gets one node with no children
/// (the walk then finds nothing) and one unused triangle (WGSL arrays cannot be empty).
pub(crate) fn gpu_bvh(bvh: &SceneBvh) -> (Vec<GpuWideNode>, Vec<Triangle>) {
    let wide: &WideBvh = &bvh.wide;
    let mut triangles = Vec::with_capacity(bvh.triangles.len());
    let mut nodes: Vec<GpuWideNode> = wide
        .nodes
        .iter()
        .map(|node| {
            let mut out = GpuWideNode {
                lanes: node.lanes,
                ..GpuWideNode::zeroed()
            };
            for axis in 0..3 {
                for half in 0..HALVES {
                    out.min[HALVES * axis + half] = node.min[axis][half].to_array();
                    out.max[HALVES * axis + half] = node.max[axis][half].to_array();
                }
            }
            for lane in (0..WIDTH).filter(|lane| node.lanes & (1 << lane) != 0) {
                let child = node.child[lane];
                out.child[lane] = if child & LEAF == 0 {
                    child
                } else {
                    let (cpu_first, count) = leaf_triangles(child);
                    let first = triangles.len();
                    triangles.extend((cpu_first..cpu_first + count).map(|index| gpu_triangle(bvh, index)));
                    let count = count as u32;
                    debug_assert!(count >= 1 && first < GPU_MAX_TRIANGLES);
                    GPU_LEAF | ((count - 1) << GPU_LEAF_COUNT_SHIFT) | first as u32
                };
            }
            out
        })
        .collect();
    if nodes.is_empty() {
        nodes.push(GpuWideNode::zeroed());
    }
    if triangles.is_empty() {
        triangles.push(Triangle::zeroed());
    }
    (nodes, triangles)
}

/// Triangle `index` (BVH leaf order) as f32 corner and edges (the edges taken in f64).
fn gpu_triangle(bvh: &SceneBvh, index: usize) -> Triangle {
    let t = &bvh.triangles[index];
    Triangle {
        v0: t[0].as_vec3().to_array(),
        face: bvh.face[index],
        e1: (t[1] - t[0]).as_vec3().to_array(),
        leaf_order: index as u32,
        e2: (t[2] - t[0]).as_vec3().to_array(),
        _pad: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each GPU node holds its CPU twin's boxes where the shader reads them and its inner
    /// children; each GPU leaf is a run of exactly the CPU leaf's triangles, in order, each as
    /// the scene's own triangle; every triangle lies in exactly one leaf.
    #[test]
    fn gpu_nodes_and_leaves_are_the_wide_bvh() {
        for name in ["env1", "env2"] {
            let (_, bvh) = crate::trace::test_scene(name);
            let (nodes, triangles) = gpu_bvh(&bvh);
            assert_eq!(nodes.len(), bvh.wide.nodes.len(), "{name}");
            assert_eq!(triangles.len(), bvh.triangles.len(), "{name}");
            let mut seen = vec![0; bvh.triangles.len()];
            for (gpu, cpu) in nodes.iter().zip(&bvh.wide.nodes) {
                assert_eq!(gpu.lanes, cpu.lanes);
                for lane in (0..WIDTH).filter(|lane| cpu.lanes & (1 << lane) != 0) {
                    // bvh.wgsl: min[2·axis + half][k] for child 4·half + k.
                    for axis in 0..3 {
                        assert_eq!(
                            gpu.min[2 * axis + lane / 4][lane % 4],
                            cpu.min[axis][lane / 4][lane % 4]
                        );
                        assert_eq!(
                            gpu.max[2 * axis + lane / 4][lane % 4],
                            cpu.max[axis][lane / 4][lane % 4]
                        );
                    }
                    let (gpu_child, cpu_child) = (gpu.child[lane], cpu.child[lane]);
                    assert_eq!(gpu_child & GPU_LEAF, cpu_child & LEAF);
                    if cpu_child & LEAF == 0 {
                        assert_eq!(gpu_child, cpu_child);
                        continue;
                    }
                    let (cpu_first, cpu_count) = leaf_triangles(cpu_child);
                    let expected: Vec<u32> = (cpu_first as u32..(cpu_first + cpu_count) as u32).collect();
                    let first = (gpu_child & (GPU_MAX_TRIANGLES as u32 - 1)) as usize;
                    let count = ((gpu_child & !GPU_LEAF) >> GPU_LEAF_COUNT_SHIFT) as usize + 1;
                    let run = &triangles[first..first + count];
                    assert_eq!(run.iter().map(|t| t.leaf_order).collect::<Vec<_>>(), expected);
                    for t in run {
                        let corners = bvh.triangles[t.leaf_order as usize];
                        assert_eq!(t.v0, corners[0].as_vec3().to_array());
                        assert_eq!(t.e1, (corners[1] - corners[0]).as_vec3().to_array());
                        assert_eq!(t.e2, (corners[2] - corners[0]).as_vec3().to_array());
                        assert_eq!(t.face, bvh.face[t.leaf_order as usize]);
                        seen[t.leaf_order as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{name}: every triangle in one leaf");
        }
    }

    /// A BVH as deep as the shader's stack is walked, one level deeper is refused, and so are
    /// node and triangle counts past what the GPU's entries address.
    #[test]
    fn limits_are_checked_before_conversion() {
        use crate::gpu::context::GpuError;
        use crate::gpu::scene::check_limits;
        let stack = crate::gpu::shader::STACK_SIZE;
        assert!(check_limits(stack, GPU_MAX_NODES, GPU_MAX_TRIANGLES).is_ok());
        assert!(
            matches!(check_limits(stack + 1, 1, 1), Err(GpuError::BvhTooDeep { depth, limit }) if depth == stack + 1 && limit == stack)
        );
        for (what, nodes, triangles, count, limit) in [
            ("nodes", GPU_MAX_NODES + 1, 1, GPU_MAX_NODES + 1, GPU_MAX_NODES),
            (
                "triangles",
                1,
                GPU_MAX_TRIANGLES + 1,
                GPU_MAX_TRIANGLES + 1,
                GPU_MAX_TRIANGLES,
            ),
        ] {
            let error = check_limits(1, nodes, triangles).unwrap_err();
            assert!(
                matches!(error, GpuError::BvhFormatLimit { what: w, count: c, limit: l } if w == what && c == count && l == limit),
                "{error}"
            );
        }
    }
}
