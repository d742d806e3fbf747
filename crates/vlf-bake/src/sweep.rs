//! `vlf-bake sweep`: speed against accuracy on one scene (`docs/ACCURACY.md`). Bakes the scene over a grid
//! of parameters, renders one viewpoint of each bake with the five-pass renderer, and compares
//! it with a reference image; the path tracer (an error-vs-time curve over samples per pixel)
//! and the matrix radiosity baseline (diffuse scenes) are measured on the same view. One CSV row
//! per point, rewritten atomically after every point so an interrupted sweep keeps what it
//! measured. `cargo xtask chart` runs this over the shared scenes and draws the charts.
//!
//! What each time column means (all wall-clock seconds on the machine that ran the sweep):
//! * `vlf`: load + plan + prepare + propagate + write of `vlf-bake bake` (the product's bake);
//!   the image is then rendered from the file as read back, as the viewer would.
//! * `pathtrace`: BVH build + rendering this one view at `spp` samples per pixel (all cores).
//! * `radiosity`: form factors (ray casting, all cores) + solve.
//!
//! `render_s` is the time of the still render of the light field (16 jittered samples per
//! pixel by default); a walkthrough pays it per frame, the path tracer pays `time_s` per view.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use glam::Vec3;
use vlf_core::image::{self, Image};
use vlf_core::lightfield::LightField;
use vlf_core::pathtrace::{self, PinholeCamera, PreparedScene, RenderSettings};
use vlf_gpu::GpuContext;
use vlf_gpu::render::{CameraView, Renderer};

use crate::bake::{bake_scene, resolve_params};
use crate::batch::write_bytes_atomic;
use crate::cli::{
    BakeArgs, DeviceArg, GridArg, IterationsArg, OnOff, Point, QualityArg, Rgb, SweepArgs,
};
use crate::memory::Budget;
use crate::{Compute, open_device};

/// One measured point.
#[derive(Clone, Debug, Default)]
pub struct Row {
    pub scene: String,
    /// `vlf`, `pathtrace`, `radiosity_gs` or `radiosity_jacobi_gpu`.
    pub method: &'static str,
    pub label: String,
    /// The `--quality` preset this point is (`draft`, `auto`, `high`), empty for grid points.
    pub preset: String,
    pub directions: u32,
    pub resolution: u32,
    pub tile: u32,
    pub texel_scale: f32,
    pub perturb: u32,
    /// `auto:THRESHOLD` or the fixed count asked for.
    pub iterations_rule: String,
    pub iterations: u32,
    pub spp: u32,
    pub rays_per_patch: u32,
    /// Time to produce the radiance (see the module documentation).
    pub time_s: f64,
    pub render_s: f64,
    /// Peak working memory of the method: the bake's memory plan (host + GPU buffers), the
    /// radiosity matrix, or the path tracer's BVH and frame buffer.
    pub work_bytes: u64,
    /// What is kept for rendering: the light-field file's size (0 for the path tracer).
    pub stored_bytes: u64,
    pub rel_mse: f64,
    pub flip: f64,
    pub mse: f64,
    pub device: String,
}

const HEADER: &str = "scene,method,label,preset,directions,resolution,tile,texel_scale,perturb,\
iterations_rule,iterations,spp,rays_per_patch,time_s,render_s,work_bytes,stored_bytes,rel_mse,\
flip,mse,device";

impl Row {
    fn csv(&self) -> String {
        let clean = |s: &str| s.replace([',', '\n', '"'], " ");
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{},{},{:.6e},{:.6},{:.6e},{}",
            clean(&self.scene),
            self.method,
            clean(&self.label),
            self.preset,
            self.directions,
            self.resolution,
            self.tile,
            self.texel_scale,
            self.perturb,
            self.iterations_rule,
            self.iterations,
            self.spp,
            self.rays_per_patch,
            self.time_s,
            self.render_s,
            self.work_bytes,
            self.stored_bytes,
            self.rel_mse,
            self.flip,
            self.mse,
            clean(&self.device),
        )
    }
}

