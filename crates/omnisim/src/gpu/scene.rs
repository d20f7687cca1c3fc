//! A scene on the GPU: geometry buffers (BVH nodes, triangles) uploaded once, and the small
//! appearance buffers (materials, lights, shading uniform) rewritten whenever colours or
//! lights change, without touching the geometry or the pipelines.

use std::sync::Mutex;

use bytemuck::Zeroable;
use glam::DVec3;

use super::context::{GpuContext, GpuError};
use super::layout::{GpuLight, GpuMaterial, GpuSurface, SURFACE_COLOURS, SURFACE_UNLIT, ShadingParams};
use super::timing::PassClock;
use super::{shader, wide};
use crate::accel::SceneBvh;
use crate::scene::lighting::{LightKind, linear_rgb};
use crate::scene::surface::{NO_SURFACE, Surfaces};
use crate::scene::texture::Texture;
use crate::shade::Appearance;

/// Per-frame buffers for one band size, reused between frames of one size.
pub(super) struct BandBuffers {
    pub(super) rows: u32,
    pub(super) width: u32,
    pub(super) hits: wgpu::Buffer,
    pub(super) hits_readback: wgpu::Buffer,
    pub(super) shaded: wgpu::Buffer,
    pub(super) shaded_readback: wgpu::Buffer,
    pub(super) camera: wgpu::Buffer,
    /// Host-visible hits a re-shade writes (made by the first re-shade of this band size).
    pub(super) upload: Option<wgpu::Buffer>,
    /// Timestamps of the passes, where the device has timestamp queries (made by the first
    /// frame that times its passes, [`super::GpuRenderer::time_passes`]).
    pub(super) clock: Option<PassClock>,
}

/// Buffers of one prepared scene.
pub(crate) struct GpuScene {
    pub(super) offset: DVec3,
    pub(super) nodes: wgpu::Buffer,
    pub(super) triangles: wgpu::Buffer,
    pub(super) materials: wgpu::Buffer,
    pub(super) lights: wgpu::Buffer,
    pub(super) shading: wgpu::Buffer,
    pub(super) surfaces: wgpu::Buffer,
    pub(super) textures: wgpu::Buffer,
    pub(super) band: Mutex<Option<BandBuffers>>,
    /// Face count, fixed by the geometry; appearances must match it.
    faces: usize,
}

/// Refuses, before any conversion, a BVH (of `depth` levels below its root, `nodes` wide nodes
/// and `triangles` triangles) the shader cannot walk: deeper than its stack, or with
/// more nodes or triangles than its entries address.
pub(super) fn check_limits(depth: usize, nodes: usize, triangles: usize) -> Result<(), GpuError> {
    // The walk keeps one group (the children not taken yet) per inner node above the one it
    // visits: one stack entry per level below the root.
    if depth > shader::STACK_SIZE {
        return Err(GpuError::BvhTooDeep {
            depth,
            limit: shader::STACK_SIZE,
        });
    }
    let counts = [
        ("nodes", nodes, wide::GPU_MAX_NODES),
        ("triangles", triangles, wide::GPU_MAX_TRIANGLES),
    ];
    match counts.into_iter().find(|&(_, count, limit)| count > limit) {
        Some((what, count, limit)) => Err(GpuError::BvhFormatLimit { what, count, limit }),
        None => Ok(()),
    }
}

impl GpuScene {
    /// Uploads the geometry and the appearance; refuses what the adapter cannot bind.
    pub(crate) fn new(context: &GpuContext, bvh: &SceneBvh, appearance: &Appearance) -> Result<Self, GpuError> {
        check_limits(bvh.wide.depth, bvh.wide.nodes.len(), bvh.triangles.len())?;
        let limit = context.storage_limit();
        let (nodes, triangles) = wide::gpu_bvh(bvh);
        let (surfaces, textures) = surface_data(bvh.offset, &appearance.surfaces);
        let sizes = [
            ("BVH nodes", std::mem::size_of_val(nodes.as_slice()), limit),
            ("triangles", std::mem::size_of_val(triangles.as_slice()), limit),
            ("materials", bvh.face_normals.len() * 16, limit),
            ("surfaces", std::mem::size_of_val(surfaces.as_slice()), limit),
            ("textures", std::mem::size_of_val(textures.as_slice()), limit),
        ];
        if let Some(&(buffer, bytes, limit)) = sizes.iter().find(|(_, bytes, limit)| *bytes as u64 > *limit) {
            return Err(GpuError::SceneTooLarge {
                buffer,
                bytes: bytes as u64,
                limit,
            });
        }
        context.known_loss()?;
        let storage = |label: &str, contents: &[u8]| {
            context.buffer_init(
                label,
                contents,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            )
        };
        let (materials, lights, shading) = appearance_data(bvh.offset, appearance);
        Ok(Self {
            offset: bvh.offset,
            nodes: storage("bvh nodes", bytemuck::cast_slice(&nodes))?,
            triangles: storage("triangles", bytemuck::cast_slice(&triangles))?,
            materials: storage("materials", bytemuck::cast_slice(&materials))?,
            lights: storage("lights", bytemuck::cast_slice(&lights))?,
            shading: context.buffer_init(
                "shading",
                bytemuck::bytes_of(&shading),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            )?,
            surfaces: storage("surfaces", bytemuck::cast_slice(&surfaces))?,
            textures: storage("textures", bytemuck::cast_slice(&textures))?,
            band: Mutex::new(None),
            faces: bvh.face_normals.len(),
        })
    }

