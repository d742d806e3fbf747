//! The final gather on the GPU (`docs/GATHER.md`): the texel estimators of `vlf_core::gather` (the
//! specification) in `shaders/gather_texels.wgsl`, one invocation per texel, with rays traced
//! inline through the ray engine's BVH ([`crate::raytrace::GpuScene`]), the path tracer's light
//! list and sampling code (`shaders/common/rt_scene.wgsl`, `sampling.wgsl`, `random.wgsl`), the
//! direction lookup of `common/directions.wgsl` and the renderer's mirror-tile lookup
//! (`common/mirror_tiles.wgsl`, the same textures as [`crate::render::upload`]). Everything but
//! the estimators is shared with the CPU gather: the grids and their charts
//! (`vlf_core::gather::Grids`), the dilated propagation irradiance, and the assembly
//! (`vlf_core::gather::assemble`).
//!
//! Every texel draws the CPU's random stream in the CPU's order, so GPU and CPU estimates are
//! the same up to f32 rounding of sin/cos/sqrt (which now and then sends a ray, or a sample
//! point's openness probe, another way). Results do not depend on how the work is split: each
//! texel's estimate depends on its index only. No atomics.
//!
//! **Steps.** A texel's estimate runs as a sequence of steps, one dispatch each (sample points
//! in batches of [`GatherOptions::point_batch`], rays in batches of
//! [`GatherOptions::ray_batch`]; the list is [`steps`]), its state kept between them in a
//! scratch buffer, partial sums in the CPU's order of addition. One invocation tracing all of a
//! texel's rays ran out of llvmpipe's loop budget (65,535 loop trips per shader invocation,
//! after which every loop ends silently: see `gather_texels.wgsl`) at a few hundred rays per
//! texel and came out low; a step checks at its end that the budget held, and a grid whose
//! texels report a cut step is gathered again with half the batches
//! ([`GpuGatherError::LoopBudget`] once they are single samples).
//!
//! Bind groups of every step: 0 = [`GatherGlobals`] (one entry per step, dynamic offset), the
//! grid (faces, texels, chart triangles: one buffer in sections), the output and the scratch,
//! 1 = the ray-tracing scene (`common/rt_scene.wgsl`), 2 = the converged field:
//! direction tables (0, 1), mirror tiles (3–5), the propagation's faces, dilated irradiance and
//! contact bits (6, one buffer). Eight storage buffers in all, the device's minimum per stage.
//!
//! **Panes.** Rays go on through thin glass panes as the CPU gather's do
//! (`vlf_core::gather::through`, ported in `shaders/common/pane_trace.wgsl`): cosine rays and
//! shadow rays (light samples, suns, point and spot lights) attenuated by the panes they cross,
//! indirect rays reading each pane's tiles and diffuse part on their way, openness probes
//! passing panes and surfaces of thin diffuse transmission (the materials' openness flags of
//! [`crate::raytrace::scene`]). Scenes without panes trace as before (one query per ray).
//!
//! **Contacts.** A gather ray's read of the field stops at contacts as the CPU's does
//! (`vlf_core::gather::field::Field::irradiance_at`): the per-texel contact bits are computed
//! on the CPU ([`Contacts`], once per field) and uploaded; `shaders/common/gather_field.wgsl`
//! ports the fallback of a read whose quad is not clear, its visibility rays traced through the
//! same BVH (and counted in the same loop budget) as the gather's rays.

mod grid;
mod plan;

use std::sync::Arc;

use glam::{Vec3, Vec4};
use vlf_core::gather::field::Contacts;
use vlf_core::gather::{
    self as spec, Converged, Gathered, Grid, Grids, SEED, STREAM_DIRECT, STREAM_INDIRECT,
    strata_side,
};
use vlf_core::lightfield::{GatherParams, ParamsError};
use vlf_core::pathtrace::PreparedScene;
use vlf_core::scene::Scene;

use crate::device::GpuFault;
use crate::directions::GpuDirections;
use crate::layout::{DirTables, GatherGlobals, RtSceneInfo};
use crate::raytrace::{GpuScene, RaytraceError};
use crate::readback::read_buffer;
use crate::render::RenderError;
use crate::render::upload::float_tile_textures;
use crate::wgpu_util::{
    compute_pipeline, compute_storage, dispatch_2d, pipeline_layout, texture_entry, uniform_entry,
};
use crate::{GpuContext, shaders};
use grid::{contact_entries, grid_data};
pub use plan::{GatherBuffer, GatherCounts, GatherPlan, GatherRecord};
use plan::{Planned, create, texture_bytes};