/// One bake of the grid: a preset plus explicit overrides.
#[derive(Clone, Debug)]
struct GridPoint {
    label: String,
    preset: Option<QualityArg>,
    directions: Option<u32>,
    resolution: Option<u32>,
    tile: Option<u32>,
    iterations: Option<IterationsArg>,
    perturb: Option<u32>,
    final_gather: OnOff,
}

impl GridPoint {
    fn preset(q: QualityArg, name: &str) -> Self {
        Self {
            label: name.into(),
            preset: Some(q),
            directions: None,
            resolution: None,
            tile: None,
            iterations: None,
            perturb: None,
            final_gather: OnOff::On,
        }
    }

    fn grid(l: u32, n: u32) -> Self {
        Self {
            label: format!("l={l} N={n}"),
            preset: None,
            directions: Some(l),
            resolution: Some(n),
            tile: None,
            iterations: None,
            // Grid points isolate directions × resolution: no perturbation unless asked.
            perturb: Some(0),
            final_gather: OnOff::On,
        }
    }

    /// The same bake without the final gather (the light field alone), labelled as such.
    fn without_gather(mut self) -> Self {
        self.label = format!("{} no-gather", self.label);
        self.final_gather = OnOff::Off;
        self
    }

    fn args(&self, sky: Option<Rgb>, flat_normals: bool) -> BakeArgs {
        BakeArgs {
            quality: self.preset.unwrap_or(QualityArg::Auto),
            directions: self.directions,
            resolution: self.resolution,
            tile: self.tile,
            iterations: self.iterations,
            threshold: None,
            perturb: self.perturb,
            texel_scale: None,
            final_gather: self.final_gather,
            gather_texel_scale: None,
            gather_rays: None,
            gather_sampling: None,
            gather_target: None,
            gather_max_rounds: None,
            denoise: None,
            sky,
            sky_if_unlit: None,
            flat_normals,
            max_memory: None,
            // Every core, as the path tracer and radiosity use.
            threads: 0,
        }
    }
}

/// The bakes of a grid, cheapest first (an interrupted sweep keeps the cheap points).
fn plan(grid: GridArg, high: bool) -> Vec<GridPoint> {
    // With the final gather (the default), then the light field alone as its own series.
    let mut v = vec![
        GridPoint::preset(QualityArg::Draft, "draft"),
        GridPoint::grid(126, 32),
        GridPoint::grid(126, 64),
        GridPoint::grid(246, 64),
        GridPoint::preset(QualityArg::Auto, "auto"),
        GridPoint::preset(QualityArg::Draft, "draft").without_gather(),
        GridPoint::grid(126, 32).without_gather(),
        GridPoint::grid(126, 64).without_gather(),
        GridPoint::grid(606, 32).without_gather(),
        GridPoint::grid(606, 64).without_gather(),
        GridPoint::preset(QualityArg::Auto, "auto").without_gather(),
    ];
    if grid == GridArg::Full {
        for (l, n) in [(246, 32), (606, 64), (126, 128)] {
            v.push(GridPoint::grid(l, n));
        }
        for (l, n) in [(246, 32), (246, 64), (126, 128), (1126, 64), (606, 128)] {
            v.push(GridPoint::grid(l, n).without_gather());
        }
        for k in [1, 2, 3, 5] {
            let mut p = GridPoint::grid(606, 64).without_gather();
            p.label = format!("l=606 N=64 iterations={k} no-gather");
            p.iterations = Some(IterationsArg::Fixed(k));
            v.push(p);
        }
        for m in [4, 16] {
            let mut p = GridPoint::grid(606, 64).without_gather();
            p.label = format!("l=606 N=64 tile={m} no-gather");
            p.tile = Some(m);
            v.push(p);
        }
        for k in [4, 16] {
            let mut p = GridPoint::grid(126, 64).without_gather();
            p.label = format!("l=126 N=64 perturb={k} no-gather");
            p.perturb = Some(k);
            v.push(p);
        }
    }
    if high {
        v.push(GridPoint::preset(QualityArg::High, "high"));
        v.push(GridPoint::preset(QualityArg::High, "high").without_gather());
    }
    v
}

/// The view both the renderer and the path tracer use.
struct View {
    camera: Option<usize>,
    look: Option<(Vec3, Vec3, f32)>,
}

