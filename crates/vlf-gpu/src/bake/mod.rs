//! The GPU propagator: the same algorithm as `vlf_core::bake::reference`, with steps 2–4 of
//! every transport direction (cell lists, interface, gather) as compute passes.
//!
//! Pass order per direction (the one place it is written down): [`cells`] → [`interface`] →
//! [`gather`] → [`reflect`] (scenes with mirror/mixed faces only). Per iteration
//! ([`iteration`]): upload the unshot radiance, clear the accumulators, run every direction,
//! read the accumulators back and finish the iteration on the CPU with
//! `reference::finish_iteration` (a few flops per texel, shared code, f64 energy sums).
//!
//! Split as re_renderer splits a renderer from its draw data:
//! * [`BakePipelines`] ([`pipelines`]): layouts and compute pipelines, created once per device
//!   and shared by every scene baked on it (a batch compiles them once);
//! * [`BakePlan`] ([`plan`]): every buffer of one scene's bake, with sizes from the
//!   `#[repr(C)]` types, and the [`chunks`] of whole directions the tile bins and reflect
//!   items are split into (one storage binding each); `vlf-bake`'s memory budget reads it;
//! * [`SceneResources`] ([`resources`]): the plan's buffers, allocated through one helper, and
//!   the bind groups over them, built from each pass's named bindings.
//!
//! Triangle binning into tiles is done on the CPU (`reference::bin_triangles`): once by the
//! plan to size the chunks, once more to write each direction into its chunk, so the host
//! holds one direction's bins at a time.

mod cells;
pub mod chunks;
mod gather;
mod interface;
mod iteration;
pub mod pipelines;
pub mod plan;
mod reflect;
pub mod resources;
pub mod stats;

use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, Propagated};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::BakeParams;

pub use chunks::{Chunk, ChunkBytes, Chunker, DEFAULT_MAX_CHUNK_BYTES, chunk_cap};
pub use pipelines::BakePipelines;
pub use plan::{BakeBuffer, BakePlan, MirrorCounts, PlannedBuffer};
pub use resources::{AllocatedBuffer, SceneResources};
pub use stats::{GpuBakeStats, IterationStats, PassKind};

use crate::GpuContext;
use plan::Setup;
use resources::Host;

/// Stride of the per-direction uniforms (≥ `min_uniform_buffer_offset_alignment`).
pub const DIR_STRIDE: u64 = 256;
/// Cap on crossings kept per ray.
pub const MAX_CROSSINGS: u32 = 256;
/// Bytes written to the GPU between two submissions while uploading the bins: bounds the
/// staging memory `queue.write_buffer` holds until its submission completes.
pub const UPLOAD_FLUSH_BYTES: u64 = 32 << 20;

#[derive(Debug, thiserror::Error)]
pub enum GpuBakeError {
    #[error(
        "{what} needs {need} bytes in one GPU buffer but the adapter allows {limit}; lower --resolution or --directions"
    )]
    TooLarge { what: String, need: u64, limit: u64 },
    #[error(
        "a ray crosses {crossings} faces, more than the {max} supported (depth complexity too high)"
    )]
    DepthComplexity { crossings: u32, max: u32 },
    #[error("reading back from the GPU failed (device lost?)")]
    Readback,
}

/// Progress of a propagation (shared with the CPU propagator), for the binary's progress bar.
pub use vlf_core::bake::reference::Progress;

/// Settings of the GPU propagator that do not change its result (the tests check that).
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuBakeOptions {
    /// Cap on one chunk buffer (tile bins, tile starts, reflect items) in bytes; `None`:
    /// [`DEFAULT_MAX_CHUNK_BYTES`]. Never above the adapter's binding limit (see [`chunk_cap`]).
    pub max_chunk_bytes: Option<u64>,
}

/// The largest storage buffer one binding may hold on `device`.
pub fn binding_limit(device: &wgpu::Device) -> u64 {
    let l = device.limits();
    l.max_storage_buffer_binding_size.min(l.max_buffer_size)
}

