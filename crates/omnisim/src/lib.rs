//! omnisim: exact, ray-traced simulation of pinhole, panoramic and catadioptric cameras in
//! scenes made of coloured planar faces, for ground-truth robot-vision data sets.
//!
//! Data flows one way: scene file → [`Scene`] → [`Renderer::prepare`] → [`PreparedScene`]
//! (BVH, geometry buffers, appearance) → ([`Rig`] views, [`Pose`]) → rays → hit planes →
//! [`shade`] (face colours and lights) → [`Frame`] planes → [`OutputSet`] (which files, per
//! view and per run; [`output`] writers) and [`RenderMetadata`] (`render.json`). [`Renderer`]
//! holds the backend for the program's life and hides whether the GPU (wgpu, `shaders/`, the
//! default `gpu` feature) or the CPU tracers ([`trace`]) do the work.
//!
//! The reference paper's omnidirectional camera in its first room, written as a PNG:
//!
//! ```
//! use omnisim::glam::dvec3;
//! use omnisim::{BackendChoice, Camera, Catadioptric, Planes, Pose, Renderer, Scene, output};
//!
//! let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/env1.ron"))?;
//! let renderer = Renderer::new(BackendChoice::Cpu)?;
//! let prepared = renderer.prepare(&scene)?;
//! // Hyperbolic mirror a = 40 mm, b = 160 mm; rim where it sees 20° above its horizon.
//! let omni = Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()));
//! let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
//! let frame = renderer.render(&prepared, &Camera::Catadioptric(omni), &pose, Planes::COLOUR)?;
//! output::write_png(&std::env::temp_dir().join("omnisim-env1-omni.png"), &frame)?;
//! # assert!(frame.hit_count() > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod accel;
pub mod calibration;
pub mod camera;
pub mod frame;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod input;
pub mod metadata;
pub mod output;
pub mod pose;
pub mod pose_sets;
pub mod renderer;
pub mod rig;
pub mod scene;
pub mod shade;
pub mod trace;

/// The vector and matrix types of the API (positions, angles, rotations).
pub use glam;

pub use camera::{Camera, CameraError, CameraRay, Catadioptric, Cylindrical, Equirectangular, Pinhole, StereoRig};
pub use frame::{Frame, Pixel, Plane, Planes};
pub use metadata::RenderMetadata;
pub use output::{FrameTarget, OutputSet};
pub use pose::Pose;
pub use renderer::{BackendChoice, PreparedScene, RenderError, Renderer};
pub use rig::{Rig, View};
pub use scene::lighting::{Light, LightKind, Lighting};
pub use scene::{Scene, SceneError};
pub use shade::Appearance;
pub use trace::CpuTracer;
