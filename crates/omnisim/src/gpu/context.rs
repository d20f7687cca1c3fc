//! Finding an adapter and opening a device, saying plainly which one and why; one device a
//! process, opened again in its place when it is lost.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

/// Why the GPU backend is unavailable or failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter opened (no driver, or none of the requested backend).
    #[error("no Vulkan, Metal or DX12 adapter found ({0}); install the GPU's Vulkan driver, or use the CPU backend")]
    NoAdapter(String),
    /// `WGPU_BACKEND` asked for backends that gave no adapter.
    #[error(
        "no adapter of WGPU_BACKEND={asked} found ({why}); unset WGPU_BACKEND to let omnisim choose \
         (Vulkan, Metal or DX12), name another (vulkan, metal, dx12, gl), or use the CPU backend"
    )]
    NoAdapterOfBackend {
        /// The variable's value.
        asked: String,
        /// What wgpu said.
        why: String,
    },
    /// `WGPU_ADAPTER_NAME` matched none of the adapters.
    #[error(
        "WGPU_ADAPTER_NAME={asked} is part of no adapter's name (adapters found: {found}); give part of one of \
         those names, or unset it to let omnisim choose"
    )]
    NoAdapterNamed {
        /// The variable's value.
        asked: String,
        /// The adapters there are, with their backends, or "none".
        found: String,
    },
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
    /// Mapping a new buffer to fill it failed.
    #[error("writing the {buffer} to the GPU failed: {reason}")]
    Upload {
        /// Which buffer.
        buffer: String,
        /// What wgpu said.
        reason: String,
    },
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
    /// The device was lost (a driver reset or GPU timeout, a GPU fault, or destroyed): this
    /// renderer's frames all fail, and the next renderer made opens a fresh device. Where the
    /// driver reports the loss while wgpu waits, wgpu panics and omnisim catches it (this needs
    /// `panic = "unwind"`, Rust's default): the panic hook's line `Error in Device::poll:
    /// Parent device is lost` may come before this error.
    #[error(
        "the GPU device on '{adapter}' was lost ({reason}); a renderer made from now on opens it again \
         (rerun the command; a data set resumes), or use --backend cpu"
    )]
    DeviceLost {
        /// The adapter: its name, backend and device type.
        adapter: String,
        /// What wgpu said: why, and its message.
        reason: String,
    },
}

impl GpuError {
    /// Whether the device failed (lost, or a new buffer would not map), not the scene: no
    /// reason for `auto` to trace the scene on the CPU instead.
    pub(crate) fn is_device_failure(&self) -> bool {
        matches!(self, Self::DeviceLost { .. } | Self::Upload { .. })
    }
}

/// The process's GPU context, opened on first use and never dropped. Renderers made and
/// dropped on several threads at once (tests, a library user's workers) each opened and closed
/// their own Vulkan instance and device before; on an NVIDIA H100 (driver 580.159.04) one
/// thread's `vkDestroyDevice` and another's `vkDestroyInstance` then deadlocked inside the
/// driver and the Vulkan loader (5 runs of `tests/tests/stability.rs` in 16 hung). One device
/// also spares each renderer the adapter's start-up.
static SHARED: Mutex<Contexts> = Mutex::new(Contexts {
    current: None,
    lost: Vec::new(),
});

/// The context renderers get, and the lost ones it replaced.
struct Contexts {
    current: Option<Arc<GpuContext>>,
    /// Contexts whose device was lost, kept for the process: dropped when their last renderer
    /// is, they would destroy their device and instance while other threads' renderers open or
    /// use the fresh one, the teardown that deadlocked (see [`SHARED`]). One a loss, each
    /// holding what wgpu keeps of a lost device (it frees the device's buffers).
    lost: Vec<Arc<GpuContext>>,
}

