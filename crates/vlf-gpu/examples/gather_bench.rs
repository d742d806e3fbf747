//! Final-gather benchmark: the CPU gather (`vlf_core::gather`, all cores) against the GPU gather
//! (`vlf_gpu::gather`) on one propagated field, with the difference between their atlases.
//!
//! `cargo run --release -p vlf-gpu --example gather_bench -- [SCENE.gltf] [--resolution N]`
//!
//! Default: the Cornell box with the parameters `vlf-bake bake` picks for it by default
//! (`bake::refine` at `--quality auto`: resolution, directions, gather settings), propagated on
//! the GPU (4 iterations; `--resolution N` overrides). Prints wall time and the process's CPU
//! time (user + system, from /proc/self/stat, lavapipe's worker threads included: on a loaded
//! machine the fairer figure) of each gather; `GATHER_BENCH_ROUNDS=n` alternates n GPU and n
//! CPU gathers.

use std::time::Instant;

use glam::Vec4;
use vlf_core::bake::{BakeScene, Quality};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::final_gather;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_gpu::gather::{self, GatherPipelines};
use vlf_gpu::{DeviceOptions, GpuContext};

/// CPU seconds (user + system) of this process so far.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command's closing parenthesis: utime and stime are the 12th and 13th.
    let rest = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(2)
        .map(|x| x.parse().unwrap_or(0.0))
        .collect();
    f.iter().sum::<f64>() / 100.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut path = "assets/cornell-box/cornell-box.gltf".to_string();
    let mut resolution = None;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--resolution" => {
                resolution = Some(args[i + 1].parse()?);
                i += 1;
            }
            p => path = p.to_string(),
        }
        i += 1;
    }
    let scene = vlf_core::scene::load(std::path::Path::new(&path))?;
    let auto = vlf_core::bake::refine::refine(&scene, Quality::Auto, true).params;
    let mut gp = auto.final_gather.expect("the default bake gathers");
    if let Ok(v) = std::env::var("GATHER_BENCH_GP") {
        // texel scale, indirect texel scale, light samples, direct rays, indirect rays
        let f: Vec<f32> = v.split(',').map(|x| x.parse().unwrap()).collect();
        gp.texel_scale = f[0];
        gp.indirect_texel_scale = f[1];
        gp.light_samples = f[2] as u32;
        gp.direct_rays = f[3] as u32;
        gp.indirect_rays = f[4] as u32;
    }
    let params = BakeParams {
        resolution: resolution.unwrap_or(auto.resolution),
        iterations: Iterations::Fixed(4),
        final_gather: Some(gp),
        ..auto
    };
    println!(
        "{path}: resolution {}, {} directions, gather {gp:?}",
        params.resolution, params.directions
    );
    let ctx = GpuContext::new(&DeviceOptions::default())?;
    println!("adapter: {}", ctx.summary);
    let prep = BakeScene::new(&scene, &params)?;
    let set = DirectionSet::at_least(params.directions)?;
    let out = vlf_gpu::bake::propagate(&ctx, &prep, &set, &params, &mut |_| {})?;
    let field = vlf_core::pipeline::converged(&prep, &params, &set, &out);

    let (t, c) = (Instant::now(), cpu_seconds());
    let pipelines = GatherPipelines::of(&ctx);
    println!(
        "GPU gather pipelines: {:.2} s wall, {:.2} s CPU",
        t.elapsed().as_secs_f64(),
        cpu_seconds() - c
    );
    let run_gpu = || -> Result<_, Box<dyn std::error::Error>> {
        let (t, c) = (Instant::now(), cpu_seconds());
        let g = gather::final_gather(&ctx, &pipelines, &scene, &field, &gp)?;
        println!(
            "GPU gather: {:.2} s wall, {:.2} s CPU ({} texels, {} indirect)",
            t.elapsed().as_secs_f64(),
            cpu_seconds() - c,
            g.stats.texels,
            g.stats.indirect_texels
        );
        Ok(g)
    };
    let run_cpu = || -> Result<_, Box<dyn std::error::Error>> {
        let (t, c) = (Instant::now(), cpu_seconds());
        let g = final_gather(&scene, &field, &gp, 0)?;
        println!(
            "CPU gather: {:.2} s wall, {:.2} s CPU ({} threads)",
            t.elapsed().as_secs_f64(),
            cpu_seconds() - c,
            std::thread::available_parallelism().map_or(1, |n| n.get())
        );
        Ok(g)
    };
    let rounds: usize = std::env::var("GATHER_BENCH_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let (mut gpu, mut cpu) = (run_gpu()?, run_cpu()?);
    for _ in 1..rounds {
        gpu = run_gpu()?;
        cpu = run_cpu()?;
    }
    println!("CPU stats: {:?}", cpu.stats);
    println!("GPU stats: {:?}", gpu.stats);
    let (mut diff, mut total, mut beyond, mut covered) = (0.0f64, 0.0f64, 0usize, 0usize);
    for (t, (a, b)) in cpu.irradiance.iter().zip(&gpu.irradiance).enumerate() {
        if cpu.atlas.texel_area[t] <= 0.0 {
            continue;
        }
        let (a, b) = (Vec4::from(*a), Vec4::from(*b));
        let d = f64::from((a - b).abs().element_sum());
        let s = f64::from(a.abs().element_sum());
        diff += d;
        total += s;
        covered += 1;
        if d > 1e-3 * s.max(1e-6) {
            if beyond < 12 {
                println!(
                    "texel {t}: cpu {a:?} gpu {b:?} at {:?}",
                    cpu.atlas.texel_center[t]
                );
            }
            beyond += 1;
        }
    }
    println!(
        "GPU vs CPU: mean relative difference {:.3e}, texels beyond 1e-3: {} of {covered}",
        diff / total.max(1e-30),
        beyond
    );
    Ok(())
}
