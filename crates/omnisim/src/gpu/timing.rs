//! Where a GPU frame's time goes: the host's stages timed by the clock, and the passes' own
//! GPU time by timestamp queries where the adapter has them (`Features::TIMESTAMP_QUERY`).
//! On a real GPU the host's part decides whether the backend beats the CPU tracer, so
//! `omnisim bench` reports both.

use std::time::Duration;

/// The time of the GPU backend's last frame (a render or a re-shade), summed over its bands.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[non_exhaustive]
pub struct GpuStages {
    /// Bands the image was traced in (one where the adapter binds the whole image).
    pub bands: u32,
    /// Host, before the GPU can start: bind groups, the camera block, the hits a re-shade
    /// uploads, encoding and submitting the passes.
    pub submit: Duration,
    /// From the submit until the results are mapped: the passes, the copies into
    /// host-visible memory and the driver's latency.
    pub wait: Duration,
    /// Host: the mapped results turned into the frame's planes (f32 points back to f64 world
    /// metres, colours unpacked).
    pub readback: Duration,
    /// GPU time of the trace pass, by timestamp queries; `None` where the adapter has none or
    /// nothing was traced (a re-shade).
    pub trace_pass: Option<Duration>,
    /// GPU time of the shade pass, by timestamp queries; `None` where the adapter has none or
    /// nothing was shaded (hit planes only).
    pub shade_pass: Option<Duration>,
}

/// Which pass a pair of timestamps brackets.
#[derive(Debug, Clone, Copy)]
pub(super) enum Pass {
    Trace,
    Shade,
}

/// Resolved queries sit at 256-byte aligned offsets (`QUERY_RESOLVE_BUFFER_ALIGNMENT`): one
/// slot per pass.
const SLOT_BYTES: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;

/// A begin and an end timestamp for each pass, resolved and read back with the frame's
/// results.
pub(super) struct PassClock {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    pub(super) readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

/// Whether `device` was opened with timestamp queries (the one test of it: the renderer's
/// `has_pass_clock` and [`PassClock::new`] must agree).
pub(super) fn has_timestamps(device: &wgpu::Device) -> bool {
    device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
}

impl PassClock {
    /// A clock on `device`, or `None` where the device was opened without timestamp queries.
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<Self> {
        if !has_timestamps(device) {
            return None;
        }
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 2 * SLOT_BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(Self {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 4,
            }),
            resolved: buffer(
                "pass timestamps resolved",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "pass timestamps readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            period_ns: f64::from(queue.get_timestamp_period()),
        })
    }

    /// The timestamp writes bracketing `pass`.
    pub(super) fn writes(&self, pass: Pass) -> wgpu::ComputePassTimestampWrites<'_> {
        let first = Self::first_query(pass);
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(first),
            end_of_pass_write_index: Some(first + 1),
        }
    }

    /// Resolves `pass`'s two timestamps and copies them to the readback buffer (after the pass).
    pub(super) fn resolve(&self, encoder: &mut wgpu::CommandEncoder, pass: Pass) {
        let first = Self::first_query(pass);
        let offset = u64::from(first / 2) * SLOT_BYTES;
        encoder.resolve_query_set(&self.queries, first..first + 2, &self.resolved, offset);
        encoder.copy_buffer_to_buffer(&self.resolved, offset, &self.readback, offset, 16);
    }

    /// `pass`'s GPU time from the mapped readback buffer; `None` if its end precedes its begin
    /// (a counter that wrapped or was reset).
    pub(super) fn elapsed(&self, mapped: &[u8], pass: Pass) -> Option<Duration> {
        let at = (Self::first_query(pass) / 2) as usize * SLOT_BYTES as usize;
        let tick = |at: usize| bytemuck::pod_read_unaligned::<u64>(&mapped[at..at + 8]);
        let ticks = tick(at + 8).checked_sub(tick(at))?;
        Some(Duration::from_secs_f64(ticks as f64 * self.period_ns * 1e-9))
    }

    fn first_query(pass: Pass) -> u32 {
        match pass {
            Pass::Trace => 0,
            Pass::Shade => 2,
        }
    }
}

/// Adds `more` to a pass time summed over bands (`None` stays `None` once a band had none).
pub(super) fn add_pass(total: &mut Option<Duration>, more: Option<Duration>, first_band: bool) {
    *total = match (first_band, *total, more) {
        (true, _, more) => more,
        (false, Some(total), Some(more)) => Some(total + more),
        _ => None,
    };
}
