//! The fast CPU tracer against the f64 reference (issue 10, ties issue 18): the same hit
//! planes bit for bit on every pixel, faces included, and the same shadow answers
//! (`watertight.rs` checks that no ray of either escapes). Every camera model in both
//! reference rooms, a seeded clutter scene, a room 10 km from the origin, the stability cases
//! (shared edges and corners, rays in the plane of a face, axis rays with −0 components) and
//! coincident and overlapping coplanar faces.
//!
//! Ties (two faces at exactly the same f64 distance) are settled by one rule in both tracers:
//! the lower face id wins. Where the tests meet exact ties they count them with an independent
//! f64 ray–triangle test, so a test that stopped meeting ties would say so.

mod common;

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3, dvec3};
use omnisim::advanced::CpuTracer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::Equirectangular;
use omnisim::frame::Pixel;
use omnisim::scene::{Face, SceneObject};
use omnisim::{Camera, Frame, Pose, Scene, advanced as trace};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Distance along a unit ray (scene-local origin) to triangle `i`, by a plain f64
/// Möller–Trumbore with the reference's edge slack (the same arithmetic, so an exact tie here
/// is one the tracers see).
fn triangle_distance(bvh: &SceneBvh, i: usize, origin: DVec3, direction: DVec3) -> Option<f64> {
    let slack = 1e-10;
    let [a, b, c] = bvh.triangles()[i];
    let (e1, e2) = (b - a, c - a);
    let p = direction.cross(e2);
    let det = e1.dot(p);
    let inv = 1.0 / det;
    let s = origin - a;
    let (u, q) = (s.dot(p) * inv, s.cross(e1));
    let v = direction.dot(q) * inv;
    let inside = (-slack..=1.0 + slack).contains(&u) && v >= -slack && u + v <= 1.0 + slack;
    (det != 0.0 && inside).then(|| e2.dot(q) * inv)
}

/// Whether a triangle of another face than `face` lies on the ray at exactly distance `t`.
fn is_exact_tie(bvh: &SceneBvh, face: u32, t: f64, origin: DVec3, direction: DVec3) -> bool {
    (0..bvh.triangles().len())
        .any(|i| bvh.triangle_face(i) != face && triangle_distance(bvh, i, origin, direction) == Some(t))
}

/// Pixels (or rays) compared, and how many of them were exact ties.
#[derive(Default)]
struct Agreement {
    pixels: usize,
    ties: usize,
    /// Skips counting ties (a scan of every triangle per pixel, too slow for dense scenes).
    uncounted: bool,
}

/// Whether two pixels are the same bit for bit (faces, ranges, points, normals).
fn same_bits(a: &Pixel, b: &Pixel) -> bool {
    a.face == b.face
        && a.range.to_bits() == b.range.to_bits()
        && a.point.to_array().map(f64::to_bits) == b.point.to_array().map(f64::to_bits)
        && a.normal.to_array().map(f32::to_bits) == b.normal.to_array().map(f32::to_bits)
}

