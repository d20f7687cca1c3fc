//! Finding an adapter and opening a device once a process, saying plainly which one and why.

use std::sync::{Arc, Mutex};

/// Why the GPU backend is unavailable or failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter opened (no driver, or none of the requested backend).
    #[error("no Vulkan, Metal or DX12 adapter found ({0}); install the GPU's Vulkan driver, or use the CPU backend")]
    NoAdapter(String),
    /// `auto` found only a software adapter, which is slower than the CPU tracer.
    #[error(
        "the only adapter, {0}, is a software rasteriser on the CPU, where the f64 CPU tracer is faster \
         (--backend gpu uses it anyway)"
    )]
    SoftwareAdapter(String),
    /// The adapter opened but gave no device.
    #[error("the adapter '{adapter}' refused a device: {source}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// What wgpu said.
        source: wgpu::RequestDeviceError,
    },
    /// The BVH is deeper than the shader's traversal stack can walk.
    #[error(
        "the scene's wide BVH is {depth} levels deep; the GPU traversal stack walks at most {limit} (use the CPU backend)"
    )]
    BvhTooDeep {
        /// Depth of the scene's wide BVH below its root.
        depth: usize,
        /// Deepest level the shader's stack walks.
        limit: usize,
    },
    /// The scene has more nodes or triangles than the GPU's BVH entries can address.
    #[error(
        "the scene's wide BVH has {count} {what}; the GPU's BVH entries address at most {limit} (use the CPU backend)"
    )]
    BvhFormatLimit {
        /// What there are too many of (`nodes`, `triangles`).
        what: &'static str,
        /// How many the scene has.
        count: usize,
        /// How many the format addresses.
        limit: usize,
    },
    /// A scene buffer exceeds what the adapter binds.
    #[error(
        "the scene's {buffer} take {bytes} bytes; the adapter binds at most {limit} bytes per buffer (use the CPU backend)"
    )]
    SceneTooLarge {
        /// Which buffer.
        buffer: &'static str,
        /// Its size.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// Mapping a result buffer failed.
    #[error("reading results back from the GPU failed: {0}")]
    Readback(String),
    /// Even a band of one row is too large for the adapter.
    #[error("the image is {width}×{height}: one row alone exceeds the adapter's storage limit")]
    ImageTooWide {
        /// Image width, pixels.
        width: u32,
        /// Image height, pixels.
        height: u32,
    },
    /// A camera model with no GPU ray generation.
    #[error("the GPU backend has no rays for the {0} lens; render it with --backend cpu")]
    NoGpuCamera(&'static str),
}

/// The process's one GPU context: opened once and never dropped. Renderers made and dropped on
/// several threads at once (tests, a library user's workers) each opened and closed their own
/// Vulkan instance and device before; on an NVIDIA H100 (driver 580.159.04) one thread's
/// `vkDestroyDevice` and another's `vkDestroyInstance` then deadlocked inside the driver and
/// the Vulkan loader (5 runs of `tests/tests/stability.rs` in 16 hung). One device also spares each
/// renderer the adapter's start-up.
static SHARED: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);

/// The adapter and device in use, and the limits every buffer is checked against.
pub(crate) struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) adapter: wgpu::AdapterInfo,
    pub(crate) limits: wgpu::Limits,
}

impl GpuContext {
    /// Opens the adapter chosen by `WGPU_BACKEND` / `WGPU_ADAPTER_NAME` / `WGPU_POWER_PREF`
    /// when set, else the best Vulkan, Metal or DX12 adapter. OpenGL is used only when asked
    /// for (`WGPU_BACKEND=gl`), so a missing Vulkan driver is reported, not papered over.
    ///
    /// The process has one context, opened by the first caller and shared by every renderer
    /// after it (see [`SHARED`]).
    pub(crate) fn new() -> Result<Arc<Self>, GpuError> {
        Self::shared(false)
    }

    /// As [`GpuContext::new`], but refuses a software adapter (llvmpipe, lavapipe, WARP: wgpu's
    /// `DeviceType::Cpu`): the `auto` backend's choice. wgpu ranks hardware adapters first, so
    /// a software one means there is no other.
    pub(crate) fn new_hardware() -> Result<Arc<Self>, GpuError> {
        Self::shared(true)
    }

    /// The process's context, opened on first use; an open that fails is tried again next time.
    /// A software adapter that `new_hardware` refuses stays open for a later `new`.
    fn shared(hardware_only: bool) -> Result<Arc<Self>, GpuError> {
        // Poisoned only if an open panicked; the slot is still a valid `Option`.
        let mut slot = SHARED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let context = match &*slot {
            Some(context) => Arc::clone(context),
            None => Arc::clone(slot.insert(Arc::new(Self::open()?))),
        };
        if hardware_only && context.is_software() {
            return Err(GpuError::SoftwareAdapter(format!(
                "{} ({:?})",
                context.adapter.name, context.adapter.backend
            )));
        }
        Ok(context)
    }

    fn open() -> Result<Self, GpuError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if wgpu::Backends::from_env().is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(descriptor);
        let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(&instance, None))
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("omnisim"),
            required_limits: limits.clone(),
            // Where the adapter has them, so that `omnisim bench` can time the passes
            // (`timing.rs`); frames write timestamps only when asked to (`GpuRenderer::time_passes`).
            required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
            ..Default::default()
        }))
        .map_err(|source| GpuError::Device {
            adapter: info.name.clone(),
            source,
        })?;
        Ok(Self {
            device,
            queue,
            adapter: info,
            limits,
        })
    }

    /// Whether the adapter is a software rasteriser on the CPU (llvmpipe, lavapipe, WARP).
    pub(crate) fn is_software(&self) -> bool {
        self.adapter.device_type == wgpu::DeviceType::Cpu
    }

    /// The largest storage buffer the adapter binds, bytes.
    pub(crate) fn storage_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// "name (backend, device type)", for messages and benchmark records.
    pub(crate) fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.adapter.name, self.adapter.backend, self.adapter.device_type
        )
    }
}
