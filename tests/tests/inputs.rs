//! Hostile and huge inputs: scene names that would write outside the output folder, special
//! files, mesh files that are not meshes, coordinates beyond what f32 and f64 handle, and
//! scenes large enough to expose quadratic validation. Each is refused clearly or handled,
//! quickly, never with a panic.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use omnisim::advanced::SceneBvh;
use omnisim::{Scene, SceneError};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

/// Runs `f` on another thread and fails the test if it takes longer than `limit` (a FIFO that
/// is opened blocks forever: the test must fail, not hang).
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (send, receive) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = send.send(f());
    });
    receive.recv_timeout(limit).expect("finished in time")
}

fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success());
}

fn scene_in(dir: &Path, objects: &str) -> PathBuf {
    let path = dir.join("scene.ron");
    std::fs::write(&path, format!("Scene(name: \"s\", objects: [\n{objects}\n])")).unwrap();
    path
}

#[test]
fn crashing_inputs_found_by_review_are_refused_with_their_position() {
    for (file, expected) in [
        (
            "earcut-collinear-at-max-f64.ron",
            ":2:13: object 'line': Polygon: vertex 0 is 1.798e308 m",
        ),
        (
            "bvh-coordinate-1e39.ron",
            ":2:10: object 'far wall': Wall: vertex 1 is 1.000e39 m",
        ),
        (
            "collinear-at-1e30.ron",
            ":2:13: object 'line': Polygon: vertex 0 is 1.000e30 m",
        ),
        (
            "triangle-at-1e30.ron",
            ":2:13: object 'triangle': Polygon: vertex 0 is 1.000e30 m",
        ),
        (
            "square-at-1e308.ron",
            ":2:11: object 'square': Floor: vertex 0 is 1.000e308 m",
        ),
        ("name-escapes-out.ron", ":1:7: the scene name '../escaped' contains '/'"),
    ] {
        let error = Scene::load(fixture(file)).unwrap_err().to_string();
        assert!(error.contains(expected), "{file}: {error}");
    }
}

#[test]
fn validation_is_scale_aware_within_the_coordinate_limit() {
    // A 1 mm triangle 990 km from the origin is a face; a collinear one is not.
    let at = |vertices: &str| {
        Scene::from_ron(
            &format!("Scene(name: \"s\", objects: [Polygon(name: \"p\", vertices: [{vertices}], colour: (1, 1, 1))])"),
            Path::new("far.ron"),
        )
    };
    let scene = at("(990000.0, 5.0, 0.0), (990000.001, 5.0, 0.0), (990000.0, 5.0, 0.001)").unwrap();
    let bvh = SceneBvh::build(&scene).unwrap();
    assert_eq!(bvh.triangles().len(), 1);
    let error = at("(990000.0, 5.0, 0.0), (990000.001, 5.0, 0.0), (990000.002, 5.0, 0.0)").unwrap_err();
    assert!(error.to_string().contains("degenerate"), "{error}");
    // A square of 1.9e6 m side centred on the origin is within ±1e6 m and simple.
    let square = "(-950000.0, -950000.0, 0.0), (950000.0, -950000.0, 0.0), (950000.0, 950000.0, 0.0), (-950000.0, 950000.0, 0.0)";
    assert!(at(square).is_ok());
}

#[test]
fn hostile_scene_names_are_refused_on_load() {
    let long = "a".repeat(101);
    for name in [
        "../escaped",
        "/tmp/abs",
        "a\\\\b",
        "a\\u{0}b",
        "",
        ".hidden",
        "tab\\there",
        long.as_str(),
    ] {
        let text = format!(
            "Scene(\n  name: \"{name}\",\n  objects: [Wall(name: \"w\", from: (0.0, 0.0), to: (1.0, 0.0), height: 1.0, colour: (1, 1, 1))])"
        );
        let error = Scene::from_ron(&text, Path::new("n.ron")).unwrap_err();
        assert!(
            matches!(error, SceneError::Parse { line: 2, column: 3, .. }) && error.to_string().contains("scene name"),
            "{name}: {error}"
        );
    }
}

