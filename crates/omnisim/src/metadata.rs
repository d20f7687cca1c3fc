//! `render.json`: everything needed to use rendered files without reading omnisim's code: the
//! camera and its parameters, the conventions of every file, the backend, and every frame with
//! its pose and files. Typed, so that a data-set manifest can reuse the parts; the field names
//! are the file's format and stay as they are. The record also writes a frame's files through
//! the output set (`RenderMetadata::write_frame`) and adds the frame's entry only once they are
//! written, so output never needs to know the record.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::atomic_file::write_atomically;
use crate::camera::{Camera, Catadioptric, MirrorShape, NO_DISPARITY, Pinhole, Rig, RigSpec};
use crate::frame::Frame;
use crate::output::folder::RunFolder;
use crate::output::store::Synced;
use crate::output::{self, Destination, FrameTarget, OutputError, OutputSet};
use crate::pose::Pose;
use crate::renderer::{PreparedScene, Renderer};
use crate::scene::Scene;

/// The contents of `render.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RenderMetadata {
    /// Version of omnisim that wrote the files.
    pub omnisim: &'static str,
    /// Which scene was rendered.
    pub scene: SceneMetadata,
    /// The rig as it was described (`render --rig` RON, a data-set spec's `rig:`), where it
    /// was: what `describe` and `project` rebuild the camera from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigSpec>,
    /// The rig: one camera's parameters, or a stereo pair's.
    pub camera: RigMetadata,
    /// Which backend traced the frames, and why.
    pub backend: BackendMetadata,
    /// What the numbers in every file mean.
    pub conventions: Conventions,
    /// Every rendered pose, in order.
    pub frames: Vec<FrameMetadata>,
}

impl RenderMetadata {
    /// Metadata of a render of `scene` through `rig`, with no frames yet.
    pub fn new(scene: &Scene, rig: &Rig, backend: BackendMetadata) -> Self {
        Self {
            omnisim: env!("CARGO_PKG_VERSION"),
            scene: SceneMetadata {
                name: scene.name.clone(),
                file: scene.source.clone(),
                faces: scene.faces.len(),
            },
            rig: None,
            camera: RigMetadata::of(rig),
            backend,
            conventions: Conventions::of(rig),
            frames: Vec::new(),
        }
    }

    /// Writes frame `target`'s files as `outputs` asks ([`OutputSet::write_frame_files`]) and
    /// adds its entry, the files relative to the output folder.
    pub fn write_frame(
        &mut self,
        outputs: &OutputSet,
        folder: &mut impl Destination,
        target: &FrameTarget,
        rig: &Rig,
        frames: &[Frame],
    ) -> Result<(), OutputError> {
        let written = outputs.write_frame_files(folder, target, rig, frames)?;
        let files = written
            .into_iter()
            .map(|path| path.strip_prefix(folder.dir()).map(Path::to_path_buf).unwrap_or(path))
            .collect();
        self.frames
            .push(FrameMetadata::new(target.index, target.stem(), target.pose, files));
        Ok(())
    }

    /// Writes the files of a render run that are not per frame: those of
    /// [`OutputSet::write_set_files`], `poses.txt` (TUM, the frames' poses) and `render.json`
    /// (this). Returns their paths.
    pub fn write_run_files(
        &self,
        outputs: &OutputSet,
        folder: &mut RunFolder,
        scene: &Scene,
        rig: &Rig,
    ) -> Result<Vec<PathBuf>, OutputError> {
        let mut written = outputs.write_set_files(folder, scene, rig)?;
        let poses_path = Destination::claim(folder, "poses.txt".into())?;
        write_atomically(&poses_path, |out| {
            writeln!(
                out,
                "# omnisim poses, TUM format: index tx ty tz qx qy qz qw (world_from_body; metres)"
            )?;
            for frame in &self.frames {
                let [x, y, z] = frame.position;
                let [qx, qy, qz, qw] = frame.quaternion_xyzw;
                writeln!(out, "{} {x} {y} {z} {qx} {qy} {qz} {qw}", frame.index)?;
            }
            Ok(())
        })
        .map_err(output::failed(&poses_path))?;
        written.push(poses_path);
        let metadata_path = Destination::claim(folder, "render.json".into())?;
        output::write_json(&mut Synced, &metadata_path, self)?;
        written.push(metadata_path);
        Ok(written)
    }
}