impl Agreement {
    /// Compares the fast tracer's frame (traced in packets; the 250×250 omni images end in
    /// partial tiles and have rayless pixels), its portable path's (the same box tests in
    /// other instructions) and the reference's: every pixel the same bits. Counts the pixels
    /// that were exact ties; returns the reference frame.
    fn frames(&mut self, bvh: &SceneBvh, camera: &Camera, pose: &Pose, label: &str) -> Frame {
        let reference = trace::trace(bvh, camera, pose);
        let fast = CpuTracer::Fast.trace(bvh, camera, pose);
        let portable = CpuTracer::FastPortable.trace(bvh, camera, pose);
        let rotation = pose.world_from_body_rotation();
        for (index, ((r, f), p)) in reference
            .pixels()
            .iter()
            .zip(fast.pixels())
            .zip(portable.pixels())
            .enumerate()
        {
            self.pixels += 1;
            assert!(same_bits(f, p), "{label}: pixel {index}: fast {f:?}, portable {p:?}");
            assert!(same_bits(r, f), "{label}: pixel {index}: reference {r:?}, fast {f:?}");
            if !r.is_hit() || self.uncounted {
                continue;
            }
            let pixel = DVec2::new(
                (index % reference.width as usize) as f64,
                (index / reference.width as usize) as f64,
            );
            let ray = camera.ray(pixel).expect("a hit pixel has a ray");
            let origin = pose.position - bvh.offset() + rotation * ray.origin;
            let direction = rotation * ray.direction;
            // The range is the f64 distance rounded to f32: the exact one is recomputed.
            let t = (0..bvh.triangles().len())
                .filter(|&i| bvh.triangle_face(i) == r.face)
                .filter_map(|i| triangle_distance(bvh, i, origin, direction))
                .filter(|&t| t > 0.0)
                .min_by(f64::total_cmp)
                .expect("the face hit lies on the ray");
            if is_exact_tie(bvh, r.face, t, origin, direction) {
                self.ties += 1;
            }
        }
        reference
    }

    /// Compares one ray's closest hits in the three tracers: the same triangle at the same
    /// distance. Counts the ray as a tie where another face lies at exactly that distance.
    fn ray(&mut self, bvh: &SceneBvh, origin: DVec3, direction: DVec3, label: &str) {
        self.pixels += 1;
        let reference = trace::closest_hit(bvh, origin, direction, 0.0);
        let fast = CpuTracer::Fast.closest_hit(bvh, origin, direction, 0.0);
        let portable = CpuTracer::FastPortable.closest_hit(bvh, origin, direction, 0.0);
        assert_eq!(fast, portable, "{label}: fast and portable paths differ");
        assert_eq!(reference, fast, "{label}: ray from {origin} along {direction}");
        let Some(hit) = reference else {
            panic!("{label}: ray from {origin} along {direction} escaped");
        };
        if is_exact_tie(bvh, bvh.triangle_face(hit.triangle), hit.t, origin, direction) {
            self.ties += 1;
        }
    }

    fn report(&self, label: &str) {
        if self.uncounted {
            eprintln!("{label}: {} rays, every one the same in both tracers", self.pixels);
            return;
        }
        eprintln!(
            "{label}: {} rays, every one the same in both tracers, {} of them exact ties",
            self.pixels, self.ties
        );
    }
}

/// Two poses per room: off-centre and turned, and at the exact centre of the scene's bounds
/// (the scene-local origin, where f32 lanes see exact zeros).
fn poses(scene: &Scene) -> [Pose; 2] {
    let (lo, hi) = scene.bounds().unwrap();
    [
        Pose::from_degrees(lo.lerp(hi, 0.3) + dvec3(0.0, 0.0, 0.1), dvec3(3.0, -5.0, 60.0)),
        Pose::new((lo + hi) / 2.0, DVec3::ZERO),
    ]
}

#[test]
fn every_camera_model_in_both_rooms_sees_the_reference_faces_and_ranges() {
    for room in common::ROOMS {
        let scene = common::load(room);
        let bvh = SceneBvh::build(&scene).unwrap();
        let mut agreement = Agreement::default();
        for camera in common::cameras() {
            for pose in poses(&scene) {
                agreement.frames(&bvh, &camera, &pose, &format!("{room}, {}", common::describe(&camera)));
            }
        }
        agreement.report(room);
    }
}

/// env1 with `boxes` small boxes at seeded random positions and rotations, each face its own.
fn clutter(boxes: usize, seed: u64) -> Scene {
    let mut scene = common::load("env1.ron");
    let (lo, hi) = scene.bounds().unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let object = scene.objects.len() as u32;
    scene.objects.push(SceneObject {
        name: "clutter".into(),
        kind: "Mesh",
    });
    for _ in 0..boxes {
        let centre = DVec3::from_array(std::array::from_fn(|k| rng.random_range(lo[k]..hi[k])));
        let half = DVec3::from_array(std::array::from_fn(|_| rng.random_range(0.01..0.15)));
        let angles = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-PI..PI)));
        let rotation = Pose::new(DVec3::ZERO, angles).world_from_body_rotation();
        for vertices in common::box_faces(centre, half, rotation) {
            scene.faces.push(Face {
                vertices: vertices.into(),
                colour: [120, 130, 140],
                object,
            });
        }
    }
    scene
}

