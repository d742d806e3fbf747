//! Iterations-vs-error curves of the matrix radiosity solvers (issue #8): CSV on stdout of
//! `iteration, gauss_seidel, jacobi`, each the relative L2 error of the sweep's radiance against
//! the converged solution (Gauss–Seidel in f64 until it stops changing), over patches and
//! channels. The curves flatten at f32 rounding (~1e-7).
//! A summary (patches, non-zeros, timings, iteration counts) goes to stderr.
//!
//! `cargo run --release -p vlf-core --example radiosity_curve -- [SCENE] [RAYS] [SWEEPS] [--vs-vlf]`
//! (defaults: the shared Cornell box at the `--quality auto` parameters, 1024 rays, 40 sweeps).
//! `--vs-vlf` also bakes the scene with the VLF CPU reference at the same parameters and prints
//! the mean relative difference over covered texels.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec4;
use vlf_core::bake::{self, BakeScene, Quality};
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::radiosity::{self, RadiositySettings};

fn rel_l2(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let (mut num, mut den) = (0f64, 0f64);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            num += f64::from(x[c] - y[c]).powi(2);
            den += f64::from(y[c]).powi(2);
        }
    }
    (num / den.max(1e-300)).sqrt()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let vs_vlf = args.iter().any(|a| a == "--vs-vlf");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let path = pos.first().map_or_else(
        || {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared/scenes/cornell-box/cornell.gltf")
        },
        PathBuf::from,
    );
    let rays: u32 = pos.get(1).map_or(1024, |s| s.parse().expect("RAYS"));
    let sweeps: u32 = pos.get(2).map_or(40, |s| s.parse().expect("SWEEPS"));

    let scene = vlf_core::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let params = bake::refine::refine(&scene, Quality::Auto, false).params;
    let prep = BakeScene::new(&scene, &params).expect("params");
    let settings = RadiositySettings {
        rays_per_patch: rays,
        max_iterations: sweeps,
        threshold: 0.0,
        ..Default::default()
    };
    let t = Instant::now();
    let ff = radiosity::form_factors(&prep, params.sky, &settings).expect("form factors");
    let ff_s = t.elapsed().as_secs_f64();

    let converged = converged_f64(&ff);
    let mut gs = Vec::new();
    let mut jac = Vec::new();
    let t = Instant::now();
    radiosity::solve_gauss_seidel(
        &ff,
        &settings,
        Some(&mut |_, l: &[[f32; 4]]| gs.push(rel_l2(l, &converged))),
    );
    let gs_fixed_s = t.elapsed().as_secs_f64();
    radiosity::solve_jacobi(
        &ff,
        &settings,
        Some(&mut |_, l: &[[f32; 4]]| jac.push(rel_l2(l, &converged))),
    );
    println!("iteration,gauss_seidel,jacobi");
    let l0 = ff.scatter(&ff.source);
    println!(
        "0,{:.6e},{:.6e}",
        rel_l2(&l0, &converged),
        rel_l2(&l0, &converged)
    );
    for k in 0..sweeps as usize {
        println!("{},{:.6e},{:.6e}", k + 1, gs[k], jac[k]);
    }

    // Iterations and times to the default threshold.
    let run = RadiositySettings {
        rays_per_patch: rays,
        ..Default::default()
    };
    let t = Instant::now();
    let g = radiosity::solve_gauss_seidel(&ff, &run, None);
    let g_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let j = radiosity::solve_jacobi(&ff, &run, None);
    let j_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let j1 = radiosity::solve_jacobi(
        &ff,
        &RadiositySettings {
            threads: 1,
            ..run.clone()
        },
        None,
    );
    let j1_s = t.elapsed().as_secs_f64();
    assert_eq!(
        j1.radiance, j.radiance,
        "Jacobi depends on the thread count"
    );
    eprintln!(
        "{}: params N={} texel_scale={} directions={}; patches {} of {} texels, nonzeros {} ({:.1} per row), {:.1} MiB; lost rays {}",
        path.display(),
        params.resolution,
        params.texel_scale,
        params.directions,
        ff.patches(),
        ff.texel_count,
        ff.nonzeros(),
        ff.nonzeros() as f64 / ff.patches() as f64,
        ff.memory_bytes() as f64 / 1048576.0,
        ff.lost_rays
    );
    eprintln!(
        "form factors: {rays} rays/patch, {ff_s:.2} s on {} threads",
        run.worker_threads()
    );
    eprintln!("{sweeps} Gauss–Seidel sweeps with snapshots: {gs_fixed_s:.3} s");
    eprintln!(
        "to residual {:e}: Gauss–Seidel {} sweeps {g_s:.3} s; Jacobi {} sweeps {j_s:.3} s ({} threads), {j1_s:.3} s (1 thread); GS vs Jacobi rel. L2 {:.2e}",
        run.threshold,
        g.iterations,
        j.iterations,
        run.worker_threads(),
        rel_l2(&g.radiance, &j.radiance)
    );

    if vs_vlf {
        let params = BakeParams {
            iterations: Iterations::Converge {
                threshold: 1e-4,
                max: 200,
            },
            ..params
        };
        let t = Instant::now();
        let set = vlf_core::directions::DirectionSet::at_least(params.directions).unwrap();
        let vlf = bake::reference::propagate(&prep, &set, &params);
        let vlf_s = t.elapsed().as_secs_f64();
        let vlf_radiance = prep.outgoing_radiance(&vlf.irradiance);
        // A second seed: the radiosity's own noise.
        let seed2 = RadiositySettings {
            seed: 7,
            ..run.clone()
        };
        let ff2 = radiosity::form_factors(&prep, params.sky, &seed2).expect("form factors");
        let g2 = radiosity::solve_gauss_seidel(&ff2, &seed2, None);
        let (mut room, mut blocks) = (0f32, 0f32);
        for (fi, f) in prep.faces.iter().enumerate() {
            // Front sides (the sides that face the room).
            let base = f.texel_base as usize;
            let (mut fa, mut fb, mut area) = (Vec4::ZERO, Vec4::ZERO, 0f32);
            for t in base..base + f.texels_per_side() as usize {
                let a = prep.texel_area[t];
                fa += Vec4::from(g.radiance[t]) * a;
                fb += Vec4::from(vlf_radiance[t]) * a;
                area += a;
            }
            let d = (fa - fb).abs().truncate().element_sum() / fb.truncate().element_sum();
            if fi < 7 {
                room = room.max(d);
            } else {
                blocks = blocks.max(d);
            }
            eprintln!(
                "  face {fi}: radiosity {:.4} VLF {:.4} (differ by {:.2} %)",
                (fa / area).truncate(),
                (fb / area).truncate(),
                100.0 * d
            );
        }
        eprintln!(
            "VLF CPU reference bake ({} iterations) {vlf_s:.1} s; radiosity vs VLF: mean per-texel relative difference {:.4} (radiosity seed vs seed {:.4}); face means: room (faces 0-6) within {room:.4}, blocks within {blocks:.4}",
            vlf.iterations,
            radiosity::mean_texel_difference(&prep, &g.radiance, &vlf_radiance),
            radiosity::mean_texel_difference(&prep, &g.radiance, &g2.radiance),
        );
    }
}