/// The scene of a render.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneMetadata {
    /// Name from the scene file.
    pub name: String,
    /// The file it was loaded from, if any.
    pub file: Option<PathBuf>,
    /// Number of planar faces.
    pub faces: usize,
}

/// The backend that traced the frames.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BackendMetadata {
    /// "gpu" or "cpu".
    pub name: &'static str,
    /// The adapter, or the CPU tracer and its threads.
    pub device: String,
    /// Why this backend traced the scene.
    pub reason: String,
}

impl BackendMetadata {
    /// What traces `prepared` on `renderer`, and why.
    pub fn of(renderer: &Renderer, prepared: &PreparedScene) -> Self {
        Self {
            name: prepared.backend_name(),
            device: renderer.device_name(),
            reason: prepared.fallback().unwrap_or(renderer.reason()).to_string(),
        }
    }
}

/// The rig of a render.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum RigMetadata {
    /// One camera.
    Single(CameraMetadata),
    /// A stereo pair.
    Stereo(StereoMetadata),
}

impl RigMetadata {
    /// The parameters of `rig`.
    pub fn of(rig: &Rig) -> Self {
        match rig {
            Rig::Single(camera) => RigMetadata::Single(CameraMetadata::of(camera)),
            Rig::Stereo(stereo) => {
                let [left, right] = stereo.cameras();
                RigMetadata::Stereo(StereoMetadata {
                    model: "stereo",
                    baseline: stereo.baseline,
                    left: CameraMetadata::of(&left),
                    right: CameraMetadata::of(&right),
                    disparity: if stereo.has_disparity() {
                        "<stem>-disparity.exr: u_left - u_right = fx*baseline/z for the left image"
                    } else {
                        NO_DISPARITY
                    },
                })
            }
        }
    }
}

/// A stereo pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StereoMetadata {
    /// Always "stereo".
    pub model: &'static str,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
    /// The left camera (at +baseline/2 on body y).
    pub left: CameraMetadata,
    /// The right camera.
    pub right: CameraMetadata,
    /// What the disparity file holds, or why a pair with a lens has none.
    pub disparity: &'static str,
}

/// One camera: model, image size and the model's own parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraMetadata {
    /// Model name (`Camera::model_name`).
    pub model: &'static str,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Whether every ray starts at the pose position.
    pub central: bool,
    /// The model's parameters, beside the fields above.
    #[serde(flatten)]
    pub parameters: CameraParameters,
}

impl CameraMetadata {
    /// The parameters of `camera`.
    pub fn of(camera: &Camera) -> Self {
        let (width, height) = camera.size();
        let parameters = match camera {
            Camera::Pinhole(c) => CameraParameters::Pinhole(PinholeParameters::of(c)),
            Camera::Equirectangular(_) => CameraParameters::Equirectangular {
                azimuth_of_column_u: AZIMUTH_OF_COLUMN,
                elevation_of_row_v: "pi/2 - pi*(v + 0.5)/height",
            },
            Camera::Cylindrical(c) => CameraParameters::Cylindrical {
                fy: c.fy,
                cy: c.cy,
                azimuth_of_column_u: AZIMUTH_OF_COLUMN,
                row_v: "a ray rises (cy - v)/fy per unit of horizontal distance",
            },
            Camera::Catadioptric(c) => CameraParameters::Catadioptric(Box::new(CatadioptricMetadata::of(c))),
            Camera::Lens(c) => CameraParameters::Lens(Box::new(LensMetadata {
                intrinsics: PinholeParameters::of(&c.intrinsics),
                lens: c.model.name(),
                lens_parameters: c.model.parameters().into_iter().collect(),
                max_angle_off_axis_degrees: c.model.max_angle().to_degrees(),
                pixels_without_ray: c.pixels_without_ray(),
            })),
        };
        Self {
            model: camera.model_name(),
            width,
            height,
            central: camera.is_central(),
            parameters,
        }
    }
}

