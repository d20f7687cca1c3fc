//! The f32 GPU path against the f64 CPU reference: same scene, camera and pose, every camera
//! model, both rooms. Face ids agree on ≥ 99.99 % of pixels; range within 1e-5 relative.

mod common;

use glam::dvec3;
use omnisim::bvh::SceneBvh;
use omnisim::{Pose, cpu};

fn poses() -> Vec<Pose> {
    vec![
        Pose::from_degrees(dvec3(0.0, 0.0, 0.0), dvec3(0.0, 0.0, 0.0)),
        Pose::from_degrees(dvec3(0.0, 0.0, 0.4), dvec3(0.0, 0.0, 0.0)),
        Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0)),
        Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 50.0, 60.0)),
        Pose::from_degrees(dvec3(-0.7, 0.3, 1.2), dvec3(12.0, -20.0, 200.0)),
    ]
}

#[test]
fn gpu_matches_f64_reference_for_every_camera_and_room() {
    for room in common::ROOMS {
        let scene = common::load(room);
        let bvh = SceneBvh::build(&scene);
        let Some(gpu) = common::gpu_tracer(&bvh) else {
            return;
        };
        for camera in common::cameras() {
            let (mut pixels, mut same_face, mut worst_range) = (0usize, 0usize, 0f64);
            for pose in poses() {
                let reference = cpu::render(&bvh, &camera, &pose);
                let frame = gpu.render(&camera, &pose).expect("GPU render");
                for (r, g) in reference.pixels().iter().zip(frame.pixels()) {
                    pixels += 1;
                    if r.face == g.face {
                        same_face += 1;
                        if r.is_hit() {
                            let error = ((g.range as f64 - r.range as f64) / r.range as f64).abs();
                            worst_range = worst_range.max(error);
                        }
                    }
                }
                assert!(
                    reference.hit_count() > 0,
                    "{room} {}: nothing visible",
                    camera.model_name()
                );
            }
            let agreement = same_face as f64 / pixels as f64;
            eprintln!(
                "{room} {:<24} face ids agree on {:.5} % of {pixels} pixels; worst range error {worst_range:.2e}",
                camera.model_name(),
                agreement * 100.0
            );
            assert!(
                agreement >= 0.9999,
                "{room} {}: face ids agree on only {agreement}",
                camera.model_name()
            );
            assert!(
                worst_range <= 1e-5,
                "{room} {}: range error {worst_range}",
                camera.model_name()
            );
        }
    }
}

#[test]
fn gpu_hit_points_lie_on_the_ray_at_the_reported_range() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene);
    let Some(gpu) = common::gpu_tracer(&bvh) else {
        return;
    };
    let pose = Pose::from_degrees(dvec3(0.3, -0.2, 0.9), dvec3(5.0, 10.0, 30.0));
    for camera in common::cameras() {
        let frame = gpu.render(&camera, &pose).expect("GPU render");
        for p in frame.pixels().iter().filter(|p| p.is_hit()) {
            let distance = (p.point - pose.position).length();
            // Central cameras: the hit lies `range` from the viewpoint.
            assert!(
                (distance - p.range as f64).abs() <= 1e-5 * distance,
                "{} vs {}",
                distance,
                p.range
            );
        }
    }
}
