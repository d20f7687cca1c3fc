//! Host twins of the WGSL structs in `shaders/common.wgsl`, laid out by WGSL's rules.
//! Keep in sync: `gpu/tests.rs` compares every size and offset with naga's layout.

use bytemuck::{Pod, Zeroable};

/// WGSL twin: `CameraParams`, the camera uniform: the frame, then each model's block.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct CameraParams {
    pub(crate) frame: FrameBlock,
    pub(crate) projection: ProjectionBlock,
    pub(crate) mirror: MirrorBlock,
}

/// WGSL twin: `FrameBlock`, what every camera has: pose, image, band.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct FrameBlock {
    /// mat3x3<f32>: three columns, each padded to 16 bytes.
    pub(crate) world_from_body: [[f32; 4]; 3],
    pub(crate) origin: [f32; 3],
    pub(crate) kind: u32,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) row_offset: u32,
    pub(crate) band_rows: u32,
    pub(crate) samples_per_axis: u32,
    /// WGSL rounds the struct up to its 16-byte alignment.
    pub(crate) _pad: [u32; 3],
}

/// WGSL twin: `ProjectionBlock`, a pinhole-like projection (pinhole, cylindrical, the
/// catadioptric camera's lens).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct ProjectionBlock {
    pub(crate) focal: [f32; 2],
    pub(crate) principal: [f32; 2],
    pub(crate) lens_origin: [f32; 3],
    /// WGSL rounds the struct up to its 16-byte alignment.
    pub(crate) _pad: f32,
}

/// WGSL twin: `MirrorBlock`, the catadioptric camera's mirror and misalignment.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct MirrorBlock {
    /// mat3x3<f32>: three columns, each padded to 16 bytes.
    pub(crate) camera_tilt: [[f32; 4]; 3],
    pub(crate) mirror_diag: [f32; 3],
    pub(crate) mirror_constant: f32,
    pub(crate) mirror_linear: [f32; 3],
    pub(crate) mount_sign: f32,
    pub(crate) camera_offset: [f32; 3],
    pub(crate) rim_sq: f32,
    pub(crate) mirror_min_z: f32,
    pub(crate) hidden_centre_sq: f32,
    pub(crate) orthographic: u32,
    pub(crate) central: u32,
    pub(crate) shortcut: u32,
    pub(crate) inner_lens: u32,
    /// WGSL rounds the struct up to its 16-byte alignment.
    pub(crate) _pad: [u32; 2],
}

/// WGSL twin: `Triangle`, in the order the wide BVH's leaves reach it (`gpu/wide.rs`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct Triangle {
    pub(crate) v0: [f32; 3],
    pub(crate) face: u32,
    pub(crate) e1: [f32; 3],
    /// Index in BVH leaf order, which breaks ties between triangles of one face.
    pub(crate) leaf_order: u32,
    pub(crate) e2: [f32; 3],
    pub(crate) _pad: u32,
}

/// WGSL twin: `WideNode`, a node of the 8-wide BVH (`gpu/wide.rs` converts the CPU's).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuWideNode {
    /// Children's box corners, lane i = child i: entry 2·axis + half holds children
    /// 4·half..4·half + 4 on that axis.
    pub(crate) min: [[f32; 4]; 6],
    pub(crate) max: [[f32; 4]; 6],
    /// Inner node index, or `GPU_LEAF` | (triangle count − 1) << 26 | first triangle.
    pub(crate) child: [u32; 8],
    /// Bit i set where child i exists.
    pub(crate) lanes: u32,
    /// WGSL rounds the struct up to its 16-byte alignment.
    pub(crate) _pad: [u32; 3],
}

/// WGSL twin: `PixelHit`, the hit planes of one pixel.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct PixelHit {
    /// Hit point relative to the scene offset.
    pub(crate) point: [f32; 3],
    pub(crate) range: f32,
    /// Unit face normal turned towards the ray origin.
    pub(crate) normal: [f32; 3],
    pub(crate) face: u32,
}

/// WGSL twin: `ShadedPixel`, the shading stage's output for one pixel.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct ShadedPixel {
    pub(crate) linear: [f32; 3],
    /// 8-bit sRGB packed as `pack4x8unorm` (r in the low byte).
    pub(crate) colour: u32,
}

