//! Textured faces: texels where the closed form puts them, no aliasing where a pixel covers
//! many texels, footprints that match neighbouring pixels' rays for every camera model, and
//! the GPU's filtering against the CPU's.

mod common;

use std::path::Path;

use glam::{DVec2, DVec3, dvec3};
use omnisim::advanced::{self, CpuTracer, Footprint, SceneBvh};
use omnisim::camera::{Cylindrical, Equirectangular, FisheyeSpec, LensSpec, Pinhole, RigSpec};
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

/// The bilinear texel of the 4×3 texture at (u, v) with clamped (or repeated) edges, in linear
/// light: the textbook definition (texel centres at (i + ½) / size), written out here
/// independently.
fn bilinear_closed_form(u: f64, v: f64, repeat: bool) -> DVec3 {
    let texel = |x: i64, y: i64| {
        let (x, y) = if repeat {
            (x.rem_euclid(4), y.rem_euclid(3))
        } else {
            (x.clamp(0, 3), y.clamp(0, 2))
        };
        let c = TEXELS[(y * 4 + x) as usize];
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

fn check_texels_exact(tracer: &common::Tracer, repeat: bool) {
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(120, 90, 60f64.to_radians()));
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    let frame = tracer.render(&camera, &pose).unwrap();
    let hits: Vec<bool> = frame.pixels().iter().map(omnisim::advanced::Pixel::is_hit).collect();
    check_closed_form(&camera, frame.colour().unwrap(), &hits, |direction| {
        let uv = closed_form_uv(direction);
        bilinear_closed_form(uv.x, uv.y, repeat).to_array().map(linear_to_srgb)
    });
}

/// Asserts that every hit pixel of `camera`'s colour frame `colour` is within 1/255 of
/// `expected` of its ray's direction, and that more than 5000 pixels were checked.
fn check_closed_form(camera: &Camera, colour: &[[u8; 3]], hits: &[bool], expected: impl Fn(DVec3) -> [u8; 3]) {
    let (width, height) = camera.size();
    let mut checked = 0;
    for v in 0..height {
        for u in 0..width {
            let index = (v * width + u) as usize;
            if !hits[index] {
                continue;
            }
            let direction = camera.ray(DVec2::new(f64::from(u), f64::from(v))).unwrap().direction;
            let expected = expected(direction);
            for k in 0..3 {
                assert!(
                    colour[index][k].abs_diff(expected[k]) <= 1,
                    "pixel ({u}, {v}): {:?} vs closed form {expected:?}",
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
    check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn magnified_texels_are_the_bilinear_texel_at_the_closed_form_uv_on_the_gpu() {
    let folder = tempfile::tempdir().unwrap();
    let scene = textured_square(folder.path());
    check_texels_exact(&common::gpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
}

/// The square of `textured_square` as a mesh file of `format` (written by this test), its
/// texture coordinates v up as OBJ and PLY have them.
fn square_mesh(folder: &Path, format: &str) -> Scene {
    write_texture(folder);
    let corners = ["2 1 0.75", "2 1 -0.75", "2 -1 -0.75", "2 -1 0.75"];
    let uvs = ["0 1", "0 0", "1 0", "1 1"];
    let file = if format == "obj" {
        std::fs::write(folder.join("square.mtl"), "newmtl tiles\nKd 1 1 1\nmap_Kd tiles.png\n").unwrap();
        let mut text = String::from("mtllib square.mtl\nusemtl tiles\n");
        corners.iter().for_each(|c| text += &format!("v {c}\n"));
        uvs.iter().for_each(|uv| text += &format!("vt {uv}\n"));
        text += "f 1/1 2/2 3/3 4/4\n";
        std::fs::write(folder.join("square.obj"), text).unwrap();
        "square.obj"
    } else {
        let mut text = String::from(
            "ply\nformat ascii 1.0\ncomment TextureFile tiles.png\nelement vertex 4\nproperty float x\n\
                 property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n\
                 property list uchar float texcoord\nend_header\n",
        );
        corners.iter().for_each(|c| text += &format!("{c}\n"));
        text += &format!("3 0 1 2 6 {} {} {}\n", uvs[0], uvs[1], uvs[2]);
        text += &format!("3 0 2 3 6 {} {} {}\n", uvs[0], uvs[2], uvs[3]);
        std::fs::write(folder.join("square.ply"), text).unwrap();
        "square.ply"
    };
    let text = format!(r#"Scene(name: "mesh", objects: [Mesh(name: "square", path: "{file}", colour: (9, 9, 9))])"#);
    Scene::from_ron(&text, &folder.join("mesh.ron")).unwrap()
}

#[test]
fn obj_with_mtl_and_ply_with_texcoords_map_their_textures_exactly() {
    for format in ["obj", "ply"] {
        let folder = tempfile::tempdir().unwrap();
        let scene = square_mesh(folder.path(), format);
        assert_eq!(scene.faces.len(), 2, "{format}");
        check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), true);
    }
}

/// Triangles a mesh is made into faces at a time (`MESH_CHUNK` in omnisim's scene/build.rs).
const MESH_CHUNK: usize = 1 << 15;

/// A PLY strip of two chunks and a part of triangles, with zero-area triangles in each chunk
/// (first and last of a chunk among them), textured triangles and, in the second chunk, plain
/// ones among them (which make the chunk take the one-by-one path): the scene's faces and
/// surfaces are the closed form's, as one list of the whole mesh would give them.
#[test]
fn a_mesh_of_several_chunks_keeps_its_faces_and_surfaces_in_order_and_drops_the_flat_ones() {
    let triangles = 2 * MESH_CHUNK + 4000;
    let flat = [
        3,
        MESH_CHUNK - 1,
        MESH_CHUNK,
        40_001,
        50_000,
        2 * MESH_CHUNK + 17,
        triangles - 1,
    ];
    // The second chunk's every fifth triangle is plain, its last one (65,535) among them, so
    // the third chunk's surfaces follow a face without one.
    let textured = |t: usize| t / MESH_CHUNK != 1 || !t.is_multiple_of(5);
    // Triangle t: (t, 0, 0), (t + 1, 0, 0), (t, 1, 0), u = t + x and v = y (v up); a flat one
    // has its third corner at (t + 2, 0, 0). Vertex 2i is (i, 0, 0), 2i + 1 is (i, 1, 0).
    let folder = tempfile::tempdir().unwrap();
    write_texture(folder.path());
    let vertices = 2 * (triangles + 2);
    let mut text = format!(
        "ply\nformat ascii 1.0\ncomment TextureFile tiles.png\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nelement face {triangles}\nproperty list uchar int vertex_indices\n\
         property list uchar float texcoord\nend_header\n"
    );
    for i in 0..vertices / 2 {
        text += &format!("{i} 0 0\n{i} 1 0\n");
    }
    for t in 0..triangles {
        let third = if flat.contains(&t) { 2 * t + 4 } else { 2 * t + 1 };
        text += &format!("3 {} {} {third} ", 2 * t, 2 * t + 2);
        text += &if textured(t) {
            format!("6 {t} 0 {} 0 {t} 1\n", t + 1)
        } else {
            "0\n".to_string()
        };
    }
    std::fs::write(folder.path().join("strip.ply"), text).unwrap();
    let scene = Scene::from_ron(
        r#"Scene(name: "strip", objects: [Mesh(name: "strip", path: "strip.ply", colour: (9, 9, 9))])"#,
        &folder.path().join("strip.ron"),
    )
    .unwrap();

    let kept: Vec<usize> = (0..triangles).filter(|t| !flat.contains(t)).collect();
    assert_eq!(
        scene.warnings,
        vec![format!("mesh 'strip': dropped {} degenerate triangles", flat.len())]
    );
    assert_eq!(scene.faces.len(), kept.len());
    let surfaces = &scene.surfaces;
    assert_eq!(surfaces.list().len(), kept.iter().filter(|&&t| textured(t)).count());
    assert!(surfaces.of_face().len() <= scene.faces.len());
    for (k, (&t, face)) in kept.iter().zip(&scene.faces).enumerate() {
        let x = t as f64;
        assert_eq!(
            face.vertices.as_slice(),
            [dvec3(x, 0.0, 0.0), dvec3(x + 1.0, 0.0, 0.0), dvec3(x, 1.0, 0.0)],
            "face {k} is triangle {t}"
        );
        let surface = surfaces.of(k as u32);
        if textured(t) {
            // A textured triangle without a colour shows its texture untinted.
            assert_eq!(face.colour, [255; 3], "face {k}");
            let surface = surface.unwrap_or_else(|| panic!("face {k} (triangle {t}) has no surface"));
            let uv = surface.uv.as_ref().unwrap();
            assert_eq!(surface.anchor, dvec3(x, 0.0, 0.0), "face {k}");
            assert_eq!(
                (uv.texture, uv.at_anchor, uv.gradient),
                (0, DVec2::new(x, 1.0), [DVec3::X, -DVec3::Y]),
                "face {k} (triangle {t})"
            );
        } else {
            assert_eq!(face.colour, [9; 3], "face {k}");
            assert!(surface.is_none(), "face {k} (plain triangle {t}) has a surface");
        }
    }
}

#[test]
fn ply_vertex_colours_are_interpolated_across_each_triangle() {
    let folder = tempfile::tempdir().unwrap();
    let corners = [dvec3(2.0, 1.0, -0.75), dvec3(2.0, -1.0, -0.75), dvec3(2.0, 0.0, 0.75)];
    let colours = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255]];
    let mut text = String::from(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n",
    );
    for (p, c) in corners.iter().zip(colours) {
        text += &format!("{} {} {} {} {} {}\n", p.x, p.y, p.z, c[0], c[1], c[2]);
    }
    text += "3 0 1 2\n";
    std::fs::write(folder.path().join("fan.ply"), text).unwrap();
    check_fan_colours(folder.path(), corners, colours);
}

/// The triangle whose `corners` have vertex `colours`, read from `fan.ply` in `folder` and
/// seen from the origin: every pixel's colour is the barycentric mix of the corners' colours
/// in linear light at its hit point, within 1/255.
fn check_fan_colours(folder: &Path, corners: [DVec3; 3], colours: [[u8; 3]; 3]) {
    let scene = Scene::from_ron(
        r#"Scene(name: "fan", objects: [Mesh(name: "fan", path: "fan.ply", colour: (9, 9, 9))])"#,
        &folder.join("fan.ron"),
    )
    .unwrap();
    assert_eq!(scene.faces.len(), 1);
    let tracer = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap());
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(64, 48, 60f64.to_radians()));
    let frame = tracer.render(&camera, &Pose::new(DVec3::ZERO, DVec3::ZERO)).unwrap();
    let mut checked = 0;
    for (i, hit) in frame.pixels().iter().enumerate() {
        if !hit.is_hit() {
            continue;
        }
        // Barycentric weights of the hit point (the triangle lies in x = 2).
        let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).x;
        let total = area(corners[0], corners[1], corners[2]);
        let w = [
            area(hit.point, corners[1], corners[2]) / total,
            area(corners[0], hit.point, corners[2]) / total,
            area(corners[0], corners[1], hit.point) / total,
        ];
        let expected = (0..3).fold(DVec3::ZERO, |sum, k| {
            sum + w[k] * DVec3::from_array(colours[k].map(srgb_to_linear))
        });
        let expected = expected.to_array().map(linear_to_srgb);
        let got = frame.colour().unwrap()[i];
        assert!(
            (0..3).all(|k| got[k].abs_diff(expected[k]) <= 1),
            "pixel {i}: {got:?} vs {expected:?}"
        );
        checked += 1;
    }
    assert!(checked > 300, "{checked}");
}

/// The error loading a scene whose mesh `name` holds `text` (and the 4×3 texture beside it).
fn mesh_error(name: &str, text: impl AsRef<[u8]>, extra: &[(&str, &str)]) -> String {
    let folder = tempfile::tempdir().unwrap();
    write_texture(folder.path());
    std::fs::write(folder.path().join(name), text).unwrap();
    for (file, content) in extra {
        std::fs::write(folder.path().join(file), content).unwrap();
    }
    let scene = format!(r#"Scene(name: "bad", objects: [Mesh(name: "bad", path: "{name}", colour: (9, 9, 9))])"#);
    Scene::from_ron(&scene, &folder.path().join("bad.ron"))
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_textured_meshes_get_located_errors() {
    let ply = |comment: &str, face: &str| {
        format!(
            "ply\nformat ascii 1.0\n{comment}element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n{face}\n"
        )
    };
    // A binary PLY triangle whose second corner's u is NaN (ASCII PLY has no NaN).
    let mut binary = b"ply\nformat binary_little_endian 1.0\ncomment TextureFile tiles.png\nelement vertex 3\n\
        property float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
        property list uchar float texcoord\nend_header\n"
        .to_vec();
    for value in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        binary.extend(value.to_le_bytes());
    }
    binary.push(3);
    for index in [0i32, 1, 2] {
        binary.extend(index.to_le_bytes());
    }
    binary.push(6);
    for value in [0.0f32, 0.0, f32::NAN, 0.0, 0.0, 1.0] {
        binary.extend(value.to_le_bytes());
    }
    let cases = [
        (
            "missing texture",
            mesh_error(
                "a.ply",
                ply("comment TextureFile gone.png\n", "3 0 1 2 6 0 0 1 0 0 1"),
                &[],
            ),
            "gone.png: file not found",
        ),
        (
            "NaN UV",
            mesh_error("a.ply", &binary, &[]),
            "face 0: texture coordinate (NaN, 0) is not finite",
        ),
        (
            "index out of range",
            mesh_error(
                "a.ply",
                ply("comment TextureFile tiles.png\n", "3 0 1 7 6 0 0 1 0 0 1"),
                &[],
            ),
            "face 0 refers to vertex 7",
        ),
        (
            "texture outside",
            mesh_error(
                "a.ply",
                ply("comment TextureFile ../tiles.png\n", "3 0 1 2 6 0 0 1 0 0 1"),
                &[],
            ),
            "must be relative",
        ),
        (
            "mtllib outside",
            mesh_error("a.obj", "mtllib ../x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &[]),
            "mtllib path '../x.mtl' must be relative",
        ),
        (
            "missing mtllib",
            mesh_error("a.obj", "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &[]),
            "x.mtl",
        ),
        (
            // Empty files read no bytes: the count of files bounds what a long line makes.
            "mtllib of many empty files",
            mesh_error(
                "a.obj",
                format!(
                    "mtllib {}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                    vec!["e.mtl"; 65].join(" ")
                ),
                &[("e.mtl", "")],
            ),
            "give more than 64 MTL file names",
        ),
        (
            "mtllib list escaping the folder",
            mesh_error(
                "a.obj",
                "mtllib m.mtl ../x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                &[("m.mtl", "")],
            ),
            "mtllib path '../x.mtl' must be relative",
        ),
        (
            "missing map_Kd",
            mesh_error(
                "a.obj",
                "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n",
                &[("m.mtl", "newmtl a\nmap_Kd nope.jpg\n")],
            ),
            "nope.jpg: file not found",
        ),
        (
            "obj face index past the vertices",
            mesh_error("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n", &[]),
            "a.obj: line 5: face index 9 names no vertex: the file has 3 vertices (`v` lines); OBJ indices count \
             from 1",
        ),
        (
            "obj face index past the texture coordinates",
            mesh_error("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/5 3/1\n", &[]),
            "line 5: face index 5 names no texture coordinate: the file has 1 texture coordinates (`vt` lines)",
        ),
        (
            // tobj's index arithmetic overflows on these (a panic where overflow checks are on:
            // the workspace turns them off for tobj, Cargo.toml).
            "obj relative face index before the first texture coordinate",
            mesh_error("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-9 2/1 3/1\n", &[]),
            "line 5: face index -9 names no texture coordinate: the file has 1 texture coordinates (`vt` lines) \
             before this face",
        ),
        (
            "obj face normal index of 19 digits",
            mesh_error(
                "a.obj",
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//9223372036854775807 2//1 3//1\n",
                &[],
            ),
            "line 5: face index 9223372036854775807 names no normal: the file has 1 normals (`vn` lines);",
        ),
        (
            // tobj reads an object's faces against the vertices before the object ends.
            "obj face index of a vertex of a later object",
            mesh_error(
                "a.obj",
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\no next\nv 0 0 1\nf 1 2 3\n",
                &[],
            ),
            "line 4: face index 4 names no vertex: the file has 3 vertices (`v` lines) before this face",
        ),
        (
            "obj NaN UV",
            mesh_error(
                "a.obj",
                "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt nan 0\nf 1/1 2/1 3/1\n",
                &[("m.mtl", "newmtl a\nmap_Kd tiles.png\n")],
            ),
            "not finite",
        ),
    ];
    for (what, error, expected) in cases {
        assert!(error.contains(expected) && error.contains("bad.ron"), "{what}: {error}");
    }
}

/// An OBJ whose first `mtllib` line names two MTL files (the format's list of names) and whose
/// second names a third: each face takes the `Kd` of its material from whichever file defines
/// it. MTL files that together pass the 16 MiB cap on an OBJ's MTL bytes (each within it) are
/// refused, naming the file that passes it.
#[test]
fn every_file_of_every_mtllib_line_is_read_within_one_budget() {
    let folder = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(folder.path().join(name), text).unwrap();
    write("a.mtl", "newmtl red\nKd 1 0 0\n");
    write("b.mtl", "newmtl green\nKd 0 1 0\n");
    write("c d.mtl", "newmtl blue\nKd 0 0 1\n");
    let mut obj = String::from("mtllib a.mtl b.mtl\nmtllib c d.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for material in ["red", "green", "blue"] {
        obj += &format!("usemtl {material}\nf 1 2 3\n");
    }
    write("a.obj", &obj);
    let load = || {
        Scene::from_ron(
            r#"Scene(name: "mtl", objects: [Mesh(name: "m", path: "a.obj", colour: (9, 9, 9))])"#,
            &folder.path().join("mtl.ron"),
        )
    };
    let scene = load().unwrap();
    let colours: Vec<[u8; 3]> = scene.faces.iter().map(|face| face.colour).collect();
    assert_eq!(colours, [[255, 0, 0], [0, 255, 0], [0, 0, 255]]);
    // Two files of 9 MiB each (comments): each within the cap, together past it.
    let comments = format!(
        "newmtl red\nKd 1 0 0\n{}",
        "# padding padding padding padding\n".repeat(9 << 15)
    );
    write("a.mtl", &comments);
    write("b.mtl", &comments.replace("red", "green"));
    let error = load().map(|_| ()).unwrap_err().to_string();
    assert!(
        error.contains("b.mtl: the OBJ's MTL files hold more than 16777216 bytes together"),
        "{error}"
    );
}

/// The start of a PNG whose header claims `side` × `side` RGB texels: its header and the first
/// bytes of its data, no more (it cannot be decoded; a reader that tried would fail).
fn png_start(side: u32) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, side, side);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer.write_chunk(png::chunk::IDAT, &[0x78, 0x01]).unwrap();
    drop(writer);
    out
}

/// Three textures of 16384² texels each (the most one texture may have) are more than a scene
/// may hold (2^29 texels): the third is refused from its header, naming its file, its texels
/// and the cap, located in the scene file, before any of the three is decoded (decoding them
/// would fail: their data is cut short).
#[test]
fn textures_past_the_scene_cap_are_refused_from_their_headers() {
    let folder = tempfile::tempdir().unwrap();
    let mut mtl = String::new();
    let mut obj = String::from("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n");
    for i in 0..3 {
        std::fs::write(folder.path().join(format!("big{i}.png")), png_start(16_384)).unwrap();
        mtl += &format!("newmtl m{i}\nmap_Kd big{i}.png\n");
        obj += &format!("usemtl m{i}\nf 1/1 2/1 3/1\n");
    }
    std::fs::write(folder.path().join("m.mtl"), mtl).unwrap();
    std::fs::write(folder.path().join("a.obj"), obj).unwrap();
    let scene = "Scene(name: \"big\", objects: [\n  Mesh(name: \"scan\", path: \"a.obj\", colour: (9, 9, 9))])";
    let error = Scene::from_ron(scene, &folder.path().join("big.ron"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("big.ron:2:")
            && error.contains("big2.png: its 268435456 texels would bring the scene's textures to 805306368 texels")
            && error.contains("more than omnisim loads (536870912 texels"),
        "{error}"
    );
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
    let bvh = SceneBvh::build(&scene).unwrap();
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

/// The world origin and direction of `camera`'s ray at `pixel` at `pose`.
fn world_ray(camera: &Camera, pose: &Pose, pixel: DVec2) -> Option<(DVec3, DVec3, f64)> {
    let ray = camera.ray(pixel)?;
    let rotation = pose.world_from_body_rotation();
    Some((
        pose.position + rotation * ray.origin,
        rotation * ray.direction,
        ray.t_min,
    ))
}

/// Where a body-frame ray of `camera` at `pose` meets the plane through `on` with `normal`.
fn meet(camera: &Camera, pose: &Pose, pixel: DVec2, on: DVec3, normal: DVec3) -> Option<DVec3> {
    let (origin, direction, t_min) = world_ray(camera, pose, pixel)?;
    let t = (on - origin).dot(normal) / direction.dot(normal);
    (t > t_min && t.is_finite()).then(|| origin + t * direction)
}

/// The finite-difference footprint of `pixel` on the plane through `point` with `normal`:
/// per image axis, half the distance between the neighbours' rays (behind and ahead) where
/// they meet it; `None` for an axis where the two one-sided differences differ by more than
/// 5 % (grazing views, the panoramas' poles: neither is then a footprint) or the spacing
/// exceeds 0.5 m.
fn neighbour_spacing(camera: &Camera, pose: &Pose, pixel: DVec2, point: DVec3, normal: DVec3) -> [Option<f64>; 2] {
    [DVec2::X, DVec2::Y].map(|step| {
        let ahead = meet(camera, pose, pixel + step, point, normal)?;
        let behind = meet(camera, pose, pixel - step, point, normal)?;
        let (forward, backward) = ((ahead - point).length(), (point - behind).length());
        let spacing = (ahead - behind).length() / 2.0;
        (forward <= 1.05 * backward && backward <= 1.05 * forward && spacing <= 0.5).then_some(spacing)
    })
}

#[test]
fn ray_cone_footprints_equal_the_spacing_of_neighbouring_pixels_rays_for_every_camera_model() {
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
        let (mut across, mut slanted) = (0, 0);
        for v in (1..height - 1).step_by(7) {
            for u in (1..width - 1).step_by(7) {
                let pixel = DVec2::new(f64::from(u), f64::from(v));
                let footprint = Footprint::of_pixel(camera, &pose, pixel);
                for (on, normal) in planes {
                    let Some(point) = meet(camera, &pose, pixel, on, normal) else {
                        continue;
                    };
                    let (origin, direction, _) = world_ray(camera, &pose, pixel).unwrap();
                    let range = (point - origin).length() as f32;
                    let describe = |what: &str| format!("{}: pixel {pixel}, {what}", common::describe(camera));
                    // On the plane across the ray the cone's width is the longer spacing of the
                    // neighbours' rays (exact to first order for every camera model).
                    let width = f64::from(footprint.width(range));
                    if let [Some(x), Some(y)] = neighbour_spacing(camera, &pose, pixel, point, direction) {
                        let longer = x.max(y);
                        let error = (width - longer).abs() / longer;
                        assert!(
                            error <= 0.05,
                            "{}",
                            describe(&format!(
                                "cone width {width} vs neighbours {longer} ({:.1} %)",
                                error * 100.0
                            ))
                        );
                        across += 1;
                    }
                    // On the known, slanted plane the neighbours' longer spacing lies between the
                    // width and the cone's longer axis there, width / |cos θ|.
                    let longer_axis = f64::from(footprint.longer_axis(range, normal.as_vec3()));
                    let cosine = direction.dot(normal).abs();
                    assert!(
                        (longer_axis * cosine - width).abs() <= 1e-5 * width,
                        "{}",
                        describe("longer axis")
                    );
                    if let [Some(x), Some(y)] = neighbour_spacing(camera, &pose, pixel, point, normal) {
                        let longer = x.max(y);
                        assert!(
                            0.95 * width <= longer && longer <= 1.05 * longer_axis,
                            "{}",
                            describe(&format!("neighbours {longer} outside [{width}, {longer_axis}]"))
                        );
                        slanted += 1;
                    }
                }
            }
        }
        assert!(
            across > 100 && slanted > 100,
            "{}: only {across} and {slanted} footprints compared",
            common::describe(camera)
        );
    }
}

#[test]
#[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
fn the_gpu_filters_the_textured_room_as_the_cpu_does() {
    let scene = common::load("env1-textured.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let (cpu, gpu) = (common::cpu_tracer(&scene, &bvh), common::gpu_tracer(&scene, &bvh));
    let pose = Pose::from_degrees(dvec3(1.0, 0.0, 0.4), dvec3(0.0, 0.0, 200.0));
    for camera in [
        Camera::Catadioptric(common::paper_omni()),
        Camera::Pinhole(Pinhole::with_horizontal_fov(320, 240, 70f64.to_radians())),
        Camera::Equirectangular(Equirectangular {
            width: 512,
            height: 256,
        }),
        // A lens camera: the GPU's footprints read the neighbours' rays from its ray table.
        Camera::Lens(Box::new(common::lens_camera(&RigSpec::Fisheye(FisheyeSpec {
            size: (320, 320),
            lens: LensSpec::Equidistant,
            fov: Some(200.0),
            focal: None,
        })))),
    ]
    .into_iter()
    // Lens cameras one pixel wide and one high: no neighbour inside the image across, on
    // either backend (the GPU reads only its ray table).
    .chain([(1, 96), (96, 1)].map(|size| {
        Camera::Lens(Box::new(common::lens_camera(&RigSpec::Fisheye(FisheyeSpec {
            size,
            lens: LensSpec::Equidistant,
            fov: None,
            // Every pixel of the line inside the lens's field (48 px off centre: 69°).
            focal: Some(40.0),
        }))))
    }))
    // Every mirror of the shared list: non-central ones (misaligned, spherical, parabolic),
    // whose cones have a width at the origin, and one seen through an inner lens, whose rays
    // the GPU reads from the ray table.
    .chain(
        common::cameras()
            .into_iter()
            .filter(|camera| matches!(camera, Camera::Catadioptric(_))),
    ) {
        let planes = Planes::COLOUR.with(Plane::LinearColour);
        let (a, b) = (
            cpu.render_planes(&camera, &pose, planes).unwrap(),
            gpu.render_planes(&camera, &pose, planes).unwrap(),
        );
        let (la, lb) = (a.linear_colour().unwrap(), b.linear_colour().unwrap());
        let (mut compared, mut worst) = (0usize, 0f32);
        for i in 0..a.pixels().len() {
            if a.pixels()[i].face != b.pixels()[i].face || !a.pixels()[i].is_hit() {
                continue;
            }
            compared += 1;
            let difference = (0..3).map(|k| (la[i][k] - lb[i][k]).abs()).fold(0.0, f32::max);
            worst = worst.max(difference);
        }
        // f32 hit points move a texture coordinate by ~1e-6 of a repeat and the level of detail
        // by as little (measured on lavapipe: at most 2e-5 in linear light).
        assert!(
            compared > a.pixels().len() / 2 && worst <= 1e-3,
            "{}: worst linear difference {worst} over {compared} pixels",
            common::describe(&camera)
        );
    }
}

/// The textured square as a GLB: the square lies in its node's xy plane, placed at x = 2
/// facing the origin by a parent node (scale 2, translation) and a child (rotation, scale ½);
/// the 4×3 texture is embedded, clamped. `uv` maps each local (u, v) to what the file
/// stores, and `extension` is added to the texture info (`KHR_texture_transform` tests).
fn square_glb(uv: impl Fn(DVec2) -> DVec2, extension: Option<serde_json::Value>, mode: u32) -> Vec<u8> {
    square_glb_drawn(uv, extension, mode, &[0, 1, 2, 0, 2, 3])
}

/// [`square_glb`] drawn as primitive `mode` through the corner `indices` (corners 0–3: top
/// left, bottom left, bottom right, top right as the origin sees them).
fn square_glb_drawn(
    uv: impl Fn(DVec2) -> DVec2,
    extension: Option<serde_json::Value>,
    mode: u32,
    indices: &[u16],
) -> Vec<u8> {
    let corners = [
        [-1.0f32, 0.75, 0.0],
        [-1.0, -0.75, 0.0],
        [1.0, -0.75, 0.0],
        [1.0, 0.75, 0.0],
    ];
    let uvs = [
        DVec2::new(0.0, 0.0),
        DVec2::new(0.0, 1.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(1.0, 0.0),
    ]
    .map(uv);
    let mut bin: Vec<u8> = corners.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    bin.extend(
        uvs.iter()
            .flat_map(|uv| [uv.x as f32, uv.y as f32])
            .flat_map(f32::to_le_bytes),
    );
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    bin.resize(bin.len().div_ceil(4) * 4, 0);
    let png_at = bin.len();
    let png = image_rgb(4, 3, &TEXELS.iter().flatten().copied().collect::<Vec<u8>>());
    bin.extend(&png);
    // Local x → world −y, y → z, z → −x (a proper rotation).
    let rotation = glam::DQuat::from_mat3(&glam::DMat3::from_cols(-DVec3::Y, DVec3::Z, -DVec3::X));
    let mut info = serde_json::json!({"index": 0});
    if let Some(extension) = extension {
        info["extensions"] = serde_json::json!({ "KHR_texture_transform": extension });
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"children": [1], "translation": [2.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0]},
            {"mesh": 0, "rotation": [rotation.x, rotation.y, rotation.z, rotation.w], "scale": [0.5, 0.5, 0.5]}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0, "mode": mode}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": info}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33071}],
        "images": [{"bufferView": 3, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1.0, -0.75, 0.0], "max": [1.0, 0.75, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 2 * indices.len()},
            {"buffer": 0, "byteOffset": png_at, "byteLength": png.len()}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    common::glb(&json, &bin)
}

/// The GLB `glb` with its JSON changed by `edit` (its binary chunk kept).
fn with_json(glb: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    with_json_and_bytes(glb, &[], |json, _| edit(json))
}

/// The GLB `glb` with `extra` bytes appended to its binary chunk (at a 4-byte boundary, the
/// offset `edit` is given) and its JSON changed by `edit`.
fn with_json_and_bytes(glb: &[u8], extra: &[u8], edit: impl FnOnce(&mut serde_json::Value, usize)) -> Vec<u8> {
    let json_end = 20 + u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&glb[20..json_end]).unwrap();
    let mut bin = glb[json_end + 8..].to_vec();
    bin.resize(bin.len().div_ceil(4) * 4, 0);
    let at = bin.len();
    bin.extend(extra);
    json["buffers"][0]["byteLength"] = bin.len().into();
    edit(&mut json, at);
    common::glb(&json, &bin)
}

/// Appends `views` (byte offset, length and stride, if any) to `json`'s buffer views and an
/// accessor over each (`accessors`: the rest of its fields), returning the first new
/// accessor's index.
fn add_accessors(
    json: &mut serde_json::Value,
    views: &[(usize, usize, Option<usize>)],
    accessors: &[serde_json::Value],
) -> usize {
    let first_view = json["bufferViews"].as_array().unwrap().len();
    let first = json["accessors"].as_array().unwrap().len();
    for (k, ((offset, length, stride), accessor)) in views.iter().zip(accessors).enumerate() {
        let mut view = serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
        if let Some(stride) = stride {
            view["byteStride"] = (*stride).into();
        }
        json["bufferViews"].as_array_mut().unwrap().push(view);
        let mut accessor = accessor.clone();
        accessor["bufferView"] = (first_view + k).into();
        json["accessors"].as_array_mut().unwrap().push(accessor);
    }
    first
}

/// The faces of `scene` face the origin (their normals along −x), as the square's do.
fn assert_facing_the_origin(scene: &Scene) {
    for face in &scene.faces {
        let v = &face.vertices;
        let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        assert!(
            (normal - dvec3(-1.0, 0.0, 0.0)).length() < 1e-9,
            "face {v:?} faces {normal}, not the origin"
        );
    }
}

fn load_glb(bytes: &[u8]) -> Result<Scene, omnisim::SceneError> {
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("square.glb"), bytes).unwrap();
    Scene::from_ron(
        r#"Scene(name: "glb", objects: [Mesh(name: "square", path: "square.glb", colour: (9, 9, 9))])"#,
        &folder.path().join("glb.ron"),
    )
}

#[test]
fn a_glb_square_through_its_node_hierarchy_maps_its_embedded_texture_exactly() {
    let scene = load_glb(&square_glb(|uv| uv, None, 4)).unwrap();
    assert_eq!(scene.faces.len(), 2);
    check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
}

/// The square as a triangle list, a strip and a fan: the same two faces, textured exactly, all
/// wound as the list is (their normals face the origin). glTF 2.0 (3.7.2.1) flips a strip's
/// odd triangles (pᵢ = {vᵢ, vᵢ₊₁₊ᵢ﹪₂, vᵢ₊₂₋ᵢ﹪₂}) and turns a fan around its first vertex
/// (pᵢ = {vᵢ₊₁, vᵢ₊₂, v₀}); a strip read without the flip, or a fan wound the other way,
/// faces away.
#[test]
fn a_glb_square_as_a_strip_and_as_a_fan_is_the_triangle_lists_faces_wound_alike() {
    for (mode, indices) in [
        (4, &[0u16, 1, 2, 0, 2, 3][..]),
        (5, &[1, 2, 0, 3][..]),
        (6, &[0, 1, 2, 3][..]),
    ] {
        let scene = load_glb(&square_glb_drawn(|uv| uv, None, mode, indices)).unwrap();
        assert_eq!(scene.faces.len(), 2, "mode {mode}");
        assert_facing_the_origin(&scene);
        check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
    }
}

/// The square's node mirrored (scale −½ along its x: a negative determinant) winds the file's
/// triangles clockwise as the origin sees them, which glTF 2.0 (3.7.2.1) then makes their front:
/// the faces still face the origin, and the texture is seen mirrored, each pixel the bilinear
/// texel at (1 − u, v). Read without the turn, the faces face away.
#[test]
fn a_mirroring_node_keeps_its_faces_front_and_shows_its_texture_mirrored() {
    let glb = with_json(&square_glb(|uv| uv, None, 4), |json| {
        json["nodes"][1]["scale"] = serde_json::json!([-0.5, 0.5, 0.5]);
    });
    let scene = load_glb(&glb).unwrap();
    assert_eq!(scene.faces.len(), 2);
    assert_facing_the_origin(&scene);
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(120, 90, 60f64.to_radians()));
    let frame = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap())
        .render(&camera, &Pose::new(DVec3::ZERO, DVec3::ZERO))
        .unwrap();
    let hits: Vec<bool> = frame.pixels().iter().map(omnisim::advanced::Pixel::is_hit).collect();
    check_closed_form(&camera, frame.colour().unwrap(), &hits, |direction| {
        let uv = closed_form_uv(direction);
        bilinear_closed_form(1.0 - uv.x, uv.y, false)
            .to_array()
            .map(linear_to_srgb)
    });
}

/// `EXT_mesh_gpu_instancing` on the square's node: three instances (TRANSLATION and SCALE in
/// f32, ROTATION in normalized i16), each applied after the node's own transform, as a child
/// node of that TRS would be: the faces are the closed form's parent · node · instance · corner,
/// both triangles of each instance. A SCALE of fewer instances is refused naming each accessor.
#[test]
fn gpu_instances_are_placed_after_their_nodes_transform() {
    let translations = [[0.0f32, 0.0, 0.0], [0.0, 0.0, -3.0], [1.0, 2.0, -6.0]];
    let scales = [[1.0f32; 3], [0.5; 3], [1.0, 2.0, 1.0]];
    // The identity twice, then a quarter turn about z: (0, 0, sin 45°, cos 45°), quantized.
    let half = (0.5f64.sqrt() * 32767.0).round() as i16;
    let rotations = [[0i16, 0, 0, 32767], [0, 0, 0, 32767], [0, 0, half, half]];
    let mut extra: Vec<u8> = translations.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    extra.extend(scales.iter().flatten().flat_map(|v| v.to_le_bytes()));
    extra.extend(rotations.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let instanced = |scale_count: usize| {
        with_json_and_bytes(&square_glb(|uv| uv, None, 4), &extra, |json, at| {
            let vec3 = |count: usize| serde_json::json!({"componentType": 5126, "count": count, "type": "VEC3"});
            let rotation = serde_json::json!({"componentType": 5122, "normalized": true, "count": 3, "type": "VEC4"});
            let first = add_accessors(
                json,
                &[(at, 36, None), (at + 36, 36, None), (at + 72, 24, None)],
                &[vec3(3), vec3(scale_count), rotation],
            );
            json["nodes"][1]["extensions"] = serde_json::json!({"EXT_mesh_gpu_instancing": {"attributes":
                {"TRANSLATION": first, "SCALE": first + 1, "ROTATION": first + 2}}});
            json["extensionsUsed"] = serde_json::json!(["KHR_texture_transform", "EXT_mesh_gpu_instancing"]);
        })
    };
    let scene = load_glb(&instanced(3)).unwrap();
    // The nodes of `square_glb`, by hand: parent (translation, scale 2) and child (rotation,
    // scale ½).
    let parent = glam::DMat4::from_translation(dvec3(2.0, 0.0, 0.0)) * glam::DMat4::from_scale(DVec3::splat(2.0));
    let turn = glam::DQuat::from_mat3(&glam::DMat3::from_cols(-DVec3::Y, DVec3::Z, -DVec3::X));
    let node = glam::DMat4::from_quat(turn) * glam::DMat4::from_scale(DVec3::splat(0.5));
    let corners = [
        dvec3(-1.0, 0.75, 0.0),
        dvec3(-1.0, -0.75, 0.0),
        dvec3(1.0, -0.75, 0.0),
        dvec3(1.0, 0.75, 0.0),
    ];
    let instances = [
        glam::DQuat::IDENTITY,
        glam::DQuat::IDENTITY,
        glam::DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
    ];
    assert_eq!(scene.faces.len(), 6);
    for (i, rotation) in instances.into_iter().enumerate() {
        let instance = glam::DMat4::from_scale_rotation_translation(
            DVec3::from_array(scales[i].map(f64::from)),
            rotation,
            DVec3::from_array(translations[i].map(f64::from)),
        );
        for triangle in [[0, 1, 2], [0, 2, 3]] {
            let expected = triangle.map(|c| (parent * node * instance).transform_point3(corners[c]));
            assert!(
                scene
                    .faces
                    .iter()
                    .any(|face| same_triangle(&face.vertices, &expected, 1e-6).is_some()),
                "instance {i}: {expected:?} is not a face"
            );
        }
    }
    let error = load_glb(&instanced(2)).map(|_| ()).unwrap_err().to_string();
    assert!(
        error.contains(
            "node 1 (EXT_mesh_gpu_instancing): its TRANSLATION, ROTATION and SCALE counts differ (accessor 3 \
             (TRANSLATION) 3, accessor 5 (ROTATION) 3, accessor 4 (SCALE) 2)"
        ),
        "{error}"
    );
}

/// `KHR_mesh_quantization`: the square's positions as i16 integers (four times the floats',
/// the node scaled by ¼ more; six bytes an element, 8 apart) and its texture coordinates as
/// normalized u16 (65535 is 1): texel-exact, as the float file is.
#[test]
fn a_quantized_square_maps_its_texture_exactly() {
    let mut extra = Vec::new();
    for [x, y] in [[-4i16, 3], [-4, -3], [4, -3], [4, 3]] {
        extra.extend([x, y, 0, 0].iter().flat_map(|v| v.to_le_bytes()));
    }
    for [u, v] in [[0u16, 0], [0, 65535], [65535, 65535], [65535, 0]] {
        extra.extend([u, v].iter().flat_map(|v| v.to_le_bytes()));
    }
    let glb = with_json_and_bytes(&square_glb(|uv| uv, None, 4), &extra, |json, at| {
        let first = add_accessors(
            json,
            &[(at, 32, Some(8)), (at + 32, 16, None)],
            &[
                serde_json::json!({"componentType": 5122, "count": 4, "type": "VEC3", "min": [-4, -3, 0], "max": [4, 3, 0]}),
                serde_json::json!({"componentType": 5123, "normalized": true, "count": 4, "type": "VEC2"}),
            ],
        );
        json["meshes"][0]["primitives"][0]["attributes"] =
            serde_json::json!({"POSITION": first, "TEXCOORD_0": first + 1});
        json["nodes"][1]["scale"] = serde_json::json!([0.125, 0.125, 0.125]);
        json["extensionsUsed"] = serde_json::json!(["KHR_texture_transform", "KHR_mesh_quantization"]);
        json["extensionsRequired"] = serde_json::json!(["KHR_mesh_quantization"]);
    });
    let scene = load_glb(&glb).unwrap();
    assert_eq!(scene.faces.len(), 2);
    check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
}

/// [`square_glb`] with a `KHR_texture_transform` on its texture info and, in the file, the
/// inverse of the extension's formula (offset + R(rotation)·(scale ⊙ uv)) applied to its
/// coordinates: read right, its texels land where the plain square's do.
fn transformed_square_glb() -> Vec<u8> {
    let (offset, rotation, scale) = (DVec2::new(0.1, -0.2), 0.3f64, DVec2::new(1.5, 0.75));
    let inverse = |t: DVec2| {
        let (sin, cos) = rotation.sin_cos();
        let r = t - offset;
        DVec2::new(cos * r.x + sin * r.y, -sin * r.x + cos * r.y) / scale
    };
    let transform =
        serde_json::json!({"offset": [offset.x, offset.y], "rotation": rotation, "scale": [scale.x, scale.y]});
    square_glb(inverse, Some(transform), 4)
}

#[test]
fn khr_texture_transform_equals_the_coordinates_it_stands_for() {
    let plain = load_glb(&square_glb(|uv| uv, None, 4)).unwrap();
    let transformed = load_glb(&transformed_square_glb()).unwrap();
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(120, 90, 60f64.to_radians()));
    let pose = Pose::new(DVec3::ZERO, DVec3::ZERO);
    let render = |scene: &Scene| {
        let tracer = common::cpu_tracer(scene, &SceneBvh::build(scene).unwrap());
        tracer.render(&camera, &pose).unwrap().colour().unwrap().to_vec()
    };
    let (a, b) = (render(&plain), render(&transformed));
    let worst = a
        .iter()
        .zip(&b)
        .flat_map(|(x, y)| (0..3).map(move |k| x[k].abs_diff(y[k])))
        .max()
        .unwrap();
    assert!(worst <= 1, "largest difference {worst}/255");
}

/// `KHR_materials_pbrSpecularGlossiness` (older Sketchfab and 3ds Max exports): its diffuse
/// texture, through its `KHR_texture_transform`, and its diffuse factor are the base colour,
/// not the metallic-roughness fallback beside them (red, untextured: read instead, the texels
/// and colours below differ).
#[test]
fn specular_glossiness_diffuse_texture_and_factor_are_the_base_colour() {
    let specular_glossiness = |glb: Vec<u8>, factor: [f64; 4], textured: bool| {
        with_json(&glb, |json| {
            let info = json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].take();
            let mut diffuse = serde_json::json!({"diffuseFactor": factor});
            if textured {
                diffuse["diffuseTexture"] = info;
            }
            json["materials"][0] = serde_json::json!({
                "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.0, 0.0, 1.0]},
                "extensions": {"KHR_materials_pbrSpecularGlossiness": diffuse}
            });
            json["extensionsUsed"] =
                serde_json::json!(["KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness"]);
        })
    };
    for glb in [square_glb(|uv| uv, None, 4), transformed_square_glb()] {
        let scene = load_glb(&specular_glossiness(glb, [1.0; 4], true)).unwrap();
        check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
    }
    let scene = load_glb(&specular_glossiness(
        square_glb(|uv| uv, None, 4),
        [0.2, 0.4, 0.6, 1.0],
        false,
    ))
    .unwrap();
    assert_eq!(scene.faces.len(), 2);
    for (k, face) in scene.faces.iter().enumerate() {
        assert_eq!(face.colour, [0.2, 0.4, 0.6].map(linear_to_srgb));
        assert!(scene.surfaces.of(k as u32).is_none_or(|surface| surface.uv.is_none()));
    }
}

