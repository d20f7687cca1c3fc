//! Output files read back by independent readers (png, exr, ply-rs, tobj) equal what was
//! rendered or exported.

mod common;

use glam::dvec3;
use omnisim::advanced::SceneBvh;
use omnisim::output::ExrCompression;
use omnisim::output::store::Synced;
use omnisim::scene::ExportFormat;
use omnisim::{Pose, advanced as trace, output};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};

fn rendered() -> omnisim::Frame {
    let scene = common::load("env1.ron");
    let camera = omnisim::Camera::Catadioptric(common::paper_omni());
    let frame = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap())
        .render(
            &camera,
            &Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0)),
        )
        .unwrap();
    assert!(
        frame.hit_count() > 0 && frame.hit_count() < frame.pixels().len(),
        "omni image has mirror and background"
    );
    frame
}

fn float(p: &Property) -> f32 {
    match p {
        Property::Float(v) => *v,
        other => panic!("expected float, got {other:?}"),
    }
}

fn uchar(p: &Property) -> u8 {
    match p {
        Property::UChar(v) => *v,
        other => panic!("expected uchar, got {other:?}"),
    }
}

#[test]
fn png_reads_back_pixel_for_pixel() {
    let frame = rendered();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("colour.png");
    output::write_png(&mut Synced, &path, &frame).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut bytes).unwrap();
    assert_eq!((info.width, info.height), (frame.width, frame.height));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let expected: Vec<u8> = frame.colour().unwrap().iter().flatten().copied().collect();
    assert_eq!(&bytes[..info.buffer_size()], &expected[..]);
}

#[test]
fn exr_range_reads_back_bit_for_bit_with_infinity_for_misses() {
    let frame = rendered();
    let dir = tempfile::tempdir().unwrap();
    for (compression, stored) in [
        (ExrCompression::Zip, exr::prelude::Compression::ZIP16),
        (ExrCompression::Rle, exr::prelude::Compression::RLE),
        (ExrCompression::None, exr::prelude::Compression::Uncompressed),
    ] {
        let path = dir.path().join(format!("range-{compression:?}.exr"));
        output::write_range_exr(
            &mut Synced,
            &path,
            &frame,
            &omnisim::Camera::Catadioptric(common::paper_omni()),
            compression,
        )
        .unwrap();
        check_range_exr(&path, &frame, stored);
    }
}

/// A range image that hits nothing: one constant plane (+inf), whose RLE blocks (one scan line
/// each) run through their even bytes and end in a literal. Written with RLE by omnisim's own
/// encoder, 250 and 33 pixels wide, into `dir`; returns the files and their frames.
fn constant_range_exrs(dir: &std::path::Path) -> Vec<(std::path::PathBuf, omnisim::Frame)> {
    [(250, 250), (33, 3)]
        .into_iter()
        .map(|(width, height)| {
            let frame = omnisim::Frame::empty(width, height);
            let path = dir.join(format!("nothing-{width}x{height}.exr"));
            output::write_range_exr(
                &mut Synced,
                &path,
                &frame,
                &omnisim::Camera::Catadioptric(common::paper_omni()),
                ExrCompression::Rle,
            )
            .unwrap();
            (path, frame)
        })
        .collect()
}

#[test]
fn a_range_exr_that_hits_nothing_reads_back_as_infinity() {
    let dir = tempfile::tempdir().unwrap();
    for (path, frame) in constant_range_exrs(dir.path()) {
        check_range_exr(&path, &frame, exr::prelude::Compression::RLE);
    }
}

/// `OpenEXR` (the reference library, through its Python binding) reads the constant planes of
/// [`constant_range_exrs`] as RLE files of +inf, bit for bit (`tests/readers/check_infinite_range_exr.py`).
#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn openexr_reads_a_range_exr_that_hits_nothing_as_infinity() {
    let python = std::env::var_os("OMNISIM_PYTHON")
        .expect("OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (README, Tests)");
    let dir = tempfile::tempdir().unwrap();
    let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let mut command = std::process::Command::new(python);
    command
        .arg("tests/readers/check_infinite_range_exr.py")
        .arg(output::VALUE_CHANNEL)
        .current_dir(workspace);
    for (path, frame) in constant_range_exrs(dir.path()) {
        command
            .arg(&path)
            .arg(frame.width.to_string())
            .arg(frame.height.to_string());
    }
    let run = command.output().expect("Python runs");
    assert!(
        run.status.success(),
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
}

