//! Seeded mutations of the shipped scenes (bytes and tokens) through loading, validation, the
//! BVH build and a tiny CPU render: no input may panic, and every parse error names its
//! <file:line:column>. Time per input is bounded by construction (the scenes are a few KB, the
//! render 16×8 rays), so a hang shows as a slow test, never an endless one.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::DVec3;
use omnisim::camera::Equirectangular;
use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene, SceneError};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Mutations per shipped scene.
const MUTATIONS: usize = 2500;

/// Numbers that broke or could break geometry code.
const NUMBERS: [&str; 14] = [
    "0.0",
    "-0.0",
    "-1.0",
    "1e308",
    "1.7976931348623157e308",
    "1e39",
    "-1e30",
    "1e-320",
    "NaN",
    "inf",
    "1e6",
    "1000000.1",
    "4294967296",
    "255",
];

/// Token-level edits keep the file mostly well-formed, so they reach validation and the BVH.
fn mutate_tokens(text: &str, rng: &mut StdRng) -> String {
    let numbers: Vec<(usize, usize)> = {
        let bytes = text.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i].is_ascii_digit() && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric()) {
                let start = if i > 0 && bytes[i - 1] == b'-' { i - 1 } else { i };
                while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                    i += 1;
                }
                spans.push((start, i));
            } else {
                i += 1;
            }
        }
        spans
    };
    let mut out = text.to_string();
    for _ in 0..rng.random_range(1..4) {
        match rng.random_range(0..4) {
            // A number replaced by one of the dangerous ones.
            0 | 1 => {
                let (start, end) = numbers[rng.random_range(0..numbers.len())];
                if end <= out.len() && out.is_char_boundary(start) && out.is_char_boundary(end) {
                    out.replace_range(start..end, NUMBERS[rng.random_range(0..NUMBERS.len())]);
                }
            }
            // A line duplicated (duplicate names, repeated objects) or removed.
            2 => {
                let mut lines: Vec<&str> = out.lines().collect();
                let k = rng.random_range(0..lines.len());
                if rng.random_bool(0.5) {
                    lines.insert(k, lines[k]);
                } else {
                    lines.remove(k);
                }
                out = lines.join("\n");
            }
            // A name made hostile.
            _ => {
                out = out.replacen(
                    "name: \"",
                    ["name: \"../", "name: \"/", "name: \"\\u{0}", "name: \"\""][rng.random_range(0..4)],
                    1,
                );
            }
        }
    }
    out
}