/// WGSL twin: `GpuLight`. Point lights: `vector` = position relative to the scene offset and
/// `strength` = linear colour × candela; directional: `vector` = unit travel direction and
/// `strength` = linear colour × lux.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuLight {
    pub(crate) vector: [f32; 3],
    pub(crate) kind: u32,
    pub(crate) strength: [f32; 3],
    pub(crate) _pad: u32,
}

/// WGSL twin: `Material`: a face's linear albedo and its surface's index (or `NO_SURFACE`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuMaterial {
    pub(crate) rgb: [f32; 3],
    pub(crate) surface: u32,
}

/// WGSL twin: `GpuSurface` (`shaders/texture.wgsl`): a face's u, v and vertex colours as
/// affine functions of the scene-local hit point, and where its texture's levels are.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuSurface {
    pub(crate) anchor: [f32; 3],
    pub(crate) levels_at: u32,
    pub(crate) u_gradient: [f32; 3],
    pub(crate) u_at_anchor: f32,
    pub(crate) v_gradient: [f32; 3],
    pub(crate) v_at_anchor: f32,
    pub(crate) colour_at_anchor: [f32; 3],
    pub(crate) level_count: u32,
    pub(crate) red_gradient: [f32; 3],
    pub(crate) wrap_u: u32,
    pub(crate) green_gradient: [f32; 3],
    pub(crate) wrap_v: u32,
    pub(crate) blue_gradient: [f32; 3],
    /// [`SURFACE_COLOURS`] | [`SURFACE_UNLIT`].
    pub(crate) flags: u32,
}

/// `GpuSurface::flags` bit: the vertex colours replace the face colour (WGSL `SURFACE_COLOURS`).
pub(crate) const SURFACE_COLOURS: u32 = 1;
/// `GpuSurface::flags` bit: drawn in its albedo whatever the lights (WGSL `SURFACE_UNLIT`).
pub(crate) const SURFACE_UNLIT: u32 = 2;

/// WGSL twin: `ShadingParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct ShadingParams {
    pub(crate) ambient: f32,
    /// 1 / white (lux⁻¹): the exposure.
    pub(crate) inverse_white: f32,
    pub(crate) light_count: u32,
    /// 0: flat face colours; 1: lit.
    pub(crate) lit: u32,
}

/// A host struct's name, size and (field, offset) list.
#[cfg(test)]
pub(crate) type StructLayout = (&'static str, usize, Vec<(&'static str, usize)>);