/// The range EXR at `path` holds `frame`'s ranges bit for bit, compressed as `compression`.
fn check_range_exr(path: &std::path::Path, frame: &omnisim::Frame, compression: exr::prelude::Compression) {
    let image = common::read_exr(path);
    let layer = &image.layer_data[0];
    assert_eq!(layer.size.0, frame.width as usize);
    let comments = layer
        .attributes
        .comments
        .as_ref()
        .map(std::string::ToString::to_string)
        .unwrap_or_default();
    assert!(comments.contains("metres") && comments.contains("+inf"), "{comments}");
    let quantity = layer
        .attributes
        .other
        .get(&exr::prelude::Text::from(output::QUANTITY_ATTRIBUTE));
    assert!(
        matches!(quantity, Some(exr::prelude::AttributeValue::Text(t)) if t.eq("range")),
        "{quantity:?}"
    );
    assert_eq!(layer.encoding.compression, compression);
    // Blocks in a fixed order: the bytes depend on the values only.
    assert_eq!(layer.encoding.line_order, exr::prelude::LineOrder::Increasing);
    let channel = &layer.channel_data.list[0];
    assert_eq!(channel.name.to_string(), output::VALUE_CHANNEL);
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    assert_eq!(values.len(), frame.pixels().len());
    for (value, pixel) in values.iter().zip(frame.pixels()) {
        assert_eq!(value.to_bits(), pixel.range.to_bits());
        assert_eq!(value.is_infinite(), !pixel.is_hit());
    }
}

#[test]
fn ply_point_cloud_reads_back_point_for_point() {
    let frame = rendered();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cloud.ply");
    output::write_point_cloud_ply(&mut Synced, &path, &frame, "pose θx=30°").unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let header_end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
    assert!(bytes[..header_end].is_ascii(), "PLY headers are ASCII");
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut std::io::BufReader::new(std::fs::File::open(&path).unwrap()))
        .unwrap();
    assert_eq!(ply.header.encoding, ply_rs_bw::ply::Encoding::BinaryLittleEndian);
    let vertices = &ply.payload["vertex"];
    let hits: Vec<_> = frame
        .pixels()
        .iter()
        .zip(frame.colour().unwrap())
        .filter(|(p, _)| p.is_hit())
        .collect();
    assert_eq!(vertices.len(), hits.len());
    for (vertex, (pixel, colour)) in vertices.iter().zip(hits) {
        assert_eq!(float(&vertex["x"]), pixel.point.x as f32);
        assert_eq!(float(&vertex["y"]), pixel.point.y as f32);
        assert_eq!(float(&vertex["z"]), pixel.point.z as f32);
        assert_eq!(
            [uchar(&vertex["red"]), uchar(&vertex["green"]), uchar(&vertex["blue"])],
            *colour
        );
    }
}

#[test]
fn exported_scene_has_every_triangle_and_colour() {
    let scene = common::load("env2.ron");
    let triangles = scene.triangulate();
    let dir = tempfile::tempdir().unwrap();

    let ply_path = dir.path().join("env2.ply");
    scene.export(&ply_path, ExportFormat::Ply).unwrap();
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut std::io::BufReader::new(std::fs::File::open(&ply_path).unwrap()))
        .unwrap();
    let vertices = &ply.payload["vertex"];
    assert_eq!(ply.payload["face"].len(), triangles.len());
    assert_eq!(vertices.len(), 3 * triangles.len());
    for (i, (corners, face)) in triangles.corners.iter().zip(&triangles.face).enumerate() {
        for (k, corner) in corners.iter().enumerate() {
            let v = &vertices[3 * i + k];
            assert_eq!(float(&v["x"]), corner.x as f32);
            assert_eq!(float(&v["z"]), corner.z as f32);
            assert_eq!(uchar(&v["green"]), scene.faces[*face as usize].colour[1]);
        }
    }

    let obj_path = dir.path().join("env2.obj");
    scene.export(&obj_path, ExportFormat::Obj).unwrap();
    let (models, _) = tobj::load_obj(
        &obj_path,
        &tobj::LoadOptions {
            triangulate: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(models.len(), scene.objects.len());
    let total: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    assert_eq!(total, triangles.len());
    let first = &models[0].mesh;
    let colour = scene.faces[0].colour.map(|c| f32::from(c) / 255.0);
    assert!((first.vertex_color[0] - colour[0]).abs() < 1e-6);
}

#[test]
fn failed_write_leaves_nothing_behind() {
    let frame = rendered();
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no such folder").join("colour.png");
    assert!(output::write_png(&mut Synced, &missing, &frame).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn tum_depth_png_holds_z_times_5000_and_zero_for_misses() {
    let scene = common::load("env1.ron");
    let bvh = SceneBvh::build(&scene).unwrap();
    let pinhole = omnisim::camera::Pinhole::with_horizontal_fov(160, 120, 90f64.to_radians());
    let pose = Pose::from_degrees(dvec3(-2.0, 0.3, 0.5), dvec3(0.0, 10.0, 20.0));
    let frame = trace::trace(&bvh, &omnisim::Camera::Pinhole(pinhole.clone()), &pose);
    let mut depth = pinhole.axial_depth(&frame, &pose);
    depth[0] = f32::INFINITY; // a miss
    depth[1] = 20.0; // beyond what 16 bits hold at 1/5000 m
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("depth.png");
    output::write_tum_depth_png(&mut Synced, &path, (160, 120), &depth).unwrap();
    let stored = read_png16(&path);
    assert_eq!(&stored[..2], &[0, 0]);
    for (value, z) in stored.iter().zip(&depth).skip(2) {
        assert_eq!(f64::from(*value), (f64::from(*z) * 5000.0).round(), "z = {z}");
    }
    // z is the depth along the optical axis: the hit point's optical-frame z.
    let forward = pose.world_from_body_rotation() * glam::DVec3::X;
    let pixel = frame.pixel(80, 60);
    assert!(((pixel.point - pose.position).dot(forward) - f64::from(depth[60 * 160 + 80])).abs() < 1e-6);
}

/// Every plane of the paper's omni camera in env1, rendered on the f64 CPU tracer.
fn rendered_with_every_plane(pose: &Pose) -> (omnisim::Scene, omnisim::Frame) {
    let scene = common::load("env1.ron");
    let tracer = common::cpu_tracer(&scene, &SceneBvh::build(&scene).unwrap());
    let camera = omnisim::Camera::Catadioptric(common::paper_omni());
    let frame = tracer
        .renderer
        .render(&tracer.scene, &camera, pose, omnisim::Planes::ALL)
        .unwrap();
    (scene, frame)
}

/// Values of a 16-bit grey PNG.
fn read_png16(path: &std::path::Path) -> Vec<u16> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut bytes).unwrap();
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Sixteen)
    );
    bytes[..info.buffer_size()]
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect()
}

