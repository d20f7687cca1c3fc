//! omnisim: exact, ray-traced simulation of pinhole, panoramic and catadioptric cameras in
//! scenes made of coloured planar faces, for ground-truth robot-vision data sets.
//!
//! The main path, in the order data flows: a scene file → [`Scene`] → [`Renderer::prepare`] →
//! [`PreparedScene`]; a rig described once ([`RigSpec`], as `render --rig` and data-set specs
//! hold it) → [`RigSpec::build`] → [`Rig`] and its [`View`]s; a [`Pose`] → [`Renderer::render`]
//! → a [`Frame`] of the [`Planes`] asked for → an [`OutputSet`] of files and a
//! [`RenderMetadata`] (`render.json`). [`Renderer`] holds the backend for the program's life and
//! hides whether the GPU (wgpu, `shaders/`, the default `gpu` feature) or the CPU tracers do
//! the work. Modules: [`scene`] (files, lights), [`camera`] (models and [`RigSpec`]),
//! [`pose_sets`] (grids, trajectories, random poses), [`output`] (file writers, run folders),
//! [`calibration`], [`metadata`], [`input`] (reading user files safely), and [`advanced`]: the
//! BVH, tracers and shading stage under the renderer, for tests, benchmarks and tools.
//!
//! The reference paper's omnidirectional camera in its first room, written as a PNG:
//!
//! ```
//! use omnisim::glam::dvec3;
//! use omnisim::{BackendChoice, Planes, Pose, Renderer, RigSpec, Scene, output};
//!
//! let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/env1.ron"))?;
//! let renderer = Renderer::new(BackendChoice::Cpu)?;
//! let prepared = renderer.prepare(&scene)?;
//! // The paper's camera: hyperbolic mirror a = 40 mm, b = 160 mm, 250 × 250, rim at 20°.
//! let rig: RigSpec = omnisim::input::ron_options().from_str("Omni(size: (250, 250))")?;
//! let camera = rig.build()?.views().remove(0).camera;
//! let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
//! let frame = renderer.render(&prepared, &camera, &pose, Planes::COLOUR)?;
//! let path = std::env::temp_dir().join("omnisim-env1-omni.png");
//! output::write_png(&mut output::store::Synced, &path, &frame)?;
//! # assert!(frame.hit_count() > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A data set written from code is the `omnisim-dataset` crate's first example, and a
//! descriptor computed on a rendered image the `omnisim-vision` crate's.

mod accel;
pub mod advanced;
pub mod atomic_file;
pub mod avx2;
pub mod calibration;
pub mod camera;
pub mod frame;
#[cfg(feature = "gpu")]
mod gpu;
pub mod input;
pub mod metadata;
pub mod output;
pub mod pose;
pub mod pose_sets;
mod renderer;
pub mod scene;
mod shade;
mod trace;

/// The vector and matrix types of the API (positions, angles, rotations).
pub use glam;

pub use camera::{Camera, Rig, RigSpec, View};
pub use frame::{Frame, Plane, Planes};
pub use metadata::RenderMetadata;
pub use output::OutputSet;
pub use pose::Pose;
pub use renderer::{BackendChoice, PreparedScene, RenderError, Renderer};
pub use scene::{Scene, SceneError};
