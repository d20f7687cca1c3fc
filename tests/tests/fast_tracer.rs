//! The fast CPU tracer against the f64 reference (issue 10): same faces except counted ties,
//! same ranges, the same shadow answers (`watertight.rs` checks that no ray of either escapes). Every camera model in both reference
//! rooms, a seeded clutter scene, a room 10 km from the origin, and the stability cases (shared
//! edges and corners, rays in the plane of a face, axis rays with −0 components).
//!
//! A tie is a ray along which both faces lie at the same f64 distance (within 1e-9 relative),
//! checked here with an independent f64 ray–triangle test; there either face is right.

mod common;

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3, dvec3};
use omnisim::advanced::CpuTracer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::Equirectangular;
use omnisim::scene::{Face, SceneObject};
use omnisim::{Camera, Pose, Scene, advanced as trace};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Least share of image pixels on which the fast tracer must name the reference's face.
const IMAGES: f64 = 0.9999;

/// Distance along a unit ray (scene-local origin) to the nearest triangle of `face`, by a
/// plain f64 Möller–Trumbore with the reference's edge slack.
fn face_distance(bvh: &SceneBvh, face: u32, origin: DVec3, direction: DVec3) -> Option<f64> {
    let slack = 1e-10;
    (0..bvh.triangles().len())
        .filter(|&i| bvh.triangle_face(i) == face)
        .filter_map(|i| {
            let [a, b, c] = bvh.triangles()[i];
            let (e1, e2) = (b - a, c - a);
            let p = direction.cross(e2);
            let det = e1.dot(p);
            let s = origin - a;
            let (u, q) = (s.dot(p) / det, s.cross(e1));
            let v = direction.dot(q) / det;
            let inside = u >= -slack && v >= -slack && u + v <= 1.0 + slack;
            (det != 0.0 && inside).then(|| e2.dot(q) / det)
        })
        .filter(|&t| t > 0.0)
        .reduce(f64::min)
}

/// Whether faces `a` and `b` both lie on the ray at the same f64 distance.
fn is_tie(bvh: &SceneBvh, a: u32, b: u32, origin: DVec3, direction: DVec3) -> bool {
    match (
        face_distance(bvh, a, origin, direction),
        face_distance(bvh, b, origin, direction),
    ) {
        (Some(ta), Some(tb)) => (ta - tb).abs() <= 1e-9 * ta.max(tb),
        _ => false,
    }
}

/// Pixels compared, face mismatches (every one a checked tie), and the worst relative range
/// difference where faces agree.
#[derive(Default)]
struct Agreement {
    pixels: usize,
    ties: usize,
    worst_range: f64,
}

impl Agreement {
    /// Compares the fast tracer's frame (traced in 8×8 packets; the 250×250 omni images end
    /// in partial tiles and have rayless pixels) with the reference's; panics on any difference that
    /// is not a tie. The fast tracer's AVX2 path (where the CPU has it) and its portable path
    /// must agree exactly: the same box tests in other instructions.
    fn frames(&mut self, bvh: &SceneBvh, camera: &Camera, pose: &Pose, label: &str) {
        let reference = trace::trace(bvh, camera, pose);
        let fast = CpuTracer::Fast.trace(bvh, camera, pose);
        let portable = CpuTracer::FastPortable.trace(bvh, camera, pose);
        for (index, (f, p)) in fast.pixels().iter().zip(portable.pixels()).enumerate() {
            assert!(
                f.face == p.face && f.range.to_bits() == p.range.to_bits(),
                "{label}: pixel {index}: fast {f:?}, portable {p:?}"
            );
        }
        let rotation = pose.world_from_body_rotation();
        for (index, (r, f)) in reference.pixels().iter().zip(fast.pixels()).enumerate() {
            self.pixels += 1;
            assert_eq!(r.is_hit(), f.is_hit(), "{label}: hit or miss differs at pixel {index}");
            if r.face == f.face {
                if r.is_hit() {
                    let error = (f64::from(f.range) - f64::from(r.range)).abs() / f64::from(r.range);
                    self.worst_range = self.worst_range.max(error);
                    assert!(
                        r.point.distance(f.point) <= 1e-9 * (1.0 + f64::from(r.range)),
                        "{label}: point at {index}"
                    );
                }
                continue;
            }
            let pixel = DVec2::new(
                (index % reference.width as usize) as f64,
                (index / reference.width as usize) as f64,
            );
            let ray = camera.ray(pixel).expect("a hit pixel has a ray");
            let origin = pose.position - bvh.offset() + rotation * ray.origin;
            let direction = rotation * ray.direction;
            assert!(
                is_tie(bvh, r.face, f.face, origin, direction),
                "{label}: pixel {index} sees face {} (reference) and {} (fast), not at one distance",
                r.face,
                f.face
            );
            self.ties += 1;
        }
    }

