//! Uploads a scene once, then traces frames: one dispatch per band of image rows, each band
//! small enough for the adapter's storage-binding limit (128 MiB on lavapipe).

use glam::{DMat3, DVec3};
use wgpu::util::DeviceExt;

use super::context::{GpuContext, GpuError};
use super::layout::{CameraParams, PixelHit, Triangle};
use super::shader;
use crate::bvh::SceneBvh;
use crate::camera::{Camera, MirrorRays, Mount};
use crate::frame::{Frame, NO_FACE, Pixel};
use crate::pose::Pose;
use crate::pose::rotation_xyz;

/// Per-frame GPU buffers for one band size.
struct BandBuffers {
    bytes: u64,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

pub struct GpuTracer {
    context: GpuContext,
    pipeline: wgpu::ComputePipeline,
    refine_pipeline: wgpu::ComputePipeline,
    nodes: wgpu::Buffer,
    triangles: wgpu::Buffer,
    face_colours: wgpu::Buffer,
    offset: DVec3,
    band: std::sync::Mutex<Option<BandBuffers>>,
    max_band_rows: Option<u32>,
}

impl GpuTracer {
    pub fn new(context: GpuContext, bvh: &SceneBvh) -> Result<Self, GpuError> {
        let depth = bvh.depth();
        if depth >= shader::STACK_SIZE {
            return Err(GpuError::BvhTooDeep {
                depth,
                limit: shader::STACK_SIZE,
            });
        }
        let device = &context.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("omnisim trace"),
            source: wgpu::ShaderSource::Wgsl(shader::source().into()),
        });
        let pipeline_for = |entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: None,
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipeline = pipeline_for(shader::ENTRY_POINT);
        let refine_pipeline = pipeline_for(shader::REFINE_ENTRY_POINT);
        let storage = |label: &str, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let triangles: Vec<Triangle> = bvh
            .triangles
            .iter()
            .zip(&bvh.face)
            .map(|(t, &face)| Triangle {
                v0: t[0].as_vec3().to_array(),
                face,
                e1: (t[1] - t[0]).as_vec3().to_array(),
                _pad1: 0,
                e2: (t[2] - t[0]).as_vec3().to_array(),
                _pad2: 0,
            })
            .collect();
        let colours: Vec<u32> = bvh
            .face_colours
            .iter()
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], 255]))
            .collect();
        let limit = context
            .limits
            .max_storage_buffer_binding_size
            .min(context.limits.max_buffer_size);
        let sizes = [
            ("BVH nodes", std::mem::size_of_val(bvh.bvh.nodes.as_slice())),
            ("triangles", std::mem::size_of_val(triangles.as_slice())),
            ("face colours", std::mem::size_of_val(colours.as_slice())),
        ];
        if let Some(&(buffer, bytes)) = sizes.iter().find(|(_, bytes)| *bytes as u64 > limit) {
            return Err(GpuError::SceneTooLarge {
                buffer,
                bytes: bytes as u64,
                limit,
            });
        }
        Ok(Self {
            nodes: storage("bvh nodes", bytemuck::cast_slice(&bvh.bvh.nodes)),
            triangles: storage("triangles", bytemuck::cast_slice(&triangles)),
            face_colours: storage("face colours", bytemuck::cast_slice(&colours)),
            offset: bvh.offset,
            band: std::sync::Mutex::new(None),
            max_band_rows: None,
            pipeline,
            refine_pipeline,
            context,
        })
    }

    /// Traces at most `rows` image rows per dispatch (at least 1), below the adapter's own
    /// limit: for adapters that struggle with large buffers, and to test the banding.
    pub fn limit_band_rows(&mut self, rows: u32) {
        self.max_band_rows = Some(rows.max(1));
    }

    pub fn context(&self) -> &GpuContext {
        &self.context
    }

    pub fn render(&self, camera: &Camera, pose: &Pose) -> Result<Frame, GpuError> {
        let (width, height) = camera.size();
        let row_bytes = width as u64 * std::mem::size_of::<PixelHit>() as u64;
        let max_binding = self
            .context
            .limits
            .max_storage_buffer_binding_size
            .min(self.context.limits.max_buffer_size);
        let max_rows_by_dispatch =
            self.context.limits.max_compute_workgroups_per_dimension as u64 * shader::WORKGROUP_SIZE[1] as u64;
        let band_rows = (max_binding / row_bytes)
            .min(max_rows_by_dispatch)
            .min(self.max_band_rows.unwrap_or(u32::MAX) as u64)
            .min(height as u64) as u32;
        if band_rows == 0 {
            return Err(GpuError::ImageTooWide { width, height });
        }
        let mut params = camera_params(camera, pose, self.offset);
        let band_bytes = band_rows as u64 * row_bytes;
        // Consecutive frames of one size (trajectories, grids) reuse their buffers.
        let mut cache = self.band.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if cache.as_ref().is_some_and(|b| b.bytes != band_bytes) {
            *cache = None;
        }
        let buffers = &*cache.get_or_insert_with(|| self.band_buffers(band_bytes));
        let mut frame = Frame::empty(width, height);
        let mut row = 0;
        while row < height {
            let rows = band_rows.min(height - row);
            params.row_offset = row;
            params.band_rows = rows;
            self.context
                .queue
                .write_buffer(&buffers.uniform, 0, bytemuck::bytes_of(&params));
            let groups = [
                width.div_ceil(shader::WORKGROUP_SIZE[0]),
                rows.div_ceil(shader::WORKGROUP_SIZE[1]),
            ];
            let hits: Vec<PixelHit> = self.run_pass(
                &self.pipeline,
                &buffers.bind_group,
                groups,
                (&buffers.output, &buffers.readback),
                rows as u64 * row_bytes,
            )?;
            let start = row as usize * width as usize;
            for (pixel, hit) in frame.pixels_mut()[start..start + hits.len()].iter_mut().zip(&hits) {
                if hit.face != NO_FACE {
                    let [r, g, b, _] = hit.colour.to_le_bytes();
                    *pixel = Pixel {
                        colour: [r, g, b],
                        range: hit.range,
                        face: hit.face,
                        point: self.offset + glam::Vec3::from_array(hit.point).as_dvec3(),
                    };
                }
            }
            row += rows;
        }
        Ok(frame)
    }

    /// Replaces the colour of every edge pixel (see `antialias::edge_pixels`) by the mean of
    /// `samples_per_axis²` stratified samples traced on the GPU. Returns how many pixels.
    pub fn refine_edges(
        &self,
        camera: &Camera,
        pose: &Pose,
        frame: &mut Frame,
        samples_per_axis: u32,
    ) -> Result<usize, GpuError> {
        let edges: Vec<u32> = crate::antialias::edge_pixels(frame)
            .into_iter()
            .map(|i| i as u32)
            .collect();
        if samples_per_axis <= 1 || edges.is_empty() {
            return Ok(0);
        }
        let device = &self.context.device;
        let mut params = camera_params(camera, pose, self.offset);
        params.samples_per_axis = samples_per_axis;
        let bytes = (edges.len() * std::mem::size_of::<u32>()) as u64;
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let uniform = init("camera", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let pixels = init("edge pixels", bytemuck::cast_slice(&edges), wgpu::BufferUsages::STORAGE);
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage,
                mapped_at_creation: false,
            })
        };
        let colours = buffer(
            "edge colours",
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let readback = buffer(
            "edge colours readback",
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let bindings = [
            (0, &uniform),
            (1, &self.nodes),
            (2, &self.triangles),
            (3, &self.face_colours),
            (5, &pixels),
            (6, &colours),
        ];
        let bind_group = self.bind_group("refine edges", &self.refine_pipeline, &bindings);
        let groups = (edges.len() as u32).div_ceil(shader::REFINE_WORKGROUP_SIZE);
        let columns = groups.min(self.context.limits.max_compute_workgroups_per_dimension);
        let groups = [columns, groups.div_ceil(columns)];
        let refined: Vec<u32> =
            self.run_pass(&self.refine_pipeline, &bind_group, groups, (&colours, &readback), bytes)?;
        for (&index, colour) in edges.iter().zip(refined) {
            let [r, g, b, _] = colour.to_le_bytes();
            frame.pixels_mut()[index as usize].colour = [r, g, b];
        }
        Ok(edges.len())
    }

    /// Output, readback and camera buffers for bands of `bytes`, bound with the scene.
    fn band_buffers(&self, bytes: u64) -> BandBuffers {
        let device = &self.context.device;
        let buffer = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let output = buffer(
            "pixel hits",
            bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let readback = buffer(
            "pixel hits readback",
            bytes,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let uniform = buffer(
            "camera",
            std::mem::size_of::<CameraParams>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let bindings = [
            (0, &uniform),
            (1, &self.nodes),
            (2, &self.triangles),
            (3, &self.face_colours),
            (4, &output),
        ];
        let bind_group = self.bind_group("trace", &self.pipeline, &bindings);
        BandBuffers {
            bytes,
            output,
            readback,
            uniform,
            bind_group,
        }
    }

    /// Dispatches `pipeline` over `groups` (x, y) workgroups, copies the first `bytes` of
    /// `output` to the mappable `readback` and reads them back.
    fn run_pass<T: bytemuck::Pod>(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bind_group: &wgpu::BindGroup,
        groups: [u32; 2],
        (output, readback): (&wgpu::Buffer, &wgpu::Buffer),
        bytes: u64,
    ) -> Result<Vec<T>, GpuError> {
        let mut encoder = self.context.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], 1);
        }
        encoder.copy_buffer_to_buffer(output, 0, readback, 0, bytes);
        self.context.queue.submit([encoder.finish()]);
        self.read(readback, bytes)
    }

    /// Binds whole buffers to the numbered bindings of group 0 of `pipeline`.
    fn bind_group(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        self.context.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    fn read<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<T>, GpuError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, ..bytes, move |result| {
            let _ = sender.send(result);
        });
        self.context
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        receiver
            .recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let hits = {
            let view = buffer
                .get_mapped_range(..bytes)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            bytemuck::cast_slice::<u8, T>(&view).to_vec()
        };
        buffer.unmap();
        Ok(hits)
    }
}

