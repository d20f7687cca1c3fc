//! A lost GPU device (a driver reset, a GPU fault; here `wgpu::Device::destroy`): the renderer
//! that held it fails its frames with `GpuError::DeviceLost`, never a panic or a hang; a
//! renderer made after it opens a fresh device, whose frames equal the earlier ones and the
//! f64 CPU reference; a data set whose device is lost mid-run renders that frame again on a
//! fresh one and finishes with the same files.
//!
//! The process has one device, shared by every renderer: destroying it fails whatever GPU
//! frame another test runs meanwhile. So the tests that destroy it live in this binary of
//! their own, and take [`SERIAL`] so that they run one at a time.

mod common;

use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Mutex;

use glam::dvec3;
use omnisim::advanced::{self as trace, Appearance, SceneBvh};
use omnisim::{Planes, Pose};
use omnisim_dataset::{Dataset, RunOptions};

/// Held by every test of this binary: one destroys the device at a time, with no other GPU
/// work running.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    // A failed test poisons the lock; the next one still runs alone.
    SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// `error` is the loss, named with its adapter and what wgpu said, telling the user the way on.
fn assert_device_lost(error: &omnisim::RenderError, adapter: &str) {
    let text = error.to_string();
    assert!(error.is_device_lost(), "not a lost device: {text}");
    for part in [adapter, "Destroyed", "opens it again", "--backend cpu"] {
        assert!(text.contains(part), "'{part}' missing from: {text}");
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_lost_device_fails_its_renderer_and_the_next_renderer_opens_a_fresh_one() {
    let _serial = serial();
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let camera = common::cameras()[0].clone();
    let mut old = common::gpu_tracer(&scene, &bvh);
    let adapter = old.renderer.device_name();
    let before = old.render(&camera, &pose).expect("a frame before the loss");
    // `auto` on the same device (on lavapipe, `auto` itself would choose the CPU).
    let auto = omnisim::Renderer::new(omnisim::BackendChoice::Gpu).unwrap().as_auto();
    old.renderer.destroy_device();

    // The first frame finds the loss as it runs (wgpu learns of it on its poll); the next
    // ones are refused at once. Re-shading, supersampling, a new appearance and a new scene
    // on the lost device fail the same way.
    for _ in 0..2 {
        assert_device_lost(&old.render(&camera, &pose).unwrap_err(), &adapter);
    }
    let mut frame = before.clone();
    let reshaded = old
        .renderer
        .reshade(&old.scene, &camera, &pose, &mut frame, Planes::COLOUR);
    assert_device_lost(&reshaded.unwrap_err(), &adapter);
    let supersampled = old
        .renderer
        .render_antialiased(&old.scene, &camera, &pose, Planes::COLOUR, 3);
    assert_device_lost(&supersampled.unwrap_err(), &adapter);
    let appearance = old.renderer.set_appearance(&mut old.scene, Appearance::of(&scene));
    assert_device_lost(&appearance.unwrap_err(), &adapter);
    assert_device_lost(&old.renderer.prepare(&scene).err().unwrap(), &adapter);
    // Not a scene too large for the GPU, which `auto` would trace on the CPU instead.
    assert_device_lost(&auto.prepare(&scene).err().unwrap(), &adapter);

    // A renderer made now opens a fresh device, as does reopening the lost one; their frames
    // are the frame made before the loss, byte for byte, on the same adapter.
    let fresh = common::gpu_tracer(&scene, &bvh);
    let reopened = old.renderer.reopen().expect("a renderer on a fresh device");
    let reopened_scene = reopened.prepare_with(&scene, bvh.clone()).unwrap();
    for after in [
        fresh.render(&camera, &pose).expect("a frame on the fresh device"),
        reopened
            .render(&reopened_scene, &camera, &pose, Planes::COLOUR)
            .unwrap(),
    ] {
        assert_eq!(after.pixels(), before.pixels());
        assert_eq!(after.colour(), before.colour());
    }

    // And they match the f64 CPU reference as every GPU frame does (tests/gpu_vs_cpu.rs):
    // face ids on ≥ 99.99 % of pixels (counting a tie at one range along a shared edge),
    // ranges within 1e-5 relative.
    let after = fresh.render(&camera, &pose).unwrap();
    let reference = trace::trace(&bvh, &camera, &pose);
    let (mut agree, mut worst) = (0usize, 0f64);
    for (r, g) in reference.pixels().iter().zip(after.pixels()) {
        let error = (f64::from(g.range) - f64::from(r.range)).abs() / f64::from(r.range);
        if r.face == g.face || (r.is_hit() && g.is_hit() && error <= 1e-5) {
            agree += 1;
        }
        if r.face == g.face && r.is_hit() {
            worst = worst.max(error);
        }
    }
    assert!(reference.hit_count() > 0);
    let agreement = agree as f64 / reference.pixels().len() as f64;
    assert!(agreement >= 0.9999, "face ids agree on only {agreement}");
    assert!(worst <= 1e-5, "range error {worst}");
}

const ROOM: &str = r#"Scene(name: "room", objects: [
    Floor(name: "floor", corners: [(-2.0, -1.5), (2.0, -1.5), (2.0, 1.5), (-2.0, 1.5)], colour: (150, 140, 120)),
    Wall(name: "south", from: (-2.0, -1.5), to: (2.0, -1.5), height: 2.5, colour: (200, 190, 160)),
    Wall(name: "east", from: (2.0, -1.5), to: (2.0, 1.5), height: 2.5, colour: (90, 160, 200)),
    Wall(name: "north", from: (2.0, 1.5), to: (-2.0, 1.5), height: 2.5, colour: (200, 120, 90)),
    Wall(name: "west", from: (-2.0, 1.5), to: (-2.0, -1.5), height: 2.5, colour: (185, 210, 170)),
    Box(name: "table", size: (0.8, 0.6, 0.7), position: (1.2, 0.8, 0.0), colour: (150, 60, 40)),
], lighting: (ambient: 10.0, white: 60.0, lights: [Point(name: "lamp", position: (0.0, 0.0, 2.2), intensity: 150.0)]))"#;