#[test]
fn fifos_and_devices_are_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let pipe = dir.path().join("pipe.ply");
    mkfifo(&pipe);
    let scene_pipe = dir.path().join("scene-pipe.ron");
    mkfifo(&scene_pipe);
    let obj = dir.path().join("m.obj");
    mkfifo(&dir.path().join("m.mtl"));
    std::fs::write(&obj, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n").unwrap();
    let dir_path = dir.path().to_path_buf();
    let (scene_error, mesh_error, obj_scene) = within(Duration::from_secs(20), move || {
        let scene_error = Scene::load(&scene_pipe).unwrap_err().to_string();
        let mesh = scene_in(&dir_path, "Mesh(name: \"m\", path: \"pipe.ply\", colour: (1, 1, 1)),");
        let mesh_error = Scene::load(&mesh).unwrap_err().to_string();
        let obj = scene_in(&dir_path, "Mesh(name: \"m\", path: \"m.obj\", colour: (1, 2, 3)),");
        (scene_error, mesh_error, Scene::load(&obj))
    });
    assert!(
        scene_error.contains("is a FIFO (named pipe), not a regular file"),
        "{scene_error}"
    );
    assert!(mesh_error.contains("pipe.ply is a FIFO"), "{mesh_error}");
    // The OBJ's material file (a FIFO here) is checked before it is opened: refused, not waited on.
    let obj_error = obj_scene.unwrap_err().to_string();
    assert!(obj_error.contains("m.mtl is a FIFO"), "{obj_error}");
    let error = Scene::load("/dev/zero").unwrap_err().to_string();
    assert!(error.contains("is a device"), "{error}");
}

#[test]
fn meshes_are_read_only_from_the_scene_folder() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(dir.path().join("sub/t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let ok = scene_in(dir.path(), "Mesh(name: \"m\", path: \"sub/t.obj\", colour: (1, 1, 1)),");
    assert_eq!(Scene::load(&ok).unwrap().faces.len(), 1);
    for path in ["../t.obj", "/etc/passwd", "sub/../../t.obj", ""] {
        let bad = scene_in(
            dir.path(),
            &format!("Mesh(name: \"m\", path: \"{path}\", colour: (1, 1, 1)),"),
        );
        let error = Scene::load(&bad).unwrap_err().to_string();
        assert!(
            error.contains("must be relative to the scene file's folder"),
            "{path}: {error}"
        );
    }
}

#[test]
fn mesh_errors_give_the_position_not_the_contents() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("secret.ply"),
        "root:x:0:0:secret-password:/root:/bin/bash\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("bad-data.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 secret-password\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("empty.obj"), "# nothing\n").unwrap();
    for (file, expected) in [
        ("secret.ply", "line 1: expected a PLY header"),
        (
            "bad-data.ply",
            "line 11: the data of element 'vertex' does not match what the header declares",
        ),
        ("empty.obj", "the mesh has no triangles"),
    ] {
        let scene = scene_in(
            dir.path(),
            &format!("Mesh(name: \"m\", path: \"{file}\", colour: (1, 1, 1)),"),
        );
        let error = Scene::load(&scene).unwrap_err().to_string();
        assert!(
            error.contains(expected) && !error.contains("secret-password"),
            "{file}: {error}"
        );
    }
}

#[test]
fn validation_is_near_linear() {
    // 64k vertices on a circle: one face (quadratic checks took 31 s).
    let n = 65_536;
    let vertices: Vec<String> = (0..n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            format!("({}, {}, 1.0)", 10.0 * a.cos(), 10.0 * a.sin())
        })
        .collect();
    let polygon = |vertices: &[String]| {
        format!(
            "Scene(name: \"s\", objects: [Polygon(name: \"disc\", vertices: [{}], colour: (1, 1, 1))])",
            vertices.join(", ")
        )
    };
    let started = Instant::now();
    let scene = Scene::from_ron(&polygon(&vertices), Path::new("disc.ron")).unwrap();
    assert_eq!(scene.faces[0].vertices.len(), n);
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    // Two vertices swapped far apart: the outline crosses itself, found as fast.
    let mut crossed = vertices.clone();
    crossed.swap(100, 40_000);
    let started = Instant::now();
    let error = Scene::from_ron(&polygon(&crossed), Path::new("disc.ron")).unwrap_err();
    assert!(error.to_string().contains("crosses itself"), "{error}");
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());

    // 100,000 boxes (quadratic checks took 98 s).
    let boxes: Vec<String> = (0..100_000)
        .map(|i| {
            format!(
                "Box(name: \"b{i}\", size: (0.5, 0.5, 0.5), position: ({}, {}, 0.0), colour: (1, 1, 1))",
                i % 400,
                i / 400
            )
        })
        .collect();
    let text = format!("Scene(name: \"s\", objects: [{}])", boxes.join(",\n"));
    let started = Instant::now();
    let scene = Scene::from_ron(&text, Path::new("boxes.ron")).unwrap();
    assert_eq!(scene.faces.len(), 600_000);
    assert!(started.elapsed() < Duration::from_secs(30), "{:?}", started.elapsed());
}
