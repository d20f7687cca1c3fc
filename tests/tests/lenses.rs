//! Lens cameras through the renderer and against independent readers: range and z-depth at
//! the image border against the closed-form distance to the room's planes (past 180° where
//! the lens reaches), and every calibration file a lens writes read by `OpenCV`, Kalibr's and
//! Basalt's equations and loader rules and `OCamCalib`'s functions in Python (`tests/readers/check_lens_calibration.py`),
//! which must project the same points to omnisim's pixels within 1e-6 px.

mod common;

use std::fmt::Write;
use std::path::Path;
use std::process::Command;

use glam::{DVec3, dvec2, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::advanced::trace;
use omnisim::calibration;
use omnisim::camera::spec::defaults;
use omnisim::camera::{
    BrownConrady, Catadioptric, FisheyeSpec, LensCamera, LensModel, LensSpec, MirrorSpec, Misalignment, Mount,
    OmniSpec, PinholeSpec, RigSpec, StereoSpec,
};
use omnisim::{Camera, Pose, Rig, Scene};

/// The room: x in [-2, 2], y in [-3, 3], z in [0, 3] (a box seen from inside).
const ROOM: (DVec3, DVec3) = (DVec3::new(-2.0, -3.0, 0.0), DVec3::new(2.0, 3.0, 3.0));

fn room() -> Scene {
    Scene::from_ron(
        r#"Scene(name: "room", objects: [
            Box(name: "room", size: (4.0, 6.0, 3.0), position: (0.0, 0.0, 0.0), colour: (200, 180, 160)),
        ])"#,
        Path::new("lens-room.ron"),
    )
    .expect("the room")
}

/// Distance from `origin` inside the room along unit `direction` to the first plane it meets.
fn distance_to_room(origin: DVec3, direction: DVec3) -> f64 {
    (0..3)
        .filter(|&axis| direction[axis] != 0.0)
        .map(|axis| {
            let wall = if direction[axis] > 0.0 {
                ROOM.1[axis]
            } else {
                ROOM.0[axis]
            };
            (wall - origin[axis]) / direction[axis]
        })
        .fold(f64::INFINITY, f64::min)
}

fn fisheye(lens: LensSpec, fov: Option<f64>) -> RigSpec {
    RigSpec::Fisheye(FisheyeSpec {
        size: (96, 80),
        lens,
        fov,
        focal: None,
    })
}

/// One camera of each lens family, wide where the lens allows.
fn lens_rigs() -> Vec<RigSpec> {
    let pinhole = |distortion: &[f64]| {
        RigSpec::Pinhole(PinholeSpec {
            size: (96, 80),
            hfov: 100.0,
            focal: None,
            distortion: Some(distortion.to_vec()),
        })
    };
    vec![
        pinhole(&[-0.3, 0.09, 1e-3, -2e-3]),
        pinhole(&[-0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005]),
        pinhole(&[
            -0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005, 1e-3, -1e-3, 2e-3, 5e-4,
        ]),
        fisheye(
            LensSpec::KannalaBrandt {
                k: [0.02, -0.004, 1e-4, -2e-5],
            },
            Some(250.0),
        ),
        fisheye(LensSpec::Equisolid, Some(260.0)),
        fisheye(LensSpec::DoubleSphere { xi: -0.2, alpha: 0.6 }, Some(230.0)),
        fisheye(LensSpec::Eucm { alpha: 0.6, beta: 1.1 }, Some(240.0)),
        fisheye(
            LensSpec::Unified {
                xi: 1.3,
                distortion: [-0.05, 0.01, 1e-4, -2e-4],
            },
            Some(250.0),
        ),
        fisheye(
            LensSpec::Scaramuzza {
                poly: vec![-40.0, 0.0, 8e-3, -3e-5, 1.5e-8],
                affine: (1.0003, 2e-4, -1e-4),
            },
            None,
        ),
        // Without distortion the unified model is also Basalt's `ucm`.
        fisheye(
            LensSpec::Unified {
                xi: 0.8,
                distortion: [0.0; 4],
            },
            Some(200.0),
        ),
    ]
}

