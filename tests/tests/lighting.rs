//! Lights, shading and hard shadows: the closed form of a point light over a floor, shadows
//! that hide exactly the light they should (and no light leaks through a closed box), the GPU
//! twin against the f64 shading on the lit rooms, flat colours without lighting, switching a
//! lamp, edge supersampling of lit images, and the shipped lit rooms themselves.

mod common;

use std::path::Path;

use common::Tracer;
use glam::{DMat3, DVec3, Vec3, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::advanced::{Appearance, CpuTracer, Pixel};
use omnisim::camera::{Equirectangular, Pinhole};
use omnisim::scene::lighting::linear_rgb;
use omnisim::{Camera, Frame, Plane, Planes, Pose, Scene, advanced as shade, advanced as trace};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// 8-bit and linear colour.
const SHADED: Planes = Planes::COLOUR.with(Plane::LinearColour);

fn scene(text: &str) -> Scene {
    Scene::from_ron(text, Path::new("lighting-test.ron")).expect("test scene")
}

/// A pose at `from` whose body x axis (the pinhole's optical axis) points at `to`.
fn look_at(from: DVec3, to: DVec3) -> Pose {
    // Rx(0)·Ry(θy)·Rz(θz) turns body x into (cos θz cos θy, sin θz, −cos θz sin θy).
    let d = (to - from).normalize();
    Pose::new(from, dvec3(0.0, (-d.z).atan2(d.x), d.y.asin()))
}

fn pinhole(width: u32, height: u32, hfov_degrees: f64) -> Camera {
    Camera::Pinhole(Pinhole::with_horizontal_fov(width, height, hfov_degrees.to_radians()))
}

fn omni() -> Camera {
    Camera::Catadioptric(common::paper_omni())
}

/// The f64 CPU tracer and the GPU, each with `scene` prepared.
fn tracers(scene: &Scene) -> Vec<(&'static str, Tracer)> {
    let bvh = SceneBvh::build(scene).unwrap();
    let mut tracers = vec![("cpu", common::cpu_tracer(scene, &bvh))];
    tracers.push(("gpu", common::gpu_tracer(scene, &bvh)));
    tracers
}

fn render(tracer: &Tracer, camera: &Camera, pose: &Pose, planes: Planes) -> Frame {
    tracer.render_planes(camera, pose, planes).expect("render")
}

/// `scene`'s appearance with exactly the lights named in `on` switched on.
fn with_lights_on(scene: &Scene, on: &[&str]) -> Appearance {
    let mut appearance = Appearance::of(scene);
    for light in &mut appearance.lighting.as_mut().expect("a lit scene").lights {
        light.on = on.contains(&light.name.as_str());
    }
    appearance
}

/// Relative tolerance on linear colour: the f64 reference, and the GPU's f32 twin.
fn tolerance(backend: &str) -> f64 {
    if backend == "cpu" { 1e-9 } else { 1e-4 }
}

/// A hit's linear colour at the backend's own precision: the f64 shading for the CPU (its
/// frame plane is rounded to f32), the frame plane for the GPU.
fn shaded_value(backend: &str, tracer: &Tracer, hit: &Pixel, plane: [f32; 3]) -> DVec3 {
    if backend == "cpu" {
        shade::shade(
            tracer.renderer.cpu_tracer(),
            tracer.scene.geometry(),
            tracer.scene.appearance(),
            hit,
            &shade::Footprint::POINT,
        )
    } else {
        Vec3::from_array(plane).as_dvec3()
    }
}

/// Largest relative difference over the channels of a linear colour.
fn relative_error(value: [f32; 3], expected: DVec3) -> f64 {
    (0..3)
        .map(|k| ((f64::from(value[k]) - expected[k]) / expected[k]).abs())
        .fold(0.0, f64::max)
}

/// Whether the segment a–b passes through the axis-aligned box [min, max] (slab test).
fn segment_meets_box(a: DVec3, b: DVec3, min: DVec3, max: DVec3) -> bool {
    let (mut enter, mut leave) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let d = b[k] - a[k];
        if d == 0.0 {
            if a[k] < min[k] || a[k] > max[k] {
                return false;
            }
            continue;
        }
        let (t1, t2) = ((min[k] - a[k]) / d, (max[k] - a[k]) / d);
        enter = enter.max(t1.min(t2));
        leave = leave.min(t1.max(t2));
    }
    enter <= leave
}

