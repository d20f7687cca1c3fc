//! The device and the compiled pipelines, made once and used for any number of scenes and
//! frames: a trace pass writes the hit planes, a shade pass turns them into colour, a refine
//! pass supersamples edge pixels. Images are traced in bands of rows, each small enough for
//! the adapter's storage-binding limit (128 MiB on lavapipe).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use rayon::prelude::*;

use glam::{DMat3, DVec3, Vec3};

use super::bindings::{
    self, Binding, CAMERA, CAMERA_RAYS, EDGE_COLOURS, EDGE_PIXELS, HITS, LIGHTS, MATERIALS, NODES, SHADED, SHADING,
    SURFACES, Stage, TEXTURES, TRIANGLES,
};
use super::context::{GpuContext, GpuError};
use super::layout::{CameraParams, FrameBlock, MirrorBlock, PixelHit, ProjectionBlock, ShadedPixel};
use super::scene::{BandBuffers, GpuScene};
use super::shader;
use super::timing::{self, GpuStages, Pass, PassClock};
use crate::camera::{Camera, MirrorRays, Mount};
use crate::frame::{BACKGROUND, Frame, NO_FACE, Pixel, Plane, Planes};
use crate::pose::{Pose, rotation_xyz};

/// How many compute pipelines this process has compiled, for tests that prove a change of
/// colours or lights compiles nothing.
static PIPELINES_BUILT: AtomicUsize = AtomicUsize::new(0);

/// The GPU backend: the process's shared context (`context.rs`) and this renderer's three
/// compute pipelines.
pub struct GpuRenderer {
    context: Arc<GpuContext>,
    trace: Pipeline,
    shade: Pipeline,
    refine: Pipeline,
    max_band_rows: Option<u32>,
    /// Whether frames time their passes by timestamp queries (`omnisim bench`; off by default).
    time_passes: bool,
    /// The ray table of the last lens camera traced (`camera_table.wgsl`), uploaded once per
    /// camera and kept under [`table_key`]; other cameras bind `no_rays`.
    rays: Mutex<Option<(Camera, Arc<wgpu::Buffer>)>>,
    no_rays: Arc<wgpu::Buffer>,
    /// Where the last frame spent its time, for `omnisim bench`; [`crate::Renderer`] clears it
    /// as a frame starts, and a frame that finishes on the GPU sets it. One slot: meaningful
    /// when frames run one at a time.
    stages: Mutex<Option<GpuStages>>,
}

/// How long a frame waits, after the GPU finished its work, for its buffers' map callbacks that
/// another thread's poll is running: far beyond the milliseconds that takes, and a bound where a
/// callback never comes.
const CALLBACK_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

/// What a camera's ray table depends on: the camera without its place. The table holds
/// directions only (origins come from `lens_origin`), so the two cameras of a stereo pair
/// share one upload.
fn table_key(camera: &Camera) -> Camera {
    let mut key = camera.clone();
    if let Camera::Lens(lens) = &mut key {
        lens.intrinsics.position = DVec3::ZERO;
    }
    key
}

/// A compute pipeline with the explicit layout of its stage's bindings (`bindings.rs`).
#[derive(Debug)]
struct Pipeline {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    stage: &'static Stage,
}

/// Where the hits of a band come from: traced now, or uploaded from a frame to re-shade.
#[derive(Clone, Copy)]
enum HitSource<'a> {
    Trace,
    Upload(&'a [Pixel]),
}

/// The planes a run of bands made: the hit planes where it traced (empty for an upload), and
/// the shaded planes the request asked for (each empty where not asked for).
struct BandOutput {
    hits: Vec<Pixel>,
    colour: Vec<[u8; 3]>,
    linear: Vec<[f32; 3]>,
}

