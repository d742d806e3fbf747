//! Ray throughput of the GPU ray engine against the CPU BVH, and the GPU path tracer's kernels.
//!
//!     cargo run --release -p vlf-gpu --example rays_bench -- [SCENE.gltf|glb ...] [--spp N]
//!
//! For each scene (default: the shared Cornell box): closest-hit rays/s for coherent primary
//! rays (a 512×512 camera grid in 8×8-pixel tiles) and for incoherent rays (from uniformly
//! chosen surface points in cosine-distributed directions, like diffuse bounces), any-hit rays/s
//! for shadow rays between random surface points; the same ray sets traced by the CPU BVH on all
//! cores; then a 256×256 path-traced image on the CPU, the GPU wavefront and the GPU megakernel.
//! GPU times are wall-clock around submit + wait of repeated dispatches (upload and readback
//! excluded), the way the Ray Engine paper counts rays/s (rays intersected with the whole scene).
//!
//! On a software adapter (lavapipe) both sides run on the CPU, and on a shared machine wall time
//! depends on the load; each figure is therefore also given per CPU-second of this process
//! (utime + stime from `/proc/self/stat`, all threads, lavapipe's workers included) scaled by
//! the number of cores: `rays / (CPU seconds / cores)` = the rate on an otherwise idle machine.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use vlf_core::pathtrace::{
    PinholeCamera, PreparedScene, Ray, RenderSettings, Rng, render, sampling,
};
use vlf_gpu::raytrace::{GpuPathTracer, GpuRenderOptions, GpuScene, Kernel, Query, RayBatch};
use vlf_gpu::{DeviceOptions, GpuContext};

/// Camera 0, or for the shared scenes without one the viewpoint their README suggests, or the
/// centre of the bounds looking down −Z.
fn camera(scene: &vlf_core::scene::Scene, w: u32, h: u32) -> PinholeCamera {
    if let Ok(cam) = PinholeCamera::from_scene(scene, 0, w, h) {
        return cam;
    }
    let name = scene
        .source
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (from, at, fov) = match name.as_str() {
        "VolumetricFogExample.glb" => (Vec3::new(2.8, 3.0, 0.0), Vec3::new(-3.0, 1.0, 0.0), 75.0),
        "cornellBox-2.80-Eevee-gltf.gltf" => {
            (Vec3::new(0.0, 1.5, 6.5), Vec3::new(0.0, 1.4, 0.0), 40.0)
        }
        "DepthOfFieldExample.glb" => (Vec3::new(0.0, 1.6, 4.6), Vec3::new(0.0, 0.4, 0.0), 50.0),
        "room.glb" => (Vec3::new(4.5, 2.5, 4.5), Vec3::new(0.0, 1.5, 0.0), 70.0),
        _ => {
            let c = scene.bounds.center();
            (c, c - Vec3::Z, 70.0)
        }
    };
    PinholeCamera::look_at(from, at, fov, w, h).expect("look-at camera")
}

fn primary_rays(cam: &PinholeCamera, w: u32, h: u32) -> Vec<Ray> {
    let mut rays = Vec::with_capacity((w * h) as usize);
    for ty in 0..h / 8 {
        for tx in 0..w / 8 {
            for i in 0..64 {
                let (x, y) = (tx * 8 + i % 8, ty * 8 + i / 8);
                let d = cam.direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                rays.push(Ray::new(cam.position, d, f32::INFINITY));
            }
        }
    }
    rays
}

/// (point, normal) uniformly by area over the scene's surfaces.
fn surface_points(prep: &PreparedScene, n: usize, rng: &mut Rng) -> Vec<(Vec3, Vec3)> {
    let tris = &prep.bvh.triangles;
    let mut cdf = Vec::with_capacity(tris.len());
    let mut acc = 0.0f64;
    for t in tris {
        let [a, b, c] = t.corners();
        acc += f64::from((b - a).cross(c - a).length());
        cdf.push(acc);
    }
    (0..n)
        .map(|_| {
            let u = f64::from(rng.next_f32()) * acc;
            let i = cdf.partition_point(|&x| x <= u).min(tris.len() - 1);
            let [a, b, c] = tris[i].corners();
            let bary = sampling::triangle_barycentrics(rng.next_2d());
            let p = a * (1.0 - bary.x - bary.y) + b * bary.x + c * bary.y;
            let mut nrm = (b - a).cross(c - a).normalize();
            if rng.next_f32() < 0.5 {
                nrm = -nrm;
            }
            (p, nrm)
        })
        .collect()
}