const AZIMUTH_OF_COLUMN: &str = "pi - 2*pi*(u + 0.5)/width, counter-clockwise from body +x";

/// The parameters of each camera model.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum CameraParameters {
    /// Perspective camera, `OpenCV` intrinsics.
    Pinhole(PinholeParameters),
    /// Full-sphere panorama.
    Equirectangular {
        /// Azimuth of each column.
        azimuth_of_column_u: &'static str,
        /// Elevation of each row.
        elevation_of_row_v: &'static str,
    },
    /// 360° cylindrical panorama.
    Cylindrical {
        /// Vertical focal length, pixels.
        fy: f64,
        /// Row of the horizon.
        cy: f64,
        /// Azimuth of each column.
        azimuth_of_column_u: &'static str,
        /// Slope of each row.
        row_v: &'static str,
    },
    /// Camera looking at a mirror.
    Catadioptric(Box<CatadioptricMetadata>),
    /// A camera with a lens model (docs/cameras.md gives each model's equations).
    Lens(Box<LensMetadata>),
}

/// A lens camera: K and place as a pinhole's, the model and its valid field of view.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LensMetadata {
    /// K and the optical centre, as a pinhole's.
    #[serde(flatten)]
    pub intrinsics: PinholeParameters,
    /// The lens model.
    pub lens: &'static str,
    /// The model's parameters by name.
    pub lens_parameters: std::collections::BTreeMap<&'static str, Vec<f64>>,
    /// The valid field of view's half-angle; pixels beyond it are background.
    pub max_angle_off_axis_degrees: f64,
    /// How many pixels of the image lie beyond it (background in every output).
    pub pixels_without_ray: u64,
}

/// A perspective camera's `OpenCV` intrinsics and place (also a lens camera's).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PinholeParameters {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
    /// Optical centre in the body frame, metres.
    pub position_in_body: [f64; 3],
    /// Axes of the optical frame.
    pub optical_frame: &'static str,
}

impl PinholeParameters {
    fn of(c: &Pinhole) -> Self {
        Self {
            fx: c.fx,
            fy: c.fy,
            cx: c.cx,
            cy: c.cy,
            position_in_body: c.position.to_array(),
            optical_frame: "OpenCV (x right, y down, z forward); looks along body +x",
        }
    }
}

/// A catadioptric camera: the mirror, the camera looking at it, and the unified model where
/// one describes it exactly.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CatadioptricMetadata {
    /// Mirror shape and size.
    pub mirror: MirrorMetadata,
    /// Focal length, pixels (or pixels per metre for the orthographic camera of a paraboloid).
    pub focal: f64,
    /// Image centre, column.
    pub cx: f64,
    /// Image centre, row.
    pub cy: f64,
    /// Mirror rim radius, metres, if any.
    pub rim_radius: Option<f64>,
    /// Radius of the image centre hidden by the camera's body, pixels.
    pub hidden_centre_px: f64,
    /// "Up" or "Down": which way the mirror axis points in the body frame.
    pub mount: String,
    /// How far the camera is displaced and tilted from its nominal place.
    pub misalignment: MisalignmentMetadata,
    /// "Reflect" or "Shortcut": how mirror rays are found.
    pub mirror_rays: String,
    /// Body origin in the mirror frame, metres.
    pub body_origin_in_mirror_frame: [f64; 3],
    /// Mei's unified model, for aligned central mirrors.
    pub unified_model: Option<UnifiedModelMetadata>,
    /// The lens of the camera that looks at the mirror; absent for the ideal pinhole.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_lens: Option<MirrorLensMetadata>,
    /// How body azimuth maps to image angle.
    pub image_azimuth: &'static str,
    /// Where per-pixel rays are.
    pub rays: &'static str,
}

