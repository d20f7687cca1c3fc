//! Textured faces: texels where the closed form puts them, no aliasing where a pixel covers
//! many texels, footprints that match neighbouring pixels' rays for every camera model, and
//! the GPU's filtering against the CPU's.

mod common;

use std::path::Path;

use glam::{DVec2, DVec3, dvec3};
use omnisim::advanced::{self, CpuTracer, Footprint, SceneBvh};
use omnisim::camera::{Cylindrical, Equirectangular, Pinhole};
use omnisim::scene::lighting::{linear_to_srgb, srgb_to_linear};
use omnisim::{Camera, Plane, Planes, Pose, Scene};

/// A 4×3 texture of distinct colours (sRGB), row by row.
const TEXELS: [[u8; 3]; 12] = [
    [255, 0, 0],
    [0, 255, 0],
    [0, 0, 255],
    [255, 255, 0],
    [0, 255, 255],
    [255, 0, 255],
    [40, 40, 40],
    [230, 230, 230],
    [128, 64, 0],
    [0, 64, 128],
    [64, 128, 0],
    [200, 100, 50],
];

/// Writes the 4×3 texture as a PNG in `folder`.
fn write_texture(folder: &Path) {
    let bytes: Vec<u8> = TEXELS.iter().flatten().copied().collect();
    let image = image_rgb(4, 3, &bytes);
    std::fs::write(folder.join("tiles.png"), image).unwrap();
}

/// A PNG of RGB8 pixels, written with the png crate (not omnisim's writer).
fn image_rgb(width: u32, height: u32, bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().unwrap().write_image_data(bytes).unwrap();
    out
}

/// The bilinear texel of the 4×3 texture at (u, v) with clamped edges, in linear light: the
/// textbook definition (texel centres at (i + ½) / size), written out here independently.
fn bilinear_closed_form(u: f64, v: f64) -> DVec3 {
    let texel = |x: i64, y: i64| {
        let c = TEXELS[(y.clamp(0, 2) * 4 + x.clamp(0, 3)) as usize];
        DVec3::new(srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]))
    };
    let (x, y) = (u * 4.0 - 0.5, v * 3.0 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let top = texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx;
    let bottom = texel(i, j + 1) * (1.0 - fx) + texel(i + 1, j + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// A 2 m × 1.5 m square at x = 2 facing the origin, the 4×3 texture stretched over it once
/// (scale (2, 1.5), its top-left corner at y = 1, z = 0.75), clamped.
fn textured_square(folder: &Path) -> Scene {
    write_texture(folder);
    let text = r#"Scene(name: "square", objects: [
        Polygon(name: "square", vertices: [(2.0, 1.0, 0.75), (2.0, 1.0, -0.75), (2.0, -1.0, -0.75), (2.0, -1.0, 0.75)],
                colour: (255, 255, 255),
                texture: (image: "tiles.png", scale: (2.0, 1.5), offset: (-1.0, -0.75), wrap: Clamp)),
    ])"#;
    Scene::from_ron(text, &folder.join("square.ron")).unwrap()
}

/// (u, v) of the square's texture where `ray` from the origin meets x = 2: u runs along −y
/// from y = 1, v along −z from z = 0.75 (the face's right and down axes seen from the origin).
fn closed_form_uv(direction: DVec3) -> DVec2 {
    let point = direction * (2.0 / direction.x);
    DVec2::new((1.0 - point.y) / 2.0, (0.75 - point.z) / 1.5)
}

fn check_texels_exact(tracer: &common::Tracer) {
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(120, 90, 60f64.to_radians()));
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    let frame = tracer.render(&camera, &pose).unwrap();
    let colour = frame.colour().unwrap();
    let mut checked = 0;
    for v in 0..90 {
        for u in 0..120 {
            let index = frame.index(u, v);
            if !frame.pixels()[index].is_hit() {
                continue;
            }
            let ray = camera.ray(DVec2::new(f64::from(u), f64::from(v))).unwrap();
            let uv = closed_form_uv(ray.direction);
            let expected = bilinear_closed_form(uv.x, uv.y).to_array().map(linear_to_srgb);
            for k in 0..3 {
                assert!(
                    colour[index][k].abs_diff(expected[k]) <= 1,
                    "pixel ({u}, {v}) uv {uv}: {:?} vs closed form {expected:?}",
                    colour[index]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 5000, "{checked} pixels see the square");
}

#[test]
fn magnified_texels_are_the_bilinear_texel_at_the_closed_form_uv_on_the_cpu() {
    let folder = tempfile::tempdir().unwrap();
    let scene = textured_square(folder.path());
    check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene)));
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn magnified_texels_are_the_bilinear_texel_at_the_closed_form_uv_on_the_gpu() {
    let folder = tempfile::tempdir().unwrap();
    let scene = textured_square(folder.path());
    check_texels_exact(&common::gpu_tracer(&scene, &SceneBvh::build(&scene)));
}

/// A 200 m floor with a 5 mm black-and-white checker, seen at grazing angles by a pinhole
/// 1 m above it.
fn fine_checker() -> (Scene, Camera, Pose) {
    let text = r#"Scene(name: "checker", objects: [
        Floor(name: "floor", corners: [(-100.0, -100.0), (100.0, -100.0), (100.0, 100.0), (-100.0, 100.0)], z: -1.0,
              colour: (255, 255, 255),
              texture: (pattern: Checker(colours: ((0, 0, 0), (255, 255, 255)), squares: 8), texels: 64, scale: (0.04, 0.04))),
    ])"#;
    let scene = Scene::from_ron(text, Path::new("checker.ron")).unwrap();
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(160, 120, 60f64.to_radians()));
    // Looking 2° down: the floor from about 1.7 m (bottom row) to the horizon.
    let pose = Pose::from_degrees(DVec3::ZERO, dvec3(0.0, 2.0, 0.0));
    (scene, camera, pose)
}