impl GpuRenderer {
    /// Compiles the WGSL program and its pipelines on `context`'s device.
    pub(crate) fn new(context: Arc<GpuContext>) -> Self {
        let device = &context.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("omnisim"),
            source: wgpu::ShaderSource::Wgsl(shader::source().into()),
        });
        let pipeline_for = |stage: &'static Stage| {
            PIPELINES_BUILT.fetch_add(1, Ordering::Relaxed);
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(stage.entry_point),
                entries: &bindings::layout_entries(stage),
            });
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(stage.entry_point),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(stage.entry_point),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(stage.entry_point),
                compilation_options: Default::default(),
                cache: None,
            });
            Pipeline {
                pipeline,
                layout,
                stage,
            }
        };
        let no_rays = Arc::new(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no camera rays"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        }));
        Self {
            trace: pipeline_for(&bindings::TRACE),
            shade: pipeline_for(&bindings::SHADE),
            refine: pipeline_for(&bindings::REFINE),
            context,
            max_band_rows: None,
            time_passes: false,
            rays: Mutex::new(None),
            no_rays,
            stages: Mutex::new(None),
        }
    }

    /// Takes `old`'s band limit and pass timing: a renderer reopened in its place.
    pub(crate) fn keep_settings(&mut self, old: &GpuRenderer) {
        self.max_band_rows = old.max_band_rows;
        self.time_passes = old.time_passes;
    }

    /// Compute pipelines compiled by this process so far (every `GpuRenderer` adds three): a
    /// test counter.
    #[cfg(feature = "test-counters")]
    pub fn pipelines_built() -> usize {
        PIPELINES_BUILT.load(Ordering::Relaxed)
    }

    /// Traces at most `rows` image rows per dispatch (at least 1), below the adapter's own
    /// limit: for adapters that struggle with large buffers, and to test the banding.
    pub fn limit_band_rows(&mut self, rows: u32) {
        self.max_band_rows = Some(rows.max(1));
    }

    /// Times each pass of the next frames on the GPU ([`GpuStages::trace_pass`] and
    /// [`GpuStages::shade_pass`]), where the device has timestamp queries: for `omnisim
    /// bench`. Off by default, so that other frames write and read back no timestamps.
    pub fn time_passes(&mut self, on: bool) {
        self.time_passes = on;
    }

    /// Whether the device has timestamp queries, so that [`GpuRenderer::time_passes`] times
    /// the passes.
    pub fn has_pass_clock(&self) -> bool {
        timing::has_timestamps(&self.context.device)
    }

    /// Whether the adapter is a software rasteriser on the CPU (llvmpipe, lavapipe, WARP).
    pub fn is_software(&self) -> bool {
        self.context.is_software()
    }

    pub(crate) fn context(&self) -> &GpuContext {
        &self.context
    }

    /// Where the last frame (render or re-shade) spent its time; `None` if it failed or did
    /// not run here. Meaningful when frames run one at a time (one slot for all frames).
    pub(crate) fn last_stages(&self) -> Option<GpuStages> {
        *self.stages.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Forgets the last frame's stages, as a frame starts.
    pub(crate) fn forget_stages(&self) {
        *self.stages.lock().unwrap_or_else(PoisonError::into_inner) = None;
    }

    /// Runs a frame's GPU work: refused at once where the device is known to be lost, and any
    /// failure on a device lost meanwhile reported as that loss ([`GpuError::DeviceLost`]).
    fn on_device<T>(&self, work: impl FnOnce() -> Result<T, GpuError>) -> Result<T, GpuError> {
        self.context.known_loss()?;
        work().map_err(|error| self.context.blame(error))
    }

    /// Traces a frame and shades the planes `planes` asks for.
    pub(crate) fn render(
        &self,
        scene: &GpuScene,
        camera: &Camera,
        pose: &Pose,
        planes: Planes,
    ) -> Result<Frame, GpuError> {
        let (width, height) = camera.size();
        let output = self.on_device(|| self.run_bands(scene, camera, pose, planes, HitSource::Trace))?;
        let mut frame = Frame::from_hits(width, height, output.hits);
        if planes.needs_shading() {
            frame.set_shading(planes, output.linear, output.colour);
        }
        Ok(frame)
    }

    /// Shades `frame`'s hit planes again (after a change of colours or lights), no tracing.
    pub(crate) fn reshade(
        &self,
        scene: &GpuScene,
        camera: &Camera,
        pose: &Pose,
        frame: &mut Frame,
        planes: Planes,
    ) -> Result<(), GpuError> {
        let source = HitSource::Upload(frame.pixels());
        let output = self.on_device(|| self.run_bands(scene, camera, pose, planes, source))?;
        if planes.needs_shading() {
            frame.set_shading(planes, output.linear, output.colour);
        }
        Ok(())
    }

    /// The ray table of a camera with a lens model (made and uploaded on its first frame,
    /// kept while the same camera is traced); a placeholder for the cameras the shader
    /// computes rays for.
    fn camera_rays(&self, camera: &Camera) -> Result<Arc<wgpu::Buffer>, GpuError> {
        if !camera.has_lens_model() {
            return Ok(Arc::clone(&self.no_rays));
        }
        let key = table_key(camera);
        // The lock is held only to look and to store: the table is built on the rayon pool,
        // which may run another frame on this thread meanwhile (rayon issue #592).
        if let Some((cached, buffer)) = self.rays.lock().unwrap_or_else(PoisonError::into_inner).as_ref()
            && *cached == key
        {
            return Ok(Arc::clone(buffer));
        }
        let (width, height) = camera.size();
        let pixels = width as usize * height as usize;
        let bytes = pixels as u64 * 16;
        let limit = self.context.storage_limit();
        if bytes > limit {
            return Err(GpuError::SceneTooLarge {
                buffer: "camera ray table (16 bytes a pixel)",
                bytes,
                limit,
            });
        }
        let table: Vec<[f32; 4]> = (0..pixels)
            .into_par_iter()
            .map(|index| {
                let direction = match camera {
                    // The mirror's camera: its lens's direction, before the tilt and the mirror.
                    Camera::Catadioptric(c) => c
                        .lens_ray(crate::camera::pixel_centre(index, width))
                        .map(|(_, direction)| direction),
                    _ => camera.pixel_ray(index).map(|ray| ray.direction),
                };
                direction.map_or([0.0; 4], |d| d.as_vec3().extend(1.0).to_array())
            })
            .collect();
        let buffer = Arc::new(self.context.buffer_init(
            "camera rays",
            bytemuck::cast_slice(&table),
            wgpu::BufferUsages::STORAGE,
        )?);
        *self.rays.lock().unwrap_or_else(PoisonError::into_inner) = Some((key, Arc::clone(&buffer)));
        Ok(buffer)
    }

    /// Traces (or uploads) and shades the image band by band. Each band's results are read
    /// straight from the mapped buffers into the frame's planes, on every core: on a real GPU
    /// this host work, not the GPU's, decided the time per image (docs/benchmarks.md, issue 18).
    fn run_bands(
        &self,
        scene: &GpuScene,
        camera: &Camera,
        pose: &Pose,
        planes: Planes,
        source: HitSource,
    ) -> Result<BandOutput, GpuError> {
        let (width, height) = camera.size();
        let row_bytes = u64::from(width) * size_of::<PixelHit>();
        let max_rows_by_dispatch =
            u64::from(self.context.limits.max_compute_workgroups_per_dimension) * u64::from(shader::WORKGROUP_SIZE[1]);
        let band_rows = (self.context.storage_limit() / row_bytes.max(1))
            .min(max_rows_by_dispatch)
            .min(u64::from(self.max_band_rows.unwrap_or(u32::MAX)))
            .min(u64::from(height)) as u32;
        if band_rows == 0 {
            return Err(GpuError::ImageTooWide { width, height });
        }
        // Band 1's submit stage includes the bind groups and the ray table's first upload.
        let submit_start = Instant::now();
        let params = camera_params(camera, pose, scene.offset);
        let rays = self.camera_rays(camera)?;
        // Consecutive frames of one size (trajectories, grids) reuse their buffers. They are
        // taken out of the scene for the frame, not locked through it: the frame's rayon work
        // may run another frame of this scene on the same thread (rayon issue #592), which
        // then makes its own set. A frame that fails or panics drops its set. The lock is held
        // only to take or put back a set, which cannot panic, so a poisoned lock holds no
        // mapped buffers.
        let cached = scene.band.lock().unwrap_or_else(PoisonError::into_inner).take();
        let mut buffers = cached
            .filter(|b| (b.rows, b.width) == (band_rows, width))
            .unwrap_or_else(|| self.band_buffers(band_rows, width));
        if matches!(source, HitSource::Upload(_)) && buffers.upload.is_none() {
            let usage = wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC;
            buffers.upload = Some(self.buffer("hits upload", buffers.hits.size(), usage));
        }
        if self.time_passes && buffers.clock.is_none() {
            buffers.clock = PassClock::new(&self.context.device, &self.context.queue);
        }
        let output = self.trace_bands(
            scene,
            &buffers,
            camera,
            params,
            &rays,
            band_rows,
            planes,
            source,
            submit_start,
        )?;
        *scene.band.lock().unwrap_or_else(PoisonError::into_inner) = Some(buffers);
        Ok(output)
    }

    /// The bands of one frame, on `buffers` (bands of `band_rows` rows of the camera's width).
    #[expect(
        clippy::too_many_arguments,
        reason = "one frame's state, split from `run_bands` for its buffers' lifetime"
    )]
    fn trace_bands(
        &self,
        scene: &GpuScene,
        buffers: &BandBuffers,
        camera: &Camera,
        mut params: CameraParams,
        rays: &wgpu::Buffer,
        band_rows: u32,
        planes: Planes,
        source: HitSource,
        mut submit_start: Instant,
    ) -> Result<BandOutput, GpuError> {
        let (width, height) = camera.size();
        let trace = matches!(source, HitSource::Trace);
        let shade = planes.needs_shading();
        let clock = buffers.clock.as_ref().filter(|_| self.time_passes);
        let trace_group = self.bind_group(
            &self.trace,
            &[
                (CAMERA, &buffers.camera),
                (NODES, &scene.nodes),
                (TRIANGLES, &scene.triangles),
                (HITS, &buffers.hits),
                (CAMERA_RAYS, rays),
            ],
        );
        let shade_group = self.bind_group(
            &self.shade,
            &[
                (CAMERA, &buffers.camera),
                (NODES, &scene.nodes),
                (TRIANGLES, &scene.triangles),
                (MATERIALS, &scene.materials),
                (HITS, &buffers.hits),
                (LIGHTS, &scene.lights),
                (SHADING, &scene.shading),
                (SHADED, &buffers.shaded),
                (CAMERA_RAYS, rays),
                (SURFACES, &scene.surfaces),
                (TEXTURES, &scene.textures),
            ],
        );
        let pixel_count = width as usize * height as usize;
        let wanted = |wanted: bool| if wanted { pixel_count } else { 0 };
        let mut output = BandOutput {
            hits: Vec::with_capacity(wanted(trace)),
            colour: Vec::with_capacity(wanted(planes.contains(Plane::Colour))),
            linear: Vec::with_capacity(wanted(planes.contains(Plane::LinearColour))),
        };
        let mut stages = GpuStages::default();
        let mut row = 0;
        while row < height {
            let rows = band_rows.min(height - row);
            params.frame.row_offset = row;
            params.frame.band_rows = rows;
            let queue = &self.context.queue;
            queue.write_buffer(&buffers.camera, 0, bytemuck::bytes_of(&params));
            let range = row as usize * width as usize..(row + rows) as usize * width as usize;
            let pixels = range.len() as u64;
            let hit_bytes = pixels * size_of::<PixelHit>();
            let shaded_bytes = pixels * size_of::<ShadedPixel>();
            let mut encoder = self.context.device.create_command_encoder(&Default::default());
            if let (HitSource::Upload(hits), Some(upload)) = (source, &buffers.upload) {
                // Sliced before mapping: nothing that can panic runs while the buffer is mapped.
                let band_hits = &hits[range.clone()];
                self.map_buffers(&[(upload, hit_bytes)], wgpu::MapMode::Write)?;
                let unmap = Unmap(vec![upload]);
                upload
                    .get_mapped_range_mut(..hit_bytes)
                    .map(|mut view| write_gpu_hits(view.slice(..), band_hits, scene.offset))
                    .map_err(|e| GpuError::Readback(e.to_string()))?;
                drop(unmap);
                copy(&mut encoder, upload, &buffers.hits, hit_bytes);
            }
            let groups = [
                width.div_ceil(shader::WORKGROUP_SIZE[0]),
                rows.div_ceil(shader::WORKGROUP_SIZE[1]),
            ];
            let mut to_map = Vec::with_capacity(3);
            if trace {
                let writes = clock.map(|c| c.writes(Pass::Trace));
                dispatch(&mut encoder, &self.trace, &trace_group, groups, writes);
                copy(&mut encoder, &buffers.hits, &buffers.hits_readback, hit_bytes);
                to_map.push((&buffers.hits_readback, hit_bytes));
            }
            if shade {
                let writes = clock.map(|c| c.writes(Pass::Shade));
                dispatch(&mut encoder, &self.shade, &shade_group, groups, writes);
                copy(&mut encoder, &buffers.shaded, &buffers.shaded_readback, shaded_bytes);
                to_map.push((&buffers.shaded_readback, shaded_bytes));
            }
            if let Some(clock) = clock {
                let passes = [(trace, Pass::Trace), (shade, Pass::Shade)];
                for (_, pass) in passes.into_iter().filter(|(run, _)| *run) {
                    clock.resolve(&mut encoder, pass);
                }
                to_map.push((&clock.readback, clock.readback.size()));
            }
            queue.submit([encoder.finish()]);
            stages.submit += submit_start.elapsed();
            let wait_start = Instant::now();
            self.map_buffers(&to_map, wgpu::MapMode::Read)?;
            // Declared before the views, so dropped after them, on every exit.
            let unmap = Unmap(to_map.iter().map(|&(buffer, _)| buffer).collect());
            let read_start = Instant::now();
            stages.wait += read_start - wait_start;
            let hits_view = trace.then(|| mapped(&buffers.hits_readback, hit_bytes)).transpose()?;
            let shaded_view = shade
                .then(|| mapped(&buffers.shaded_readback, shaded_bytes))
                .transpose()?;
            let gpu_hits: Option<&[PixelHit]> = hits_view.as_deref().map(bytemuck::cast_slice);
            let shaded: Option<&[ShadedPixel]> = shaded_view.as_deref().map(bytemuck::cast_slice);
            let offset = scene.offset;
            match (gpu_hits, shaded.filter(|_| planes.contains(Plane::Colour))) {
                // Hits and colour in one parallel pass (one fork-join): on an H200 this
                // took the readback of a Mpixel from 1.45 to 0.7-0.8 ms.
                (Some(gpu_hits), Some(shaded)) => {
                    let mut both = (std::mem::take(&mut output.hits), std::mem::take(&mut output.colour));
                    both.par_extend(
                        gpu_hits
                            .par_iter()
                            .zip(shaded)
                            .with_min_len(MIN_TASK_PIXELS)
                            .map(|(h, s)| {
                                let hit = host_hit(h, offset);
                                (hit, colour_of(s, &hit))
                            }),
                    );
                    (output.hits, output.colour) = both;
                }
                (Some(gpu_hits), None) => output.hits.par_extend(
                    gpu_hits
                        .par_iter()
                        .with_min_len(MIN_TASK_PIXELS)
                        .map(|h| host_hit(h, offset)),
                ),
                // A re-shade: the hits are the frame's own.
                (None, Some(shaded)) => {
                    if let HitSource::Upload(hits) = source {
                        output.colour.par_extend(
                            shaded
                                .par_iter()
                                .zip(&hits[range])
                                .with_min_len(MIN_TASK_PIXELS)
                                .map(|(s, hit)| colour_of(s, hit)),
                        );
                    }
                }
                (None, None) => {}
            }
            if let Some(shaded) = shaded.filter(|_| planes.contains(Plane::LinearColour)) {
                output
                    .linear
                    .par_extend(shaded.par_iter().with_min_len(MIN_TASK_PIXELS).map(|s| s.linear));
            }
            drop((hits_view, shaded_view));
            if let Some(clock) = clock {
                let view = mapped(&clock.readback, clock.readback.size())?;
                let first_band = row == 0;
                timing::add_pass(
                    &mut stages.trace_pass,
                    trace.then(|| clock.elapsed(&view, Pass::Trace)).flatten(),
                    first_band,
                );
                timing::add_pass(
                    &mut stages.shade_pass,
                    shade.then(|| clock.elapsed(&view, Pass::Shade)).flatten(),
                    first_band,
                );
            }
            drop(unmap);
            stages.readback += read_start.elapsed();
            stages.bands += 1;
            row += rows;
            submit_start = Instant::now();
        }
        *self.stages.lock().unwrap_or_else(PoisonError::into_inner) = Some(stages);
        Ok(output)
    }

    /// Replaces the shaded planes of the pixels `edges` (see `shade/coverage.rs`) by the
    /// mean of `samples_per_axis²` stratified samples traced and shaded on the GPU. Returns
    /// how many pixels were refined.
    pub(crate) fn refine_edges(
        &self,
        scene: &GpuScene,
        camera: &Camera,
        pose: &Pose,
        frame: &mut Frame,
        samples_per_axis: u32,
        edges: &[usize],
    ) -> Result<usize, GpuError> {
        self.on_device(|| {
            let edges: Vec<u32> = edges.iter().map(|&i| i as u32).collect();
            if samples_per_axis <= 1 || edges.is_empty() {
                return Ok(0);
            }
            if camera.has_lens_model() {
                // The table holds pixel centres only; the renderer refines lens cameras on the CPU.
                return Err(GpuError::NoGpuCamera(camera.model_name()));
            }
            let mut params = camera_params(camera, pose, scene.offset);
            params.frame.samples_per_axis = samples_per_axis;
            let bytes = edges.len() as u64 * size_of::<ShadedPixel>();
            let context = &self.context;
            let uniform = context.buffer_init("camera", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM)?;
            let pixels =
                context.buffer_init("edge pixels", bytemuck::cast_slice(&edges), wgpu::BufferUsages::STORAGE)?;
            let colours = self.buffer(
                "edge colours",
                bytes,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            );
            let readback = self.buffer(
                "edge colours readback",
                bytes,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            );
            let bind_group = self.bind_group(
                &self.refine,
                &[
                    (CAMERA, &uniform),
                    (NODES, &scene.nodes),
                    (TRIANGLES, &scene.triangles),
                    (MATERIALS, &scene.materials),
                    (EDGE_PIXELS, &pixels),
                    (EDGE_COLOURS, &colours),
                    (LIGHTS, &scene.lights),
                    (SHADING, &scene.shading),
                    (CAMERA_RAYS, &self.no_rays),
                    (SURFACES, &scene.surfaces),
                    (TEXTURES, &scene.textures),
                ],
            );
            let groups = (edges.len() as u32).div_ceil(shader::REFINE_WORKGROUP_SIZE);
            let columns = groups.min(self.context.limits.max_compute_workgroups_per_dimension);
            let mut encoder = context.device.create_command_encoder(&Default::default());
            dispatch(
                &mut encoder,
                &self.refine,
                &bind_group,
                [columns, groups.div_ceil(columns)],
                None,
            );
            copy(&mut encoder, &colours, &readback, bytes);
            self.context.queue.submit([encoder.finish()]);
            let refined: Vec<ShadedPixel> = self.read(&readback, bytes)?;
            let (colour, linear) = frame.shading_mut();
            if let Some(colour) = colour {
                for (&index, s) in edges.iter().zip(&refined) {
                    colour[index as usize] = unpack(s.colour);
                }
            }
            if let Some(linear) = linear {
                for (&index, s) in edges.iter().zip(&refined) {
                    linear[index as usize] = s.linear;
                }
            }
            Ok(edges.len())
        })
    }

    /// Hit, shaded and readback buffers for bands of `rows` × `width` pixels.
    fn band_buffers(&self, rows: u32, width: u32) -> BandBuffers {
        let pixels = u64::from(rows) * u64::from(width);
        let output = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let readback = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let hit_bytes = pixels * size_of::<PixelHit>();
        let shaded_bytes = pixels * size_of::<ShadedPixel>();
        BandBuffers {
            rows,
            width,
            hits: self.buffer("hits", hit_bytes, output),
            hits_readback: self.buffer("hits readback", hit_bytes, readback),
            shaded: self.buffer("shaded", shaded_bytes, output),
            shaded_readback: self.buffer("shaded readback", shaded_bytes, readback),
            camera: self.buffer(
                "camera",
                size_of::<CameraParams>(),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            clock: None,
            upload: None,
        }
    }

    fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    }

    /// Binds whole buffers to the bindings of group 0 of `pipeline`: exactly its stage's.
    fn bind_group(&self, pipeline: &Pipeline, buffers: &[(Binding, &wgpu::Buffer)]) -> wgpu::BindGroup {
        debug_assert!(
            buffers.iter().map(|(b, _)| b).eq(pipeline.stage.bindings),
            "bind group of {} does not follow its table",
            pipeline.stage.entry_point
        );
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: binding.index,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        self.context.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(pipeline.stage.entry_point),
            layout: &pipeline.layout,
            entries: &entries,
        })
    }

    /// Maps the first `bytes` of each buffer, after one wait for the GPU. On an
    /// error, the buffers that did map are unmapped again, so that the next frame can map them.
    fn map_buffers(&self, buffers: &[(&wgpu::Buffer, u64)], mode: wgpu::MapMode) -> Result<(), GpuError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        for (index, &(buffer, bytes)) in buffers.iter().enumerate() {
            let sender = sender.clone();
            buffer.map_async(mode, ..bytes, move |result| {
                let _ = sender.send((index, result));
            });
        }
        drop(sender);
        let mut failure = self.context.poll(wgpu::PollType::wait_indefinitely()).err();
        let mut mapped = Vec::with_capacity(buffers.len());
        // A map callback runs on whichever thread polls the device: with the process's one
        // device shared by every renderer, any other thread's poll may have taken ours
        // and be running it as this wait returns (seen on an NVIDIA H200: "did not map"). So
        // once the GPU is done, wait for them a while, polling again without blocking; after a
        // failed poll some may never run, so take only those that did.
        let waited = Instant::now();
        while failure.is_none() && mapped.len() < buffers.len() {
            match receiver.recv_timeout(std::time::Duration::from_millis(2)) {
                Ok((index, Ok(()))) => mapped.push(index),
                Ok((_, Err(e))) => failure = Some(GpuError::Readback(e.to_string())),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) if waited.elapsed() < CALLBACK_WAIT => {
                    failure = self.context.poll(wgpu::PollType::Poll).err();
                }
                Err(_) => break,
            }
        }
        if mapped.len() < buffers.len() {
            for index in mapped {
                buffers[index].0.unmap();
            }
            return Err(failure.unwrap_or_else(|| GpuError::Readback("the GPU did not map a result buffer".into())));
        }
        Ok(())
    }

    /// The first `bytes` of `buffer` (after the GPU work that writes it was submitted).
    fn read<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<T>, GpuError> {
        self.map_buffers(&[(buffer, bytes)], wgpu::MapMode::Read)?;
        let _unmap = Unmap(vec![buffer]);
        mapped(buffer, bytes).map(|view| bytemuck::cast_slice::<u8, T>(&view).to_vec())
    }
}

