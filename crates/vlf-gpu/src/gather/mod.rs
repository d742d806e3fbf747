//! The final gather on the GPU (issue 14): the texel estimators of `vlf_core::gather` (the
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
//! point's openness probe, another way). Results do not depend on how the texels are split into
//! dispatches: each texel's estimate depends on its index only. No atomics.
//!
//! Bind groups of both entry points (`indirect`, `direct`): 0 = [`GatherGlobals`], the grid
//! (faces, texels, chart triangles: one buffer in sections) and the output, 1 = the ray-tracing
//! scene (`common/rt_scene.wgsl`), 2 = the converged field: direction tables (0, 1), mirror
//! tiles (3–5), the propagation's faces and dilated irradiance (6, one buffer). Eight storage
//! buffers in all, the device's minimum per stage. Each invocation keeps its sample points and
//! strata order in a scratch storage buffer (8 KiB per texel of a chunk), not in private
//! arrays (see `gather_texels.wgsl`).

use std::sync::Arc;

use glam::{Vec3, Vec4};
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
use crate::passes::dispatch_2d;
use crate::raytrace::{GpuScene, RaytraceError, storage_entry, uniform_entry};
use crate::readback::{read_buffer, storage_buffer};
use crate::render::RenderError;
use crate::render::upload::float_tile_textures;
use crate::{GpuContext, shaders};

/// Invocations per workgroup (`@workgroup_size` of `gather_texels.wgsl`).
const WORKGROUP: u32 = 64;
/// Bounds of a texel's sample points and strata in `gather_texels.wgsl` (`MAX_POINTS`,
/// `MAX_STRATA`).
pub const MAX_SAMPLES: u32 = 256;
/// Scratch entries (vec4) per invocation: sample points and strata order
/// (`gather_texels.wgsl`'s `SCRATCH`).
const SCRATCH: u64 = 2 * MAX_SAMPLES as u64;
/// Texels per dispatch by default: small enough that no dispatch runs for long on a software
/// adapter (one submission each).
pub const DEFAULT_CHUNK: u32 = 4096;

#[derive(Debug, thiserror::Error)]
pub enum GpuGatherError {
    #[error(transparent)]
    Params(#[from] ParamsError),
    #[error(transparent)]
    Scene(#[from] RaytraceError),
    #[error(transparent)]
    Upload(#[from] RenderError),
    #[error("{what} = {count} exceeds the GPU gather's bound of {max} per texel")]
    TooManySamples {
        what: &'static str,
        count: u32,
        max: u32,
    },
    #[error("{what} needs {bytes} bytes but the device binds at most {limit}")]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error(transparent)]
    Fault(#[from] GpuFault),
    #[error("reading the gathered texels back failed")]
    Readback(#[from] wgpu::BufferAsyncError),
}

/// The gather's pipelines and bind-group layouts, created once per device ([`Self::of`]).
pub struct GatherPipelines {
    grid_layout: wgpu::BindGroupLayout,
    scene_layout: wgpu::BindGroupLayout,
    field_layout: wgpu::BindGroupLayout,
    indirect: wgpu::ComputePipeline,
    direct: wgpu::ComputePipeline,
}

impl GatherPipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let grid_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Gather::grid_layout"),
            entries: &[
                uniform_entry::<GatherGlobals>(0, false),
                storage_entry(1, true),
                storage_entry(2, false),
                storage_entry(3, false),
            ],
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Gather::scene_layout"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, true),
                uniform_entry::<RtSceneInfo>(3, false),
            ],
        });
        let vis = wgpu::ShaderStages::COMPUTE;
        let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
        let texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: vis,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let field_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Gather::field_layout"),
            entries: &[
                uniform_entry::<DirTables>(0, false),
                storage_entry(1, true),
                texture(3, wgpu::TextureSampleType::Uint),
                texture(4, unfiltered),
                texture(5, unfiltered),
                storage_entry(6, true),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Gather::pipeline_layout"),
            bind_group_layouts: &[Some(&grid_layout), Some(&scene_layout), Some(&field_layout)],
            immediate_size: 0,
        });
        let module = shaders::GATHER_TEXELS.module(device);
        let pipeline = |label, entry| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        Self {
            indirect: pipeline("Gather::indirect_pipeline", "indirect"),
            direct: pipeline("Gather::direct_pipeline", "direct"),
            grid_layout,
            scene_layout,
            field_layout,
        }
    }

    /// The pipelines of `ctx`'s device: created on the first call, shared afterwards.
    pub fn of(ctx: &GpuContext) -> Arc<GatherPipelines> {
        ctx.shared(|ctx| GatherPipelines::new(&ctx.device))
    }
}