const LAMP_HEIGHT: f64 = 2.5;
const INTENSITY: f64 = 300.0;
const WHITE: f64 = 50.0;
const FLOOR_COLOUR: [u8; 3] = [200, 170, 120];

/// Closed form for a lamp `LAMP_HEIGHT` above the origin of a horizontal floor:
/// E(r) = I·h/(h² + r²)^{3/2}, linear = albedo·(ambient + E)/white.
fn lamp_over_floor(point: DVec3, ambient: f64) -> DVec3 {
    let h = LAMP_HEIGHT - point.z;
    let r_squared = point.x * point.x + point.y * point.y;
    linear_rgb(FLOOR_COLOUR) * (ambient + INTENSITY * h / (h * h + r_squared).powf(1.5)) / WHITE
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_point_light_over_a_large_floor_follows_the_closed_form() {
    let [r, g, b] = FLOOR_COLOUR;
    let scene = scene(&format!(
        r#"Scene(name: "lamp over floor", objects: [
            Floor(name: "floor", corners: [(-100.0, -100.0), (100.0, -100.0), (100.0, 100.0), (-100.0, 100.0)], z: 0.0, colour: ({r}, {g}, {b})),
        ], lighting: (ambient: 0.0, white: {WHITE:.1}, lights: [
            Point(name: "lamp", position: (0.0, 0.0, {LAMP_HEIGHT:.1}), intensity: {INTENSITY:.1}),
        ]))"#
    ));
    let viewpoint = dvec3(0.7, -0.4, 1.2);
    let views = [
        (
            "pinhole looking down",
            pinhole(128, 96, 100.0),
            Pose::from_degrees(viewpoint, dvec3(0.0, 90.0, 0.0)),
        ),
        ("omni", omni(), Pose::new(viewpoint, DVec3::ZERO)),
    ];
    for (backend, tracer) in tracers(&scene) {
        for (name, camera, pose) in &views {
            let frame = render(&tracer, camera, pose, SHADED);
            let linear = frame.linear_colour().unwrap();
            let (mut worst, mut worst_plane, mut hits) = (0f64, 0f64, 0usize);
            let (mut darkest, mut brightest) = (f64::INFINITY, 0f64);
            for (hit, plane) in frame.pixels().iter().zip(linear).filter(|(hit, _)| hit.is_hit()) {
                let expected = lamp_over_floor(hit.point, 0.0);
                hits += 1;
                darkest = darkest.min(expected.x);
                brightest = brightest.max(expected.x);
                worst_plane = worst_plane.max(relative_error(*plane, expected));
                let value = shaded_value(backend, &tracer, hit, *plane);
                worst = worst.max(((value - expected) / expected).abs().max_element());
            }
            eprintln!(
                "{backend} {name}: {hits} floor pixels, linear red from {darkest:.2e} to {brightest:.2e}; worst \
                 relative error {worst:.1e} ({}), linear plane {worst_plane:.1e}",
                if backend == "cpu" { "f64 shading" } else { "f32" }
            );
            assert!(hits > 10_000, "{backend} {name}: only {hits} pixels see the floor");
            assert!(worst <= tolerance(backend), "{backend} {name}: error {worst}");
            // The CPU's linear plane is its f64 value rounded to f32.
            assert!(
                worst_plane <= tolerance(backend).max(1e-7),
                "{backend} {name}: plane error {worst_plane}"
            );
        }
    }
}

