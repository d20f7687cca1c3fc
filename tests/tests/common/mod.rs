//! Helpers shared by the integration tests: shipped scenes, cameras, the GPU (or a loud skip).
#![allow(dead_code)]

use std::path::PathBuf;

use omnisim::bvh::SceneBvh;
use omnisim::gpu::{GpuContext, GpuTracer};
use omnisim::{Camera, Catadioptric, Equirectangular, Pinhole, Scene};

pub fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name)
}

pub fn load(name: &str) -> Scene {
    Scene::load(scene_path(name)).expect("shipped scene loads")
}

pub const ROOMS: [&str; 2] = ["env1.ron", "env2.ron"];

/// One camera of each model, at test-friendly sizes.
pub fn cameras() -> Vec<Camera> {
    vec![
        Camera::Pinhole(Pinhole::with_horizontal_fov(320, 240, 70f64.to_radians())),
        Camera::Equirectangular(Equirectangular {
            width: 512,
            height: 256,
        }),
        Camera::Catadioptric(Catadioptric::hyperbolic(
            250,
            250,
            0.04,
            0.16,
            Some(20f64.to_radians()),
        )),
    ]
}

/// A GPU tracer for `bvh`, or `None` after a loud message when no adapter exists and CI is
/// not set. In CI a missing adapter fails the test.
pub fn gpu_tracer(bvh: &SceneBvh) -> Option<GpuTracer> {
    match GpuContext::new() {
        Ok(context) => Some(GpuTracer::new(context, bvh).expect("GPU tracer builds")),
        Err(error) => {
            if std::env::var_os("CI").is_some() {
                panic!("CI is set but the GPU backend is unavailable: {error}");
            }
            eprintln!(
                "\n**** SKIPPED GPU CHECK: no GPU adapter ({error}). Install mesa-vulkan-drivers to run it. ****\n"
            );
            None
        }
    }
}
