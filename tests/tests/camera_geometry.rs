//! Camera models against closed forms written out independently here: the paper's rotation
//! matrices, pinhole K·(R|t), the equirectangular angles, Mei's unified model for the
//! hyperbolic mirror, and the column shift of a panorama turned about z.

mod common;

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3, dvec2, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::camera::MirrorShape;
use omnisim::camera::{Catadioptric, Equirectangular, Pinhole};
use omnisim::pose::rotation_xyz;
use omnisim::{Camera, Pose, advanced as trace};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Eqs. (8)–(11) of the reference paper, row by row.
fn paper_rotation(tx: f64, ty: f64, tz: f64) -> DMat3 {
    let rows = |r: [[f64; 3]; 3]| DMat3::from_cols_array_2d(&r).transpose();
    let rx = rows([[1.0, 0.0, 0.0], [0.0, tx.cos(), -tx.sin()], [0.0, tx.sin(), tx.cos()]]);
    let ry = rows([[ty.cos(), 0.0, ty.sin()], [0.0, 1.0, 0.0], [-ty.sin(), 0.0, ty.cos()]]);
    let rz = rows([[tz.cos(), -tz.sin(), 0.0], [tz.sin(), tz.cos(), 0.0], [0.0, 0.0, 1.0]]);
    rx * ry * rz
}