impl View {
    fn for_light_field(&self, lf: &LightField) -> anyhow::Result<CameraView> {
        if let Some((from, at, fov)) = self.look {
            return Ok(CameraView::look_at(
                lf.to_vlf.apply(from),
                lf.to_vlf.apply(at),
                fov.to_radians(),
            ));
        }
        let i = self.camera.unwrap_or(0);
        let cam = lf.cameras.get(i).with_context(|| {
            format!(
                "the scene has {} camera(s), no camera {i}: give --look-from/--look-at",
                lf.cameras.len()
            )
        })?;
        Ok(CameraView::from_gltf(cam, &lf.to_vlf))
    }

    fn for_path_tracer(
        &self,
        scene: &vlf_core::scene::Scene,
        w: u32,
        h: u32,
    ) -> anyhow::Result<PinholeCamera> {
        Ok(match self.look {
            Some((from, at, fov)) => PinholeCamera::look_at(from, at, fov, w, h)?,
            None => PinholeCamera::from_scene(scene, self.camera.unwrap_or(0), w, h)?,
        })
    }
}

struct Sweep<'a> {
    args: &'a SweepArgs,
    reference: Image,
    rows: Vec<Row>,
    scene_name: String,
    /// Exposure (stops) of the PNG previews: the reference's mean luminance at 0.18.
    exposure: f32,
}

impl Sweep<'_> {
    fn record(&mut self, mut row: Row, image: &Image) -> anyhow::Result<()> {
        let (report, _) = image::compare_images(
            image,
            &self.reference,
            Path::new("render"),
            &self.args.reference,
        )?;
        row.scene = self.scene_name.clone();
        row.rel_mse = report.rel_mse;
        row.flip = report.flip_mean;
        row.mse = report.mse;
        if let Some(dir) = &self.args.images {
            std::fs::create_dir_all(dir)?;
            let name = format!("{}-{}-{}.exr", row.method, row.label, row.spp)
                .replace([' ', '=', '/'], "_");
            image::write_exr(dir.join(&name), image)?;
            image::write_png(
                dir.join(name).with_extension("png"),
                image,
                self.exposure,
                image::Tonemap::Aces,
            )?;
        }
        eprintln!(
            "{:<22} {:<28} time {:>8.2} s  relMSE {:.3e}  FLIP {:.4}",
            row.method, row.label, row.time_s, row.rel_mse, row.flip
        );
        self.rows.push(row);
        let mut text = String::from(HEADER);
        text.push('\n');
        for r in &self.rows {
            writeln!(text, "{}", r.csv()).expect("write to String");
        }
        write_bytes_atomic(&self.args.csv, text.as_bytes())
            .with_context(|| format!("writing {}", self.args.csv.display()))
    }
}

fn render(
    ctx: &GpuContext,
    lf: &LightField,
    view: &View,
    w: u32,
    h: u32,
    spp: u32,
) -> anyhow::Result<(Image, f64)> {
    let cam = view.for_light_field(lf)?;
    let mut renderer = Renderer::new(ctx, lf).context("uploading the light field")?;
    // Warm-up (pipeline compilation, target allocation) outside the timed render.
    renderer.render_still(ctx, &cam, w, h, 1)?;
    let t = Instant::now();
    let pixels = renderer.render_still(ctx, &cam, w, h, spp)?;
    let s = t.elapsed().as_secs_f64();
    Ok((
        Image {
            width: w,
            height: h,
            pixels,
        },
        s,
    ))
}