#[test]
fn segmentation_ids_round_trip_through_png_and_legend() {
    let dir = tempfile::tempdir().unwrap();
    let mut face_of_pixel = Vec::new();
    for (index, pose) in [
        Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0)),
        Pose::from_degrees(dvec3(-1.0, 0.5, 0.2), dvec3(10.0, 0.0, -30.0)),
    ]
    .iter()
    .enumerate()
    {
        let (scene, frame) = rendered_with_every_plane(pose);
        let legend = output::SegmentationLegend::of(&scene);
        let size = (frame.width, frame.height);
        let object_path = dir.path().join(format!("{index}-object.png"));
        let face_path = dir.path().join(format!("{index}-face.png"));
        output::write_id_png(&mut Synced, &object_path, size, frame.object().unwrap()).unwrap();
        output::write_id_png(&mut Synced, &face_path, size, &output::face_ids(&frame)).unwrap();
        let (objects, faces) = (read_png16(&object_path), read_png16(&face_path));
        assert_eq!(legend.objects.len(), scene.objects.len());
        let mut seen = std::collections::BTreeSet::new();
        for ((pixel, &object), &face) in frame.pixels().iter().zip(&objects).zip(&faces) {
            assert_eq!(object == 0, !pixel.is_hit());
            assert_eq!(face == 0, !pixel.is_hit());
            if !pixel.is_hit() {
                continue;
            }
            // The face id is the scene face + 1 and lies in its object's range of the legend.
            assert_eq!(u32::from(face), pixel.face + 1);
            let entry = &legend.objects[object as usize - 1];
            assert_eq!(entry.id, u32::from(object));
            assert!((entry.first_face..=entry.last_face).contains(&u32::from(face)));
            assert_eq!(
                entry.name,
                scene.objects[scene.faces[pixel.face as usize].object as usize].name
            );
            seen.insert(object);
        }
        assert!(seen.len() >= 8, "only {} objects seen", seen.len());
        face_of_pixel.push(faces);
    }
    // The same legend serves every pose: ids are the scene's, not the frame's.
    assert_ne!(face_of_pixel[0], face_of_pixel[1]);
}

