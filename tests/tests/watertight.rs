//! Inside a closed room no ray escapes: at 200 random poses per room every direction of a
//! full panorama hits a face (both CPU tracers), and at 20 poses per room on the GPU too.

mod common;

use std::f64::consts::PI;

use glam::dvec3;
use omnisim::advanced::CpuTracer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::Equirectangular;
use omnisim::{Camera, Pose};
use rand::{Rng, SeedableRng, rngs::StdRng};

fn random_poses(scene: &omnisim::Scene, count: usize, seed: u64) -> Vec<Pose> {
    let (lo, hi) = scene.bounds().unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let margin = 0.01;
            let p = dvec3(
                rng.random_range(lo.x + margin..hi.x - margin),
                rng.random_range(lo.y + margin..hi.y - margin),
                rng.random_range(lo.z + margin..hi.z - margin),
            );
            let a = dvec3(
                rng.random_range(-PI..PI),
                rng.random_range(-PI..PI),
                rng.random_range(-PI..PI),
            );
            Pose::new(p, a)
        })
        .collect()
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn no_ray_escapes_a_closed_room() {
    let camera = Camera::Equirectangular(Equirectangular { width: 96, height: 48 });
    for (seed, room) in common::ROOMS.iter().enumerate() {
        let scene = common::load(room);
        let bvh = SceneBvh::build(&scene).unwrap();
        for pose in random_poses(&scene, 200, seed as u64) {
            for tracer in [CpuTracer::Reference, CpuTracer::Fast] {
                let frame = tracer.trace(&bvh, &camera, &pose);
                assert_eq!(
                    frame.hit_count(),
                    96 * 48,
                    "{room}: {tracer:?} rays escaped at {pose:?}"
                );
            }
        }
        let gpu = common::gpu_tracer(&scene, &bvh);
        for pose in random_poses(&scene, 20, 100 + seed as u64) {
            let frame = gpu.render(&camera, &pose).unwrap();
            assert_eq!(frame.hit_count(), 96 * 48, "{room}: GPU rays escaped at {pose:?}");
        }
    }
}
