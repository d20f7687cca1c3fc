//! Helpers shared by the integration tests: shipped scenes, cameras, the CPU and GPU tracers.
#![allow(dead_code)]

use std::path::PathBuf;

use glam::{DMat3, DVec3, dvec3};
use omnisim::advanced::CpuTracer;
use omnisim::advanced::SceneBvh;
use omnisim::camera::{BrownConrady, FisheyeSpec, LensCamera, LensModel, LensSpec, PinholeSpec, RigSpec};
use omnisim::camera::{Catadioptric, Cylindrical, Equirectangular, Pinhole, StereoRig};
use omnisim::camera::{MirrorShape, Misalignment, Mount};
use omnisim::scene::{Face, SceneObject};
use omnisim::{BackendChoice, Camera, Frame, Planes, Pose, PreparedScene, RenderError, Renderer, Rig, Scene};

pub(crate) fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(name)
}

pub(crate) fn load(name: &str) -> Scene {
    Scene::load(scene_path(name)).expect("shipped scene loads")
}

pub(crate) const ROOMS: [&str; 2] = ["env1.ron", "env2.ron"];

/// The paper's hyperbolic omni camera with the default 20° rim.
pub(crate) fn paper_omni() -> Catadioptric {
    Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()))
}

/// The six faces (corners in order around each) of the box `centre ± world_from_box · half`;
/// neighbouring faces share their corner vertices exactly.
pub(crate) fn box_faces(centre: DVec3, half: DVec3, world_from_box: DMat3) -> Vec<Vec<DVec3>> {
    let corner = |signs: [f64; 3]| centre + world_from_box * (half * DVec3::from_array(signs));
    let mut faces = Vec::new();
    for axis in 0..3 {
        let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [-1.0, 1.0] {
            let face = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(sj, sk)| {
                let mut signs = [0.0; 3];
                (signs[axis], signs[j], signs[k]) = (side, sj, sk);
                corner(signs)
            });
            faces.push(face.to_vec());
        }
    }
    faces
}

/// One camera of each model and option, at test-friendly sizes.
pub(crate) fn cameras() -> Vec<Camera> {
    let pinhole = Pinhole::with_horizontal_fov(320, 240, 70f64.to_radians());
    let [_, stereo_right] = StereoRig::rectified(pinhole.clone(), 0.12).pinholes();
    let mut misaligned = paper_omni();
    misaligned.misalignment = Misalignment {
        offset: dvec3(0.002, -0.001, 0.003),
        tilt: dvec3(0.01, -0.02, 0.3),
    };
    let mut turned_over = paper_omni();
    turned_over.mount = Mount::Down;
    turned_over.hidden_centre_px = 20.0;
    let mut elliptic = Catadioptric::parabolic(250, 250, 0.04, 0.02, 20f64.to_radians());
    elliptic.mirror = MirrorShape::Parabolic {
        a: 0.04,
        b: 0.05,
        h: 0.02,
    };
    // A misaligned mirror seen through a distorted lens (its rays to the mirror come from the
    // lens's inverse; the GPU reads them from the ray table), and the right eye of a fisheye pair.
    let mut lensed = misaligned.clone();
    lensed.lens = Some(Box::new(LensModel::Perspective(
        BrownConrady::new(&[-0.12, 0.03, 1e-3, -2e-3, 0.004]).expect("radtan"),
    )));
    let fisheye_pair = StereoRig {
        camera: lens_camera(&RigSpec::Fisheye(FisheyeSpec {
            size: (200, 160),
            lens: LensSpec::Equidistant,
            fov: Some(200.0),
            focal: None,
        }))
        .intrinsics,
        lens: Some(LensModel::Equidistant),
        baseline: 0.12,
    };
    let [_, fisheye_right] = fisheye_pair.cameras();
    vec![
        Camera::Pinhole(pinhole),
        Camera::Pinhole(stereo_right),
        Camera::Catadioptric(lensed),
        fisheye_right,
        Camera::Equirectangular(Equirectangular {
            width: 512,
            height: 256,
        }),
        Camera::Cylindrical(Cylindrical::with_vertical_fov(512, 128, 100f64.to_radians())),
        Camera::Catadioptric(paper_omni()),
        Camera::Catadioptric(misaligned),
        Camera::Catadioptric(turned_over),
        Camera::Catadioptric(Catadioptric::parabolic(250, 250, 0.04, 0.02, 20f64.to_radians())),
        Camera::Catadioptric(elliptic),
        Camera::Catadioptric(Catadioptric::spherical(250, 250, 0.05, 0.25)),
        lens(&RigSpec::Fisheye(FisheyeSpec {
            size: (200, 180),
            lens: LensSpec::KannalaBrandt {
                k: [0.02, -0.004, 1e-4, -2e-5],
            },
            fov: Some(230.0),
            focal: None,
        })),
        lens(&RigSpec::Fisheye(FisheyeSpec {
            size: (160, 160),
            lens: LensSpec::Unified {
                xi: 1.3,
                distortion: [-0.05, 0.01, 1e-4, -2e-4],
            },
            fov: Some(250.0),
            focal: None,
        })),
        lens(&RigSpec::Pinhole(PinholeSpec {
            size: (160, 120),
            hfov: 100.0,
            focal: None,
            distortion: Some(vec![
                -0.28, 0.07, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.005, 1e-3, -1e-3, 2e-3, 5e-4,
            ]),
        })),
    ]
}

