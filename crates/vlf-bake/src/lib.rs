//! The `vlf-bake` command-line tool as a library: `main.rs` only parses arguments and calls
//! [`run`]. Progress output belongs here (binary side), never in `vlf-core`/`vlf-gpu`.

pub mod bake;
pub mod batch;
pub mod cli;
pub mod export;
pub mod memory;
pub mod reference;
pub mod sweep;

use anyhow::Context as _;
use cli::{Cli, Command, DeviceArg};
use std::path::Path;

/// Exit codes, documented in `--help` (2 is clap's usage error).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ExitCode {
    Internal = 1,
    BadInput = 3,
    /// No usable GPU device, or the device was lost.
    NoDevice = 4,
    /// `batch`: at least one scene failed (the others were baked).
    BatchFailed = 5,
    /// The bake does not fit the memory budget, or the GPU ran out of memory.
    OutOfMemory = 6,
    /// Interrupted by Ctrl-C (128 + SIGINT).
    Interrupted = 130,
}

impl From<ExitCode> for std::process::ExitCode {
    fn from(c: ExitCode) -> Self {
        std::process::ExitCode::from(c as u8)
    }
}

/// Maps an error chain to the exit code of its root kind.
pub fn exit_code(err: &anyhow::Error) -> ExitCode {
    for cause in err.chain() {
        if cause.is::<vlf_core::scene::SceneError>()
            || cause.is::<vlf_core::format::FormatError>()
            || cause.is::<vlf_core::lightfield::ParamsError>()
            || cause.is::<vlf_core::image::ImageError>()
            || cause.is::<vlf_core::pathtrace::PathTraceError>()
            || cause.is::<vlf_core::export::ExportError>()
        {
            return ExitCode::BadInput;
        }
        if cause.is::<vlf_gpu::DeviceError>() {
            return ExitCode::NoDevice;
        }
        if let Some(e) = cause.downcast_ref::<memory::MemoryError>() {
            return match e {
                memory::MemoryError::DeviceLost { .. } => ExitCode::NoDevice,
                memory::MemoryError::Gpu { .. } => ExitCode::Internal,
                _ => ExitCode::OutOfMemory,
            };
        }
        if let Some(e) = cause.downcast_ref::<batch::BatchError>() {
            return e.exit_code();
        }
    }
    ExitCode::Internal
}

pub fn init_logging(verbose: u8, quiet: bool) {
    let level = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        (false, 2) => "debug",
        _ => "trace",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .init();
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Bake {
            scene,
            output,
            params,
            json,
        } => bake::bake_command(&scene, &output, &params, cli.device, json, cli.quiet),
        Command::Batch {
            dir,
            output,
            jobs,
            json,
            force,
            no_default_sky,
            shard,
            mut params,
        } => batch::batch_command(&batch::BatchOptions {
            dir,
            output,
            jobs,
            report: json,
            force,
            shard,
            args: {
                if !no_default_sky && params.sky_if_unlit.is_none() {
                    params.sky_if_unlit = Some(cli::Rgb([1.0; 3]));
                }
                params
            },
            device: cli.device,
            quiet: cli.quiet,
        }),
        Command::Info { file, json } => info(&file, json),
        Command::Reference(args) => reference::reference_command(&args, cli.device, cli.quiet),
        Command::Sweep(args) => sweep::sweep_command(&args, cli.device, cli.quiet),
        Command::Compare {
            test,
            reference,
            json,
            diff,
        } => compare(&test, &reference, json, diff.as_deref()),
        Command::Export {
            file,
            output,
            texture,
            max_size,
            scene,
            json,
        } => export::export_command(&file, &output, texture, max_size, scene.as_deref(), json),
        Command::Inspect { scene, json } => inspect(&scene, json),
        Command::Selftest { json } => selftest(cli.device, json),
    }
}

fn compare(test: &Path, reference: &Path, json: bool, diff: Option<&Path>) -> anyhow::Result<()> {
    use vlf_core::image;
    let t = image::read_any(test)?;
    let r = image::read_any(reference)?;
    let (report, flip) = image::compare_images(&t, &r, test, reference)?;
    if let Some(path) = diff {
        image::error_map_png(path, &flip.map, t.width, t.height)?;
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} vs {} ({}×{}): MSE {:.4e}, relMSE {:.4e}, mean FLIP {:.4}",
            test.display(),
            reference.display(),
            report.width,
            report.height,
            report.mse,
            report.rel_mse,
            report.flip_mean
        );
    }
    Ok(())
}

