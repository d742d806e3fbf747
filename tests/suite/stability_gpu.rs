//! The stability suite on the GPU (issue 8): the important cases of
//! `crates/vlf-core/tests/core/stability.rs` baked by the GPU propagator, which must equal the CPU
//! reference (area-weighted mean relative difference < 1e-3) and keep its exact properties (a
//! wall passes exactly nothing, bakes are bit-reproducible). The physics bounds themselves are
//! asserted on the CPU; the scenes are rebuilt here (the two test crates share no code).

use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, Propagated};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::scene::{Scene, SceneBuilder};
use vlf_tests::bakes::params;
use vlf_tests::gpu;
use vlf_tests::scenes::{hrect, rect};

/// CPU and GPU bakes of `scene`, or `None` when there is no GPU (and it is not required).
fn both(scene: &Scene, params: &BakeParams) -> Option<(BakeScene, Propagated, Propagated)> {
    let ctx = gpu()?;
    let prep = BakeScene::new(scene, params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let cpu = reference::propagate(&prep, &set, params);
    let gpu = vlf_gpu::bake::propagate(ctx, &prep, &set, params, &mut |_| {}).expect("GPU bake");
    Some((prep, cpu, gpu))
}

/// Asserts the GPU bake equals the CPU one: irradiance (area-weighted mean relative difference
/// over covered texels above 1e-4 < 1e-3), mirror tiles, and the energy terms; no NaN.
fn assert_gpu_matches(what: &str, prep: &BakeScene, cpu: &Propagated, gpu: &Propagated) {
    for (t, l) in gpu.irradiance.iter().enumerate() {
        assert!(
            l.iter().all(|x| x.is_finite() && *x >= 0.0),
            "{what}: GPU texel {t} = {l:?}"
        );
    }
    assert_eq!(cpu.iterations, gpu.iterations, "{what}: iterations");
    let (mut sum, mut area, mut max) = (0f64, 0f64, 0f32);
    for t in 0..cpu.irradiance.len() {
        let (x, y) = (Vec4::from(cpu.irradiance[t]), Vec4::from(gpu.irradiance[t]));
        if prep.texel_area[t] <= 0.0 || x.max_element() <= 1e-4 {
            continue;
        }
        let r = (x - y).abs().max_element() / x.max_element();
        sum += f64::from(r * prep.texel_area[t]);
        area += f64::from(prep.texel_area[t]);
        max = max.max(r);
    }
    let mean = sum / area.max(1e-30);
    let tiles = match (&cpu.tiles, &gpu.tiles) {
        (Some((ci, cv)), Some((gi, gv))) => {
            assert_eq!(ci, gi, "{what}: tile index");
            let (mut d, mut n) = (0f64, 0f64);
            for (a, b) in cv.iter().zip(gv) {
                let (a, b) = (Vec4::from(*a), Vec4::from(*b));
                d += f64::from((a - b).abs().element_sum());
                n += f64::from(a.element_sum());
            }
            d / n.max(1e-30)
        }
        (None, None) => 0.0,
        _ => panic!("{what}: tiles on one side only"),
    };
    let (ec, eg) = (&cpu.energy, &gpu.energy);
    let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(1e-30);
    eprintln!(
        "{what}: GPU vs CPU texels mean {mean:.1e} max {max:.1e}, tiles L1 {tiles:.1e}, absorbed {:.1e}, escaped {:.1e}",
        rel(ec.absorbed, eg.absorbed),
        rel(ec.escaped, eg.escaped)
    );
    // Same algorithm in f32 on both sides: differences only where rounding (FMA, operation
    // order) flips a ray across a texel or triangle edge. Lavapipe: bit-identical so far.
    assert!(mean < 1e-3, "{what}: mean relative difference {mean:e}");
    assert!(tiles < 1e-3, "{what}: tile difference {tiles:e}");
    assert!(
        rel(ec.absorbed, eg.absorbed) < 1e-3,
        "{what}: {ec:?} vs {eg:?}"
    );
    if ec.escaped > 1e-6 * ec.emitted {
        assert!(
            rel(ec.escaped, eg.escaped) < 1e-3,
            "{what}: {ec:?} vs {eg:?}"
        );
    }
}

/// Adds the rectangle facing +y (whichever of the two windings does).
fn rect_up(b: &mut SceneBuilder, o: Vec3, e1: Vec3, e2: Vec3, m: u32) {
    if e1.cross(e2).y > 0.0 {
        rect(b, o, e1, e2, m);
    } else {
        rect(b, o, e2, e1, m);
    }
}

/// Case 1: three cyclically overlapping sticks and two interpenetrating quads over a lit floor.
#[test]
fn gpu_stability_cyclic_overlaps() {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.7, 0.2, 0.2), Vec3::ZERO);
    let green = b.diffuse("green", Vec3::new(0.2, 0.7, 0.2), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(5.0));
    for i in 0..3 {
        let th = i as f32 * 2.0 * std::f32::consts::PI / 3.0;
        let perp = Vec3::new(th.cos(), 0.0, th.sin());
        let dir = Vec3::new(-th.sin(), 0.15, th.cos());
        let o = perp * 0.3 - dir * 0.8 - perp * 0.06;
        rect_up(&mut b, o, dir * 1.6, perp * 0.12, white);
    }
    for (s, m) in [(0.5f32, red), (-0.5, green)] {
        let o = Vec3::new(-0.4, -0.4 * s, 0.55);
        rect_up(&mut b, o, Vec3::new(0.8, 0.8 * s, 0.0), Vec3::Z * 0.4, m);
    }
    hrect(&mut b, 0.6, (-0.3, 0.3), (-0.3, 0.3), false, light);
    hrect(&mut b, -0.5, (-1.0, 1.0), (-1.0, 1.2), true, white);
    let scene = b.build("tangle");
    let Some((prep, cpu, gpu)) = both(&scene, &params(46, 64, Iterations::Fixed(3))) else {
        return;
    };
    assert_gpu_matches("cyclic overlaps", &prep, &cpu, &gpu);
}