/// Invocations per workgroup (`@workgroup_size` of `gather_texels.wgsl`).
const WORKGROUP: u32 = 64;
/// Scratch entries (vec4) of a texel's state before its points (`HEADER` of the shader).
const HEADER: u32 = 4;
/// Texels per dispatch by default: small enough that no dispatch runs for long on a software
/// adapter (one submission per chunk).
pub const DEFAULT_CHUNK: u32 = 4096;
/// Sample points per `draw_points` step by default (up to 8 draws each, each with up to 4
/// traced probes where the texel is partly enclosed).
pub const DEFAULT_POINT_BATCH: u32 = 8;
/// Rays (light samples, cosine rays, points of delta-light rays) per step by default.
pub const DEFAULT_RAY_BATCH: u32 = 32;

#[derive(Debug, thiserror::Error)]
pub enum GpuGatherError {
    #[error(transparent)]
    Params(#[from] ParamsError),
    #[error(transparent)]
    Scene(#[from] RaytraceError),
    #[error(transparent)]
    Upload(#[from] RenderError),
    #[error(
        "the GPU gather's steps ran out of the adapter's loop budget even one sample at a time"
    )]
    LoopBudget,
    #[error("{what} needs {bytes} bytes but the device binds at most {limit}")]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error(transparent)]
    Fault(#[from] GpuFault),
    #[error(
        "the GPU gather samples fixed counts only (no guided or adaptive sampling, no denoiser): gather on the CPU"
    )]
    Unsupported,
    #[error("reading the gathered texels back failed")]
    Readback(#[from] wgpu::BufferAsyncError),
}

/// The shader's entry points, one pipeline each (see `gather_texels.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    Begin,
    DrawPoints,
    FinishPoints,
    Shuffle,
    IndirectRays,
    IndirectEnd,
    LightSamples,
    CosineRays,
    DeltaRays,
    DirectEnd,
}

impl Entry {
    const ALL: [Entry; 10] = [
        Entry::Begin,
        Entry::DrawPoints,
        Entry::FinishPoints,
        Entry::Shuffle,
        Entry::IndirectRays,
        Entry::IndirectEnd,
        Entry::LightSamples,
        Entry::CosineRays,
        Entry::DeltaRays,
        Entry::DirectEnd,
    ];

    /// The WGSL entry point.
    pub fn name(self) -> &'static str {
        match self {
            Entry::Begin => "begin",
            Entry::DrawPoints => "draw_points",
            Entry::FinishPoints => "finish_points",
            Entry::Shuffle => "shuffle",
            Entry::IndirectRays => "indirect_rays",
            Entry::IndirectEnd => "indirect_end",
            Entry::LightSamples => "light_samples",
            Entry::CosineRays => "cosine_rays",
            Entry::DeltaRays => "delta_rays",
            Entry::DirectEnd => "direct_end",
        }
    }
}

/// The gather's pipelines and bind-group layouts, created once per device ([`Self::of`]).
pub struct GatherPipelines {
    grid_layout: wgpu::BindGroupLayout,
    scene_layout: wgpu::BindGroupLayout,
    field_layout: wgpu::BindGroupLayout,
    /// One per [`Entry`], in the order of `Entry::ALL`.
    steps: Vec<wgpu::ComputePipeline>,
}

impl GatherPipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let grid_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("FinalGather::grid_layout"),
            entries: &[
                uniform_entry::<GatherGlobals>(0, wgpu::ShaderStages::COMPUTE, true),
                compute_storage(1, true),
                compute_storage(2, false),
                compute_storage(3, false),
            ],
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("FinalGather::scene_layout"),
            entries: &[
                compute_storage(0, true),
                compute_storage(1, true),
                compute_storage(2, true),
                uniform_entry::<RtSceneInfo>(3, wgpu::ShaderStages::COMPUTE, false),
                compute_storage(6, true),
            ],
        });
        let vis = wgpu::ShaderStages::COMPUTE;
        let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
        let texture = |binding, sample_type| texture_entry(binding, vis, sample_type);
        let field_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("FinalGather::field_layout"),
            entries: &[
                uniform_entry::<DirTables>(0, wgpu::ShaderStages::COMPUTE, false),
                compute_storage(1, true),
                texture(3, wgpu::TextureSampleType::Uint),
                texture(4, unfiltered),
                texture(5, unfiltered),
                compute_storage(6, true),
            ],
        });
        let layout = pipeline_layout(
            device,
            "FinalGather::pipeline_layout",
            &[Some(&grid_layout), Some(&scene_layout), Some(&field_layout)],
        );
        let module = shaders::GATHER_TEXELS.module(device);
        let steps = Entry::ALL
            .iter()
            .map(|e| compute_pipeline(device, "FinalGather", &layout, &module, e.name()))
            .collect();
        Self {
            steps,
            grid_layout,
            scene_layout,
            field_layout,
        }
    }

    /// The pipelines of `ctx`'s device: created on the first call, shared afterwards.
    pub fn of(ctx: &GpuContext) -> Arc<GatherPipelines> {
        ctx.shared(|ctx| GatherPipelines::new(&ctx.device))
    }

    fn pipeline(&self, e: Entry) -> &wgpu::ComputePipeline {
        let i = Entry::ALL.iter().position(|x| *x == e).unwrap_or(0);
        &self.steps[i]
    }
}

