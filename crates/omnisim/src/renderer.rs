//! One entry point for rendering, whichever backend does the work.
//!
//! A [`Renderer`] holds the backend (device and compiled pipelines) for the life of the
//! program; [`Renderer::prepare`] turns a [`Scene`] into a [`PreparedScene`] (BVH and geometry
//! buffers), whose colours and lights can then change between frames without rebuilding
//! either. Frames are traced into hit planes and shaded by one shading stage.

use std::sync::atomic::{AtomicUsize, Ordering};

use crate::accel::SceneBvh;
use crate::camera::Camera;
use crate::frame::{Frame, NO_FACE, Planes};
#[cfg(feature = "gpu")]
use crate::gpu::{GpuContext, GpuError, GpuRenderer, GpuScene};
use crate::pose::Pose;
use crate::scene::Scene;
use crate::shade::antialias;
use crate::shade::coverage::{self, Outline};
use crate::shade::{self, Appearance};
use crate::trace::CpuTracer;
use crate::trace::ray_table::{self, RayCache};

/// Which backend the user asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// A hardware GPU if one opens, else the CPU (saying why); software adapters are slower
    /// than the CPU tracer on the same cores.
    #[default]
    Auto,
    /// The wgpu backend; fails if no adapter opens.
    Gpu,
    /// The CPU tracer ([`Renderer::set_cpu_tracer`]) on all cores.
    Cpu,
}

/// Why a render could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The GPU backend failed.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The GPU backend was asked for, but this build of omnisim has none.
    #[error("omnisim was built without its `gpu` feature, so it has no GPU backend")]
    GpuNotBuilt,
    /// An appearance that does not fit the prepared scene's geometry.
    #[error("the appearance has {given} face colours but the scene has {faces} faces")]
    FaceCount {
        /// Colours given.
        given: usize,
        /// Faces of the scene.
        faces: usize,
    },
    /// A frame to re-shade that another camera made.
    #[error(
        "the frame to re-shade is {frame_width}×{frame_height} with {pixels} pixels, but the camera makes \
         {camera_width}×{camera_height} images: re-shade a frame with the camera that rendered it"
    )]
    FrameSize {
        /// The frame's width.
        frame_width: u32,
        /// The frame's height.
        frame_height: u32,
        /// The frame's pixel count.
        pixels: usize,
        /// The camera's image width.
        camera_width: u32,
        /// The camera's image height.
        camera_height: u32,
    },
    /// A camera that cannot make an image.
    #[error("the camera cannot make an image: {0}")]
    Camera(#[from] crate::camera::CameraError),
    /// A scene of more triangles than the BVH addresses (one built in code: scene files are
    /// refused on load).
    #[error("the scene has {0}")]
    TooManyTriangles(#[from] crate::scene::TooManyTriangles),
    /// A texture the renderer cannot filter (one built by hand, too large).
    #[error("texture {index} ({source_name}): {message}")]
    Texture {
        /// Its index in the scene's textures.
        index: usize,
        /// Where it came from (the scene's texture sources), or "built by hand".
        source_name: String,
        /// What is wrong and how to fix it.
        message: String,
    },
}

impl RenderError {
    /// Whether the GPU device was lost (a driver reset, a GPU fault; [`GpuError::DeviceLost`]):
    /// the renderer's frames all fail, and a renderer made now ([`Renderer::reopen`]) opens a
    /// fresh device.
    pub fn is_device_lost(&self) -> bool {
        #[cfg(feature = "gpu")]
        return matches!(self, Self::Gpu(GpuError::DeviceLost { .. }));
        #[cfg(not(feature = "gpu"))]
        false
    }
}

/// Refuses an appearance with a texture the filter cannot read ([`Texture::oversized`]).
///
/// [`Texture::oversized`]: crate::scene::texture::Texture::oversized
fn check_textures(appearance: &Appearance) -> Result<(), RenderError> {
    let surfaces = &appearance.surfaces;
    for (index, texture) in surfaces.textures.iter().enumerate() {
        if let Some(message) = texture.oversized() {
            let source_name = surfaces.sources.get(index).map_or("built by hand", String::as_str);
            return Err(RenderError::Texture {
                index,
                source_name: source_name.to_owned(),
                message,
            });
        }
    }
    Ok(())
}

enum Backend {
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuRenderer>),
    Cpu,
}