/// The lens camera `spec` describes.
pub(crate) fn lens_camera(spec: &RigSpec) -> LensCamera {
    match spec.build().expect("a valid lens") {
        Rig::Single(Camera::Lens(lens)) => *lens,
        other => panic!("not a lens camera: {other:?}"),
    }
}

fn lens(spec: &RigSpec) -> Camera {
    Camera::Lens(Box::new(lens_camera(spec)))
}

/// Human-readable name of a camera from `cameras()`, for messages.
pub(crate) fn describe(camera: &Camera) -> String {
    match camera {
        Camera::Pinhole(p) => format!("pinhole at {}", p.position),
        Camera::Catadioptric(c) => format!(
            "{:?} mount {:?} central {} hidden {} lens {}",
            c.mirror,
            c.mount,
            c.is_central(),
            c.hidden_centre_px,
            c.lens.as_deref().map_or("none", LensModel::name)
        ),
        Camera::Lens(c) => format!("{} at {}", c.model.name(), c.intrinsics.position),
        other => other.model_name().to_string(),
    }
}

/// A renderer with one scene prepared on it.
pub(crate) struct Tracer {
    pub renderer: Renderer,
    pub scene: PreparedScene,
}

impl Tracer {
    /// Hit planes and 8-bit colour of one frame.
    pub(crate) fn render(&self, camera: &Camera, pose: &Pose) -> Result<Frame, RenderError> {
        self.render_planes(camera, pose, Planes::COLOUR)
    }

    /// Hit planes and the planes `planes` asks for.
    pub(crate) fn render_planes(&self, camera: &Camera, pose: &Pose, planes: Planes) -> Result<Frame, RenderError> {
        self.renderer.render(&self.scene, camera, pose, planes)
    }
}

/// `scene` prepared (with the BVH `bvh`) on the f64 reference CPU tracer.
pub(crate) fn cpu_tracer(scene: &Scene, bvh: &SceneBvh) -> Tracer {
    let mut renderer = Renderer::new(BackendChoice::Cpu).expect("CPU backend");
    renderer.set_cpu_tracer(CpuTracer::Reference);
    let scene = renderer.prepare_with(scene, bvh.clone()).expect("CPU scene");
    Tracer { renderer, scene }
}

