//! The wgpu backend: WGSL compute passes in `shaders/` trace every pixel (ray generation, BVH
//! traversal) into hit planes and shade them, on any adapter wgpu finds (lavapipe in CI).

mod bindings;
mod context;
mod layout;
mod scene;
mod shader;
#[cfg(test)]
mod tests;
mod timing;
mod tracer;
mod wide;

pub(crate) use context::GpuContext;
pub use context::GpuError;
pub(crate) use scene::GpuScene;
pub use timing::GpuStages;
pub use tracer::GpuRenderer;