/// The backend, opened once and used for any number of scenes and frames.
pub struct Renderer {
    backend: Backend,
    choice: BackendChoice,
    /// Why this backend was chosen, for the user.
    reason: String,
    /// Which tracer the CPU backend (and `auto`'s CPU fallback) uses.
    cpu_tracer: CpuTracer,
    /// Camera rays of the last cameras traced on the CPU, reused across poses.
    rays: RayCache,
    geometry_builds: AtomicUsize,
}

/// A scene made ready for tracing: geometry (BVH, and its GPU buffers) plus the appearance
/// (face colours and lights), which can change without touching the geometry.
pub struct PreparedScene {
    geometry: SceneBvh,
    appearance: Appearance,
    /// Object id (1-based) of each face.
    face_object: Vec<u32>,
    object_names: Vec<String>,
    #[cfg(feature = "gpu")]
    gpu: Option<GpuScene>,
    /// Set when `auto` traces this scene on the CPU although a GPU is open, and why.
    fallback: Option<String>,
    /// The faces' outlines, made on the first edge-supersampled render.
    outline: std::sync::OnceLock<Outline>,
}

impl Renderer {
    /// Opens the requested backend and compiles its pipelines.
    pub fn new(choice: BackendChoice) -> Result<Self, RenderError> {
        let (backend, reason) = match choice {
            BackendChoice::Cpu => (Backend::Cpu, "the CPU backend was requested".to_string()),
            BackendChoice::Gpu => (Self::open_gpu(false)?, "the GPU backend was requested".to_string()),
            BackendChoice::Auto => match Self::open_gpu(true) {
                Ok(gpu) => (gpu, "auto: a GPU adapter was found".to_string()),
                Err(e) => (
                    Backend::Cpu,
                    format!("auto: GPU unavailable ({e}); using the CPU tracer"),
                ),
            },
        };
        Ok(Self {
            backend,
            choice,
            reason,
            cpu_tracer: CpuTracer::default(),
            rays: RayCache::default(),
            geometry_builds: AtomicUsize::new(0),
        })
    }

    /// A renderer as this one was asked for (backend choice, CPU tracer, and the GPU's band
    /// limit and pass timing), opened now: after a lost device ([`RenderError::is_device_lost`])
    /// it opens a fresh one, on which scenes must be prepared again. `None` where it would not
    /// render the same bytes as this one ([`Renderer::renders_with`]: `auto` that finds no GPU
    /// now, another adapter) or none opens.
    pub fn reopen(&self) -> Option<Self> {
        let mut fresh = Self::new(self.choice).ok()?;
        fresh.cpu_tracer = self.cpu_tracer;
        #[cfg(feature = "gpu")]
        if let (Backend::Gpu(fresh), Backend::Gpu(old)) = (&mut fresh.backend, &self.backend) {
            fresh.keep_settings(old);
        }
        (fresh.renders_with() == self.renders_with()).then_some(fresh)
    }

    /// This renderer as `auto` would have opened it (on the GPU it already has): for tests of
    /// what `auto` does with a lost device, where the only adapter is a software one.
    #[cfg(all(feature = "gpu", feature = "test-counters"))]
    #[doc(hidden)]
    pub fn as_auto(mut self) -> Self {
        self.choice = BackendChoice::Auto;
        self
    }

    /// Destroys the GPU device this renderer uses (`wgpu::Device::destroy`), as a driver reset
    /// loses it: for tests of a lost device. Every renderer on it then fails its frames with
    /// [`GpuError::DeviceLost`], and the next renderer made opens a fresh device.
    #[cfg(all(feature = "gpu", feature = "test-counters"))]
    #[doc(hidden)]
    pub fn destroy_device(&self) {
        if let Backend::Gpu(renderer) = &self.backend {
            renderer.context().device.destroy();
        }
    }

    /// Chooses the tracer of the CPU backend (default [`CpuTracer::Fast`]); scenes the GPU
    /// traces are not affected.
    pub fn set_cpu_tracer(&mut self, tracer: CpuTracer) {
        self.cpu_tracer = tracer;
    }

    /// The tracer the CPU backend uses.
    pub fn cpu_tracer(&self) -> CpuTracer {
        self.cpu_tracer
    }