/// How the gather's work is split (results do not depend on it).
#[derive(Clone, Copy, Debug)]
pub struct GatherOptions {
    /// Texels per dispatch (one submission each).
    pub chunk: u32,
}

impl Default for GatherOptions {
    fn default() -> Self {
        Self {
            chunk: DEFAULT_CHUNK,
        }
    }
}

/// What one grid's estimator is asked for.
struct Estimator {
    stream: u32,
    points: u32,
    light_samples: u32,
    cosine_rays: u32,
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
    for (what, count) in [
        ("light samples", gp.light_samples),
        ("direct rays", gp.direct_rays),
        ("indirect rays", gp.indirect_rays),
    ] {
        if count > MAX_SAMPLES {
            return Err(GpuGatherError::TooManySamples {
                what,
                count,
                max: MAX_SAMPLES,
            });
        }
    }
    let grids = Grids::new(scene, field, gp)?;
    let ps = PreparedScene::new(scene);
    let device = &ctx.device;
    let (ind, dir) = ctx.trap(|| -> Result<_, GpuGatherError> {
        let gpu_scene = GpuScene::upload(device, &ps)?;
        let (field_bg, irradiance_at) = field_bind_group(ctx, pipelines, field)?;
        let scene_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Gather::scene_bind_group"),
            layout: &pipelines.scene_layout,
            entries: &[
                entry(0, &gpu_scene.nodes),
                entry(1, &gpu_scene.triangles),
                entry(2, &gpu_scene.blob),
                entry(3, &gpu_scene.info),
            ],
        });
        let has_emitters = gpu_scene.packed.emitter_count > 0;
        let n_l = if has_emitters { gp.light_samples } else { 0 };
        let run = |grid: &Grid, pipeline: &wgpu::ComputePipeline, est: Estimator| {
            gather_grid(
                ctx,
                pipelines,
                scene,
                field,
                grid,
                pipeline,
                &est,
                [&scene_bg, &field_bg],
                irradiance_at,
                options.chunk.max(1),
            )
        };
        let ind = run(
            &grids.indirect,
            &pipelines.indirect,
            Estimator {
                stream: STREAM_INDIRECT,
                points: gp.indirect_rays,
                light_samples: 0,
                cosine_rays: gp.indirect_rays,
            },
        )?;
        let dir = run(
            &grids.direct,
            &pipelines.direct,
            Estimator {
                stream: STREAM_DIRECT,
                points: gp.light_samples.max(gp.direct_rays).max(1),
                light_samples: n_l,
                cosine_rays: gp.direct_rays,
            },
        )?;
        Ok((ind, dir))
    })??;
    Ok(spec::assemble(field, grids, &ind, &dir))
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// A storage buffer of `data` (at least one element), checked against the binding limit.
fn checked<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &'static str,
    data: &[T],
    extra: wgpu::BufferUsages,
) -> Result<wgpu::Buffer, GpuGatherError> {
    let limit = device.limits().max_storage_buffer_binding_size;
    let bytes = std::mem::size_of_val(data) as u64;
    if bytes > limit {
        return Err(GpuGatherError::TooLarge {
            what: label,
            bytes,
            limit,
        });
    }
    let one = [T::zeroed()];
    let data = if data.is_empty() { &one[..] } else { data };
    Ok(storage_buffer(device, label, data, extra))
}

/// Group 2: the converged field (directions, mirror tiles, propagation faces and dilated
/// irradiance), and where the irradiance starts in its buffer.
fn field_bind_group(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    field: &Converged,
) -> Result<(wgpu::BindGroup, u32), GpuGatherError> {
    let device = &ctx.device;
    let dirs = GpuDirections::new(device, field.directions);
    let mut bytes = 0;
    let [words, values, frames] = float_tile_textures(
        device,
        &ctx.queue,
        "Gather",
        field.tiles,
        field.directions,
        &mut bytes,
    )?;
    let mut data: Vec<[f32; 4]> = bytemuck::cast_slice(&field.prep.faces).to_vec();
    let irradiance_at = data.len() as u32;
    data.extend(spec::dilated_irradiance(field));
    let data = checked(device, "Gather::field", &data, wgpu::BufferUsages::empty())?;
    let tex = |binding, view| wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    };
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("Gather::field_bind_group"),
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
    Ok((bind_group, irradiance_at))
}