fn info(path: &Path, json: bool) -> anyhow::Result<()> {
    let info = vlf_core::format::describe(path)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        println!("{info}");
    }
    Ok(())
}

/// What `vlf-bake inspect --json` prints: the scene's counts, each material's model (lobes, mask,
/// pane) and how it shades, and the lights.
#[derive(serde::Serialize)]
struct Inspection {
    #[serde(flatten)]
    summary: vlf_core::scene::SceneSummary,
    /// (name, model) of every material ([`vlf_core::scene::Material::model`]).
    material_models: Vec<(String, String)>,
    shading: Vec<vlf_core::scene::MaterialShading>,
    lights: Vec<LightReport>,
    translucency: Vec<vlf_core::scene::MaterialTranslucency>,
}

fn inspect(path: &Path, json: bool) -> anyhow::Result<()> {
    let scene = vlf_core::scene::load(path)?;
    let report = Inspection {
        summary: scene.summary(),
        material_models: scene
            .materials
            .iter()
            .map(|m| (m.name.clone(), m.model()))
            .collect(),
        shading: scene.material_shading(),
        lights: scene.lights.iter().map(LightReport::of).collect(),
        // Each material's subsurface model (docs/SUBSURFACE.md).
        translucency: scene.material_translucency(),
    };
    let translucency = &report.translucency;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!("scene {}", path.display());
    println!("{}", serde_json::to_string_pretty(&report.summary)?);
    for (i, ((name, model), m)) in report
        .material_models
        .iter()
        .zip(&report.shading)
        .enumerate()
    {
        println!("material {i} {name:?}: {model}; {}", describe_shading(m));
    }
    for l in &report.lights {
        println!("{l}");
    }
    for m in translucency {
        println!("{m}");
    }
    for w in &scene.warnings {
        println!("warning: {w}");
    }
    Ok(())
}

/// A point or spot light as `inspect` lists it.
#[derive(serde::Serialize)]
struct LightReport {
    name: Option<String>,
    kind: &'static str,
    position: [f32; 3],
    direction: [f32; 3],
    /// color × intensity (W/sr, radiometric).
    intensity: [f32; 3],
    /// Spot: (inner, outer) cone angles in radians.
    cone: Option<[f32; 2]>,
    range: Option<f32>,
}

impl LightReport {
    fn of(l: &vlf_core::scene::PunctualLight) -> LightReport {
        use vlf_core::scene::PunctualKind;
        let (kind, cone) = match l.kind {
            PunctualKind::Point => ("point", None),
            PunctualKind::Spot { inner, outer } => ("spot", Some([inner, outer])),
        };
        LightReport {
            name: l.name.clone(),
            kind,
            position: l.position.to_array(),
            direction: l.direction.to_array(),
            intensity: l.intensity.to_array(),
            cone,
            range: l.range,
        }
    }
}

impl std::fmt::Display for LightReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.position;
        let [r, g, b] = self.intensity;
        write!(f, "light: {}", self.kind)?;
        if let Some(n) = &self.name {
            write!(f, " {n:?}")?;
        }
        write!(
            f,
            " at ({x:.3}, {y:.3}, {z:.3}), color × intensity ({r:.4}, {g:.4}, {b:.4}) W/sr"
        )?;
        if let Some([inner, outer]) = self.cone {
            let [dx, dy, dz] = self.direction;
            write!(
                f,
                ", pointing ({dx:.3}, {dy:.3}, {dz:.3}), cone {inner:.4}–{outer:.4} rad ({:.2}°–{:.2}°)",
                inner.to_degrees(),
                outer.to_degrees()
            )?;
        }
        match self.range {
            Some(r) => write!(f, ", range {r} (windowed)"),
            None => write!(f, ", no range"),
        }
    }
}

/// One line on how a material shades: smooth or flat, vertex colours, texture coordinate sets,
/// an ignored normal map.
fn describe_shading(m: &vlf_core::scene::MaterialShading) -> String {
    let mut parts = vec![match (m.triangles, m.smooth_triangles) {
        (0, _) => "no triangles".to_string(),
        (_, 0) => format!("{} triangles, flat", m.triangles),
        (t, s) if s == t => format!("{t} triangles, smooth (NORMAL shading normals)"),
        (t, s) => format!("{t} triangles, {s} smooth (NORMAL shading normals), the rest flat"),
    }];
    if m.colored_triangles > 0 {
        parts.push(format!(
            "vertex colours (COLOR_0) on {} triangles",
            m.colored_triangles
        ));
    }
    for (slot, set) in [
        ("base colour", m.base_color_texcoord),
        ("emissive", m.emissive_texcoord),
    ] {
        if let Some(set) = set {
            parts.push(format!("{slot} texture on TEXCOORD_{set}"));
        }
    }
    if m.normal_map_ignored {
        parts.push("normalTexture ignored (normal maps are not modelled)".into());
    }
    parts.join("; ")
}