#[test]
fn a_cluttered_room_and_its_shadow_rays_match_the_reference() {
    let scene = clutter(400, 11);
    let bvh = SceneBvh::build(&scene).unwrap();
    let camera = Camera::Equirectangular(Equirectangular {
        width: 256,
        height: 128,
    });
    let mut agreement = Agreement::default();
    for pose in poses(&scene) {
        agreement.frames(&bvh, &camera, &pose, "clutter");
    }
    agreement.report("clutter, equirectangular");
    // Shadow rays between random points: the same answer, always (both decide in f64).
    let (lo, hi) = scene.bounds().unwrap();
    let mut rng = StdRng::seed_from_u64(12);
    let mut blocked = 0;
    for _ in 0..4000 {
        let [a, b] = [(); 2].map(|_| DVec3::from_array(std::array::from_fn(|k| rng.random_range(lo[k]..hi[k]))));
        let (origin, offset) = (a - bvh.offset(), b - a);
        let distance = offset.length();
        let skip = rng.random_range(0..scene.faces.len() as u32);
        let reference = trace::occluded(&bvh, origin, offset / distance, distance, skip);
        let fast = CpuTracer::Fast.occluded(&bvh, origin, offset / distance, distance, skip);
        let portable = CpuTracer::FastPortable.occluded(&bvh, origin, offset / distance, distance, skip);
        assert_eq!(
            fast, portable,
            "shadow ray from {a} to {b}: fast and portable paths differ"
        );
        assert_eq!(reference, fast, "shadow ray from {a} to {b}");
        blocked += usize::from(reference);
    }
    assert!(
        (100..3900).contains(&blocked),
        "{blocked} of 4000 shadow rays blocked: a poor test"
    );
}

/// The AVX2 single-ray walk filters a leaf and the next leaf along at once where both lie in
/// two triangle groups; its counts (what `omnisim bench` reports a ray) stay the portable
/// walk's: the same box and f32 triangle tests, and at least as many f64 tests, at most 5 %
/// more (a partner leaf is filtered against the bound from before its neighbour's hits, and
/// a leaf across two groups in one test where the portable walk narrows the bound between
/// them). The paper's omni camera in a cluttered room, whose
/// bottom nodes hold many leaves. (Without AVX2 both run the portable walk.)
#[test]
fn the_fast_walk_counts_the_portable_tests_and_a_few_more_f64_tests() {
    let scene = clutter(400, 11);
    let bvh = SceneBvh::build(&scene).unwrap();
    let camera = Camera::Catadioptric(common::paper_omni());
    for pose in poses(&scene) {
        let fast = CpuTracer::Fast.count_tests(&bvh, &camera, &pose);
        let portable = CpuTracer::FastPortable.count_tests(&bvh, &camera, &pose);
        assert!(portable.primitive_tests > 20_000, "{portable:?}: a poor test");
        assert_eq!(fast.node_tests, portable.node_tests, "box tests");
        assert_eq!(fast.primitive_tests, portable.primitive_tests, "f32 triangle tests");
        assert!(
            (portable.exact_tests..=portable.exact_tests + portable.exact_tests / 20).contains(&fast.exact_tests),
            "f64 tests: fast {}, portable {}",
            fast.exact_tests,
            portable.exact_tests
        );
    }
}

