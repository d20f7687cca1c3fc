//! Edge supersampling decides from coverage which pixels to refine: a strip thinner than a
//! pixel that touches no pixel centre shows at its coverage, and marker centroids keep
//! converging as the sample count grows (issue 20).

mod common;

use std::path::Path;

use glam::{DVec2, DVec3, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::camera::Pinhole;
use omnisim::{Camera, Plane, Planes, Pose, Scene};

/// A black wall at x = 2 and, 5 mm in front of it, a white vertical strip covering
/// `from`..`to` pixels right of the image centre line of a 64×48 pinhole (hfov 60°), which
/// puts pixel centres at ±0.5, ±1.5, … pixels from that line.
fn strip_scene(from: f64, to: f64) -> (Scene, Camera) {
    let camera = Pinhole::with_horizontal_fov(64, 48, 60f64.to_radians());
    let x = 1.995;
    // Image column offset c (pixels right of the centre line) sees y = −c·x / fx.
    let y = |c: f64| -c * x / camera.fx;
    let text = format!(
        r#"Scene(name: "strip", objects: [
            Polygon(name: "wall", vertices: [(2.0, 3.0, -2.0), (2.0, -3.0, -2.0), (2.0, -3.0, 2.0), (2.0, 3.0, 2.0)], colour: (0, 0, 0)),
            Polygon(name: "strip", vertices: [({x}, {a}, -2.0), ({x}, {b}, -2.0), ({x}, {b}, 2.0), ({x}, {a}, 2.0)], colour: (255, 255, 255)),
        ])"#,
        a = y(from),
        b = y(to),
    );
    (
        Scene::from_ron(&text, Path::new("strip.ron")).unwrap(),
        Camera::Pinhole(camera),
    )
}

fn check_strip(tracer: &common::Tracer, camera: &Camera) {
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    let planes = Planes::COLOUR.with(Plane::LinearColour);
    let plain = tracer.render_planes(camera, &pose, planes).unwrap();
    // No pixel centre sees the strip: without refinement the column stays black.
    assert!(
        plain.pixels().iter().all(|p| p.face == 0),
        "a pixel centre sees the strip"
    );
    let refined = tracer
        .renderer
        .render_antialiased(&tracer.scene, camera, &pose, planes, 8)
        .unwrap();
    let linear = refined.linear_colour().unwrap();
    for v in 0..48 {
        // Column 32 spans 0..1 px right of the centre line; the strip covers 0.6..0.9 of it,
        // which 2 of the 8 sample columns (at 0.6875 and 0.8125) see.
        let covered = linear[refined.index(32, v)][0];
        assert!((covered - 0.25).abs() < 1e-3, "row {v}: column 32 at {covered}");
        for u in (0..64).filter(|&u| u != 32) {
            assert_eq!(linear[refined.index(u, v)][0], 0.0, "pixel ({u}, {v})");
        }
    }
}

#[test]
fn a_strip_thinner_than_a_pixel_between_pixel_centres_shows_at_its_coverage() {
    let (scene, camera) = strip_scene(0.6 - 0.5, 0.9 - 0.5);
    check_strip(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), &camera);
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_strip_thinner_than_a_pixel_shows_at_its_coverage_on_the_gpu() {
    let (scene, camera) = strip_scene(0.6 - 0.5, 0.9 - 0.5);
    check_strip(&common::gpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), &camera);
}

/// The centroid error (pixels) of a black square 3.3 px across on a white wall, turned by
/// `turn` in the image and centred at `centre` (sub-pixel), with `samples_per_axis`² samples
/// on edge pixels: the centroid of darkness (1 − linear colour) against the square's centre,
/// where the pinhole projects it exactly (a fronto-parallel square stays a square).
fn centroid_error(
    tracer_for: &dyn Fn(&Scene) -> common::Tracer,
    centre: DVec2,
    turn: f64,
    samples_per_axis: u32,
) -> f64 {
    let camera = Pinhole::with_horizontal_fov(32, 32, 60f64.to_radians());
    let (fx, cx, cy) = (camera.fx, camera.cx, camera.cy);
    let x = 2.0;
    let half = 1.65 * x / fx;
    let world = |u: f64, v: f64| dvec3(x, -(u - cx) * x / fx, -(v - cy) * x / fx);
    let (sin, cos) = turn.sin_cos();
    let centre_world = world(centre.x, centre.y);
    let corners: Vec<String> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(a, b)| {
            let (dy, dz) = (half * (a * cos - b * sin), half * (a * sin + b * cos));
            let p = centre_world + dvec3(-0.005, dy, dz);
            format!("({}, {}, {})", p.x, p.y, p.z)
        })
        .collect();
    let text = format!(
        r#"Scene(name: "marker", objects: [
            Polygon(name: "wall", vertices: [(2.0, 3.0, -3.0), (2.0, 3.0, 3.0), (2.0, -3.0, 3.0), (2.0, -3.0, -3.0)], colour: (255, 255, 255)),
            Polygon(name: "marker", vertices: [{}], colour: (0, 0, 0)),
        ])"#,
        corners.join(", ")
    );
    let scene = Scene::from_ron(&text, Path::new("marker.ron")).unwrap();
    let tracer = tracer_for(&scene);
    let planes = Planes::COLOUR.with(Plane::LinearColour);
    let camera = Camera::Pinhole(camera);
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    let frame = tracer
        .renderer
        .render_antialiased(&tracer.scene, &camera, &pose, planes, samples_per_axis)
        .unwrap();
    let linear = frame.linear_colour().unwrap();
    let (mut sum, mut weight) = (DVec2::ZERO, 0.0);
    for v in 0..32 {
        for u in 0..32 {
            let dark = 1.0 - f64::from(linear[frame.index(u, v)][0]);
            sum += dark * DVec2::new(f64::from(u), f64::from(v));
            weight += dark;
        }
    }
    (sum / weight).distance(centre)
}

#[test]
fn marker_centroid_errors_keep_falling_as_edge_samples_grow() {
    let cpu = |scene: &Scene| common::cpu_tracer(scene, &SceneBvh::build(scene).unwrap());
    // Twelve placements: sub-pixel centres and turns (seeded by hand, spread over a pixel).
    let placements: Vec<(DVec2, f64)> = (0..12)
        .map(|k| {
            let k = f64::from(k);
            (
                DVec2::new(15.0 + (k * 0.37) % 1.0, 16.0 + (k * 0.61) % 1.0),
                (k * 7.3).to_radians(),
            )
        })
        .collect();
    let mean_error = |n: u32| {
        placements
            .iter()
            .map(|&(centre, turn)| centroid_error(&cpu, centre, turn, n))
            .sum::<f64>()
            / placements.len() as f64
    };
    let errors: Vec<f64> = [1, 2, 4, 8, 16].into_iter().map(mean_error).collect();
    println!("mean centroid error for 1, 4, 16, 64, 256 samples: {errors:?}");
    for pair in errors.windows(2) {
        assert!(pair[1] < pair[0], "centroid errors stop falling: {errors:?}");
    }
    assert!(errors[4] < 0.01, "{errors:?}");
}