/// Three one-primitive meshes whose primitives share one `TEXCOORD_0` accessor (read once for
/// each `KHR_texture_transform`): the first and second also share their POSITION accessor and
/// differ in their materials' transforms; the third has positions of its own and the first's
/// material. Each node lifts its mesh by its index in z. Every face's texture coordinates at
/// its corners are its own material's transform of the file's.
#[test]
fn primitives_sharing_texture_coordinates_under_different_transforms_each_get_their_own() {
    let corners = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let uvs = [[0.0f32, 0.0], [0.5, 0.0], [0.5, 0.25], [0.0, 0.25]];
    // The third mesh's own positions: the square stretched twice along x.
    let stretched = corners.map(|[x, y, z]| [2.0 * x, y, z]);
    let mut bin: Vec<u8> = corners.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    bin.extend(uvs.iter().flatten().flat_map(|v| v.to_le_bytes()));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let stretched_at = bin.len();
    bin.extend(stretched.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let png_at = bin.len();
    let png = image_rgb(4, 3, &TEXELS.iter().flatten().copied().collect::<Vec<u8>>());
    bin.extend(&png);
    let transforms = [
        serde_json::json!({"offset": [0.25, -0.5], "scale": [2.0, 4.0]}),
        serde_json::json!({"offset": [0.1, 0.2], "rotation": 0.7, "scale": [0.5, 3.0]}),
    ];
    let material = |transform: &serde_json::Value| {
        serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture":
            {"index": 0, "extensions": {"KHR_texture_transform": transform}}}})
    };
    let primitive = |position: u32, material: u32| {
        serde_json::json!({"primitives": [{"attributes": {"POSITION": position, "TEXCOORD_0": 1},
            "indices": 2, "material": material}]})
    };
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": (0..3).map(|m| serde_json::json!({"mesh": m, "translation": [0.0, 0.0, f64::from(m)]}))
            .collect::<Vec<_>>(),
        "meshes": [primitive(0, 0), primitive(0, 1), primitive(3, 0)],
        "materials": transforms.iter().map(material).collect::<Vec<_>>(),
        "textures": [{"source": 0}],
        "images": [{"bufferView": 4, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [2.0, 1.0, 0.0]}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12},
            {"buffer": 0, "byteOffset": stretched_at, "byteLength": 48},
            {"buffer": 0, "byteOffset": png_at, "byteLength": png.len()}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    let scene = load_glb(&common::glb(&json, &bin)).unwrap();
    assert_eq!(scene.faces.len(), 6);
    // offset + R(rotation)·(scale ⊙ uv), the extension's formula, written out here (its
    // numbers are read as f32).
    let transformed = |transform: &serde_json::Value, uv: [f32; 2]| {
        let number = |v: &serde_json::Value| f64::from(v.as_f64().unwrap() as f32);
        let rotation = transform.get("rotation").map_or(0.0, number);
        let (sin, cos) = rotation.sin_cos();
        let s = DVec2::new(f64::from(uv[0]), f64::from(uv[1]))
            * DVec2::new(number(&transform["scale"][0]), number(&transform["scale"][1]));
        DVec2::new(number(&transform["offset"][0]), number(&transform["offset"][1]))
            + DVec2::new(cos * s.x - sin * s.y, sin * s.x + cos * s.y)
    };
    let mut meshes_seen = [0; 3];
    for (k, face) in scene.faces.iter().enumerate() {
        let mesh = face.vertices[0].z as usize;
        meshes_seen[mesh] += 1;
        let (positions, transform) = match mesh {
            0 => (corners, &transforms[0]),
            1 => (corners, &transforms[1]),
            _ => (stretched, &transforms[0]),
        };
        let surface = scene.surfaces.of(k as u32).unwrap();
        let map = surface.uv.as_ref().unwrap();
        for vertex in &face.vertices {
            let corner = positions
                .iter()
                .position(|p| DVec3::from_array(p.map(f64::from)) + dvec3(0.0, 0.0, mesh as f64) == *vertex)
                .unwrap();
            let (got, expected) = (
                omnisim::scene::surface::Surface::uv_at(map, surface.anchor, *vertex),
                transformed(transform, uvs[corner]),
            );
            assert!(
                (got - expected).length() < 1e-9,
                "mesh {mesh} corner {corner}: uv {got}, its transform gives {expected}"
            );
        }
    }
    assert_eq!(meshes_seen, [2; 3]);
}

