//! `vlf-bake reference`: an unbiased path-traced reference image of a scene, following the
//! conventions of the shared Mitsuba references (`shared/reference/README.md`), so that bakes
//! can be validated without any other tool.
//!
//! The CPU path tracer is `vlf_core::pathtrace`; the GPU one (`vlf_gpu::raytrace`) runs the same
//! estimator with the same random streams, so both give the same image up to rounding.
//! Device choice (`--device`, [`crate::open_device`]): `cpu` → CPU; `gpu` → the GPU (fails
//! without an adapter); `auto` → a hardware GPU when there is one, else the CPU tracer: on a
//! software adapter (lavapipe) the GPU kernels run on the same CPU cores about 3× slower than
//! the native tracer.

use std::time::Instant;

use anyhow::Context as _;
use glam::Vec3;
use serde::Serialize;
use vlf_core::image::{Image, write_exr};
use vlf_core::pathtrace::{self, PinholeCamera, PreparedScene, RenderSettings};
use vlf_gpu::raytrace::{GpuPathTracer, GpuRenderOptions, Kernel};

use crate::Compute;
use crate::cli::{DeviceArg, KernelArg, Point, ReferenceArgs, Size};

/// What `--json` prints.
#[derive(Serialize)]
pub struct ReferenceReport {
    pub scene: String,
    pub output: String,
    pub device: String,
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    pub camera: String,
    pub triangles: usize,
    pub emissive_triangles: usize,
    pub suns: usize,
    /// Point and spot lights.
    pub lights: usize,
    pub mean_rgb: [f64; 3],
    pub render_s: f64,
    pub total_s: f64,
    /// GPU wavefront only: camera, continuation and shadow rays traced.
    pub rays: Option<u64>,
    pub warnings: Vec<String>,
}

fn progress_bar(prefix: &str, total: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] {percent}% ETA {eta}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(prefix.to_string());
    bar
}

/// `vlf-bake reference`: renders `args.scene` and writes `args.output`.
pub fn reference_command(
    args: &ReferenceArgs,
    device: DeviceArg,
    quiet: bool,
) -> anyhow::Result<()> {
    let t_total = Instant::now();
    let mut scene = vlf_core::scene::load(&args.scene)?;
    if args.flat_normals {
        scene.flatten_normals();
    }
    let sky = args.sky.map_or(Vec3::ZERO, |s| Vec3::from(s.0));
    vlf_core::scene::check_lighting(&scene, Some(sky))?;
    let Size(width, height) = args.size;
    let settings = RenderSettings {
        width,
        height,
        spp: args.spp,
        seed: args.seed,
        sky,
        threads: args.threads,
    };
    settings.validate().context("reference settings")?;
    let (camera, camera_desc) = match (args.look_from, args.look_at) {
        (Some(Point(from)), Some(Point(at))) => (
            PinholeCamera::look_at(from, at, args.fov, width, height)
                .context("--look-from/--look-at")?,
            format!("look-from {from} look-at {at} fov {}°", args.fov),
        ),
        _ => {
            let index = args.camera.unwrap_or(0);
            let camera = PinholeCamera::from_scene(&scene, index, width, height).with_context(|| {
                if scene.cameras.is_empty() {
                    "the scene has no camera: give a viewpoint with --look-from x,y,z --look-at x,y,z \
                     [--fov deg]"
                } else {
                    "--camera"
                }
            })?;
            (camera, format!("camera {index}"))
        }
    };
    let tracer = if scene.has_translucency() {
        // The GPU path tracer has no random walk or diffuse transmission yet
        // (docs/SUBSURFACE.md): scenes with translucent materials are traced on the CPU.
        Compute::Cpu("translucent materials: the GPU path tracer has no random walk yet".into())
    } else {
        crate::open_device(device)?
    };
    let prep = PreparedScene::new(&scene);
    let total = u64::from(width) * u64::from(height) * u64::from(args.spp);
    let show = !quiet && !args.json;
    let t_render = Instant::now();
    let (image, device_name, adapter, rays): (Image, &str, String, Option<u64>) = match &tracer {
        Compute::Cpu(why) => {
            if show {
                eprintln!("path tracing on the CPU ({why})");
            }
            let bar = show.then(|| progress_bar("path tracing (CPU)", total));
            let image = pathtrace::render(&prep, &camera, &settings, &|done, _| {
                if let Some(bar) = &bar {
                    bar.set_position(done);
                }
            })?;
            if let Some(bar) = bar {
                bar.finish_and_clear();
            }
            (image, "cpu", "CPU path tracer".into(), None)
        }
        Compute::Gpu(ctx, _) => {
            let gpu = GpuPathTracer::new(&ctx.device);
            let options = GpuRenderOptions {
                kernel: match args.gpu_kernel {
                    KernelArg::Wavefront => Kernel::Wavefront,
                    KernelArg::Megakernel => Kernel::Megakernel,
                },
                ..Default::default()
            };
            let bar =
                show.then(|| progress_bar(&format!("path tracing on {}", ctx.summary), total));
            let (image, stats) = gpu
                .render(ctx, &prep, &camera, &settings, &options, &|done, _| {
                    if let Some(bar) = &bar {
                        bar.set_position(done);
                    }
                })
                .context("GPU path tracing")?;
            if let Some(bar) = bar {
                bar.finish_and_clear();
            }
            let rays = stats.extension_rays + stats.shadow_rays;
            (
                image,
                "gpu",
                ctx.summary.to_string(),
                (rays > 0).then_some(rays),
            )
        }
    };
    let render_s = t_render.elapsed().as_secs_f64();
    write_exr(&args.output, &image)?;
    let summary = scene.summary();
    let report = ReferenceReport {
        scene: args.scene.display().to_string(),
        output: args.output.display().to_string(),
        device: device_name.into(),
        adapter,
        width,
        height,
        spp: args.spp,
        seed: args.seed,
        camera: camera_desc,
        triangles: summary.triangles,
        emissive_triangles: prep.lights.emitters.len(),
        suns: scene.suns.len(),
        lights: scene.lights.len(),
        mean_rgb: image.mean(),
        render_s,
        total_s: t_total.elapsed().as_secs_f64(),
        rays,
        warnings: scene.warnings.clone(),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else if !quiet {
        let m = report.mean_rgb;
        println!(
            "rendered {} → {} ({}×{}, {} spp, {}) in {:.2} s on {}; mean RGB ({:.4}, {:.4}, {:.4})",
            report.scene,
            report.output,
            width,
            height,
            args.spp,
            report.camera,
            render_s,
            report.adapter,
            m[0],
            m[1],
            m[2]
        );
    }
    Ok(())
}