/// The uniform block of one render: camera model parameters and the pose, with the viewpoint
/// made relative to the scene offset in f64 before rounding to f32.
fn camera_params(camera: &Camera, pose: &Pose, offset: DVec3) -> CameraParams {
    let column = |c: DVec3| [c.x as f32, c.y as f32, c.z as f32, 0.0];
    let columns = |m: DMat3| [column(m.x_axis), column(m.y_axis), column(m.z_axis)];
    let vector = |v: DVec3| v.as_vec3().to_array();
    let (width, height) = camera.size();
    let mut params = CameraParams {
        world_from_body: columns(pose.world_from_body_rotation()),
        origin: vector(pose.position - offset),
        kind: camera.gpu_kind(),
        width,
        height,
        row_offset: 0,
        band_rows: height,
        focal: [1.0, 1.0],
        principal: [0.0, 0.0],
        lens_origin: [0.0; 3],
        mirror_min_z: 0.0,
        camera_tilt: columns(DMat3::IDENTITY),
        mirror_diag: [0.0; 3],
        mirror_constant: 0.0,
        mirror_linear: [0.0; 3],
        mount_sign: 1.0,
        camera_offset: [0.0; 3],
        rim_sq: -1.0,
        hidden_centre_sq: 0.0,
        orthographic: 0,
        central: 1,
        shortcut: 0,
        samples_per_axis: 1,
        _pad: [0; 3],
    };
    match camera {
        Camera::Pinhole(c) => {
            params.focal = [c.fx as f32, c.fy as f32];
            params.principal = [c.cx as f32, c.cy as f32];
            params.lens_origin = vector(c.position);
        }
        Camera::Equirectangular(_) => {}
        Camera::Cylindrical(c) => {
            params.focal = [1.0, c.fy as f32];
            params.principal = [0.0, c.cy as f32];
        }
        Camera::Catadioptric(c) => {
            // Frame C: the mirror frame shifted to the nominal camera position N.
            let nominal = c.nominal_camera_in_mirror();
            let quadric = c.quadric().shifted(nominal);
            params.focal = [c.focal as f32, c.focal as f32];
            params.principal = [c.cx as f32, c.cy as f32];
            params.lens_origin = vector(c.body_from_mirror() * (nominal - c.body_origin_in_mirror()));
            params.mirror_min_z = quadric.min_z.max(-3.0e38) as f32;
            params.camera_tilt = columns(rotation_xyz(c.misalignment.tilt));
            params.mirror_diag = vector(quadric.diag);
            params.mirror_constant = quadric.constant as f32;
            params.mirror_linear = vector(quadric.linear);
            params.mount_sign = if c.mount == Mount::Up { 1.0 } else { -1.0 };
            params.camera_offset = vector(c.misalignment.offset);
            params.rim_sq = c.rim_radius.map_or(-1.0, |r| (r * r) as f32);
            params.hidden_centre_sq = (c.hidden_centre_px * c.hidden_centre_px) as f32;
            params.orthographic = u32::from(!c.is_perspective());
            params.central = u32::from(c.is_central());
            params.shortcut = u32::from(c.rays == MirrorRays::Shortcut);
        }
    }
    params
}