#[test]
fn bad_gltf_files_get_located_errors_without_panicking() {
    let good = square_glb(|uv| uv, None, 4);
    let error = |bytes: &[u8]| load_glb(bytes).map(|_| ()).unwrap_err().to_string();
    let truncated = error(&good[..good.len() - 300]);
    assert!(
        truncated.contains("square.glb") && truncated.contains("glb.ron"),
        "{truncated}"
    );
    assert!(
        error(&good[..40]).contains("not a readable glTF"),
        "{}",
        error(&good[..40])
    );
    let lines = error(&square_glb(|uv| uv, None, 1));
    assert!(
        lines.contains("mesh 0 primitive 0") && lines.contains("triangle primitives only"),
        "{lines}"
    );
    let nan = error(&square_glb(
        |uv| if uv.x > 0.5 { DVec2::new(f64::NAN, uv.y) } else { uv },
        None,
        4,
    ));
    assert!(
        nan.contains("mesh 0 primitive 0: accessor 1 (TEXCOORD_0) vertex 2: texture coordinate")
            && nan.contains("not finite"),
        "{nan}"
    );
    // Index 7 of 4 vertices, and a required extension omnisim lacks.
    let mut bytes = good.clone();
    let at = bytes
        .windows(12)
        .position(|w| w == [0, 0, 1, 0, 2, 0, 0, 0, 2, 0, 3, 0])
        .unwrap();
    bytes[at + 2] = 7;
    let out_of_range = error(&bytes);
    assert!(
        out_of_range.contains(
            "mesh 0 primitive 0: accessor 2 (indices): index 7 is out of range of accessor 0 (POSITION)'s 4 vertices"
        ),
        "{out_of_range}"
    );
    let edited = |edit: &dyn Fn(&mut serde_json::Value)| error(&with_json(&good, edit));
    let draco = edited(&|json| {
        json["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
        json["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    });
    assert!(draco.contains("KHR_draco_mesh_compression"), "{draco}");
    // Each refusal of a primitive names the mesh, the primitive and the accessor or material
    // at fault.
    type Edit<'a> = &'a dyn Fn(&mut serde_json::Value);
    let cases: [(Edit, &str); 4] = [
        (
            &|json| json["accessors"][1]["count"] = 3.into(),
            "mesh 0 primitive 0: accessor 1 (TEXCOORD_0) has 3 entries, fewer than accessor 0 (POSITION)'s 4 vertices",
        ),
        (
            &|json| {
                let colours = serde_json::json!({"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"});
                json["accessors"].as_array_mut().unwrap().push(colours);
                json["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = 3.into();
            },
            "mesh 0 primitive 0: accessor 3 (COLOR_0) has 3 entries, fewer than accessor 0 (POSITION)'s 4 vertices",
        ),
        (
            &|json| json["accessors"][2]["count"] = 5.into(),
            "mesh 0 primitive 0: accessor 2 (indices): 5 indices is not a whole number of triangles",
        ),
        (
            &|json| json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1.into(),
            "mesh 0 primitive 0: material 0's base colour texture reads TEXCOORD_1, which the primitive does not have",
        ),
    ];
    for (edit, expected) in cases {
        let message = edited(edit);
        assert!(message.contains(expected), "{message}");
    }
}

/// 51 meshes that share one index accessor of a million triangles' corners (3 MB of the
/// file), each one primitive of `mode` (4: triangles, 0: points).
fn shared_indices_glb(mode: u32) -> Vec<u8> {
    let corners = 3_000_000usize;
    let bin = triangle_then_zeros(corners);
    let mut json = meshes_one_per_node(
        (0..51)
            .map(|_| serde_json::json!({"attributes": {"POSITION": 0}, "indices": 1, "mode": mode}))
            .collect(),
    );
    json["accessors"] = serde_json::json!([
        {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
         "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
        {"bufferView": 1, "componentType": 5121, "count": corners, "type": "SCALAR"},
    ]);
    json["bufferViews"] = serde_json::json!([
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": corners},
    ]);
    json["buffers"] = serde_json::json!([{"byteLength": bin.len()}]);
    common::glb(&json, &bin)
}

/// A buffer of one triangle's f32 corners (0, 0, 0), (1, 0, 0), (0, 1, 0), then `zeros` bytes.
fn triangle_then_zeros(zeros: usize) -> Vec<u8> {
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    bin.resize(36 + zeros, 0);
    bin
}

/// A glTF document (no buffers yet) of one mesh for each of `primitives`, each placed by a
/// root node of the default scene.
fn meshes_one_per_node(primitives: Vec<serde_json::Value>) -> serde_json::Value {
    serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..primitives.len()).collect::<Vec<_>>()}],
        "nodes": (0..primitives.len()).map(|m| serde_json::json!({"mesh": m})).collect::<Vec<_>>(),
        "meshes": primitives.into_iter().map(|p| serde_json::json!({"primitives": [p]})).collect::<Vec<_>>(),
    })
}

/// The meshes of [`shared_indices_glb`] are more than a mesh may hold (50 M triangles):
/// refused from the accessors' counts, at the placement that passes the cap, before any
/// primitive is read (reading them all would take about 8 GB).
#[test]
fn a_gltf_whose_placements_pass_the_triangle_cap_is_refused_before_reading() {
    let error = load_glb(&shared_indices_glb(4)).map(|_| ()).unwrap_err().to_string();
    // The walk pops nodes from a stack: the last node's mesh is placed first.
    assert!(
        error.contains("square.glb")
            && error.contains("glb.ron")
            && error.contains("mesh 0 primitive 0 (accessor 1, 3000000 corners): more than 50000000 triangles"),
        "{error}"
    );
}

/// Points are refused as points, not counted as triangles against the cap first.
#[test]
fn a_gltf_of_points_past_the_triangle_cap_is_refused_for_its_points() {
    let error = load_glb(&shared_indices_glb(0)).map(|_| ()).unwrap_err().to_string();
    assert!(
        error.contains("primitive 0: its mode is Points; omnisim reads triangle primitives only"),
        "{error}"
    );
}

/// One mesh (a triangle) placed by two nodes under one parent (translation and scale), one
/// translated, the other rotated a quarter turn about z and scaled by ½: both copies are in
/// the scene at their world corners (by hand: 2·(p + (0, 0, 1)) + (1, 0, 0), and R·p + (1, 0,
/// 0)), each a face of its own, and both of the mesh file's one object (README: a mesh file is
/// one object, each of its triangles a face).
#[test]
fn a_gltf_mesh_placed_by_two_nodes_is_in_the_scene_twice_as_one_object() {
    let corners = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let bin: Vec<u8> = corners.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"children": [1, 2], "translation": [1.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0]},
            {"mesh": 0, "translation": [0.0, 0.0, 1.0]},
            {"mesh": 0, "rotation": [0.0, 0.0, half, half], "scale": [0.5, 0.5, 0.5]}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
        "buffers": [{"byteLength": bin.len()}]
    });
    let scene = load_glb(&common::glb(&json, &bin)).unwrap();
    let translated = [dvec3(1.0, 0.0, 2.0), dvec3(3.0, 0.0, 2.0), dvec3(1.0, 2.0, 2.0)];
    let rotated = [dvec3(1.0, 0.0, 0.0), dvec3(1.0, 1.0, 0.0), dvec3(0.0, 0.0, 0.0)];
    assert_eq!(scene.faces.len(), 2);
    assert_eq!(scene.objects.len(), 1);
    let mut found = [false; 2];
    for face in &scene.faces {
        assert_eq!(face.object, 0);
        for (k, expected) in [translated, rotated].iter().enumerate() {
            // The file's rotation is an f32 quaternion: within 1e-6.
            let near = face.vertices.iter().zip(expected).all(|(a, b)| a.distance(*b) < 1e-6);
            found[k] |= near;
        }
    }
    assert_eq!(found, [true, true], "{:?}", scene.faces);
}

