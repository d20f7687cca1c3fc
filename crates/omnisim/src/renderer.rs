//! One entry point for rendering, whichever backend does the work.

use crate::bvh::SceneBvh;
use crate::camera::Camera;
use crate::cpu;
use crate::frame::Frame;
use crate::gpu::{GpuContext, GpuError, GpuTracer};
use crate::pose::Pose;
use crate::scene::Scene;

/// Which backend the user asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// The GPU if an adapter can be opened, else the CPU (saying why).
    #[default]
    Auto,
    Gpu,
    Cpu,
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("the camera cannot make an image: {0}")]
    Camera(#[from] crate::camera::CameraError),
}

enum Backend {
    Gpu(Box<GpuTracer>),
    Cpu,
}

pub struct Renderer {
    bvh: SceneBvh,
    backend: Backend,
    /// Why this backend was chosen, for the user.
    reason: String,
}

impl Renderer {
    /// Builds the BVH and opens the requested backend.
    pub fn new(scene: &Scene, choice: BackendChoice) -> Result<Self, RenderError> {
        let bvh = SceneBvh::build(scene);
        let (backend, reason) = match choice {
            BackendChoice::Cpu => (Backend::Cpu, "the CPU backend was requested".to_string()),
            BackendChoice::Gpu => (Self::open_gpu(&bvh)?, "the GPU backend was requested".to_string()),
            BackendChoice::Auto => match Self::open_gpu(&bvh) {
                Ok(gpu) => (gpu, "auto: a GPU adapter was found".to_string()),
                Err(e) => (
                    Backend::Cpu,
                    format!("auto: GPU unavailable ({e}); using the f64 CPU tracer"),
                ),
            },
        };
        Ok(Self { bvh, backend, reason })
    }

    fn open_gpu(bvh: &SceneBvh) -> Result<Backend, GpuError> {
        Ok(Backend::Gpu(Box::new(GpuTracer::new(GpuContext::new()?, bvh)?)))
    }

    pub fn render(&self, camera: &Camera, pose: &Pose) -> Result<Frame, RenderError> {
        camera.validate()?;
        match &self.backend {
            Backend::Gpu(tracer) => Ok(tracer.render(camera, pose)?),
            Backend::Cpu => Ok(cpu::render(&self.bvh, camera, pose)),
        }
    }

    /// Renders, then refines the colour of pixels on face edges with `samples_per_axis²`
    /// stratified samples each, traced by the same backend.
    pub fn render_antialiased(
        &self,
        camera: &Camera,
        pose: &Pose,
        samples_per_axis: u32,
    ) -> Result<Frame, RenderError> {
        let mut frame = self.render(camera, pose)?;
        match &self.backend {
            Backend::Gpu(tracer) => {
                tracer.refine_edges(camera, pose, &mut frame, samples_per_axis)?;
            }
            Backend::Cpu => {
                crate::antialias::supersample_edges(&self.bvh, camera, pose, &mut frame, samples_per_axis);
            }
        }
        Ok(frame)
    }

    /// "gpu" or "cpu".
    pub fn backend_name(&self) -> &'static str {
        match self.backend {
            Backend::Gpu(_) => "gpu",
            Backend::Cpu => "cpu",
        }
    }

    /// The adapter in use, or a description of the CPU backend.
    pub fn device_name(&self) -> String {
        match &self.backend {
            Backend::Gpu(tracer) => tracer.context().describe(),
            Backend::Cpu => format!("f64 CPU tracer on {} threads", rayon::current_num_threads()),
        }
    }

    pub fn reason(&self) -> &str {
        &self.reason
    }

    pub fn bvh(&self) -> &SceneBvh {
        &self.bvh
    }
}
