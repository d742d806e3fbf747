//! The GPU propagator against the CPU reference, and the physics checks on the GPU.

use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, Propagated};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::scene::{Scene, SceneBuilder};
use vlf_tests::bakes;
use vlf_tests::scenes;
use vlf_tests::{gpu, repo_dir};

fn both(scene: &Scene, params: &BakeParams) -> Option<(BakeScene, Propagated, Propagated)> {
    let ctx = gpu()?;
    let prep = BakeScene::new(scene, params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let cpu = reference::propagate(&prep, &set, params);
    let gpu = vlf_gpu::bake::propagate(ctx, &prep, &set, params, &mut |_| {}).expect("GPU bake");
    Some((prep, cpu, gpu))
}

/// (area-weighted mean relative difference, 99th-percentile relative difference) of covered
/// texels whose CPU irradiance is above `floor`.
fn difference(prep: &BakeScene, a: &[[f32; 4]], b: &[[f32; 4]], floor: f32) -> (f64, f32) {
    let mut rel = Vec::new();
    let (mut sum, mut area) = (0f64, 0f64);
    for t in 0..a.len() {
        let (x, y) = (Vec4::from(a[t]).truncate(), Vec4::from(b[t]).truncate());
        if prep.texel_area[t] <= 0.0 || x.max_element() <= floor {
            continue;
        }
        let r = ((x - y).abs().max_element()) / x.max_element();
        rel.push(r);
        sum += f64::from(r * prep.texel_area[t]);
        area += f64::from(prep.texel_area[t]);
    }
    rel.sort_by(f32::total_cmp);
    (sum / area, rel[(rel.len() * 99) / 100])
}

/// GPU equals the CPU reference on the diffuse Cornell box at small settings.
#[test]
fn gpu_matches_cpu_reference_on_cornell_box() {
    let scene =
        vlf_core::scene::load(&repo_dir().join("assets/cornell-box/cornell-box.gltf")).unwrap();
    let params = bakes::params(46, 32, Iterations::Fixed(3));
    let Some((prep, cpu, gpu)) = both(&scene, &params) else {
        return;
    };
    assert_eq!(cpu.iterations, gpu.iterations);
    let (mean, p99) = difference(&prep, &cpu.irradiance, &gpu.irradiance, 1e-4);
    eprintln!("GPU vs CPU: mean relative difference {mean:.2e}, 99th percentile {p99:.2e}");
    // Same algorithm, f32 on both sides; differences come from rounding (FMA, operation order)
    // flipping which rays count as crossing a texel at its boundary.
    assert!(mean < 1e-3 && p99 < 1e-2, "mean {mean:.2e} p99 {p99:.2e}");
    let (ec, eg) = (&cpu.energy, &gpu.energy);
    assert!(
        ((ec.absorbed - eg.absorbed) / ec.absorbed).abs() < 1e-3,
        "{ec:?} vs {eg:?}"
    );
    // The energy bookkeeping agrees too (its absolute balance at these coarse settings, 46
    // directions and 32² rays, is a property of the discretisation, checked on the CPU at 126
    // directions in vlf-core's tests/propagation.rs).
    assert!(
        (eg.relative_imbalance() - ec.relative_imbalance()).abs() < 1e-4,
        "GPU imbalance {eg:?} vs CPU {ec:?}"
    );
}

/// Furnace on the GPU: closed box, emission L_e, albedo ρ → L_e / (1 − ρ) within 1 %.
#[test]
fn gpu_furnace_closed_box() {
    let (le, rho) = (Vec3::new(1.0, 0.5, 0.25), 0.5);
    let scene = scenes::furnace_box(le, rho);
    let params = bakes::params(
        46,
        32,
        Iterations::Converge {
            threshold: 1e-5,
            max: 100,
        },
    );
    let Some((prep, _, gpu)) = both(&scene, &params) else {
        return;
    };
    let want = le / (1.0 - rho);
    let radiance = prep.outgoing_radiance(&gpu.irradiance);
    for f in &prep.faces {
        let n = f.texels_per_side() as usize;
        for t in f.texel_base as usize..f.texel_base as usize + n {
            if prep.texel_area[t] <= 0.0 {
                continue;
            }
            let l = Vec4::from(radiance[t]).truncate();
            let dev = ((l - want).abs() / want).max_element();
            assert!(dev < 0.01, "texel {t}: {l:?} want {want:?}");
        }
    }
}

/// A lone plane under a constant sky S with albedo ρ reads ρ·S on both sides (GPU).
#[test]
fn gpu_open_plane_under_sky() {
    let (sky, rho) = (Vec3::new(2.0, 1.0, 0.5), 0.6);
    let scene = scenes::sky_plane(rho);
    let params = BakeParams {
        sky,
        ..bakes::params(46, 32, Iterations::Fixed(2))
    };
    let Some((prep, _, gpu)) = both(&scene, &params) else {
        return;
    };
    let radiance = prep.outgoing_radiance(&gpu.irradiance);
    for t in 0..prep.texel_count() {
        if prep.texel_area[t] > 0.0 {
            let l = Vec4::from(radiance[t]).truncate();
            assert!(
                ((l - sky * rho).abs() / (sky * rho)).max_element() < 1e-3,
                "texel {t}: {l:?}"
            );
        }
    }
}

/// GPU equals the CPU reference on the mirror Cornell box (texels and mirror tiles).
#[test]
fn gpu_matches_cpu_reference_on_mirror_cornell_box() {
    let scene =
        vlf_core::scene::load(&repo_dir().join("assets/cornell-mirror/cornell-mirror.gltf"))
            .unwrap();
    let params = bakes::params(46, 32, Iterations::Fixed(3));
    let Some((prep, cpu, gpu)) = both(&scene, &params) else {
        return;
    };
    let (mean, p99) = difference(&prep, &cpu.irradiance, &gpu.irradiance, 1e-4);
    let (ci, cv) = cpu.tiles.as_ref().expect("CPU tiles");
    let (gi, gv) = gpu.tiles.as_ref().expect("GPU tiles");
    assert_eq!(ci, gi, "tile index");
    let (mut sum, mut norm, mut worst) = (0f64, 0f64, 0f32);
    for (a, b) in cv.iter().zip(gv) {
        let (a, b) = (Vec4::from(*a).truncate(), Vec4::from(*b).truncate());
        sum += f64::from((a - b).abs().element_sum());
        norm += f64::from(a.element_sum());
        if a.max_element() > 1e-3 {
            worst = worst.max((a - b).abs().max_element() / a.max_element());
        }
    }
    let tile_rel = sum / norm.max(1e-30);
    eprintln!(
        "mirror box GPU vs CPU: texels mean {mean:.2e} p99 {p99:.2e}; tiles L1 {tile_rel:.2e}, worst {worst:.2e}"
    );
    assert!(
        mean < 1e-3 && p99 < 1e-2,
        "texels: mean {mean:.2e} p99 {p99:.2e}"
    );
    assert!(
        tile_rel < 1e-3,
        "tiles: relative L1 difference {tile_rel:.2e}"
    );
    assert!(
        ((cpu.energy.escaped - gpu.energy.escaped) / cpu.energy.escaped).abs() < 1e-3,
        "{:?} vs {:?}",
        cpu.energy,
        gpu.energy
    );
}

/// Bit patterns of radiance values, for exact comparisons.
fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|x| x.map(f32::to_bits)).collect()
}