/// A 1 m cube (or none) on a 20 m floor, lit from the side by a lamp 3 m away, 1.5 m up.
fn cube_on_floor(cube: bool) -> Scene {
    let [r, g, b] = FLOOR_COLOUR;
    let cube = if cube {
        r#"Box(name: "cube", size: (1.0, 1.0, 1.0), position: (0.0, 0.0, 0.0), colour: (90, 120, 200)),"#
    } else {
        ""
    };
    scene(&format!(
        r#"Scene(name: "cube on floor", objects: [
            Floor(name: "floor", corners: [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)], z: 0.0, colour: ({r}, {g}, {b})),
            {cube}
        ], lighting: (ambient: 5.0, white: {WHITE:.1}, lights: [
            Point(name: "lamp", position: (3.0, 0.0, 1.5), intensity: {INTENSITY:.1}),
        ]))"#
    ))
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_point_hidden_by_a_box_receives_exactly_the_ambient_term() {
    let lamp = dvec3(3.0, 0.0, 1.5);
    let ambient_only = linear_rgb(FLOOR_COLOUR) * 5.0 / WHITE;
    // Floor points whose segment to the lamp crosses the cube shrunk by 1 mm are hidden; those
    // whose segment misses it grown by 1 mm are lit; the rest straddle the shadow's edge.
    let margin = DVec3::splat(1e-3);
    let (cube_min, cube_max) = (dvec3(-0.5, -0.5, 0.0), dvec3(0.5, 0.5, 1.0));
    let views = [
        (
            "pinhole above",
            pinhole(128, 128, 90.0),
            look_at(dvec3(-1.0, 0.3, 6.0), dvec3(-1.0, 0.3, 0.0)),
        ),
        ("omni", omni(), Pose::new(dvec3(-2.5, 1.2, 0.4), DVec3::ZERO)),
    ];
    let lit = cube_on_floor(true);
    let bare = cube_on_floor(false);
    for ((backend, tracer), (_, bare_tracer)) in tracers(&lit).into_iter().zip(tracers(&bare)) {
        for (name, camera, pose) in &views {
            let frame = render(&tracer, camera, pose, SHADED);
            let without_cube = render(&bare_tracer, camera, pose, SHADED);
            let linear = frame.linear_colour().unwrap();
            let bare_linear = without_cube.linear_colour().unwrap();
            let (mut hidden, mut lit_points, mut straddling) = (0usize, 0usize, 0usize);
            let (mut worst_hidden, mut worst_lit) = (0f64, 0f64);
            for (i, hit) in frame.pixels().iter().enumerate().filter(|(_, hit)| hit.face == 0) {
                let value = linear[i];
                let precise = shaded_value(backend, &tracer, hit, value);
                let error = |expected: DVec3| ((precise - expected) / expected).abs().max_element();
                if segment_meets_box(hit.point, lamp, cube_min + margin, cube_max - margin) {
                    hidden += 1;
                    if backend == "cpu" {
                        assert_eq!(precise, ambient_only, "{name}: hidden point {} is lit", hit.point);
                        assert_eq!(value, ambient_only.as_vec3().to_array());
                    }
                    worst_hidden = worst_hidden.max(error(ambient_only));
                    // The same ray without the cube meets the same floor point, lit.
                    let unshadowed = bare_linear[i];
                    assert_eq!(without_cube.pixels()[i].face, 0);
                    assert!(
                        (0..3).all(|k| value[k] < unshadowed[k]),
                        "{backend} {name}: shadowed {value:?} not darker than unshadowed {unshadowed:?}"
                    );
                } else if !segment_meets_box(hit.point, lamp, cube_min - margin, cube_max + margin) {
                    lit_points += 1;
                    let offset = lamp - hit.point;
                    let distance = offset.length();
                    let lux = 5.0 + INTENSITY * (offset.z / distance) / (distance * distance);
                    worst_lit = worst_lit.max(error(linear_rgb(FLOOR_COLOUR) * lux / WHITE));
                } else {
                    straddling += 1;
                }
            }
            eprintln!(
                "{backend} {name}: {hidden} hidden floor pixels (worst relative error against the ambient term \
                 {worst_hidden:.1e}), {lit_points} lit ({worst_lit:.1e}), {straddling} on the shadow's edge"
            );
            assert!(
                hidden > 300 && lit_points > 3000,
                "{backend} {name}: too few pixels to judge"
            );
            assert!(worst_hidden <= tolerance(backend) && worst_lit <= tolerance(backend));
        }
    }
}

/// A 20 m floor cut in two by a 10 m high wall along x = 0, a lamp on each side of it.
fn wall_with_lamps() -> Scene {
    scene(
        r#"Scene(name: "wall", objects: [
            Floor(name: "floor", corners: [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)], z: 0.0, colour: (180, 180, 170)),
            Wall(name: "wall", from: (0.0, -10.0), to: (0.0, 10.0), bottom: 0.0, height: 10.0, colour: (200, 120, 90)),
        ], lighting: (ambient: 4.0, white: 40.0, lights: [
            Point(name: "behind", position: (1.0, 0.0, 1.0), intensity: 500.0),
            Point(name: "in front", position: (-1.0, 0.0, 1.0), intensity: 500.0, on: false),
        ]))"#,
    )
}

/// The 8-bit and linear colour planes of one frame.
type ShadedPlanes = (Vec<[u8; 3]>, Vec<[f32; 3]>);