/// A glTF of 3,000 small primitives (24 triangles each, 72,000 in all: three of the loader's
/// chunks of 32,768, cut inside primitives) in 120 meshes placed by nodes under three group
/// nodes (translated, one scaled by 2): textured and plain materials alternate, and every
/// seventh primitive has a triangle without area. Every face is checked in order against the
/// closed form, the hierarchy walked depth first and a node's last child first (as the loader
/// walks it): corners, colour, texture coordinates at the corners, no surface on plain faces,
/// object 0, and the dropped count.
#[test]
fn a_gltf_of_thousands_of_primitives_under_a_node_hierarchy_is_read_face_by_face() {
    const GROUPS: usize = 3;
    const NODES: usize = 40; // meshes per group
    const PRIMITIVES: usize = 25; // per mesh
    const TRIANGLES: usize = 24; // per primitive
    // A strip of quads a quarter metre wide along x, primitive p at y = p.
    let local = |p: usize, vertex: u16| {
        DVec3::new(
            f64::from(vertex / 2) * 0.25,
            p as f64 + f64::from(vertex % 2) * 0.25,
            0.0,
        )
    };
    let triangle = |primitive: usize, t: usize| -> [u16; 3] {
        let a = (t / 2 * 2) as u16;
        match (t % 2, t == 5 && primitive.is_multiple_of(7)) {
            (_, true) => [a, a + 3, a + 3],
            (0, false) => [a, a + 2, a + 3],
            _ => [a, a + 3, a + 1],
        }
    };
    let vertices = (TRIANGLES / 2 + 1) * 2;
    let mut bin = Vec::new();
    let (mut views, mut accessors, mut meshes) = (Vec::new(), Vec::new(), Vec::new());
    let mut add = |bytes: Vec<u8>, component: u32, kind: &str, count: usize, bounds: Option<[[f64; 3]; 2]>| {
        views.push(serde_json::json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        bin.resize(bin.len().div_ceil(4) * 4, 0);
        let mut accessor = serde_json::json!({"bufferView": views.len() - 1, "componentType": component, "count": count, "type": kind});
        if let Some([min, max]) = bounds {
            accessor["min"] = serde_json::json!(min);
            accessor["max"] = serde_json::json!(max);
        }
        accessors.push(accessor);
        accessors.len() - 1
    };
    for mesh in 0..GROUPS * NODES {
        let primitives: Vec<serde_json::Value> = (0..PRIMITIVES)
            .map(|p| {
                let corners: Vec<DVec3> = (0..vertices as u16).map(|v| local(p, v)).collect();
                let position = add(
                    corners
                        .iter()
                        .flat_map(|c| c.to_array().map(|x| x as f32))
                        .flat_map(f32::to_le_bytes)
                        .collect(),
                    5126,
                    "VEC3",
                    vertices,
                    Some([
                        [0.0, p as f64, 0.0],
                        [(TRIANGLES / 2) as f64 * 0.25, p as f64 + 0.25, 0.0],
                    ]),
                );
                let uv = add(
                    corners
                        .iter()
                        .flat_map(|c| [c.x as f32, c.y as f32])
                        .flat_map(f32::to_le_bytes)
                        .collect(),
                    5126,
                    "VEC2",
                    vertices,
                    None,
                );
                let primitive = mesh * PRIMITIVES + p;
                let indices: Vec<u8> = (0..TRIANGLES)
                    .flat_map(|t| triangle(primitive, t))
                    .flat_map(u16::to_le_bytes)
                    .collect();
                let indices = add(indices, 5123, "SCALAR", TRIANGLES * 3, None);
                serde_json::json!({"attributes": {"POSITION": position, "TEXCOORD_0": uv}, "indices": indices,
                    "material": primitive % 3})
            })
            .collect();
        meshes.push(serde_json::json!({ "primitives": primitives }));
    }
    let png_at = bin.len();
    let png = image_rgb(4, 3, &TEXELS.iter().flatten().copied().collect::<Vec<u8>>());
    bin.extend(&png);
    views.push(serde_json::json!({"buffer": 0, "byteOffset": png_at, "byteLength": png.len()}));
    // Nodes 0.. place the meshes, a group node holds its NODES, the root the groups.
    let group_translation = |g: usize| DVec3::new(100.0 * g as f64, 0.0, 0.0);
    let group_scale = |g: usize| if g == 1 { 2.0 } else { 1.0 };
    let node_translation = |k: usize| DVec3::new(0.0, 0.0, 3.0 * k as f64);
    let mut nodes: Vec<serde_json::Value> = (0..GROUPS * NODES)
        .map(|m| serde_json::json!({"mesh": m, "translation": node_translation(m % NODES).to_array()}))
        .collect();
    for g in 0..GROUPS {
        let scale = [group_scale(g); 3];
        nodes.push(
            serde_json::json!({"children": (g * NODES..(g + 1) * NODES).collect::<Vec<_>>(),
            "translation": group_translation(g).to_array(), "scale": scale}),
        );
    }
    nodes.push(serde_json::json!({"children": (GROUPS * NODES..GROUPS * NODES + GROUPS).collect::<Vec<_>>()}));
    let textured = |factor: [f64; 4]| serde_json::json!({"pbrMetallicRoughness": {"baseColorFactor": factor, "baseColorTexture": {"index": 0}}});
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [nodes.len() - 1]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [
            textured([1.0; 4]),
            {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.0, 0.0, 1.0]}},
            textured([0.0, 1.0, 0.0, 1.0])
        ],
        "textures": [{"source": 0}],
        "images": [{"bufferView": views.len() - 1, "mimeType": "image/png"}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}]
    });
    let scene = load_glb(&common::glb(&json, &bin)).unwrap();
    let mut faces = scene.faces.iter().enumerate();
    let mut dropped = 0;
    for g in (0..GROUPS).rev() {
        for k in (0..NODES).rev() {
            let mesh = g * NODES + k;
            for p in 0..PRIMITIVES {
                let primitive = mesh * PRIMITIVES + p;
                for t in 0..TRIANGLES {
                    let corners = triangle(primitive, t);
                    if corners[1] == corners[2] {
                        dropped += 1;
                        continue;
                    }
                    let (id, face) = faces.next().expect("a face for every triangle with area");
                    let what = format!("face {id}: mesh {mesh} primitive {p} triangle {t}");
                    let world =
                        corners.map(|v| group_translation(g) + group_scale(g) * (node_translation(k) + local(p, v)));
                    assert!(
                        face.vertices.iter().zip(&world).all(|(a, b)| a.distance(*b) < 1e-12),
                        "{what}: corners {:?}, expected {world:?}",
                        face.vertices
                    );
                    assert_eq!(face.object, 0, "{what}");
                    let colour = [[255, 255, 255], [255, 0, 0], [0, 255, 0]][primitive % 3];
                    assert_eq!(face.colour, colour, "{what}");
                    let surface = scene.surfaces.of(id as u32);
                    if primitive % 3 == 1 {
                        assert!(surface.is_none(), "{what}: a plain material's face has a surface");
                        continue;
                    }
                    let surface = surface.unwrap_or_else(|| panic!("{what}: a textured face without a surface"));
                    let map = surface.uv.as_ref().unwrap();
                    for (corner, point) in corners.iter().zip(&world) {
                        let uv = omnisim::scene::surface::Surface::uv_at(map, surface.anchor, *point);
                        let expected = local(p, *corner).truncate();
                        assert!(
                            (uv - expected).length() < 1e-9,
                            "{what}: uv {uv} at a corner of uv {expected}"
                        );
                    }
                }
            }
        }
    }
    assert!(faces.next().is_none(), "more faces than triangles with area");
    assert_eq!(scene.faces.len(), GROUPS * NODES * PRIMITIVES * TRIANGLES - dropped);
    let warning = format!("mesh 'square': dropped {dropped} degenerate triangles");
    assert!(scene.warnings.contains(&warning), "{:?}", scene.warnings);
}

