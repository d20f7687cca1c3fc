//! `cargo bench -p omnisim-benches`: BVH build time and whole-image render time for each
//! camera model on env1, on both CPU tracers (fast and f64 reference) and (when an adapter
//! opens) the GPU, and the CPU tracers with the camera at the scene's centre and 1 cm off it.
//! `omnisim bench` reports the same quantities as JSON for scripts and notes.

use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::dvec3;
use omnisim::advanced::CpuTracer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::{Catadioptric, Equirectangular, Pinhole};
use omnisim::{BackendChoice, Camera, Planes, Pose, PreparedScene, Renderer, Scene};

fn env1() -> Scene {
    Scene::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/env1.ron")).expect("env1 loads")
}

fn cameras() -> Vec<(&'static str, Camera)> {
    vec![
        (
            "pinhole 640x480",
            Camera::Pinhole(Pinhole::with_horizontal_fov(640, 480, 60f64.to_radians())),
        ),
        (
            "equirect 1024x512",
            Camera::Equirectangular(Equirectangular {
                width: 1024,
                height: 512,
            }),
        ),
        (
            "omni 250x250",
            Camera::Catadioptric(Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()))),
        ),
    ]
}

fn benchmarks(c: &mut Criterion) {
    let scene = env1();
    c.bench_function("bvh build env1", |b| b.iter(|| SceneBvh::build(&scene).unwrap()));
    let cpu_tracers: Vec<(&str, Renderer, PreparedScene)> =
        [("cpu fast", CpuTracer::Fast), ("cpu f64", CpuTracer::Reference)]
            .into_iter()
            .map(|(name, tracer)| {
                let mut renderer = Renderer::new(BackendChoice::Cpu).expect("CPU backend");
                renderer.set_cpu_tracer(tracer);
                let prepared = renderer.prepare(&scene).expect("scene");
                (name, renderer, prepared)
            })
            .collect();
    let gpu = Renderer::new(BackendChoice::Gpu).ok().map(|gpu| {
        let prepared = gpu.prepare(&scene).expect("GPU scene");
        (gpu, prepared)
    });
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let mut group = c.benchmark_group("render env1");
    group.sample_size(20);
    for (name, camera) in cameras() {
        let (w, h) = camera.size();
        group.throughput(Throughput::Elements(u64::from(w) * u64::from(h)));
        for (tracer, cpu, cpu_scene) in &cpu_tracers {
            group.bench_function(format!("{tracer} {name}"), |b| {
                b.iter(|| cpu.render(cpu_scene, &camera, &pose, Planes::COLOUR).expect("render"));
            });
        }
        if let Some((gpu, prepared)) = &gpu {
            group.bench_function(format!("gpu f32 {name}"), |b| {
                b.iter(|| gpu.render(prepared, &camera, &pose, Planes::COLOUR).expect("render"));
            });
        }
    }
    group.finish();

    // Issue 10: a camera coordinate equal to the scene's centre (the BVH's local origin) once
    // made every box test multiply subnormals; the two poses must cost the same.
    let (lo, hi) = scene.bounds().expect("env1 has faces");
    let centre = (lo + hi) / 2.0;
    let camera = Camera::Equirectangular(Equirectangular {
        width: 512,
        height: 512,
    });
    let mut group = c.benchmark_group("camera at the scene centre");
    group.sample_size(20);
    group.throughput(Throughput::Elements(512 * 512));
    for (name, position) in [("centre", centre), ("centre + 1 cm", centre + 0.01)] {
        let pose = Pose::from_degrees(position, dvec3(0.0, 0.0, 0.0));
        for (tracer, cpu, cpu_scene) in &cpu_tracers {
            group.bench_function(format!("{tracer} equirect 512x512 {name}"), |b| {
                b.iter(|| cpu.render(cpu_scene, &camera, &pose, Planes::COLOUR).expect("render"));
            });
        }
    }
    group.finish();
}

criterion_group!(benches, benchmarks);
criterion_main!(benches);
