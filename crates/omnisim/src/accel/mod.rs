//! The acceleration structure shared by both tracers: an obvhs BVH2 over the scene's triangles.
//!
//! Triangles are stored relative to `offset` (the centre of the scene's bounds, in f64), so the
//! f32 GPU path keeps full precision however far from the world origin a scene is placed.
//! They are reordered into BVH leaf order, so a leaf's `first_index..first_index+prim_count`
//! addresses them directly on both CPU and GPU.

mod collapse;
pub(crate) mod wide;

use std::time::{Duration, Instant};

use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

use crate::scene::triangulate::TriangleIndex;
use crate::scene::{Scene, TooManyTriangles};
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

// The wide BVH's leaves hold at most `wide::MAX_LEAF_TRIANGLES` triangles; both presets collapse
// leaves as `collapse::collapse_leaf_pairs` does (leaves of `collapse::MAX_LEAF`, a traversal
// cost of at least that, no reinsertion after the collapse).
const _: () = {
    // The leaves address every triangle a scene may have.
    assert!(SceneBvh::MAX_TRIANGLES <= wide::FIRST_TRIANGLE as usize + 1);
    assert!(collapse::MAX_LEAF as usize <= wide::MAX_LEAF_TRIANGLES);
    let presets = [BUILD_PARAMS, LARGE_BUILD_PARAMS];
    let mut i = 0;
    while i < presets.len() {
        assert!(presets[i].max_prims_per_leaf == collapse::MAX_LEAF);
        assert!(presets[i].collapse_traversal_cost >= collapse::MAX_LEAF as f32);
        assert!(presets[i].post_collapse_reinsertion_batch_ratio_multiplier == 0.0);
        i += 1;
    }
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

/// Below this many triangles the build's per-triangle passes (corners, boxes, the leaf collapse,
/// leaf order, the wide BVH's subtrees and groups, face normals) stay on the calling thread: at 10k triangles
/// handing them to rayon's pool cost more than the work, even once the CLI starts the pool
/// early (docs/benchmarks.md, "BVH build at small sizes", "2026-11-27 (lead)").
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

/// `f` of each of `0..count`, in order, as two lists: one pass where two maps would read the
/// same input twice (on all threads from [`PARALLEL_FROM`] items, else on this one).
fn map_indices_unzip<A: Send, B: Send>(count: usize, f: impl Fn(usize) -> (A, B) + Sync + Send) -> (Vec<A>, Vec<B>) {
    if count < PARALLEL_FROM {
        (0..count).map(f).unzip()
    } else {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        (0..count).into_par_iter().map(f).unzip_into_vecs(&mut a, &mut b);
        (a, b)
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
    /// The most triangles a scene may have, [`crate::scene::MAX_TRIANGLES`], which the wide
    /// BVH's leaves address.
    pub const MAX_TRIANGLES: usize = crate::scene::MAX_TRIANGLES;

    /// Builds the BVH with the local origin at the centre of the scene's bounds; refuses a scene
    /// of more than [`SceneBvh::MAX_TRIANGLES`] triangles.
    pub fn build(scene: &Scene) -> Result<Self, TooManyTriangles> {
        let (lo, hi) = scene.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
        Self::build_with_offset(scene, (lo + hi) / 2.0)
    }

    /// Builds the BVH with the local origin at `offset` (world metres), refusing what `build`
    /// refuses. `build` picks the scene's centre; other offsets exist to measure what that
    /// choice buys (docs/accuracy.md).
    ///
    /// Peak memory is what limits scene size, so the order matters: the face normals and the
    /// wide BVH are made only once the builder's working set is freed. The corners in face
    /// order (72 bytes a triangle) are held while obvhs builds, for a faster leaf order: at 1M
    /// triangles that raised the process's peak from 626 to 669 MB for 29 ms less build
    /// (docs/benchmarks.md, "2026-11-27 (build)"). Since then the build's heap high-water at
    /// 1M is below scene loading's (heaptrack 451 → 440 MB, the loader's; the peak RSS of
    /// 669 MB is the loader's pages reused; "2026-11-27 midday (build)").
    pub fn build_with_offset(scene: &Scene, offset: DVec3) -> Result<Self, TooManyTriangles> {
        // Timed from the scene's faces, as Open3D's build is timed from its triangle arrays:
        // triangulation, boxes, obvhs, leaf order, the wide BVH and face normals.
        let start = Instant::now();
        // A mesh's faces are all triangles: triangle i is then face i, and the list of triangle
        // indices (16 bytes a triangle, made on one thread) is not needed.
        let all_triangles = every_face_a_triangle(scene);
        // Counted before anything is made for them.
        crate::scene::check_triangle_count(if all_triangles {
            scene.faces.len()
        } else {
            scene.triangle_count()
        })?;
        let triangles = (!all_triangles).then(|| scene.triangle_indices());
        let triangle_count = triangles.as_ref().map_or(scene.faces.len(), Vec::len);
        let triangle = |i: usize| {
            triangles
                .as_ref()
                .map_or_else(|| TriangleIndex::whole_face(i as u32), |list| list[i])
        };
        // Each triangle's corners read from its face once, in face order (on all threads from
        // `PARALLEL_FROM`), for the boxes and the leaf order both. Read again from the faces in
        // leaf order instead, each triangle cost two scattered reads (its index, then its face)
        // where it now costs one: at 1M triangles the leaf order took 96 ms on two threads
        // against 51, for 16 ms more in the boxes' pass (docs/benchmarks.md, "2026-11-27 (build)").
        // obvhs reads each triangle's box from the corners once, as it makes its leaves: a list
        // of boxes (32 bytes a triangle) is never made.
        let read_once: Vec<Corners> = map_indices(triangle_count, |i| {
            Corners(triangle(i).corners(scene).map(|p| p - offset))
        });
        let mut bvh = if read_once.is_empty() {
            Bvh2::default()
        } else {
            let params = if read_once.len() > LARGE_SCENE {
                LARGE_BUILD_PARAMS
            } else {
                BUILD_PARAMS
            };
            build_bvh2(&read_once, params)
        };
        // Leaf order (obvhs may list a primitive more than once if it splits primitives).
        // Indexed collects: each list is allocated once, by this thread.
        // Only the BVH2's nodes are walked after the build (the reference tracer): its leaf order
        // lives on in `corners` and `face`; its parents list went in the leaf collapse.
        let order = std::mem::take(&mut bvh.primitive_indices);
        let (corners, face): (Vec<[DVec3; 3]>, Vec<u32>) = map_indices_unzip(order.len(), |k| {
            let index = order[k] as usize;
            (read_once[index].0, triangle(index).face)
        });
        drop((triangles, read_once, order));
        let wide = WideBvh::build(&bvh, &corners);
        let face_normals = map_indices(scene.faces.len(), |face| scene.face_normal(face));
        Ok(Self {
            offset,
            triangles: corners,
            face,
            face_normals,
            bvh,
            wide,
            build_time: start.elapsed(),
        })
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

    /// Heap bytes this BVH holds once built (both tracers' trees, the f64 corners, faces and
    /// face normals), for memory per triangle (`omnisim bench`'s `bvh_bytes`).
    pub fn heap_bytes(&self) -> usize {
        fn bytes<T>(list: &Vec<T>) -> usize {
            list.capacity() * std::mem::size_of::<T>()
        }
        bytes(&self.bvh.nodes)
            + bytes(&self.bvh.primitive_indices)
            + bytes(&self.bvh.primitive_indices_freelist)
            + bytes(&self.bvh.primitives_to_nodes)
            + bytes(&self.bvh.parents)
            + bytes(&self.triangles)
            + bytes(&self.face)
            + bytes(&self.face_normals)
            + bytes(&self.wide.nodes)
            + bytes(&self.wide.groups)
    }

    /// Scene face of triangle `triangle` (an index in BVH leaf order, as in [`crate::trace::Hit`]).
    pub fn triangle_face(&self, triangle: usize) -> u32 {
        self.face[triangle]
    }
}

/// obvhs's BVH2 over `corners` with `params`: its builder and reinsertion, then its leaf
/// collapse as [`collapse::collapse_leaf_pairs`] does it (the same tree, on all threads).
fn build_bvh2(corners: &[Corners], params: BvhBuildParams) -> Bvh2 {
    let mut bvh = build_uncollapsed(corners, params);
    collapse::collapse_leaf_pairs(&mut bvh);
    bvh
}

/// obvhs's BVH2 over `corners` before its leaves are collapsed: PLOC, then reinsertion.
fn build_uncollapsed(corners: &[Corners], params: BvhBuildParams) -> Bvh2 {
    let all = (0..corners.len() as u32).collect();
    let mut bvh = obvhs::ploc::PlocBuilder::with_capacity(corners.len()).build(
        params.ploc_search_distance,
        corners,
        all,
        params.sort_precision,
        params.search_depth_threshold,
    );
    obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh, params.reinsertion_batch_ratio, None);
    bvh
}

/// Whether every face of `scene` is a triangle (on all threads from [`PARALLEL_FROM`] faces).
fn every_face_a_triangle(scene: &Scene) -> bool {
    let triangle = |face: &crate::scene::Face| face.vertices.len() == 3;
    if scene.faces.len() < PARALLEL_FROM {
        scene.faces.iter().all(triangle)
    } else {
        scene.faces.par_iter().all(triangle)
    }
}

/// A triangle's corners, which obvhs bounds by their [`padded_aabb`].
struct Corners([DVec3; 3]);

impl obvhs::Boundable for Corners {
    fn aabb(&self) -> Aabb {
        padded_aabb(&self.0)
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
    use super::wide::{LEAF, WIDTH, leaf_triangles};
    use super::*;
    use crate::scene::Face;
    use glam::{Vec3, Vec4};

    /// The cap is the scene's, which the wide BVH's leaves address: 2^29 triangles pass, one
    /// more is refused naming the count, the cap and what to do, and `Renderer::prepare` (the
    /// build's refusal) says so (scene loading's side: `scene::build`'s `triangle_cap_tests`).
    /// A scene's count is what triangulating it gives (env1 has polygons of more than three
    /// vertices), so no scene of that size is made.
    #[test]
    fn a_scene_over_2_pow_29_triangles_is_refused_by_its_count() {
        assert!(crate::scene::check_triangle_count(SceneBvh::MAX_TRIANGLES).is_ok());
        let refusal = crate::scene::check_triangle_count(SceneBvh::MAX_TRIANGLES + 1).unwrap_err();
        let message = refusal.to_string();
        assert_eq!(
            message,
            "536870913 triangles, more than the 536870912 (2^29) omnisim traces in one scene (its BVH addresses \
             triangles in 29 bits): split the scene into several, or simplify its meshes"
        );
        assert_eq!(
            crate::RenderError::from(refusal).to_string(),
            format!("the scene has {message}")
        );
        let (scene, _) = crate::trace::test_scene("env1");
        assert!(scene.faces.iter().any(|face| face.vertices.len() > 3));
        assert_eq!(scene.triangle_count(), scene.triangulate().len());
    }

    /// env1 plus a bumpy grid of `2 * cells²` triangles (as `omnisim bench
    /// --synthetic-triangles` adds one, `add_height_field` in the CLI, which this crate cannot call).
    pub(super) fn grid_scene(cells: usize) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env1.ron");
        let mut scene = Scene::load(&path).unwrap();
        let point = |i: usize, j: usize| {
            let (s, t) = (i as f64 / cells as f64, j as f64 / cells as f64);
            DVec3::new(
                s * 3.0 - 1.5,
                t * 3.0 - 1.5,
                0.1 + 0.05 * (s * 40.0).sin() * (t * 33.0).cos(),
            )
        };
        for i in 0..cells {
            for j in 0..cells {
                let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
                for vertices in [[a, b, c], [a, c, d]] {
                    scene.faces.push(Face {
                        vertices: vertices.into(),
                        colour: [200, 200, 200],
                        object: 0,
                    });
                }
            }
        }
        scene
    }

    /// Each triangle in leaf order keeps its face, with or without the list of triangle indices
    /// (a mesh of triangles only goes without): its corners are the face's vertices, in the
    /// face's order where the face is a triangle.
    #[test]
    fn leaf_order_keeps_each_triangle_with_its_face() {
        // 160² cells: both scenes at least `PARALLEL_FROM` triangles, where the passes run on all threads.
        for cells in [50, 160] {
            let mixed = grid_scene(cells);
            let mut triangles_only = mixed.clone();
            triangles_only.faces.retain(|face| face.vertices.len() == 3);
            assert!(triangles_only.faces.len() < mixed.faces.len());
            for scene in [mixed, triangles_only] {
                let bvh = SceneBvh::build(&scene).unwrap();
                assert_eq!(bvh.face.len(), bvh.triangles.len());
                let mut per_face = vec![0; scene.faces.len()];
                for (corners, &face) in bvh.triangles.iter().zip(&bvh.face) {
                    per_face[face as usize] += 1;
                    let vertices: Vec<DVec3> = scene.faces[face as usize]
                        .vertices
                        .iter()
                        .map(|&v| v - bvh.offset)
                        .collect();
                    if vertices.len() == 3 {
                        assert_eq!(corners.as_slice(), vertices.as_slice(), "face {face}");
                    } else {
                        assert!(corners.iter().all(|corner| vertices.contains(corner)), "face {face}");
                    }
                }
                // A polygon of n vertices is n − 2 triangles.
                for (face, &count) in per_face.iter().enumerate() {
                    assert_eq!(count, scene.faces[face].vertices.len() - 2, "face {face}");
                }
            }
        }
    }

    /// Scenes of one to five triangles, each in both face orders (obvhs leaves BVHs of up to
    /// three triangles in its builder's order, where a two-triangle subtree need not be a run
    /// of leaf order): each builds, and both fast walks find the reference's hits on rays from
    /// the world origin in every direction.
    #[test]
    fn tiny_scenes_build_and_trace_as_the_reference() {
        use crate::trace::CpuTracer;
        let face = |vertices: &[[f64; 3]]| Face {
            vertices: vertices.iter().map(|&v| DVec3::from_array(v)).collect(),
            colour: [200, 200, 200],
            object: 0,
        };
        let quad = [[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [1.0, 2.0, 1.0], [-1.0, 2.0, 1.0]];
        let pentagon = [
            [-1.0, -2.0, -1.0],
            [1.0, -2.0, -1.0],
            [1.5, -2.0, 0.5],
            [0.0, -2.0, 1.5],
            [-1.5, -2.0, 0.5],
        ];
        let triangle = |x: f64| [[x, -1.0, 3.0], [x + 1.0, -1.0, 3.0], [x, 1.0, 3.0]];
        let scenes: Vec<Vec<Face>> = vec![
            vec![face(&triangle(0.0))],
            vec![face(&quad)],
            vec![face(&pentagon)],
            vec![face(&triangle(-2.0)), face(&triangle(1.0))],
            vec![face(&triangle(-2.0)), face(&triangle(1.0)), face(&triangle(-0.5))],
            vec![face(&quad), face(&pentagon)],
        ];
        let directions: Vec<DVec3> = (0..40)
            .flat_map(|i| (0..80).map(move |j| (i, j)))
            .map(|(i, j)| {
                let (polar, azimuth) = (
                    std::f64::consts::PI * (f64::from(i) + 0.5) / 40.0,
                    std::f64::consts::TAU * f64::from(j) / 80.0,
                );
                DVec3::new(polar.sin() * azimuth.cos(), polar.sin() * azimuth.sin(), polar.cos())
            })
            .collect();
        for (s, faces) in scenes.into_iter().enumerate() {
            for reversed in [false, true] {
                let mut faces = faces.clone();
                if reversed {
                    faces.reverse();
                    for face in &mut faces {
                        face.vertices.reverse();
                    }
                }
                let scene = Scene {
                    faces,
                    ..Scene::default()
                };
                let bvh = SceneBvh::build(&scene).unwrap();
                let mut hits = 0;
                for &direction in &directions {
                    let origin = -bvh.offset;
                    let reference = CpuTracer::Reference.closest_hit(&bvh, origin, direction, 0.0);
                    hits += usize::from(reference.is_some());
                    for tracer in [CpuTracer::Fast, CpuTracer::FastPortable] {
                        assert_eq!(
                            tracer.closest_hit(&bvh, origin, direction, 0.0),
                            reference,
                            "scene {s} {reversed}"
                        );
                    }
                }
                assert!(hits > 0, "scene {s}: no ray met it");
            }
        }
    }

    /// Below and above `PARALLEL_FROM`: the wide BVH, walked from its root, reaches every
    /// triangle exactly once, inside its lane's box, its children point inside it, each node
    /// is full unless all its children are leaves, and the built BVH keeps under 240 bytes a
    /// triangle (221 measured at 1 M triangles, 213 at 10k, with leaves of two triangles and
    /// groups dense in leaf order; docs/benchmarks.md) with the BVH2's build lists freed.
    #[test]
    fn wide_bvh_holds_every_triangle_once_in_bounded_memory() {
        for cells in [50, 160] {
            let scene = grid_scene(cells);
            let bvh = SceneBvh::build(&scene).unwrap();
            let count = bvh.triangles.len();
            assert!(count > 2 * cells * cells);
            // Walked from the root (above `PARALLEL_FROM` the subtrees are built apart and
            // joined): every node and triangle reached once, each triangle and each child's
            // boxes inside the box of the lane that leads to them, no node deeper than `depth`.
            let wide = &bvh.wide;
            let mut nodes_seen = vec![0u32; wide.nodes.len()];
            let mut seen = vec![0u32; count];
            let everywhere = [Vec3::NEG_INFINITY, Vec3::INFINITY];
            let mut pending = vec![(0usize, 0usize, everywhere)];
            while let Some((index, depth, [parent_lo, parent_hi])) = pending.pop() {
                nodes_seen[index] += 1;
                assert!(depth <= wide.depth, "{cells}: node {index} {depth} levels down");
                let node = &wide.nodes[index];
                for (lane, &child) in node.child[..node.lanes.count_ones() as usize].iter().enumerate() {
                    let corner = |bound: &[[Vec4; 2]; 3]| {
                        Vec3::from_array([0, 1, 2].map(|axis| bound[axis][lane / 4][lane % 4]))
                    };
                    let (lo, hi) = (corner(&node.min), corner(&node.max));
                    assert!(
                        lo.cmpge(parent_lo).all() && hi.cmple(parent_hi).all(),
                        "{cells}: node {index}"
                    );
                    if child & LEAF == 0 {
                        pending.push((child as usize, depth + 1, [lo, hi]));
                        continue;
                    }
                    let (first, triangles) = leaf_triangles(child);
                    for (triangle, reached) in seen.iter_mut().enumerate().skip(first).take(triangles) {
                        *reached += 1;
                        for point in bvh.triangles[triangle].map(DVec3::as_vec3) {
                            assert!(
                                point.cmpge(lo).all() && point.cmple(hi).all(),
                                "{cells}: triangle {triangle}"
                            );
                        }
                    }
                }
            }
            assert!(
                nodes_seen.iter().all(|&n| n == 1),
                "{cells}: a node unreached or repeated"
            );
            // Group k lane j holds triangle 4k + j of leaf order; the last group's spare lanes are zero.
            for (k, group) in wide.groups.iter().enumerate() {
                for lane in 0..4 {
                    let corner = group.lanes4.corner.map(|axis| axis[lane]);
                    let expected = bvh
                        .triangles
                        .get(4 * k + lane)
                        .map_or([0.0; 3], |t| t[0].as_vec3().to_array());
                    assert_eq!(corner, expected, "{cells}: group {k} lane {lane}");
                }
            }
            assert_eq!(wide.groups.len(), count.div_ceil(4), "{cells}: a group too many");
            assert!(seen.iter().all(|&n| n == 1), "{cells}: a triangle missing or repeated");
            for node in &bvh.wide.nodes {
                // `open` stops short of eight children only when none of them can be opened.
                let all_leaves = node.child[..node.lanes.count_ones() as usize]
                    .iter()
                    .all(|&child| child & LEAF != 0);
                assert!(
                    node.lanes == (1 << WIDTH) - 1 || all_leaves,
                    "{cells}: {:b}",
                    node.lanes
                );
                for lane in 0..node.lanes.count_ones() as usize {
                    let child = node.child[lane];
                    if child & LEAF == 0 {
                        assert!((child as usize) < bvh.wide.nodes.len());
                    } else {
                        let (first, triangles) = leaf_triangles(child);
                        assert!(first + triangles <= count);
                    }
                }
            }
            assert!(bvh.bvh.primitive_indices.is_empty() && bvh.bvh.parents.is_empty());
            let per_triangle = bvh.heap_bytes() as f64 / count as f64;
            assert!(
                (100.0..240.0).contains(&per_triangle),
                "{cells}: {per_triangle} bytes a triangle"
            );
        }
    }
}
