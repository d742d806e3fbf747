//! Pass `RadiosityJacobi` (`shaders/radiosity_jacobi.wgsl`): the Jacobi solver of the matrix
//! radiosity baseline on the GPU, the counterpart of `vlf_core::radiosity::solve_jacobi` (which
//! specifies it and is tested against it in `tests/suite/radiosity_gpu.rs`).
//!
//! Per sweep two dispatches: `sweep` (one invocation per patch: one SpMV row, ping-pong L
//! buffers, per-workgroup maxima of the change) and `reduce` (one workgroup: the residual, the
//! history and the stop flag, all on the GPU). Sweeps are encoded in batches; after each batch
//! the CPU reads the 16-byte head of the state buffer to see whether the solver stopped, so
//! nothing else crosses the bus until the end (a callback asks for the radiance after every
//! sweep, which reads it back each time).
//!
//! Bind group 0: the globals (uniform). Group 1, bindings in order: row_start (r), columns (r),
//! values (r), terms (r), src (r), dst (rw), partials (rw), state (rw).

use std::time::Instant;

use vlf_core::bake::BakeScene;
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, LightField};
use vlf_core::radiosity::{
    self, FormFactors, IterationCallback, RadiosityError, RadiosityReport, RadiositySettings,
    Solution,
};
use vlf_core::scene::Scene;
use wgpu::util::DeviceExt;

use crate::GpuContext;
use crate::layout::{PatchTerm, RadiosityGlobals};
use crate::readback::read_buffer;
use crate::wgpu_util::{
    buffer_bind_group, compute_pipeline, compute_storage, dispatch_2d, pipeline_layout,
    uniform_entry,
};

/// Invocations per workgroup of `sweep` (`WG` in the WGSL).
const WORKGROUP: u32 = 64;
/// Sweeps encoded per submission when no callback is given.
const SWEEPS_PER_SUBMIT: u32 = 16;
/// Words before the residual history in the state buffer.
const STATE_HEAD: usize = 4;

#[derive(Debug, thiserror::Error)]
pub enum GpuRadiosityError {
    #[error(
        "{what} needs {need} bytes in one GPU buffer but the adapter allows {limit}; use fewer patches (lower --resolution or raise --texel-scale) or fewer rays"
    )]
    TooLarge {
        what: &'static str,
        need: u64,
        limit: u64,
    },
    #[error("reading back from the GPU failed (device lost?)")]
    Readback,
    #[error(transparent)]
    Radiosity(#[from] RadiosityError),
}

/// The two pipelines and their layouts.
pub struct RadiosityJacobi {
    pub globals_layout: wgpu::BindGroupLayout,
    pub pass_layout: wgpu::BindGroupLayout,
    pub sweep: wgpu::ComputePipeline,
    pub reduce: wgpu::ComputePipeline,
}

impl RadiosityJacobi {
    pub fn new(device: &wgpu::Device) -> Self {
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("RadiosityJacobi::globals_layout"),
            entries: &[uniform_entry::<RadiosityGlobals>(
                0,
                wgpu::ShaderStages::COMPUTE,
                false,
            )],
        });
        let entries: Vec<_> = [true, true, true, true, true, false, false, false]
            .iter()
            .enumerate()
            .map(|(i, &ro)| compute_storage(i as u32, ro))
            .collect();
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("RadiosityJacobi::pass_layout"),
            entries: &entries,
        });
        let layout = pipeline_layout(
            device,
            "RadiosityJacobi::pipeline_layout",
            &[Some(&globals_layout), Some(&pass_layout)],
        );
        let module = crate::shaders::RADIOSITY_JACOBI.module(device);
        let pipeline =
            |entry: &str| compute_pipeline(device, "RadiosityJacobi", &layout, &module, entry);
        Self {
            sweep: pipeline("sweep"),
            reduce: pipeline("reduce"),
            globals_layout,
            pass_layout,
        }
    }
}