#[test]
fn normals_are_unit_face_the_camera_and_read_back_from_exr() {
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let (_, frame) = rendered_with_every_plane(&pose);
    for p in frame.pixels().iter().filter(|p| p.is_hit()) {
        assert!((p.normal.length() - 1.0).abs() < 1e-6, "{}", p.normal);
        // Central camera: the ray comes from the viewpoint, so the normal faces it.
        assert!(p.normal.as_dvec3().dot(p.point - pose.position) < 0.0);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("normal.exr");
    output::write_normal_exr(&mut Synced, &path, &frame, ExrCompression::Zip).unwrap();
    // R G B = x y z, the layout OpenCV reads; what they are is in the header.
    let (channels, quantity) = common::read_xyz_exr(&path);
    assert_eq!(quantity, "normal");
    for (axis, channel) in channels.iter().enumerate() {
        for (value, p) in channel.iter().zip(frame.pixels()) {
            if p.is_hit() {
                assert_eq!(value.to_bits(), p.normal.to_array()[axis].to_bits());
            } else {
                assert!(value.is_nan());
            }
        }
    }
}

#[test]
fn linear_colour_exr_reads_back_and_encodes_to_the_png_colour() {
    let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
    let (_, frame) = rendered_with_every_plane(&pose);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("linear.exr");
    output::write_linear_exr(&mut Synced, &path, &frame, ExrCompression::Zip).unwrap();
    let image = common::read_exr(&path);
    let channels = &image.layer_data[0].channel_data.list;
    let linear = frame.linear_colour().unwrap();
    for (k, name) in ["R", "G", "B"].iter().enumerate() {
        let channel = channels.iter().find(|c| c.name.to_string() == *name).unwrap();
        for (value, l) in channel.sample_data.values_as_f32().zip(linear) {
            assert_eq!(value.to_bits(), l[k].to_bits());
        }
    }
    for (l, c) in linear.iter().zip(frame.colour().unwrap()) {
        assert_eq!(omnisim::advanced::encode(glam::Vec3::from_array(*l).as_dvec3()), *c);
    }
}

/// Every writer, twice: the same values give the same bytes.
#[test]
fn every_file_is_byte_reproducible() {
    let frame = rendered();
    let camera = omnisim::Camera::Catadioptric(common::paper_omni());
    let dir = tempfile::tempdir().unwrap();
    let write = |n: usize| -> Vec<Vec<u8>> {
        let path = |name: &str| dir.path().join(format!("{n}-{name}"));
        let depth: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
        let size = (frame.width, frame.height);
        output::write_png(&mut Synced, &path("c.png"), &frame).unwrap();
        output::write_range_exr(&mut Synced, &path("r.exr"), &frame, &camera, ExrCompression::Zip).unwrap();
        output::write_axial_depth_exr(&mut Synced, &path("z.exr"), size, &depth, ExrCompression::Zip).unwrap();
        output::write_disparity_exr(&mut Synced, &path("d.exr"), size, &depth, ExrCompression::Zip).unwrap();
        output::write_tum_depth_png(&mut Synced, &path("z.png"), size, &depth).unwrap();
        let ray_maps = ["origin.exr", "direction.exr", "all.exr"].map(path);
        output::write_ray_map_exrs(
            &mut Synced,
            ray_maps.each_ref().map(std::path::PathBuf::as_path),
            &camera,
        )
        .unwrap();
        output::write_normal_exr(&mut Synced, &path("n.exr"), &frame, ExrCompression::Zip).unwrap();
        output::write_point_cloud_ply(&mut Synced, &path("p.ply"), &frame, "test").unwrap();
        [
            "c.png",
            "r.exr",
            "z.exr",
            "d.exr",
            "z.png",
            "origin.exr",
            "direction.exr",
            "all.exr",
            "n.exr",
            "p.ply",
        ]
        .map(|name| std::fs::read(path(name)).unwrap())
        .to_vec()
    };
    let (first, second) = (write(0), write(1));
    for (a, b) in first.iter().zip(&second) {
        assert!(a == b, "two writes of the same values differ");
    }
}

/// A link planted at any name a temporary could take is never followed, and the result is a
/// regular file even where the destination itself was a link.
#[cfg(unix)]
#[test]
fn temporary_files_never_follow_links() {
    let frame = rendered();
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim");
    std::fs::write(&victim, "precious").unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let pid = std::process::id();
    for name in [
        format!(".colour.png.partial-{pid}"),
        format!(".colour.png.partial-{}", pid + 1),
        format!("{}{pid}-", omnisim::atomic_file::TEMPORARY_PREFIX),
        "colour.png".to_string(),
    ] {
        std::os::unix::fs::symlink(&victim, out.join(name)).unwrap();
    }
    let path = out.join("colour.png");
    output::write_png(&mut Synced, &path, &frame).unwrap();
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
    assert!(std::fs::symlink_metadata(&path).unwrap().file_type().is_file());
    let temporaries = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name().to_string_lossy().into_owned();
            name.starts_with(omnisim::atomic_file::TEMPORARY_PREFIX) && !name.ends_with('-')
        })
        .count();
    assert_eq!(temporaries, 0, "no temporary left behind");
}