/// Runs the propagation on the GPU. Same inputs and outputs as `reference::propagate`.
pub fn propagate(
    ctx: &GpuContext,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    progress: &mut dyn FnMut(Progress),
) -> Result<Propagated, GpuBakeError> {
    propagate_with(
        ctx,
        scene,
        set,
        params,
        &GpuBakeOptions::default(),
        progress,
    )
}

/// [`propagate`] with [`GpuBakeOptions`]; the result does not depend on them.
pub fn propagate_with(
    ctx: &GpuContext,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    options: &GpuBakeOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Propagated, GpuBakeError> {
    let setup = Setup::new(scene, set, params);
    let cap = chunk_cap(binding_limit(&ctx.device), options.max_chunk_bytes);
    let plan = BakePlan::from_setup(scene, params, &setup, cap);
    run(
        ctx,
        Host::new(scene, set, params, &plan, Some(setup)),
        progress,
    )
    .map(|(out, _)| out)
}

/// [`propagate`] with a plan already made for this scene and these parameters
/// ([`BakePlan::new`], e.g. by a memory budget), so the directions are not binned again to
/// size the buffers. Panics when the plan does not fit the scene.
pub fn propagate_planned(
    ctx: &GpuContext,
    plan: &BakePlan,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    progress: &mut dyn FnMut(Progress),
) -> Result<Propagated, GpuBakeError> {
    propagate_counted(ctx, Some(plan), scene, set, params, progress).map(|(out, _)| out)
}

/// [`propagate_planned`] (or [`propagate`] when `plan` is `None`) that also says what it
/// asked of the device: dispatches, submits, waits and device times per iteration.
pub fn propagate_counted(
    ctx: &GpuContext,
    plan: Option<&BakePlan>,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Propagated, GpuBakeStats), GpuBakeError> {
    match plan {
        Some(plan) => run(ctx, Host::new(scene, set, params, plan, None), progress),
        None => {
            let setup = Setup::new(scene, set, params);
            let cap = chunk_cap(binding_limit(&ctx.device), None);
            let plan = BakePlan::from_setup(scene, params, &setup, cap);
            run(
                ctx,
                Host::new(scene, set, params, &plan, Some(setup)),
                progress,
            )
        }
    }
}

/// The driver: the device's pipelines, the scene's resources, then iterations until the
/// stopping rule says so.
fn run(
    ctx: &GpuContext,
    mut host: Host,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Propagated, GpuBakeStats), GpuBakeError> {
    let pipelines = BakePipelines::of(ctx);
    let res = SceneResources::build(ctx, &pipelines, &mut host)?;
    let passes = host.setup.dirs.len().div_ceil(iteration::DIRS_PER_SUBMIT) as u32;
    let mut timer = stats::PassTimer::new(&ctx.device, &ctx.queue, passes);
    let mut stats = GpuBakeStats {
        timestamps: timer.is_some(),
        directions_per_dispatch: 1,
        iterations: Vec::new(),
    };
    let mut state = iteration::HostRadiance::new(&host);
    let (max_iter, threshold) = reference::stopping(host.params.iterations);
    let mut iterations = 0;
    let mut first_bounce = None;
    for it in 0..max_iter {
        stats.iterations.push(IterationStats::default());
        iteration::run_iteration(
            (ctx, &pipelines, &res),
            &host,
            &mut state,
            (it, max_iter),
            timer.as_mut(),
            stats.iterations.last_mut().expect("pushed"),
            progress,
        )?;
        iterations = it + 1;
        if it == 0 {
            first_bounce = Some(state.irradiance.clone());
        }
        if state.energy.converged(threshold) {
            break;
        }
    }
    Ok((
        Propagated {
            irradiance: state.irradiance,
            first_bounce,
            tiles: host.setup.spec.map(|s| (s.index, state.total_tiles)),
            iterations,
            energy: state.energy,
        },
        stats,
    ))
}
