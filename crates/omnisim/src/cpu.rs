//! The f64 reference tracer: the accuracy yardstick for the GPU path and the fallback backend.
//!
//! BVH traversal uses obvhs's f32 boxes (padded in `bvh.rs`, so they cull conservatively);
//! every triangle test and every returned distance is f64.

use glam::{DMat3, DVec2, DVec3, Vec3A};
use obvhs::ray::{Ray, RayHit};
use rayon::prelude::*;

use crate::bvh::SceneBvh;
use crate::camera::Camera;
use crate::frame::Frame;
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

/// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`.
pub fn closest_hit(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_min: f64) -> Option<Hit> {
    let ray = Ray::new(
        Vec3A::from(origin.as_vec3()),
        Vec3A::from(direction.as_vec3()),
        0.0,
        f32::INFINITY,
    );
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

/// A pose made ready for tracing: rotation, and the viewpoint relative to the BVH's offset.
pub struct LocalPose {
    world_from_body: DMat3,
    origin: DVec3,
}

impl LocalPose {
    pub fn new(bvh: &SceneBvh, pose: &Pose) -> Self {
        Self {
            world_from_body: pose.world_from_body_rotation(),
            origin: pose.position - bvh.offset,
        }
    }
}

/// A traced pixel: its ray (scene-local origin, world direction) and closest hit.
pub struct TracedPixel {
    pub origin: DVec3,
    pub direction: DVec3,
    pub hit: Hit,
}

/// Traces the camera ray through `pixel` (sub-pixel positions allowed); `None` where the
/// pixel has no ray or the ray hits nothing.
pub fn trace_pixel(bvh: &SceneBvh, camera: &Camera, pose: &LocalPose, pixel: DVec2) -> Option<TracedPixel> {
    let ray = camera.ray(pixel)?;
    let origin = pose.origin + pose.world_from_body * ray.origin;
    let direction = pose.world_from_body * ray.direction;
    let hit = closest_hit(bvh, origin, direction, ray.t_min)?;
    Some(TracedPixel { origin, direction, hit })
}

/// Renders one frame on all CPU threads.
pub fn render(bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
    let (width, height) = camera.size();
    let local = LocalPose::new(bvh, pose);
    let mut frame = Frame::empty(width, height);
    frame
        .pixels_mut()
        .par_chunks_mut(width as usize)
        .enumerate()
        .for_each(|(row, pixels)| {
            for (column, pixel) in pixels.iter_mut().enumerate() {
                if let Some(traced) = trace_pixel(bvh, camera, &local, DVec2::new(column as f64, row as f64)) {
                    let face = bvh.face[traced.hit.triangle];
                    pixel.face = face;
                    pixel.colour = bvh.face_colours[face as usize];
                    pixel.range = traced.hit.t as f32;
                    pixel.point = bvh.offset + traced.origin + traced.hit.t * traced.direction;
                }
            }
        });
    frame
}

#[cfg(test)]
mod tests {
    use super::*;

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