/// The layout of every host twin, for the layout test.
#[cfg(test)]
pub(crate) fn host_layouts() -> Vec<StructLayout> {
    use std::mem::{offset_of, size_of};
    vec![
        (
            "CameraParams",
            size_of::<CameraParams>(),
            vec![
                ("frame", offset_of!(CameraParams, frame)),
                ("projection", offset_of!(CameraParams, projection)),
                ("mirror", offset_of!(CameraParams, mirror)),
            ],
        ),
        (
            "FrameBlock",
            size_of::<FrameBlock>(),
            vec![
                ("world_from_body", offset_of!(FrameBlock, world_from_body)),
                ("origin", offset_of!(FrameBlock, origin)),
                ("kind", offset_of!(FrameBlock, kind)),
                ("width", offset_of!(FrameBlock, width)),
                ("height", offset_of!(FrameBlock, height)),
                ("row_offset", offset_of!(FrameBlock, row_offset)),
                ("band_rows", offset_of!(FrameBlock, band_rows)),
                ("samples_per_axis", offset_of!(FrameBlock, samples_per_axis)),
            ],
        ),
        (
            "ProjectionBlock",
            size_of::<ProjectionBlock>(),
            vec![
                ("focal", offset_of!(ProjectionBlock, focal)),
                ("principal", offset_of!(ProjectionBlock, principal)),
                ("lens_origin", offset_of!(ProjectionBlock, lens_origin)),
            ],
        ),
        (
            "MirrorBlock",
            size_of::<MirrorBlock>(),
            vec![
                ("camera_tilt", offset_of!(MirrorBlock, camera_tilt)),
                ("mirror_diag", offset_of!(MirrorBlock, mirror_diag)),
                ("mirror_constant", offset_of!(MirrorBlock, mirror_constant)),
                ("mirror_linear", offset_of!(MirrorBlock, mirror_linear)),
                ("mount_sign", offset_of!(MirrorBlock, mount_sign)),
                ("camera_offset", offset_of!(MirrorBlock, camera_offset)),
                ("rim_sq", offset_of!(MirrorBlock, rim_sq)),
                ("mirror_min_z", offset_of!(MirrorBlock, mirror_min_z)),
                ("hidden_centre_sq", offset_of!(MirrorBlock, hidden_centre_sq)),
                ("orthographic", offset_of!(MirrorBlock, orthographic)),
                ("central", offset_of!(MirrorBlock, central)),
                ("shortcut", offset_of!(MirrorBlock, shortcut)),
                ("inner_lens", offset_of!(MirrorBlock, inner_lens)),
            ],
        ),
        (
            "Triangle",
            size_of::<Triangle>(),
            vec![
                ("v0", offset_of!(Triangle, v0)),
                ("face", offset_of!(Triangle, face)),
                ("e1", offset_of!(Triangle, e1)),
                ("leaf_order", offset_of!(Triangle, leaf_order)),
                ("e2", offset_of!(Triangle, e2)),
            ],
        ),
        (
            "PixelHit",
            size_of::<PixelHit>(),
            vec![
                ("point", offset_of!(PixelHit, point)),
                ("range", offset_of!(PixelHit, range)),
                ("normal", offset_of!(PixelHit, normal)),
                ("face", offset_of!(PixelHit, face)),
            ],
        ),
        (
            "ShadedPixel",
            size_of::<ShadedPixel>(),
            vec![
                ("linear", offset_of!(ShadedPixel, linear)),
                ("colour", offset_of!(ShadedPixel, colour)),
            ],
        ),
        (
            "GpuLight",
            size_of::<GpuLight>(),
            vec![
                ("vector", offset_of!(GpuLight, vector)),
                ("kind", offset_of!(GpuLight, kind)),
                ("strength", offset_of!(GpuLight, strength)),
            ],
        ),
        (
            "Material",
            size_of::<GpuMaterial>(),
            vec![
                ("rgb", offset_of!(GpuMaterial, rgb)),
                ("surface", offset_of!(GpuMaterial, surface)),
            ],
        ),
        (
            "GpuSurface",
            size_of::<GpuSurface>(),
            vec![
                ("anchor", offset_of!(GpuSurface, anchor)),
                ("levels_at", offset_of!(GpuSurface, levels_at)),
                ("u_gradient", offset_of!(GpuSurface, u_gradient)),
                ("u_at_anchor", offset_of!(GpuSurface, u_at_anchor)),
                ("v_gradient", offset_of!(GpuSurface, v_gradient)),
                ("v_at_anchor", offset_of!(GpuSurface, v_at_anchor)),
                ("colour_at_anchor", offset_of!(GpuSurface, colour_at_anchor)),
                ("level_count", offset_of!(GpuSurface, level_count)),
                ("red_gradient", offset_of!(GpuSurface, red_gradient)),
                ("wrap_u", offset_of!(GpuSurface, wrap_u)),
                ("green_gradient", offset_of!(GpuSurface, green_gradient)),
                ("wrap_v", offset_of!(GpuSurface, wrap_v)),
                ("blue_gradient", offset_of!(GpuSurface, blue_gradient)),
                ("flags", offset_of!(GpuSurface, flags)),
            ],
        ),
        (
            "ShadingParams",
            size_of::<ShadingParams>(),
            vec![
                ("ambient", offset_of!(ShadingParams, ambient)),
                ("inverse_white", offset_of!(ShadingParams, inverse_white)),
                ("light_count", offset_of!(ShadingParams, light_count)),
                ("lit", offset_of!(ShadingParams, lit)),
            ],
        ),
        (
            "WideNode",
            size_of::<GpuWideNode>(),
            vec![
                ("min", offset_of!(GpuWideNode, min)),
                ("max", offset_of!(GpuWideNode, max)),
                ("child", offset_of!(GpuWideNode, child)),
                ("lanes", offset_of!(GpuWideNode, lanes)),
            ],
        ),
    ]
}