/// How the gather's work is split (results do not depend on it).
#[derive(Clone, Copy, Debug)]
pub struct GatherOptions {
    /// Texels per chunk (one submission each; fewer when the scratch buffer would not fit one
    /// binding).
    pub chunk: u32,
    /// Sample points per `draw_points` step.
    pub point_batch: u32,
    /// Rays per ray step.
    pub ray_batch: u32,
    /// CPU workers for what the gather prepares on the host (the contact bits; 0 = all cores).
    pub threads: usize,
}

impl Default for GatherOptions {
    fn default() -> Self {
        Self {
            chunk: DEFAULT_CHUNK,
            point_batch: DEFAULT_POINT_BATCH,
            ray_batch: DEFAULT_RAY_BATCH,
            threads: 0,
        }
    }
}

/// Which estimator a grid runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Indirect,
    Direct,
}

/// What one grid's estimator is asked for.
#[derive(Clone, Copy, Debug)]
pub struct Estimator {
    pub kind: Kind,
    pub stream: u32,
    /// Sample points per texel.
    pub points: u32,
    pub light_samples: u32,
    pub cosine_rays: u32,
    /// Whether the scene has delta lights: suns, point or spot lights (direct: one step per
    /// batch of points).
    pub delta_lights: bool,
}

impl Estimator {
    /// The estimators of the two grids of `gp` (indirect, direct), as `vlf_core::gather`'s
    /// `indirect` and `direct` draw them.
    pub fn of(gp: &GatherParams, has_emitters: bool, delta_lights: bool) -> [Estimator; 2] {
        [
            Estimator {
                kind: Kind::Indirect,
                stream: STREAM_INDIRECT,
                points: gp.indirect_rays,
                light_samples: 0,
                cosine_rays: gp.indirect_rays,
                delta_lights: false,
            },
            Estimator {
                kind: Kind::Direct,
                stream: STREAM_DIRECT,
                points: gp.light_samples.max(gp.direct_rays).max(1),
                light_samples: if has_emitters { gp.light_samples } else { 0 },
                cosine_rays: gp.direct_rays,
                delta_lights,
            },
        ]
    }

    fn light_side(&self) -> u32 {
        strata_side(self.light_samples)
    }

    fn cosine_side(&self) -> u32 {
        strata_side(self.cosine_rays)
    }

    /// Scratch entries (vec4) per texel: state, points, the larger strata order.
    pub fn scratch_stride(&self) -> u32 {
        let strata = match self.kind {
            Kind::Indirect => self.cosine_side().pow(2),
            Kind::Direct => self.light_side().pow(2).max(self.cosine_side().pow(2)),
        };
        HEADER + self.points + strata
    }
}

/// One step: its entry point and range (see `gather_texels.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    pub entry: Entry,
    pub k0: u32,
    pub k1: u32,
    pub side: u32,
}

/// Whether this GPU gather implements the final gather `gp` of `scene`: it samples fixed counts
/// only, so guided or adaptive sampling and the atlas denoiser gather on the CPU, and so do
/// translucent scenes, which propagate on the CPU. A bake gathers here, and plans this gather's
/// buffers, only then.
pub fn implements(scene: &Scene, gp: &GatherParams) -> bool {
    gp.sampling.is_fixed() && !gp.denoise.is_on() && !scene.has_translucency()
}