    /// Compares one ray's closest hits; panics on an escape or a difference that is no tie.
    fn ray(&mut self, bvh: &SceneBvh, origin: DVec3, direction: DVec3, label: &str) {
        self.pixels += 1;
        let reference = trace::closest_hit(bvh, origin, direction, 0.0);
        let fast = CpuTracer::Fast.closest_hit(bvh, origin, direction, 0.0);
        let portable = CpuTracer::FastPortable.closest_hit(bvh, origin, direction, 0.0);
        assert_eq!(fast, portable, "{label}: fast and portable paths differ");
        let (Some(r), Some(f)) = (reference, fast) else {
            panic!("{label}: ray from {origin} along {direction}: reference {reference:?}, fast {fast:?}");
        };
        let (rf, ff) = (bvh.triangle_face(r.triangle), bvh.triangle_face(f.triangle));
        if rf == ff {
            self.worst_range = self.worst_range.max((r.t - f.t).abs() / r.t);
        } else {
            assert!(
                is_tie(bvh, rf, ff, origin, direction),
                "{label}: faces {rf} and {ff} along {direction}"
            );
            self.ties += 1;
        }
    }

    /// Faces agree on at least `min_same` of the rays (images: 99.99 %; rays aimed at edges
    /// tie often, and every tie was checked) and ranges within 1e-6 relative where they do.
    fn check(&self, label: &str, min_same: f64) {
        let same = 1.0 - self.ties as f64 / self.pixels as f64;
        eprintln!(
            "{label}: {} rays, {} ties ({:.4} % same face), range within {:.1e} relative",
            self.pixels,
            self.ties,
            100.0 * same,
            self.worst_range
        );
        assert!(same >= min_same, "{label}: only {:.4} % same face", 100.0 * same);
        assert!(
            self.worst_range <= 1e-6,
            "{label}: range {:e} relative",
            self.worst_range
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
        let bvh = SceneBvh::build(&scene);
        let mut agreement = Agreement::default();
        for camera in common::cameras() {
            for pose in poses(&scene) {
                agreement.frames(&bvh, &camera, &pose, &format!("{room}, {}", common::describe(&camera)));
            }
        }
        agreement.check(room, IMAGES);
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
    let bvh = SceneBvh::build(&scene);
    let camera = Camera::Equirectangular(Equirectangular {
        width: 256,
        height: 128,
    });
    let mut agreement = Agreement::default();
    for pose in poses(&scene) {
        agreement.frames(&bvh, &camera, &pose, "clutter");
    }
    agreement.check("clutter, equirectangular", IMAGES);
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
        SceneBvh::build(&scene),
        SceneBvh::build_with_offset(&scene, DVec3::ZERO),
    ] {
        for pose in poses(&scene) {
            agreement.frames(&bvh, &camera, &pose, "env1 at 10 km");
        }
    }
    agreement.check("env1 at 10 km", IMAGES);
}

/// A closed unit cube centred at (0.5, 0.5, 0.5), turned by `world_from_cube`.
fn cube_room(world_from_cube: DMat3) -> Scene {
    let mut scene = Scene::default();
    scene.objects.push(SceneObject {
        name: "cube".into(),
        kind: "Box",
    });
    for vertices in common::box_faces(DVec3::splat(0.5), DVec3::splat(0.5), world_from_cube) {
        scene.faces.push(Face {
            vertices: vertices.into(),
            colour: [200, 200, 200],
            object: 0,
        });
    }
    scene
}

#[test]
fn edges_corners_grazing_rays_and_negative_zeros_match_the_reference() {
    let turned = Pose::new(DVec3::ZERO, dvec3(0.3, -0.5, 1.1)).world_from_body_rotation();
    for (label, world_from_cube) in [("axis-aligned cube", DMat3::IDENTITY), ("turned cube", turned)] {
        let bvh = SceneBvh::build(&cube_room(world_from_cube));
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
        agreement.check(label, 0.0);
    }
}