/// `a` and `b` are the same bits: radiance, irradiance, mirror tiles, iterations and energy
/// sums.
fn assert_identical(a: &Propagated, b: &Propagated, what: &str) {
    assert_eq!(a.iterations, b.iterations, "{what}: iterations");
    assert!(
        bits(&a.irradiance) == bits(&b.irradiance),
        "{what}: texel irradiance differs"
    );
    match (&a.tiles, &b.tiles) {
        (None, None) => {}
        (Some((ia, va)), Some((ib, vb))) => {
            assert_eq!(ia, ib, "{what}: tile index");
            assert!(bits(va) == bits(vb), "{what}: mirror tile values differ");
        }
        _ => panic!("{what}: only one side has mirror tiles"),
    }
    assert_eq!(a.energy, b.energy, "{what}: energy");
}

/// The tile bins (and reflect items) split into several buffers, one `Cells`/`Reflect` bind
/// group per chunk of directions, give exactly the bits of one buffer, on the diffuse and the
/// mirror Cornell box: with a few directions per chunk and with one direction per chunk (the
/// cap below a single direction's bins). Both agree with the CPU reference as closely as the
/// unchunked propagator does.
#[test]
fn chunked_bins_give_identical_bits() {
    use vlf_gpu::bake::{BakePlan, GpuBakeOptions, binding_limit, propagate_with};
    let Some(ctx) = gpu() else {
        return;
    };
    let limit = binding_limit(&ctx.device);
    for asset in [
        "assets/cornell-box/cornell-box.gltf",
        "assets/cornell-mirror/cornell-mirror.gltf",
    ] {
        let scene = vlf_core::scene::load(&repo_dir().join(asset)).unwrap();
        let params = bakes::params(46, 32, Iterations::Fixed(2));
        let prep = BakeScene::new(&scene, &params).unwrap();
        let set = DirectionSet::at_least(params.directions).unwrap();
        let (dirs, _) = reference::all_directions(&prep, &set, &params);

        let chunk_layout = |cap| BakePlan::new(&prep, &set, &params, limit, cap).chunks;
        let whole = chunk_layout(None);
        assert_eq!(whole.len(), 1, "{asset}: small bake, one chunk by default");
        assert_eq!(whole[0].directions, 0..dirs.len());
        let quarter = whole[0].bytes.largest() / 4;
        let several = chunk_layout(Some(quarter));
        assert!(
            several.len() >= 4 && several.iter().all(|c| c.bytes.largest() <= quarter),
            "{asset}: {several:?}"
        );
        assert!(several.iter().any(|c| c.directions.len() > 1));
        let single = chunk_layout(Some(1));
        assert_eq!(single.len(), dirs.len(), "{asset}: one direction per chunk");

        let run = |cap: Option<u64>| {
            let options = GpuBakeOptions {
                max_chunk_bytes: cap,
            };
            propagate_with(ctx, &prep, &set, &params, &options, &mut |_| {}).expect("GPU bake")
        };
        let one = run(None);
        for cap in [quarter, 1] {
            assert_identical(&one, &run(Some(cap)), &format!("{asset}, cap {cap} B"));
        }
        // The unchunked path is what `propagate` runs.
        let plain = vlf_gpu::bake::propagate(ctx, &prep, &set, &params, &mut |_| {}).unwrap();
        assert_identical(&one, &plain, asset);

        let cpu = reference::propagate(&prep, &set, &params);
        let (mean, p99) = difference(&prep, &cpu.irradiance, &one.irradiance, 1e-4);
        let same = bits(&cpu.irradiance) == bits(&one.irradiance)
            && cpu.tiles.as_ref().map(|t| bits(&t.1)) == one.tiles.as_ref().map(|t| bits(&t.1));
        eprintln!(
            "{asset}: {} chunks / {} directions; GPU = CPU bit for bit: {same} (mean {mean:.2e}, p99 {p99:.2e})",
            several.len(),
            dirs.len()
        );
        if ctx.summary.is_software() {
            // lavapipe rounds as the CPU does (docs/PROPAGATION.md): every bit agrees.
            assert!(
                same,
                "{asset}: GPU differs from the CPU reference on lavapipe"
            );
        } else {
            assert!(
                mean < 1e-3 && p99 < 1e-2,
                "{asset}: mean {mean:.2e} p99 {p99:.2e}"
            );
        }
    }
}

