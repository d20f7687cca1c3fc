//! The library's output set: a frame's entry lists exactly the files written for it, the run
//! files complete the folder, and render.json keeps the field names its readers use.

mod common;

use std::collections::BTreeSet;
use std::path::PathBuf;

use glam::dvec3;
use omnisim::camera::{Pinhole, StereoRig};
use omnisim::metadata::BackendMetadata;
use omnisim::output::FrameTarget;
use omnisim::output::folder::{MANIFEST_NAME, RunFolder};
use omnisim::{BackendChoice, Camera, OutputSet, Planes, Pose, RenderMetadata, Renderer, Rig};

fn everything() -> OutputSet {
    OutputSet {
        segmentation: true,
        normals: true,
        linear: true,
        ..OutputSet::default()
    }
}

#[test]
fn frame_entries_and_run_files_account_for_every_file_in_the_folder() {
    let scene = common::load("env1.ron");
    let rig = Rig::Stereo(StereoRig::rectified(
        Pinhole::with_horizontal_fov(32, 24, 70f64.to_radians()),
        0.12,
    ));
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let outputs = everything();
    let out = tempfile::tempdir().unwrap();
    let mut folder = RunFolder::open(out.path(), "test", "test", false).unwrap();
    let mut metadata = RenderMetadata::new(&scene, &rig, BackendMetadata::of(&renderer, &prepared));
    let poses = [
        Pose::from_degrees(dvec3(0.0, 0.0, 0.4), dvec3(0.0, 0.0, 30.0)),
        Pose::from_degrees(dvec3(1.0, -0.5, 0.2), dvec3(0.0, 10.0, -45.0)),
    ];
    for (index, pose) in poses.iter().enumerate() {
        let frames: Vec<_> = rig
            .views()
            .iter()
            .map(|view| {
                renderer
                    .render(&prepared, &view.camera, pose, outputs.planes())
                    .unwrap()
            })
            .collect();
        let target = FrameTarget {
            scene: &scene.name,
            index,
            pose,
        };
        metadata
            .write_frame(&outputs, &mut folder, &target, &rig, &frames)
            .unwrap();
    }
    let run_files = metadata.write_run_files(&outputs, &mut folder, &scene, &rig).unwrap();
    folder.finish().unwrap();

    // Per view: png, range, depth png + exr, object, face, normal, linear, ply; plus disparity.
    let first = &metadata.frames[0];
    assert_eq!(first.stem, "env1-0000");
    assert_eq!(first.files.len(), 2 * 9 + 1, "{:?}", first.files);
    for name in [
        "env1-0000-left.png",
        "env1-0000-right-face.png",
        "env1-0000-disparity.exr",
    ] {
        assert!(first.files.contains(&PathBuf::from(name)), "{name} not listed");
    }
    let listed: BTreeSet<PathBuf> = metadata
        .frames
        .iter()
        .flat_map(|f| f.files.iter().cloned())
        .chain(
            run_files
                .iter()
                .map(|p| p.strip_prefix(out.path()).unwrap().to_path_buf()),
        )
        .collect();
    // Everything but the run folder's own manifest.
    let present: BTreeSet<PathBuf> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| PathBuf::from(e.unwrap().file_name()))
        .filter(|name| name.as_os_str() != MANIFEST_NAME)
        .collect();
    assert_eq!(listed, present);
    for name in [
        "calibration-opencv-stereo.yaml",
        "raymap-right-origin.exr",
        "raymap-right-direction.exr",
        "raymap-right-all.exr",
        "segmentation.json",
        "poses.txt",
        "render.json",
    ] {
        assert!(present.contains(&PathBuf::from(name)), "{name} missing");
    }
    let poses_txt = std::fs::read_to_string(out.path().join("poses.txt")).unwrap();
    let [qx, qy, qz, qw] = poses[1].quaternion_xyzw();
    assert_eq!(
        poses_txt.lines().nth(2).unwrap(),
        format!("1 1 -0.5 0.2 {qx} {qy} {qz} {qw}")
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("render.json")).unwrap()).unwrap();
    assert_eq!(json["frames"][1]["files"].as_array().unwrap().len(), 19);
    assert_eq!(json["camera"]["right"]["position_in_body"][1], -0.06);
}