/// Unmaps its buffers when dropped, on every exit of the code that mapped them (errors and
/// panics included), so that the next frame can map them again.
struct Unmap<'a>(Vec<&'a wgpu::Buffer>);

impl Drop for Unmap<'_> {
    fn drop(&mut self) {
        for buffer in &self.0 {
            buffer.unmap();
        }
    }
}

/// The mapped first `bytes` of `buffer`.
fn mapped(buffer: &wgpu::Buffer, bytes: u64) -> Result<wgpu::BufferView, GpuError> {
    buffer
        .get_mapped_range(..bytes)
        .map_err(|e| GpuError::Readback(e.to_string()))
}

fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &Pipeline,
    bind_group: &wgpu::BindGroup,
    groups: [u32; 2],
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites>,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(pipeline.stage.entry_point),
        timestamp_writes,
    });
    pass.set_pipeline(&pipeline.pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.dispatch_workgroups(groups[0], groups[1], 1);
}

fn copy(encoder: &mut wgpu::CommandEncoder, from: &wgpu::Buffer, to: &wgpu::Buffer, bytes: u64) {
    encoder.copy_buffer_to_buffer(from, 0, to, 0, bytes);
}

fn size_of<T>() -> u64 {
    std::mem::size_of::<T>() as u64
}