impl CatadioptricMetadata {
    /// The parameters of `c`.
    pub fn of(c: &Catadioptric) -> Self {
        let mirror = match c.mirror {
            MirrorShape::Hyperbolic { a, b } => MirrorMetadata::Hyperbolic {
                shape: "hyperbolic: (x^2+y^2)/a^2 - z^2/b^2 = -1, upper sheet; perspective camera at the outer focus",
                a,
                b,
                c: c.c(),
            },
            MirrorShape::Parabolic { a, b, h } => MirrorMetadata::Parabolic {
                shape: "parabolic: z = h*(x^2/a^2 + y^2/b^2); orthographic camera along the axis (focal = pixels per metre)",
                a,
                b,
                h,
            },
            MirrorShape::Spherical {
                radius,
                camera_distance,
            } => MirrorMetadata::Spherical {
                shape: "spherical: x^2+y^2+z^2 = R^2; perspective camera at (0,0,-D); body origin at the centre",
                radius,
                camera_distance,
            },
        };
        Self {
            mirror,
            focal: c.focal,
            cx: c.cx,
            cy: c.cy,
            rim_radius: c.rim_radius,
            hidden_centre_px: c.hidden_centre_px,
            mount: format!("{:?}", c.mount),
            misalignment: MisalignmentMetadata {
                offset_m: c.misalignment.offset.to_array(),
                tilt_rad: c.misalignment.tilt.to_array(),
            },
            mirror_rays: format!("{:?}", c.rays),
            body_origin_in_mirror_frame: c.body_origin_in_mirror().to_array(),
            unified_model: c.unified_model().map(|m| UnifiedModelMetadata {
                xi: m.xi,
                gamma_x: m.gamma_x,
                gamma_y: m.gamma_y,
                projection: "u = cx + gamma_x*s_x/(xi - s_z), v = cy + gamma_y*s_y/(xi - s_z), s = unit direction from F' in the mirror frame",
            }),
            camera_lens: c.lens.as_ref().map(|lens| MirrorLensMetadata {
                lens: lens.name(),
                lens_parameters: lens.parameters().into_iter().collect(),
                applied: "m = ((u - cx)/focal, (v - cy)/focal) is the lens's normalised image point; its inverse \
                          gives the camera's ray to the mirror",
                unified_model_distortion: c.unified_distortion(),
            }),
            image_azimuth: "a point at body azimuth phi appears at atan2(v - cy, u - cx) = phi with the mirror mounted up, -phi mounted down (u right, v down): the image is mirrored on screen",
            rays: "see raymap-origin.exr and raymap-direction.exr (or both in raymap-all.exr): per-pixel origin and unit direction in the body frame",
        }
    }
}

/// The lens of a catadioptric camera's inner camera.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MirrorLensMetadata {
    /// The lens model's name.
    pub lens: &'static str,
    /// Its parameters by name.
    pub lens_parameters: std::collections::BTreeMap<&'static str, Vec<f64>>,
    /// How the lens applies.
    pub applied: &'static str,
    /// The unified model's radtan k1 k2 p1 p2 that expresses this lens exactly (`cv::omnidir`;
    /// the calibration files carry it); absent where none does.
    pub unified_model_distortion: Option<[f64; 4]>,
}

/// A mirror's shape and parameters, metres.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum MirrorMetadata {
    /// Hyperboloid.
    Hyperbolic {
        /// The equation.
        shape: &'static str,
        /// Parameter a.
        a: f64,
        /// Parameter b.
        b: f64,
        /// Focal distance √(a² + b²).
        c: f64,
    },
    /// Elliptic paraboloid.
    Parabolic {
        /// The equation.
        shape: &'static str,
        /// Parameter a.
        a: f64,
        /// Parameter b.
        b: f64,
        /// Height h.
        h: f64,
    },
    /// Sphere.
    Spherical {
        /// The equation.
        shape: &'static str,
        /// Sphere radius R.
        radius: f64,
        /// Distance D from the centre to the camera.
        camera_distance: f64,
    },
}

