//! The layers under [`Renderer`](crate::Renderer), for tests, benchmarks and tools that trace,
//! shade or count by themselves; rendering needs none of it. The BVH ([`SceneBvh`]), the CPU
//! tracers ([`CpuTracer`]: the fast one and the f64 reference, [`closest_hit`], [`occluded`],
//! [`trace`]), what they count ([`TraversalCounts`]), the shading stage ([`Appearance`],
//! [`shade`], [`encode`], [`edge_pixels`]) and the GPU renderer. Colour conversions are in
//! [`scene::lighting`](crate::scene::lighting).

pub use crate::accel::SceneBvh;
pub use crate::frame::Pixel;
#[cfg(feature = "gpu")]
pub use crate::gpu::{GpuError, GpuRenderer, GpuStages};
pub use crate::scene::TooManyTriangles;
pub use crate::shade::antialias::edge_pixels;
pub use crate::shade::{Appearance, Footprint, encode, shade};
pub use crate::trace::counts::TraversalCounts;
pub use crate::trace::{CpuTracer, Hit, closest_hit, occluded, trace};