fn incoherent_rays(prep: &PreparedScene, n: usize) -> Vec<Ray> {
    let mut rng = Rng::for_path(7, 0, 0);
    surface_points(prep, n, &mut rng)
        .into_iter()
        .map(|(p, nrm)| {
            let d = sampling::to_world(sampling::cosine_hemisphere(rng.next_2d()), nrm);
            let o = vlf_core::pathtrace::geometry::offset_ray_origin(p, nrm);
            Ray::new(o, d, f32::INFINITY)
        })
        .collect()
}

fn shadow_rays(prep: &PreparedScene, n: usize) -> Vec<Ray> {
    let mut rng = Rng::for_path(8, 0, 0);
    let a = surface_points(prep, n, &mut rng);
    let b = surface_points(prep, n, &mut rng);
    a.iter()
        .zip(&b)
        .map(|((p, _), (q, _))| Ray::new(*p, *q - *p, 0.999))
        .collect()
}

/// Wall time and process CPU time of `f`.
struct Timing {
    wall: f64,
    cpu: f64,
}

fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    let rest = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    (f[11].parse::<f64>().unwrap_or(0.0) + f[12].parse::<f64>().unwrap_or(0.0)) / 100.0
}

fn timed(f: impl FnOnce()) -> Timing {
    let (c, t) = (process_cpu_seconds(), Instant::now());
    f();
    Timing {
        wall: t.elapsed().as_secs_f64(),
        cpu: process_cpu_seconds() - c,
    }
}

fn cores() -> f64 {
    std::thread::available_parallelism().map_or(1, |n| n.get()) as f64
}

/// "X M rays/s (idle-machine equivalent Y M rays/s)".
fn rate(rays: f64, t: &Timing) -> String {
    let idle = if t.cpu > 0.0 {
        rays / (t.cpu / cores())
    } else {
        f64::NAN
    };
    format!(
        "{:6.2} M rays/s wall, {:6.2} M/s per {} CPU-s",
        rays / t.wall / 1e6,
        idle / 1e6,
        cores()
    )
}

fn cpu_rays(prep: &PreparedScene, rays: &[Ray], any: bool) -> (f64, Timing) {
    let threads = cores() as usize;
    // Enough repetitions for about two seconds (CPU time is counted in 10 ms ticks).
    let probe = timed(|| {
        for r in rays.iter().take(20_000) {
            std::hint::black_box(prep.bvh.closest_hit(r));
        }
    });
    let per_ray = probe.wall.max(1e-4) / rays.len().min(20_000) as f64 / threads as f64;
    let reps = ((2.0 / (per_ray * rays.len() as f64)) as usize).clamp(1, 200);
    let t = timed(|| {
        for _ in 0..reps {
            std::thread::scope(|s| {
                for chunk in rays.chunks(rays.len().div_ceil(threads)) {
                    s.spawn(move || {
                        let mut hits = 0u32;
                        for r in chunk {
                            let h = if any {
                                prep.bvh.occluded(r)
                            } else {
                                prep.bvh.closest_hit(r).is_hit()
                            };
                            hits += u32::from(h);
                        }
                        std::hint::black_box(hits);
                    });
                }
            });
        }
    });
    ((reps * rays.len()) as f64, t)
}

fn gpu_rays(
    ctx: &GpuContext,
    tracer: &GpuPathTracer,
    scene: &GpuScene,
    rays: &[Ray],
    query: Query,
) -> (f64, Timing) {
    let engine = tracer.engine();
    let batch = RayBatch::new(ctx, engine, scene, rays).expect("upload");
    // Warm-up (pipeline compilation on first use).
    batch.run(ctx, engine, query, 1);
    ctx.wait_idle();
    let probe = timed(|| {
        batch.run(ctx, engine, query, 1);
        ctx.wait_idle();
    });
    let reps = ((2.0 / probe.wall.max(1e-4)) as u32).clamp(1, 200);
    let t = timed(|| {
        batch.run(ctx, engine, query, reps);
        ctx.wait_idle();
    });
    ((reps as usize * batch.len()) as f64, t)
}

