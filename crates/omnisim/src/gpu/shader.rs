//! The WGSL program, assembled from one file per concern (WGSL has no `#include`).

use std::fmt::Write as _;

/// The shader files in the order they are concatenated: definitions first, entry point last.
pub(crate) const FILES: [(&str, &str); 11] = [
    ("common.wgsl", include_str!("../../../../shaders/common.wgsl")),
    (
        "camera_pinhole.wgsl",
        include_str!("../../../../shaders/camera_pinhole.wgsl"),
    ),
    (
        "camera_equirect.wgsl",
        include_str!("../../../../shaders/camera_equirect.wgsl"),
    ),
    (
        "camera_cylindrical.wgsl",
        include_str!("../../../../shaders/camera_cylindrical.wgsl"),
    ),
    (
        "camera_catadioptric.wgsl",
        include_str!("../../../../shaders/camera_catadioptric.wgsl"),
    ),
    (
        "camera_table.wgsl",
        include_str!("../../../../shaders/camera_table.wgsl"),
    ),
    ("bvh.wgsl", include_str!("../../../../shaders/bvh.wgsl")),
    ("trace.wgsl", include_str!("../../../../shaders/trace.wgsl")),
    ("texture.wgsl", include_str!("../../../../shaders/texture.wgsl")),
    ("shade.wgsl", include_str!("../../../../shaders/shade.wgsl")),
    ("antialias.wgsl", include_str!("../../../../shaders/antialias.wgsl")),
];

/// Entry point of the trace pass.
pub(crate) const ENTRY_POINT: &str = "trace_pixels";

/// Entry point of the shading pass.
pub(crate) const SHADE_ENTRY_POINT: &str = "shade_pixels";

/// Entry point of the edge supersampling pass.
pub(crate) const REFINE_ENTRY_POINT: &str = "refine_edges";

/// Workgroup size of `refine_edges`.
pub(crate) const REFINE_WORKGROUP_SIZE: u32 = 64;

/// Workgroup size of `trace_pixels` in x (columns) and y (rows); the shaders test checks it
/// against the WGSL attribute.
pub(crate) const WORKGROUP_SIZE: [u32; 2] = [8, 8];

/// Traversal stack entries of `bvh.wgsl` (one per level of the wide BVH); deeper BVHs are
/// refused before dispatch.
pub(crate) const STACK_SIZE: usize = 64;

/// The whole program as one WGSL source.
pub(crate) fn source() -> String {
    FILES.iter().fold(String::new(), |mut source, (name, text)| {
        let _ = write!(source, "// ---- {name} ----\n{text}\n");
        source
    })
}