/// A dense scene of small boxes (over 50k triangles, the large-scene build), whose boxes are
/// small against the packets' footprints, so the packet walk tests rays one by one against
/// them (`SMALL_BOX` in `trace/fast/wide.rs`): the spherical mirror's tiles are wide, the
/// paper's hyperbolic ones narrow; every pixel must still be the reference's.
#[test]
fn a_dense_scene_with_per_ray_box_tests_matches_the_reference() {
    let scene = clutter(4_400, 13);
    let bvh = SceneBvh::build(&scene).unwrap();
    assert!(bvh.triangles().len() > 50_000, "{} triangles", bvh.triangles().len());
    let mut agreement = Agreement {
        uncounted: true,
        ..Agreement::default()
    };
    for camera in [
        Camera::Catadioptric(omnisim::camera::Catadioptric::spherical(96, 96, 0.05, 0.25)),
        Camera::Catadioptric(common::paper_omni()),
    ] {
        for pose in poses(&scene) {
            agreement.frames(&bvh, &camera, &pose, "dense clutter");
        }
    }
    agreement.report("dense clutter, omni");
}

/// The renderer's frames of non-central mirrors (the spherical mirror's rays start on the
/// mirror; a misaligned hyperbolic mirror's too), read from its ray table (each ray with its
/// own origin), equal the reference tracer's from the camera's own rays, pixel for pixel, in a
/// dense scene; a second pose reads the same table. The other tests here trace the cameras'
/// rays directly, so without this one the table's non-central path met only small env1.
#[test]
fn non_central_frames_from_the_ray_table_match_the_reference_in_a_dense_scene() {
    let scene = clutter(4_400, 17);
    let renderer = omnisim::Renderer::new(omnisim::BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let misaligned = omnisim::camera::Catadioptric {
        misalignment: omnisim::camera::Misalignment {
            offset: dvec3(0.002, -0.001, 0.003),
            tilt: dvec3(0.01, -0.02, 0.005),
        },
        ..common::paper_omni()
    };
    let mut hits = 0;
    for camera in [
        Camera::Catadioptric(omnisim::camera::Catadioptric::spherical(120, 120, 0.05, 0.25)),
        Camera::Catadioptric(misaligned),
    ] {
        for pose in poses(&scene) {
            let reference = trace::trace(prepared.geometry(), &camera, &pose);
            let tabled = renderer
                .render(&prepared, &camera, &pose, omnisim::frame::Planes::HITS)
                .unwrap();
            for (index, (r, t)) in reference.pixels().iter().zip(tabled.pixels()).enumerate() {
                assert!(same_bits(r, t), "pixel {index}: reference {r:?}, table {t:?}");
            }
            hits += reference.hit_count();
        }
    }
    assert!(hits > 40_000, "{hits} hits: a poor test");
}

#[test]
fn a_room_ten_kilometres_away_matches_the_reference() {
    let mut scene = common::load("env1.ron");
    let shift = dvec3(1e4, 1e4, 0.0);
    for vertex in scene.faces.iter_mut().flat_map(|f| f.vertices.iter_mut()) {
        *vertex += shift;
    }
    let camera = Camera::Equirectangular(Equirectangular {
        width: 256,
        height: 128,
    });
    let mut agreement = Agreement::default();
    // Scene-local (the default) and world coordinates (local origin at the world origin, so
    // every f32 coordinate carries 10 km of rounding).
    for bvh in [
        SceneBvh::build(&scene).unwrap(),
        SceneBvh::build_with_offset(&scene, DVec3::ZERO).unwrap(),
    ] {
        for pose in poses(&scene) {
            agreement.frames(&bvh, &camera, &pose, "env1 at 10 km");
        }
    }
    agreement.report("env1 at 10 km");
}

#[test]
fn edges_corners_grazing_rays_and_negative_zeros_match_the_reference() {
    let turned = Pose::new(DVec3::ZERO, dvec3(0.3, -0.5, 1.1)).world_from_body_rotation();
    for (label, world_from_cube) in [("axis-aligned cube", DMat3::IDENTITY), ("turned cube", turned)] {
        let bvh = SceneBvh::build(&common::cube_room(world_from_cube)).unwrap();
        let centre = DVec3::splat(0.5) - bvh.offset();
        let mut rng = StdRng::seed_from_u64(21);
        let mut agreement = Agreement::default();
        // Rays at triangle edges (face borders and diagonals) and at the cube's corners.
        let mut targets = Vec::new();
        for t in bvh.triangles() {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                targets.extend([a, b]);
                targets.extend((0..6).map(|_| a.lerp(b, rng.random_range(0.0..1.0))));
            }
        }
        for _ in 0..30 {
            let inside = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-0.45..0.45)));
            let origin = centre + world_from_cube * inside;
            for &target in &targets {
                agreement.ray(&bvh, origin, (target - origin).normalize(), label);
            }
        }
        // Rays in, and just inside, the plane of a face (grazing everything on it).
        for inset in [0.0, 1e-12, 1e-6] {
            for axis in 0..3 {
                for side in [-1.0, 1.0] {
                    for _ in 0..200 {
                        let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
                        let mut inside = DVec3::ZERO;
                        inside[axis] = side * (0.5 - inset);
                        inside[j] = rng.random_range(-0.45..0.45);
                        inside[k] = rng.random_range(-0.45..0.45);
                        let theta: f64 = rng.random_range(0.0..2.0 * PI);
                        let mut direction = DVec3::ZERO;
                        (direction[j], direction[k]) = (theta.cos(), theta.sin());
                        let (origin, direction) = (centre + world_from_cube * inside, world_from_cube * direction);
                        agreement.ray(&bvh, origin, direction.normalize(), label);
                    }
                }
            }
        }
        // Axis rays whose other components are −0, from the centre (local zeros too).
        for direction in [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z] {
            for origin in [centre, DVec3::ZERO, centre + dvec3(0.1, -0.2, 0.05)] {
                agreement.ray(&bvh, origin, world_from_cube * direction, label);
            }
        }
        agreement.report(label);
        assert!(
            agreement.ties > 0,
            "{label}: rays aimed at edges and corners met no exact tie"
        );
    }
}

