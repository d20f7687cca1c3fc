//! The vision systems beyond the pinhole against closed forms written out here: parabolic and
//! hyperbolic mirrors against Mei's unified model (rays, and blob centroids of markers at known
//! points), the cylindrical panorama, stereo disparity on a planar wall, the spherical mirror's
//! law of reflection, mounts and hidden centres, and the exported calibration and ray maps
//! reproducing the rendered geometry.

mod common;

use std::f64::consts::PI;
use std::path::Path;

use glam::{DVec2, DVec3, dvec2, dvec3};
use omnisim::advanced::SceneBvh;
use omnisim::camera::{Catadioptric, Cylindrical, Pinhole, StereoRig};
use omnisim::camera::{MirrorShape, Mount};
use omnisim::{Camera, Frame, Pose, Scene, advanced as trace, calibration, output};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Mei's unified model, (ξ, γ) from the mirror's closed forms (DESIGN.md §3).
fn unified(camera: &Catadioptric) -> (f64, f64) {
    match camera.mirror {
        MirrorShape::Hyperbolic { a, b } => {
            let c = (a * a + b * b).sqrt();
            (2.0 * b * c / (b * b + c * c), camera.focal * a * a / (b * b + c * c))
        }
        MirrorShape::Parabolic { a, h, .. } => (1.0, camera.focal * a * a / (2.0 * h)),
        MirrorShape::Spherical { .. } => panic!("the spherical mirror has no unified model"),
    }
}

fn mei(camera: &Catadioptric, s: DVec3) -> DVec2 {
    let (xi, gamma) = unified(camera);
    let s = s.normalize();
    dvec2(
        camera.cx + gamma * s.x / (xi - s.z),
        camera.cy + gamma * s.y / (xi - s.z),
    )
}

fn direction_at(elevation: f64, azimuth: f64) -> DVec3 {
    dvec3(
        elevation.cos() * azimuth.cos(),
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
    )
}

#[test]
fn parabolic_mirror_matches_the_unified_model() {
    let mut rng = StdRng::seed_from_u64(11);
    let camera = Catadioptric::parabolic(640, 480, 0.04, 0.02, 20f64.to_radians());
    let traced = Camera::Catadioptric(camera.clone());
    let mut checked = 0;
    while checked < 2000 {
        let pixel = dvec2(rng.random_range(0.0..640.0), rng.random_range(0.0..480.0));
        let Some(ray) = traced.ray(pixel) else { continue };
        assert!((mei(&camera, ray.direction) - pixel).length() < 0.01, "pixel {pixel}");
        checked += 1;
    }
    for _ in 0..2000 {
        let s = direction_at(rng.random_range(-1.5..0.34), rng.random_range(-PI..PI));
        let pixel = mei(&camera, s);
        let ray = traced.ray(pixel).expect("inside the rim");
        assert!(ray.direction.angle_between(s) < 1e-7);
        assert!((traced.project(s).unwrap() - pixel).length() < 1e-9);
    }
}

#[test]
fn cylindrical_panorama_matches_its_closed_form() {
    let camera = Cylindrical::with_vertical_fov(720, 200, 100f64.to_radians());
    let fy = 100.0 / (50f64.to_radians()).tan();
    let mut rng = StdRng::seed_from_u64(12);
    for _ in 0..2000 {
        let pixel = dvec2(rng.random_range(-0.5..719.5), rng.random_range(-0.5..199.5));
        let azimuth = PI - 2.0 * PI * (pixel.x + 0.5) / 720.0;
        let expected = dvec3(azimuth.cos(), azimuth.sin(), (99.5 - pixel.y) / fy).normalize();
        let ray = camera.ray(pixel);
        assert!((ray.direction - expected).length() < 1e-12);
        assert!((camera.project(ray.direction * 3.7).unwrap() - pixel).length() < 0.01);
    }
    // The horizon is the middle row; the top row sees vfov/2 up to within half a pixel.
    assert!(camera.ray(dvec2(10.0, 99.5)).direction.z.abs() < 1e-15);
    let top = camera.ray(dvec2(0.0, -0.5)).direction;
    assert!((top.z.asin() - 50f64.to_radians()).abs() < 1e-12);
}

