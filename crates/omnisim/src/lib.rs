//! omnisim: exact, ray-traced simulation of pinhole, panoramic and catadioptric cameras in
//! scenes made of coloured planar faces, for ground-truth robot-vision data sets.
//!
//! Data flows one way: scene file → [`Scene`] → [`Renderer::prepare`] → [`PreparedScene`]
//! (BVH, geometry buffers, appearance) → (camera, pose) → rays → hit planes → [`shading`]
//! (face colours and lights) → [`Frame`] planes → [`output`] writers. [`Renderer`] holds the
//! backend for the program's life and hides whether the GPU (wgpu, `shaders/`) or the f64 CPU
//! reference ([`cpu`]) does the work.

pub mod antialias;
pub mod bvh;
pub mod calibration;
pub mod camera;
pub mod cpu;
pub mod frame;
pub mod gpu;
pub mod input;
pub mod lighting;
pub mod output;
pub mod pose;
pub mod pose_sets;
pub mod renderer;
pub mod scene;
pub mod shading;
pub mod traversal;

pub use camera::{Camera, CameraError, CameraRay, Catadioptric, Cylindrical, Equirectangular, Pinhole, StereoRig};
pub use frame::{Frame, Pixel, Plane, Planes};
pub use lighting::{Light, LightKind, Lighting};
pub use pose::Pose;
pub use renderer::{BackendChoice, PreparedScene, RenderError, Renderer};
pub use scene::{Scene, SceneError};
pub use shading::Appearance;