    /// The GPU backend; `hardware_only` refuses a software adapter (what `auto` wants).
    #[cfg(feature = "gpu")]
    fn open_gpu(hardware_only: bool) -> Result<Backend, RenderError> {
        let context = if hardware_only {
            GpuContext::new_hardware()?
        } else {
            GpuContext::new()?
        };
        Ok(Backend::Gpu(Box::new(GpuRenderer::new(context))))
    }

    #[cfg(not(feature = "gpu"))]
    fn open_gpu(_hardware_only: bool) -> Result<Backend, RenderError> {
        Err(RenderError::GpuNotBuilt)
    }

    /// Builds the BVH of `scene` and, on the GPU, uploads it with the scene's appearance.
    /// With `auto`, a scene the adapter cannot hold is traced on the CPU (see
    /// [`PreparedScene::fallback`]).
    pub fn prepare(&self, scene: &Scene) -> Result<PreparedScene, RenderError> {
        let geometry = SceneBvh::build(scene)?;
        self.geometry_builds.fetch_add(1, Ordering::Relaxed);
        self.prepare_with(scene, geometry)
    }

    /// Prepares `scene` with a BVH built elsewhere (e.g. around another local origin, see
    /// [`SceneBvh::build_with_offset`]); `geometry` must have been built from `scene`.
    pub fn prepare_with(&self, scene: &Scene, geometry: SceneBvh) -> Result<PreparedScene, RenderError> {
        let appearance = Appearance::of(scene);
        check_textures(&appearance)?;
        #[cfg(feature = "gpu")]
        let (gpu, fallback) = match &self.backend {
            Backend::Cpu => (None, None),
            Backend::Gpu(renderer) => match GpuScene::new(renderer.context(), &geometry, &appearance) {
                Ok(gpu) => (Some(gpu), None),
                // A lost device is no scene too large: it fails the frame, whose caller may
                // reopen the renderer (`auto` falling back here would mix backends silently).
                Err(e) if self.choice == BackendChoice::Auto && !e.is_device_failure() => (
                    None,
                    Some(format!(
                        "auto: the GPU cannot hold this scene ({e}); using the CPU tracer"
                    )),
                ),
                Err(e) => return Err(e.into()),
            },
        };
        #[cfg(not(feature = "gpu"))]
        let fallback = None;
        Ok(PreparedScene {
            geometry,
            appearance,
            face_object: scene.faces.iter().map(|f| f.object + 1).collect(),
            object_names: scene.objects.iter().map(|o| o.name.clone()).collect(),
            #[cfg(feature = "gpu")]
            gpu,
            fallback,
            outline: std::sync::OnceLock::new(),
        })
    }

    /// Replaces the appearance (face colours, lights, surfaces) of `prepared`: no BVH build, no
    /// pipeline build, only the small appearance buffers are rewritten.
    pub fn set_appearance(&self, prepared: &mut PreparedScene, appearance: Appearance) -> Result<(), RenderError> {
        let faces = prepared.geometry.face_normals.len();
        if appearance.face_colours.len() != faces {
            return Err(RenderError::FaceCount {
                given: appearance.face_colours.len(),
                faces,
            });
        }
        check_textures(&appearance)?;
        #[cfg(feature = "gpu")]
        if let (Backend::Gpu(renderer), Some(gpu)) = (&self.backend, prepared.gpu.as_mut()) {
            gpu.set_appearance(renderer.context(), &appearance)?;
        }
        prepared.appearance = appearance;
        Ok(())
    }

    /// Traces one frame and computes the planes `planes` asks for.
    pub fn render(
        &self,
        prepared: &PreparedScene,
        camera: &Camera,
        pose: &Pose,
        planes: Planes,
    ) -> Result<Frame, RenderError> {
        self.forget_gpu_stages();
        camera.validate()?;
        let mut frame = match self.gpu(prepared) {
            #[cfg(feature = "gpu")]
            Some((renderer, gpu)) => renderer.render(gpu, camera, pose, planes)?,
            // Not wrapped in `rayon::scope` (one hand-over to rayon for the trace's and the
            // shading's loops): on a quiet host that cost clutter's cylindrical 1024×256 11 % at two
            // threads and gained nothing measurable elsewhere (docs/benchmarks.md, "2026-11-27
            // evening2 (lead)").
            None => self.cpu_frame(prepared, camera, pose, planes),
        };
        if planes.contains(crate::frame::Plane::Object) {
            let objects = frame
                .pixels()
                .iter()
                .map(|p| {
                    if p.face == NO_FACE {
                        0
                    } else {
                        prepared.face_object[p.face as usize]
                    }
                })
                .collect();
            frame.set_object(objects);
        }
        Ok(frame)
    }