/// Byte-level edits: flips, insertions, deletions, truncation.
fn mutate_bytes(text: &str, rng: &mut StdRng) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for _ in 0..rng.random_range(1..4) {
        let at = rng.random_range(0..bytes.len());
        match rng.random_range(0..4) {
            0 => bytes[at] = rng.random(),
            1 => bytes.insert(at, b"()[]{},:\"-.e0\\"[rng.random_range(0..14)]),
            2 => {
                let end = (at + rng.random_range(1..40)).min(bytes.len());
                bytes.drain(at..end);
            }
            _ => bytes.truncate(at),
        }
        if bytes.is_empty() {
            break;
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Loads, builds and renders one mutated scene: whether it rendered, or `Err` describing a
/// broken promise.
fn exercise(text: &str) -> Result<bool, String> {
    let path = Path::new("fuzz.ron");
    match Scene::from_ron(text, path) {
        Ok(scene) => {
            let renderer = Renderer::new(BackendChoice::Cpu).map_err(|e| e.to_string())?;
            let prepared = renderer.prepare(&scene).map_err(|e| e.to_string())?;
            let (lo, hi) = scene.bounds().ok_or("a loaded scene has bounds")?;
            let camera = Camera::Equirectangular(Equirectangular { width: 16, height: 8 });
            renderer
                .render(
                    &prepared,
                    &camera,
                    &Pose::new((lo + hi) / 2.0, DVec3::ZERO),
                    Planes::COLOUR,
                )
                .map_err(|e| format!("render failed: {e}"))?;
            Ok(true)
        }
        Err(error @ SceneError::Parse { line, column, .. }) if line >= 1 && column >= 1 => {
            let message = error.to_string();
            message
                .starts_with(&format!("fuzz.ron:{line}:{column}: "))
                .then_some(false)
                .ok_or(format!("parse error without its position: {message}"))
        }
        Err(error @ SceneError::Invalid { location: None, .. }) => {
            // Only a name the text does not hold literally (escapes) cannot be located.
            let SceneError::Invalid { ref object, .. } = error else {
                unreachable!()
            };
            match text.contains(&format!("\"{object}\"")) {
                true => Err(format!("invalid object not located: {error}")),
                false => Ok(false),
            }
        }
        Err(SceneError::Parse { .. }) => Err("parse error at line or column 0".into()),
        Err(_) => Ok(false),
    }
}

#[test]
fn mutated_scene_files_never_panic_and_errors_say_where() {
    let mut failures = Vec::new();
    let mut rendered = 0;
    for (room_index, room) in common::ROOMS.iter().enumerate() {
        let text = std::fs::read_to_string(common::scene_path(room)).unwrap();
        let mut rng = StdRng::seed_from_u64(0x5eed + room_index as u64);
        for case in 0..MUTATIONS {
            let mutated = if case % 2 == 0 {
                mutate_tokens(&text, &mut rng)
            } else {
                mutate_bytes(&text, &mut rng)
            };
            let outcome =
                catch_unwind(AssertUnwindSafe(|| exercise(&mutated))).unwrap_or_else(|_| Err("panicked".to_string()));
            rendered += usize::from(outcome == Ok(true));
            if let Err(problem) = outcome {
                let kept = std::env::temp_dir().join(format!("omnisim-fuzz-{room}-{case}.ron"));
                let _ = std::fs::write(&kept, &mutated);
                failures.push(format!("{room} case {case} ({}): {problem}", kept.display()));
            }
        }
    }
    // The token edits must reach the BVH and the renderer often, or they test only the parser.
    assert!(rendered > MUTATIONS / 10, "only {rendered} mutated scenes rendered");
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Whether a refusal says where the fault is: one of `fuzz.glb` names the file and the part of
/// it at fault (an accessor, a mesh's primitive, a node, a buffer, an image, …, or the JSON
/// path or line and column gltf-json gives); one of the placed faces (no file named) comes
/// from the mesh object's own checks. Every error names the object, so that alone is no test.
fn located(error: &str) -> bool {
    const PARTS: [&str; 11] = [
        "accessor",
        "primitive",
        "node",
        "scene",
        "buffer",
        "image",
        "texture",
        "material",
        "sampler",
        "extension",
        "at line ",
    ];
    if error.contains("fuzz.glb") {
        PARTS.iter().any(|part| error.contains(part))
    } else {
        error.contains("object 'm': Mesh: ")
    }
}

/// A 2×1 RGB PNG (a red and a blue texel).
fn two_texel_png() -> Vec<u8> {
    let mut png = Vec::new();
    let mut encoder = png::Encoder::new(&mut png, 2, 1);
    encoder.set_color(png::ColorType::Rgb);
    encoder
        .write_header()
        .unwrap()
        .write_image_data(&[255, 0, 0, 0, 0, 255])
        .unwrap();
    png
}

/// A GLB of the glTF readers' every path: a quantized (normalized i16, byteStride 8) POSITION
/// with a sparse substitute, a triangle strip through u8 indices, normalized u8 texture
/// coordinates under `KHR_texture_transform`, a u16 VEC4 `COLOR_0`, a view-less accessor
/// (`TEXCOORD_1`: the unmutated material reads set 0, so only mutations that make its
/// `texCoord` 1 read it), an embedded PNG, a node hierarchy and `EXT_mesh_gpu_instancing`.
fn every_path_glb() -> (serde_json::Value, Vec<u8>) {
    let mut bin = Vec::new();
    for p in [[0i16, 0, 0], [0, 16000, 100], [16000, 0, 200], [16000, 16000, 300]] {
        bin.extend(p.iter().flat_map(|c| c.to_le_bytes()));
        bin.extend([0, 0]);
    }
    bin.extend([0u8, 0, 255, 0, 0, 255, 255, 255]); // texture coordinates at 32
    bin.extend([1u8, 0, 3, 2]); // strip indices at 40
    bin.extend([65535u16, 0, 0, 65535].repeat(4).iter().flat_map(|c| c.to_le_bytes())); // colours at 44
    bin.extend(2u16.to_le_bytes()); // sparse index at 76
    bin.extend([100i16, 100, 100].iter().flat_map(|c| c.to_le_bytes())); // sparse value at 78
    bin.extend([0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0].iter().flat_map(|v| v.to_le_bytes())); // instances at 84
    let png_at = bin.len();
    let png = two_texel_png();
    bin.extend(&png);
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_texture_transform", "EXT_mesh_gpu_instancing"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"children": [1], "scale": [2.0, 2.0, 2.0]},
            {"mesh": 0, "translation": [0.0, 0.0, 1.0],
             "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 6}}}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 3, "TEXCOORD_1": 4},
                                    "indices": 2, "material": 0, "mode": 5}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0,
            "extensions": {"KHR_texture_transform": {"scale": [2.0, 1.0]}}}}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33648}],
        "images": [{"bufferView": 7, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [16000, 16000, 300],
             "sparse": {"count": 1, "indices": {"bufferView": 4, "componentType": 5123},
                        "values": {"bufferView": 5}}},
            {"bufferView": 1, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5121, "count": 4, "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC4"},
            {"componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 6, "byteOffset": 0, "componentType": 5126, "count": 2, "type": "VEC3"},
            {"bufferView": 6, "componentType": 5126, "count": 2, "type": "VEC3"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8},
            {"buffer": 0, "byteOffset": 32, "byteLength": 8},
            {"buffer": 0, "byteOffset": 40, "byteLength": 4},
            {"buffer": 0, "byteOffset": 44, "byteLength": 32},
            {"buffer": 0, "byteOffset": 76, "byteLength": 2},
            {"buffer": 0, "byteOffset": 78, "byteLength": 6},
            {"buffer": 0, "byteOffset": 84, "byteLength": 24},
            {"buffer": 0, "byteOffset": png_at, "byteLength": png.len()}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    (json, bin)
}

/// The JSON pointers of every number and string in `value` (the fields a mutation rewrites).
fn leaves(value: &serde_json::Value, at: &str, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(map) => map.iter().for_each(|(k, v)| leaves(v, &format!("{at}/{k}"), out)),
        serde_json::Value::Array(list) => list
            .iter()
            .enumerate()
            .for_each(|(i, v)| leaves(v, &format!("{at}/{i}"), out)),
        serde_json::Value::Number(_) | serde_json::Value::String(_) => out.push(at.to_string()),
        _ => {}
    }
}