#[test]
fn coincident_and_overlapping_coplanar_faces_resolve_to_the_lower_face_id_in_both_tracers() {
    let scene = common::coincident_faces();
    let (lower_copy, wall_4, wall_2, upper_copy, wall_5, triangle) = common::COINCIDENT_FACE_IDS;
    let bvh = SceneBvh::build(&scene).unwrap();
    let camera = Camera::Equirectangular(Equirectangular {
        width: 256,
        height: 128,
    });
    let mut agreement = Agreement::default();
    let mut seen = [0usize; 9];
    for pose in [
        Pose::new(dvec3(0.5, 0.5, 0.5), DVec3::ZERO),
        Pose::from_degrees(dvec3(0.3, 0.6, 0.45), dvec3(10.0, -20.0, 35.0)),
    ] {
        let frame = agreement.frames(&bvh, &camera, &pose, "coincident faces");
        for pixel in frame.pixels() {
            assert!(pixel.is_hit(), "the closed cube lets no ray out");
            seen[pixel.face as usize] += 1;
        }
    }
    agreement.report("coincident faces");
    // An exact copy ties everywhere: the lower id is all that is ever seen of the pair.
    assert!(seen[lower_copy] > 1000 && seen[wall_4] == 0, "{seen:?}");
    assert!(seen[wall_2] > 1000 && seen[upper_copy] == 0, "{seen:?}");
    // The overlapping triangle has other corners, so it ties with wall 5 only where the f64
    // arithmetic happens to agree; both tracers pick the same face either way.
    assert!(seen[wall_5] + seen[triangle] > 1000, "{seen:?}");
    assert!(
        agreement.ties >= seen[lower_copy] + seen[wall_2],
        "{} ties",
        agreement.ties
    );
}

