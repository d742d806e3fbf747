//! `vlf-bake bake`: scene → light-field file.

use std::path::Path;
use std::time::Instant;

use anyhow::Context as _;
use serde::Serialize;
use vlf_core::bake::reference::Progress;
use vlf_core::bake::{self, Quality};
use vlf_core::lightfield::{BakeParams, BakeStats, Iterations};

use crate::cli::{BakeArgs, DeviceArg, IterationsArg, OnOff};
use crate::memory::{self, Budget};
use crate::{Compute, open_device};

fn quality(a: &BakeArgs) -> Quality {
    a.quality.into()
}

fn final_gather(a: &BakeArgs) -> bool {
    a.final_gather == OnOff::On
}

/// Parameters from the preset and the explicit options, before looking at a scene.
pub fn params_from_args(a: &BakeArgs) -> anyhow::Result<BakeParams> {
    let mut p = quality(a).preset().params(final_gather(a));
    apply_explicit(a, &mut p);
    p.validate().context("bake parameters")?;
    p.check_available().context("bake parameters")?;
    Ok(p)
}

/// Parameters for `scene`: the preset refined by the scene rules (`vlf_core::bake::refine`: ray
/// spacing, tile size, perturbation, the final gather's texels), then every explicit option on
/// top. Returns the rules' reasons for `-v` and `--json`.
pub fn resolve_params(
    a: &BakeArgs,
    scene: &vlf_core::scene::Scene,
) -> anyhow::Result<(BakeParams, Vec<String>)> {
    // The sky the scene will be lit by: the scene rules refine for it.
    let no_sky = a
        .sky
        .is_none_or(|s| glam::Vec3::from(s.0) == glam::Vec3::ZERO);
    let unlit_sky = a.sky_if_unlit.filter(|_| no_sky && !scene.has_lights());
    let sky = unlit_sky.or(a.sky).map_or(glam::Vec3::ZERO, |s| s.0.into());
    let report = bake::refine::refine_under_sky(scene, quality(a), final_gather(a), sky);
    let mut p = report.params;
    let mut reasons = report.reasons;
    apply_explicit(a, &mut p);
    if let Some(sky) = unlit_sky {
        p.sky = glam::Vec3::from(sky.0);
        let msg = format!(
            "no emitter, sun or lamp: lit by a sky of radiance {:?} (--sky-if-unlit)",
            sky.0
        );
        log::warn!("{}: {msg}", scene.source.display());
        reasons.push(msg);
    }
    p.validate().context("bake parameters")?;
    p.check_available().context("bake parameters")?;
    Ok((p, reasons))
}

fn apply_explicit(a: &BakeArgs, p: &mut BakeParams) {
    if let Some(v) = a.directions {
        p.directions = v;
    }
    if let Some(v) = a.resolution {
        p.resolution = v;
        // Keep the tile if it divides the new resolution, else use the largest divisor ≤ it.
        if a.tile.is_none() && !v.is_multiple_of(p.tile) {
            p.tile = (1..=p.tile)
                .rev()
                .find(|t| v.is_multiple_of(*t))
                .unwrap_or(1);
        }
    }
    if let Some(v) = a.tile {
        p.tile = v;
    }
    match a.iterations {
        Some(IterationsArg::Fixed(k)) => p.iterations = Iterations::Fixed(k),
        Some(IterationsArg::Auto) | None => {
            if let (Iterations::Converge { max, .. }, Some(threshold)) = (p.iterations, a.threshold)
            {
                p.iterations = Iterations::Converge { threshold, max };
            }
        }
    }
    if let Some(v) = a.perturb {
        p.perturb = v;
    }
    if let Some(v) = a.texel_scale {
        p.texel_scale = v;
    }
    if let Some(s) = a.sky {
        p.sky = glam::Vec3::from(s.0);
    }
    if let Some(g) = &mut p.final_gather {
        if let Some(v) = a.gather_texel_scale {
            g.texel_scale = v;
            g.indirect_texel_scale = g.indirect_texel_scale.max(v);
        }
        if let Some(v) = a.gather_rays {
            g.indirect_rays = v;
        }
        if let Some(mode) = a.gather_sampling {
            use crate::cli::GatherSampling;
            let preset = quality(a).preset().gather.sampling;
            g.sampling = match mode {
                GatherSampling::Fixed => vlf_core::lightfield::Sampling::FIXED,
                GatherSampling::Guided => vlf_core::lightfield::Sampling {
                    guided: true,
                    ..vlf_core::lightfield::Sampling::FIXED
                },
                GatherSampling::Adaptive => vlf_core::lightfield::Sampling {
                    guided: true,
                    target_error: if preset.target_error > 0.0 {
                        preset.target_error
                    } else {
                        0.05
                    },
                    max_rounds: preset.max_rounds.max(4),
                },
            };
        }
        if let Some(v) = a.gather_target {
            g.sampling.target_error = v;
        }
        if let Some(v) = a.gather_max_rounds {
            g.sampling.max_rounds = v;
        }
        if let Some(v) = a.denoise {
            g.denoise = v.into();
        }
    }
}