#[test]
fn stereo_disparity_is_f_b_over_z_on_a_planar_wall() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let rig = StereoRig::rectified(Pinhole::with_horizontal_fov(320, 240, 60f64.to_radians()), 0.12);
    let [left, right] = rig.pinholes();
    // Facing the east wall (x = 3) squarely from x = 0.5: z = 2.5 m on the whole wall.
    let pose = Pose::from_degrees(dvec3(0.5, -0.4, 1.2), DVec3::ZERO);
    let frame = trace::trace(&bvh, &Camera::Pinhole(left.clone()), &pose);
    let disparity = rig.disparity(&frame, &pose).expect("ideal pinholes have disparity");
    let east_wall = scene.objects.iter().position(|o| o.name == "east wall").unwrap() as u32;
    let expected = rig.camera.fx * rig.baseline / 2.5;
    let mut on_wall = 0;
    for (index, (pixel, d)) in frame.pixels().iter().zip(&disparity).enumerate() {
        if pixel.is_hit() && scene.faces[pixel.face as usize].object == east_wall {
            assert!((f64::from(*d) - expected).abs() < 0.01, "disparity {d} vs {expected}");
            on_wall += 1;
        }
        if pixel.is_hit() {
            // The right camera sees the same point at u − d on the same row.
            let (u, v) = ((index % 320) as f64, (index / 320) as f64);
            let seen_from_right = right.ray(dvec2(u - f64::from(*d), v));
            let towards_point =
                pose.world_from_body_rotation().transpose() * (pixel.point - pose.position) - right.position;
            assert!(seen_from_right.direction.angle_between(towards_point) < 1e-6);
        }
    }
    assert!(on_wall > 1000, "the wall fills much of the view: {on_wall} pixels");
}