/// Renders `views` with each appearance in turn; the shaded planes of each view and appearance.
fn shaded_planes(
    tracer: &mut Tracer,
    views: &[(&str, Camera, Pose)],
    appearances: &[Appearance],
) -> Vec<Vec<ShadedPlanes>> {
    appearances
        .iter()
        .map(|appearance| {
            tracer
                .renderer
                .set_appearance(&mut tracer.scene, appearance.clone())
                .expect("appearance fits");
            views
                .iter()
                .map(|(_, camera, pose)| {
                    let frame = render(tracer, camera, pose, SHADED);
                    (
                        frame.colour().unwrap().to_vec(),
                        frame.linear_colour().unwrap().to_vec(),
                    )
                })
                .collect()
        })
        .collect()
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_light_behind_a_wall_lights_nothing_in_front_of_it() {
    let scene = wall_with_lamps();
    let views = [
        (
            "pinhole",
            pinhole(128, 96, 100.0),
            look_at(dvec3(-4.0, 0.5, 1.5), dvec3(0.0, 0.0, 0.5)),
        ),
        ("omni", omni(), Pose::new(dvec3(-2.0, 3.0, 0.4), DVec3::ZERO)),
    ];
    for (backend, mut tracer) in tracers(&scene) {
        let appearances = [
            with_lights_on(&scene, &[]),
            with_lights_on(&scene, &["behind"]),
            with_lights_on(&scene, &["in front"]),
        ];
        let images = shaded_planes(&mut tracer, &views, &appearances);
        for (v, (name, ..)) in views.iter().enumerate() {
            let (dark, behind, front) = (&images[0][v], &images[1][v], &images[2][v]);
            // The control: the same lamp on the camera's side changes most of the image.
            let changed_by = |image: &(Vec<[u8; 3]>, Vec<[f32; 3]>)| {
                (0..dark.1.len())
                    .filter(|&i| image.0[i] != dark.0[i] || image.1[i] != dark.1[i])
                    .count()
            };
            let (leaked, changed) = (changed_by(behind), changed_by(front));
            eprintln!(
                "{backend} {name}: the lamp behind the wall changes {leaked} pixels; in front of it, {changed} of {}",
                dark.1.len()
            );
            assert!(
                changed > dark.1.len() / 3,
                "{backend} {name}: the control lamp lights only {changed}"
            );
            assert_eq!(leaked, 0, "{backend} {name}: light leaks through the wall");
        }
    }
}

/// A closed 2 × 1.5 × 1 m box turned 25° on a floor, with a lamp inside it.
struct ClosedBox {
    scene: Scene,
    centre: DVec3,
    rotation: DMat3,
    half: DVec3,
    lamp: DVec3,
}

impl ClosedBox {
    fn new() -> Self {
        let centre = dvec3(0.3, -0.2, 0.0);
        let rotation = DMat3::from_rotation_z(25f64.to_radians());
        let half = dvec3(1.0, 0.75, 0.5);
        let lamp = centre + rotation * dvec3(0.3, -0.2, 0.6);
        let scene = scene(&format!(
            r#"Scene(name: "closed box", objects: [
                Floor(name: "floor", corners: [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)], z: 0.0, colour: (180, 170, 150)),
                Box(name: "box", size: (2.0, 1.5, 1.0), position: ({}, {}, 0.0), rotation: (0.0, 0.0, 25.0), colour: (100, 160, 90)),
            ], lighting: (ambient: 6.0, white: 60.0, lights: [
                Point(name: "lamp", position: ({}, {}, {}), intensity: 200.0),
            ]))"#,
            centre.x, centre.y, lamp.x, lamp.y, lamp.z
        ));
        Self {
            scene,
            centre,
            rotation,
            half,
            lamp,
        }
    }

    /// The world point of box coordinates in [−1, 1]³ (z = −1 is the floor).
    fn point(&self, local: DVec3) -> DVec3 {
        self.centre + self.rotation * (local * self.half + dvec3(0.0, 0.0, self.half.z))
    }
}