/// The adapter and device in use, and the limits every buffer is checked against.
pub(crate) struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) adapter: wgpu::AdapterInfo,
    pub(crate) limits: wgpu::Limits,
    /// Set, with what wgpu said, by the device-lost callback. wgpu runs it where the driver
    /// reports the loss, or on the first poll after `Device::destroy` once the queue is idle.
    lost: Arc<OnceLock<String>>,
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

    /// The process's context, opened on first use and again after its device was lost; an open
    /// that fails is tried again next time. A software adapter that `new_hardware` refuses
    /// stays open for a later `new`.
    fn shared(hardware_only: bool) -> Result<Arc<Self>, GpuError> {
        // Poisoned only if an open panicked; the slot is still valid.
        let mut slot = SHARED.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(current) = slot.current.take_if(|current| current.poll_loss().is_err()) {
            slot.lost.push(current);
        }
        let context = match &slot.current {
            Some(context) => Arc::clone(context),
            None => Arc::clone(slot.current.insert(Arc::new(Self::open()?))),
        };
        if hardware_only && context.is_software() {
            return Err(GpuError::SoftwareAdapter(format!(
                "{} ({:?})",
                context.adapter.name, context.adapter.backend
            )));
        }
        Ok(context)
    }

    /// The adapter `WGPU_ADAPTER_NAME` names part of (as wgpu's `initialize_adapter_from_env`
    /// matches, which panics where none does), else the best one `WGPU_POWER_PREF` leads to.
    fn adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter, GpuError> {
        if let Ok(asked) = std::env::var("WGPU_ADAPTER_NAME") {
            let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
            let wanted = asked.to_lowercase();
            if let Some(at) =
                (adapters.iter()).position(|adapter| adapter.get_info().name.to_lowercase().contains(&wanted))
            {
                return Ok(adapters.swap_remove(at));
            }
            let found: Vec<String> = (adapters.iter())
                .map(|adapter| {
                    let info = adapter.get_info();
                    format!("{} ({:?})", info.name, info.backend)
                })
                .collect();
            return Err(GpuError::NoAdapterNamed {
                asked,
                found: if found.is_empty() {
                    "none".into()
                } else {
                    found.join(", ")
                },
            });
        }
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
            ..Default::default()
        }))
        // WGPU_BACKEND is named where it chose the backends (an empty or unknown value leaves
        // wgpu's primary ones).
        .map_err(|e| match std::env::var("WGPU_BACKEND") {
            Ok(asked) if wgpu::Backends::from_env().is_some() => GpuError::NoAdapterOfBackend {
                asked,
                why: e.to_string(),
            },
            _ => GpuError::NoAdapter(e.to_string()),
        })
    }

    fn open() -> Result<Self, GpuError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if wgpu::Backends::from_env().is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(descriptor);
        let adapter = Self::adapter(&instance)?;
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
        let lost = Arc::new(OnceLock::new());
        let flag = Arc::clone(&lost);
        // Must not call wgpu nor take `SHARED`: wgpu runs it under its own locks.
        device.set_device_lost_callback(move |reason, message| {
            let _ = flag.set(match message.as_str() {
                "" => format!("{reason:?}"),
                message => format!("{reason:?}: {message}"),
            });
        });
        let flag = Arc::clone(&lost);
        device.on_uncaptured_error(Arc::new(move |error| {
            // wgpu's own handler panics on every error, as this one does while the device
            // lives. Once it is lost, its resources are freed and using one is an error: the
            // frame then fails with the loss (`blame`), not a panic.
            assert!(flag.get().is_some(), "wgpu error: {error}");
        }));
        Ok(Self {
            device,
            queue,
            adapter: info,
            limits,
            lost,
        })
    }

    /// [`GpuError::DeviceLost`] after a poll (without waiting), which runs the callback of a
    /// destroyed device whose work is done.
    pub(crate) fn poll_loss(&self) -> Result<(), GpuError> {
        // A poll that fails says why; only a loss counts here.
        let _ = self.poll(wgpu::PollType::Poll);
        self.known_loss()
    }

    /// [`GpuError::DeviceLost`] once the device is known to be lost.
    pub(crate) fn known_loss(&self) -> Result<(), GpuError> {
        match self.lost.get() {
            Some(reason) => Err(GpuError::DeviceLost {
                adapter: self.describe(),
                reason: reason.clone(),
            }),
            None => Ok(()),
        }
    }

    /// `error`, or [`GpuError::DeviceLost`] in its place where the device was lost: whatever
    /// failed in a frame on a lost device (a map, a read) failed because of the loss.
    pub(crate) fn blame(&self, error: GpuError) -> GpuError {
        match self.poll_loss() {
            Err(lost) => lost,
            Ok(()) => error,
        }
    }

    /// A buffer holding `contents`: wgpu's `DeviceExt::create_buffer_init`, which panics where
    /// the device is lost (a lost device's buffer cannot be mapped), with that as an error.
    pub(crate) fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        // wgpu's rule for a mapped buffer: a multiple of 4 bytes, at least 4.
        let align = wgpu::COPY_BUFFER_ALIGNMENT;
        let size = (contents.len() as u64).next_multiple_of(align).max(align);
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: true,
        });
        buffer
            .get_mapped_range_mut(..)
            .map(|mut view| view.slice(..contents.len()).copy_from_slice(contents))
            .map_err(|e| {
                self.blame(GpuError::Upload {
                    buffer: label.to_owned(),
                    reason: e.to_string(),
                })
            })?;
        buffer.unmap();
        Ok(buffer)
    }

    /// Polls the device; see [`GpuContext::catch_loss`].
    pub(crate) fn poll(&self, poll_type: wgpu::PollType) -> Result<(), GpuError> {
        self.known_loss()?;
        self.catch_loss(|| self.device.poll(poll_type))?
            .map(drop)
            .map_err(|error| GpuError::Readback(error.to_string()))
    }

    /// Runs `work`, a call into wgpu. wgpu panics where the driver reports the device lost while
    /// it waits (`Device::poll` treats every error but a timeout as fatal), after running the
    /// device-lost callback: that panic becomes [`GpuError::DeviceLost`] here (the panic hook
    /// has printed it). Any other panic goes on.
    fn catch_loss<T>(&self, work: impl FnOnce() -> T) -> Result<T, GpuError> {
        // wgpu panics after its poll returned and ran its callbacks: no lock held, no state
        // half updated.
        catch_unwind(AssertUnwindSafe(work)).or_else(|panic| {
            self.known_loss()?;
            resume_unwind(panic)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A context of this test's own, not the process's: destroying it touches no other test's
    /// frames. Never dropped, even where the test fails: a device torn down beside other
    /// threads' could deadlock (see [`SHARED`]).
    fn own_context() -> std::mem::ManuallyDrop<GpuContext> {
        std::mem::ManuallyDrop::new(
            GpuContext::open().unwrap_or_else(|error| {
                panic!("no GPU adapter opens ({error}): install a Vulkan driver (README, Tests)")
            }),
        )
    }

    /// Once the device is lost, wgpu frees its buffers, and using one (here: unmapping) is an
    /// error wgpu hands to the device's handler: the loss is what the caller hears, not a
    /// panic. While the device lives, such an error still panics, as wgpu's own handler does.
    #[test]
    #[cfg_attr(omnisim_no_gpu, ignore = "needs a GPU adapter (README, Tests)")]
    fn errors_on_a_lost_device_are_the_loss_and_not_a_panic() {
        let context = own_context();
        let usage = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let unmapped = context.buffer_init("unmapped", &[1, 2, 3], usage).unwrap();
        let unmapped_twice = catch_unwind(AssertUnwindSafe(|| unmapped.unmap()));
        assert!(unmapped_twice.is_err(), "a wgpu error on a live device panics");
        let live_panic = catch_unwind(AssertUnwindSafe(|| context.catch_loss(|| panic!("a bug"))));
        assert!(live_panic.is_err(), "a panic on a live device goes on");

        let mapped = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mapped"),
            size: 16,
            usage,
            mapped_at_creation: true,
        });
        context.device.destroy();
        let lost = |result: Result<(), GpuError>| {
            let text = result.map_or_else(|e| e.to_string(), |()| "no error".into());
            assert!(text.contains("was lost (Destroyed)"), "{text}");
        };
        // The first poll runs the callback, and frees the buffers.
        lost(context.poll_loss());
        lost(context.poll(wgpu::PollType::wait_indefinitely()));
        mapped.unmap();
        lost(context.buffer_init("late", &[1], usage).map(drop));
        // wgpu's panic where the driver reports the loss as it waits.
        lost(context.catch_loss(|| panic!("Error in Device::poll: Parent device is lost")));
    }
}