#[test]
fn the_shipped_crate_looks_the_same_from_obj_and_gltf_and_is_textured_in_ply() {
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(160, 120, 70f64.to_radians()));
    let pose = Pose::from_degrees(dvec3(-0.6, -0.3, 0.6), dvec3(0.0, 15.0, 15.0));
    let render = |name: &str| {
        let scene = common::load(name);
        assert!(
            !scene.surfaces.is_empty() && !scene.surfaces.textures.is_empty(),
            "{name}"
        );
        let tracer = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap());
        tracer.render(&camera, &pose).unwrap().colour().unwrap().to_vec()
    };
    let (obj, gltf, ply) = (
        render("textured-obj.ron"),
        render("textured-gltf.ron"),
        render("textured-ply.ron"),
    );
    // The same crate, texture and placement: the same image (the glTF's y-up corners come back
    // through the scene's rotation, up to rounding).
    let worst = obj
        .iter()
        .zip(&gltf)
        .flat_map(|(a, b)| (0..3).map(move |k| a[k].abs_diff(b[k])))
        .max()
        .unwrap();
    assert!(worst <= 1, "OBJ and glTF differ by {worst}/255");
    // The PLY's vertex colours darken the crate's lower half.
    assert!(obj.iter().zip(&ply).filter(|(a, b)| a != b).count() > 1000);
}

