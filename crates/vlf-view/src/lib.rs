//! The `vlf-view` program as a library: `main.rs` only parses arguments and calls [`run`].
//!
//! * headless: [`still`] (`--still`) and [`bench`] (`--bench-frames`) need a GPU adapter but no
//!   window or display;
//! * interactive: [`app`] (winit 0.30 window + egui 0.37 panel).

pub mod app;
pub mod cli;
pub mod fly;

use std::path::Path;
use std::time::Instant;

use anyhow::Context as _;
use cli::{Cli, TonemapArg};
use vlf_core::image::{Image, Tonemap};
use vlf_core::lightfield::LightField;
use vlf_gpu::render::{CameraView, Pass, RenderError, Renderer, TIMED_PASSES};
use vlf_gpu::wgpu_util::texture_2d;
use vlf_gpu::{DeviceOptions, GpuContext};

/// Exit codes, documented in `--help`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ExitCode {
    Internal = 1,
    Usage = 2,
    BadInput = 3,
    NoDevice = 4,
}

impl From<ExitCode> for std::process::ExitCode {
    fn from(c: ExitCode) -> Self {
        std::process::ExitCode::from(c as u8)
    }
}

/// A command-line value that parses but makes no sense (unknown camera…): exit code 2.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Maps an error chain to the exit code of its root kind.
pub fn exit_code(err: &anyhow::Error) -> ExitCode {
    for cause in err.chain() {
        if cause.is::<UsageError>() {
            return ExitCode::Usage;
        }
        if cause.is::<vlf_core::scene::SceneError>() || cause.is::<vlf_core::format::FormatError>()
        {
            return ExitCode::BadInput;
        }
        match cause.downcast_ref::<vlf_gpu::render::RenderError>() {
            Some(RenderError::InvalidLightField(_)) => return ExitCode::BadInput,
            // The light field or image exceeds what this device can hold.
            Some(RenderError::TooLarge { .. }) => return ExitCode::NoDevice,
            Some(RenderError::Size { .. }) => return ExitCode::Usage,
            _ => {}
        }
        if cause.is::<vlf_gpu::DeviceError>() {
            return ExitCode::NoDevice;
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

impl From<TonemapArg> for Tonemap {
    fn from(t: TonemapArg) -> Self {
        match t {
            TonemapArg::Clamp => Tonemap::Clamp,
            TonemapArg::Aces => Tonemap::Aces,
        }
    }
}

/// The display tonemap matching a PNG tonemap.
pub fn gpu_tonemap(t: Tonemap) -> vlf_gpu::render::Tonemap {
    match t {
        Tonemap::Aces => vlf_gpu::render::Tonemap::Aces,
        _ => vlf_gpu::render::Tonemap::Clamp,
    }
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    let lf = load(&cli)?;
    log::info!(
        "light field: {} faces, {} triangles, {} atlas texels, {} directions, {:.1} MiB light, \
         {} textures ({:.1} MiB)",
        lf.faces.len(),
        lf.triangles.len(),
        lf.irradiance.len(),
        lf.directions.len(),
        lf.light_bytes() as f64 / (1 << 20) as f64,
        lf.shading.textures.len(),
        lf.shading.texels.byte_len() as f64 / (1 << 20) as f64
    );
    let camera = match (cli.look_from, cli.look_at) {
        (Some(from), Some(at)) => {
            fly::look_at_camera(&lf, from, at, cli.fov).map_err(UsageError)?
        }
        _ => fly::start_camera(&lf, cli.camera.as_deref()).map_err(UsageError)?,
    };
    if let Some(out) = &cli.still {
        image_kind(out)?;
        let (w, h) = cli.size.unwrap_or((512, 512));
        let ctx = GpuContext::new(&DeviceOptions::default())?;
        let mut renderer = Renderer::new(&ctx, &lf)?;
        renderer.set_mirror_tracing(cli.mirror_tracing.into());
        let img = still_with(
            &mut renderer,
            &ctx,
            &camera,
            w,
            h,
            cli.spp,
            cli.debug_view.into(),
        )?;
        write_image(out, &img, cli.exposure, cli.tonemap.into())?;
        let spp = if cli.debug_view == cli::DebugViewArg::FinalRadiance {
            cli.spp
        } else {
            1
        };
        println!("wrote {} ({w}×{h}, {spp} spp)", out.display());
        return Ok(());
    }
    if let Some(n) = cli.bench_frames {
        let (w, h) = cli.size.unwrap_or((1024, 768));
        let ctx = GpuContext::new(&DeviceOptions::default())?;
        let mut renderer = Renderer::new(&ctx, &lf)?;
        renderer.set_mirror_tracing(cli.mirror_tracing.into());
        let report = bench(&ctx, &mut renderer, &camera, w, h, n, cli.debug_view.into())?;
        println!("{report}");
        return Ok(());
    }
    app::run_window(lf, camera, &cli)
}

/// Reads the `.vlf` file, or bakes `--bake-preview`'s scene with the CPU reference.
pub fn load(cli: &Cli) -> anyhow::Result<LightField> {
    if let Some(scene) = &cli.bake_preview {
        return bake_preview(scene);
    }
    let path = cli
        .file
        .as_deref()
        .expect("clap requires FILE without --bake-preview");
    Ok(vlf_core::format::read(path)?)
}

/// Bakes `scene` with the CPU reference at tiny settings (development aid).
pub fn bake_preview(scene: &Path) -> anyhow::Result<LightField> {
    let t = Instant::now();
    let s = vlf_core::scene::load(scene)?;
    let params = vlf_core::lightfield::BakeParams {
        directions: 46,
        resolution: 32,
        tile: 8,
        iterations: vlf_core::lightfield::Iterations::Fixed(2),
        ..vlf_core::lightfield::BakeParams::paper()
    };
    let lf = vlf_core::pipeline::bake_cpu(&s, &params)
        .with_context(|| format!("preview bake of {}", scene.display()))?;
    log::info!(
        "preview bake of {} in {:.2} s",
        scene.display(),
        t.elapsed().as_secs_f64()
    );
    Ok(lf)
}

/// Renders a still (or a pass's debug view) into an [`Image`].
pub fn still(
    ctx: &GpuContext,
    lf: &LightField,
    camera: &CameraView,
    width: u32,
    height: u32,
    spp: u32,
    view: Pass,
) -> anyhow::Result<Image> {
    let mut renderer = Renderer::new(ctx, lf)?;
    still_with(&mut renderer, ctx, camera, width, height, spp, view)
}

/// [`still`] with an existing renderer (the window's screenshots use this).
pub fn still_with(
    renderer: &mut Renderer,
    ctx: &GpuContext,
    camera: &CameraView,
    width: u32,
    height: u32,
    spp: u32,
    view: Pass,
) -> anyhow::Result<Image> {
    let pixels = renderer.render_debug_still(ctx, camera, width, height, spp, view)?;
    Ok(Image {
        width,
        height,
        pixels,
    })
}

/// Writes `img` as EXR (linear, `exposure` ignored) or PNG (exposed, tonemapped, sRGB), by the
/// file extension.
pub fn write_image(
    path: &Path,
    img: &Image,
    exposure: f32,
    tonemap: Tonemap,
) -> anyhow::Result<()> {
    match image_kind(path)? {
        ImageKind::Exr => vlf_core::image::write_exr(path, img)?,
        ImageKind::Png => vlf_core::image::write_png(path, img, exposure, tonemap)?,
    }
    Ok(())
}

/// Output image formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    Exr,
    Png,
}

/// The image format named by `path`'s extension (a usage error otherwise).
pub fn image_kind(path: &Path) -> Result<ImageKind, UsageError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => Ok(ImageKind::Exr),
        Some("png") => Ok(ImageKind::Png),
        _ => Err(UsageError(format!(
            "cannot tell the image format of {}: use a .exr or .png extension",
            path.display()
        ))),
    }
}
/// Frame-time figures of [`bench`].
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// Whether mirror pixels traced their reflections (false without mirrors).
    pub mirror_tracing: bool,
    /// Wall-clock milliseconds per frame (encode, submit, wait), sorted.
    pub frame_ms: Vec<f64>,
    /// Mean GPU milliseconds per pass ([`TIMED_PASSES`] order) over the frames that ran it
    /// (`None` for a pass no frame ran), when timestamps exist.
    pub pass_ms: Option<Vec<Option<f64>>>,
}