/// Seeded rewrites of [`every_path_glb`]'s counts, offsets, strides, lengths, component types,
/// modes, indices and type names (numbers and names that broke or could break a reader):
/// loading never panics, and every refusal names the file and the part of it at fault (or,
/// for its placed faces, the mesh object). gltf-json's validation itself panicked on an attribute naming an accessor
/// past the list until omnisim checked those first.
#[test]
fn mutated_gltf_files_never_panic() {
    let (json, bin) = every_path_glb();
    let folder = tempfile::tempdir().unwrap();
    let load = |bytes: &[u8]| {
        std::fs::write(folder.path().join("fuzz.glb"), bytes).unwrap();
        Scene::from_ron(
            r#"Scene(name: "fuzz", objects: [Mesh(name: "m", path: "fuzz.glb", colour: (9, 9, 9))])"#,
            &folder.path().join("fuzz.ron"),
        )
    };
    let faces = load(&common::glb(&json, &bin)).unwrap().faces.len();
    assert_eq!(faces, 4, "the unmutated file: a strip of 2 triangles, 2 instances");
    let mut fields = Vec::new();
    leaves(&json, "", &mut fields);
    let values: Vec<serde_json::Value> = [
        "0",
        "-1",
        "1",
        "2",
        "3",
        "4",
        "5",
        "6",
        "7",
        "8",
        "255",
        "256",
        "65535",
        "4294967295",
        "4294967296",
        "1e20",
        "5120",
        "5121",
        "5122",
        "5123",
        "5125",
        "5126",
        "0.5",
        "\"SCALAR\"",
        "\"VEC2\"",
        "\"VEC4\"",
        "\"MAT4\"",
    ]
    .iter()
    .map(|v| serde_json::from_str(v).unwrap())
    .collect();
    let mut rng = StdRng::seed_from_u64(20);
    let mut failures = Vec::new();
    let mut read = 0;
    for round in 0..MUTATIONS {
        let mut mutated = json.clone();
        for _ in 0..rng.random_range(1..4) {
            let field = &fields[rng.random_range(0..fields.len())];
            *mutated.pointer_mut(field).unwrap() = values[rng.random_range(0..values.len())].clone();
        }
        let bytes = common::glb(&mutated, &bin);
        match catch_unwind(AssertUnwindSafe(|| load(&bytes))) {
            Err(_) => failures.push(format!("round {round} panicked: {mutated}")),
            // The mesh file and the part of it at fault, or for what is wrong with its placed
            // faces the mesh object.
            Ok(Err(e)) if !located(&e.to_string()) => {
                failures.push(format!("round {round}: the error does not say where the fault is: {e}"));
            }
            Ok(Ok(_)) => read += 1,
            Ok(Err(_)) => {}
        }
    }
    // Mutations that leave the file readable reach every reader past the parse (272 of 2500
    // when written).
    assert!(
        read > MUTATIONS / 20,
        "only {read} of {MUTATIONS} mutated files were read"
    );
    assert!(
        failures.is_empty(),
        "{} of {MUTATIONS}:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Seeded token and byte edits of a textured ASCII PLY (face `texcoord` lists, `texnumber`,
/// `comment TextureFile`, float colours) and of an OBJ's MTL (`map_Kd` options, colours):
/// loading never panics, and every refusal is located.
#[test]
fn mutated_text_meshes_never_panic() {
    let folder = tempfile::tempdir().unwrap();
    let png = two_texel_png();
    std::fs::write(folder.path().join("tiles.png"), png).unwrap();
    let ply = "ply\nformat ascii 1.0\ncomment TextureFile tiles.png\nelement vertex 4\nproperty float x\n\
               property float y\nproperty float z\nproperty float red\nproperty float green\nproperty float blue\n\
               element face 2\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\n\
               property int texnumber\nend_header\n0 0 0 1 0 0\n1 0 0 0 1 0\n1 1 0 0 0 1\n0 1 0.5 0.5 0.5 0.5\n\
               3 0 1 2 6 0 0 1 0 1 1 0\n4 0 2 3 1 8 0 0 1 1 0 1 0.5 0.5 0\n";
    let obj = "mtllib mesh.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0.5\nvt 0 0\nvt 1 0\nvt 1 1 0\nvt 0 1\n\
               usemtl tiles\nf -4/-4 -3/-3 -2/-2 -1/-1\nf 1/1 2/2 3/3\n";
    let mtl = "newmtl tiles\nKd 1 0.5 0.25\nmap_Kd -s 2 2 1 -o 0.5 0.25 -clamp on -bm 0.5 tiles.png\n";
    let mut rng = StdRng::seed_from_u64(21);
    let mut failures = Vec::new();
    // The OBJ and its MTL are edited in turn, each as often as the PLY.
    for (file, text, beside) in [("mesh.ply", ply, None), ("mesh.obj", obj, Some(mtl))] {
        let rounds = if beside.is_some() {
            2 * MUTATIONS / 5
        } else {
            MUTATIONS / 5
        };
        for round in 0..rounds {
            let edit = |text: &str, rng: &mut StdRng| {
                if rng.random_bool(0.5) {
                    mutate_tokens(text, rng)
                } else {
                    mutate_bytes(text, rng)
                }
            };
            let (text, mtl) = match beside {
                Some(mtl) if round % 2 == 0 => (text.to_string(), edit(mtl, &mut rng)),
                Some(_) | None => (edit(text, &mut rng), mtl.to_string()),
            };
            std::fs::write(folder.path().join(file), &text).unwrap();
            std::fs::write(folder.path().join("mesh.mtl"), &mtl).unwrap();
            let scene =
                format!(r#"Scene(name: "fuzz", objects: [Mesh(name: "m", path: "{file}", colour: (9, 9, 9))])"#);
            let loaded = catch_unwind(AssertUnwindSafe(|| {
                Scene::from_ron(&scene, &folder.path().join("fuzz.ron"))
            }));
            match loaded {
                Err(_) => failures.push(format!("{file} round {round} panicked:\n{text}\n{mtl}")),
                Ok(Err(e)) if !e.to_string().contains(file) && !e.to_string().contains("object 'm'") => {
                    failures.push(format!(
                        "{file} round {round}: the error names neither file nor object: {e}"
                    ));
                }
                Ok(_) => {}
            }
        }
    }
    assert!(failures.is_empty(), "{}:\n{}", failures.len(), failures.join("\n"));
}
