//! Stability where methods fail (DESIGN.md §5), measured and bounded. Every test prints the
//! figures quoted in `docs/accuracy.md`:
//!
//! 1. a camera displaced from the mirror's focus: the error of the reference paper's shortcut
//!    (aligned closed form applied to a non-central camera), and `validate` refusing it;
//! 2. a room up to 10 km from the world origin: the f32 GPU against the f64 reference, with
//!    the default scene-local offset and with naive world coordinates;
//! 3. pixels grazing the mirror rim: a sharp, finite, panic-free cut-off on the CPU, and
//!    CPU/GPU hit-or-miss agreement everywhere but next to the rim circle;
//! 4. rays aimed exactly at shared edges and corners of a closed cube room (none escapes), and
//!    rays travelling in (or parallel to) the plane of a face (no bogus distance);
//! 5. a 1 mm marker and a 10 km floor in one view: the marker where its closed-form
//!    projection says, the floor's kilometre ranges equal on CPU and GPU.

mod common;

use std::f64::consts::TAU;
use std::path::Path;

use glam::{DMat3, DVec2, DVec3, dvec2, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::camera::MirrorRays;
use omnisim::camera::{Catadioptric, Equirectangular, Pinhole};
use omnisim::pose::rotation_xyz;
use omnisim::{Camera, Frame, Pose, Scene, advanced as trace};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Pixel radius of `common::paper_omni`'s rim circle: half the shorter image side.
const RIM_RADIUS_PX: f64 = 125.0;

/// Every pixel centre of a `width`×`height` image, row by row.
fn pixel_centres(width: u32, height: u32) -> impl Iterator<Item = DVec2> {
    (0..height).flat_map(move |v| (0..width).map(move |u| dvec2(f64::from(u), f64::from(v))))
}

/// How closely a frame matches a reference frame of the same camera and pose.
struct Agreement {
    pixels: usize,
    same_face: usize,
    /// Largest |range − reference| / reference over hit pixels that name the same face.
    worst_range: f64,
}

impl Agreement {
    fn measure(reference: &Frame, frame: &Frame) -> Self {
        let mut agreement = Agreement {
            pixels: 0,
            same_face: 0,
            worst_range: 0.0,
        };
        for (r, f) in reference.pixels().iter().zip(frame.pixels()) {
            agreement.pixels += 1;
            if r.face == f.face {
                agreement.same_face += 1;
                if r.is_hit() {
                    let error = (f64::from(f.range) - f64::from(r.range)).abs() / f64::from(r.range);
                    agreement.worst_range = agreement.worst_range.max(error);
                }
            }
        }
        agreement
    }

    fn face_fraction(&self) -> f64 {
        self.same_face as f64 / self.pixels as f64
    }

    /// "max relative range error, face-id agreement %", for the tables.
    fn summary(&self) -> String {
        format!("{:.2e}, {:.4} %", self.worst_range, 100.0 * self.face_fraction())
    }
}

/// A scene made in code from RON object entries (`Polygon(...)`, `Floor(...)`).
fn scene_from_objects(name: &str, objects: &[String]) -> Scene {
    let text = format!("Scene(name: \"{name}\", objects: [\n{}\n])", objects.join(",\n"));
    Scene::from_ron(&text, Path::new("test.ron")).expect("test scene is valid")
}

/// A RON `Polygon` entry; vertices are written in Rust's shortest round-trip form, so the
/// scene holds exactly these f64 values.
fn polygon(name: &str, vertices: &[DVec3], colour: (u8, u8, u8)) -> String {
    let vertices: Vec<String> = vertices
        .iter()
        .map(|v| format!("({}, {}, {})", v.x, v.y, v.z))
        .collect();
    format!(
        "Polygon(name: \"{name}\", vertices: [{}], colour: {colour:?})",
        vertices.join(", ")
    )
}

/// Index of the (single) face of the object called `name`.
fn face_of(scene: &Scene, name: &str) -> u32 {
    scene
        .faces
        .iter()
        .position(|f| scene.objects[f.object as usize].name == name)
        .unwrap_or_else(|| panic!("no object '{name}'")) as u32
}

// ---------------------------------------------------------------------------------------
// 1. Misalignment: the paper's shortcut on a camera off the mirror's focus.

/// Camera offsets of the misalignment study, millimetres.
const OFFSETS_MM: [f64; 5] = [0.0, 0.5, 1.0, 2.0, 5.0];

/// Pixel error of the shortcut over a whole image.
struct ShortcutError {
    mean: f64,
    max: f64,
    /// Mean error vector: the part of the error a recalibrated principal point would absorb.
    shift: DVec2,
    /// Largest error left after removing `shift`.
    max_after_shift: f64,
    /// Pixels whose exact ray exists but whose scene point the aligned model cannot project
    /// (past the rim or outside the mirror's field of view).
    unprojectable: usize,
    measured: usize,
}

/// Traces every pixel of `paper_omni` with its camera displaced by `offset` (metres, mirror
/// frame) by the law of reflection, puts the scene point 2 m along each exact ray, and
/// projects it with the aligned camera's closed form, as the paper's method would.
fn shortcut_error(offset: DVec3) -> ShortcutError {
    let aligned = common::paper_omni();
    let mut camera = aligned.clone();
    camera.misalignment.offset = offset;
    let (mut errors, mut unprojectable) = (Vec::new(), 0);
    for pixel in pixel_centres(camera.width, camera.height) {
        let Some(ray) = camera.ray(pixel) else {
            continue;
        };
        // For a non-central camera the ray starts at the mirror point Q; for the aligned one
        // at the viewpoint F'. Either way the point lies on the ray the pixel really sees.
        match aligned.project(ray.origin + 2.0 * ray.direction) {
            Some(projected) => errors.push(projected - pixel),
            None => unprojectable += 1,
        }
    }
    let measured = errors.len();
    let shift = errors.iter().sum::<DVec2>() / measured as f64;
    let lengths = |removed: DVec2| errors.iter().map(move |e| (*e - removed).length());
    ShortcutError {
        mean: lengths(DVec2::ZERO).sum::<f64>() / measured as f64,
        max: lengths(DVec2::ZERO).fold(0.0, f64::max),
        shift,
        max_after_shift: lengths(shift).fold(0.0, f64::max),
        unprojectable,
        measured,
    }
}

#[test]
fn shortcut_error_grows_with_camera_offset_and_validate_refuses_it() {
    for (axis, direction) in [("x", DVec3::X), ("z", DVec3::Z)] {
        let errors: Vec<ShortcutError> = OFFSETS_MM
            .iter()
            .map(|&mm| shortcut_error(mm * 1e-3 * direction))
            .collect();
        for (mm, e) in OFFSETS_MM.iter().zip(&errors) {
            eprintln!(
                "misalignment along {axis}: {mm:>3} mm  mean {:.3e} px  max {:.3e} px  mean shift ({:.3}, {:.3}) px  max after shift {:.3e} px  ({} pixels, {} unprojectable)",
                e.mean, e.max, e.shift.x, e.shift.y, e.max_after_shift, e.measured, e.unprojectable
            );
        }
        assert!(
            errors[0].max < 1e-6,
            "aligned camera: the closed form misses the traced rays by {} px",
            errors[0].max
        );
        for (pair, mm) in errors.windows(2).zip(&OFFSETS_MM[1..]) {
            assert!(
                pair[1].mean > pair[0].mean && pair[1].max > pair[0].max,
                "offset {mm} mm along {axis}: error did not grow ({:.3e}/{:.3e} px after {:.3e}/{:.3e} px)",
                pair[1].mean,
                pair[1].max,
                pair[0].mean,
                pair[0].max
            );
        }
    }

    let mut shortcut = common::paper_omni();
    shortcut.rays = MirrorRays::Shortcut;
    assert_eq!(shortcut.check_rays(), Ok(()), "aligned shortcut is exact");
    for offset in [dvec3(1e-3, 0.0, 0.0), dvec3(0.0, 0.0, 1e-3)] {
        shortcut.misalignment.offset = offset;
        let refusal = shortcut
            .check_rays()
            .expect_err("non-central shortcut refused")
            .to_string();
        assert!(refusal.contains("shortcut"), "{refusal}");
    }
}

// ---------------------------------------------------------------------------------------
// 2. A room far from the world origin.

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn far_scene_keeps_gpu_precision_with_the_scene_local_offset() {
    let room = common::load("env1.ron");
    let camera = Camera::Equirectangular(Equirectangular {
        width: 256,
        height: 128,
    });
    let mut at_10_km = None;
    for distance in [0.0, 1.0, 100.0, 1e3, 1e4] {
        let shift = dvec3(distance, distance, 0.0);
        let mut scene = room.clone();
        for vertex in scene.faces.iter_mut().flat_map(|f| f.vertices.iter_mut()) {
            *vertex += shift;
        }
        let pose = Pose::new(dvec3(0.3, -0.2, 0.5) + shift, DVec3::ZERO);
        let local = SceneBvh::build(&scene).unwrap();
        let naive = SceneBvh::build_with_offset(&scene, DVec3::ZERO).unwrap();
        let reference = trace::trace(&local, &camera, &pose);
        // The reference itself must not care where its local origin is (up to the f32
        // rounding of the range a frame stores).
        let cpu_naive = Agreement::measure(&reference, &trace::trace(&naive, &camera, &pose));
        let render = |bvh: &SceneBvh| {
            let gpu = common::gpu_tracer(&scene, bvh);
            gpu.render(&camera, &pose).expect("GPU render")
        };
        let default = Agreement::measure(&reference, &render(&local));
        let world = Agreement::measure(&reference, &render(&naive));
        eprintln!(
            "far scene at {distance:>7} m: GPU scene-local {}; GPU world coordinates {}; CPU world coordinates {}",
            default.summary(),
            world.summary(),
            cpu_naive.summary()
        );
        assert!(
            cpu_naive.worst_range <= 1e-7 && cpu_naive.face_fraction() >= 0.9999,
            "{distance} m: the f64 reference depends on the BVH offset: {}",
            cpu_naive.summary()
        );
        assert!(
            default.worst_range <= 1e-5,
            "{distance} m: scene-local GPU range error {}",
            default.worst_range
        );
        assert!(
            default.face_fraction() >= 0.999,
            "{distance} m: scene-local GPU face ids agree on {}",
            default.face_fraction()
        );
        at_10_km = Some((default, world));
    }
    let (default, world) = at_10_km.expect("10 km measured");
    assert!(
        world.worst_range > 10.0 * default.worst_range,
        "at 10 km world coordinates ({}) should be much worse than scene-local ({})",
        world.summary(),
        default.summary()
    );
}

// ---------------------------------------------------------------------------------------
// 3. Grazing rays at the mirror rim.

/// Radial steps around the rim circle, pixels: strictly inside, then strictly outside.
const RIM_STEPS_PX: [f64; 8] = [-0.01, -1e-3, -1e-4, -1e-5, 1e-5, 1e-4, 1e-3, 0.01];

/// Pixel radius, between `inside` (sees) and `outside` (does not), where `camera` stops
/// seeing along the image direction `(cos θ, sin θ)`, by bisection to 1e-12 px.
fn rim_cut_off(camera: &Catadioptric, theta: f64, mut inside: f64, mut outside: f64) -> f64 {
    let centre = dvec2(camera.cx, camera.cy);
    let along = dvec2(theta.cos(), theta.sin());
    while outside - inside > 1e-12 {
        let middle = 0.5 * (inside + outside);
        if camera.ray(centre + middle * along).is_some() {
            inside = middle;
        } else {
            outside = middle;
        }
    }
    0.5 * (inside + outside)
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn rim_cut_off_is_sharp_on_cpu_and_matches_gpu_away_from_the_rim_circle() {
    let mirror = common::paper_omni();
    let centre = dvec2(mirror.cx, mirror.cy);
    let angles = 3600;
    let mut worst_cut_off = 0f64;
    for k in 0..angles {
        let theta = TAU * f64::from(k) / f64::from(angles);
        let along = dvec2(theta.cos(), theta.sin());
        for step in RIM_STEPS_PX {
            let pixel = centre + (RIM_RADIUS_PX + step) * along;
            match mirror.ray(pixel) {
                Some(ray) => {
                    assert!(step < 0.0, "pixel {pixel} ({step} px outside the rim) sees");
                    assert!(
                        ray.origin.is_finite()
                            && ray.direction.is_finite()
                            && ray.t_min.is_finite()
                            && (ray.direction.length() - 1.0).abs() < 1e-12,
                        "pixel {pixel}: bad ray {ray:?}"
                    );
                }
                None => assert!(step > 0.0, "pixel {pixel} ({step} px inside the rim) sees nothing"),
            }
        }
        let cut_off = rim_cut_off(
            &mirror,
            theta,
            RIM_RADIUS_PX + RIM_STEPS_PX[3],
            RIM_RADIUS_PX + RIM_STEPS_PX[4],
        );
        worst_cut_off = worst_cut_off.max((cut_off - RIM_RADIUS_PX).abs());
    }
    eprintln!("rim: CPU cut-off within {worst_cut_off:.2e} px of the {RIM_RADIUS_PX} px circle at {angles} angles");
    assert!(worst_cut_off < 1e-6, "rim cut-off {worst_cut_off} px off");

    // Whole image in a closed room: every pixel whose ray exists hits, so hit/miss is the
    // ray generator's verdict; CPU and GPU may differ only next to the rim circle.
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let camera = Camera::Catadioptric(mirror.clone());
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let reference = trace::trace(&bvh, &camera, &pose);
    let frame = gpu.render(&camera, &pose).expect("GPU render");
    let (mut near_rim, mut near_rim_differ, mut far_differ) = (0, 0, Vec::new());
    for ((pixel, r), g) in pixel_centres(mirror.width, mirror.height)
        .zip(reference.pixels())
        .zip(frame.pixels())
    {
        let near = (pixel.distance(centre) - RIM_RADIUS_PX).abs() <= 0.5;
        near_rim += usize::from(near);
        if r.is_hit() != g.is_hit() {
            if near {
                near_rim_differ += 1;
            } else {
                far_differ.push(pixel);
            }
        }
    }
    eprintln!(
        "rim: CPU and GPU hit/miss differ at {near_rim_differ} of the {near_rim} pixels within 0.5 px of the rim circle, {} elsewhere",
        far_differ.len()
    );
    assert!(
        far_differ.is_empty(),
        "hit/miss differs away from the rim at {far_differ:?}"
    );
}

// ---------------------------------------------------------------------------------------
// 4. Shared edges, corners and rays in the plane of a face.

/// A closed room: the six square faces of a unit cube centred at `centre`, turned by
/// `world_from_cube`. Neighbouring faces share their corner vertices exactly.
fn cube_room(centre: DVec3, world_from_cube: DMat3) -> Scene {
    let faces: Vec<String> = common::box_faces(centre, DVec3::splat(0.5), world_from_cube)
        .iter()
        .enumerate()
        .map(|(index, vertices)| polygon(&format!("face {index}"), vertices, (200, 200, 200)))
        .collect();
    scene_from_objects("cube room", &faces)
}

/// The two cube rooms of the edge studies, both centred at (0.5, 0.5, 0.5): axis-aligned
/// (faces on exact coordinate planes) and turned (no face plane is exactly representable).
fn cube_rooms() -> [(&'static str, DMat3); 2] {
    [
        ("axis-aligned", DMat3::IDENTITY),
        ("turned", rotation_xyz(dvec3(0.3, -0.5, 1.1))),
    ]
}

const CUBE_CENTRE: DVec3 = DVec3::splat(0.5);

#[test]
fn rays_at_shared_edges_and_corners_never_escape_a_cube_room() {
    for (label, world_from_cube) in cube_rooms() {
        let bvh = SceneBvh::build(&cube_room(CUBE_CENTRE, world_from_cube)).unwrap();
        let centre_local = CUBE_CENTRE - bvh.offset();
        let mut rng = StdRng::seed_from_u64(7);
        // Targets on every triangle edge (face borders and the diagonals inside each face):
        // both ends (cube corners) and random points along it.
        let mut targets = Vec::new();
        for t in bvh.triangles() {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                targets.extend([a, b]);
                targets.extend((0..8).map(|_| a.lerp(b, rng.random_range(0.0..1.0))));
            }
        }
        let (mut rays, mut worst) = (0, 0f64);
        for _ in 0..50 {
            let inside = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-0.45..0.45)));
            let origin = centre_local + world_from_cube * inside;
            for &target in &targets {
                let distance = origin.distance(target);
                let direction = (target - origin) / distance;
                let hit = trace::closest_hit(&bvh, origin, direction, 0.0)
                    .unwrap_or_else(|| panic!("{label} cube: ray from {origin} to edge point {target} escapes"));
                worst = worst.max((hit.t - distance).abs() / distance);
                rays += 1;
            }
        }
        eprintln!(
            "{label} cube: {rays} rays at edges and corners, none escapes, hit distance within {worst:.2e} relative of the edge point"
        );
        assert!(worst < 1e-9, "{label} cube: hit {worst} relative off the edge point");
    }
}

