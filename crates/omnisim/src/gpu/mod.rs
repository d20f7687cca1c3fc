//! The wgpu backend: one compute pass per image band traces every pixel (ray generation,
//! BVH traversal, shading) in `shaders/`, on any adapter wgpu finds (lavapipe in CI).

mod context;
pub mod layout;
pub mod shader;
mod tracer;

pub use context::{GpuContext, GpuError};
pub use tracer::GpuTracer;