/// 8-bit sRGB from `pack4x8unorm`.
fn unpack(packed: u32) -> [u8; 3] {
    let [r, g, b, _] = packed.to_le_bytes();
    [r, g, b]
}

/// Fewest pixels a rayon task converts, so that a small image wakes few threads.
const MIN_TASK_PIXELS: usize = 8192;

/// A shaded pixel's 8-bit colour: the background where nothing was hit.
fn colour_of(shaded: &ShadedPixel, hit: &Pixel) -> [u8; 3] {
    if hit.is_hit() {
        unpack(shaded.colour)
    } else {
        BACKGROUND
    }
}

/// A GPU hit as the frame's hit planes (points back in world metres, in f64).
fn host_hit(hit: &PixelHit, offset: DVec3) -> Pixel {
    if hit.face == NO_FACE {
        return Pixel::MISS;
    }
    Pixel {
        face: hit.face,
        range: hit.range,
        point: offset + Vec3::from_array(hit.point).as_dvec3(),
        normal: Vec3::from_array(hit.normal),
    }
}

/// Hits converted per parallel task when uploading: 128 KiB of GPU hits.
const UPLOAD_BLOCK: usize = 4096;

/// Writes `hits` as GPU data into `slots` (a mapped upload buffer, exactly their size), in
/// parallel blocks: the mapping is write-only, and only its fixed-size blocks can go to
/// other threads (wgpu's `WriteOnly` slices are not `Send`).
fn write_gpu_hits(slots: wgpu::WriteOnly<'_, [u8]>, hits: &[Pixel], offset: DVec3) {
    const HIT_BYTES: usize = std::mem::size_of::<PixelHit>();
    let record = |hit: &Pixel| bytemuck::cast::<PixelHit, [u8; HIT_BYTES]>(gpu_hit(hit, offset));
    let (records, _) = slots.into_chunks::<HIT_BYTES>();
    let (blocks, rest) = records.into_chunks::<UPLOAD_BLOCK>();
    let blocks: Vec<_> = blocks.into_iter().collect();
    let whole = hits.chunks_exact(UPLOAD_BLOCK);
    rest.write_iter(whole.remainder().iter().map(record));
    blocks
        .into_par_iter()
        .zip(whole.collect::<Vec<_>>())
        .for_each(|(block, hits)| {
            wgpu::WriteOnly::<[[u8; HIT_BYTES]]>::from(block).write_iter(hits.iter().map(record));
        });
}