#[test]
fn spherical_mirror_rays_obey_the_law_of_reflection() {
    let scene = common::load("env2.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let (radius, distance) = (0.05, 0.25);
    let camera = Catadioptric::spherical(200, 200, radius, distance);
    let traced = Camera::Catadioptric(camera.clone());
    let pose = Pose::from_degrees(dvec3(0.4, 0.3, 0.8), dvec3(10.0, -5.0, 30.0));
    let frame = trace::trace(&bvh, &traced, &pose);
    let body_from_world = pose.world_from_body_rotation().transpose();
    let pinhole = dvec3(0.0, 0.0, -distance);
    let mut checked = 0;
    for (index, pixel) in frame.pixels().iter().enumerate() {
        let image_point = dvec2((index % 200) as f64, (index / 200) as f64);
        let Some(ray) = traced.ray(image_point) else { continue };
        assert!(pixel.is_hit(), "closed room");
        let mirror_point = ray.origin;
        assert!((mirror_point.length() - radius).abs() < 1e-12 * radius);
        // The pinhole sees the mirror point at this pixel.
        let projected = dvec2(
            camera.cx + camera.focal * mirror_point.x / (mirror_point.z + distance),
            camera.cy + camera.focal * mirror_point.y / (mirror_point.z + distance),
        );
        assert!((projected - image_point).length() < 1e-9);
        // Incoming from the pinhole, out to the world point the pixel images.
        let incoming = (mirror_point - pinhole).normalize();
        let normal = mirror_point / radius;
        let outgoing = (body_from_world * (pixel.point - pose.position) - mirror_point).normalize();
        let reflected = incoming - 2.0 * incoming.dot(normal) * normal;
        assert!(
            (outgoing - reflected).length() < 1e-9,
            "reflection off by {}",
            (outgoing - reflected).length()
        );
        checked += 1;
    }
    assert!(checked > 20_000);
}

#[test]
fn turned_over_mirror_and_hidden_centre() {
    let up = common::paper_omni();
    let mut down = up.clone();
    down.mount = Mount::Down;
    down.hidden_centre_px = 15.0;
    let mut rng = StdRng::seed_from_u64(13);
    for _ in 0..500 {
        let p = dvec3(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
        );
        let mirrored = dvec3(p.x, -p.y, -p.z);
        match (
            Camera::Catadioptric(down.clone()).project(p),
            Camera::Catadioptric(up.clone()).project(mirrored),
        ) {
            (Some(a), Some(b)) => assert!((a - b).length() < 1e-12),
            (None, Some(b)) => assert!(b.distance(dvec2(up.cx, up.cy)) < 15.0, "only the hidden centre is lost"),
            (a, b) => assert_eq!(a.is_some(), b.is_some()),
        }
    }
    let turned = Camera::Catadioptric(down.clone());
    assert!(turned.ray(dvec2(down.cx + 14.9, down.cy)).is_none());
    let just_outside = turned.ray(dvec2(down.cx + 15.1, down.cy)).unwrap();
    assert!(
        just_outside.direction.z > 0.9,
        "the centre of a downward mirror looks up past the camera"
    );
}

/// Half the side of a marker, metres.
const MARKER_HALF_SIDE: f64 = 0.05;

/// The corners of a square marker centred at `centre`, facing the viewpoint at the origin.
fn marker_corners(centre: DVec3) -> [DVec3; 4] {
    let towards = -centre.normalize();
    let side = towards.cross(DVec3::Z).normalize() * MARKER_HALF_SIDE;
    let up = side.cross(towards).normalize() * MARKER_HALF_SIDE;
    [
        centre + side + up,
        centre - side + up,
        centre - side - up,
        centre + side - up,
    ]
}

/// A dark closed box with small bright 10 cm square markers facing the viewpoint at known points.
fn marker_scene(markers: &[DVec3]) -> Scene {
    let mut text = String::from(
        "Scene(name: \"markers\", objects: [\n  Box(name: \"room\", size: (12.0, 12.0, 8.0), position: (0.0, 0.0, -4.0), colour: (20, 20, 20)),\n",
    );
    for (i, centre) in markers.iter().enumerate() {
        let corners: Vec<String> = marker_corners(*centre)
            .iter()
            .map(|c| format!("({:?}, {:?}, {:?})", c.x, c.y, c.z))
            .collect();
        text += &format!(
            "  Polygon(name: \"marker {i}\", vertices: [{}], colour: (255, 255, 255)),\n",
            corners.join(", ")
        );
    }
    text += "])";
    Scene::from_ron(&text, Path::new("markers.ron")).expect("marker scene")
}

/// Where the unified model puts the centroid of a marker's image: the area centroid of its
/// outline, projected point by point (200 points an edge) with Mei's closed form.
fn predicted_centroid(camera: &Catadioptric, centre: DVec3) -> DVec2 {
    let corners = marker_corners(centre);
    let outline: Vec<DVec2> = (0..4)
        .flat_map(|e| (0..200).map(move |k| corners[e].lerp(corners[(e + 1) % 4], f64::from(k) / 200.0)))
        .map(|p| mei(camera, p))
        .collect();
    let (mut area, mut moment) = (0.0, DVec2::ZERO);
    for (i, a) in outline.iter().enumerate() {
        let b = outline[(i + 1) % outline.len()];
        let cross = a.perp_dot(b);
        area += cross / 2.0;
        moment += (*a + b) * cross / 6.0;
    }
    moment / area
}

/// Centroid of the pixels showing each object (index 1.. are the markers).
fn centroids(frame: &Frame, scene: &Scene, count: usize) -> Vec<Option<DVec2>> {
    let mut sums = vec![(DVec2::ZERO, 0usize); count];
    for (index, pixel) in frame.pixels().iter().enumerate() {
        if pixel.is_hit() {
            let object = scene.faces[pixel.face as usize].object as usize;
            if object > 0 {
                let sum = &mut sums[object - 1];
                sum.0 += dvec2(
                    (index % frame.width as usize) as f64,
                    (index / frame.width as usize) as f64,
                );
                sum.1 += 1;
            }
        }
    }
    sums.into_iter()
        .map(|(sum, n)| (n >= 4).then(|| sum / n as f64))
        .collect()
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn marker_centroids_land_where_the_unified_model_says() {
    // A grid of directions far enough apart that no marker hides another.
    let markers: Vec<DVec3> = [-0.9, -0.5, -0.15, 0.2]
        .iter()
        .enumerate()
        .flat_map(|(row, &elevation)| {
            (0..6).map(move |k| {
                let azimuth = (f64::from(k) + 0.3 * row as f64) * PI / 3.0;
                direction_at(elevation, azimuth) * if k % 2 == 0 { 1.3 } else { 1.8 }
            })
        })
        .collect();
    let scene = marker_scene(&markers);
    let bvh = SceneBvh::build(&scene).unwrap();
    let gpu = common::gpu_tracer(&scene, &bvh);
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    for camera in [
        Catadioptric::hyperbolic(1000, 1000, 0.04, 0.16, Some(25f64.to_radians())),
        Catadioptric::parabolic(1000, 1000, 0.04, 0.02, 25f64.to_radians()),
    ] {
        let traced = Camera::Catadioptric(camera.clone());
        let frames = [
            ("cpu", trace::trace(&bvh, &traced, &pose)),
            ("gpu", gpu.render(&traced, &pose).unwrap()),
        ];
        for (backend, frame) in frames {
            let mut worst: f64 = 0.0;
            let found = centroids(&frame, &scene, markers.len());
            for (marker, centroid) in markers.iter().zip(&found) {
                let expected = predicted_centroid(&camera, *marker);
                let centroid = centroid.unwrap_or_else(|| panic!("{backend}: marker at {marker} not seen"));
                worst = worst.max(centroid.distance(expected));
            }
            eprintln!(
                "{} {backend}: worst marker centroid error {worst:.3} px",
                traced.model_name()
            );
            assert!(worst < 0.3, "{backend}: centroid {worst} px from the unified model");
        }
    }
}

/// The numbers of `data: [ … ]` under `name:` in an `OpenCV` YAML file.
fn yaml_matrix(text: &str, name: &str) -> Vec<f64> {
    let block = &text[text.find(&format!("\n{name}:")).unwrap_or_else(|| panic!("no {name}"))..];
    let data = &block[block.find('[').unwrap() + 1..block.find(']').unwrap()];
    data.split(',').map(|v| v.trim().parse().unwrap()).collect()
}

/// The numbers of the first Kalibr `intrinsics: [ … ]` line.
fn kalibr_intrinsics(text: &str) -> Vec<f64> {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("intrinsics:"))
        .unwrap();
    numbers_in_brackets(line)
}

fn numbers_in_brackets(line: &str) -> Vec<f64> {
    let data = &line[line.find('[').unwrap() + 1..line.find(']').unwrap()];
    data.split(',').map(|v| v.trim().parse().unwrap()).collect()
}

/// The first Kalibr `T_cam_imu` (`camera_from_body`) as a function of body points.
fn kalibr_camera_from_body(text: &str) -> impl Fn(DVec3) -> DVec3 {
    let start = text.find("T_cam_imu:").expect("T_cam_imu");
    let rows: Vec<Vec<f64>> = text[start..].lines().skip(1).take(3).map(numbers_in_brackets).collect();
    move |p: DVec3| {
        let row = |r: &Vec<f64>| r[0] * p.x + r[1] * p.y + r[2] * p.z + r[3];
        dvec3(row(&rows[0]), row(&rows[1]), row(&rows[2]))
    }
}

/// `xi: value` of an `OpenCV` omnidir file.
fn yaml_real(text: &str, name: &str) -> f64 {
    let line = text.lines().find(|l| l.starts_with(&format!("{name}:"))).unwrap();
    line[name.len() + 1..].trim().parse().unwrap()
}

#[test]
fn exported_calibration_reproduces_the_rendered_geometry() {
    let mut rng = StdRng::seed_from_u64(15);
    // Omnidirectional: OpenCV omnidir and Kalibr omni, frame X_model = (x_M, y_M, −z_M).
    let mut omni = common::paper_omni();
    omni.mount = Mount::Down;
    let opencv = calibration::opencv_omnidir(&omni).unwrap();
    let k = yaml_matrix(&opencv, "camera_matrix");
    let xi = yaml_real(&opencv, "xi");
    let body_from_mirror = yaml_matrix(&opencv, "body_from_mirror");
    let kalibr_text = calibration::kalibr_omni(&omni).unwrap();
    let kalibr = kalibr_intrinsics(&kalibr_text);
    // Kalibr's proper camera frame Rx(π)·M with positive focal lengths describes the image
    // flipped top to bottom: row v becomes H − 1 − v.
    let last_row = 249.0;
    assert_eq!(kalibr, vec![xi, k[0], k[4], k[2], last_row - k[5]]);
    assert!(kalibr_text.contains("IMAGE FLIPPED"));
    let kalibr_camera = kalibr_camera_from_body(&kalibr_text);
    let mounted_up = Catadioptric {
        mount: Mount::Up,
        ..omni.clone()
    };
    assert_ne!(
        kalibr_text,
        calibration::kalibr_omni(&mounted_up).unwrap(),
        "the mount is in the file"
    );
    let traced = Camera::Catadioptric(omni);
    let mut checked = 0;
    while checked < 1000 {
        let pixel = dvec2(rng.random_range(0.0..250.0), rng.random_range(0.0..250.0));
        let Some(ray) = traced.ray(pixel) else { continue };
        let b = ray.direction;
        // mirror = body_from_mirror^T · body (the matrix is written row by row).
        let m = dvec3(
            body_from_mirror[0] * b.x + body_from_mirror[3] * b.y + body_from_mirror[6] * b.z,
            body_from_mirror[1] * b.x + body_from_mirror[4] * b.y + body_from_mirror[7] * b.z,
            body_from_mirror[2] * b.x + body_from_mirror[5] * b.y + body_from_mirror[8] * b.z,
        );
        let model = dvec3(m.x, m.y, -m.z);
        let denominator = model.z + xi * model.length();
        let projected = dvec2(k[0] * model.x / denominator + k[2], k[4] * model.y / denominator + k[5]);
        assert!(
            (projected - pixel).length() < 0.01,
            "omnidir calibration off by {}",
            (projected - pixel).length()
        );
        // Kalibr: T_cam_imu takes the body direction (F' is the body origin) to its frame.
        let x = kalibr_camera(b);
        let denominator = x.z + kalibr[0] * x.length();
        let projected = dvec2(
            kalibr[1] * x.x / denominator + kalibr[3],
            kalibr[2] * x.y / denominator + kalibr[4],
        );
        let flipped = dvec2(pixel.x, last_row - pixel.y);
        assert!(
            (projected - flipped).length() < 0.01,
            "Kalibr omni off by {}",
            (projected - flipped).length()
        );
        checked += 1;
    }
    // Pinhole: K and body_from_camera (row by row) reproduce its projection; Kalibr agrees.
    let pinhole = Pinhole {
        fx: 300.0,
        fy: 310.0,
        cx: 150.2,
        cy: 99.7,
        ..Pinhole::with_horizontal_fov(320, 200, 1.0)
    };
    let opencv = calibration::opencv_pinhole(&pinhole);
    let (k, r) = (
        yaml_matrix(&opencv, "camera_matrix"),
        yaml_matrix(&opencv, "body_from_camera"),
    );
    let kalibr_text = calibration::kalibr_pinhole(&pinhole);
    assert_eq!(kalibr_intrinsics(&kalibr_text), vec![k[0], k[4], k[2], k[5]]);
    let kalibr_camera = kalibr_camera_from_body(&kalibr_text);
    for _ in 0..200 {
        let body = dvec3(
            rng.random_range(0.5..5.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-1.0..1.0),
        );
        // optical = body_from_camera^T · body.
        let optical = dvec3(
            r[0] * body.x + r[3] * body.y + r[6] * body.z,
            r[1] * body.x + r[4] * body.y + r[7] * body.z,
            r[2] * body.x + r[5] * body.y + r[8] * body.z,
        );
        let projected = dvec2(k[0] * optical.x / optical.z + k[2], k[4] * optical.y / optical.z + k[5]);
        assert!((pinhole.project(body).unwrap() - projected).length() < 1e-9);
        assert!((kalibr_camera(body) - optical).length() < 1e-12, "Kalibr T_cam_imu");
    }
    // Stereo: X_right = X_left + T, both projected with their camera matrices.
    let rig = StereoRig::rectified(Pinhole::with_horizontal_fov(400, 300, 70f64.to_radians()), 0.2);
    let stereo = calibration::opencv_stereo(&rig);
    let (m2, t) = (yaml_matrix(&stereo, "M2"), yaml_matrix(&stereo, "T"));
    let [left, right] = rig.pinholes();
    // The stereo file places the left camera as the pinhole file does; Kalibr places both.
    let pinhole_file = calibration::opencv_pinhole(&left);
    for name in ["body_from_camera", "camera_position_in_body"] {
        assert_eq!(yaml_matrix(&stereo, name), yaml_matrix(&pinhole_file, name), "{name}");
    }
    let kalibr = calibration::kalibr_stereo(&rig).expect("Kalibr has the pinhole");
    let right_from_body = kalibr_camera_from_body(&kalibr[kalibr.find("cam1:").unwrap()..]);
    for _ in 0..200 {
        let body = dvec3(
            rng.random_range(1.0..5.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-1.0..1.0),
        );
        let Some(in_left) = left.project(body) else { continue };
        let optical_left =
            dvec3((in_left.x - left.cx) / left.fx, (in_left.y - left.cy) / left.fy, 1.0) * (body - left.position).x;
        let optical_right = optical_left + dvec3(t[0], t[1], t[2]);
        let expected = dvec2(
            m2[0] * optical_right.x / optical_right.z + m2[2],
            m2[4] * optical_right.y / optical_right.z + m2[5],
        );
        assert!((right.project(body).unwrap() - expected).length() < 1e-9);
        assert!(
            (right_from_body(body) - optical_right).length() < 1e-9,
            "Kalibr cam1 T_cam_imu"
        );
    }
}

#[test]
fn ray_map_rebuilds_the_points_of_a_non_central_camera() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let camera = Camera::Catadioptric(Catadioptric::spherical(160, 160, 0.05, 0.25));
    assert!(!camera.is_central());
    let pose = Pose::from_degrees(dvec3(-0.5, 0.2, 0.7), dvec3(0.0, 0.0, 45.0));
    let frame = trace::trace(&bvh, &camera, &pose);
    let dir = tempfile::tempdir().unwrap();
    let [origin_path, direction_path, all_path] = output::ray_map_names("").map(|name| dir.path().join(name));
    let paths = [&origin_path, &direction_path, &all_path].map(std::path::PathBuf::as_path);
    output::write_ray_map_exrs(&mut output::store::Synced, paths, &camera).unwrap();
    let (origin, quantity) = common::read_xyz_exr(&origin_path);
    assert_eq!(quantity, "ray origin");
    let (direction, quantity) = common::read_xyz_exr(&direction_path);
    assert_eq!(quantity, "ray direction");
    // The six-channel file holds the same values, bit for bit, under the names OpenEXR-based
    // tools read (origin.X ... direction.Z).
    let all = common::read_exr(&all_path);
    let channels = &all.layer_data[0].channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(
        names,
        [
            "direction.X",
            "direction.Y",
            "direction.Z",
            "origin.X",
            "origin.Y",
            "origin.Z"
        ]
    );
    for (k, (channel, split)) in channels.iter().zip(direction.iter().chain(&origin)).enumerate() {
        let stored: Vec<u32> = channel.sample_data.values_as_f32().map(f32::to_bits).collect();
        let expected: Vec<u32> = split.iter().map(|value| value.to_bits()).collect();
        assert_eq!(stored, expected, "channel {k} of raymap-all.exr");
    }
    let rotation = pose.world_from_body_rotation();
    let mut rebuilt = 0;
    for (i, pixel) in frame.pixels().iter().enumerate() {
        if !pixel.is_hit() {
            assert!(origin[0][i].is_nan() || camera.ray(dvec2((i % 160) as f64, (i / 160) as f64)).is_some());
            continue;
        }
        let o = dvec3(
            f64::from(origin[0][i]),
            f64::from(origin[1][i]),
            f64::from(origin[2][i]),
        );
        let d = dvec3(
            f64::from(direction[0][i]),
            f64::from(direction[1][i]),
            f64::from(direction[2][i]),
        );
        assert!((d.length() - 1.0).abs() < 1e-6, "direction {d} is not unit");
        let point = pose.position + rotation * (o + f64::from(pixel.range) * d);
        assert!(
            point.distance(pixel.point) < 1e-5 * (1.0 + f64::from(pixel.range)),
            "{point} vs {}",
            pixel.point
        );
        rebuilt += 1;
    }
    assert!(rebuilt > 15_000);
}