/// The linear vertex colour the glTF square of [`gltf_square_with_colours`] gives local
/// point (x, y): affine over the whole square, so both triangles interpolate this one
/// function and it is the closed form everywhere on it.
fn square_colour(x: f64, y: f64) -> DVec3 {
    // Whole 255ths at the corners, which normalized u8 and u16 hold exactly.
    DVec3::new(51.0 + 51.0 * (x + 1.0) / 2.0, 230.0 - 128.0 * (y + 0.75) / 1.5, 128.0) / 255.0
}

/// The `COLOR_0` component types: f32 (VEC3), and normalized u8 and u16 (VEC4, alpha 1).
const COLOUR_COMPONENTS: [u32; 3] = [5126, 5121, 5123];

/// A `.gltf` (JSON) whose geometry lives in an external `square.bin` beside it: the square of
/// [`square_glb`] (same nodes: at x = 2 facing the origin) with `COLOR_0` from [`square_colour`]
/// in `component`s (one of [`COLOUR_COMPONENTS`]), a `baseColorFactor` of `factor` and, where
/// `unlit`, the `KHR_materials_unlit` extension. Written into `folder`; returns the glTF's file
/// name.
fn gltf_square_with_colours(folder: &Path, factor: [f64; 4], unlit: bool, component: u32) -> &'static str {
    let corners = [
        [-1.0f32, 0.75, 0.0],
        [-1.0, -0.75, 0.0],
        [1.0, -0.75, 0.0],
        [1.0, 0.75, 0.0],
    ];
    let mut bin: Vec<u8> = corners.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    for c in corners {
        let colour = square_colour(f64::from(c[0]), f64::from(c[1])).extend(1.0).to_array();
        match component {
            5126 => bin.extend(colour[..3].iter().flat_map(|&k| (k as f32).to_le_bytes())),
            5121 => bin.extend(colour.map(|k| (k * 255.0).round() as u8)),
            _ => bin.extend(
                colour
                    .iter()
                    .flat_map(|&k| ((k * 65535.0).round() as u16).to_le_bytes()),
            ),
        }
    }
    let (colours, colour_type) = (bin.len() - 48, if component == 5126 { "VEC3" } else { "VEC4" });
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(folder.join("square.bin"), &bin).unwrap();
    let rotation = glam::DQuat::from_mat3(&glam::DMat3::from_cols(-DVec3::Y, DVec3::Z, -DVec3::X));
    let mut material = serde_json::json!({"pbrMetallicRoughness": {"baseColorFactor": factor}});
    if unlit {
        material["extensions"] = serde_json::json!({"KHR_materials_unlit": {}});
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"children": [1], "translation": [2.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0]},
            {"mesh": 0, "rotation": [rotation.x, rotation.y, rotation.z, rotation.w], "scale": [0.5, 0.5, 0.5]}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [material],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1.0, -0.75, 0.0], "max": [1.0, 0.75, 0.0]},
            {"bufferView": 1, "componentType": component, "normalized": component != 5126, "count": 4, "type": colour_type},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": colours},
            {"buffer": 0, "byteOffset": 48 + colours, "byteLength": 12}
        ],
        "buffers": [{"uri": "square.bin", "byteLength": bin.len()}]
    });
    std::fs::write(folder.join("square.gltf"), serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    "square.gltf"
}

/// The colour frame of the square mesh `file` in `folder`, in a scene lit by a lamp where
/// `lit`, seen by a pinhole at the origin looking along +x.
fn render_mesh(folder: &Path, file: &str, lit: bool) -> (Camera, Vec<[u8; 3]>, Vec<bool>) {
    let lighting = if lit {
        r#", lighting: (lights: [Point(name: "lamp", position: (0.5, 0.6, 0.4), intensity: 150.0)])"#
    } else {
        ""
    };
    let text =
        format!(r#"Scene(name: "gltf", objects: [Mesh(name: "square", path: "{file}", colour: (9, 9, 9))]{lighting})"#);
    let scene = Scene::from_ron(&text, &folder.join("gltf.ron")).unwrap();
    let camera = Camera::Pinhole(Pinhole::with_horizontal_fov(120, 90, 60f64.to_radians()));
    let frame = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap())
        .render(&camera, &Pose::new(DVec3::ZERO, DVec3::ZERO))
        .unwrap();
    let hits = frame.pixels().iter().map(omnisim::advanced::Pixel::is_hit).collect();
    (camera, frame.colour().unwrap().to_vec(), hits)
}

/// `COLOR_0` in f32 and in normalized u8 and u16 (linear, as the spec says), times a
/// `baseColorFactor` other than 1: each pixel the closed form's colour at its hit point.
#[test]
fn gltf_vertex_colours_times_base_colour_factor_from_an_external_buffer_match_the_closed_form() {
    let folder = tempfile::tempdir().unwrap();
    let factor = [0.8, 0.5, 1.0, 1.0];
    for component in COLOUR_COMPONENTS {
        let file = gltf_square_with_colours(folder.path(), factor, false, component);
        let (camera, colour, hits) = render_mesh(folder.path(), file, false);
        check_closed_form(&camera, &colour, &hits, |direction| {
            // World (2, y, z) is local (−y, z): the colour there, times the factor.
            let point = direction * (2.0 / direction.x);
            let linear = square_colour(-point.y, point.z) * DVec3::new(factor[0], factor[1], factor[2]);
            linear.to_array().map(linear_to_srgb)
        });
        // The colours vary across the square (a flat mean would fail the closed form above).
        let seen: std::collections::HashSet<[u8; 3]> = colour.iter().copied().collect();
        assert!(seen.len() > 100, "component type {component}: {} colours", seen.len());
    }
}