/// How far inside the room (metres, along the face normal) the rays parallel to a face start:
/// 0 is exactly in the face's plane.
const INSETS: [f64; 3] = [0.0, 1e-12, 1e-6];

/// A random ray parallel to the face of the unit cube (faces at ±0.5, cube frame) whose normal
/// is `axis` and which lies on `side`, starting `inset` inside the room over the face. Returns
/// (origin, unit direction, distance to the edge where the ray leaves the face's square and
/// meets the neighbouring face).
fn ray_along_face(rng: &mut StdRng, axis: usize, side: f64, inset: f64) -> (DVec3, DVec3, f64) {
    let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut origin = DVec3::ZERO;
    origin[axis] = side * (0.5 - inset);
    origin[j] = rng.random_range(-0.45..0.45);
    origin[k] = rng.random_range(-0.45..0.45);
    let theta = rng.random_range(0.0..TAU);
    let mut direction = DVec3::ZERO;
    (direction[j], direction[k]) = (theta.cos(), theta.sin());
    let direction = direction.normalize();
    let edge = [j, k]
        .into_iter()
        .filter(|&a| direction[a] != 0.0)
        .map(|a| (0.5 * direction[a].signum() - origin[a]) / direction[a])
        .fold(f64::INFINITY, f64::min);
    (origin, direction, edge)
}