/// The exact solution of the same system, for reference: Gauss–Seidel in f64 until a sweep
/// changes nothing by more than 1e-13 relative.
fn converged_f64(ff: &radiosity::FormFactors) -> Vec<[f32; 4]> {
    let mut l: Vec<[f64; 3]> = ff
        .source
        .iter()
        .map(|s| [0, 1, 2].map(|c| f64::from(s[c])))
        .collect();
    for _ in 0..10_000 {
        let (mut dmax, mut vmax) = (0f64, 0f64);
        for i in 0..ff.patches() {
            let (cols, vals) = ff.row(i);
            for c in 0..3 {
                let mut acc = 0f64;
                for (&j, &v) in cols.iter().zip(vals) {
                    acc += f64::from(v) * l[j as usize][c];
                }
                let new = f64::from(ff.source[i][c]) + f64::from(ff.albedo[i][c]) * acc;
                dmax = dmax.max((new - l[i][c]).abs());
                vmax = vmax.max(new.abs());
                l[i][c] = new;
            }
        }
        if dmax <= 1e-13 * vmax {
            break;
        }
    }
    let patch: Vec<[f32; 4]> = l
        .iter()
        .map(|x| [x[0] as f32, x[1] as f32, x[2] as f32, 0.0])
        .collect();
    ff.scatter(&patch)
}