/// The steps of one grid's estimator, in order, with `options`' batches.
pub fn steps(est: &Estimator, options: &GatherOptions) -> Vec<Step> {
    let one = |entry, side| Step {
        entry,
        k0: 0,
        k1: 0,
        side,
    };
    let batches = |entry, count: u32, batch: u32, out: &mut Vec<Step>| {
        let batch = batch.max(1);
        let mut k0 = 0;
        while k0 < count {
            out.push(Step {
                entry,
                k0,
                k1: (k0 + batch).min(count),
                side: 0,
            });
            k0 += batch;
        }
    };
    let mut s = vec![one(Entry::Begin, 0)];
    batches(Entry::DrawPoints, est.points, options.point_batch, &mut s);
    match est.kind {
        Kind::Indirect => {
            s.push(one(Entry::FinishPoints, est.cosine_side()));
            batches(Entry::IndirectRays, est.points, options.ray_batch, &mut s);
            s.push(one(Entry::IndirectEnd, 0));
        }
        Kind::Direct => {
            s.push(one(Entry::FinishPoints, est.light_side()));
            batches(
                Entry::LightSamples,
                est.light_samples,
                options.ray_batch,
                &mut s,
            );
            s.push(one(Entry::Shuffle, est.cosine_side()));
            batches(
                Entry::CosineRays,
                est.cosine_rays,
                options.ray_batch,
                &mut s,
            );
            if est.delta_lights {
                batches(Entry::DeltaRays, est.points, options.ray_batch, &mut s);
            }
            s.push(one(Entry::DirectEnd, 0));
        }
    }
    s
}

/// Runs the final gather over `field` on the GPU: the GPU form of
/// `vlf_core::gather::final_gather`, with the same grids, streams, estimators and assembly.
pub fn final_gather(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    scene: &Scene,
    field: &Converged,
    gp: &GatherParams,
) -> Result<Gathered, GpuGatherError> {
    final_gather_with(ctx, pipelines, scene, field, gp, &GatherOptions::default())
}

/// [`final_gather`] with explicit work splitting.
pub fn final_gather_with(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    scene: &Scene,
    field: &Converged,
    gp: &GatherParams,
    options: &GatherOptions,
) -> Result<Gathered, GpuGatherError> {
    let mut record = GatherRecord::default();
    final_gather_recorded(ctx, pipelines, scene, field, gp, options, &mut record)
}