/// `scene` prepared (with the BVH `bvh`) on the GPU. Tests that call it are ignored where no
/// adapter is expected (`omnisim_no_gpu`, `tests/test_cfg.rs`); where they run, none fails them.
pub(crate) fn gpu_tracer(scene: &Scene, bvh: &SceneBvh) -> Tracer {
    let renderer = Renderer::new(BackendChoice::Gpu).unwrap_or_else(|error| {
        panic!(
            "no GPU adapter opens ({error}): install a Vulkan driver (Debian: mesa-vulkan-drivers), or set \
             OMNISIM_GPU_TESTS=ignore to count the GPU tests as ignored (README, Tests)"
        )
    });
    let scene = renderer.prepare_with(scene, bvh.clone()).expect("GPU scene");
    Tracer { renderer, scene }
}

/// Every channel and attribute of an EXR file, read with the exr crate's reader.
pub(crate) fn read_exr(
    path: &std::path::Path,
) -> exr::image::Image<exr::image::Layers<exr::image::AnyChannels<exr::image::FlatSamples>>> {
    use exr::prelude::*;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .expect("EXR reads back")
}

/// A three-value EXR (normals, ray origins or directions): its channels, which must be exactly
/// `R G B` (x y z, the layout `OpenCV` opens), and its `quantity` header attribute.
pub(crate) fn read_xyz_exr(path: &std::path::Path) -> ([Vec<f32>; 3], String) {
    let image = read_exr(path);
    let layer = &image.layer_data[0];
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(names, ["B", "G", "R"], "{}", path.display());
    let channel = |name: &str| -> Vec<f32> {
        let list = &layer.channel_data.list;
        let c = list.iter().find(|c| c.name.to_string() == name).unwrap();
        c.sample_data.values_as_f32().collect()
    };
    let quantity = match layer.attributes.other.get(&exr::prelude::Text::from("quantity")) {
        Some(exr::prelude::AttributeValue::Text(text)) => text.to_string(),
        other => panic!("{}: quantity {other:?}", path.display()),
    };
    ([channel("R"), channel("G"), channel("B")], quantity)
}

/// A closed unit cube centred at (0.5, 0.5, 0.5), turned by `world_from_cube`.
pub(crate) fn cube_room(world_from_cube: DMat3) -> Scene {
    let mut scene = Scene::default();
    scene.objects.push(SceneObject {
        name: "cube".into(),
        kind: "Box",
    });
    for vertices in box_faces(DVec3::splat(0.5), DVec3::splat(0.5), world_from_cube) {
        scene.faces.push(Face {
            vertices: vertices.into(),
            colour: [200, 200, 200],
            object: 0,
        });
    }
    scene
}

/// The cube room plus faces on its walls' planes: an exact copy of wall 2 (a later id), a
/// copy of wall 4 listed first (id 0, so the copy is the lower id), and a triangle lying
/// across part of wall 5 with corners of its own. Every pixel of an equirectangular view from
/// inside sees two faces at once wherever they overlap.
pub(crate) fn coincident_faces() -> Scene {
    let mut scene = cube_room(DMat3::IDENTITY);
    let walls: Vec<Face> = scene.faces.clone();
    let copy = |face: &Face| Face {
        colour: [10, 200, 10],
        ..face.clone()
    };
    scene.faces.insert(0, copy(&walls[4]));
    scene.faces.push(copy(&walls[2]));
    let wall = &walls[5].vertices;
    scene.faces.push(Face {
        vertices: vec![wall[0], wall[0].lerp(wall[1], 0.7), wall[0].lerp(wall[2], 0.6)].into(),
        colour: [200, 10, 10],
        object: 0,
    });
    scene
}

/// Faces of [`coincident_faces`] after the insertion: the copy of wall 4 (id 0), wall 4 (5),
/// wall 2 (3), its copy (7), wall 5 (6) and the triangle across it (8).
pub(crate) const COINCIDENT_FACE_IDS: (usize, usize, usize, usize, usize, usize) = (0, 5, 3, 7, 6, 8);

/// A GLB container of `json` and the binary chunk `bin` (both padded to 4 bytes).
pub(crate) fn glb(json: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(json).unwrap();
    json.resize(json.len().div_ceil(4) * 4, b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().div_ceil(4) * 4, 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}