/// The estimates of every texel of `grid` (`None`: no open point).
#[allow(clippy::too_many_arguments)]
fn gather_grid(
    ctx: &GpuContext,
    pipelines: &GatherPipelines,
    scene: &Scene,
    field: &Converged,
    grid: &Grid,
    pipeline: &wgpu::ComputePipeline,
    est: &Estimator,
    [scene_bg, field_bg]: [&wgpu::BindGroup; 2],
    irradiance_at: u32,
    chunk: u32,
) -> Result<Vec<Option<Vec3>>, GpuGatherError> {
    let device = &ctx.device;
    let atlas = &grid.atlas;
    let count = atlas.texel_count() as u32;
    if count == 0 {
        return Ok(Vec::new());
    }
    // The grid buffer's sections (see gather_texels.wgsl).
    let mut data: Vec<[f32; 4]> = bytemuck::cast_slice(&atlas.faces).to_vec();
    let grid_texels = data.len() as u32;
    for ((c, a), f) in atlas
        .texel_center
        .iter()
        .zip(&atlas.texel_area)
        .zip(&grid.tex_face)
    {
        data.push([c[0], c[1], c[2], *a]);
        data.push([f32::from_bits(*f), 0.0, 0.0, 0.0]);
    }
    let chart_start = data.len() as u32;
    let mut tris: Vec<[f32; 4]> = Vec::new();
    for fi in 0..atlas.faces.len() {
        data.push([f32::from_bits((tris.len() / 2) as u32), 0.0, 0.0, 0.0]);
        for t in grid.charts.triangles(fi) {
            tris.push([t[0].x, t[0].y, t[1].x, t[1].y]);
            tris.push([t[2].x, t[2].y, 0.0, 0.0]);
        }
    }
    data.push([f32::from_bits((tris.len() / 2) as u32), 0.0, 0.0, 0.0]);
    let chart_tris = data.len() as u32;
    data.extend(tris);
    let data = checked(device, "Gather::grid", &data, wgpu::BufferUsages::empty())?;
    let out = checked(
        device,
        "Gather::out",
        &vec![[0.0f32; 4]; count as usize],
        wgpu::BufferUsages::COPY_SRC,
    )?;
    let scratch_bytes = u64::from(chunk.min(count)) * SCRATCH * 16;
    let limit = device.limits().max_storage_buffer_binding_size;
    if scratch_bytes > limit {
        return Err(GpuGatherError::TooLarge {
            what: "Gather::scratch",
            bytes: scratch_bytes,
            limit,
        });
    }
    let scratch = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("Gather::scratch"),
        size: scratch_bytes,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let globals = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("Gather::globals"),
        size: std::mem::size_of::<GatherGlobals>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let grid_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("Gather::grid_bind_group"),
        layout: &pipelines.grid_layout,
        entries: &[
            entry(0, &globals),
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
        points_side: if est.points == 0 {
            1
        } else {
            strata_side(est.points)
        },
        r_close: grid.r_close(scene),
        has_tiles: u32::from(field.tiles.is_some()),
        light_samples: est.light_samples,
        light_side: strata_side(est.light_samples),
        cosine_rays: est.cosine_rays,
        cosine_side: strata_side(est.cosine_rays),
        grid_texels,
        chart_start,
        chart_tris,
        field_irradiance: irradiance_at,
        ..Default::default()
    };
    let max_groups = device.limits().max_compute_workgroups_per_dimension;
    let mut base = 0;
    while base < count {
        let n = chunk.min(count - base);
        g.texel_base = base;
        g.texel_count = n;
        ctx.queue.write_buffer(&globals, 0, bytemuck::bytes_of(&g));
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Gather::encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("Gather::pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &grid_bg, &[]);
            pass.set_bind_group(1, scene_bg, &[]);
            pass.set_bind_group(2, field_bg, &[]);
            let (gx, gy) = dispatch_2d(n, WORKGROUP, max_groups);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        ctx.queue.submit(Some(encoder.finish()));
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        base += n;
    }
    let out: Vec<[f32; 4]> = read_buffer(device, &ctx.queue, &out)?;
    Ok(out
        .iter()
        .take(count as usize)
        .map(|e| {
            let e = Vec4::from(*e);
            (e.w > 0.0).then(|| e.truncate())
        })
        .collect())
}