#[test]
fn khr_materials_unlit_draws_the_albedo_whatever_the_lights() {
    let folder = tempfile::tempdir().unwrap();
    let factor = [1.0, 1.0, 1.0, 1.0];
    let file = gltf_square_with_colours(folder.path(), factor, true, 5126);
    let (_, unlit_in_the_dark, _) = render_mesh(folder.path(), file, false);
    let (_, unlit_under_the_lamp, hits) = render_mesh(folder.path(), file, true);
    assert!(hits.iter().filter(|&&h| h).count() > 5000);
    assert_eq!(unlit_in_the_dark, unlit_under_the_lamp);
    // The same material without the extension is shaded by the lamp: nearly every pixel differs.
    let file = gltf_square_with_colours(folder.path(), factor, false, 5126);
    let (_, lit, _) = render_mesh(folder.path(), file, true);
    let differing = lit
        .iter()
        .zip(&unlit_under_the_lamp)
        .zip(&hits)
        .filter(|((a, b), hit)| **hit && a != b)
        .count();
    assert!(differing > 5000, "{differing} pixels differ");
}

#[test]
fn a_missing_or_escaping_external_buffer_is_a_located_error() {
    let folder = tempfile::tempdir().unwrap();
    let file = gltf_square_with_colours(folder.path(), [1.0; 4], false, 5126);
    let load = |folder: &Path| {
        Scene::from_ron(
            &format!(r#"Scene(name: "gltf", objects: [Mesh(name: "square", path: "{file}", colour: (9, 9, 9))])"#),
            &folder.join("gltf.ron"),
        )
        .map(|_| ())
        .unwrap_err()
        .to_string()
    };
    std::fs::remove_file(folder.path().join("square.bin")).unwrap();
    let missing = load(folder.path());
    assert!(
        missing.contains("square.bin") && missing.contains("square.gltf"),
        "{missing}"
    );
    let text = std::fs::read_to_string(folder.path().join(file)).unwrap();
    std::fs::write(
        folder.path().join(file),
        text.replace("\"square.bin\"", "\"../square.bin\""),
    )
    .unwrap();
    let escaping = load(folder.path());
    assert!(escaping.contains("..") && escaping.contains("inside"), "{escaping}");
}

/// Runs the Python writer `script` (tests/readers) on `folder` with `OMNISIM_PYTHON`.
fn run_python_writer(script: &str, folder: &Path) {
    let python = std::env::var_os("OMNISIM_PYTHON")
        .expect("OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (README, Tests)");
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let writer = std::process::Command::new(python)
        .arg(script)
        .arg(folder)
        .current_dir(workspace)
        .output()
        .unwrap_or_else(|e| panic!("{script}: Python does not run: {e}"));
    assert!(
        writer.status.success(),
        "{script}: {}",
        String::from_utf8_lossy(&writer.stderr)
    );
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn a_gltf_and_a_glb_written_by_pygltflib_map_their_texture_exactly() {
    let folder = tempfile::tempdir().unwrap();
    write_texture(folder.path());
    run_python_writer("tests/readers/write_textured_gltf.py", folder.path());
    for file in ["square.gltf", "square.glb"] {
        let text =
            format!(r#"Scene(name: "pygltflib", objects: [Mesh(name: "square", path: "{file}", colour: (9, 9, 9))])"#);
        let scene = Scene::from_ron(&text, &folder.path().join("square.ron")).unwrap();
        assert_eq!(scene.faces.len(), 2, "{file}");
        check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), false);
    }
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn an_obj_and_a_ply_written_by_trimesh_keep_their_uvs_and_colours() {
    let folder = tempfile::tempdir().unwrap();
    write_texture(folder.path());
    run_python_writer("tests/readers/write_trimesh_meshes.py", folder.path());
    // The OBJ, its MTL and trimesh's copy of the texture: vertices and UVs (v up) as the square
    // of `square_mesh`, so every texel is where the closed form puts it (OBJ repeats).
    let text = r#"Scene(name: "trimesh", objects: [Mesh(name: "square", path: "square.obj", colour: (9, 9, 9))])"#;
    let scene = Scene::from_ron(text, &folder.path().join("square.ron")).unwrap();
    assert_eq!(scene.faces.len(), 2);
    check_texels_exact(&common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap()), true);
    // The binary PLY's vertices and vertex colours.
    let corners = [dvec3(2.0, 1.0, -0.75), dvec3(2.0, -1.0, -0.75), dvec3(2.0, 0.0, 0.75)];
    check_fan_colours(folder.path(), corners, [[255, 0, 0], [0, 255, 0], [0, 0, 255]]);
}

/// Textured frames are shaded in chunks of pixels and runs of eight pixels of one face (`shade/textured.rs`)
/// and lit from the frame's shadow-ray packets; each pixel must still be, bit for bit, what
/// shading its hit alone gives with its own footprint (`shade`, `Footprint::of_pixel`), linear
/// and 8-bit, with the linear plane and without it (8-bit only). The omni image's odd size puts
/// chunk and run ends mid-row; the lit textured room has textured, plain and unlit faces and
/// misses, the unlit one textured and plain faces, and the PLY's crate textured faces with vertex
/// colours: more textured faces in a chunk than it keeps runs open, so a run is replaced by a new
/// face's (about a hundred times a frame at the omni pose).
/// The unturned poses give the frame's body-frame footprints and `of_pixel`'s world-frame ones
/// the same numbers, so those frames must match bit for bit; a turned pose (roll, pitch and the
/// benchmarks' 60° yaw) rounds a footprint's angle differently in f32, so its pixels must match
/// to [`ALONG_TURNED`]'s tolerance, which a footprint laid in the wrong frame exceeds.
#[test]
fn a_textured_frame_is_each_pixel_shaded_alone_bit_for_bit() {
    let cases = [
        ("env1-textured-lit.ron", dvec3(1.5, 0.0, 0.4)),
        ("env1-textured.ron", dvec3(1.5, 0.0, 0.4)),
        ("textured-ply.ron", dvec3(-0.6, -0.3, 0.6)),
    ];
    let cameras = [
        Camera::Pinhole(Pinhole::with_horizontal_fov(37, 29, 80f64.to_radians())),
        Camera::Catadioptric(common::paper_omni()),
    ];
    for ((scene, position), angles) in cases.into_iter().flat_map(|case| [(case, DVec3::ZERO), (case, TURNED)]) {
        let pose = Pose::from_degrees(position, angles);
        let exact = angles == DVec3::ZERO;
        let loaded = common::load(scene);
        let bvh = SceneBvh::build(&loaded).unwrap();
        let mut tracer = common::cpu_tracer(&loaded, &bvh);
        let appearance = tracer.scene.appearance();
        assert_eq!(appearance.lighting.is_some(), scene.contains("-lit"), "{scene}");
        let surface_of = |face: u32| appearance.surfaces.of(face);
        let textured = |face: u32| surface_of(face).is_some_and(|surface| surface.uv.is_some());
        let coloured = |face: u32| textured(face) && surface_of(face).is_some_and(|surface| surface.colours.is_some());
        for cpu in [CpuTracer::Fast, CpuTracer::Reference] {
            tracer.renderer.set_cpu_tracer(cpu);
            for camera in &cameras {
                for planes in [Planes::COLOUR.with(Plane::LinearColour), Planes::COLOUR] {
                    let frame = tracer.render_planes(camera, &pose, planes).expect("render");
                    let (linear, colour) = (frame.linear_colour(), frame.colour().unwrap());
                    assert_eq!(linear.is_some(), planes.contains(Plane::LinearColour));
                    let width = frame.width as usize;
                    let (mut textured_pixels, mut coloured_pixels) = (0, 0);
                    let name = format!("{scene} {angles} {} {cpu:?} {planes:?}", common::describe(camera));
                    for (index, hit) in frame.pixels().iter().enumerate() {
                        let pixel = DVec2::new((index % width) as f64, (index / width) as f64);
                        let footprint = Footprint::of_pixel(camera, &pose, pixel);
                        let alone =
                            advanced::shade(cpu, tracer.scene.geometry(), tracer.scene.appearance(), hit, &footprint);
                        let name = format!("{name} pixel {index}");
                        if let Some(linear) = linear {
                            assert_shaded_alone(linear[index], alone, exact, &name);
                        }
                        if hit.is_hit() {
                            assert_encoded_alone(colour[index], alone, exact, &name);
                            textured_pixels += usize::from(textured(hit.face));
                            coloured_pixels += usize::from(coloured(hit.face));
                        } else {
                            // Written as black, with no fill before (`shade/textured.rs`).
                            assert_eq!(colour[index], [0, 0, 0], "{name}: a miss");
                        }
                    }
                    assert!(
                        textured_pixels > frame.pixels().len() / 10,
                        "{name}: {textured_pixels} textured pixels"
                    );
                    if scene == "textured-ply.ron" {
                        // The turned pose sees the crate's corner, 56 such pixels of the pinhole's.
                        let least = if exact { 100 } else { 40 };
                        assert!(
                            coloured_pixels > least,
                            "{name}: {coloured_pixels} vertex-coloured textured pixels"
                        );
                    }
                }
            }
        }
    }
}

/// A turned pose: roll, pitch and the benchmarks' 60° yaw (degrees), so that the camera body's
/// frame, where a frame's footprints lie, is not the world's.
const TURNED: DVec3 = dvec3(5.0, -8.0, 60.0);

/// How far a turned frame's linear colour may lie from its pixel shaded alone, relative to
/// the colour (at least 1): a footprint's angle rounded in f32 in the body frame rather than
/// the world's moves its level of detail in the last bits, and the colour with it. A
/// footprint laid on a world normal in the body frame (or the reverse) moves whole levels.
const ALONG_TURNED: f64 = 1e-5;

/// Asserts that linear colour `linear` is `alone` (a pixel shaded alone): bit for bit where
/// `exact`, else to [`ALONG_TURNED`].
fn assert_shaded_alone(linear: [f32; 3], alone: DVec3, exact: bool, name: &str) {
    if exact {
        assert_eq!(linear, alone.as_vec3().to_array(), "{name}");
    } else {
        let error = (DVec3::from(linear.map(f64::from)) - alone).abs().max_element();
        assert!(
            error <= ALONG_TURNED * alone.abs().max_element().max(1.0),
            "{name}: {linear:?} against {alone}"
        );
    }
}

/// Asserts that 8-bit colour `colour` is `alone` (a pixel shaded alone) encoded: bit for bit
/// where `exact`, else within one step (a colour [`ALONG_TURNED`] off may round across one).
fn assert_encoded_alone(colour: [u8; 3], alone: DVec3, exact: bool, name: &str) {
    let expected = advanced::encode(alone);
    if exact {
        assert_eq!(colour, expected, "{name}");
    } else {
        assert!(
            colour
                .iter()
                .zip(expected)
                .all(|(&byte, expected)| byte.abs_diff(expected) <= 1),
            "{name}: {colour:?} against {expected:?}"
        );
    }
}

/// As [`a_textured_frame_is_each_pixel_shaded_alone_bit_for_bit`], for images too large for a
/// ray table, whose footprints come from a cone table (above 2^20 pixels) or from the
/// camera's rays alone (above 2^22): every 61st pixel, linear and 8-bit, unturned (bit for
/// bit) and turned ([`TURNED`]). The sizes are forced by the ray table's limits (`MAX_PIXELS`,
/// `MAX_CONE_PIXELS` in `trace/ray_table.rs`); the equirect panorama's rays come from its
/// per-column and per-row ray source there, a pinhole's pixel by pixel.
#[test]
fn a_textured_frame_too_large_for_a_ray_table_is_each_pixel_shaded_alone_bit_for_bit() {
    let loaded = common::load("env1-textured.ron");
    let bvh = SceneBvh::build(&loaded).unwrap();
    let mut tracer = common::cpu_tracer(&loaded, &bvh);
    tracer.renderer.set_cpu_tracer(CpuTracer::Fast);
    let appearance = tracer.scene.appearance();
    let pinhole = |width, height| Camera::Pinhole(Pinhole::with_horizontal_fov(width, height, 80f64.to_radians()));
    let cameras = [
        pinhole(1100, 1000),
        pinhole(4200, 1000),
        Camera::Equirectangular(Equirectangular {
            width: 1450,
            height: 725,
        }),
    ];
    for (camera, angles) in cameras
        .iter()
        .flat_map(|camera| [(camera, DVec3::ZERO), (camera, TURNED)])
    {
        let (width, height) = camera.size();
        let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), angles);
        let exact = angles == DVec3::ZERO;
        let frame = tracer
            .render_planes(camera, &pose, Planes::COLOUR.with(Plane::LinearColour))
            .expect("render");
        let (linear, colour) = (frame.linear_colour().unwrap(), frame.colour().unwrap());
        let mut textured_pixels = 0;
        for index in (0..frame.pixels().len()).step_by(61) {
            let hit = &frame.pixels()[index];
            let pixel = DVec2::new((index % width as usize) as f64, (index / width as usize) as f64);
            let footprint = Footprint::of_pixel(camera, &pose, pixel);
            let alone = advanced::shade(CpuTracer::Fast, tracer.scene.geometry(), appearance, hit, &footprint);
            let name = format!("{width}×{height} {angles} pixel {index}");
            assert_shaded_alone(linear[index], alone, exact, &name);
            if hit.is_hit() {
                assert_encoded_alone(colour[index], alone, exact, &name);
            }
            textured_pixels += usize::from(appearance.needs_footprint(hit.face));
        }
        assert!(
            textured_pixels > 1000,
            "{width}×{height} {angles}: {textured_pixels} textured pixels"
        );
    }
}