    /// [`Renderer::render`]'s frame on the CPU: traced from `camera`'s ray table (made on first
    /// use), then shaded where `planes` asks for colour.
    fn cpu_frame(&self, prepared: &PreparedScene, camera: &Camera, pose: &Pose, planes: Planes) -> Frame {
        let table = self.rays.table(camera);
        let mut frame = ray_table::trace_frame(self.cpu_tracer, &prepared.geometry, camera, pose, table.as_deref());
        if planes.needs_shading() {
            let (geometry, appearance) = (&prepared.geometry, &prepared.appearance);
            let view = shade::View::new(camera, pose, table.as_deref(), Some(&self.rays));
            shade::shade_frame(self.cpu_tracer, geometry, appearance, view, &mut frame, planes);
        }
        frame
    }

    /// Renders, then refines the shaded planes of pixels on face edges with
    /// `samples_per_axis²` stratified samples each, traced and shaded by the same backend.
    pub fn render_antialiased(
        &self,
        prepared: &PreparedScene,
        camera: &Camera,
        pose: &Pose,
        planes: Planes,
        samples_per_axis: u32,
    ) -> Result<Frame, RenderError> {
        let mut frame = self.render(prepared, camera, pose, planes)?;
        if planes.needs_shading() && samples_per_axis > 1 {
            let outline = prepared.outline.get_or_init(|| Outline::of(&prepared.geometry));
            let table = self.rays.table(camera);
            let edges = coverage::pixels_to_refine(&frame, &prepared.geometry, outline, camera, pose, table.as_deref());
            // The GPU's lens rays are a table of pixel centres: their sub-pixel samples are
            // traced by the CPU, exactly.
            let gpu = self.gpu(prepared).filter(|_| !camera.has_lens_model());
            match gpu {
                #[cfg(feature = "gpu")]
                Some((renderer, gpu)) => {
                    renderer.refine_edges(gpu, camera, pose, &mut frame, samples_per_axis, &edges)?;
                }
                None => {
                    antialias::supersample_edges(
                        self.cpu_tracer,
                        &prepared.geometry,
                        &prepared.appearance,
                        camera,
                        pose,
                        &mut frame,
                        samples_per_axis,
                        &edges,
                    );
                }
            }
        }
        Ok(frame)
    }

    /// Shades `frame` again with `prepared`'s current appearance, without tracing: what a
    /// change of colours or lights costs.
    pub fn reshade(
        &self,
        prepared: &PreparedScene,
        camera: &Camera,
        pose: &Pose,
        frame: &mut Frame,
        planes: Planes,
    ) -> Result<(), RenderError> {
        self.forget_gpu_stages();
        let (camera_width, camera_height) = camera.size();
        let pixels = frame.pixels().len();
        if (frame.width, frame.height) != (camera_width, camera_height)
            || pixels != camera_width as usize * camera_height as usize
        {
            return Err(RenderError::FrameSize {
                frame_width: frame.width,
                frame_height: frame.height,
                pixels,
                camera_width,
                camera_height,
            });
        }
        match self.gpu(prepared) {
            #[cfg(feature = "gpu")]
            Some((renderer, gpu)) => renderer.reshade(gpu, camera, pose, frame, planes)?,
            None => {
                let table = self.rays.table(camera);
                let view = shade::View::new(camera, pose, table.as_deref(), Some(&self.rays));
                shade::shade_frame(
                    self.cpu_tracer,
                    &prepared.geometry,
                    &prepared.appearance,
                    view,
                    frame,
                    planes,
                );
            }
        }
        Ok(())
    }

