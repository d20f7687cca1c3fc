//! The acceleration structure shared by both tracers: an obvhs BVH2 over the scene's triangles.
//!
//! Triangles are stored relative to `offset` (the centre of the scene's bounds, in f64), so the
//! f32 GPU path keeps full precision however far from the world origin a scene is placed.
//! They are reordered into BVH leaf order, so a leaf's `first_index..first_index+prim_count`
//! addresses them directly on both CPU and GPU.

pub(crate) mod wide;

use std::time::{Duration, Instant};

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

use crate::scene::Scene;
use crate::scene::triangulate::TriangleIndex;
use wide::WideBvh;

/// obvhs's medium build with leaves of at most two triangles instead of eight, and without its
/// second reinsertion pass (after the leaves are collapsed). Leaves of two, counted by
/// `omnisim bench` on the clutter anchor (240k triangles, built with this preset before
/// `LARGE_SCENE` existed), equirectangular from its centre: 27.6 → 11.0 f64 triangle tests
/// and 214 → 226 f32 box tests per ray, CPU 5–20 % faster, lavapipe unchanged. The second
/// reinsertion pass was a sixth of a 10k-triangle build's instructions (callgrind 38.9 →
/// 32.2 M), for under 1 % of a frame's (omni 250² +0.9 % at 10k triangles, +0.5 % at 30k);
/// against `Open3D`'s build the wall-clock runs were too noisy to decide (docs/benchmarks.md,
/// "small scenes' frames and builds").
const BUILD_PARAMS: BvhBuildParams = BvhBuildParams {
    max_prims_per_leaf: 2,
    post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
    ..BvhBuildParams::medium_build()
};

/// Scenes with more triangles than this get `LARGE_BUILD_PARAMS`: from 50k triangles the fast
/// build takes about half the medium build's time for 3–8 % more box tests per ray, below it
/// 20–40 % more (issue 18, `bench/bvh_build.py` scenes; docs/benchmarks.md, "BVH build").
pub(crate) const LARGE_SCENE: usize = 50_000;

/// obvhs's fast build (narrower PLOC search, less reinsertion), leaves of at most two
/// triangles, for large scenes where build time counts (docs/benchmarks.md, "BVH build").
const LARGE_BUILD_PARAMS: BvhBuildParams = BvhBuildParams {
    max_prims_per_leaf: 2,
    ..BvhBuildParams::fast_build()
};

/// Below this many triangles the build's per-triangle passes (boxes, leaf order, the wide
/// BVH's groups, face normals) stay on the calling thread: at 10k triangles handing them to
/// rayon's pool, which a fresh process must start first, cost more than the work
/// (docs/benchmarks.md, "BVH build at small sizes").
const PARALLEL_FROM: usize = 50_000;

/// `f` of each of `0..count`, in order: on all threads from [`PARALLEL_FROM`] items, else on
/// this one.
pub(crate) fn map_indices<U: Send>(count: usize, f: impl Fn(usize) -> U + Sync + Send) -> Vec<U> {
    if count < PARALLEL_FROM {
        (0..count).map(f).collect()
    } else {
        (0..count).into_par_iter().map(f).collect()
    }
}

/// A scene's triangles in a BVH, around a local origin: what both tracers traverse. Built once
/// per geometry ([`crate::Renderer::prepare`]); colours and lights live elsewhere.
#[derive(Clone)]
pub struct SceneBvh {
    /// World position of the local origin of `triangles` and of the BVH.
    pub(crate) offset: DVec3,
    pub(crate) bvh: Bvh2,
    /// Triangle corners relative to `offset`, in BVH leaf order.
    pub(crate) triangles: Vec<[DVec3; 3]>,
    /// Scene face of each triangle, in BVH leaf order.
    pub(crate) face: Vec<u32>,
    /// Unit normal of each scene face (f64, orientation as the face's vertex order), so that
    /// shading works with exact normals whatever precision the hit came in.
    pub(crate) face_normals: Vec<DVec3>,
    /// The 8-wide BVH over the same boxes and triangles that the fast CPU tracer and the GPU
    /// walk (`gpu/wide.rs` converts it).
    pub(crate) wide: WideBvh,
    /// Time the whole build took: triangulation, boxes, obvhs's builder, leaf order, the
    /// wide BVH collapsed from it and the face normals.
    pub(crate) build_time: Duration,
}

impl SceneBvh {
    /// Builds the BVH with the local origin at the centre of the scene's bounds.
    pub fn build(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
        Self::build_with_offset(scene, (lo + hi) / 2.0)
    }

    /// Builds the BVH with the local origin at `offset` (world metres). `build` picks the
    /// scene's centre; other offsets exist to measure what that choice buys (docs/accuracy.md).
    ///
    /// Peak memory is what limits scene size, so the order matters: triangles are held by
    /// reference (16 bytes each) while obvhs builds, and their f64 corners (72 bytes) and the
    /// face normals are made only once the builder's working set is freed.
    pub fn build_with_offset(scene: &Scene, offset: DVec3) -> Self {
        // Timed from the scene's faces, as Open3D's build is timed from its triangle arrays:
        // triangulation, boxes, obvhs, leaf order, the wide BVH and face normals.
        let start = Instant::now();
        let triangles = scene.triangle_indices();
        let local = |t: &TriangleIndex| t.corners(scene).map(|p| p - offset);
        // Small scenes read each triangle's corners from its face once, for the boxes and the
        // leaf order both; large ones read them twice rather than hold 72 bytes a triangle
        // while obvhs builds.
        let read_once: Vec<[DVec3; 3]> = if triangles.len() < PARALLEL_FROM {
            triangles.iter().map(local).collect()
        } else {
            Vec::new()
        };
        let corners_of = |i: usize| read_once.get(i).copied().unwrap_or_else(|| local(&triangles[i]));
        let boxes: Vec<Aabb> = map_indices(triangles.len(), |i| padded_aabb(&corners_of(i)));
        let mut core_time = Duration::ZERO;
        let bvh = if boxes.is_empty() {
            Bvh2::default()
        } else {
            let params = if boxes.len() > LARGE_SCENE {
                LARGE_BUILD_PARAMS
            } else {
                BUILD_PARAMS
            };
            obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut core_time)
        };
        drop(boxes);
        // Leaf order (obvhs may list a primitive more than once if it splits primitives).
        // Indexed collects: each list is allocated once, by this thread.
        let order = &bvh.primitive_indices;
        let corners: Vec<[DVec3; 3]> = map_indices(order.len(), |k| corners_of(order[k] as usize));
        let face: Vec<u32> = map_indices(order.len(), |k| triangles[order[k] as usize].face);
        drop((triangles, read_once));
        let wide = WideBvh::build(&bvh, &corners);
        let face_normals = map_indices(scene.faces.len(), |face| scene.face_normal(face));
        Self {
            offset,
            triangles: corners,
            face,
            face_normals,
            bvh,
            wide,
            build_time: start.elapsed(),
        }
    }

    /// World position of the local origin: triangles and tracing rays are given relative to it.
    pub fn offset(&self) -> DVec3 {
        self.offset
    }

    /// Triangle corners relative to [`SceneBvh::offset`], in BVH leaf order.
    pub fn triangles(&self) -> &[[DVec3; 3]] {
        &self.triangles
    }

    /// Time the whole build took, from the scene's faces to the wide BVH and face normals.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Scene face of triangle `triangle` (an index in BVH leaf order, as in [`crate::trace::Hit`]).
    pub fn triangle_face(&self, triangle: usize) -> u32 {
        self.face[triangle]
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
