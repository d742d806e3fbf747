//! GPU pass times from timestamp queries (only where the device has `TIMESTAMP_QUERY`).
//!
//! Each frame writes a begin/end timestamp pair per pass it runs, in the order it encodes them
//! ([`FrameTimestamps`]: a frame may skip passes). The results are copied to a readback buffer
//! and mapped asynchronously, so reading them never stalls the frame: [`GpuTimer::latest`]
//! returns the most recent completed frame's times, a frame or two late.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Readback states.
const IDLE: u8 = 0;
const COPIED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

pub struct GpuTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Number of timed passes (two queries each).
    passes: u32,
    period_ns: f64,
    state: Arc<AtomicU8>,
    /// The passes timed in the frame whose results are being read back, in query order.
    copied: Vec<u32>,
    latest: Option<Vec<Option<f64>>>,
}

/// The passes one frame times, in the order it encodes them: the `i`-th gets the timer's
/// query pair `i`, so the queries written are always the first ones, whichever passes ran.
pub struct FrameTimestamps<'a> {
    timer: Option<&'a GpuTimer>,
    passes: Vec<u32>,
}

impl<'a> FrameTimestamps<'a> {
    /// Timestamps of `timer`'s (none without one).
    pub fn new(timer: Option<&'a GpuTimer>) -> Self {
        Self {
            timer,
            passes: Vec::new(),
        }
    }

    /// The timestamp writes of the next pass encoded, pass `pass` of the timer's passes.
    pub fn writes(&mut self, pass: u32) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        let timer = self.timer?;
        let slot = self.passes.len() as u32;
        self.passes.push(pass);
        Some(timer.render_writes(slot))
    }

    /// The passes timed, in query order (for [`GpuTimer::resolve`]).
    pub fn into_passes(self) -> Vec<u32> {
        self.passes
    }
}

impl GpuTimer {
    /// A timer for `passes` passes, or `None` without `TIMESTAMP_QUERY`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, passes: u32) -> Option<Self> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let count = passes * 2;
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("Renderer::timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let size = u64::from(count) * 8;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::timestamp_resolve"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::timestamp_readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Some(Self {
            query_set,
            resolve,
            readback,
            passes,
            period_ns: f64::from(queue.get_timestamp_period()),
            state: Arc::new(AtomicU8::new(IDLE)),
            copied: Vec::new(),
            latest: None,
        })
    }

    fn render_writes(&self, slot: u32) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(2 * slot),
            end_of_pass_write_index: Some(2 * slot + 1),
        }
    }

    /// Resolves the queries of this frame's timed `passes` ([`FrameTimestamps::into_passes`]:
    /// each wrote both timestamps of its query pair) and copies them for readback when the
    /// readback buffer is free.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder, passes: &[u32]) {
        let passes = &passes[..passes.len().min(self.passes as usize)];
        if passes.is_empty() {
            return;
        }
        let n = passes.len() as u32;
        encoder.resolve_query_set(&self.query_set, 0..n * 2, &self.resolve, 0);
        if self.state.load(Ordering::Acquire) == IDLE {
            encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, u64::from(n) * 16);
            self.copied = passes.to_vec();
            self.state.store(COPIED, Ordering::Release);
        }
    }

    /// Call after the frame's commands were submitted: starts mapping the copied results and
    /// collects any that finished mapping.
    pub fn after_submit(&mut self, device: &wgpu::Device) {
        if self.state.load(Ordering::Acquire) == COPIED {
            self.state.store(MAPPING, Ordering::Release);
            let state = Arc::clone(&self.state);
            self.readback
                .slice(..)
                .map_async(wgpu::MapMode::Read, move |r| {
                    state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
                });
        }
        let _ = device.poll(wgpu::PollType::Poll);
        match self.state.load(Ordering::Acquire) {
            MAPPED => {
                if let Ok(view) = self.readback.slice(..).get_mapped_range() {
                    let ticks: &[u64] = bytemuck::cast_slice(&view);
                    let mut latest = vec![None; self.passes as usize];
                    for (&pass, p) in self.copied.iter().zip(ticks.chunks_exact(2)) {
                        latest[pass as usize] =
                            Some(p[1].saturating_sub(p[0]) as f64 * self.period_ns * 1e-6);
                    }
                    self.latest = Some(latest);
                }
                self.readback.unmap();
                self.state.store(IDLE, Ordering::Release);
            }
            FAILED => self.state.store(IDLE, Ordering::Release),
            _ => {}
        }
    }

    /// Milliseconds per timed pass of the latest completed frame (`None` for a pass it did not
    /// run).
    pub fn latest(&self) -> Option<&[Option<f64>]> {
        self.latest.as_deref()
    }
}
