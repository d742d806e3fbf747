//! What the GPU propagation asked of the device, per iteration: the dispatches of each pass
//! kind, the queue submissions, the host's blocking waits and the bytes it read back, and,
//! where the adapter has `TIMESTAMP_QUERY`, the device time of each pass kind (timestamp pairs
//! around every compute pass, summed by label). `vlf-bake bake --json` reports them
//! (`gpu_propagation`) and `cargo xtask gpu-timing` prints them.

/// The bake's pass kinds, in the order they run on a set of directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    Cells,
    Interface,
    Gather,
    Reflect,
}

impl PassKind {
    pub const ALL: [PassKind; 4] = [
        PassKind::Cells,
        PassKind::Interface,
        PassKind::Gather,
        PassKind::Reflect,
    ];

    pub fn name(self) -> &'static str {
        match self {
            PassKind::Cells => "cells",
            PassKind::Interface => "interface",
            PassKind::Gather => "gather",
            PassKind::Reflect => "reflect",
        }
    }
}

/// One iteration's work on the device.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IterationStats {
    /// Compute dispatches per pass kind, in [`PassKind::ALL`] order.
    pub dispatches: [u32; 4],
    /// `queue.submit` calls.
    pub submits: u32,
    /// Times the host blocked until the device was done (`poll(wait)`, buffer readbacks).
    pub waits: u32,
    /// Bytes copied back to the host.
    pub readback_bytes: u64,
    /// Device time of the timed compute passes in milliseconds, summed by label, in the order
    /// first seen (empty without timestamp queries).
    pub device_ms: Vec<(&'static str, f64)>,
}

impl IterationStats {
    pub fn dispatched(&mut self, kind: PassKind) {
        self.dispatches[kind as usize] += 1;
    }

    pub fn dispatches_of(&self, kind: PassKind) -> u32 {
        self.dispatches[kind as usize]
    }
}

/// Every iteration's [`IterationStats`] of one GPU propagation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GpuBakeStats {
    /// The adapter has `TIMESTAMP_QUERY` (else `device_ms` stays empty).
    pub timestamps: bool,
    /// Directions propagated per set of dispatches (the most a pass covers at once).
    pub directions_per_dispatch: u32,
    pub iterations: Vec<IterationStats>,
}

impl GpuBakeStats {
    /// The most of `f` over the iterations (0 without any).
    pub fn max_over(&self, f: impl Fn(&IterationStats) -> u32) -> u32 {
        self.iterations.iter().map(f).max().unwrap_or(0)
    }

    /// Device milliseconds per label over every iteration, in the order first seen.
    pub fn device_ms_total(&self) -> Vec<(&'static str, f64)> {
        let mut out: Vec<(&'static str, f64)> = Vec::new();
        for (label, ms) in self.iterations.iter().flat_map(|i| &i.device_ms) {
            match out.iter_mut().find(|(l, _)| l == label) {
                Some(e) => e.1 += ms,
                None => out.push((label, *ms)),
            }
        }
        out
    }
}

/// Begin/end timestamps around compute passes, resolved once per iteration (into a buffer
/// made for that readback and dropped with it, like the readback's staging buffer, so the
/// buffers alive while the iteration runs stay the plan's).
pub(super) struct PassTimer {
    query_set: wgpu::QuerySet,
    /// Pairs the query set holds.
    capacity: u32,
    period_ns: f64,
    /// Label of each pair written since the last [`PassTimer::take`].
    labels: Vec<&'static str>,
}

impl PassTimer {
    /// A timer for up to `passes` timed passes per iteration, or `None` without
    /// `TIMESTAMP_QUERY`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, passes: u32) -> Option<PassTimer> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let capacity = passes.clamp(1, wgpu::QUERY_SET_MAX_QUERIES / 2);
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("Bake::timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity * 2,
        });
        Some(PassTimer {
            query_set,
            capacity,
            period_ns: f64::from(queue.get_timestamp_period()),
            labels: Vec::new(),
        })
    }

    /// Begins a compute pass labelled `label`, timed when `timer` has a free pair.
    pub fn begin<'e>(
        timer: Option<&mut PassTimer>,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &'static str,
    ) -> wgpu::ComputePass<'e> {
        let writes = timer.and_then(|t| {
            let slot = t.labels.len() as u32;
            (slot < t.capacity).then(|| {
                t.labels.push(label);
                wgpu::ComputePassTimestampWrites {
                    query_set: &t.query_set,
                    beginning_of_pass_write_index: Some(2 * slot),
                    end_of_pass_write_index: Some(2 * slot + 1),
                }
            })
        });
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: writes,
        })
    }

    /// Resolves the pairs written so far into a new resolve buffer: the buffer and the bytes
    /// to read back (`None` when nothing was timed).
    pub fn resolve(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Option<(wgpu::Buffer, u64)> {
        let n = self.labels.len() as u32;
        if n == 0 {
            return None;
        }
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Bake::timestamp_resolve"),
            size: u64::from(n) * 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        encoder.resolve_query_set(&self.query_set, 0..2 * n, &resolve, 0);
        Some((resolve, u64::from(n) * 16))
    }

    /// The times of the pairs written since the last call, summed by label, from the `ticks`
    /// read back from [`PassTimer::resolve`]'s buffer; starts the next iteration's pairs.
    pub fn take(&mut self, ticks: &[u64]) -> Vec<(&'static str, f64)> {
        let mut out: Vec<(&'static str, f64)> = Vec::new();
        for (label, p) in self.labels.iter().zip(ticks.chunks_exact(2)) {
            let ms = p[1].saturating_sub(p[0]) as f64 * self.period_ns * 1e-6;
            match out.iter_mut().find(|(l, _)| l == label) {
                Some(e) => e.1 += ms,
                None => out.push((label, ms)),
            }
        }
        self.labels.clear();
        out
    }
}