#[test]
fn no_light_leaks_through_the_edges_and_corners_of_a_closed_box() {
    let closed = ClosedBox::new();
    let bvh = SceneBvh::build(&closed.scene).unwrap();
    let appearance = Appearance::of(&closed.scene);
    let ambient_only = linear_rgb([180, 170, 150]) * 6.0 / 60.0;
    let mut rng = StdRng::seed_from_u64(7);
    let sign = |rng: &mut StdRng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    // 6000 points outside the box whose shadow ray to the lamp passes exactly through a
    // corner, a point of an edge or a point of a face (a third each), between 1 µm and 3 m
    // from it; the floor is skipped, so only the box can stop them.
    let mut leaks = Vec::new();
    for n in 0..6000 {
        let mut local = DVec3::new(sign(&mut rng), sign(&mut rng), sign(&mut rng));
        let free = n % 3; // how many coordinates leave the corner: 0 corner, 1 edge, 2 face
        for k in 0..free {
            local[(n / 3 + k) % 3] = rng.random_range(-1.0..1.0);
        }
        let through = closed.point(local);
        let outward = (through - closed.lamp).normalize();
        let origin = through + outward * 10f64.powf(rng.random_range(-6.0..0.5));
        let to_lamp = closed.lamp - origin;
        let distance = to_lamp.length();
        if !trace::occluded(&bvh, origin - bvh.offset(), to_lamp / distance, distance, 0) {
            leaks.push(through);
        }
    }
    // 4000 floor points just outside the box's base, 0.1 µm to 10 cm from a bottom edge or
    // corner, shaded as a camera would see them.
    let mut floor_leaks = Vec::new();
    let mut floor_points = 0;
    while floor_points < 4000 {
        let mut local = DVec3::new(sign(&mut rng), sign(&mut rng), -1.0);
        if floor_points % 2 == 1 {
            let k = floor_points / 2 % 2;
            local[k] = rng.random_range(-1.0..1.0);
        }
        let angle = rng.random_range(0.0..std::f64::consts::TAU);
        let step = 10f64.powf(rng.random_range(-7.0..-1.0));
        let point = closed.point(local) + step * dvec3(angle.cos(), angle.sin(), 0.0);
        let inside = closed.rotation.transpose() * (point - closed.centre);
        if inside.x.abs() <= closed.half.x && inside.y.abs() <= closed.half.y {
            continue;
        }
        floor_points += 1;
        let hit = Pixel {
            face: 0,
            range: 1.0,
            point,
            normal: Vec3::Z,
        };
        if shade::shade(CpuTracer::Fast, &bvh, &appearance, &hit, &shade::Footprint::POINT) != ambient_only {
            floor_leaks.push(point);
        }
    }
    eprintln!(
        "10⁴ shadow rays towards a lamp inside a closed box: {} of 6000 through corners, edges and faces and \
         {} of 4000 from the floor at its base reach the lamp",
        leaks.len(),
        floor_leaks.len()
    );
    assert!(
        leaks.is_empty(),
        "light leaks through {:?}",
        &leaks[..leaks.len().min(5)]
    );
    assert!(
        floor_leaks.is_empty(),
        "light reaches the floor at {:?}",
        &floor_leaks[..floor_leaks.len().min(5)]
    );
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_closed_lit_box_seen_from_outside_shows_only_the_ambient_term() {
    let closed = ClosedBox::new();
    let corner = closed.point(dvec3(1.0, -1.0, -1.0));
    let views = [
        (
            "pinhole",
            pinhole(128, 128, 60.0),
            look_at(dvec3(3.5, 2.5, 1.8), closed.point(DVec3::ZERO)),
        ),
        // A 4° view of one bottom corner, where floor and two sides meet.
        (
            "pinhole at a corner",
            pinhole(128, 128, 4.0),
            look_at(corner + closed.rotation * dvec3(1.2, -1.0, 0.5), corner),
        ),
        ("omni", omni(), Pose::new(dvec3(2.5, -1.5, 0.4), DVec3::ZERO)),
    ];
    for (backend, mut tracer) in tracers(&closed.scene) {
        let appearances = [with_lights_on(&closed.scene, &[]), Appearance::of(&closed.scene)];
        let images = shaded_planes(&mut tracer, &views, &appearances);
        for (v, (name, ..)) in views.iter().enumerate() {
            let differing = images[0][v]
                .1
                .iter()
                .zip(&images[1][v].1)
                .filter(|(a, b)| a != b)
                .count();
            eprintln!("{backend} {name}: {differing} pixels differ from the unlit image");
            assert_eq!(differing, 0, "{backend} {name}: light leaks out of the closed box");
        }
    }
}

/// How a GPU image compares with the f64 reference: 8-bit colours within one step, and the
/// pixels that are not, by cause.
#[derive(Default)]
struct Agreement {
    pixels: usize,
    within_one: usize,
    /// Exceptions next to a change of face (in the reference, or where the GPU saw another face).
    edge: usize,
    /// Exceptions next to a change of which lights reach the surface (shadow boundaries).
    shadow: usize,
    /// Exceptions with neither: a shading error.
    unexplained: usize,
}

impl Agreement {
    /// Adds one frame; `reached` gives, per reference pixel, a bit per light that reaches it.
    fn add(&mut self, reference: &Frame, reached: &[u32], frame: &Frame) {
        let (w, h) = (i64::from(reference.width), i64::from(reference.height));
        let (want, got) = (reference.colour().unwrap(), frame.colour().unwrap());
        let face = |i: usize| reference.pixels()[i].face;
        for i in 0..want.len() {
            self.pixels += 1;
            if (0..3).all(|k| want[i][k].abs_diff(got[i][k]) <= 1) {
                self.within_one += 1;
                continue;
            }
            let (x, y) = (i as i64 % w, i as i64 / w);
            let neighbours = (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
                .filter(|&(u, v)| (0..w).contains(&u) && (0..h).contains(&v))
                .map(|(u, v)| (v * w + u) as usize);
            if frame.pixels()[i].face != face(i) || neighbours.clone().any(|j| face(j) != face(i)) {
                self.edge += 1;
            } else if neighbours.clone().any(|j| reached[j] != reached[i]) {
                self.shadow += 1;
            } else {
                self.unexplained += 1;
            }
        }
    }

    fn share(&self) -> f64 {
        self.within_one as f64 / self.pixels as f64
    }
}

/// Which lights reach each pixel of a reference frame (bit k for light k): the frame shaded
/// again with one light on at a time, against all lights off.
fn lights_reaching(cpu: &mut Tracer, scene: &Scene, frame: &Frame, camera: &Camera, pose: &Pose) -> Vec<u32> {
    let lighting = scene.lighting.as_ref().expect("a lit scene");
    let names: Vec<&str> = lighting.lights.iter().map(|l| l.name.as_str()).collect();
    let mut shaded = |on: &[&str]| {
        cpu.renderer
            .set_appearance(&mut cpu.scene, with_lights_on(scene, on))
            .unwrap();
        let mut copy = frame.clone();
        cpu.renderer
            .reshade(
                &cpu.scene,
                camera,
                pose,
                &mut copy,
                Planes::HITS.with(Plane::LinearColour),
            )
            .unwrap();
        copy.linear_colour().unwrap().to_vec()
    };
    let dark = shaded(&[]);
    let mut reached = vec![0u32; dark.len()];
    for (k, name) in names.iter().enumerate() {
        for (i, (lit, unlit)) in shaded(&[name]).iter().zip(&dark).enumerate() {
            if lit != unlit {
                reached[i] |= 1 << k;
            }
        }
    }
    cpu.renderer
        .set_appearance(&mut cpu.scene, Appearance::of(scene))
        .unwrap();
    reached
}

/// A shipped lit room with every lamp switched on.
fn lit_room(name: &str) -> Scene {
    let mut scene = common::load(name);
    for light in &mut scene.lighting.as_mut().expect("a lit room").lights {
        light.on = true;
    }
    scene
}

const LIT_ROOMS: [&str; 2] = ["env1-lit.ron", "env2-lit.ron"];

/// Compares GPU and CPU images of both lit rooms (every lamp on) for `cameras` at `poses`,
/// rendered by `render`; asserts ≥ 99.9 % within one step and every exception explained.
fn gpu_agrees_with_the_reference(
    cameras: &[Camera],
    poses: &[Pose],
    render: impl Fn(&Tracer, &Camera, &Pose) -> Frame,
    what: &str,
) {
    for room in LIT_ROOMS {
        let scene = lit_room(room);
        let bvh = SceneBvh::build(&scene).unwrap();
        let gpu = common::gpu_tracer(&scene, &bvh);
        let mut cpu = common::cpu_tracer(&scene, &bvh);
        for camera in cameras {
            let mut agreement = Agreement::default();
            for pose in poses {
                let reference = render(&cpu, camera, pose);
                let reached = lights_reaching(&mut cpu, &scene, &reference, camera, pose);
                agreement.add(&reference, &reached, &render(&gpu, camera, pose));
            }
            let name = common::describe(camera);
            eprintln!(
                "{what} {room} {name}: 8-bit colours within 1 on {:.4} % of {} pixels; exceptions: {} at face \
                 edges, {} at shadow boundaries, {} unexplained",
                agreement.share() * 100.0,
                agreement.pixels,
                agreement.edge,
                agreement.shadow,
                agreement.unexplained
            );
            assert!(agreement.share() >= 0.999, "{what} {room} {name}");
            assert_eq!(
                agreement.unexplained, 0,
                "{what} {room} {name}: shading errors away from edges"
            );
        }
    }
}

fn room_poses() -> [Pose; 2] {
    [
        Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0)),
        Pose::from_degrees(dvec3(-0.7, 0.3, 1.2), dvec3(12.0, -20.0, 200.0)),
    ]
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_shading_matches_the_f64_reference_in_the_lit_rooms() {
    gpu_agrees_with_the_reference(
        &common::cameras(),
        &room_poses(),
        |tracer, camera, pose| render(tracer, camera, pose, Planes::COLOUR),
        "plain",
    );
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_edge_samples_of_lit_images_match_the_f64_reference() {
    let cameras = [omni(), pinhole(160, 120, 70.0)];
    gpu_agrees_with_the_reference(
        &cameras,
        &room_poses()[..1],
        |tracer, camera, pose| {
            tracer
                .renderer
                .render_antialiased(&tracer.scene, camera, pose, Planes::COLOUR, 4)
                .expect("antialiased render")
        },
        "4×4 edge samples",
    );
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn without_lighting_every_pixel_shows_its_face_colour() {
    let scene = common::load("env1.ron");
    assert!(scene.lighting.is_none());
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let cameras = [
        omni(),
        Camera::Equirectangular(Equirectangular {
            width: 256,
            height: 128,
        }),
    ];
    for (backend, tracer) in tracers(&scene) {
        for camera in &cameras {
            let frame = render(&tracer, camera, &pose, Planes::COLOUR);
            let mut hits = 0;
            for (hit, colour) in frame.pixels().iter().zip(frame.colour().unwrap()) {
                let expected = if hit.is_hit() {
                    hits += 1;
                    scene.faces[hit.face as usize].colour
                } else {
                    omnisim::frame::BACKGROUND
                };
                assert_eq!(*colour, expected, "{backend} {}", camera.model_name());
            }
            eprintln!(
                "{backend} {}: all {hits} hit pixels in their face's flat colour",
                camera.model_name()
            );
            assert!(hits > 30_000);
        }
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn switching_a_lamp_on_only_brightens() {
    let scene = common::load("env2-lit.ron");
    let lighting = scene.lighting.as_ref().unwrap();
    assert!(!lighting.lights[1].on, "env2-lit's desk lamp is off as shipped");
    let pose = Pose::new(dvec3(-2.6, 0.8, 0.4), DVec3::ZERO);
    let views = [
        ("omni", omni(), pose),
        (
            "equirect",
            Camera::Equirectangular(Equirectangular {
                width: 256,
                height: 128,
            }),
            pose,
        ),
    ];
    for (backend, mut tracer) in tracers(&scene) {
        let appearances = [
            Appearance::of(&scene),
            with_lights_on(&scene, &["ceiling lamp", "desk lamp"]),
        ];
        let images = shaded_planes(&mut tracer, &views, &appearances);
        for (v, (name, ..)) in views.iter().enumerate() {
            let ((off_colour, off), (on_colour, on)) = (&images[0][v], &images[1][v]);
            let brighter = off.iter().zip(on).filter(|(a, b)| a != b).count();
            eprintln!(
                "{backend} {name}: the desk lamp brightens {brighter} of {} pixels",
                off.len()
            );
            assert!(
                brighter > off.len() / 10,
                "{backend} {name}: the lamp lights only {brighter} pixels"
            );
            for i in 0..off.len() {
                assert!(
                    (0..3).all(|k| on[i][k] >= off[i][k] && on_colour[i][k] >= off_colour[i][k]),
                    "{backend} {name}: pixel {i} darkens from {:?} to {:?}",
                    off[i],
                    on[i]
                );
            }
        }
    }
}

#[test]
fn lit_rooms_are_the_reference_rooms_with_lamps_in_free_space() {
    for (lit_name, plain_name) in [("env1-lit.ron", "env1.ron"), ("env2-lit.ron", "env2.ron")] {
        let (lit, plain) = (common::load(lit_name), common::load(plain_name));
        assert_eq!(lit.objects, plain.objects, "{lit_name}");
        assert_eq!(
            lit.faces, plain.faces,
            "{lit_name}: the lit room's faces differ from {plain_name}"
        );
        assert!(plain.lighting.is_none());
        let lighting = lit.lighting.as_ref().expect("a lit room");
        let names: Vec<&str> = lighting.lights.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["ceiling lamp", "desk lamp"], "{lit_name}");
        let bvh = SceneBvh::build(&lit).unwrap();
        let object_hit = |origin: DVec3, direction: DVec3| {
            trace::closest_hit(&bvh, origin - bvh.offset(), direction, 0.0).map(|hit| {
                let face = &lit.faces[bvh.triangle_face(hit.triangle) as usize];
                (lit.objects[face.object as usize].name.as_str(), hit.t)
            })
        };
        let mut rng = StdRng::seed_from_u64(3);
        for light in &lighting.lights {
            let omnisim::scene::lighting::LightKind::Point { position, .. } = light.kind else {
                panic!("{lit_name}: {} is not a point light", light.name);
            };
            // Not inside furniture: straight up is the ceiling; not on a face: every one of
            // 2000 random rays travels at least 10 cm before meeting one.
            assert_eq!(object_hit(position, DVec3::Z).map(|(o, _)| o), Some("ceiling"));
            let nearest = (0..2000)
                .map(|_| {
                    let direction = dvec3(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    )
                    .normalize();
                    object_hit(position, direction).expect("the room is closed").1
                })
                .fold(f64::INFINITY, f64::min);
            eprintln!("{lit_name} {}: nearest face {nearest:.2} m away", light.name);
            assert!(nearest > 0.1, "{lit_name} {}", light.name);
        }
    }
}

/// The 8-bit colour plane is the same whether or not the linear plane is asked for (the CPU
/// shades colour alone without storing linear colour), lit and unlit, on every backend.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn colour_alone_equals_colour_beside_linear_colour() {
    for name in ["env1.ron", "env1-lit.ron"] {
        let scene = if name.contains("-lit") {
            lit_room(name)
        } else {
            common::load(name)
        };
        let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
        for (backend, tracer) in tracers(&scene) {
            let alone = render(&tracer, &omni(), &pose, Planes::COLOUR);
            let beside = render(&tracer, &omni(), &pose, SHADED);
            assert!(alone.linear_colour().is_none() && beside.linear_colour().is_some());
            assert!(
                alone.colour().unwrap() == beside.colour().unwrap(),
                "{name} on {backend}: colour differs"
            );
            let lit_pixels = beside.colour().unwrap().iter().filter(|c| **c != [0, 0, 0]).count();
            assert!(lit_pixels > 10_000, "{name} on {backend}: {lit_pixels} coloured pixels");
        }
    }
}

/// A lit frame's shadow rays are traced tile by tile as packets (`shade_frame`); each pixel's
/// linear colour must still be, bit for bit, what shading its hit alone gives (`shade`, whose
/// shadow rays go one by one), and its 8-bit colour that colour encoded: on the fast tracer
/// and the reference alike, with unlit pixels and lights behind faces among them.
#[test]
fn a_lit_frame_is_each_pixel_shaded_alone_bit_for_bit() {
    for room in LIT_ROOMS {
        let scene = lit_room(room);
        let bvh = SceneBvh::build(&scene).unwrap();
        let mut tracer = common::cpu_tracer(&scene, &bvh);
        for cpu in [CpuTracer::Fast, CpuTracer::Reference] {
            tracer.renderer.set_cpu_tracer(cpu);
            for camera in common::cameras() {
                for pose in room_poses() {
                    let frame = render(&tracer, &camera, &pose, SHADED);
                    let (linear, colour) = (frame.linear_colour().unwrap(), frame.colour().unwrap());
                    let mut lit = 0;
                    for (index, hit) in frame.pixels().iter().enumerate() {
                        let alone = shade::shade(
                            cpu,
                            tracer.scene.geometry(),
                            tracer.scene.appearance(),
                            hit,
                            &shade::Footprint::POINT,
                        );
                        let name = common::describe(&camera);
                        assert_eq!(
                            linear[index],
                            alone.as_vec3().to_array(),
                            "{room} {name} {cpu:?} pixel {index}"
                        );
                        if hit.is_hit() {
                            assert_eq!(
                                colour[index],
                                shade::encode(alone),
                                "{room} {name} {cpu:?} pixel {index}"
                            );
                            lit += usize::from(alone != DVec3::ZERO);
                        }
                    }
                    assert!(lit > frame.pixels().len() / 10, "{room}: {lit} lit pixels");
                }
            }
        }
    }
}