#[test]
fn range_and_depth_at_the_border_are_the_distance_to_the_plane() {
    let scene = room();
    let bvh = SceneBvh::build(&scene).unwrap();
    let pose = Pose::new(dvec3(0.3, -0.2, 1.4), dvec3(0.1, -0.2, 0.5));
    let world_from_body = pose.world_from_body_rotation();
    for spec in lens_rigs() {
        let lens = common::lens_camera(&spec);
        let name = lens.model.name();
        let camera = Camera::Lens(Box::new(lens.clone()));
        let frame = trace(&bvh, &camera, &pose);
        let depth = lens.intrinsics.axial_depth(&frame, &pose);
        let axis = world_from_body * dvec3(1.0, 0.0, 0.0);
        let (width, height) = lens.size();
        let (mut border, mut past_90) = (0, 0);
        for v in 0..height {
            for u in 0..width {
                if !(u == 0 || v == 0 || u == width - 1 || v == height - 1) {
                    continue;
                }
                let pixel = frame.pixel(u, v);
                let Some(ray) = camera.ray(dvec2(f64::from(u), f64::from(v))) else {
                    assert!(!pixel.is_hit(), "{name} ({u},{v}): a pixel without a ray is background");
                    continue;
                };
                let direction = world_from_body * ray.direction;
                let expected = distance_to_room(pose.position, direction);
                assert!(pixel.is_hit(), "{name} ({u},{v}): the closed room is hit everywhere");
                let hit = pixel.point - pose.position;
                assert!(
                    (hit.length() - expected).abs() <= 1e-9 * expected,
                    "{name} ({u},{v}): range {} vs the plane's {expected}",
                    hit.length()
                );
                assert!((f64::from(pixel.range) - expected).abs() <= 1e-6 * expected);
                let z = expected * direction.dot(axis);
                let index = (v * width + u) as usize;
                assert!(
                    (f64::from(depth[index]) - z).abs() <= 1e-6 * expected,
                    "{name}: z-depth"
                );
                border += 1;
                past_90 += usize::from(z < 0.0);
            }
        }
        assert!(border > 20, "{name}: {border} border pixels with rays");
        eprintln!("{name}: {border} border pixels, {past_90} past 90° off axis");
        if lens.model.max_angle() > 1.7 && !matches!(spec, RigSpec::Pinhole(_)) {
            assert!(past_90 > 0, "{name}: the border sees past 90°");
        }
    }
}