/// Cases 2b and 7: a wall made of needle triangles across a closed room passes exactly nothing.
#[test]
fn gpu_stability_needle_wall_passes_no_light() {
    let mut b = SceneBuilder::new();
    let left = b.diffuse("left", Vec3::splat(0.7), Vec3::ZERO);
    let right = b.diffuse("right", Vec3::splat(0.7), Vec3::ZERO);
    let wall = b.diffuse("wall", Vec3::splat(0.7), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(10.0));
    let (up, deep) = (Vec3::Y, Vec3::Z);
    for (m, x0) in [(left, -1.0f32), (right, 0.0f32)] {
        hrect(&mut b, -0.5, (x0, x0 + 1.0), (-0.5, 0.5), true, m);
        hrect(&mut b, 0.5, (x0, x0 + 1.0), (-0.5, 0.5), false, m);
        rect(&mut b, Vec3::new(x0, -0.5, -0.5), Vec3::X, up, m);
        rect(&mut b, Vec3::new(x0, -0.5, 0.5), up, Vec3::X, m);
    }
    rect(&mut b, Vec3::new(-1.0, -0.5, -0.5), up, deep, left);
    rect(&mut b, Vec3::new(1.0, -0.5, -0.5), deep, up, right);
    // The wall at x = 0 facing −x, with a needle along its bottom edge and one across it.
    let at = |z: f32, y: f32| Vec3::new(0.0, y, z);
    let (a, bb, c, d) = (at(-0.5, -0.5), at(0.5, -0.5), at(0.5, 0.5), at(-0.5, 0.5));
    let p = at(0.0, -0.5 + 1e-4);
    let (pc, pd) = (c - p, d - p);
    let q = p + pc * 0.5 + (pd - pc * (pd.dot(pc) / pc.length_squared())).normalize() * 1e-4;
    for t in [
        [a, bb, p],
        [p, bb, c],
        [p, q, c],
        [p, d, q],
        [q, d, c],
        [p, a, d],
    ] {
        let facing_light = (t[1] - t[0]).cross(t[2] - t[0]).x < 0.0;
        b.triangle(if facing_light { t } else { [t[0], t[2], t[1]] }, wall);
    }
    hrect(&mut b, 0.48, (-0.7, -0.3), (-0.2, 0.2), false, light);
    let scene = b.build("split room");
    let Some((prep, cpu, gpu)) = both(&scene, &params(46, 64, Iterations::Fixed(3))) else {
        return;
    };
    assert_gpu_matches("needle wall", &prep, &cpu, &gpu);
    let mut dark = 0.0f32;
    for (fi, f) in scene.faces.iter().enumerate() {
        let sides: &[u32] = match f.material {
            m if m == right => &[0, 1],
            m if m == wall => &[1],
            _ => &[],
        };
        let pf = prep.faces[fi];
        for &s in sides {
            let base = (pf.texel_base + s * pf.texels_per_side()) as usize;
            for t in base..base + pf.texels_per_side() as usize {
                dark = dark.max(Vec4::from(gpu.irradiance[t]).max_element());
            }
        }
    }
    assert_eq!(dark, 0.0, "light passed the wall on the GPU");
}