fn buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    label: &str,
    data: &[T],
    usage: wgpu::BufferUsages,
) -> Result<wgpu::Buffer, GpuRadiosityError> {
    // Zero-length storage bindings are invalid: pad empty arrays to one element.
    let zero = [T::zeroed()];
    let data = if data.is_empty() { &zero[..] } else { data };
    let need = std::mem::size_of_val(data) as u64;
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    if need > limit {
        return Err(GpuRadiosityError::TooLarge {
            what: "the radiosity matrix",
            need,
            limit,
        });
    }
    Ok(ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE | usage,
        }))
}

/// Solves `L = S + ρ ⊙ (F L)` by Jacobi sweeps on the GPU: the same iteration, residual and
/// stopping rule as `vlf_core::radiosity::solve_jacobi` (equal up to float rounding). With a
/// callback, the radiance is read back after every sweep.
pub fn solve_jacobi(
    ctx: &GpuContext,
    ff: &FormFactors,
    settings: &RadiositySettings,
    mut on_iteration: IterationCallback,
) -> Result<Solution, GpuRadiosityError> {
    settings.validate()?;
    let device = &ctx.device;
    let n = ff.patches() as u32;
    let max_iterations = if n == 0 { 0 } else { settings.max_iterations };
    let max_dim = device.limits().max_compute_workgroups_per_dimension;
    let (gx, gy) = dispatch_2d(n, WORKGROUP, max_dim);
    let partial_count = gx * gy;

    let copy = wgpu::BufferUsages::COPY_SRC;
    let none = wgpu::BufferUsages::empty();
    let row_start = buffer(ctx, "RadiosityJacobi::row_start", &ff.row_start, none)?;
    let columns = buffer(ctx, "RadiosityJacobi::columns", &ff.columns, none)?;
    let values = buffer(ctx, "RadiosityJacobi::values", &ff.values, none)?;
    let terms: Vec<PatchTerm> = ff
        .source
        .iter()
        .zip(&ff.albedo)
        .map(|(s, a)| PatchTerm {
            source: *s,
            albedo: *a,
        })
        .collect();
    let terms = buffer(ctx, "RadiosityJacobi::terms", &terms, none)?;
    // L⁰ = S in buffer a; sweep k (1-based) writes b when k is odd, a when even.
    let l_a = buffer(ctx, "RadiosityJacobi::radiance_a", &ff.source, copy)?;
    let l_b = buffer(
        ctx,
        "RadiosityJacobi::radiance_b",
        &vec![[0f32; 4]; n as usize],
        copy,
    )?;
    let partials = buffer(
        ctx,
        "RadiosityJacobi::partials",
        &vec![[0f32; 2]; partial_count as usize],
        none,
    )?;
    let state = buffer(
        ctx,
        "RadiosityJacobi::state",
        &vec![0u32; STATE_HEAD + max_iterations as usize],
        copy,
    )?;
    let globals = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("RadiosityJacobi::globals"),
        contents: bytemuck::bytes_of(&RadiosityGlobals {
            patches: n,
            groups_x: gx,
            partial_count,
            max_iterations,
            threshold: settings.threshold,
            ..Default::default()
        }),
        usage: wgpu::BufferUsages::UNIFORM,
    });

    let pass = RadiosityJacobi::new(device);
    let globals_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("RadiosityJacobi::globals_bind_group"),
        layout: &pass.globals_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: globals.as_entire_binding(),
        }],
    });
    let pass_bg = |label: &str, src: &wgpu::Buffer, dst: &wgpu::Buffer| {
        let buffers = [
            &row_start, &columns, &values, &terms, src, dst, &partials, &state,
        ];
        buffer_bind_group(device, label, &pass.pass_layout, &buffers)
    };
    // Index k % 2 of the next sweep k: 1 → a→b, 0 → b→a.
    let bind = [
        pass_bg("RadiosityJacobi::bind_group_b_to_a", &l_b, &l_a),
        pass_bg("RadiosityJacobi::bind_group_a_to_b", &l_a, &l_b),
    ];
    let batch = if on_iteration.is_some() {
        1
    } else {
        SWEEPS_PER_SUBMIT
    };
    let read_state = || -> Result<Vec<u32>, GpuRadiosityError> {
        read_buffer::<u32>(device, &ctx.queue, &state).map_err(|_| GpuRadiosityError::Readback)
    };
    let read_radiance = |sweeps: u32| -> Result<Vec<[f32; 4]>, GpuRadiosityError> {
        let buf = if sweeps % 2 == 1 { &l_b } else { &l_a };
        let mut v = read_buffer::<[f32; 4]>(device, &ctx.queue, buf)
            .map_err(|_| GpuRadiosityError::Readback)?;
        v.truncate(n as usize);
        Ok(v)
    };

    let mut encoded = 0u32;
    let mut head = vec![0u32; STATE_HEAD];
    while encoded < max_iterations && head[0] == 0 {
        let count = batch.min(max_iterations - encoded);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("RadiosityJacobi::encoder"),
        });
        {
            let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("RadiosityJacobi::pass"),
                timestamp_writes: None,
            });
            cpass.set_bind_group(0, &globals_bg, &[]);
            for k in encoded + 1..=encoded + count {
                cpass.set_bind_group(1, &bind[(k % 2) as usize], &[]);
                cpass.set_pipeline(&pass.sweep);
                cpass.dispatch_workgroups(gx, gy, 1);
                cpass.set_pipeline(&pass.reduce);
                cpass.dispatch_workgroups(1, 1, 1);
            }
        }
        ctx.queue.submit(Some(encoder.finish()));
        encoded += count;
        head = read_state()?;
        if let Some(cb) = on_iteration.as_mut() {
            let sweeps = head[1];
            if sweeps == encoded {
                cb(sweeps, &ff.scatter(&read_radiance(sweeps)?));
            }
        }
    }
    let last = if max_iterations > 0 {
        read_state()?
    } else {
        head
    };
    let sweeps = last[1];
    let history: Vec<f32> = last[STATE_HEAD..STATE_HEAD + sweeps as usize]
        .iter()
        .map(|&b| f32::from_bits(b))
        .collect();
    let converged = history
        .last()
        .is_some_and(|&r| radiosity::stops(r, settings.threshold));
    let l = if n == 0 {
        Vec::new()
    } else {
        read_radiance(sweeps)?
    };
    Ok(Solution {
        radiance: ff.scatter(&l),
        iterations: sweeps,
        residual_history: history,
        converged,
    })
}