fn main() {
    let mut scenes = Vec::new();
    let mut spp = 16;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--spp" {
            spp = args.next().and_then(|s| s.parse().ok()).expect("--spp N");
        } else {
            scenes.push(PathBuf::from(a));
        }
    }
    if scenes.is_empty() {
        scenes.push(
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared/scenes/cornell-box/cornell.gltf"),
        );
    }
    let ctx = GpuContext::new(&DeviceOptions::default()).expect("GPU adapter");
    println!("adapter: {}", ctx.summary);
    println!(
        "CPU threads: {}",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    let tracer = GpuPathTracer::new(&ctx.device);
    for path in scenes {
        let scene = vlf_core::scene::load(&path).expect("scene");
        let t = Instant::now();
        let prep = PreparedScene::new(&scene);
        println!(
            "\n{}: {} triangles, BVH {} nodes built in {:.1} ms",
            path.display(),
            scene.triangles.len(),
            prep.bvh.nodes().len(),
            t.elapsed().as_secs_f64() * 1e3
        );
        let gpu_scene = GpuScene::upload(&ctx.device, &prep).expect("upload");
        let cam = camera(&scene, 512, 512);
        let sets = [
            (
                "primary (coherent, 8×8 tiles)",
                primary_rays(&cam, 512, 512),
                Query::Closest,
            ),
            (
                "incoherent (diffuse bounces)",
                incoherent_rays(&prep, 1 << 18),
                Query::Closest,
            ),
            (
                "shadow (any hit, random pairs)",
                shadow_rays(&prep, 1 << 18),
                Query::Any,
            ),
        ];
        for (name, rays, query) in &sets {
            let any = *query == Query::Any;
            let (n, t) = gpu_rays(&ctx, &tracer, &gpu_scene, rays, *query);
            println!("  {name:32} {:>7} rays  GPU {}", rays.len(), rate(n, &t));
            let (n, t) = cpu_rays(&prep, rays, any);
            println!("  {name:32} {:>7} rays  CPU {}", rays.len(), rate(n, &t));
        }
        let settings = RenderSettings {
            width: 256,
            height: 256,
            spp,
            seed: 1,
            sky: Vec3::splat(if scene.has_emitters() || !scene.suns.is_empty() {
                0.0
            } else {
                1.0
            }),
            threads: 0,
        };
        let cam = camera(&scene, 256, 256);
        let mut cpu_img = None;
        let t = timed(|| {
            cpu_img = Some(render(&prep, &cam, &settings, &|_, _| {}).expect("CPU render"))
        });
        let cpu_img = cpu_img.expect("rendered");
        println!(
            "  path tracing 256×256 at {spp} spp: CPU {:.2} s wall, {:.2} CPU-s",
            t.wall, t.cpu
        );
        for kernel in [Kernel::Wavefront, Kernel::Megakernel] {
            let options = GpuRenderOptions {
                kernel,
                ..Default::default()
            };
            let mut out = None;
            let t = timed(|| {
                out = Some(
                    tracer
                        .render(&ctx, &prep, &cam, &settings, &options, &|_, _| {})
                        .expect("GPU render"),
                )
            });
            let (img, stats) = out.expect("rendered");
            let rays = (stats.extension_rays + stats.shadow_rays) as f64;
            let rays = if rays > 0.0 {
                format!(", {}", rate(rays, &t))
            } else {
                String::new()
            };
            println!(
                "  path tracing 256×256 at {spp} spp: GPU {kernel:?} {:.2} s wall, {:.2} CPU-s ({} waves{rays}), relMSE vs CPU {:.1e}",
                t.wall,
                t.cpu,
                stats.waves,
                vlf_core::image::rel_mse(&img, &cpu_img)
            );
        }
    }
}
