//! The reference tracer: a stack walk of the BVH2 with the f64 test of every triangle reached,
//! generic over what it counts.
//!
//! The algorithm is obvhs's `Bvh2::ray_traverse_dynamic` step by step:
//! test both children of a node, handle hit leaves at once, go on into the nearer hit inner
//! child and push the farther. It is written here for two reasons obvhs's traversal cannot
//! serve: `omnisim bench` reports node and primitive tests per ray, counted by the same code
//! that traces (a `Counter` that does nothing compiles away), and obvhs's box test reads a
//! `small_bvh2_node` as two 4-lane vectors whose fourth lanes are the node's integer fields:
//! subnormal floats, which made every box test slow for a ray origin with z exactly 0
//! (issue 10). Here a node's corners are loaded as three lanes only.

use glam::{DVec3, Vec3A};
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::fast_stack;
use obvhs::faststack::FastStack;
use obvhs::ray::safe_inverse;

use super::counts::Counter;
use super::triangle::{Hit, Visit, blocks, nearer, shadow_bound};
use crate::accel::SceneBvh;

/// A ray prepared for f32 slab tests against the (padded, conservative) node boxes.
pub(crate) struct BoxRay {
    origin: Vec3A,
    inv_direction: Vec3A,
}

impl BoxRay {
    pub(crate) fn new(origin: DVec3, direction: DVec3) -> Self {
        let direction = direction.as_vec3();
        Self {
            origin: Vec3A::from(origin.as_vec3()),
            inv_direction: Vec3A::new(
                safe_inverse(direction.x),
                safe_inverse(direction.y),
                safe_inverse(direction.z),
            ),
        }
    }

    /// Distances to the planes of the node's box: its min corner, then its max corner.
    #[inline(always)]
    fn slabs(&self, node: &Bvh2Node) -> (Vec3A, Vec3A) {
        // `Vec3A::from(Vec3)` fills the fourth lane with z: never the node's integer fields.
        let t1 = (Vec3A::from(node.min) - self.origin) * self.inv_direction;
        let t2 = (Vec3A::from(node.max) - self.origin) * self.inv_direction;
        (t1, t2)
    }

    /// Entry distance into the node's box (negative when the origin is inside), or infinity
    /// when the ray misses it; obvhs's `Aabb::intersect_ray`.
    #[inline(always)]
    fn enter(&self, node: &Bvh2Node) -> f32 {
        let (t1, t2) = self.slabs(node);
        let near = t1.min(t2).max_element();
        let far = t1.max(t2).min_element();
        if far >= near && far >= 0.0 { near } else { f32::INFINITY }
    }
}

/// Walks `bvh` along `ray`, nearest child first, calling `visit` for every primitive (index
/// in leaf order) of every leaf whose box the ray enters before `t_max`.
#[inline(always)]
pub(crate) fn traverse<C: Counter>(
    bvh: &Bvh2,
    ray: &BoxRay,
    mut t_max: f32,
    counter: &mut C,
    mut visit: impl FnMut(usize) -> Visit,
) {
    let Some(root) = bvh.nodes.first() else {
        return;
    };
    // Visits a hit leaf's primitives; false when the traversal must stop.
    let mut leaf = |node: &Bvh2Node, t_max: &mut f32, counter: &mut C| {
        for primitive in node.first_index..node.first_index + node.prim_count {
            counter.primitive_test();
            match visit(primitive as usize) {
                Visit::Miss => {}
                Visit::Closer(t) => *t_max = t_max.min(t),
                Visit::Stop => return false,
            }
        }
        true
    };
    counter.node_test();
    if ray.enter(root) >= t_max {
        return;
    }
    if root.is_leaf() {
        leaf(root, &mut t_max, counter);
        return;
    }
    fast_stack!(u32, (96, 192), bvh.max_depth, stack, {
        let mut current = root.first_index as usize;
        loop {
            let (mut near, mut far) = (&bvh.nodes[current], &bvh.nodes[current + 1]);
            counter.node_test();
            counter.node_test();
            let (mut t_near, mut t_far) = (ray.enter(near), ray.enter(far));
            if t_near > t_far {
                std::mem::swap(&mut t_near, &mut t_far);
                std::mem::swap(&mut near, &mut far);
            }
            let mut descend = |node: &Bvh2Node, t: f32, t_max: &mut f32| -> Option<bool> {
                if t >= *t_max {
                    Some(false)
                } else if node.is_leaf() {
                    leaf(node, t_max, counter).then_some(false)
                } else {
                    Some(true)
                }
            };
            let Some(go_near) = descend(near, t_near, &mut t_max) else {
                return;
            };
            let Some(go_far) = descend(far, t_far, &mut t_max) else {
                return;
            };
            current = match (go_near, go_far) {
                (true, true) => {
                    stack.push(far.first_index);
                    near.first_index as usize
                }
                (true, false) => near.first_index as usize,
                (false, true) => far.first_index as usize,
                (false, false) => match stack.pop() {
                    Some(next) => next as usize,
                    None => return,
                },
            };
        }
    });
}

/// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`, by the reference
/// tracer.
pub fn closest_hit(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_min: f64) -> Option<Hit> {
    closest_hit_counted(bvh, origin, direction, t_min, &mut ())
}

/// [`closest_hit`], counting its box and triangle tests.
pub(super) fn closest_hit_counted<C: Counter>(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    counter: &mut C,
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let ray = BoxRay::new(origin, direction);
    traverse(&bvh.bvh, &ray, f32::INFINITY, counter, |triangle| {
        nearer(bvh, origin, direction, t_min, &mut best, triangle)
    });
    best
}

/// Whether anything but face `skip_face` lies on the ray (scene-local origin, unit
/// direction) strictly between t = 0 and `t_max`: the shadow test, by the reference tracer.
/// Any hit ends the search.
pub fn occluded(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
    let mut blocked = false;
    let ray = BoxRay::new(origin, direction);
    traverse(&bvh.bvh, &ray, shadow_bound(t_max), &mut (), |triangle| {
        blocks(bvh, origin, direction, t_max, skip_face, &mut blocked, triangle)
    });
    blocked
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::counts::TraversalCounts;

    /// Subnormal lanes among the box-test operands of `values`, every lane counted.
    fn subnormal_lanes(values: impl IntoIterator<Item = Vec3A>) -> usize {
        let values: Vec<Vec3A> = values.into_iter().collect();
        bytemuck::cast_slice::<Vec3A, f32>(&values)
            .iter()
            .filter(|v| v.is_subnormal())
            .count()
    }

    /// Issue 10: a camera at the height of the scene's centre (local z exactly 0) made every
    /// box test multiply subnormals, 1.5–2.5× slower with the same work.
    #[test]
    fn box_tests_see_no_subnormal_for_a_camera_at_the_scene_centre() {
        let (_, bvh) = crate::trace::test_scene("env1");
        let directions = [DVec3::new(0.3, -0.5, 0.8), -DVec3::X, DVec3::new(0.0, 0.6, -0.8)];
        for direction in directions {
            let ray = BoxRay::new(DVec3::ZERO, direction.normalize());
            let operands = bvh.bvh.nodes.iter().flat_map(|node| {
                let (t1, t2) = ray.slabs(node);
                [
                    Vec3A::from(node.min) - ray.origin,
                    Vec3A::from(node.max) - ray.origin,
                    t1,
                    t2,
                ]
            });
            assert_eq!(subnormal_lanes(operands), 0, "{direction}");
        }
        // Why obvhs's own box test is not used: its view of a node has the node's integer
        // fields, subnormal as floats, in the fourth lanes.
        let obvhs_boxes = bvh.bvh.nodes.iter().flat_map(|node| [node.aabb().min, node.aabb().max]);
        assert!(subnormal_lanes(obvhs_boxes) > 0);
    }

    #[test]
    fn counts_every_box_and_primitive_test() {
        let (_, bvh) = crate::trace::test_scene("env1");
        let ray = BoxRay::new(DVec3::ZERO, DVec3::new(0.3, -0.5, 0.8).normalize());
        let mut counts = TraversalCounts::default();
        let mut visited = 0;
        traverse(&bvh.bvh, &ray, f32::INFINITY, &mut counts, |_| {
            visited += 1;
            Visit::Miss
        });
        assert_eq!(counts.primitive_tests, visited);
        // The root, then both children of every inner node entered.
        assert!(counts.node_tests >= 3 && counts.node_tests % 2 == 1, "{counts:?}");
    }

    #[test]
    fn axis_rays_with_negative_zero_components_hit_the_walls() {
        let text = r#"Scene(name: "cube", objects: [Box(name: "room", size: (4.0, 2.0, 2.0), colour: (9, 9, 9))])"#;
        let scene = crate::scene::Scene::from_ron(text, std::path::Path::new("cube.ron")).unwrap();
        let bvh = SceneBvh::build(&scene).unwrap();
        let origin = DVec3::new(0.1, 0.2, 0.9) - bvh.offset;
        // −DVec3::X is (−1, −0, −0): signed zeros must not change what a ray hits.
        let expected = [
            (DVec3::X, 1.9),
            (-DVec3::X, 2.1),
            (DVec3::Y, 0.8),
            (-DVec3::Y, 1.2),
            (DVec3::Z, 1.1),
            (-DVec3::Z, 0.9),
        ];
        for (direction, distance) in expected {
            let hit = closest_hit(&bvh, origin, direction, 0.0).unwrap_or_else(|| panic!("{direction} escaped"));
            assert!((hit.t - distance).abs() < 1e-12, "{direction}: {} vs {distance}", hit.t);
        }
    }
}