/// Largest relative deviation of an 8×8-pixel region's mean linear colour from the checker's
/// mean (0.5), over regions wholly on the floor, with `shade` giving each hit's colour.
fn worst_region(frame: &omnisim::Frame, shade: impl Fn(usize) -> f64) -> f64 {
    let mut worst: f64 = 0.0;
    for by in 0..frame.height / 8 {
        for bx in 0..frame.width / 8 {
            let indices: Vec<usize> = (0..64).map(|k| frame.index(bx * 8 + k % 8, by * 8 + k / 8)).collect();
            if !indices.iter().all(|&i| frame.pixels()[i].is_hit()) {
                continue;
            }
            let mean = indices.iter().map(|&i| shade(i)).sum::<f64>() / 64.0;
            worst = worst.max((mean - 0.5).abs() / 0.5);
        }
    }
    worst
}

#[test]
fn a_fine_checker_at_grazing_angles_averages_to_grey_and_point_sampling_would_alias() {
    let (scene, camera, pose) = fine_checker();
    let bvh = SceneBvh::build(&scene);
    let tracer = common::cpu_tracer(&scene, &bvh);
    let frame = tracer
        .render_planes(&camera, &pose, Planes::COLOUR.with(Plane::LinearColour))
        .unwrap();
    let linear = frame.linear_colour().unwrap();
    let filtered = worst_region(&frame, |i| f64::from(linear[i][0]));
    assert!(
        filtered < 0.02,
        "filtered: a region's mean is {:.1} % off the checker's",
        filtered * 100.0
    );
    // The same hits shaded at the finest level (point sampling): moiré.
    let appearance = tracer.scene.appearance();
    let point = |i: usize| {
        advanced::shade(
            CpuTracer::Reference,
            &bvh,
            appearance,
            &frame.pixels()[i],
            &Footprint::POINT,
        )
        .x
    };
    let aliased = worst_region(&frame, point);
    assert!(
        aliased > 0.1,
        "point sampling should alias, yet its worst region is {:.1} % off",
        aliased * 100.0
    );
}

/// Where a body-frame ray of `camera` at `pose` meets the plane through `on` with `normal`.
fn meet(camera: &Camera, pose: &Pose, pixel: DVec2, on: DVec3, normal: DVec3) -> Option<DVec3> {
    let ray = camera.ray(pixel)?;
    let rotation = pose.world_from_body_rotation();
    let (origin, direction) = (pose.position + rotation * ray.origin, rotation * ray.direction);
    let t = (on - origin).dot(normal) / direction.dot(normal);
    (t > ray.t_min && t.is_finite()).then(|| origin + t * direction)
}

#[test]
fn footprints_equal_the_spacing_of_neighbouring_pixels_rays_for_every_camera_model() {
    let mut cameras = common::cameras();
    cameras.push(Camera::Equirectangular(Equirectangular {
        width: 360,
        height: 180,
    }));
    cameras.push(Camera::Cylindrical(Cylindrical::with_vertical_fov(
        360,
        90,
        90f64.to_radians(),
    )));
    // A floor 0.8 m below and a wall 2 m ahead: the known planes.
    let planes = [(dvec3(0.0, 0.0, -0.8), DVec3::Z), (dvec3(2.0, 0.0, 0.0), DVec3::X)];
    let pose = Pose::from_degrees(dvec3(0.1, -0.2, 0.05), dvec3(0.0, 0.0, 10.0));
    for camera in &cameras {
        let (width, height) = camera.size();
        let mut compared = 0;
        for v in (1..height - 1).step_by(7) {
            for u in (1..width - 1).step_by(7) {
                let pixel = DVec2::new(f64::from(u), f64::from(v));
                for (on, normal) in planes {
                    let Some(point) = meet(camera, &pose, pixel, on, normal) else {
                        continue;
                    };
                    let sides = Footprint::of_pixel(camera, &pose, pixel).on_plane(point, normal);
                    for (axis, step) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
                        let (Some(ahead), Some(behind)) = (
                            meet(camera, &pose, pixel + step, on, normal),
                            meet(camera, &pose, pixel - step, on, normal),
                        ) else {
                            continue;
                        };
                        // The central difference of the neighbours' hits; the footprint is a
                        // one-sided difference, so where the two sides differ by more than 5 %
                        // (grazing views, the panoramas' poles) neither is a footprint.
                        let spacing = (ahead - behind) / 2.0;
                        if (ahead - point).length() > 1.05 * (point - behind).length()
                            || (point - behind).length() > 1.05 * (ahead - point).length()
                            || spacing.length() > 0.5
                        {
                            continue;
                        }
                        // The footprint's width along this image axis.
                        let error = (sides[axis].length() - spacing.length()).abs() / spacing.length();
                        assert!(
                            error <= 0.05,
                            "{}: pixel {pixel} axis {axis}: footprint {} vs neighbours {} ({:.1} %)",
                            common::describe(camera),
                            sides[axis],
                            spacing,
                            error * 100.0
                        );
                        compared += 1;
                    }
                }
            }
        }
        assert!(
            compared > 100,
            "{}: only {compared} footprints compared",
            common::describe(camera)
        );
    }
}