/// `vlf-bake sweep`.
pub fn sweep_command(args: &SweepArgs, device: DeviceArg, _quiet: bool) -> anyhow::Result<()> {
    let reference = image::read_exr(&args.reference)?;
    let (w, h) = (reference.width, reference.height);
    let mut scene = vlf_core::scene::load(&args.scene)?;
    if args.flat_normals {
        scene.flatten_normals();
    }
    let view = View {
        camera: args.camera,
        look: match (args.look_from, args.look_at) {
            (Some(Point(f)), Some(Point(a))) => Some((f, a, args.fov)),
            _ => None,
        },
    };
    // Check the view before spending time on bakes.
    view.for_path_tracer(&scene, w, h)
        .context("the sweep's viewpoint")?;
    let compute = open_device(device)?;
    // Renders need an adapter even when the bakes run on the CPU.
    let render_ctx;
    let ctx: &GpuContext = match &compute {
        Compute::Gpu(c, _) => c,
        Compute::Cpu(_) => {
            render_ctx = GpuContext::new(&Default::default())
                .context("rendering the bakes needs a GPU adapter (lavapipe will do)")?;
            &render_ctx
        }
    };
    let budget = Budget::new(None, &compute, 1);
    let scene_name = args
        .scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let [r, g, b] = reference.mean();
    let mean = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    let exposure = if mean > 0.0 {
        (0.18 / mean).log2() as f32
    } else {
        0.0
    };
    if let Some(dir) = &args.images {
        std::fs::create_dir_all(dir)?;
        image::write_png(
            dir.join("reference.png"),
            &reference,
            exposure,
            image::Tonemap::Aces,
        )?;
    }
    let mut sweep = Sweep {
        args,
        reference,
        rows: Vec::new(),
        scene_name,
        exposure,
    };
    let sky = args.sky;
    let tmp = tempdir_next_to(&args.csv)?;

    // Path tracer: error against time, 1 … spp_max samples per pixel.
    if args.spp_max > 0 {
        let t = Instant::now();
        let prep = PreparedScene::new(&scene);
        let bvh_s = t.elapsed().as_secs_f64();
        let camera = view.for_path_tracer(&scene, w, h)?;
        let mut spp = 1;
        while spp <= args.spp_max {
            let settings = RenderSettings {
                width: w,
                height: h,
                spp,
                seed: args.seed,
                sky: sky.map_or(Vec3::ZERO, |s| Vec3::from(s.0)),
                threads: 0,
            };
            let t = Instant::now();
            let img = pathtrace::render(&prep, &camera, &settings, &|_, _| {})?;
            let s = t.elapsed().as_secs_f64() + bvh_s;
            let row = Row {
                method: "pathtrace",
                label: format!("{spp} spp"),
                spp,
                time_s: s,
                work_bytes: path_tracer_bytes(&prep) + u64::from(w) * u64::from(h) * 12,
                device: format!("CPU path tracer, {} threads", vlf_core::par::threads(0)),
                ..Default::default()
            };
            sweep.record(row, &img)?;
            spp *= 2;
        }
    }

    // Virtual light field over the grid.
    for (i, p) in plan(args.grid, args.with_high).iter().enumerate() {
        if !args.only.is_empty() && !args.only.contains(&p.label) {
            continue;
        }
        let bake_args = p.args(sky, args.flat_normals);
        let out = tmp.join(format!("bake-{i}.vlf"));
        let report = match bake_scene(
            &args.scene,
            &out,
            &bake_args,
            &compute,
            &budget,
            &mut |_, _, _| {},
        ) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{}: skipped: {e:#}", p.label);
                continue;
            }
        };
        let lf = vlf_core::format::read(&out)?;
        let (img, render_s) = render(ctx, &lf, &view, w, h, args.render_spp)?;
        let _ = std::fs::remove_file(&out);
        let pr = &report.params;
        let row = Row {
            // The light field alone is its own series in the charts.
            method: match p.final_gather {
                OnOff::On => "vlf",
                OnOff::Off => "vlf-no-gather",
            },
            label: p.label.clone(),
            preset: p
                .preset
                .map_or(String::new(), |q| format!("{q:?}").to_lowercase()),
            directions: report.directions as u32,
            resolution: pr.resolution,
            tile: pr.tile,
            texel_scale: pr.texel_scale,
            perturb: pr.perturb,
            iterations_rule: match pr.iterations {
                vlf_core::lightfield::Iterations::Fixed(k) => k.to_string(),
                vlf_core::lightfield::Iterations::Converge { threshold, .. } => {
                    format!("auto:{threshold:e}")
                }
            },
            iterations: report.iterations,
            time_s: report.total_s,
            render_s,
            work_bytes: report.memory.plan.host_bytes + report.memory.plan.device_bytes,
            stored_bytes: report.output_bytes,
            device: report.adapter.clone(),
            ..Default::default()
        };
        sweep.record(row, &img)?;
    }

    if !args.no_radiosity {
        radiosity(&mut sweep, &scene, ctx, &view, (w, h), sky)?;
    }
    let _ = std::fs::remove_dir_all(&tmp);
    eprintln!("{} points → {}", sweep.rows.len(), args.csv.display());
    Ok(())
}