#[test]
fn rays_in_and_parallel_to_the_plane_of_a_face_stop_at_the_edge_they_reach() {
    for (label, world_from_cube) in cube_rooms() {
        // Only axis-aligned planes hold a ray exactly: direction component along the normal
        // exactly 0, origin coordinate exactly the plane's. Turned, both are rounded.
        let exactly_in_plane = world_from_cube == DMat3::IDENTITY;
        let bvh = SceneBvh::build(&cube_room(CUBE_CENTRE, world_from_cube)).unwrap();
        let centre_local = CUBE_CENTRE - bvh.offset();
        let mut rng = StdRng::seed_from_u64(8);
        for inset in INSETS {
            let (mut rays, mut early, mut worst) = (0, 0, 0f64);
            for (axis, side) in (0..3).flat_map(|axis| [(axis, -1.0), (axis, 1.0)]) {
                for _ in 0..500 {
                    let (origin, direction, edge) = ray_along_face(&mut rng, axis, side, inset);
                    let hit = trace::closest_hit(
                        &bvh,
                        centre_local + world_from_cube * origin,
                        world_from_cube * direction,
                        0.0,
                    )
                    .unwrap_or_else(|| panic!("{label} cube: ray from {origin} along {direction} escapes"));
                    assert!(
                        hit.t <= edge + 1e-9,
                        "{label} cube: ray from {origin} along {direction} hits at {} m, past the edge {edge} m away",
                        hit.t
                    );
                    if hit.t < edge - 1e-9 {
                        early += 1;
                    } else {
                        worst = worst.max((hit.t - edge).abs());
                    }
                    rays += 1;
                }
            }
            eprintln!(
                "{label} cube, rays parallel to a face {inset:e} m inside: {rays} rays, none escapes or passes its edge; {early} meet their own face early; the rest hit the edge within {worst:.2e} m"
            );
            if exactly_in_plane || inset > 0.0 {
                assert_eq!(
                    early, 0,
                    "{label} cube, inset {inset} m: rays met their own face's plane before the edge"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// 5. A 1 mm marker and a 10 km floor.

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn millimetre_marker_and_ten_kilometre_floor_on_cpu_and_gpu() {
    // A pinhole 1 m above the floor looking along +x; the 1 mm marker 2 m ahead spans
    // 4.4 px (f = 8800 px), its projection centred off the pixel grid so no pixel centre lies
    // within 0.1 px of its border.
    let (width, height, focal, marker_px) = (320, 240, 8800.0, 4.4);
    let pinhole = Pinhole::with_horizontal_fov(width, height, 2.0 * (160.0f64 / focal).atan());
    let pose = Pose::new(dvec3(0.0, 0.0, 1.0), DVec3::ZERO);
    let marker_centre_px = dvec2(160.3, 110.1);
    let side = marker_px / focal * 2.0; // metres: pixels / focal length × distance
    // The body frame is the world frame turned by nothing: 2 m ahead is 2 m along world x.
    let towards_marker = pinhole.ray(marker_centre_px).direction;
    let centre = pose.position + towards_marker * (2.0 / towards_marker.x);
    let marker: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .map(|(y, z)| centre + 0.5 * side * dvec3(0.0, y, z))
        .collect();
    let floor = "Floor(name: \"floor\", corners: [(-5000.0, -5000.0), (5000.0, -5000.0), (5000.0, 5000.0), (-5000.0, 5000.0)], z: 0.0, colour: (150, 140, 120))";
    let scene = scene_from_objects(
        "marker and floor",
        &[floor.to_string(), polygon("marker", &marker, (250, 30, 30))],
    );
    let (marker_face, floor_face) = (face_of(&scene, "marker"), face_of(&scene, "floor"));
    let camera = Camera::Pinhole(pinhole);
    let body_from_world = pose.world_from_body_rotation().transpose();
    let projected: Vec<DVec2> = marker
        .iter()
        .map(|&p| camera.project(body_from_world * (p - pose.position)).unwrap())
        .collect();
    let lo = projected.iter().copied().reduce(DVec2::min).unwrap();
    let hi = projected.iter().copied().reduce(DVec2::max).unwrap();
    let projected_centre = projected.iter().sum::<DVec2>() / 4.0;

    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let frames = [
        ("CPU", trace::trace(&bvh, &camera, &pose)),
        ("GPU", gpu.render(&camera, &pose).expect("GPU render")),
    ];
    let mut marker_pixels = 0;
    for pixel in pixel_centres(width, height) {
        let inside = pixel.cmpgt(lo).all() && pixel.cmplt(hi).all();
        marker_pixels += usize::from(inside);
        for (backend, frame) in &frames {
            let sees = frame.pixel(pixel.x as u32, pixel.y as u32).face == marker_face;
            assert_eq!(
                sees, inside,
                "{backend}: pixel {pixel} sees the marker: {sees}; projection {lo}..{hi} says {inside}"
            );
        }
    }
    let middle = projected_centre.round();
    for (backend, frame) in &frames {
        assert_eq!(
            frame.pixel(middle.x as u32, middle.y as u32).face,
            marker_face,
            "{backend}: the projected centre {projected_centre} does not see the marker"
        );
    }

    // The floor: CPU against the closed form range h / −d_z, GPU against the CPU.
    let [(_, reference), (_, frame)] = &frames;
    let world_from_body = pose.world_from_body_rotation();
    let (mut floor_pixels, mut floor_differ) = (0, 0);
    let (mut closed_form, mut gpu_error, mut nearest, mut farthest) = (0f64, 0f64, f64::INFINITY, 0f64);
    for ((pixel, r), g) in pixel_centres(width, height).zip(reference.pixels()).zip(frame.pixels()) {
        if r.face != floor_face {
            continue;
        }
        floor_pixels += 1;
        let direction = world_from_body * camera.ray(pixel).unwrap().direction;
        let exact = pose.position.z / -direction.z;
        closed_form = closed_form.max((f64::from(r.range) - exact).abs() / exact);
        (nearest, farthest) = (nearest.min(exact), farthest.max(exact));
        if g.face == floor_face {
            gpu_error = gpu_error.max((f64::from(g.range) - f64::from(r.range)).abs() / f64::from(r.range));
        } else {
            floor_differ += 1;
        }
    }
    eprintln!(
        "marker: {marker_pixels} pixels inside its projection {lo:.2}..{hi:.2}, seen there and only there on CPU and GPU"
    );
    eprintln!(
        "10 km floor: {floor_pixels} pixels, ranges {nearest:.1}..{farthest:.1} m; CPU vs closed form {closed_form:.2e}, GPU vs CPU {gpu_error:.2e} relative; {floor_differ} pixels not floor on the GPU"
    );
    assert!(marker_pixels >= 4, "the marker covers {marker_pixels} pixels");
    assert!(closed_form < 1e-7, "CPU floor range {closed_form} off the closed form");
    assert!(gpu_error <= 1e-5, "GPU floor range {gpu_error} off the CPU");
}