/// What `--json` prints.
#[derive(Serialize)]
pub struct BakeReport {
    pub scene: String,
    pub output: String,
    /// `gpu` or `cpu`.
    pub device: String,
    /// Why `--device` chose it.
    pub device_reason: String,
    pub adapter: String,
    /// Worker threads of the CPU work (propagation on the CPU path, final gather, resampling).
    pub threads: usize,
    pub params: BakeParams,
    pub directions: usize,
    pub prepared: bake::prep::PrepSummary,
    /// How each material's metal lobe is baked (mirror, directional tiles or diffuse).
    pub materials: Vec<bake::glossy::MaterialModel>,
    pub iterations: u32,
    pub phases_s: Vec<(String, f64)>,
    pub total_s: f64,
    pub energy: EnergyReport,
    /// The final gather's bookkeeping (absent with `--final-gather off`).
    pub gather: Option<GatherReport>,
    /// The mirror tiles' resampling (with the final gather, on scenes with mirrors).
    pub resample: Option<vlf_core::resample::ResampleStats>,
    pub memory: MemoryReport,
    pub output_bytes: u64,
    pub warnings: Vec<String>,
    /// Why `--quality` chose these parameters for this scene.
    pub auto: Vec<String>,
    /// What the GPU propagation asked of the device (absent on the CPU path).
    pub gpu_propagation: Option<GpuPropagationReport>,
}

/// `vlf_gpu::bake::GpuBakeStats` in the report: per iteration, the dispatches of each pass
/// kind, the submits, the host's blocking waits, the bytes read back and the device time per
/// pass kind (timestamp queries; `null` where the adapter has none).
#[derive(Serialize)]
pub struct GpuPropagationReport {
    /// The adapter has `TIMESTAMP_QUERY`.
    pub timestamps: bool,
    /// Directions one dispatch of a pass covers at most.
    pub directions_per_dispatch: u32,
    /// Per iteration, the most and the total over the iterations.
    pub max_per_iteration: GpuIterationReport,
    pub iterations: Vec<GpuIterationReport>,
    /// Device milliseconds by pass over the whole propagation (empty without timestamps).
    pub device_ms: Vec<(String, f64)>,
}

#[derive(Serialize)]
pub struct GpuIterationReport {
    /// Dispatches per pass kind (cells, interface, gather, reflect).
    pub dispatches: std::collections::BTreeMap<String, u32>,
    pub submits: u32,
    pub waits: u32,
    pub readback_bytes: u64,
    pub device_ms: Vec<(String, f64)>,
}

impl GpuPropagationReport {
    fn new(s: &vlf_gpu::bake::GpuBakeStats) -> GpuPropagationReport {
        use vlf_gpu::bake::PassKind;
        let dispatches = |f: &dyn Fn(PassKind) -> u32| {
            PassKind::ALL
                .iter()
                .map(|&k| (k.name().to_string(), f(k)))
                .collect()
        };
        let ms = |v: &[(&str, f64)]| v.iter().map(|(l, t)| (l.to_string(), *t)).collect();
        GpuPropagationReport {
            timestamps: s.timestamps,
            directions_per_dispatch: s.directions_per_dispatch,
            max_per_iteration: GpuIterationReport {
                dispatches: dispatches(&|k| s.max_over(|i| i.dispatches_of(k))),
                submits: s.max_over(|i| i.submits),
                waits: s.max_over(|i| i.waits),
                readback_bytes: s
                    .iterations
                    .iter()
                    .map(|i| i.readback_bytes)
                    .max()
                    .unwrap_or(0),
                device_ms: Vec::new(),
            },
            iterations: s
                .iterations
                .iter()
                .map(|i| GpuIterationReport {
                    dispatches: dispatches(&|k| i.dispatches_of(k)),
                    submits: i.submits,
                    waits: i.waits,
                    readback_bytes: i.readback_bytes,
                    device_ms: ms(&i.device_ms),
                })
                .collect(),
            device_ms: ms(&s.device_ms_total()),
        }
    }
}