/// Two sets, the second with an occluder of its own: a loss in the second set's frames finds
/// a scene prepared on the lost device, which the fresh one must prepare again.
const SPEC: &str = r#"Dataset(
    scene: "room.ron",
    seed: 3,
    rig: Pinhole(size: (48, 32), hfov: 70.0),
    outputs: (point_cloud: false, segmentation: true),
    sets: [
        Set(name: "map", poses: Trajectory(through: [(-1.2, -0.8, 1.0), (1.2, -0.8, 1.0)], count: 3)),
        Set(
            name: "test",
            poses: List([(0.0, 0.0, 1.0, 0.0, 0.0, 45.0), (-1.0, 0.5, 1.2, 0.0, 0.0, 200.0)]),
            occluders: [Occluders(shape: Box(size: (0.3, 0.3, 0.5)), count: 1, per_frame: false)],
        ),
    ],
)"#;

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_data_set_whose_device_is_lost_renders_the_frame_again_on_a_fresh_one() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("room.ron"), ROOM).unwrap();
    let spec = dir.path().join("spec.ron");
    std::fs::write(&spec, SPEC).unwrap();
    let dataset = Dataset::load(&spec).unwrap();
    let gpu = || omnisim::Renderer::new(omnisim::BackendChoice::Gpu).expect("a GPU adapter (README, Tests)");
    let all = RunOptions::default();
    let unharmed = dir.path().join("unharmed");
    let summary = dataset
        .run(&gpu(), &unharmed, &all, &mut |_| ControlFlow::Continue(()))
        .unwrap();
    assert!(summary.notes.is_empty(), "{:?}", summary.notes);

    // Frames map/1 and test/0 (every second one) first; then the whole set, which hears of
    // those two as it reaches them, before it renders the next, and destroys the device there:
    // map/2 then fails on the map scene prepared on the lost device, and test/1 (on the device
    // opened in its place, lost in turn) as it prepares its set's scene.
    let lost = dir.path().join("lost");
    let odd = RunOptions {
        shard: Some("1/2".parse().unwrap()),
        ..RunOptions::default()
    };
    let first = gpu();
    dataset
        .run(&first, &lost, &odd, &mut |_| ControlFlow::Continue(()))
        .unwrap();
    let summary = dataset
        .run(&first, &lost, &all, &mut |frame| {
            if !frame.rendered {
                // A renderer made now shares the process's device with the run's.
                gpu().destroy_device();
            }
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!((summary.rendered, summary.resumed), (3, 2));
    assert!(summary.merged);
    let [map, test] = summary.notes.as_slice() else {
        panic!("two reopenings: {:?}", summary.notes)
    };
    for (note, frame) in [(map, "set 'map', frame 2"), (test, "set 'test', frame 1")] {
        assert!(note.starts_with(frame), "{note}");
        assert!(
            note.contains("was lost (Destroyed)") && note.ends_with("rendered again on the device opened in its place"),
            "{note}"
        );
    }
    // The manifest lists every file of the data set with its SHA-256.
    let manifest = |dir: &Path| std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    assert_eq!(manifest(&unharmed), manifest(&lost), "the files after the reopenings");
}