/// The compute device `--device` chose, with the reason (for `--json` and the summary line).
pub enum Compute {
    Gpu(Box<vlf_gpu::GpuContext>, String),
    /// The CPU path (all cores, `--threads`).
    Cpu(String),
}

impl Compute {
    /// `"gpu"` or `"cpu"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Compute::Gpu(..) => "gpu",
            Compute::Cpu(_) => "cpu",
        }
    }

    /// Why this device was used.
    pub fn why(&self) -> &str {
        match self {
            Compute::Gpu(_, why) | Compute::Cpu(why) => why,
        }
    }

    /// The GPU context, if the GPU is used.
    pub fn gpu(&self) -> Option<&vlf_gpu::GpuContext> {
        match self {
            Compute::Gpu(ctx, _) => Some(ctx),
            Compute::Cpu(_) => None,
        }
    }
}

/// Opens the compute device as `--device` asks: `gpu` must get an adapter (software ones
/// included); `cpu` never touches the GPU; `auto` takes the faster path: a hardware adapter
/// when there is one, the CPU path when the only adapter is a software rasterizer (lavapipe,
/// llvmpipe, WARP, SwiftShader: the same cores run the native code faster) or when there is
/// none. The one home of this rule for `bake`, `batch`, `sweep` and `reference`.
pub fn open_device(arg: DeviceArg) -> anyhow::Result<Compute> {
    match arg {
        DeviceArg::Cpu => Ok(Compute::Cpu("--device cpu".into())),
        DeviceArg::Gpu => {
            let ctx = vlf_gpu::GpuContext::new(&Default::default()).context("--device gpu")?;
            Ok(Compute::Gpu(Box::new(ctx), "--device gpu".into()))
        }
        DeviceArg::Auto => match vlf_gpu::GpuContext::new(&Default::default()) {
            Ok(ctx) if !ctx.summary.is_software() => {
                let why = format!("hardware GPU adapter {}", ctx.summary.name);
                Ok(Compute::Gpu(Box::new(ctx), why))
            }
            Ok(ctx) => {
                let why = format!(
                    "the only GPU adapter, {}, is a software rasterizer: the CPU path is faster on \
                     the same cores (--device gpu forces the adapter)",
                    ctx.summary.name
                );
                log::info!("{why}");
                Ok(Compute::Cpu(why))
            }
            Err(e) => {
                log::info!("no usable GPU ({e}); using the CPU path");
                Ok(Compute::Cpu(format!("no usable GPU adapter ({e})")))
            }
        },
    }
}

/// Probes the GPU adapter (any, software included, unless `--device cpu`) and says which
/// device `--device auto` bakes on.
fn selftest(device: DeviceArg, json: bool) -> anyhow::Result<()> {
    if device == DeviceArg::Cpu {
        anyhow::bail!("selftest probes the GPU adapter: it needs --device auto or gpu");
    }
    let ctx = vlf_gpu::GpuContext::new(&Default::default()).context("selftest")?;
    let auto = if ctx.summary.is_software() {
        "cpu (the adapter is a software rasterizer)"
    } else {
        "gpu"
    };
    let pass = vlf_gpu::smoke::SmokePass::new(&ctx.device);
    let xs: Vec<f32> = (0..65_536).map(|i| i as f32 * 0.25).collect();
    let t = std::time::Instant::now();
    let ys = pass
        .run(&ctx.device, &ctx.queue, 2.0, 1.0, &xs)
        .context("reading back the self-test buffer")?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let bad = xs
        .iter()
        .zip(&ys)
        .filter(|(x, y)| y[0] != 2.0 * **x + 1.0)
        .count();
    if json {
        println!(
            "{}",
            serde_json::json!({
                "adapter": ctx.summary.name, "backend": ctx.summary.backend,
                "device_type": ctx.summary.device_type, "driver": ctx.summary.driver,
                "selftest_elements": xs.len(), "selftest_mismatches": bad, "selftest_ms": ms,
                "bake_device_auto": auto,
            })
        );
    } else {
        println!("adapter: {}", ctx.summary);
        println!("bake --device auto uses: {auto}");
        println!(
            "compute self-test: {} elements, {bad} mismatches, {ms:.1} ms",
            xs.len()
        );
    }
    anyhow::ensure!(bad == 0, "compute self-test failed: {bad} wrong elements");
    Ok(())
}
