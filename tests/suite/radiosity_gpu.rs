//! The GPU radiosity solver (`vlf_gpu::radiosity`) against its specification, the CPU Jacobi
//! solver of `vlf_core::radiosity`, on the diffuse Cornell box.

use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::radiosity::{self, FormFactors, RadiositySettings};
use vlf_tests::bakes;
use vlf_tests::{gpu, shared_dir};

fn cornell_form_factors(rays: u32) -> (BakeParams, FormFactors) {
    let scene =
        vlf_core::scene::load(&shared_dir().join("scenes/cornell-box/cornell.gltf")).unwrap();
    let params = BakeParams {
        texel_scale: 2.0,
        ..bakes::params(46, 32, Iterations::Fixed(3))
    };
    let prep = BakeScene::new(&scene, &params).unwrap();
    let settings = RadiositySettings {
        rays_per_patch: rays,
        ..Default::default()
    };
    let ff = radiosity::form_factors(&prep, params.sky, &settings).unwrap();
    (params, ff)
}

/// Largest per-texel difference relative to the largest radiance (max norm).
fn max_rel(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let scale = a
        .iter()
        .map(|x| Vec4::from(*x).truncate().max_element())
        .fold(0f32, f32::max);
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            (Vec4::from(*x).truncate() - Vec4::from(*y).truncate())
                .abs()
                .max_element()
        })
        .fold(0f32, f32::max)
        / scale
}

/// Same sweeps, same residuals, same stopping sweep, same radiance up to float rounding (the GPU
/// may fuse multiply-adds and round its division differently; nothing else differs).
#[test]
fn gpu_jacobi_matches_cpu_jacobi() {
    let Some(ctx) = gpu() else {
        return;
    };
    let (_, ff) = cornell_form_factors(128);
    let settings = RadiositySettings {
        threshold: 1e-5,
        ..Default::default()
    };
    let cpu = radiosity::solve_jacobi(&ff, &settings, None);
    let gpu = vlf_gpu::radiosity::solve_jacobi(ctx, &ff, &settings, None).unwrap();
    let d = max_rel(&cpu.radiance, &gpu.radiance);
    eprintln!(
        "CPU Jacobi {} sweeps, GPU Jacobi {} sweeps; max relative difference {d:.2e}",
        cpu.iterations, gpu.iterations
    );
    assert!(cpu.converged && gpu.converged);
    assert_eq!(cpu.iterations, gpu.iterations);
    assert_eq!(cpu.residual_history.len(), gpu.residual_history.len());
    for (k, (a, b)) in cpu
        .residual_history
        .iter()
        .zip(&gpu.residual_history)
        .enumerate()
    {
        assert!(
            (a - b).abs() <= 1e-3 * a.abs() + 1e-9,
            "sweep {}: residual CPU {a:e} GPU {b:e}",
            k + 1
        );
    }
    assert!(d < 1e-5, "max relative difference {d:e}");
    // Uncovered texels stay black on both.
    for (t, l) in gpu.radiance.iter().enumerate() {
        if !ff.patch_texel.contains(&(t as u32)) {
            assert_eq!(*l, [0.0; 4]);
        }
    }
}

/// With a callback the GPU solver reads the radiance back after every sweep; the snapshots
/// equal the CPU's sweep by sweep, and a fixed sweep count (threshold 0) is honoured exactly.
#[test]
fn gpu_jacobi_snapshots_match_cpu_sweep_by_sweep() {
    let Some(ctx) = gpu() else {
        return;
    };
    let (_, ff) = cornell_form_factors(64);
    let settings = RadiositySettings {
        max_iterations: 5,
        threshold: 0.0,
        ..Default::default()
    };
    let mut cpu_snaps = Vec::new();
    let mut gpu_snaps = Vec::new();
    let cpu = radiosity::solve_jacobi(
        &ff,
        &settings,
        Some(&mut |k, l: &[[f32; 4]]| cpu_snaps.push((k, l.to_vec()))),
    );
    let gpu = vlf_gpu::radiosity::solve_jacobi(
        ctx,
        &ff,
        &settings,
        Some(&mut |k, l: &[[f32; 4]]| gpu_snaps.push((k, l.to_vec()))),
    )
    .unwrap();
    assert_eq!(cpu.iterations, 5);
    assert_eq!(gpu.iterations, 5);
    assert!(!gpu.converged);
    assert_eq!(cpu_snaps.len(), 5);
    assert_eq!(gpu_snaps.len(), 5);
    for ((kc, lc), (kg, lg)) in cpu_snaps.iter().zip(&gpu_snaps) {
        assert_eq!(kc, kg);
        let d = max_rel(lc, lg);
        assert!(d < 1e-5, "sweep {kc}: {d:e}");
    }
    assert_eq!(gpu_snaps.last().unwrap().1, gpu.radiance);
    // More sweeps than one batch without a callback, stopping on the count.
    let long = RadiositySettings {
        max_iterations: 37,
        threshold: 0.0,
        ..settings
    };
    let gpu = vlf_gpu::radiosity::solve_jacobi(ctx, &ff, &long, None).unwrap();
    let cpu = radiosity::solve_jacobi(&ff, &long, None);
    assert_eq!(gpu.iterations, 37);
    assert!(max_rel(&cpu.radiance, &gpu.radiance) < 1e-5);
}

/// A closed furnace box solved on the GPU reaches L = E / (1 − ρ), and the GPU bake assembles
/// a light field with a report.
#[test]
fn gpu_radiosity_furnace_and_bake() {
    let Some(ctx) = gpu() else {
        return;
    };
    let (le, rho) = (Vec3::new(1.0, 0.5, 0.25), 0.7);
    let mut b = vlf_core::scene::SceneBuilder::new();
    let m = b.diffuse("furnace", Vec3::splat(rho), le);
    b.aabox(Vec3::splat(-1.0), Vec3::new(1.0, 0.6, 0.5), true, m);
    let scene = b.build("furnace");
    let params = BakeParams {
        directions: 46,
        resolution: 16,
        tile: 8,
        texel_scale: 2.0,
        ..BakeParams::paper()
    };
    let settings = RadiositySettings {
        rays_per_patch: 32,
        threshold: 1e-6,
        ..Default::default()
    };
    let prep = BakeScene::new(&scene, &params).unwrap();
    let ff = radiosity::form_factors(&prep, params.sky, &settings).unwrap();
    let sol = vlf_gpu::radiosity::solve_jacobi(ctx, &ff, &settings, None).unwrap();
    assert!(sol.converged);
    let want = le / (1.0 - rho);
    let inside = ff
        .patch_texel
        .iter()
        .filter(|&&t| Vec4::from(ff.emission[ff.patch_texel.binary_search(&t).unwrap()]).x > 0.0);
    let mut count = 0;
    for &t in inside {
        let l = Vec4::from(sol.radiance[t as usize]).truncate();
        assert!(
            ((l - want).abs() / want).max_element() < 1e-4,
            "{l} vs {want}"
        );
        count += 1;
    }
    assert!(count * 2 == ff.patches(), "{count} of {}", ff.patches());

    let (lf, report) = vlf_gpu::radiosity::bake(ctx, &scene, &params, &settings).unwrap();
    assert_eq!(report.solver, "jacobi (gpu)");
    assert!(report.converged && report.patches == ff.patches());
    assert_eq!(lf.stats.device, "gpu");
}
