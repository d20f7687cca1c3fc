//! The f32 GPU path against the f64 CPU reference: same scene, camera and pose, every camera
//! model and option, both rooms. Face ids agree on ≥ 99.99 % of pixels, counting as agreeing a
//! pixel whose two faces lie at the same range (a ray along the edge they share: the wide
//! fisheyes see every corner of the room); range within 1e-5
//! relative for central cameras. Non-central mirrors (the spherical one above all) amplify f32
//! rounding at the mirror: within 1e-4, leaving out pixels that meet the mirror within 5° of
//! grazing, where the reflected direction is ill-conditioned (docs/accuracy.md).

mod common;

use glam::{DVec2, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::{Camera, Frame, Planes, Pose, advanced as trace};

/// Whether the camera's ray for this pixel meets the mirror within 5° of grazing.
fn grazes_the_mirror(camera: &Camera, pixel: DVec2) -> bool {
    let Camera::Catadioptric(c) = camera else { return false };
    let (origin, d) = c
        .camera_ray_in_mirror(pixel)
        .expect("no lens: every pixel has a ray to the mirror");
    let quadric = c.quadric();
    quadric
        .first_hit(origin, d)
        .is_some_and(|t| d.dot(quadric.gradient(origin + t * d).normalize()).abs() < 5f64.to_radians().sin())
}

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
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_matches_f64_reference_for_every_camera_and_room() {
    for room in common::ROOMS {
        let scene = common::load(room);
        let bvh = SceneBvh::build(&scene).unwrap();
        let gpu = common::gpu_tracer(&scene, &bvh);
        for camera in common::cameras() {
            let (mut pixels, mut same_face, mut worst_range, mut grazing) = (0usize, 0usize, 0f64, 0usize);
            let mut edge_ties = 0usize;
            let width = camera.size().0 as usize;
            for pose in poses() {
                let reference = trace::trace(&bvh, &camera, &pose);
                let frame = gpu.render(&camera, &pose).expect("GPU render");
                for (i, (r, g)) in reference.pixels().iter().zip(frame.pixels()).enumerate() {
                    pixels += 1;
                    let tie = r.is_hit() && g.is_hit() && (g.range - r.range).abs() <= 1e-5 * r.range;
                    if r.face != g.face && tie {
                        edge_ties += 1;
                    }
                    if r.face == g.face {
                        same_face += 1;
                        let pixel = DVec2::new((i % width) as f64, (i / width) as f64);
                        if r.is_hit() && !camera.is_central() && grazes_the_mirror(&camera, pixel) {
                            grazing += 1;
                        } else if r.is_hit() {
                            let error = ((f64::from(g.range) - f64::from(r.range)) / f64::from(r.range)).abs();
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
            let agreement = (same_face + edge_ties) as f64 / pixels as f64;
            let name = common::describe(&camera);
            eprintln!(
                "{room} {name}: face ids agree on {:.5} % of {pixels} pixels ({edge_ties} other faces at the same \
                 range); worst range error {worst_range:.2e} ({grazing} grazing pixels left out)",
                agreement * 100.0
            );
            let tolerance = if camera.is_central() { 1e-5 } else { 1e-4 };
            assert!(agreement >= 0.9999, "{room} {name}: face ids agree on only {agreement}");
            assert!(worst_range <= tolerance, "{room} {name}: range error {worst_range}");
        }
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_hit_points_lie_on_the_ray_at_the_reported_range() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let pose = Pose::from_degrees(dvec3(0.3, -0.2, 0.9), dvec3(5.0, 10.0, 30.0));
    for camera in common::cameras() {
        // Central cameras only: their hits lie `range` from the viewpoint.
        if !camera.is_central() {
            continue;
        }
        let frame = gpu.render(&camera, &pose).expect("GPU render");
        for p in frame.pixels().iter().filter(|p| p.is_hit()) {
            // Normals are unit and face the viewpoint the ray came from.
            assert!((p.normal.length() - 1.0).abs() < 1e-5, "{}", p.normal);
            assert!(p.normal.as_dvec3().dot(p.point - pose.position) < 0.0);
            let distance = (p.point - pose.position).length();
            // Central cameras: the hit lies `range` from the viewpoint.
            assert!(
                (distance - f64::from(p.range)).abs() <= 1e-5 * distance,
                "{} vs {}",
                distance,
                p.range
            );
        }
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_edge_supersampling_matches_the_f64_reference() {
    let scene = common::load("env2.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let cpu = common::cpu_tracer(&scene, &bvh);
    let antialiased = |tracer: &common::Tracer, camera: &Camera| {
        tracer
            .renderer
            .render_antialiased(&tracer.scene, camera, &pose, Planes::COLOUR, 4)
            .unwrap()
    };
    for camera in [Camera::Catadioptric(common::paper_omni()), common::cameras()[0].clone()] {
        let reference = antialiased(&cpu, &camera);
        let refined = omnisim::advanced::edge_pixels(&reference).len();
        let frame = antialiased(&gpu, &camera);
        assert_eq!(omnisim::advanced::edge_pixels(&frame).len(), refined);
        let close = reference
            .colour()
            .unwrap()
            .iter()
            .zip(frame.colour().unwrap())
            .filter(|(r, g)| (0..3).all(|k| r[k].abs_diff(g[k]) <= 1))
            .count();
        let share = close as f64 / frame.pixels().len() as f64;
        eprintln!(
            "{}: {refined} edge pixels; colours within 1 of the reference on {:.4} %",
            camera.model_name(),
            share * 100.0
        );
        assert!(refined > 500 && share >= 0.999, "{share}");
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn images_traced_in_bands_equal_images_traced_at_once() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let mut gpu = common::gpu_tracer(&scene, &bvh);
    let pose = Pose::from_degrees(dvec3(0.3, -0.4, 0.9), dvec3(0.0, 15.0, 100.0));
    let camera = common::cameras()[2].clone();
    let whole = gpu.render_planes(&camera, &pose, Planes::ALL).unwrap();
    gpu.renderer.gpu_renderer().unwrap().limit_band_rows(7);
    let bands = camera.size().1.div_ceil(7);
    assert!(
        bands > 2 && !camera.size().1.is_multiple_of(7),
        "full bands and a shorter last one"
    );
    let untimed = gpu.render_planes(&camera, &pose, Planes::ALL).unwrap();
    let stages = gpu.renderer.gpu_stages().unwrap();
    assert_eq!(
        (stages.trace_pass, stages.shade_pass),
        (None, None),
        "passes are timed only when asked"
    );
    let clock = gpu.renderer.gpu_renderer().unwrap().has_pass_clock();
    gpu.renderer.gpu_renderer().unwrap().time_passes(true);
    let mut banded = gpu.render_planes(&camera, &pose, Planes::ALL).unwrap();
    assert_eq!(whole, banded);
    assert_eq!(untimed, banded);
    // Each band's stages are summed; both passes are timed where the device has timestamps.
    let stages = gpu.renderer.gpu_stages().unwrap();
    eprintln!("timestamp queries: {clock}; stages {stages:?}");
    assert_eq!(stages.bands, bands);
    assert_eq!(
        (stages.trace_pass.is_some(), stages.shade_pass.is_some()),
        (clock, clock)
    );
    // A re-shade in bands uploads each band's hits and shades them to the same planes, tracing nothing.
    gpu.renderer
        .reshade(&gpu.scene, &camera, &pose, &mut banded, Planes::ALL)
        .unwrap();
    assert_eq!(whole, banded);
    let reshaded = gpu.renderer.gpu_stages().unwrap();
    assert_eq!((reshaded.bands, reshaded.trace_pass), (bands, None));
    assert_eq!(reshaded.shade_pass.is_some(), clock);
    let hits = gpu.render_planes(&camera, &pose, Planes::HITS).unwrap();
    assert_eq!(hits.pixels(), whole.pixels());
    assert_eq!(gpu.renderer.gpu_stages().unwrap().shade_pass, None);
}

/// A frame re-shaded with a camera of another size is refused with an error that names both
/// sizes, and leaves nothing behind: the next re-shade, with the right camera, equals the render.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn a_reshade_of_a_frame_of_another_size_is_an_error_and_the_next_reshade_works() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let pose = Pose::from_degrees(dvec3(0.3, -0.4, 0.9), dvec3(0.0, 15.0, 100.0));
    let camera = common::cameras()[4].clone();
    let smaller = common::cameras()[0].clone();
    let rendered = gpu.render_planes(&camera, &pose, Planes::ALL).unwrap();
    gpu.renderer
        .reshade(&gpu.scene, &camera, &pose, &mut rendered.clone(), Planes::ALL)
        .unwrap();
    let mut small = gpu.render_planes(&smaller, &pose, Planes::ALL).unwrap();
    assert!(gpu.renderer.gpu_stages().is_some());
    let error = gpu
        .renderer
        .reshade(&gpu.scene, &camera, &pose, &mut small, Planes::ALL)
        .unwrap_err();
    assert!(matches!(error, omnisim::RenderError::FrameSize { .. }), "{error:?}");
    assert!(
        error.to_string().contains("320×240") && error.to_string().contains("512×256"),
        "{error}"
    );
    assert_eq!(gpu.renderer.gpu_stages(), None, "a frame that failed has no GPU stages");
    let mut frame = rendered.clone();
    gpu.renderer
        .reshade(&gpu.scene, &camera, &pose, &mut frame, Planes::ALL)
        .unwrap();
    assert_eq!(frame, rendered);
    assert_eq!(
        gpu.renderer.gpu_stages().map(|s| s.trace_pass),
        Some(None),
        "a re-shade traces nothing"
    );
}

/// Frames of one prepared scene rendered and re-shaded from many poses at once on a rayon pool
/// equal the frames rendered one by one. A frame's own rayon work (the ray table, the upload,
/// the readback) may run another frame on the same thread (rayon issue #592): that frame must
/// not wait for a lock the first one holds, or the pool deadlocks. The frames are queued on
/// the pool from outside, a few milliseconds apart, so that a thread waiting inside a frame's
/// tasks finds the next frame queued; two lens cameras alternate, so that each frame builds
/// its ray table on the pool.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn frames_rendered_in_parallel_equal_frames_rendered_one_by_one() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = std::sync::Arc::new(common::gpu_tracer(&scene, &bvh));
    let cameras = [common::cameras()[2].clone(), common::cameras()[3].clone()];
    assert!(cameras.iter().all(Camera::has_lens_model));
    let jobs: Vec<(Camera, Pose)> = (0..48)
        .map(|i| {
            let pose = Pose::from_degrees(
                dvec3(0.05 * f64::from(i), 0.0, 0.4),
                dvec3(0.0, 0.0, 7.5 * f64::from(i)),
            );
            (cameras[i as usize % 2].clone(), pose)
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(8).build().unwrap();
    let (sender, receiver) = std::sync::mpsc::channel();
    for (index, (camera, pose)) in jobs.iter().cloned().enumerate() {
        let (gpu, sender) = (std::sync::Arc::clone(&gpu), sender.clone());
        // A job's failure is sent back as this test's failure: a panic in a spawned job would
        // abort the whole test binary.
        pool.spawn(move || {
            let job = || -> Result<(Frame, Frame), String> {
                let mut frame = gpu
                    .render_planes(&camera, &pose, Planes::ALL)
                    .map_err(|e| e.to_string())?;
                let rendered = frame.clone();
                gpu.renderer
                    .reshade(&gpu.scene, &camera, &pose, &mut frame, Planes::ALL)
                    .map_err(|e| e.to_string())?;
                Ok((rendered, frame))
            };
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job))
                .unwrap_or_else(|_| Err("the frame panicked".into()));
            let _ = sender.send((index, result));
        });
        std::thread::sleep(std::time::Duration::from_millis(3));
    }
    // One deadline for all the frames: a deadlock fails after it, not after one wait a frame.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    for _ in &jobs {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        let (index, result) = receiver
            .recv_timeout(left)
            .expect("every frame finishes: a frame's rayon work ran another frame that waited for it (deadlock)");
        let (rendered, reshaded) = result.unwrap_or_else(|e| panic!("frame {index}: {e}"));
        let (camera, pose) = &jobs[index];
        let serial = gpu.render_planes(camera, pose, Planes::ALL).unwrap();
        assert!(serial.hit_count() > 1000);
        assert!(rendered == serial && reshaded == serial, "frame {index}");
    }
}

/// A NaN ray hits nothing on the GPU, as on the CPU: a pose of NaN position or angles (the
/// library takes poses unchecked) makes every camera ray NaN, and every pixel is a miss in
/// both; a finite pose's frame still has its hits. A correctness test, one frame per pose: the
/// speed of the GPU walk's early return for such rays (`has_nan` in `shaders/bvh.wgsl`) is
/// measured in docs/benchmarks.md only.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn nan_rays_are_misses_on_the_gpu_as_on_the_cpu() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let camera = Camera::Catadioptric(common::paper_omni());
    for pose in [
        Pose::from_degrees(dvec3(f64::NAN, 0.0, 0.4), dvec3(0.0, 0.0, 60.0)),
        Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, f64::NAN, 60.0)),
    ] {
        let reference = trace::trace(&bvh, &camera, &pose);
        let frame = gpu.render(&camera, &pose).expect("GPU render");
        assert_eq!(frame.hit_count(), 0, "the GPU found hits on NaN rays");
        assert_eq!(reference.hit_count(), 0, "the CPU found hits on NaN rays");
    }
    let finite = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    assert!(gpu.render(&camera, &finite).unwrap().hit_count() > 10_000);
}

/// Ties (issue 18): where an exact copy of a wall lies on the wall, the GPU's f32 distances to
/// both are the same bits, and the lower face id wins there as on the CPU (`wins` in
/// `shaders/bvh.wgsl`), whichever the walk meets first.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn coincident_faces_resolve_to_the_lower_face_id_on_the_gpu() {
    let scene = common::coincident_faces();
    let (lower_copy, wall_4, wall_2, upper_copy, ..) = common::COINCIDENT_FACE_IDS;
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let camera = Camera::Equirectangular(omnisim::camera::Equirectangular {
        width: 256,
        height: 128,
    });
    let mut seen = [0usize; 9];
    for pose in [
        Pose::from_degrees(dvec3(0.5, 0.5, 0.5), dvec3(0.0, 0.0, 0.0)),
        Pose::from_degrees(dvec3(0.3, 0.6, 0.45), dvec3(10.0, -20.0, 35.0)),
    ] {
        for pixel in gpu.render(&camera, &pose).expect("GPU render").pixels() {
            seen[pixel.face as usize] += 1;
        }
    }
    assert!(seen[lower_copy] > 1000 && seen[wall_4] == 0, "{seen:?}");
    assert!(seen[wall_2] > 1000 && seen[upper_copy] == 0, "{seen:?}");
}

/// A dense scene, whose wide BVH is several levels deep (the walk's stack of child groups
/// several entries high) and whose leaves hold up to four triangles: env1 with 30,000 small random triangles
/// strewn through the room. Faces agree with the f64 reference as in the rooms; ranges within
/// 5e-5, not 1e-5: strewn triangles lie centimetres from the viewpoint, where the f32 test's
/// rounding (relative to the room's coordinates, not to the range) is a larger part of the
/// range. From inside the clutter and from a corner.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn gpu_matches_f64_reference_in_a_dense_scene() {
    use rand::{Rng, SeedableRng, rngs::StdRng};
    let mut scene = common::load("env1.ron");
    let room_faces = scene.faces.len() as u32;
    let (lo, hi) = scene.bounds().unwrap();
    let mut rng = StdRng::seed_from_u64(18);
    let point = |rng: &mut StdRng| {
        glam::DVec3::new(
            rng.random_range(lo.x..hi.x),
            rng.random_range(lo.y..hi.y),
            rng.random_range(lo.z..hi.z),
        )
    };
    for _ in 0..30_000 {
        let corner = point(&mut rng);
        let near = |rng: &mut StdRng| corner + (point(rng) - corner).normalize() * rng.random_range(0.01..0.08);
        let vertices = [corner, near(&mut rng), near(&mut rng)];
        scene.faces.push(omnisim::scene::Face {
            vertices: vertices.into_iter().collect(),
            colour: [90, 120, 200],
            object: 0,
        });
    }
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let camera = Camera::Equirectangular(omnisim::camera::Equirectangular {
        width: 256,
        height: 128,
    });
    let centre = (lo + hi) / 2.0;
    let (mut pixels, mut agree, mut worst_range) = (0usize, 0usize, 0f64);
    for pose in [
        Pose::from_degrees(centre, dvec3(0.0, 0.0, 0.0)),
        Pose::from_degrees(lo.lerp(hi, 0.1), dvec3(10.0, -20.0, 35.0)),
    ] {
        let reference = trace::trace(&bvh, &camera, &pose);
        let frame = gpu.render(&camera, &pose).expect("GPU render");
        for (r, g) in reference.pixels().iter().zip(frame.pixels()) {
            pixels += 1;
            let same_range = r.is_hit() && g.is_hit() && (g.range - r.range).abs() <= 1e-5 * r.range;
            if r.face == g.face || same_range {
                agree += 1;
            }
            if r.face == g.face && r.is_hit() {
                worst_range = worst_range.max(((f64::from(g.range) - f64::from(r.range)) / f64::from(r.range)).abs());
            }
        }
        let strewn = reference
            .pixels()
            .iter()
            .filter(|p| p.is_hit() && p.face >= room_faces)
            .count();
        assert!(strewn > 1000, "the strewn triangles fill {strewn} pixels");
    }
    let agreement = agree as f64 / pixels as f64;
    assert!(agreement >= 0.9999, "face ids agree on only {agreement}");
    eprintln!("dense scene: face ids agree on {agreement}, worst range error {worst_range:.2e}");
    assert!(worst_range <= 5e-5, "range error {worst_range}");
}

/// `auto` takes a hardware adapter, never a software one (llvmpipe: the f64 CPU tracer is
/// faster on the same cores), and says why; `gpu` takes whatever adapter there is.
#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn auto_prefers_the_cpu_tracer_over_a_software_adapter() {
    let scene = common::load("env1.ron");
    let mut gpu = common::gpu_tracer(&scene, &SceneBvh::build(&scene).unwrap());
    let software = gpu.renderer.gpu_renderer().unwrap().is_software();
    let auto = omnisim::Renderer::new(omnisim::BackendChoice::Auto).unwrap();
    if software {
        assert_eq!(auto.backend_name(), "cpu");
        assert!(
            auto.reason().contains("software") && auto.reason().contains("--backend gpu"),
            "{}",
            auto.reason()
        );
        let forced = omnisim::Renderer::new(omnisim::BackendChoice::Gpu).unwrap();
        assert_eq!(forced.backend_name(), "gpu");
    } else {
        assert_eq!(auto.backend_name(), "gpu", "{}", auto.reason());
    }
}
