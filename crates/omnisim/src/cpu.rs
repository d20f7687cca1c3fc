//! The f64 reference tracer: the accuracy yardstick for the GPU path and the fallback backend.
//!
//! BVH traversal uses obvhs's f32 boxes (padded in `bvh.rs`, so they cull conservatively);
//! every triangle test and every returned distance is f64. Tracing yields hit planes only;
//! `shading.rs` turns them into colour.

use glam::{DMat3, DVec2, DVec3, Vec3A};
use obvhs::ray::{Ray, RayHit};
use rayon::prelude::*;

use crate::bvh::SceneBvh;
use crate::camera::Camera;
use crate::frame::{Frame, Pixel};
use crate::pose::Pose;

/// Barycentric slack that closes the gaps f64 rounding leaves along shared edges.
const EDGE_TOLERANCE: f64 = 1e-10;

/// A closest hit: distance along the (unit) ray and triangle index in BVH order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub triangle: usize,
}

/// Möller–Trumbore in f64; returns t where the ray meets the triangle.
fn intersect(corners: &[DVec3; 3], origin: DVec3, direction: DVec3) -> Option<f64> {
    let e1 = corners[1] - corners[0];
    let e2 = corners[2] - corners[0];
    let p = direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - corners[0];
    let u = s.dot(p) * inv;
    if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = direction.dot(q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// obvhs's f32 ray for the box tests, with the unused fourth SIMD lane of its origin and
/// inverse direction set to 1.
///
/// With `small_bvh2_node`, obvhs reads a node's box as two 4-lane vectors whose fourth lanes
/// are the node's `prim_count` and `first_index` bits: small integers, that is subnormal f32.
/// glam's `Vec3A::new` copies z into the fourth lane, so for an origin with z exactly 0 (a
/// camera at the height of the scene's centre, the local origin) every box test computed
/// `(subnormal − 0) × inv_z`, a multiplication of a subnormal, which x86 CPUs finish in a slow
/// microcode path: the whole trace ran 1.5–2× slower (issue 10). `(subnormal − 1) × 1` is
/// −1, a normal number; the lane never reaches the result (obvhs reduces x, y, z only).
fn box_test_ray(origin: DVec3, direction: DVec3, t_max: f32) -> Ray {
    let mut ray = Ray::new(
        Vec3A::from(origin.as_vec3()),
        Vec3A::from(direction.as_vec3()),
        0.0,
        t_max,
    );
    ray.origin = Vec3A::from_vec4(ray.origin.extend(1.0));
    ray.inv_direction = Vec3A::from_vec4(ray.inv_direction.extend(1.0));
    ray
}

/// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`.
pub fn closest_hit(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_min: f64) -> Option<Hit> {
    let ray = box_test_ray(origin, direction, f32::INFINITY);
    let mut best: Option<Hit> = None;
    let mut record = RayHit::none();
    bvh.bvh.ray_traverse(ray, &mut record, |_, triangle| {
        match intersect(&bvh.triangles[triangle], origin, direction) {
            Some(t) if t > t_min && best.is_none_or(|b| t < b.t) => {
                best = Some(Hit { t, triangle });
                // Rounded up so the f32 culling never discards a nearer candidate.
                (t * (1.0 + 1e-6)) as f32
            }
            _ => f32::INFINITY,
        }
    });
    best
}

/// Whether anything but face `skip_face` lies on the ray (scene-local origin, unit
/// direction) strictly between t = 0 and `t_max`: the shadow test. Any hit ends the search.
pub fn occluded(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
    // The f32 bound is rounded up, so culling never drops an occluder the f64 test accepts.
    let bound = if t_max.is_finite() {
        (t_max * (1.0 + 1e-6) + 1e-6) as f32
    } else {
        f32::INFINITY
    };
    let ray = box_test_ray(origin, direction, bound);
    !bvh.bvh.ray_traverse_miss(ray, |_, triangle| {
        if bvh.face[triangle] == skip_face {
            return f32::INFINITY;
        }
        match intersect(&bvh.triangles[triangle], origin, direction) {
            Some(t) if t > 0.0 && t < t_max => 0.0,
            _ => f32::INFINITY,
        }
    })
}

/// A pose made ready for tracing: rotation, and the viewpoint relative to the BVH's offset.
pub(crate) struct LocalPose {
    world_from_body: DMat3,
    origin: DVec3,
}

impl LocalPose {
    pub(crate) fn new(bvh: &SceneBvh, pose: &Pose) -> Self {
        Self {
            world_from_body: pose.world_from_body_rotation(),
            origin: pose.position - bvh.offset,
        }
    }
}

/// Traces the camera ray through `pixel` (sub-pixel positions allowed): the hit planes of
/// that ray, [`Pixel::MISS`] where the pixel has no ray or the ray hits nothing.
pub(crate) fn trace_pixel(bvh: &SceneBvh, camera: &Camera, pose: &LocalPose, pixel: DVec2) -> Pixel {
    let Some(ray) = camera.ray(pixel) else {
        return Pixel::MISS;
    };
    let origin = pose.origin + pose.world_from_body * ray.origin;
    let direction = pose.world_from_body * ray.direction;
    let Some(hit) = closest_hit(bvh, origin, direction, ray.t_min) else {
        return Pixel::MISS;
    };
    let face = bvh.face[hit.triangle];
    let normal = bvh.face_normals[face as usize];
    Pixel {
        face,
        range: hit.t as f32,
        point: bvh.offset + origin + hit.t * direction,
        normal: if normal.dot(direction) > 0.0 { -normal } else { normal }.as_vec3(),
    }
}

/// Traces one frame's hit planes on all CPU threads.
pub fn trace(bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
    let (width, height) = camera.size();
    let local = LocalPose::new(bvh, pose);
    let mut hits = vec![Pixel::MISS; width as usize * height as usize];
    hits.par_chunks_mut(width.max(1) as usize)
        .enumerate()
        .for_each(|(row, pixels)| {
            for (column, pixel) in pixels.iter_mut().enumerate() {
                *pixel = trace_pixel(bvh, camera, &local, DVec2::new(column as f64, row as f64));
            }
        });
    Frame::from_hits(width, height, hits)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lanes of `(corner − origin)` and of its product with the inverse direction, for both
    /// corners of every node box, that are subnormal: what obvhs's box test computes.
    fn subnormal_box_lanes(bvh: &SceneBvh, ray: &Ray) -> usize {
        let lanes = |v: Vec3A| bytemuck::cast::<Vec3A, [f32; 4]>(v);
        bvh.bvh
            .nodes
            .iter()
            .flat_map(|node| [node.aabb().min, node.aabb().max])
            .flat_map(|corner| {
                let offset = corner - ray.origin;
                lanes(offset).into_iter().chain(lanes(offset * ray.inv_direction))
            })
            .filter(|lane| lane.is_subnormal())
            .count()
    }

    #[test]
    fn box_tests_multiply_no_subnormal_for_a_camera_at_the_scene_centre() {
        let scene = crate::scene::Scene::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenes/env1.ron"
        )))
        .unwrap();
        let bvh = SceneBvh::build(&scene);
        let centre = DVec3::ZERO; // the local origin: every coordinate equals the centre's
        let directions = [
            DVec3::new(0.3, -0.5, 0.8),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.6, -0.8),
        ];
        for direction in directions {
            let ray = box_test_ray(centre, direction.normalize(), f32::INFINITY);
            assert_eq!(subnormal_box_lanes(&bvh, &ray), 0, "{direction}");
        }
        // The hazard the fix removes: obvhs's own ray has z in its fourth lane, and the node
        // layout puts integer bits (subnormal floats) there. Should obvhs change its layout,
        // this fails and `box_test_ray` can go.
        let plain = Ray::new(Vec3A::ZERO, Vec3A::new(0.3, -0.5, 0.8).normalize(), 0.0, f32::INFINITY);
        assert!(subnormal_box_lanes(&bvh, &plain) > 0);
    }

    #[test]
    fn axis_rays_with_negative_zero_components_hit_the_walls() {
        let text = r#"Scene(name: "cube", objects: [Box(name: "room", size: (4.0, 2.0, 2.0), colour: (9, 9, 9))])"#;
        let scene = crate::scene::Scene::from_ron(text, std::path::Path::new("cube.ron")).unwrap();
        let bvh = SceneBvh::build(&scene);
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