/// Points around a camera, in its body frame, that it sees.
fn seen_points(lens: &LensCamera) -> Vec<(DVec3, glam::DVec2)> {
    let (width, height) = lens.size();
    let mut points = Vec::new();
    for i in 0..4000 {
        let t = f64::from(i);
        let point =
            dvec3((t * 0.37).sin(), (t * 0.91).cos(), (t * 0.13).sin() * 0.8) * (1.0 + (t * 0.07).sin().abs() * 3.0);
        if let Some(pixel) = lens.project(point)
            && pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x <= f64::from(width) - 0.5
            && pixel.y <= f64::from(height) - 0.5
        {
            points.push((point, pixel));
        }
    }
    points
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn opencv_kalibr_and_ocamcalib_read_the_calibration_files_to_omnisims_pixels() {
    let python = std::env::var_os("OMNISIM_PYTHON")
        .expect("OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (README, Tests)");
    let dir = tempfile::tempdir().unwrap();
    for (index, spec) in lens_rigs().iter().enumerate() {
        let lens = common::lens_camera(spec);
        let files = calibration::lens_files(&lens);
        if files.is_empty() {
            // The ideal equisolid, stereographic and orthographic lenses have no tool's format.
            continue;
        }
        let folder = dir.path().join(format!("{index}-{}", lens.model.name()));
        std::fs::create_dir(&folder).unwrap();
        for (name, text) in files {
            std::fs::write(folder.join(name), text).unwrap();
        }
        let mut table = String::from("# body x y z, omnisim's u v (f64)\n");
        let points = seen_points(&lens);
        assert!(points.len() > 100, "{}: {} points", lens.model.name(), points.len());
        for (point, pixel) in points {
            let _ = writeln!(
                table,
                "{:?} {:?} {:?} {:?} {:?}",
                point.x, point.y, point.z, pixel.x, pixel.y
            );
        }
        std::fs::write(folder.join("points.txt"), table).unwrap();
    }
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let check = Command::new(python)
        .arg("tests/readers/check_lens_calibration.py")
        .arg(dir.path())
        .current_dir(workspace)
        .output()
        .expect("the reader check's Python runs");
    let stdout = String::from_utf8_lossy(&check.stdout);
    eprintln!("{stdout}");
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
    assert!(stdout.contains("9 lenses checked"), "{stdout}");
    for reader in ["Basalt kb4", "Basalt ds", "Basalt eucm", "Basalt ucm"] {
        assert!(stdout.contains(reader), "{reader}: {stdout}");
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn the_gpu_reads_the_ray_table_in_bands_and_refines_lens_edges_like_the_cpu() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let mut gpu = common::gpu_tracer(&scene, &bvh);
    let cpu = common::cpu_tracer(&scene, &bvh);
    let pose = Pose::from_degrees(dvec3(0.3, -0.4, 0.9), dvec3(0.0, 15.0, 100.0));
    let camera = Camera::Lens(Box::new(common::lens_camera(&lens_rigs()[3])));
    let whole = gpu.render(&camera, &pose).unwrap();
    gpu.renderer.gpu_renderer().unwrap().limit_band_rows(7);
    let banded = gpu.render(&camera, &pose).unwrap();
    assert_eq!(whole, banded, "bands index the table by their absolute rows");
    // Edge samples of a lens camera are traced by the CPU on either backend: the same colours.
    let antialiased = |tracer: &common::Tracer| {
        tracer
            .renderer
            .render_antialiased(&tracer.scene, &camera, &pose, omnisim::Planes::COLOUR, 3)
            .unwrap()
    };
    let (reference, refined) = (antialiased(&cpu), antialiased(&gpu));
    let close = reference
        .colour()
        .unwrap()
        .iter()
        .zip(refined.colour().unwrap())
        .filter(|(r, g)| (0..3).all(|k| r[k].abs_diff(g[k]) <= 1))
        .count();
    assert!(close as f64 >= 0.999 * reference.pixels().len() as f64, "{close}");
}

/// A stereo pair with `lens` on both cameras (or Brown–Conrady `distortion`), 96×80.
fn stereo(lens: Option<LensSpec>, distortion: Option<Vec<f64>>, baseline: f64) -> RigSpec {
    RigSpec::Stereo(StereoSpec {
        size: (96, 80),
        hfov: defaults::HFOV,
        focal: None,
        baseline,
        distortion,
        fov: lens.as_ref().map(|_| 220.0),
        lens,
    })
}

#[test]
fn each_eye_of_a_stereo_lens_pair_is_the_single_lens_camera_at_that_eyes_pose() {
    let scene = room();
    let bvh = SceneBvh::build(&scene).unwrap();
    let kb = LensSpec::KannalaBrandt {
        k: [0.02, -0.004, 1e-4, -2e-5],
    };
    let distortion = vec![-0.28, 0.07, 1e-3, -2e-3, 0.01];
    let pairs = [
        (
            stereo(Some(kb.clone()), None, 0.25),
            common::lens_camera(&fisheye(kb, Some(220.0))),
        ),
        (
            stereo(None, Some(distortion.clone()), 0.25),
            common::lens_camera(&RigSpec::Pinhole(PinholeSpec {
                size: (96, 80),
                hfov: defaults::HFOV,
                focal: None,
                distortion: Some(distortion),
            })),
        ),
    ];
    for (spec, single) in pairs {
        let name = single.model.name();
        let Rig::Stereo(rig) = spec.build().expect("a valid pair") else {
            panic!("{name}: a stereo rig")
        };
        assert!(!rig.has_disparity(), "{name}: a pair with a lens has no disparity");
        let views = Rig::Stereo(rig.clone()).views();
        let single = Camera::Lens(Box::new(single));
        // Dyadic positions and no turn: the eye's place adds without rounding, so the frames are
        // the same bit for bit; a turned pose rounds the eye's origin differently, by an ulp.
        let poses = [
            (Pose::from_degrees(dvec3(0.5, -0.25, 1.0), DVec3::ZERO), true),
            (
                Pose::from_degrees(dvec3(0.3, -0.4, 0.9), dvec3(5.0, -10.0, 100.0)),
                false,
            ),
        ];
        for (pose, exact) in poses {
            let mut frames = Vec::new();
            for (view, y) in views.iter().zip([0.125, -0.125]) {
                let eye = Pose::new(
                    pose.position + pose.world_from_body_rotation() * dvec3(0.0, y, 0.0),
                    pose.angles,
                );
                let frame = trace(&bvh, &view.camera, &pose);
                let alone = trace(&bvh, &single, &eye);
                let hits = frame.pixels().iter().filter(|p| p.is_hit()).count();
                assert!(hits > 3000, "{name}{}: {hits} hits", view.suffix);
                if exact {
                    assert_eq!(frame.pixels(), alone.pixels(), "{name}{}", view.suffix);
                } else {
                    for (a, b) in frame.pixels().iter().zip(alone.pixels()) {
                        assert_eq!(a.is_hit(), b.is_hit(), "{name}{}", view.suffix);
                        let error = (f64::from(a.range) - f64::from(b.range)).abs() / f64::from(b.range.max(1.0));
                        assert!(
                            a.range == b.range || error < 1e-6,
                            "{name}{}: {a:?} vs {b:?}",
                            view.suffix
                        );
                    }
                }
                frames.push(frame);
            }
            // The eyes see the room from 0.25 m apart: their images differ.
            assert_ne!(frames[0].pixels(), frames[1].pixels(), "{name}: parallax");
        }
    }
}

#[test]
fn a_stereo_rig_refuses_lens_fields_that_do_not_apply() {
    let refusal = |spec: RigSpec| spec.build().expect_err("refused").to_string();
    let mut fov_without_lens = stereo(None, None, 0.12);
    let RigSpec::Stereo(s) = &mut fov_without_lens else {
        unreachable!()
    };
    s.fov = Some(120.0);
    assert!(refusal(fov_without_lens).contains("stereo fov does not apply to pinholes"));
    let both = stereo(Some(LensSpec::Equidistant), Some(vec![0.1, 0.0, 0.0, 0.0]), 0.12);
    assert!(refusal(both).contains("stereo distortion does not apply with a lens"));
    let mut hfov_with_lens = stereo(Some(LensSpec::Equidistant), None, 0.12);
    let RigSpec::Stereo(s) = &mut hfov_with_lens else {
        unreachable!()
    };
    s.hfov = 90.0;
    assert!(refusal(hfov_with_lens).contains("stereo hfov does not apply to a lens"));
    let too_wide = stereo(Some(LensSpec::Orthographic), None, 0.12);
    assert!(refusal(too_wide).contains("between 0 and 180.00 degrees"));
    assert!(refusal(stereo(Some(LensSpec::Equidistant), None, 0.0)).contains("baseline"));
    // A pair without a lens keeps its disparity, and its rig file its old form.
    let plain = stereo(None, None, 0.12);
    let Rig::Stereo(rig) = plain.build().unwrap() else {
        unreachable!()
    };
    assert!(rig.has_disparity());
    let text = serde_json::to_string(&plain).unwrap();
    assert!(
        !text.contains("lens") && !text.contains("distortion") && !text.contains("\"fov\""),
        "{text}"
    );
}

/// Mirrors seen through `lens`: the paper's hyperbolic one (aligned, misaligned, mounted down
/// with a hidden centre) and a sphere.
fn mirrors_with(lens: Option<&LensModel>) -> Vec<Catadioptric> {
    let paper = Catadioptric::hyperbolic(160, 160, 0.04, 0.16, Some(20f64.to_radians()));
    let mut misaligned = paper.clone();
    misaligned.misalignment = Misalignment {
        offset: dvec3(0.002, -0.001, 0.003),
        tilt: dvec3(0.01, -0.02, 0.3),
    };
    let mut down = paper.clone();
    down.mount = Mount::Down;
    down.hidden_centre_px = 12.0;
    let mut mirrors = vec![paper, misaligned, down, Catadioptric::spherical(120, 120, 0.05, 0.25)];
    for mirror in &mut mirrors {
        mirror.lens = lens.cloned().map(Box::new);
    }
    mirrors
}

fn pixels_of(camera: &Catadioptric) -> impl Iterator<Item = glam::DVec2> {
    let (width, height) = (camera.width, camera.height);
    (0..height).flat_map(move |v| (0..width).map(move |u| dvec2(f64::from(u), f64::from(v))))
}

#[test]
fn a_mirror_seen_through_a_lens_without_distortion_is_the_ideal_pinholes_bit_for_bit() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let pose = Pose::from_degrees(dvec3(0.3, -0.4, 0.9), dvec3(5.0, -10.0, 100.0));
    for zeros in [4, 5, 8, 12] {
        let lens = LensModel::Perspective(BrownConrady::new(&vec![0.0; zeros]).unwrap());
        for (ideal, lensed) in mirrors_with(None).into_iter().zip(mirrors_with(Some(&lens))) {
            lensed.validate().unwrap();
            for pixel in pixels_of(&ideal) {
                assert_eq!(ideal.ray(pixel), lensed.ray(pixel), "{pixel}");
            }
            let (ideal, lensed) = (Camera::Catadioptric(ideal), Camera::Catadioptric(lensed));
            assert_eq!(
                trace(&bvh, &ideal, &pose).pixels(),
                trace(&bvh, &lensed, &pose).pixels()
            );
        }
    }
}

/// `OpenCV`'s `projectPoints` distortion (k1 k2 p1 p2 k3), written out.
fn opencv_distort(k: [f64; 5], m: glam::DVec2) -> glam::DVec2 {
    let [k1, k2, p1, p2, k3] = k;
    let (x, y) = (m.x, m.y);
    let r2 = x * x + y * y;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    dvec2(
        x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
    )
}

#[test]
fn each_pixel_of_a_mirror_seen_through_a_distorted_lens_reflects_its_undistorted_pinhole_ray() {
    let k = [-0.12, 0.03, 1e-3, -2e-3, 0.004];
    let lens = LensModel::Perspective(BrownConrady::new(&k).unwrap());
    for (ideal, lensed) in mirrors_with(None).into_iter().zip(mirrors_with(Some(&lens))) {
        lensed.validate().unwrap();
        let (focal, centre) = (lensed.focal, dvec2(lensed.cx, lensed.cy));
        let (mut checked, mut worst) = (0usize, 0f64);
        for pixel in pixels_of(&lensed) {
            let Some(ray) = lensed.ray(pixel) else { continue };
            // The lens's inverse: the undistorted point m, which OpenCV's formula distorts back to
            // the pixel (undistortPoints' definition).
            let (towards, _) = lensed.lens_ray(pixel).expect("a pixel with a ray has a lens ray");
            let m = towards.truncate() / towards.z;
            let distorted = opencv_distort(k, m) * focal + centre;
            assert!(
                (distorted - pixel).length() < 1e-9,
                "{pixel}: m distorts to {distorted}"
            );
            // The ideal pinhole's ray through m, off the mirror: the same ray.
            let expected = ideal
                .ray(centre + m * focal)
                .expect("the ideal pinhole sees the mirror there");
            let error = (ray.origin - expected.origin)
                .length()
                .max((ray.direction - expected.direction).length())
                .max((ray.t_min - expected.t_min).abs());
            worst = worst.max(error);
            assert!(error <= 1e-9, "{pixel}: {ray:?} vs {expected:?}");
            // Aligned central mirrors: the closed-form projection (unified model, then the lens)
            // puts the ray's points back on the pixel.
            if lensed.is_central() {
                let back = lensed.project(ray.direction * 3.0).expect("inside");
                assert!((back - pixel).length() < 1e-6, "{pixel}: projects to {back}");
            }
            checked += 1;
        }
        let pixels = (lensed.width * lensed.height) as usize;
        assert!(
            checked * 3 > pixels,
            "{:?}: {checked} of {pixels} pixels",
            lensed.mirror
        );
        eprintln!(
            "{:?} mount {:?}: {checked} pixels, worst {worst:.1e}",
            lensed.mirror, lensed.mount
        );
    }
}

#[test]
fn a_mirror_lens_is_refused_where_it_does_not_apply() {
    let omni = |mirror: MirrorSpec, distortion: Option<Vec<f64>>, lens: Option<LensSpec>| {
        RigSpec::Omni(OmniSpec {
            mirror,
            max_elevation: Some(20.0),
            distortion,
            lens,
            ..OmniSpec::default()
        })
    };
    let refusal = |spec: RigSpec| spec.build().expect_err("refused").to_string();
    let parabolic = MirrorSpec::Parabolic {
        a: 0.04,
        b: None,
        h: 0.02,
    };
    let message = refusal(omni(parabolic, Some(vec![0.1, 0.0, 0.0, 0.0]), None));
    assert!(message.contains("orthographic"), "{message}");
    let scaramuzza = LensSpec::Scaramuzza {
        poly: vec![-40.0, 0.0, 8e-3],
        affine: (1.0, 0.0, 0.0),
    };
    let message = refusal(omni(MirrorSpec::default(), None, Some(scaramuzza)));
    assert!(message.contains("scaramuzza lens sets its own scale"), "{message}");
    let message = refusal(omni(
        MirrorSpec::default(),
        Some(vec![0.1, 0.0, 0.0, 0.0]),
        Some(LensSpec::Equidistant),
    ));
    assert!(
        message.contains("omni distortion does not apply with a lens"),
        "{message}"
    );
    let message = refusal(omni(MirrorSpec::default(), Some(vec![0.1, 0.0, 0.0]), None));
    assert!(message.contains("distortion takes 4"), "{message}");
    // Any central lens but Scaramuzza's: a Kannala–Brandt lens on the paper's mirror renders,
    // and files without one keep their form.
    let kb = LensSpec::KannalaBrandt {
        k: [0.01, -0.002, 0.0, 0.0],
    };
    let Rig::Single(Camera::Catadioptric(mirror)) = omni(MirrorSpec::default(), None, Some(kb)).build().unwrap() else {
        unreachable!()
    };
    assert!(matches!(mirror.lens.as_deref(), Some(LensModel::KannalaBrandt(_))));
    assert_eq!(
        mirror.unified_distortion(),
        None,
        "no unified model expresses a KB lens"
    );
    let text = serde_json::to_string(&RigSpec::Omni(OmniSpec::default())).unwrap();
    assert!(!text.contains("lens") && !text.contains("distortion"), "{text}");
}