/// [`final_gather_with`], recording what it allocated and the plans it allocated from in
/// `record`.
pub fn final_gather_recorded(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    scene: &Scene,
    field: &Converged,
    gp: &GatherParams,
    options: &GatherOptions,
    record: &mut GatherRecord,
) -> Result<Gathered, GpuGatherError> {
    if !gp.sampling.is_fixed() || gp.denoise.is_on() {
        return Err(GpuGatherError::Unsupported);
    }
    let grids = Grids::new(scene, field, gp)?;
    let ps = PreparedScene::new(scene);
    let device = &ctx.device;
    let counts = GatherCounts::of(&ps, field, &grids);
    let limits = device.limits();
    let plan_with = |opts: &GatherOptions| {
        let (limit, align) = (
            limits.max_storage_buffer_binding_size,
            limits.min_uniform_buffer_offset_alignment,
        );
        let plan = GatherPlan::new(&counts, gp, opts, limit, align);
        plan.check(limit).map(|()| plan)
    };
    let plan = plan_with(options)?;
    let (ind, dir) = ctx.trap(|| -> Result<_, GpuGatherError> {
        let gpu_scene = GpuScene::upload(device, &ps)?;
        record.shared = [
            ("RayScene::nodes", &gpu_scene.nodes),
            ("RayScene::triangles", &gpu_scene.triangles),
            ("RayScene::masks", &gpu_scene.masks),
            ("RayScene::blob", &gpu_scene.blob),
            ("RayScene::info", &gpu_scene.info),
        ]
        .map(|(name, b)| (name.to_string(), b.size()))
        .to_vec();
        let contacts = Contacts::new(&ps.bvh, scene, field.prep, options.threads);
        let (field_bg, field_at) =
            field_bind_group(ctx, pipelines, field, &contacts, &plan, &mut record.shared)?;
        let scene_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("FinalGather::scene_bind_group"),
            layout: &pipelines.scene_layout,
            entries: &[
                entry(0, &gpu_scene.nodes),
                entry(1, &gpu_scene.triangles),
                entry(2, &gpu_scene.blob),
                entry(3, &gpu_scene.info),
                entry(6, &gpu_scene.masks),
            ],
        });
        let [ind, dir] = Estimator::of(
            gp,
            gpu_scene.packed.emitter_count > 0,
            gpu_scene.packed.delta_count > 0,
        );
        let mut run = |i: usize, grid: &Grid, est: Estimator| {
            let mut opts = *options;
            loop {
                let plan = plan_with(&opts)?;
                record.grids[i].clear();
                let planned = Planned {
                    plan: &plan,
                    grid: i,
                    record: &mut record.grids[i],
                };
                let out = gather_grid(
                    ctx,
                    pipelines,
                    scene,
                    field,
                    grid,
                    &est,
                    [&scene_bg, &field_bg],
                    field_at,
                    planned,
                    &opts,
                )?;
                record.plans[i] = Some(plan);
                if let Some(out) = out {
                    return Ok(out);
                }
                if opts.point_batch <= 1 && opts.ray_batch <= 1 {
                    return Err(GpuGatherError::LoopBudget);
                }
                opts.point_batch = (opts.point_batch / 2).max(1);
                opts.ray_batch = (opts.ray_batch / 2).max(1);
                log::warn!(
                    "GPU gather ({:?}): a step ran out of the adapter's loop budget; again with \
                     {} points and {} rays per step",
                    est.kind,
                    opts.point_batch,
                    opts.ray_batch
                );
            }
        };
        Ok((run(0, &grids.indirect, ind)?, run(1, &grids.direct, dir)?))
    })??;
    Ok(spec::assemble(
        &ps,
        field,
        grids,
        &ind,
        &dir,
        options.threads,
    ))
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// Group 2: the converged field (directions, mirror tiles, propagation faces, dilated
/// irradiance and the contact bits of its atlas, 16 texels' bytes per entry), and where the
/// irradiance and the contact bits start in its buffer.
fn field_bind_group(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    field: &Converged,
    contacts: &Contacts,
    plan: &GatherPlan,
    record: &mut Vec<(String, u64)>,
) -> Result<(wgpu::BindGroup, [u32; 2]), GpuGatherError> {
    let device = &ctx.device;
    let dirs = GpuDirections::new(device, field.directions);
    record.push(("Directions::tables".into(), dirs.tables.size()));
    record.push(("Directions::mesh".into(), dirs.mesh.size()));
    let mut bytes = 0;
    let [words, values, frames] = float_tile_textures(
        device,
        &ctx.queue,
        "Gather",
        field.tiles,
        field.directions,
        &mut bytes,
    )?;
    for (name, view) in ["tile_words", "tile_values", "tile_frames"]
        .iter()
        .zip([&words, &values, &frames])
    {
        record.push((format!("Gather::{name}"), texture_bytes(view)));
    }
    let mut data: Vec<[f32; 4]> = bytemuck::cast_slice(&field.prep.faces).to_vec();
    let irradiance_at = data.len() as u32;
    data.extend(spec::dilated_irradiance(field));
    let contacts_at = data.len() as u32;
    data.extend(contact_entries(contacts.bits()));
    let data = create(
        device,
        plan.shared("FinalGather::field"),
        wgpu::BufferUsages::empty(),
        Some(bytemuck::cast_slice(&data)),
        record,
    );
    let tex = |binding, view| wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    };
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("FinalGather::field_bind_group"),
        layout: &pipelines.field_layout,
        entries: &[
            entry(0, &dirs.tables),
            entry(1, &dirs.mesh),
            tex(3, &words),
            tex(4, &values),
            tex(5, &frames),
            entry(6, &data),
        ],
    });
    Ok((bind_group, [irradiance_at, contacts_at]))
}

