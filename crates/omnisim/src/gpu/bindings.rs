//! The GPU program's interface, declared once: which buffer sits at which binding of group 0,
//! how the shader reads it, which bindings each entry point uses, and the camera-kind numbers.
//! The pipelines' explicit layouts and every bind group are made from these tables, and
//! `gpu/tests.rs` checks each entry against the WGSL as naga parses it (names, numbers,
//! address spaces, and the globals each entry point really uses).

use super::shader;
use crate::camera::Camera;

/// How the shader reads a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Access {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
}

/// One buffer binding of group 0: its number, its WGSL variable and how the shader reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Binding {
    pub(crate) index: u32,
    pub(crate) name: &'static str,
    pub(crate) access: Access,
}

const fn binding(index: u32, name: &'static str, access: Access) -> Binding {
    Binding { index, name, access }
}

pub(crate) const CAMERA: Binding = binding(0, "camera", Access::Uniform);
pub(crate) const NODES: Binding = binding(1, "nodes", Access::Read);
pub(crate) const TRIANGLES: Binding = binding(2, "triangles", Access::Read);
pub(crate) const MATERIALS: Binding = binding(3, "materials", Access::Read);
pub(crate) const HITS: Binding = binding(4, "hits", Access::ReadWrite);
pub(crate) const EDGE_PIXELS: Binding = binding(5, "edge_pixels", Access::Read);
pub(crate) const EDGE_COLOURS: Binding = binding(6, "edge_colours", Access::ReadWrite);
pub(crate) const LIGHTS: Binding = binding(7, "lights", Access::Read);
pub(crate) const SHADING: Binding = binding(8, "shading", Access::Uniform);
pub(crate) const SHADED: Binding = binding(9, "shaded", Access::ReadWrite);
/// The ray table of a lens camera (`camera_table.wgsl`), uploaded once per camera.
pub(crate) const CAMERA_RAYS: Binding = binding(10, "camera_rays", Access::Read);
pub(crate) const SURFACES: Binding = binding(11, "surfaces", Access::Read);
pub(crate) const TEXTURES: Binding = binding(12, "textures", Access::Read);

/// Every binding of the program.
#[cfg(test)]
pub(crate) const ALL: [Binding; 13] = [
    CAMERA,
    NODES,
    TRIANGLES,
    MATERIALS,
    HITS,
    EDGE_PIXELS,
    EDGE_COLOURS,
    LIGHTS,
    SHADING,
    SHADED,
    CAMERA_RAYS,
    SURFACES,
    TEXTURES,
];

/// An entry point and the bindings it uses, in binding order.
#[derive(Debug)]
pub(crate) struct Stage {
    pub(crate) entry_point: &'static str,
    pub(crate) bindings: &'static [Binding],
}

/// Tracing: camera rays through the BVH into hit planes.
pub(crate) const TRACE: Stage = Stage {
    entry_point: shader::ENTRY_POINT,
    bindings: &[CAMERA, NODES, TRIANGLES, HITS, CAMERA_RAYS],
};

/// Shading the hit planes (shadow rays walk the BVH; texture footprints read the neighbouring
/// pixels' camera rays, a lens camera's from its table).
pub(crate) const SHADE: Stage = Stage {
    entry_point: shader::SHADE_ENTRY_POINT,
    bindings: &[
        CAMERA,
        NODES,
        TRIANGLES,
        MATERIALS,
        HITS,
        LIGHTS,
        SHADING,
        SHADED,
        CAMERA_RAYS,
        SURFACES,
        TEXTURES,
    ],
};

/// Edge supersampling: traced and shaded again at sub-pixel positions.
pub(crate) const REFINE: Stage = Stage {
    entry_point: shader::REFINE_ENTRY_POINT,
    bindings: &[
        CAMERA,
        NODES,
        TRIANGLES,
        MATERIALS,
        EDGE_PIXELS,
        EDGE_COLOURS,
        LIGHTS,
        SHADING,
        CAMERA_RAYS,
        SURFACES,
        TEXTURES,
    ],
};

/// The three pipelines.
#[cfg(test)]
pub(crate) const STAGES: [&Stage; 3] = [&TRACE, &SHADE, &REFINE];

/// The WGSL constant naming each camera model, and its number in `CameraParams.kind`.
pub(crate) const CAMERA_KINDS: [(&str, u32); 5] = [
    ("CAMERA_PINHOLE", 0),
    ("CAMERA_EQUIRECTANGULAR", 1),
    ("CAMERA_CATADIOPTRIC", 2),
    ("CAMERA_CYLINDRICAL", 3),
    ("CAMERA_TABLE", 4),
];

/// The number the shader's `camera.kind` switch knows `camera` by: lens cameras read their
/// rays from the table (`CAMERA_RAYS`).
pub(crate) fn camera_kind(camera: &Camera) -> u32 {
    let index = match camera {
        Camera::Pinhole(_) => 0,
        Camera::Equirectangular(_) => 1,
        Camera::Catadioptric(_) => 2,
        Camera::Cylindrical(_) => 3,
        Camera::Lens(_) => 4,
    };
    CAMERA_KINDS[index].1
}

/// The layout entries of `stage`'s bind group, from its table.
pub(crate) fn layout_entries(stage: &Stage) -> Vec<wgpu::BindGroupLayoutEntry> {
    stage
        .bindings
        .iter()
        .map(|binding| wgpu::BindGroupLayoutEntry {
            binding: binding.index,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: match binding.access {
                    Access::Uniform => wgpu::BufferBindingType::Uniform,
                    Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                    Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        })
        .collect()
}