/// A frame's hit as GPU data, for re-shading.
fn gpu_hit(hit: &Pixel, offset: DVec3) -> PixelHit {
    PixelHit {
        point: (hit.point - offset).as_vec3().to_array(),
        range: hit.range,
        normal: hit.normal.to_array(),
        face: hit.face,
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
        frame: FrameBlock {
            world_from_body: columns(pose.world_from_body_rotation()),
            origin: vector(pose.position - offset),
            kind: bindings::camera_kind(camera),
            width,
            height,
            row_offset: 0,
            band_rows: height,
            samples_per_axis: 1,
            _pad: [0; 3],
        },
        projection: ProjectionBlock {
            focal: [1.0, 1.0],
            principal: [0.0, 0.0],
            lens_origin: [0.0; 3],
            _pad: 0.0,
        },
        mirror: MirrorBlock {
            camera_tilt: columns(DMat3::IDENTITY),
            mirror_diag: [0.0; 3],
            mirror_constant: 0.0,
            mirror_linear: [0.0; 3],
            mount_sign: 1.0,
            camera_offset: [0.0; 3],
            rim_sq: -1.0,
            mirror_min_z: 0.0,
            hidden_centre_sq: 0.0,
            orthographic: 0,
            central: 1,
            shortcut: 0,
            inner_lens: 0,
            _pad: [0; 2],
        },
    };
    match camera {
        Camera::Pinhole(c) => {
            params.projection.focal = [c.fx as f32, c.fy as f32];
            params.projection.principal = [c.cx as f32, c.cy as f32];
            params.projection.lens_origin = vector(c.position);
        }
        Camera::Equirectangular(_) => {}
        Camera::Cylindrical(c) => {
            params.projection.focal = [1.0, c.fy as f32];
            params.projection.principal = [0.0, c.cy as f32];
        }
        Camera::Catadioptric(c) => {
            // Frame C: the mirror frame shifted to the nominal camera position N.
            let nominal = c.nominal_camera_in_mirror();
            let quadric = c.quadric().shifted(nominal);
            params.projection.focal = [c.focal as f32, c.focal as f32];
            params.projection.principal = [c.cx as f32, c.cy as f32];
            params.projection.lens_origin = vector(c.body_from_mirror() * (nominal - c.body_origin_in_mirror()));
            params.mirror.mirror_min_z = quadric.min_z.max(-3.0e38) as f32;
            params.mirror.camera_tilt = columns(rotation_xyz(c.misalignment.tilt));
            params.mirror.mirror_diag = vector(quadric.diag);
            params.mirror.mirror_constant = quadric.constant as f32;
            params.mirror.mirror_linear = vector(quadric.linear);
            params.mirror.mount_sign = if c.mount == Mount::Up { 1.0 } else { -1.0 };
            params.mirror.camera_offset = vector(c.misalignment.offset);
            params.mirror.rim_sq = c.rim_radius.map_or(-1.0, |r| (r * r) as f32);
            params.mirror.hidden_centre_sq = (c.hidden_centre_px * c.hidden_centre_px) as f32;
            params.mirror.orthographic = u32::from(!c.is_perspective());
            params.mirror.central = u32::from(c.is_central());
            params.mirror.shortcut = u32::from(c.rays == MirrorRays::Shortcut);
            params.mirror.inner_lens = u32::from(c.lens.is_some());
        }
        Camera::Lens(c) => params.projection.lens_origin = vector(c.intrinsics.position),
    }
    params
}