/// The estimates of every texel of `grid` (`None`: no open point), or `None` when a step of
/// some texel ran out of the loop budget.
#[allow(clippy::too_many_arguments)]
fn gather_grid(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    scene: &Scene,
    field: &Converged,
    grid: &Grid,
    est: &Estimator,
    [scene_bg, field_bg]: [&wgpu::BindGroup; 2],
    [irradiance_at, contacts_at]: [u32; 2],
    Planned {
        plan,
        grid: i,
        record,
    }: Planned,
    options: &GatherOptions,
) -> Result<Option<Vec<Option<Vec3>>>, GpuGatherError> {
    let device = &ctx.device;
    let atlas = &grid.atlas;
    let count = atlas.texel_count() as u32;
    if count == 0 {
        return Ok(Some(Vec::new()));
    }
    let (data, [grid_texels, chart_start, chart_tris, chart_normals]) = grid_data(grid);
    let mut create =
        |name, usage, data: Option<&[u8]>| create(device, plan.grid(i, name), usage, data, record);
    let data = create(
        "FinalGather::grid",
        wgpu::BufferUsages::empty(),
        Some(bytemuck::cast_slice(&data)),
    );
    let zeros = vec![0u8; count as usize * 16];
    let out = create(
        "FinalGather::out",
        wgpu::BufferUsages::COPY_SRC,
        Some(&zeros),
    );
    let chunk = plan.chunks[i];
    let scratch = create("FinalGather::scratch", wgpu::BufferUsages::empty(), None);
    let steps = steps(est, options);
    // One GatherGlobals per step, at a dynamic offset; rewritten for every chunk.
    let stride = plan.globals_stride;
    let globals = create(
        "FinalGather::globals",
        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        None,
    );
    let grid_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("FinalGather::grid_bind_group"),
        layout: &pipelines.grid_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &globals,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<GatherGlobals>() as u64),
                }),
            },
            entry(1, &data),
            entry(2, &out),
            entry(3, &scratch),
        ],
    });
    let xf = scene.to_vlf;
    let mut g = GatherGlobals {
        sky: field.sky.extend(0.0).into(),
        xf_center: xf.center.into(),
        xf_scale: xf.scale,
        stream: est.stream,
        seed: SEED,
        points: est.points,
        points_side: strata_side(est.points),
        r_close: grid.r_close(scene),
        has_tiles: u32::from(field.tiles.is_some()),
        light_samples: est.light_samples,
        light_side: est.light_side(),
        cosine_rays: est.cosine_rays,
        cosine_side: est.cosine_side(),
        grid_texels,
        chart_start,
        chart_tris,
        chart_normals,
        field_irradiance: irradiance_at,
        field_contacts: contacts_at,
        scratch_stride: est.scratch_stride(),
        strata_at: HEADER + est.points,
        sentinel: 2,
        ..Default::default()
    };
    let max_groups = device.limits().max_compute_workgroups_per_dimension;
    let mut base = 0;
    while base < count {
        let n = chunk.min(count - base);
        g.texel_base = base;
        g.texel_count = n;
        let mut bytes = vec![0u8; stride as usize * steps.len()];
        for (i, st) in steps.iter().enumerate() {
            let at = i * stride as usize;
            let e = GatherGlobals {
                k0: st.k0,
                k1: st.k1,
                side: st.side,
                ..g
            };
            bytes[at..at + std::mem::size_of::<GatherGlobals>()]
                .copy_from_slice(bytemuck::bytes_of(&e));
        }
        ctx.queue.write_buffer(&globals, 0, &bytes);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("FinalGather::encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("FinalGather::pass"),
                timestamp_writes: None,
            });
            let (gx, gy) = dispatch_2d(n, WORKGROUP, max_groups);
            for (i, st) in steps.iter().enumerate() {
                pass.set_pipeline(pipelines.pipeline(st.entry));
                pass.set_bind_group(0, &grid_bg, &[i as u32 * stride]);
                pass.set_bind_group(1, scene_bg, &[]);
                pass.set_bind_group(2, field_bg, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        ctx.queue.submit(Some(encoder.finish()));
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        base += n;
    }
    let out: Vec<[f32; 4]> = read_buffer(device, &ctx.queue, &out)?;
    let out = &out[..count as usize];
    if out.iter().any(|e| e[3] > 1.5) {
        return Ok(None);
    }
    Ok(Some(
        out.iter()
            .map(|e| {
                let e = Vec4::from(*e);
                (e.w > 0.0).then(|| e.truncate())
            })
            .collect(),
    ))
}

/// Texels per chunk: `requested` (at least 1, at most `count`), fewer where the scratch buffer
/// of `est` would exceed one binding of `limit` bytes.
fn chunk_texels(
    est: &Estimator,
    requested: u32,
    count: u32,
    limit: u64,
) -> Result<u32, GpuGatherError> {
    let per_texel = u64::from(est.scratch_stride()) * 16;
    let fit = (limit / per_texel).min(u64::from(u32::MAX)) as u32;
    if fit == 0 {
        return Err(GpuGatherError::TooLarge {
            what: "FinalGather::scratch",
            bytes: per_texel,
            limit,
        });
    }
    Ok(requested.max(1).min(count).min(fit))
}

#[cfg(test)]
mod tests;