    /// The GPU backend and scene, where `prepared` is traced on the GPU.
    #[cfg(feature = "gpu")]
    fn gpu<'a>(&'a self, prepared: &'a PreparedScene) -> Option<(&'a GpuRenderer, &'a GpuScene)> {
        match (&self.backend, &prepared.gpu) {
            (Backend::Gpu(renderer), Some(gpu)) => Some((renderer, gpu)),
            _ => None,
        }
    }

    /// Without the `gpu` feature every scene is traced on the CPU (`None`, always: the
    /// uninhabited type spares the callers a `cfg` on their CPU arm).
    #[cfg(not(feature = "gpu"))]
    fn gpu(&self, _prepared: &PreparedScene) -> Option<std::convert::Infallible> {
        None
    }

    /// Where the last frame (render or re-shade) spent its time on the GPU; `None` where it
    /// failed or ran on the CPU (the CPU backend, or a scene `auto` traces on the CPU). One
    /// slot for all frames: meaningful when frames run one at a time, as `omnisim bench`'s do.
    #[cfg(feature = "gpu")]
    pub fn gpu_stages(&self) -> Option<crate::gpu::GpuStages> {
        match &self.backend {
            Backend::Gpu(renderer) => renderer.last_stages(),
            Backend::Cpu => None,
        }
    }

    /// Forgets the last frame's GPU stages as a frame starts, so that none are reported for a
    /// frame that fails or runs on the CPU.
    fn forget_gpu_stages(&self) {
        #[cfg(feature = "gpu")]
        if let Backend::Gpu(renderer) = &self.backend {
            renderer.forget_stages();
        }
    }

    /// "gpu" or "cpu".
    pub fn backend_name(&self) -> &'static str {
        match self.backend {
            #[cfg(feature = "gpu")]
            Backend::Gpu(_) => "gpu",
            Backend::Cpu => "cpu",
        }
    }

    /// The adapter in use, or a description of the CPU backend.
    pub fn device_name(&self) -> String {
        match &self.backend {
            #[cfg(feature = "gpu")]
            Backend::Gpu(renderer) => renderer.context().describe(),
            Backend::Cpu => format!(
                "{} on {} threads",
                self.cpu_tracer.describe(),
                rayon::current_num_threads()
            ),
        }
    }

    /// What decides this renderer's bytes: the GPU adapter, or the CPU tracer (not its thread
    /// count, which changes none). Data sets record it so that shards and resumes match.
    pub fn renders_with(&self) -> String {
        match &self.backend {
            #[cfg(feature = "gpu")]
            Backend::Gpu(renderer) => format!("gpu: {}", renderer.context().describe()),
            Backend::Cpu => format!("cpu: {}", self.cpu_tracer.describe()),
        }
    }

    /// Why this backend was chosen.
    pub fn reason(&self) -> &str {
        &self.reason
    }

    /// How many BVHs this renderer has built (one per [`Renderer::prepare`]): a test counter.
    #[cfg(feature = "test-counters")]
    pub fn geometry_builds(&self) -> usize {
        self.geometry_builds.load(Ordering::Relaxed)
    }

    /// The GPU backend, if that is the one in use (to limit its bands, or read its adapter).
    #[cfg(feature = "gpu")]
    pub fn gpu_renderer(&mut self) -> Option<&mut GpuRenderer> {
        match &mut self.backend {
            Backend::Gpu(renderer) => Some(renderer),
            Backend::Cpu => None,
        }
    }
}

impl PreparedScene {
    /// The BVH and triangles.
    pub fn geometry(&self) -> &SceneBvh {
        &self.geometry
    }

    /// The face colours and lights used by the next frame.
    pub fn appearance(&self) -> &Appearance {
        &self.appearance
    }

    /// Object names; object id `i` (1-based, as in the object plane) is `object_names()[i - 1]`.
    pub fn object_names(&self) -> &[String] {
        &self.object_names
    }

    /// "gpu" or "cpu": which backend traces this scene.
    pub fn backend_name(&self) -> &'static str {
        #[cfg(feature = "gpu")]
        if self.gpu.is_some() {
            return "gpu";
        }
        "cpu"
    }

    /// Why `auto` traces this scene on the CPU although a GPU is open, if it does.
    pub fn fallback(&self) -> Option<&str> {
        self.fallback.as_deref()
    }
}

#[cfg(test)]
mod texture_tests {
    use super::*;
    use crate::scene::texture::{MipLevel, Texture};

