//! Times the radiosity solvers on one scene: Gauss–Seidel and Jacobi on the CPU, Jacobi on the
//! GPU (to the default threshold, and a fixed 200 sweeps for the per-sweep cost), and checks that
//! the GPU and CPU Jacobi solutions agree. Prints one line per measurement.
//!
//! `cargo run --release -p vlf-gpu --example radiosity_gpu -- [SCENE] [RAYS]` (defaults: the
//! shared Cornell box at the `--quality auto` parameters, 1024 rays).

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec4;
use vlf_core::bake::{self, BakeScene, Quality};
use vlf_core::radiosity::{self, RadiositySettings};
use vlf_gpu::{DeviceOptions, GpuContext};

fn max_rel(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let scale = a
        .iter()
        .map(|x| Vec4::from(*x).truncate().max_element())
        .fold(0f32, f32::max);
    a.iter()
        .zip(b)
        .map(|(x, y)| (Vec4::from(*x) - Vec4::from(*y)).abs().max_element())
        .fold(0f32, f32::max)
        / scale
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().map_or_else(
        || {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared/scenes/cornell-box/cornell.gltf")
        },
        PathBuf::from,
    );
    let rays: u32 = args.get(1).map_or(1024, |s| s.parse().expect("RAYS"));
    let ctx = GpuContext::new(&DeviceOptions::default()).expect("GPU");
    println!("adapter: {}", ctx.summary);
    let scene = vlf_core::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let params = bake::refine::refine(&scene, Quality::Auto, false).params;
    let prep = BakeScene::new(&scene, &params).expect("params");
    let settings = RadiositySettings {
        rays_per_patch: rays,
        ..Default::default()
    };
    let t = Instant::now();
    let ff = radiosity::form_factors(&prep, params.sky, &settings).expect("form factors");
    println!(
        "form factors: {} patches, {} nonzeros, {:.1} MiB, {rays} rays/patch, {:.2} s ({} threads)",
        ff.patches(),
        ff.nonzeros(),
        ff.memory_bytes() as f64 / 1048576.0,
        t.elapsed().as_secs_f64(),
        settings.worker_threads()
    );
    let time = |name: &str, f: &mut dyn FnMut() -> radiosity::Solution| {
        let t = Instant::now();
        let s = f();
        let secs = t.elapsed().as_secs_f64();
        println!(
            "{name}: {} sweeps, {:.4} s ({:.3} ms/sweep), final residual {:.2e}",
            s.iterations,
            secs,
            1e3 * secs / f64::from(s.iterations.max(1)),
            s.residual_history.last().copied().unwrap_or(0.0)
        );
        s
    };
    let gs = time("Gauss-Seidel CPU (1 thread)", &mut || {
        radiosity::solve_gauss_seidel(&ff, &settings, None)
    });
    let jc = time("Jacobi CPU", &mut || {
        radiosity::solve_jacobi(&ff, &settings, None)
    });
    // Warm-up (pipeline compilation), then the timed run.
    vlf_gpu::radiosity::solve_jacobi(&ctx, &ff, &settings, None).expect("GPU");
    let jg = time("Jacobi GPU", &mut || {
        vlf_gpu::radiosity::solve_jacobi(&ctx, &ff, &settings, None).expect("GPU")
    });
    let fixed = RadiositySettings {
        max_iterations: 200,
        threshold: 0.0,
        ..settings.clone()
    };
    time("Jacobi CPU, 200 sweeps", &mut || {
        radiosity::solve_jacobi(&ff, &fixed, None)
    });
    time("Jacobi GPU, 200 sweeps", &mut || {
        vlf_gpu::radiosity::solve_jacobi(&ctx, &ff, &fixed, None).expect("GPU")
    });
    println!(
        "GPU vs CPU Jacobi: max relative difference {:.2e}; GS vs Jacobi {:.2e}",
        max_rel(&jc.radiance, &jg.radiance),
        max_rel(&jc.radiance, &gs.radiance)
    );
}