/// The GPU counterpart of `vlf_core::radiosity::bake`: form factors on the CPU, Jacobi on the
/// GPU, the light field through `bake::assemble`. Refuses scenes with mirror or mixed faces.
pub fn bake(
    ctx: &GpuContext,
    scene: &Scene,
    params: &BakeParams,
    settings: &RadiositySettings,
) -> Result<(LightField, RadiosityReport), GpuRadiosityError> {
    let prep = BakeScene::new(scene, params).map_err(RadiosityError::from)?;
    let directions = DirectionSet::at_least(params.directions).map_err(RadiosityError::from)?;
    let faces = radiosity::non_diffuse_faces(&prep);
    if !faces.is_empty() {
        return Err(RadiosityError::NonDiffuse { faces }.into());
    }
    let t0 = Instant::now();
    let ff = radiosity::form_factors(&prep, params.sky, settings)?;
    let mut report = RadiosityReport::for_form_factors(&ff);
    report.form_factor_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let solution = solve_jacobi(ctx, &ff, settings, None)?;
    report.set_solution("jacobi (gpu)", &solution, t1.elapsed().as_secs_f64());
    let mut lf = radiosity::to_light_field(scene, &prep, params, directions, &solution);
    lf.stats.device = "gpu".into();
    lf.stats.adapter = format!("matrix radiosity on {}", ctx.summary);
    Ok((lf, report))
}