/// Camera displacement and tilt from the nominal place, mirror frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MisalignmentMetadata {
    /// Displacement, metres.
    pub offset_m: [f64; 3],
    /// Tilt angles θx, θy, θz, radians.
    pub tilt_rad: [f64; 3],
}

/// Mei's unified model of an aligned central mirror.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnifiedModelMetadata {
    /// Mirror parameter ξ.
    pub xi: f64,
    /// Generalised focal length in x, pixels.
    pub gamma_x: f64,
    /// Generalised focal length in y, pixels.
    pub gamma_y: f64,
    /// The projection formula.
    pub projection: &'static str,
}

/// What the numbers of every file mean.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Conventions {
    /// Units of lengths and angles.
    pub units: &'static str,
    /// World frame.
    pub world: &'static str,
    /// Body frame and what the pose position is.
    pub body: &'static str,
    /// The pose rotation.
    pub rotation: &'static str,
    /// Pixel coordinates.
    pub pixels: &'static str,
    /// What range is measured from (`output::range_convention`).
    pub range: &'static str,
    /// Depth images of pinhole and stereo cameras.
    pub depth: String,
    /// The ray maps: two files per view, origin and direction.
    pub ray_map: &'static str,
    /// The point clouds.
    pub point_cloud: &'static str,
}

impl Conventions {
    /// The conventions of files rendered through `rig`.
    pub fn of(rig: &Rig) -> Self {
        Self {
            units: "metres; angles in degrees here",
            world: "right-handed, z up",
            body: "x forward, y left, z up; pose position = the body origin: the optical centre (pinhole), the rig's centre (stereo), a central mirror's viewpoint F', the sphere's centre, or a non-central paraboloid's focus",
            rotation: "world_from_body = Rx(theta_x)*Ry(theta_y)*Rz(theta_z)",
            pixels: "u = column, v = row, pixel centres at integer coordinates, (0,0) top-left",
            range: output::range_convention(&rig.first_camera()),
            depth: format!(
                "pinhole and stereo: <stem>-depth.exr ({}); <stem>-depth.png, TUM RGB-D 16-bit: value = z * {}, 0 = no hit or z > 13.1 m",
                output::AXIAL_DEPTH_CONVENTION,
                output::TUM_DEPTH_SCALE
            ),
            ray_map: output::RAY_MAP_CONVENTION,
            point_cloud: "binary little-endian PLY, float x y z in world metres + uchar red green blue, hit pixels only",
        }
    }
}

/// One rendered pose and the files written for it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameMetadata {
    /// Position in the pose list, from 0.
    pub index: usize,
    /// File-name stem of the frame's files.
    pub stem: String,
    /// Body origin in the world, metres.
    pub position: [f64; 3],
    /// θx, θy, θz of `world_from_body = Rx·Ry·Rz`, degrees.
    pub angles_deg: [f64; 3],
    /// `world_from_body` as a unit quaternion (x, y, z, w), w ≥ 0.
    pub quaternion_xyzw: [f64; 4],
    /// `world_from_body` as a 4×4 matrix, row by row.
    pub world_from_body: [[f64; 4]; 4],
    /// Every file written for this frame, relative to the output folder.
    pub files: Vec<PathBuf>,
}

impl FrameMetadata {
    /// The entry of frame `index`, named `stem`, rendered from `pose`, that wrote `files`.
    pub fn new(index: usize, stem: String, pose: &Pose, files: Vec<PathBuf>) -> Self {
        let a = pose.angles_degrees();
        Self {
            index,
            stem,
            position: pose.position.to_array(),
            angles_deg: [a.x, a.y, a.z],
            quaternion_xyzw: pose.quaternion_xyzw(),
            world_from_body: pose.world_from_body().transpose().to_cols_array_2d(),
            files,
        }
    }
}