/// A room lit only by a point and a spot light, with a block casting their shadows: the
/// lights' first bounce is injected from the CPU's array on both sides
/// (`vlf_core::bake::punctual`), so the GPU propagation equals the CPU reference bit for bit on
/// lavapipe (irradiance, first bounce, energy), and closely elsewhere.
#[test]
fn gpu_matches_cpu_bit_for_bit_with_point_and_spot_lights() {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.6), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.7, 0.2, 0.2), Vec3::ZERO);
    b.aabox(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 1.5, 1.0),
        true,
        white,
    );
    b.aabox(
        Vec3::new(-0.3, 0.0, -0.3),
        Vec3::new(0.2, 0.6, 0.2),
        false,
        red,
    );
    let mut scene = b.build("lamps in a room");
    scene.lights = vec![
        scenes::point_light(Vec3::new(0.5, 1.2, 0.4), Vec3::new(2.0, 1.8, 1.5)),
        scenes::spot_light(
            Vec3::new(-0.8, 1.4, -0.7),
            Vec3::new(0.6, -1.0, 0.5).normalize(),
            Vec3::new(3.0, 4.0, 5.0),
            (0.3, 0.4),
            Some(4.0),
        ),
    ];
    let params = bakes::params(
        46,
        32,
        Iterations::Converge {
            threshold: 1e-3,
            max: 20,
        },
    );
    let Some((prep, cpu, gpu)) = both(&scene, &params) else {
        return;
    };
    assert!(
        cpu.energy.injected > 0.0 && cpu.iterations > 2,
        "{:?}",
        cpu.energy
    );
    let software = vlf_tests::gpu().is_some_and(|c| c.summary.is_software());
    let (mean, p99) = difference(&prep, &cpu.irradiance, &gpu.irradiance, 1e-4);
    eprintln!(
        "lamps: GPU vs CPU mean {mean:.2e}, p99 {p99:.2e}, {} iterations, injected {:.4}",
        cpu.iterations, cpu.energy.injected
    );
    if software {
        assert_identical(&cpu, &gpu, "lamps in a room");
        assert!(
            cpu.first_bounce.as_deref().map(bits) == gpu.first_bounce.as_deref().map(bits),
            "first bounce differs"
        );
    } else {
        assert!(mean < 1e-3 && p99 < 1e-2, "mean {mean:.2e} p99 {p99:.2e}");
    }
}