    /// Rewrites the materials, lights and shading uniform in place (the lights buffer is
    /// replaced only when it must grow). Fails only where the device was lost.
    pub(crate) fn set_appearance(&mut self, context: &GpuContext, appearance: &Appearance) -> Result<(), GpuError> {
        context.known_loss()?;
        debug_assert_eq!(appearance.face_colours.len(), self.faces);
        let (materials, lights, shading) = appearance_data(self.offset, appearance);
        let queue = &context.queue;
        queue.write_buffer(&self.materials, 0, bytemuck::cast_slice(&materials));
        let bytes: &[u8] = bytemuck::cast_slice(&lights);
        if bytes.len() as u64 > self.lights.size() {
            let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
            self.lights = context.buffer_init("lights", bytes, usage)?;
        } else {
            queue.write_buffer(&self.lights, 0, bytes);
        }
        queue.write_buffer(&self.shading, 0, bytemuck::bytes_of(&shading));
        Ok(())
    }
}

/// The surfaces and textures as GPU data (each at least one entry: WGSL arrays cannot be
/// empty). Surfaces are uploaded with the geometry: an appearance change keeps them.
fn surface_data(offset: DVec3, surfaces: &Surfaces) -> (Vec<GpuSurface>, Vec<u32>) {
    // Each texture's level headers (first texel, width, height), then its texels; allocated
    // once, at its size (at least one word: WGSL arrays cannot be empty).
    let words: usize = surfaces.textures.iter().map(Texture::gpu_words).sum();
    let mut textures: Vec<u32> = Vec::with_capacity(words.max(1));
    let mut levels_at = Vec::with_capacity(surfaces.textures.len());
    for texture in &surfaces.textures {
        let header = textures.len();
        levels_at.push(header as u32);
        textures.resize(header + 3 * texture.levels.len(), 0);
        for (l, level) in texture.levels.iter().enumerate() {
            let first = textures.len() as u32;
            textures[header + 3 * l..header + 3 * l + 3].copy_from_slice(&[first, level.width, level.height]);
            textures.extend(level.srgb_texels());
        }
    }
    if textures.is_empty() {
        textures.push(0);
    }
    let f32s = |v: DVec3| v.as_vec3().to_array();
    let mut gpu: Vec<GpuSurface> = surfaces
        .list
        .iter()
        .map(|s| {
            let mut out = GpuSurface::zeroed();
            out.anchor = f32s(s.anchor - offset);
            out.levels_at = u32::MAX;
            if s.unlit {
                out.flags |= SURFACE_UNLIT;
            }
            if let Some(uv) = &s.uv {
                out.levels_at = levels_at[uv.texture as usize];
                out.level_count = surfaces.textures[uv.texture as usize].levels.len() as u32;
                (out.u_gradient, out.u_at_anchor) = (f32s(uv.gradient[0]), uv.at_anchor.x as f32);
                (out.v_gradient, out.v_at_anchor) = (f32s(uv.gradient[1]), uv.at_anchor.y as f32);
                (out.wrap_u, out.wrap_v) = (uv.wrap[0].gpu_code(), uv.wrap[1].gpu_code());
            }
            if let Some(c) = &s.colours {
                out.colour_at_anchor = f32s(c.at_anchor);
                out.red_gradient = f32s(c.gradient[0]);
                out.green_gradient = f32s(c.gradient[1]);
                out.blue_gradient = f32s(c.gradient[2]);
                out.flags |= SURFACE_COLOURS;
            }
            out
        })
        .collect();
    if gpu.is_empty() {
        gpu.push(GpuSurface::zeroed());
    }
    (gpu, textures)
}

/// The appearance as GPU data: linear albedo and surface per face, lights relative to the
/// scene offset (at least one entry, since WGSL arrays cannot be empty), and the shading uniform.
fn appearance_data(offset: DVec3, appearance: &Appearance) -> (Vec<GpuMaterial>, Vec<GpuLight>, ShadingParams) {
    let surface_of = &appearance.surfaces.of_face;
    let materials = appearance
        .face_colours
        .iter()
        .enumerate()
        .map(|(face, &c)| GpuMaterial {
            rgb: linear_rgb(c).as_vec3().to_array(),
            surface: surface_of.get(face).copied().unwrap_or(NO_SURFACE),
        })
        .collect();
    let mut lights: Vec<GpuLight> = appearance
        .lighting
        .iter()
        .flat_map(super::super::scene::lighting::Lighting::lights_on)
        .map(|light| {
            let (vector, kind, strength) = match light.kind {
                LightKind::Point { position, intensity } => (position - offset, 0, intensity),
                LightKind::Directional { direction, illuminance } => (direction, 1, illuminance),
            };
            GpuLight {
                vector: vector.as_vec3().to_array(),
                kind,
                strength: (light.colour * strength).as_vec3().to_array(),
                _pad: 0,
            }
        })
        .collect();
    let shading = match &appearance.lighting {
        None => ShadingParams {
            ambient: 0.0,
            inverse_white: 1.0,
            light_count: 0,
            lit: 0,
        },
        Some(lighting) => ShadingParams {
            ambient: lighting.ambient as f32,
            inverse_white: (1.0 / lighting.white) as f32,
            light_count: lights.len() as u32,
            lit: 1,
        },
    };
    if lights.is_empty() {
        lights.push(GpuLight::zeroed());
    }
    (materials, lights, shading)
}
