//! Trace once, shade many: changing face colours and lights between frames rebuilds neither
//! the BVH nor the GPU pipelines, and the re-shaded image (and a new render) equals a fresh
//! render of the changed scene. `GpuRenderer::pipelines_built` counts for the whole process,
//! so this file holds one test: nothing else builds pipelines while it runs.

mod common;

use glam::dvec3;
use omnisim::advanced::Appearance;
use omnisim::advanced::GpuRenderer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::Equirectangular;
use omnisim::scene::lighting::LightKind;
use omnisim::{Camera, Planes, Pose, Scene};

/// env1-lit with the table repainted, the ceiling lamp moved and dimmed, the desk lamp off,
/// more ambient light and another exposure.
fn changed(scene: &Scene) -> Scene {
    let mut changed = scene.clone();
    let table = changed.objects.iter().position(|o| o.name == "table").unwrap() as u32;
    for face in changed.faces.iter_mut().filter(|f| f.object == table) {
        face.colour = [30, 200, 120];
    }
    let lighting = changed.lighting.as_mut().unwrap();
    lighting.ambient = 12.0;
    lighting.white = 45.0;
    lighting.light_mut("ceiling lamp").unwrap().kind = LightKind::Point {
        position: dvec3(-1.0, 0.5, 1.9),
        intensity: 180.0,
    };
    lighting.light_mut("desk lamp").unwrap().on = false;
    changed
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn changing_colours_and_lights_rebuilds_nothing_and_equals_a_fresh_render() {
    let scene = common::load("env1-lit.ron");
    let changed = changed(&scene);
    let bvh = SceneBvh::build(&scene).unwrap();
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let cameras = [
        Camera::Catadioptric(common::paper_omni()),
        Camera::Equirectangular(Equirectangular {
            width: 256,
            height: 128,
        }),
    ];
    let tracers = [
        ("cpu", common::cpu_tracer(&scene, &bvh)),
        ("gpu", common::gpu_tracer(&scene, &bvh)),
    ];
    for (backend, mut tracer) in tracers {
        let frames: Vec<_> = cameras
            .iter()
            .map(|camera| tracer.render_planes(camera, &pose, Planes::ALL).unwrap())
            .collect();
        let (builds, pipelines) = (tracer.renderer.geometry_builds(), GpuRenderer::pipelines_built());
        tracer
            .renderer
            .set_appearance(&mut tracer.scene, Appearance::of(&changed))
            .unwrap();
        let mut reshaded = frames.clone();
        for (camera, frame) in cameras.iter().zip(&mut reshaded) {
            tracer
                .renderer
                .reshade(&tracer.scene, camera, &pose, frame, Planes::ALL)
                .unwrap();
        }
        let rerendered: Vec<_> = cameras
            .iter()
            .map(|camera| tracer.render_planes(camera, &pose, Planes::ALL).unwrap())
            .collect();
        assert_eq!(
            tracer.renderer.geometry_builds(),
            builds,
            "{backend}: a change of appearance built a BVH"
        );
        assert_eq!(
            GpuRenderer::pipelines_built(),
            pipelines,
            "{backend}: a change of appearance built pipelines"
        );
        let fresh_scene = tracer.renderer.prepare(&changed).unwrap();
        for (c, camera) in cameras.iter().enumerate() {
            let fresh = tracer
                .renderer
                .render(&fresh_scene, camera, &pose, Planes::ALL)
                .unwrap();
            let differing = frames[c]
                .colour()
                .unwrap()
                .iter()
                .zip(fresh.colour().unwrap())
                .filter(|(a, b)| a != b)
                .count();
            eprintln!(
                "{backend} {}: the change alters {differing} of {} pixels; re-shaded and re-rendered images equal \
                 the fresh render ({builds} BVH builds, {pipelines} pipelines before and after)",
                camera.model_name(),
                fresh.pixels().len()
            );
            assert!(
                differing > fresh.pixels().len() / 4,
                "{backend}: the change should show"
            );
            assert_eq!(rerendered[c], fresh, "{backend} {}: re-render", camera.model_name());
            assert_eq!(
                reshaded[c].colour(),
                fresh.colour(),
                "{backend} {}: re-shade",
                camera.model_name()
            );
            assert_eq!(
                reshaded[c].linear_colour(),
                fresh.linear_colour(),
                "{backend} {}",
                camera.model_name()
            );
            assert_eq!(reshaded[c].pixels(), fresh.pixels());
        }
    }
}