/// The cube room with a wall of small square tiles in the plane x = 0.85 (neighbours share
/// their edges' vertices exactly), each tile stacked as `COPIES` exact copies of one another,
/// one face each, and small boxes floating in front of them. Returns the scene and, per tile
/// face, which copy it is (0 for the lowest id of its stack, which wins every tie).
fn stacked_tiles() -> (Scene, Vec<Option<usize>>) {
    const TILES: usize = 12;
    const COPIES: usize = 6;
    let mut scene = common::cube_room(DMat3::IDENTITY);
    let mut copy_of = vec![None; scene.faces.len()];
    let corner = |j: usize, k: usize| {
        let at = |i: usize| 0.2 + 0.6 * i as f64 / TILES as f64;
        dvec3(0.85, at(j), at(k))
    };
    for copy in 0..COPIES {
        for j in 0..TILES {
            for k in 0..TILES {
                scene.faces.push(Face {
                    vertices: vec![corner(j, k), corner(j + 1, k), corner(j + 1, k + 1), corner(j, k + 1)].into(),
                    colour: [40 * copy as u8, 150, 90],
                    object: 0,
                });
                copy_of.push(Some(copy));
            }
        }
    }
    let mut rng = StdRng::seed_from_u64(31);
    for _ in 0..150 {
        let centre = dvec3(
            rng.random_range(0.8..0.83),
            rng.random_range(0.25..0.75),
            rng.random_range(0.25..0.75),
        );
        for vertices in common::box_faces(centre, DVec3::splat(0.012), DMat3::IDENTITY) {
            scene.faces.push(Face {
                vertices: vertices.into(),
                colour: [200, 60, 60],
                object: 0,
            });
            copy_of.push(None);
        }
    }
    (scene, copy_of)
}

/// Rays of one packet that meet a stack of exact copies (or the shared edge of two tiles) at
/// exactly equal f64 range: boxes floating just in front stop some of each packet's rays early,
/// so entries popped after a copy was found are narrowed to the rays still reaching them, and
/// subtrees few rays still reach (`FEW_RAYS` in `trace/fast/wide.rs`) are handed over to
/// single-ray walks, which must start from the packet's bound for each ray and still let the
/// lower id win the tie. Counted once with a probe in the walk (both paths, all three poses):
/// 44 k rays handed over, 1.6 k of them finding a lower-id copy at exactly the bound the packet
/// had found, 6 k from entries the narrowing had just left fewer rays. Every pixel must be the
/// reference's, and no copy but the lowest of its stack may ever be seen.
#[test]
fn ties_met_after_narrowing_and_hand_over_to_single_rays_match_the_reference() {
    let (scene, copy_of) = stacked_tiles();
    let bvh = SceneBvh::build(&scene).unwrap();
    let camera = Camera::Equirectangular(Equirectangular {
        width: 512,
        height: 256,
    });
    let mut agreement = Agreement::default();
    let mut seen = vec![0usize; copy_of.len()];
    for pose in [
        Pose::new(dvec3(0.2, 0.5, 0.5), DVec3::ZERO),
        Pose::from_degrees(dvec3(0.15, 0.43, 0.58), dvec3(4.0, -7.0, 12.0)),
        Pose::from_degrees(dvec3(0.35, 0.61, 0.4), dvec3(-3.0, 5.0, -20.0)),
    ] {
        let frame = agreement.frames(&bvh, &camera, &pose, "stacked tiles");
        for pixel in frame.pixels() {
            assert!(pixel.is_hit(), "the closed cube lets no ray out");
            seen[pixel.face as usize] += 1;
        }
    }
    agreement.report("stacked tiles");
    let tiles_seen: usize = (0..seen.len())
        .filter(|&f| copy_of[f] == Some(0))
        .map(|f| seen[f])
        .sum();
    let upper_copies_seen: usize = (0..seen.len()).filter(|&f| copy_of[f] > Some(0)).map(|f| seen[f]).sum();
    assert!(
        tiles_seen > 10_000 && upper_copies_seen == 0,
        "{tiles_seen} tile pixels, {upper_copies_seen} of upper copies"
    );
    assert!(
        agreement.ties >= tiles_seen,
        "{} ties, {tiles_seen} tile pixels",
        agreement.ties
    );
}
