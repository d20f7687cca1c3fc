//! The wgpu backend: WGSL compute passes in `shaders/` trace every pixel (ray generation, BVH
//! traversal) into hit planes and shade them, on any adapter wgpu finds (lavapipe in CI).

mod context;
pub mod layout;
mod scene;
pub mod shader;
mod tracer;

pub use context::{GpuContext, GpuError};
pub use scene::GpuScene;
pub use tracer::GpuRenderer;