/// The keys of a JSON object, sorted.
fn keys(value: &serde_json::Value) -> Vec<&str> {
    let mut keys: Vec<&str> = value
        .as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    keys
}

#[test]
fn render_json_keeps_the_field_names_of_its_readers() {
    let scene = common::load("env1.ron");
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let rig = Rig::Single(Camera::Catadioptric(common::paper_omni()));
    let mut metadata = RenderMetadata::new(&scene, &rig, BackendMetadata::of(&renderer, &prepared));
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    metadata.frames.push(omnisim::metadata::FrameMetadata::new(
        0,
        "env1-0000".into(),
        &pose,
        Vec::new(),
    ));
    let json = serde_json::to_value(&metadata).unwrap();
    assert_eq!(
        keys(&json),
        ["backend", "camera", "conventions", "frames", "omnisim", "scene"]
    );
    assert_eq!(keys(&json["scene"]), ["faces", "file", "name"]);
    assert_eq!(json["scene"]["faces"], scene.faces.len());
    assert_eq!(json["backend"]["name"], "cpu");
    assert_eq!(
        keys(&json["camera"]),
        [
            "body_origin_in_mirror_frame",
            "central",
            "cx",
            "cy",
            "focal",
            "height",
            "hidden_centre_px",
            "image_azimuth",
            "mirror",
            "mirror_rays",
            "misalignment",
            "model",
            "mount",
            "rays",
            "rim_radius",
            "unified_model",
            "width"
        ]
    );
    assert_eq!(json["camera"]["model"], "hyperbolic-catadioptric");
    assert_eq!(keys(&json["camera"]["mirror"]), ["a", "b", "c", "shape"]);
    assert_eq!(
        keys(&json["camera"]["unified_model"]),
        ["gamma_x", "gamma_y", "projection", "xi"]
    );
    assert_eq!(json["camera"]["mount"], "Up");
    assert_eq!(
        keys(&json["conventions"]),
        [
            "body",
            "depth",
            "pixels",
            "point_cloud",
            "range",
            "ray_map",
            "rotation",
            "units",
            "world"
        ]
    );
    let frame = &json["frames"][0];
    assert_eq!(
        keys(frame),
        [
            "angles_deg",
            "files",
            "index",
            "position",
            "quaternion_xyzw",
            "stem",
            "world_from_body"
        ]
    );
    assert!((frame["angles_deg"][2].as_f64().unwrap() - 60.0).abs() < 1e-12);
    // Row-major 4×4: the translation is the last column.
    assert_eq!(frame["world_from_body"][0][3], 1.5);
    assert_eq!(frame["world_from_body"][3], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
}

#[test]
fn segmentation_without_the_object_plane_is_refused_not_written_blank() {
    let scene = common::load("env1.ron");
    let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
    let prepared = renderer.prepare(&scene).unwrap();
    let rig = Rig::Single(Camera::Pinhole(Pinhole::with_horizontal_fov(16, 12, 1.0)));
    let pose = Pose::from_degrees(dvec3(0.0, 0.0, 0.4), dvec3(0.0, 0.0, 0.0));
    let frame = renderer
        .render(&prepared, &rig.first_camera(), &pose, Planes::COLOUR)
        .unwrap();
    let out = tempfile::tempdir().unwrap();
    let mut folder = RunFolder::open(out.path(), "test", "test", false).unwrap();
    let target = FrameTarget {
        scene: "t",
        index: 0,
        pose: &pose,
    };
    let error = everything()
        .write_frame_files(&mut folder, &target, &rig, &[frame])
        .unwrap_err();
    assert!(error.to_string().contains("no object plane"), "{error}");
    assert!(error.path.ends_with("t-0000-object.png"));
}