#[test]
fn rotation_is_the_papers_rx_ry_rz() {
    let mut rng = StdRng::seed_from_u64(1);
    for _ in 0..100 {
        let a = dvec3(
            rng.random_range(-PI..PI),
            rng.random_range(-PI..PI),
            rng.random_range(-PI..PI),
        );
        let difference = rotation_xyz(a) - paper_rotation(a.x, a.y, a.z);
        assert!(difference.to_cols_array().iter().all(|v| v.abs() < 1e-15));
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn pinhole_hits_project_back_to_their_pixels_by_k_r_t() {
    // At the origin and 10 km from it (DESIGN.md §7: 0.01 px in f64, 0.05 px in f32 anywhere).
    for far in [DVec3::ZERO, dvec3(1e4, -1e4, 0.0)] {
        pinhole_reprojection(far);
    }
}

/// Renders env1 moved by `far` through a pinhole at random poses and reprojects every hit.
fn pinhole_reprojection(far: DVec3) {
    let mut scene = common::load("env1.ron");
    for face in &mut scene.faces {
        face.vertices.iter_mut().for_each(|v| *v += far);
    }
    let bvh = SceneBvh::build(&scene).unwrap();
    let pinhole = Pinhole {
        position: DVec3::ZERO,
        width: 160,
        height: 120,
        fx: 150.0,
        fy: 140.0,
        cx: 81.3,
        cy: 58.9,
    };
    let camera = Camera::Pinhole(pinhole.clone());
    let k = DMat3::from_cols_array_2d(&[
        [pinhole.fx, 0.0, 0.0],
        [0.0, pinhole.fy, 0.0],
        [pinhole.cx, pinhole.cy, 1.0],
    ]);
    // optical_from_body, rows: x_opt = −y_body, y_opt = −z_body, z_opt = x_body.
    let optical_from_body = DMat3::from_cols_array_2d(&[[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]);
    let mut rng = StdRng::seed_from_u64(2);
    let gpu = common::gpu_tracer(&scene, &bvh);
    for _ in 0..8 {
        let position = far
            + dvec3(
                rng.random_range(-2.0..2.0),
                rng.random_range(-1.5..1.5),
                rng.random_range(0.0..1.8),
            );
        let angles = dvec3(
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(-PI..PI),
        );
        let pose = Pose::new(position, angles);
        let r = optical_from_body * paper_rotation(angles.x, angles.y, angles.z).transpose();
        let t = -(r * position);
        let project = |x: DVec3| {
            let p = k * (r * x + t);
            dvec2(p.x / p.z, p.y / p.z)
        };
        let frames = [
            (trace::trace(&bvh, &camera, &pose), 1e-6),
            (gpu.render(&camera, &pose).unwrap(), 0.01),
        ];
        for (frame, tolerance) in frames {
            for v in 0..frame.height {
                for u in 0..frame.width {
                    let pixel = frame.pixel(u, v);
                    assert!(pixel.is_hit(), "closed room: every pinhole pixel hits");
                    let error = (project(pixel.point) - dvec2(f64::from(u), f64::from(v))).length();
                    assert!(error < tolerance, "pixel ({u},{v}) reprojects {error} px away");
                }
            }
        }
    }
}

#[test]
fn equirectangular_rays_have_the_documented_angles() {
    let camera = Equirectangular {
        width: 360,
        height: 180,
    };
    let mut rng = StdRng::seed_from_u64(3);
    for _ in 0..1000 {
        let pixel = dvec2(rng.random_range(-0.5..359.5), rng.random_range(-0.5..179.5));
        let d = camera.ray(pixel).direction;
        let azimuth = PI - 2.0 * PI * (pixel.x + 0.5) / 360.0;
        let elevation = PI / 2.0 - PI * (pixel.y + 0.5) / 180.0;
        let expected = dvec3(
            elevation.cos() * azimuth.cos(),
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
        );
        assert!((d - expected).length() < 1e-12);
        let back = camera.project(d).unwrap();
        assert!((back - pixel).length() < 1e-9, "{back} vs {pixel}");
    }
    // Forward is the middle column, left is left of it.
    let forward = camera.project(DVec3::X).unwrap();
    assert!((forward - dvec2(179.5, 89.5)).length() < 1e-9);
    assert!(camera.project(DVec3::Y).unwrap().x < forward.x);
}

#[test]
fn turning_a_panorama_about_z_shifts_it_by_whole_columns() {
    let scene = common::load("env2.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let width = 256u32;
    let camera = Camera::Equirectangular(Equirectangular { width, height: 128 });
    let position = dvec3(0.5, -0.3, 0.6);
    let base = trace::trace(&bvh, &camera, &Pose::new(position, DVec3::ZERO));
    let shift = 37u32;
    let turned = trace::trace(
        &bvh,
        &camera,
        &Pose::new(
            position,
            dvec3(0.0, 0.0, 2.0 * PI * f64::from(shift) / f64::from(width)),
        ),
    );
    let (mut same, mut total) = (0, 0);
    for v in 0..128 {
        for u in 0..width {
            // Turning left by `shift` columns moves what was at column u + shift... to u.
            let a = turned.pixel(u, v);
            let b = base.pixel((u + width - shift) % width, v);
            total += 1;
            if a.face == b.face {
                same += 1;
                assert!((a.range - b.range).abs() <= 1e-6 * b.range, "range at ({u},{v})");
            }
        }
    }
    assert!(
        f64::from(same) >= 0.999 * f64::from(total),
        "{same} of {total} pixels unchanged"
    );
}

/// Mei's unified model for the hyperbolic mirror, written out from DESIGN.md §3.
fn mei_projection(m: &Catadioptric, s: DVec3) -> DVec2 {
    let MirrorShape::Hyperbolic { a, b } = m.mirror else {
        panic!("hyperbolic mirror expected")
    };
    let c = (a * a + b * b).sqrt();
    let xi = 2.0 * b * c / (b * b + c * c);
    let gamma = m.focal * a * a / (b * b + c * c);
    let s = s.normalize();
    dvec2(m.cx + gamma * s.x / (xi - s.z), m.cy + gamma * s.y / (xi - s.z))
}

#[test]
fn hyperbolic_reflection_matches_the_unified_model_within_a_hundredth_of_a_pixel() {
    let mut rng = StdRng::seed_from_u64(4);
    for (a, b) in [(0.04, 0.16), (0.028, 0.023), (0.03, 0.03)] {
        let mirror = Catadioptric::hyperbolic(640, 480, a, b, Some(15f64.to_radians()));
        let camera = Camera::Catadioptric(mirror.clone());
        let mut checked = 0;
        // Pixels → traced rays → closed-form pixels.
        while checked < 2000 {
            let pixel = dvec2(rng.random_range(0.0..640.0), rng.random_range(0.0..480.0));
            let Some(ray) = camera.ray(pixel) else {
                continue;
            };
            let error = (mei_projection(&mirror, ray.direction) - pixel).length();
            assert!(error < 0.01, "a={a} b={b}: pixel {pixel} off by {error} px");
            checked += 1;
        }
        // Directions → closed-form pixels → traced rays along the same directions.
        let elevation_limit = 15f64.to_radians();
        for _ in 0..2000 {
            let elevation = rng.random_range(-1.4..elevation_limit - 1e-6);
            let azimuth = rng.random_range(-PI..PI);
            let s = dvec3(
                elevation.cos() * azimuth.cos(),
                elevation.cos() * azimuth.sin(),
                elevation.sin(),
            );
            let pixel = mei_projection(&mirror, s);
            let ray = camera
                .ray(pixel)
                .expect("a direction inside the field of view has a pixel");
            let angle = ray.direction.angle_between(s);
            assert!(angle < 1e-7, "a={a} b={b}: direction off by {angle} rad");
            assert!((mei_projection(&mirror, ray.direction) - pixel).length() < 1e-6);
            assert!((camera.project(s).unwrap() - pixel).length() < 1e-9);
        }
    }
}

#[test]
fn hyperbolic_field_of_view_ends_at_the_rim_and_the_asymptote() {
    let elevation = 20f64.to_radians();
    let mirror = Catadioptric::hyperbolic(200, 200, 0.04, 0.16, Some(elevation));
    // The rim circle touches the image border: just inside it sees, just outside it does not.
    let camera = Camera::Catadioptric(mirror.clone());
    assert!(camera.ray(dvec2(mirror.cx + 99.9, mirror.cy)).is_some());
    assert!(camera.ray(dvec2(mirror.cx + 100.1, mirror.cy)).is_none());
    let rim_ray = camera.ray(dvec2(mirror.cx + 99.999, mirror.cy)).unwrap();
    assert!((rim_ray.direction.z.asin() - elevation).abs() < 1e-4);
    // Without a rim the mirror sees up to asin(b/c) at pixel radius f·a/b.
    let open = Catadioptric::hyperbolic(200, 200, 0.04, 0.16, None);
    let edge = Camera::Catadioptric(open.clone())
        .ray(dvec2(open.cx + 99.99, open.cy))
        .unwrap();
    assert!((edge.direction.z.asin() - open.asymptote_elevation()).abs() < 1e-2);
    assert!((open.focal * 0.04 / 0.16 - 100.0).abs() < 1e-9);
}