impl BenchReport {
    pub fn mean_ms(&self) -> f64 {
        self.frame_ms.iter().sum::<f64>() / self.frame_ms.len().max(1) as f64
    }

    pub fn median_ms(&self) -> f64 {
        self.frame_ms
            .get(self.frame_ms.len() / 2)
            .copied()
            .unwrap_or(0.0)
    }
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} frames at {}×{} on {}, mirror tracing {}: mean {:.2} ms, median {:.2} ms, min {:.2} ms, max {:.2} ms ({:.1} fps)",
            self.frames,
            self.width,
            self.height,
            self.adapter,
            if self.mirror_tracing { "on" } else { "off" },
            self.mean_ms(),
            self.median_ms(),
            self.frame_ms.first().copied().unwrap_or(0.0),
            self.frame_ms.last().copied().unwrap_or(0.0),
            1000.0 / self.mean_ms().max(1e-9)
        )?;
        match &self.pass_ms {
            Some(p) => {
                write!(f, "GPU pass times (mean):")?;
                for (name, ms) in TIMED_PASSES.iter().zip(p) {
                    match ms {
                        Some(ms) => write!(f, " {name} {ms:.2} ms;")?,
                        None => write!(f, " {name} skipped;")?,
                    }
                }
                write!(f, " total {:.2} ms", p.iter().flatten().sum::<f64>())
            }
            None => write!(f, "GPU pass times: unavailable (no TIMESTAMP_QUERY)"),
        }
    }
}

