//! omnisim: exact, ray-traced simulation of pinhole, panoramic and catadioptric cameras in
//! scenes made of coloured planar faces, for ground-truth robot-vision data sets.
//!
//! Data flows one way: scene file → [`Scene`] → triangles → [`bvh::SceneBvh`] → (camera,
//! pose) → rays → hits → [`Frame`] → [`output`] writers. [`Renderer`] hides whether the GPU
//! (wgpu, `shaders/`) or the f64 CPU reference ([`cpu`]) does the tracing.

pub mod antialias;
pub mod bvh;
pub mod calibration;
pub mod camera;
pub mod cpu;
pub mod frame;
pub mod gpu;
pub mod input;
pub mod output;
pub mod pose;
pub mod pose_sets;
pub mod renderer;
pub mod scene;

pub use camera::{Camera, CameraError, CameraRay, Catadioptric, Cylindrical, Equirectangular, Pinhole, StereoRig};
pub use frame::{Frame, Pixel};
pub use pose::Pose;
pub use renderer::{BackendChoice, RenderError, Renderer};
pub use scene::{Scene, SceneError};