/// Case 2a: a closed box whose bottom lies on the floor (equal depths, texel-scale leak).
#[test]
fn gpu_stability_box_on_floor() {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(10.0));
    b.aabox(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, 1.0),
        true,
        white,
    );
    hrect(&mut b, 1.98, (-0.3, 0.3), (-0.3, 0.3), false, light);
    b.aabox(
        Vec3::new(-0.3, 0.0, -0.3),
        Vec3::new(0.3, 0.6, 0.3),
        false,
        white,
    );
    let scene = b.build("box on floor");
    let Some((prep, cpu, gpu)) = both(&scene, &params(46, 64, Iterations::Fixed(3))) else {
        return;
    };
    assert_gpu_matches("box on floor", &prep, &cpu, &gpu);
}

/// Case 6: a decal exactly on a floor: the GPU bake is bit-reproducible and equals the CPU's.
#[test]
fn gpu_stability_coplanar_decal() {
    let scene = vlf_tests::scenes::decal_room();
    let p = params(46, 64, Iterations::Fixed(3));
    let Some((prep, cpu, gpu)) = both(&scene, &p) else {
        return;
    };
    assert_gpu_matches("coplanar decal", &prep, &cpu, &gpu);
    let set = DirectionSet::at_least(p.directions).unwrap();
    let again = vlf_gpu::bake::propagate(gpu_ctx(), &prep, &set, &p, &mut |_| {}).unwrap();
    let bits = |o: &Propagated| -> Vec<u32> {
        o.irradiance
            .iter()
            .flat_map(|l| l.map(f32::to_bits))
            .collect()
    };
    assert!(bits(&gpu) == bits(&again), "two GPU bakes differ");
}

fn gpu_ctx() -> &'static vlf_gpu::GpuContext {
    gpu().expect("checked by both()")
}

/// Case 3: a small distant emitter with perturbed directions (the virtual directions' path).
#[test]
fn gpu_stability_direction_holes_with_perturbation() {
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
    let floor = b.diffuse("floor", Vec3::splat(0.5), Vec3::ZERO);
    hrect(&mut b, 3.0, (-0.025, 0.025), (-0.025, 0.025), false, light);
    hrect(&mut b, 0.0, (-0.5, 0.5), (-0.5, 0.5), true, floor);
    let scene = b.build("distant emitter");
    let p = BakeParams {
        perturb: 16,
        ..params(126, 64, Iterations::Fixed(1))
    };
    let Some((prep, cpu, gpu)) = both(&scene, &p) else {
        return;
    };
    assert_gpu_matches("direction holes", &prep, &cpu, &gpu);
}

/// Case 4: the receiver of a mirror image at 46 directions (ghosting): texels and tiles.
#[test]
fn gpu_stability_mirror_image() {
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
    let recv = b.diffuse("receiver", Vec3::splat(0.5), Vec3::ZERO);
    let m = b.mirror("mirror", Vec3::splat(0.9));
    hrect(&mut b, 0.5, (-0.6, -0.2), (-0.2, 0.2), false, light);
    hrect(&mut b, 0.5, (0.2, 0.6), (-0.2, 0.2), false, recv);
    hrect(&mut b, 0.0, (-1.0, 1.0), (-0.6, 0.6), true, m);
    let scene = b.build("mirror image");
    let Some((prep, cpu, gpu)) = both(&scene, &params(46, 64, Iterations::Fixed(2))) else {
        return;
    };
    assert_gpu_matches("mirror image", &prep, &cpu, &gpu);
}

/// Case 8: a room scaled by 1e4 holding a cube 1e-4 of its size.
#[test]
fn gpu_stability_huge_scale_and_tiny_object() {
    let s = 1e4f32;
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.73), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.65, 0.05, 0.05), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(15.0));
    let room = Vec3::new(1.0, 0.9, 1.1) * s;
    b.aabox(Vec3::ZERO, room, true, red);
    hrect(
        &mut b,
        0.898 * s,
        (0.37 * s, 0.63 * s),
        (0.4 * s, 0.7 * s),
        false,
        light,
    );
    let c = Vec3::new(0.5, 0.45, 0.55) * s;
    b.aabox(c - Vec3::splat(0.5), c + Vec3::splat(0.5), false, white);
    b.aabox(
        Vec3::new(0.2, 0.0, 0.2) * s,
        Vec3::new(0.45, 0.3, 0.5) * s,
        false,
        white,
    );
    let scene = b.build("scaled room");
    let Some((prep, cpu, gpu)) = both(&scene, &params(46, 64, Iterations::Fixed(3))) else {
        return;
    };
    assert_gpu_matches("huge scale, tiny object", &prep, &cpu, &gpu);
}
