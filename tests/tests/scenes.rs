//! Scene files: the shipped rooms load as closed rooms, library objects become the faces they
//! describe, meshes load from PLY and OBJ, and bad files are refused with file, line, object.

mod common;

use std::path::Path;

use glam::dvec3;
use omnisim::{Scene, SceneError};

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::from_ron(text, Path::new("test.ron"))
}

#[test]
fn shipped_rooms_load_with_distinct_objects() {
    for room in common::ROOMS {
        let scene = common::load(room);
        assert!(scene.objects.len() >= 12, "{room}");
        assert!(scene.warnings.is_empty());
        let colours: std::collections::HashSet<_> = scene.faces.iter().map(|f| f.colour).collect();
        assert!(colours.len() >= 12, "{room} has only {} colours", colours.len());
    }
}

#[test]
fn box_becomes_six_faces_at_its_pose() {
    let scene = parse(
        r#"Scene(name: "t", objects: [
            Box(name: "b", size: (2.0, 1.0, 0.5), position: (1.0, 0.0, 0.0), rotation: (0.0, 0.0, 90.0),
                colour: (1, 2, 3), faces: { "top": (9, 9, 9) }),
        ])"#,
    )
    .unwrap();
    assert_eq!(scene.faces.len(), 6);
    let (lo, hi) = scene.bounds().unwrap();
    // Turned 90° about z: l1 = 2 now runs along y.
    assert!((lo - dvec3(0.5, -1.0, 0.0)).length() < 1e-12 && (hi - dvec3(1.5, 1.0, 0.5)).length() < 1e-12);
    let top = scene.faces.iter().find(|f| f.colour == [9, 9, 9]).unwrap();
    assert!(top.vertices.iter().all(|v| (v.z - 0.5).abs() < 1e-12));
    assert_eq!(scene.faces.iter().filter(|f| f.colour == [1, 2, 3]).count(), 5);
}

#[test]
fn meshes_load_from_ply_and_obj_with_colours_and_transform() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("quad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 10 20 30\n1 0 0 10 20 30\n1 1 0 10 20 30\n0 1 0 10 20 30\n4 0 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    )
    .unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(
        &path,
        r#"Scene(name: "meshes", objects: [
            Mesh(name: "quad", path: "quad.ply", colour: (1, 1, 1), scale: 2.0, position: (0.0, 0.0, 1.0)),
            Mesh(name: "tri", path: "tri.obj", colour: (5, 6, 7), rotation: (90.0, 0.0, 0.0)),
        ])"#,
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap();
    // The OBJ's second triangle has its corners on one line: dropped, with a warning.
    assert_eq!(scene.faces.len(), 3);
    assert_eq!(
        scene.warnings,
        vec!["mesh 'tri': dropped 1 degenerate triangles".to_string()]
    );
    assert_eq!(scene.faces[0].colour, [10, 20, 30]);
    assert!(scene.faces[0].vertices.iter().all(|v| v.z == 1.0 && v.x <= 2.0));
    assert_eq!(scene.faces[2].colour, [5, 6, 7]);
    // Rx(90°) takes the OBJ's +y corner to +z.
    assert!((scene.faces[2].vertices[2] - dvec3(0.0, 0.0, 1.0)).length() < 1e-12);
}