#[derive(Serialize)]
pub struct EnergyReport {
    pub emitted: f64,
    pub injected: f64,
    pub absorbed: f64,
    pub escaped: f64,
    pub unshot: f64,
    /// Unshot power / (emitted + injected) after the last iteration.
    pub unshot_fraction: f64,
    /// (emitted + injected − absorbed − escaped − unshot) / (emitted + injected).
    pub imbalance: f64,
}

#[derive(Serialize)]
pub struct GatherReport {
    /// Where the gather ran: `gpu` (`vlf_gpu::gather`, on the bake's device) or `cpu`
    /// (`vlf_core::gather`, on `threads` workers).
    pub device: &'static str,
    #[serde(flatten)]
    pub stats: vlf_core::gather::GatherStats,
    /// (direct + indirect) / propagated − 1: how far the gather moved the received power
    /// (Σ irradiance × area over every texel side) from what the propagation alone had.
    pub relative_difference: f64,
}

#[derive(Serialize)]
pub struct MemoryReport {
    /// Radiance during propagation: unshot, next and total maps (f32 RGBA) plus accumulators.
    pub propagation_bytes: u64,
    /// What is kept for rendering: atlas irradiance and mirror tiles (in their stored
    /// encoding in memory), materials, uvs and textures.
    pub render_bytes: u64,
    /// Of which the sparse mirror tiles (total map).
    pub tile_bytes: u64,
    /// The plan made before propagating, checked against the budget (`--max-memory`).
    pub plan: memory::MemoryPlan,
}

/// The final gather's parameters when a bake on a GPU device gathers there
/// ([`vlf_gpu::gather::implements`]).
fn gpu_gather(
    scene: &vlf_core::scene::Scene,
    params: &BakeParams,
) -> Option<vlf_core::lightfield::GatherParams> {
    params
        .final_gather
        .filter(|g| vlf_gpu::gather::implements(scene, g))
}

/// The final gather (on the GPU with a device: `vlf_gpu::gather`, tested against the CPU
/// gather; on the CPU otherwise), then the mirror tiles' resampling and the light field
/// (`vlf_core::pipeline`).
#[allow(clippy::too_many_arguments)]
fn finish(
    scene: &vlf_core::scene::Scene,
    prep: &bake::BakeScene,
    params: &BakeParams,
    set: &vlf_core::directions::DirectionSet,
    out: bake::reference::Propagated,
    stats: BakeStats,
    compute: &Compute,
    threads: usize,
) -> anyhow::Result<vlf_core::pipeline::Finished> {
    use vlf_core::pipeline;
    let gpu_gather = gpu_gather(scene, params);
    if let (Compute::Gpu(..), Some(_), None) = (compute, params.final_gather, gpu_gather) {
        log::info!(
            "final gather on the CPU: the GPU gather has no guided or adaptive sampling, \
             denoiser or translucent walls"
        );
    }
    let (Compute::Gpu(ctx, _), Some(gp)) = (compute, gpu_gather) else {
        return Ok(pipeline::finish(
            scene,
            prep,
            params,
            set.clone(),
            out,
            stats,
            threads,
        )?);
    };
    let pipelines = vlf_gpu::gather::GatherPipelines::of(ctx);
    let field = pipeline::converged(prep, params, set, &out);
    let options = vlf_gpu::gather::GatherOptions {
        threads,
        ..Default::default()
    };
    let g = vlf_gpu::gather::final_gather_with(ctx, &pipelines, scene, &field, &gp, &options)
        .context("GPU final gather")?;
    Ok(pipeline::finish_gathered(
        scene,
        prep,
        params,
        set.clone(),
        out,
        stats,
        threads,
        g,
    )?)
}