    /// A texture built by hand with a side past what the f32 filter holds exactly is refused
    /// with its index and source, on preparing and on a new appearance, not filtered wrong.
    #[test]
    fn a_texture_wider_than_the_filter_reads_is_refused_where_it_is_named() {
        let (mut scene, _) = crate::trace::test_scene("env1-textured");
        let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
        let mut prepared = renderer
            .prepare(&scene)
            .expect("the scene's own textures are within the limit");
        let surfaces = std::sync::Arc::make_mut(&mut scene.surfaces);
        let index = surfaces.textures.len() - 1;
        // Texels left empty: the side alone is refused, before any is read.
        surfaces.textures[index] = Texture {
            levels: vec![MipLevel {
                width: (1 << 23) + 1,
                height: 1,
                texels: Vec::new(),
            }],
        };
        let source = surfaces.sources[index].clone();
        for error in [
            renderer.prepare(&scene).err(),
            renderer.set_appearance(&mut prepared, Appearance::of(&scene)).err(),
        ] {
            let error = error.expect("an oversized texture is refused");
            let text = error.to_string();
            assert!(
                matches!(error, RenderError::Texture { index: i, .. } if i == index),
                "{text}"
            );
            assert!(
                text.contains(&source) && text.contains("8388609×1") && text.contains("16384"),
                "{text}"
            );
        }
    }
}

#[cfg(test)]
mod appearance_tests {
    use super::*;

    /// The one-colour faces are the surfaces' own: a data set's frames (`Appearance::of` the
    /// scene again, the same `Arc`) keep the table made by the first frame, and a render with
    /// other surfaces (a copy, as `Arc::make_mut` makes) starts without one.
    #[test]
    fn one_colour_faces_are_kept_for_the_same_surfaces_only() {
        let (mut scene, _) = crate::trace::test_scene("env1");
        let surfaces = std::sync::Arc::make_mut(&mut scene.surfaces);
        surfaces.list.push(crate::scene::surface::Surface {
            anchor: glam::DVec3::ZERO,
            uv: None,
            colours: None,
            unlit: false,
        });
        surfaces.of_face = vec![0];
        let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
        let mut prepared = renderer.prepare(&scene).unwrap();
        let camera = crate::camera::Camera::Equirectangular(crate::camera::Equirectangular { width: 16, height: 8 });
        let pose = Pose::new(glam::DVec3::new(0.3, -0.2, 0.4), glam::DVec3::ZERO);
        let table = |prepared: &PreparedScene| {
            prepared
                .appearance
                .surfaces
                .one_colour_faces
                .made()
                .map(std::ptr::from_ref)
        };
        renderer.render(&prepared, &camera, &pose, Planes::COLOUR).unwrap();
        let made = table(&prepared).expect("made by the frame");
        renderer.set_appearance(&mut prepared, Appearance::of(&scene)).unwrap();
        renderer.render(&prepared, &camera, &pose, Planes::COLOUR).unwrap();
        assert_eq!(table(&prepared), Some(made), "kept for the same surfaces");
        let mut other = Appearance::of(&scene);
        other.surfaces = std::sync::Arc::new((*other.surfaces).clone());
        renderer.set_appearance(&mut prepared, other).unwrap();
        assert_eq!(table(&prepared), None, "other surfaces start without one");
        renderer.render(&prepared, &camera, &pose, Planes::COLOUR).unwrap();
        assert!(table(&prepared).is_some_and(|other| other != made), "made for them");
    }
}

#[cfg(all(test, not(feature = "gpu")))]
mod tests {
    use super::*;

    #[test]
    fn without_the_gpu_feature_gpu_is_refused_and_auto_says_why_it_uses_the_cpu() {
        let error = Renderer::new(BackendChoice::Gpu)
            .err()
            .expect("no GPU backend in this build");
        assert!(matches!(error, RenderError::GpuNotBuilt));
        assert!(error.to_string().contains("`gpu` feature"), "{error}");
        let auto = Renderer::new(BackendChoice::Auto).expect("auto falls back to the CPU");
        assert_eq!(auto.backend_name(), "cpu");
        assert!(
            auto.reason().starts_with("auto: GPU unavailable") && auto.reason().contains("`gpu` feature"),
            "{}",
            auto.reason()
        );
    }
}