fn error_of(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

#[test]
fn bad_scenes_are_refused_naming_file_line_and_object() {
    let malformed = error_of(
        "Scene(name: \"t\", objects: [\n  Wall(name: \"w\", from: (0.0, 0.0) to: (1.0, 0.0), height: 1.0, colour: (1,1,1)),\n])",
    );
    assert!(
        malformed.starts_with("test.ron:2:") && malformed.contains("object 'w'"),
        "{malformed}"
    );

    let unknown = error_of(
        "Scene(name: \"t\", objects: [\n  Floor(name: \"f\", corners: [(0.0,0.0),(1.0,0.0),(1.0,1.0)], color: (1,1,1)),\n])",
    );
    assert!(
        unknown.starts_with("test.ron:2:") && unknown.contains("color") && unknown.contains("object 'f'"),
        "{unknown}"
    );

    let nan = error_of(
        "Scene(name: \"t\", objects: [\n\n  Box(name: \"crate\", size: (1.0, NaN, 1.0), colour: (1,1,1)),\n])",
    );
    assert!(
        nan.starts_with("test.ron:3:7: object 'crate'") && nan.contains("positive finite"),
        "{nan}"
    );

    let degenerate = error_of(
        "Scene(name: \"t\", objects: [\n  Polygon(name: \"line\", vertices: [(0.0,0.0,0.0),(1.0,0.0,0.0),(2.0,0.0,0.0)], colour: (1,1,1)),\n])",
    );
    assert!(
        degenerate.starts_with("test.ron:2:11: object 'line'") && degenerate.contains("degenerate"),
        "{degenerate}"
    );

    let bent = error_of(
        "Scene(name: \"t\", objects: [\n  Polygon(name: \"bent\", vertices: [(0.0,0.0,0.0),(1.0,0.0,0.0),(1.0,1.0,0.0),(0.0,1.0,0.1)], colour: (1,1,1)),\n])",
    );
    assert!(bent.contains("object 'bent'") && bent.contains("not planar"), "{bent}");

    let colour = error_of(
        "Scene(name: \"t\", objects: [\n  Floor(name: \"f\", corners: [(0.0,0.0),(1.0,0.0),(1.0,1.0)], colour: (300,1,1)),\n])",
    );
    assert!(
        colour.starts_with("test.ron:2:") && colour.contains("object 'f': colour:"),
        "{colour}"
    );

    let mesh = error_of(
        "Scene(name: \"t\", objects: [\n  Mesh(name: \"statue\", path: \"missing.ply\", colour: (1,1,1)),\n])",
    );
    assert!(
        mesh.contains("test.ron:2:8: object 'statue'") && mesh.contains("missing.ply") && mesh.contains("not found"),
        "{mesh}"
    );

    let duplicate = error_of(
        "Scene(name: \"t\", objects: [\n  Wall(name: \"w\", from: (0.0,0.0), to: (1.0,0.0), height: 1.0, colour: (1,1,1)),\n  Wall(name: \"w\", from: (0.0,0.0), to: (0.0,1.0), height: 1.0, colour: (1,1,1)),\n])",
    );
    assert!(duplicate.contains("unique"), "{duplicate}");
}

/// README's scene example is real: it loads from `scenes/`, statue mesh included.
#[test]
fn readme_scene_example_loads() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let start = readme.find("```ron\n").expect("README has a RON example") + "```ron\n".len();
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    let scene = Scene::from_ron(example, &common::scene_path("readme-example.ron"))
        .unwrap_or_else(|e| panic!("README's example: {e}"));
    let statue = scene.objects.iter().position(|o| o.name == "statue").expect("statue") as u32;
    let triangles = scene.faces.iter().filter(|f| f.object == statue).count();
    assert!((300..=2000).contains(&triangles), "statue of {triangles} triangles");
    let top = scene
        .faces
        .iter()
        .filter(|f| f.object == statue)
        .flat_map(|f| f.vertices.iter().map(|v| v.z))
        .fold(f64::MIN, f64::max);
    assert!(
        (1.6..1.8).contains(&top),
        "the statue (millimetres scaled to metres) stands {top} m tall"
    );
}

/// Memory limits scene size (docs/benchmarks.md: ≤ 300 bytes per triangle at 5 M triangles):
/// a mesh triangle holds its three corners inline, with no heap allocation of its own.
#[test]
fn mesh_triangles_hold_their_vertices_inline() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let start = readme.find("```ron\n").expect("README has a RON example") + "```ron\n".len();
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    let scene = Scene::from_ron(example, &common::scene_path("readme-example.ron")).unwrap();
    let statue = scene.objects.iter().position(|o| o.name == "statue").unwrap() as u32;
    let mesh: Vec<_> = scene.faces.iter().filter(|f| f.object == statue).collect();
    assert!(mesh.iter().all(|f| f.vertices.len() == 3 && !f.vertices.spilled()));
    assert!(std::mem::size_of::<omnisim::scene::Face>() <= 88);
}