/// The corners of `got` turned so that its first corner is `expected`'s (a rotation keeps the
/// winding), if its corners are `expected`'s to within `tolerance`.
fn same_triangle(got: &[DVec3], expected: &[DVec3; 3], tolerance: f64) -> Option<usize> {
    (0..3).find(|&turn| (0..3).all(|k| (got[(k + turn) % 3] - expected[k]).length() <= tolerance))
}

/// What one case of `tests/readers/write_format_variants.py` must read as: its faces, and where
/// given their colours, texture coordinates, vertex colours and a texel of the first texture.
/// Every difference is returned, so that one run lists every variant read wrongly.
fn check_variant(folder: &Path, case: &serde_json::Value) -> Vec<String> {
    let name = case["name"].as_str().unwrap();
    let loaded = Scene::from_ron(
        &std::fs::read_to_string(folder.join(case["scene"].as_str().unwrap())).unwrap(),
        &folder.join(case["scene"].as_str().unwrap()),
    );
    let scene = match (loaded, case["refuse"].as_array()) {
        (Ok(_), Some(_)) => return vec![format!("{name}: read, but must be refused")],
        (Err(e), Some(words)) => {
            let message = e.to_string();
            return words
                .iter()
                .map(|w| w.as_str().unwrap())
                .filter(|w| !message.contains(w))
                .map(|w| format!("{name}: refused without naming {w}: {message}"))
                .collect();
        }
        (Err(e), None) => return vec![format!("{name}: refused: {e}")],
        (Ok(scene), None) => scene,
    };
    let point = |v: &serde_json::Value| DVec3::from_array([0, 1, 2].map(|k| v[k].as_f64().unwrap()));
    let expected: Vec<[DVec3; 3]> = case["faces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| [0, 1, 2].map(|k| point(&f[k])))
        .collect();
    if scene.faces.len() != expected.len() {
        return vec![format!(
            "{name}: {} faces, the format defines {}",
            scene.faces.len(),
            expected.len()
        )];
    }
    let mut problems = Vec::new();
    let mut taken = vec![false; scene.faces.len()];
    for (e, corners) in expected.iter().enumerate() {
        let found = scene.faces.iter().enumerate().find_map(|(k, face)| {
            (!taken[k])
                .then(|| same_triangle(&face.vertices, corners, 1e-5))
                .flatten()
                .map(|turn| (k, turn))
        });
        let Some((k, turn)) = found else {
            problems.push(format!(
                "{name}: face {e} {corners:?} is not in the scene (or wound the other way)"
            ));
            continue;
        };
        taken[k] = true;
        let face = &scene.faces[k];
        let vertex = |c: usize| face.vertices[(c + turn) % 3];
        if let Some(colour) = case["colours"].get(e) {
            let colour: Vec<u8> = colour
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_u64().unwrap() as u8)
                .collect();
            if (0..3).any(|c| face.colour[c].abs_diff(colour[c]) > 1) {
                problems.push(format!(
                    "{name}: face {e} colour {:?}, expected {colour:?}",
                    face.colour
                ));
            }
        }
        let surface = scene.surfaces.of(k as u32);
        if let Some(uvs) = case["uvs"].get(e) {
            match surface.and_then(|s| s.uv.as_ref().map(|map| (s, map))) {
                None => problems.push(format!("{name}: face {e} has no texture coordinates")),
                Some((surface, map)) => {
                    for c in 0..3 {
                        let want = DVec2::new(uvs[c][0].as_f64().unwrap(), uvs[c][1].as_f64().unwrap());
                        let got = omnisim::scene::surface::Surface::uv_at(map, surface.anchor, vertex(c));
                        if (got - want).length() > 1e-5 {
                            problems.push(format!("{name}: face {e} corner {c}: uv {got}, expected {want}"));
                        }
                    }
                }
            }
        }
        if let Some(colours) = case["corner_colours"].get(e) {
            match surface.and_then(|s| s.colours.as_ref().map(|map| (s, map))) {
                None => problems.push(format!("{name}: face {e} has no vertex colours")),
                Some((surface, map)) => {
                    for c in 0..3 {
                        let linear = omnisim::scene::surface::Surface::colour_at(map, surface.anchor, vertex(c));
                        let got = linear.to_array().map(linear_to_srgb);
                        let want: Vec<u8> = (0..3).map(|k| colours[c][k].as_u64().unwrap() as u8).collect();
                        if (0..3).any(|k| got[k].abs_diff(want[k]) > 1) {
                            problems.push(format!(
                                "{name}: face {e} corner {c}: colour {got:?}, expected {want:?}"
                            ));
                        }
                    }
                }
            }
        }
    }
    if let Some(texel) = case.get("texel") {
        let at = |key: &str| texel[key].as_u64().unwrap() as u32;
        let within = texel.get("within").map_or(1, |w| w.as_u64().unwrap() as u8);
        match scene.surfaces.textures.first() {
            None => problems.push(format!("{name}: no texture")),
            Some(texture) => {
                let got = texture.levels[0].texel(at("x"), at("y"));
                let want: Vec<u8> = (0..3).map(|k| texel["rgb"][k].as_u64().unwrap() as u8).collect();
                if (0..3).any(|k| got[k].abs_diff(want[k]) > within) {
                    problems.push(format!("{name}: texel {got:?}, expected {want:?}"));
                }
            }
        }
    }
    problems
}

/// The mesh files users and independent checkers bring (glTF from pygltflib and trimesh in every
/// topology, index width, quantization, colour and image kind, sparse and view-less accessors,
/// node and scene layouts; PLY from plyfile, trimesh and `Open3D` in every encoding and list type;
/// OBJ with MTL options, negative indices, n-gons and awkward paths): each reads as its format
/// defines it, and what omnisim cannot show is refused by name (README, "Scene files").
#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn files_from_independent_writers_read_as_their_formats_define() {
    let folder = tempfile::tempdir().unwrap();
    run_python_writer("tests/readers/write_format_variants.py", folder.path());
    let cases: Vec<serde_json::Value> =
        serde_json::from_slice(&std::fs::read(folder.path().join("cases.json")).unwrap()).unwrap();
    assert!(cases.len() > 90, "{} cases", cases.len());
    let problems: Vec<String> = cases
        .iter()
        .flat_map(|case| check_variant(folder.path(), case))
        .collect();
    assert!(
        problems.is_empty(),
        "{} of {} cases read wrongly:\n{}",
        problems.len(),
        cases.len(),
        problems.join("\n")
    );
}

/// 40 accessors of a million f32 VEC3s over a 1 MiB buffer (`view_less`: without a buffer view,
/// each within its own bound; else all aliasing one 12 MiB view), each the POSITION of two
/// meshes of one triangle: each accessor is within bounds, but together they would decode about
/// 1 GB from a file of 1 or 12 MiB (review of the formats branch, 1.1).
fn many_large_accessors_glb(view_less: bool) -> Vec<u8> {
    let elements = 1usize << 20;
    let accessors = 40;
    let (bin, views) = if view_less {
        (
            vec![0u8; elements],
            serde_json::json!([{"buffer": 0, "byteOffset": 0, "byteLength": 4}]),
        )
    } else {
        let views = serde_json::json!([
            {"buffer": 0, "byteOffset": 0, "byteLength": 4},
            {"buffer": 0, "byteOffset": 4, "byteLength": 12 * elements},
        ]);
        (vec![0u8; 4 + 12 * elements], views)
    };
    let mut accessor_list =
        vec![serde_json::json!({"bufferView": 0, "componentType": 5121, "count": 3, "type": "SCALAR"})];
    accessor_list.extend((0..accessors).map(|_| {
        let mut accessor = serde_json::json!({"componentType": 5126, "count": elements, "type": "VEC3",
                                              "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0]});
        if !view_less {
            accessor["bufferView"] = serde_json::json!(1);
        }
        accessor
    }));
    let mut json = meshes_one_per_node(
        (0..2 * accessors)
            .map(|m| serde_json::json!({"attributes": {"POSITION": 1 + m / 2}, "indices": 0}))
            .collect(),
    );
    json["accessors"] = serde_json::json!(accessor_list);
    json["bufferViews"] = views;
    json["buffers"] = serde_json::json!([{"byteLength": bin.len()}]);
    common::glb(&json, &bin)
}

/// [`many_large_accessors_glb`]'s files are refused before any accessor is read, naming the
/// mesh, primitive and accessor that pass the file's read budget and how to mend the file.
#[test]
fn accessors_that_together_pass_the_files_read_budget_are_refused_before_reading() {
    for view_less in [true, false] {
        let error = load_glb(&many_large_accessors_glb(view_less))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("square.glb")
                && error.contains("mesh ")
                && error.contains(" primitive 0: accessor ")
                && error.contains("(POSITION)")
                && error.contains("buffer bytes"),
            "{error}"
        );
    }
}

/// A node of `EXT_mesh_gpu_instancing` whose TRANSLATION accessor claims 2 M instances (over a
/// view of one): refused for passing the node-visit cap from the accessor's count, before its
/// translations are read (read first, they were refused as truncated, or decoded, GBs of them
/// for a large file, only to be refused after).
#[test]
fn instances_past_the_node_visit_cap_are_refused_before_they_are_read() {
    let bin = triangle_then_zeros(12);
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 1}}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 2_000_000, "type": "VEC3"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 12},
        ],
        "buffers": [{"byteLength": bin.len()}],
    });
    let error = load_glb(&common::glb(&json, &bin)).map(|_| ()).unwrap_err().to_string();
    assert!(
        error.contains("node 0 (EXT_mesh_gpu_instancing): accessor 1 holds 2000000 instances")
            && error.contains("node visits pass 1000000"),
        "{error}"
    );
}