/// Renders `frames` interactive frames (five passes + display onto an sRGB 8-bit target, like
/// the window's surface) with `renderer` one after another, waiting for each, after one
/// warm-up frame.
pub fn bench(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    camera: &CameraView,
    width: u32,
    height: u32,
    frames: u32,
    view: Pass,
) -> anyhow::Result<BenchReport> {
    renderer.set_debug_view(view);
    let format = wgpu::TextureFormat::Bgra8UnormSrgb;
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let target = texture_2d(&ctx.device, "Bench::target", (width, height), format, usage);
    let view = target.create_view(&Default::default());
    let mut frame_ms = Vec::new();
    // Per pass: the sum of its times and the frames that ran it.
    let mut pass_sum: Option<Vec<(f64, u32)>> = None;
    for i in 0..=frames {
        let t = Instant::now();
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Bench::encoder"),
            });
        // The recorded camera path: a full turn in place about the up axis, starting from the
        // requested camera, so frames see every part of the scene (near and far, diffuse and
        // mirror surfaces, background).
        let turn = glam::Quat::from_rotation_y(std::f32::consts::TAU * i as f32 / frames as f32);
        let cam = CameraView {
            rotation: turn * camera.rotation,
            ..*camera
        };
        renderer.render_to_view(
            ctx,
            &mut encoder,
            &cam,
            &view,
            format,
            width,
            height,
            1.0,
            vlf_gpu::render::Tonemap::Clamp,
        )?;
        ctx.queue.submit(Some(encoder.finish()));
        ctx.wait_idle();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        renderer.frame_submitted(ctx);
        if i == 0 {
            continue; // warm-up: pipeline compilation, target creation
        }
        frame_ms.push(ms);
        if let Some(p) = renderer.pass_times() {
            let sum = pass_sum.get_or_insert_with(|| vec![(0.0, 0); p.len()]);
            for (s, v) in sum.iter_mut().zip(p) {
                if let Some(v) = v {
                    *s = (s.0 + v, s.1 + 1);
                }
            }
        }
    }
    frame_ms.sort_by(f64::total_cmp);
    Ok(BenchReport {
        adapter: ctx.summary.to_string(),
        width,
        height,
        frames,
        mirror_tracing: renderer.mirror_tracing(),
        frame_ms,
        pass_ms: pass_sum.map(|s| {
            (s.into_iter())
                .map(|(sum, n)| (n > 0).then(|| sum / f64::from(n)))
                .collect()
        }),
    })
}