/// The matrix radiosity baseline (diffuse scenes): patches = the atlas texels at ray grids of
/// 32², 64² and 128² (texel = 2×2 rays, as the bakes), form factors from 64 … 16,384 rays per
/// patch,
/// Gauss-Seidel on the CPU; one Jacobi solve on the GPU at 64² and 1,024 rays.
fn radiosity(
    sweep: &mut Sweep,
    scene: &vlf_core::scene::Scene,
    ctx: &GpuContext,
    view: &View,
    (w, h): (u32, u32),
    sky: Option<Rgb>,
) -> anyhow::Result<()> {
    use vlf_core::radiosity::{self, RadiosityError, RadiositySettings};
    let mut points: Vec<(u32, u32, bool)> = Vec::new();
    for n in [32, 64] {
        for rays in [64, 256, 1024, 4096] {
            points.push((n, rays, false));
        }
    }
    points.extend([(64, 16384, false), (128, 1024, false), (128, 4096, false)]);
    points.push((64, 1024, true));
    for (n, rays, gpu) in points {
        // The atlas of `vlf-bake bake --resolution N` on this scene: same patches as the bakes.
        let point = GridPoint {
            resolution: Some(n),
            ..GridPoint::preset(QualityArg::Auto, "radiosity")
        };
        let (params, _) = resolve_params(&point.args(sky, false), scene)?;
        let settings = RadiositySettings {
            rays_per_patch: rays,
            threshold: 1e-4,
            ..Default::default()
        };
        let result = if gpu {
            vlf_gpu::radiosity::bake(ctx, scene, &params, &settings).map_err(anyhow::Error::from)
        } else {
            radiosity::bake(scene, &params, &settings).map_err(anyhow::Error::from)
        };
        let (lf, report) = match result {
            Ok(r) => r,
            Err(e) => {
                if e.chain().any(|c| {
                    c.downcast_ref::<RadiosityError>()
                        .is_some_and(|e| matches!(e, RadiosityError::NonDiffuse { .. }))
                }) {
                    eprintln!("radiosity: not run ({e:#})");
                    return Ok(());
                }
                return Err(e.context("radiosity baseline"));
            }
        };
        let stored = vlf_core::format::to_bytes(
            &lf,
            vlf_core::lightfield::DEFAULT_ENCODING,
            Path::new("radiosity"),
        )?
        .len() as u64;
        let (img, render_s) = render(ctx, &lf, view, w, h, sweep.args.render_spp)?;
        let row = Row {
            method: if gpu {
                "radiosity_jacobi_gpu"
            } else {
                "radiosity_gs"
            },
            label: format!("N={n} rays={rays}"),
            resolution: n,
            texel_scale: params.texel_scale,
            tile: params.tile,
            iterations_rule: format!("residual:{:e}", settings.threshold),
            iterations: report.iterations,
            rays_per_patch: rays,
            time_s: report.form_factor_seconds + report.solve_seconds,
            render_s,
            work_bytes: report.memory_bytes as u64,
            stored_bytes: stored,
            device: if gpu {
                format!("form factors on the CPU, Jacobi on {}", ctx.summary)
            } else {
                "CPU".into()
            },
            ..Default::default()
        };
        sweep.record(row, &img)?;
    }
    Ok(())
}

/// A fresh scratch directory next to `csv` for the bakes' files.
fn tempdir_next_to(csv: &Path) -> anyhow::Result<PathBuf> {
    let dir = match csv.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = dir.join(format!(".sweep.tmp.{}", std::process::id()));
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    Ok(tmp)
}

/// Bytes of the path tracer's scene: BVH nodes (with their SIMD copy) and triangles.
fn path_tracer_bytes(prep: &PreparedScene) -> u64 {
    (std::mem::size_of_val(prep.bvh.nodes()) * 3
        + std::mem::size_of_val(prep.bvh.triangles.as_slice())
        + std::mem::size_of_val(prep.uvs.as_slice())) as u64
}