/// Bakes one scene with an already opened device and writes the file atomically. `progress`
/// receives (done, total) units of propagation work and what is running. The memory of the
/// bake is planned against `budget` first: `--resolution` may be lowered (with a warning, and
/// the report's `params` say so) or the bake refused ([`memory::MemoryError`]).
pub fn bake_scene(
    scene_path: &Path,
    output: &Path,
    args: &BakeArgs,
    compute: &Compute,
    budget: &Budget,
    progress: &mut dyn FnMut(u64, u64, &str),
) -> anyhow::Result<BakeReport> {
    let t = Instant::now();
    let mut scene = vlf_core::scene::load(scene_path)?;
    if args.flat_normals {
        scene.flatten_normals();
    }
    let (params, auto_reasons) = resolve_params(args, &scene)?;
    for r in &auto_reasons {
        log::info!("{}: {r}", scene_path.display());
    }
    let params = &params;
    vlf_core::scene::check_lighting(
        &scene,
        (params.sky != glam::Vec3::ZERO).then_some(params.sky),
    )?;
    let t_load = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let memory::Planned {
        params,
        prep,
        set,
        plan,
    } = memory::plan_and_prepare(&scene, params, compute, budget, scene_path)?;
    let params = &params;
    let t_plan = plan.plan_s;
    let t_prep = (t.elapsed().as_secs_f64() - t_plan).max(0.0);
    for w in scene.warnings.iter().chain(&prep.warnings) {
        log::warn!("{}: {w}", scene_path.display());
    }

    let t = Instant::now();
    let threads = vlf_core::par::threads(args.threads);
    // Directions done out of the most the bake may run (the stopping rule usually ends it
    // earlier).
    let mut report = |p: Progress| {
        let done = p.iteration as u64 * p.directions as u64 + p.directions_done as u64;
        let total = u64::from(p.max_iterations) * p.directions as u64;
        progress(done, total, &format!("iteration {}", p.iteration + 1));
    };
    let mut gpu_stats = None;
    let (out, adapter) = match compute {
        // The GPU propagator has no subsurface step yet (docs/SUBSURFACE.md): scenes with
        // translucent materials propagate on the CPU.
        Compute::Gpu(..) if !prep.translucency.is_empty() => {
            log::warn!(
                "{}: translucent materials (subsurface scattering, diffuse transmission) are propagated on the CPU: the GPU propagator has no subsurface step yet",
                scene_path.display()
            );
            (
                bake::reference::propagate_with(&prep, &set, params, threads, &mut report),
                "CPU reference (translucent materials)".to_string(),
            )
        }
        Compute::Gpu(ctx, _) => {
            let out = memory::guard_gpu(ctx, &plan, || {
                // The memory plan holds the propagator's buffer plan: the propagator allocates
                // exactly what the budget counted, without binning every direction again.
                vlf_gpu::bake::propagate_counted(
                    ctx,
                    plan.gpu.as_ref(),
                    &prep,
                    &set,
                    params,
                    &mut report,
                )
                .context("GPU propagation")
            })?;
            let (out, stats) = out;
            gpu_stats = Some(GpuPropagationReport::new(&stats));
            (out, ctx.summary.to_string())
        }
        Compute::Cpu(_) => (
            bake::reference::propagate_with(&prep, &set, params, threads, &mut report),
            "CPU reference".to_string(),
        ),
    };
    let t_prop = t.elapsed().as_secs_f64();
    let device_name = compute.kind();

    // Timings stay out of the file: the same scene, parameters and adapter must give a
    // bit-identical file. They go to the report (--json) instead.
    let mut stats = BakeStats {
        iterations: out.iterations,
        device: device_name.into(),
        adapter: adapter.clone(),
        ..Default::default()
    };
    out.energy.copy_into(&mut stats);
    let t = Instant::now();
    let iterations = out.iterations;
    let energy = out.energy.clone();
    if params.final_gather.is_some() {
        progress(1, 1, "final gather");
    }
    // The final gather (when asked for), then the light field. A non-finite radiance is a bug
    // or a degenerate input: refuse it rather than write it.
    let finished = finish(&scene, &prep, params, &set, out, stats, compute, threads)
        .with_context(|| format!("finishing the light field of {}", scene_path.display()))?;
    let t_gather = t.elapsed().as_secs_f64();
    let lf = finished.light_field;
    let t = Instant::now();
    let bytes = vlf_core::format::write_atomic(output, &lf)?;
    let t_write = t.elapsed().as_secs_f64();
    let phases: Vec<(String, f64)> = [
        ("load", t_load),
        ("plan", t_plan),
        ("prepare", t_prep),
        ("propagate", t_prop),
        (
            if finished.gather.is_some() {
                "gather"
            } else {
                "assemble"
            },
            t_gather,
        ),
        ("write", t_write),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    let total_s = phases.iter().map(|p| p.1).sum();
    let src = energy.emitted + energy.injected;
    let texels = prep.texel_count() as u64;
    let tile_values = lf.tiles.as_ref().map_or(0, |t| t.radiance.len() as u64);
    Ok(BakeReport {
        scene: scene_path.display().to_string(),
        output: output.display().to_string(),
        device: device_name.into(),
        device_reason: compute.why().to_string(),
        adapter,
        threads,
        params: params.clone(),
        directions: set.len(),
        prepared: prep.summary(),
        // As baked: a glossy lobe may have been modelled as a mirror to fit the budget.
        materials: {
            let mut r = bake::glossy::report(&scene.materials, &set);
            for (m, baked) in r.iter_mut().zip(&prep.materials) {
                m.model = baked.model;
            }
            r
        },
        iterations,
        phases_s: phases,
        total_s,
        energy: EnergyReport {
            emitted: energy.emitted,
            injected: energy.injected,
            absorbed: energy.absorbed,
            escaped: energy.escaped,
            unshot: energy.unshot,
            unshot_fraction: if src > 0.0 { energy.unshot / src } else { 0.0 },
            imbalance: energy.relative_imbalance(),
        },
        resample: finished.resample,
        gather: finished.gather.map(|stats| GatherReport {
            device: match compute {
                Compute::Gpu(..) if gpu_gather(&scene, params).is_some() => "gpu",
                _ => "cpu",
            },
            relative_difference: stats.relative_difference(),
            stats,
        }),
        memory: MemoryReport {
            propagation_bytes: (texels + tile_values) * 3 * 16 + texels * 32,
            render_bytes: (lf.light_bytes() + lf.shading.byte_len()) as u64,
            tile_bytes: lf.tiles.as_ref().map_or(0, |t| t.radiance.byte_len()) as u64,
            plan,
        },
        output_bytes: bytes,
        warnings: scene
            .warnings
            .iter()
            .chain(&prep.warnings)
            .cloned()
            .collect(),
        auto: auto_reasons,
        gpu_propagation: gpu_stats,
    })
}

/// `vlf-bake bake`.
pub fn bake_command(
    scene_path: &Path,
    output: &Path,
    args: &BakeArgs,
    device: DeviceArg,
    json: bool,
    quiet: bool,
) -> anyhow::Result<()> {
    // Validate the explicit options before opening a device (the scene refines them later).
    params_from_args(args)?;
    let t = Instant::now();
    let compute = open_device(device)?;
    let t_device = t.elapsed().as_secs_f64();
    let budget = Budget::new(args.max_memory, &compute, 1);
    let bar = (!quiet && !json).then(|| {
        progress_bar(&match &compute {
            Compute::Gpu(ctx, _) => ctx.summary.name.clone(),
            Compute::Cpu(_) => cpu_label(vlf_core::par::threads(args.threads)),
        })
    });
    let mut report = bake_scene(
        scene_path,
        output,
        args,
        &compute,
        &budget,
        &mut |done, total, msg| {
            if let Some(bar) = &bar {
                bar.set_length(total);
                bar.set_position(done);
                bar.set_message(msg.to_string());
            }
        },
    )?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    report.phases_s.insert(0, ("device".into(), t_device));
    report.total_s += t_device;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else if !quiet {
        println!(
            "baked {} → {} ({:.1} MB) in {:.2} s on {} ({}): {} directions, {}² rays, {} iterations, unshot {:.2}% of the emitted power, energy imbalance {:+.3}%",
            report.scene,
            report.output,
            report.output_bytes as f64 / 1e6,
            report.total_s,
            match report.device.as_str() {
                "cpu" => cpu_label(report.threads),
                _ => report.adapter.clone(),
            },
            report.device_reason,
            report.directions,
            report.params.resolution,
            report.iterations,
            100.0 * report.energy.unshot_fraction,
            100.0 * report.energy.imbalance
        );
    }
    Ok(())
}

/// "the CPU (N threads)", as the summary line and the progress bar name the CPU path.
pub fn cpu_label(threads: usize) -> String {
    format!(
        "the CPU ({threads} thread{})",
        if threads == 1 { "" } else { "s" }
    )
}

fn progress_bar(adapter: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] {percent}% {msg} ETA {eta}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("baking on {adapter}"));
    bar
}
