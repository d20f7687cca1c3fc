//! The acceleration structure shared by both tracers: an obvhs BVH2 over the scene's triangles.
//!
//! Triangles are stored relative to `offset` (the centre of the scene's bounds, in f64), so the
//! f32 GPU path keeps full precision however far from the world origin a scene is placed.
//! They are reordered into BVH leaf order, so a leaf's `first_index..first_index+prim_count`
//! addresses them directly on both CPU and GPU.

use std::time::{Duration, Instant};

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

use crate::scene::{Scene, Triangles};

/// obvhs's medium build with leaves of at most two triangles instead of eight. Counted by
/// `omnisim bench` on the clutter anchor (240k triangles), equirectangular from its centre:
/// 27.6 → 11.0 f64 triangle tests and 214 → 226 f32 box tests per ray, CPU 5–20 % faster,
/// lavapipe unchanged, build 165 → 137 ms (docs/benchmarks.md).
const BUILD_PARAMS: BvhBuildParams = BvhBuildParams {
    max_prims_per_leaf: 2,
    ..BvhBuildParams::medium_build()
};

#[derive(Clone)]
pub struct SceneBvh {
    /// World position of the local origin of `triangles` and of the BVH.
    pub offset: DVec3,
    pub bvh: Bvh2,
    /// Triangle corners relative to `offset`, in BVH leaf order.
    pub triangles: Vec<[DVec3; 3]>,
    /// Scene face of each triangle, in BVH leaf order.
    pub face: Vec<u32>,
    /// Unit normal of each scene face (f64, orientation as the face's vertex order), so that
    /// shading works with exact normals whatever precision the hit came in.
    pub face_normals: Vec<DVec3>,
    /// Time spent in obvhs's builder.
    pub build_time: Duration,
}

impl SceneBvh {
    /// Builds the BVH with the local origin at the centre of the scene's bounds.
    pub fn build(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
        Self::build_with_offset(scene, (lo + hi) / 2.0)
    }

    /// Builds the BVH with the local origin at `offset` (world metres). `build` picks the
    /// scene's centre; other offsets exist to measure what that choice buys (docs/accuracy.md).
    pub fn build_with_offset(scene: &Scene, offset: DVec3) -> Self {
        let triangles = scene.triangulate();
        let face_normals = (0..scene.faces.len()).map(|face| scene.face_normal(face)).collect();
        Self::from_triangles(triangles, offset, face_normals)
    }

    /// Consumes the triangles and reorders them in place: each triangle is held once (72 bytes
    /// of corners), not three times, so peak memory stays near the final structure's size.
    fn from_triangles(triangles: Triangles, offset: DVec3, face_normals: Vec<DVec3>) -> Self {
        let Triangles {
            corners: mut local,
            face: mut faces,
        } = triangles;
        for corners in &mut local {
            *corners = corners.map(|p| p - offset);
        }
        let boxes: Vec<Aabb> = local.iter().map(padded_aabb).collect();
        let start = Instant::now();
        let mut core_time = Duration::ZERO;
        let bvh = if boxes.is_empty() {
            Bvh2::default()
        } else {
            obvhs::bvh2::builder::build_bvh2(&boxes, BUILD_PARAMS, &mut core_time)
        };
        let build_time = start.elapsed();
        drop(boxes);
        if bvh.primitive_indices.len() == local.len() {
            permute(&mut local, &mut faces, &bvh.primitive_indices);
        } else {
            // Not a permutation (obvhs may split primitives): copy in leaf order.
            let order = &bvh.primitive_indices;
            local = order.iter().map(|&i| local[i as usize]).collect();
            faces = order.iter().map(|&i| faces[i as usize]).collect();
        }
        Self {
            offset,
            triangles: local,
            face: faces,
            bvh,
            face_normals,
            build_time,
        }
    }

    /// Deepest node below the root, which bounds the traversal stack any tracer needs.
    pub fn depth(&self) -> usize {
        if self.bvh.nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut pending = vec![(0usize, 0usize)];
        while let Some((index, depth)) = pending.pop() {
            deepest = deepest.max(depth);
            let node = &self.bvh.nodes[index];
            if !node.is_leaf() {
                let first = node.first_index as usize;
                pending.push((first, depth + 1));
                pending.push((first + 1, depth + 1));
            }
        }
        deepest
    }
}

/// Puts `a[order[k]]` at `a[k]` (and the same for `b`) in place, cycle by cycle, with one bit
/// per element to mark what is done.
fn permute<A: Copy, B: Copy>(a: &mut [A], b: &mut [B], order: &[u32]) {
    let mut done = vec![0u64; order.len().div_ceil(64)];
    for start in 0..order.len() {
        if done[start / 64] >> (start % 64) & 1 == 1 {
            continue;
        }
        let (first_a, first_b) = (a[start], b[start]);
        let mut k = start;
        loop {
            done[k / 64] |= 1 << (k % 64);
            let next = order[k] as usize;
            if next == start {
                (a[k], b[k]) = (first_a, first_b);
                break;
            }
            (a[k], b[k]) = (a[next], b[next]);
            k = next;
        }
    }
}

/// A triangle's f32 box, grown so that f32 box tests never reject a ray the f64 triangle test
/// would accept (rounding of the box, the ray origin and the inverse direction).
fn padded_aabb(corners: &[DVec3; 3]) -> Aabb {
    let lo = corners[0].min(corners[1]).min(corners[2]);
    let hi = corners[0].max(corners[1]).max(corners[2]);
    let pad = 1e-5 * (1.0 + lo.abs().max(hi.abs()).max_element());
    Aabb::new(Vec3A::from((lo - pad).as_vec3()), Vec3A::from((hi + pad).as_vec3()))
}

#[cfg(test)]
mod tests {
    #[test]
    fn permutes_in_place_like_a_copy() {
        let order = [3u32, 0, 4, 1, 2, 6, 5];
        let (mut a, mut b): (Vec<u32>, Vec<char>) = ((10..17).collect(), "abcdefg".chars().collect());
        super::permute(&mut a, &mut b, &order);
        assert_eq!(a, order.iter().map(|&i| 10 + i).collect::<Vec<_>>());
        assert_eq!(b.iter().collect::<String>(), "daebcgf");
    }
}
