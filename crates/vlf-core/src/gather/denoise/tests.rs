use super::*;
use crate::pathtrace::PreparedScene;
use crate::pathtrace::sampling::{Rng, pcg_hash};
use crate::scene::SceneBuilder;

/// Texels across 2 world units.
pub(crate) const ACROSS: f32 = 64.0;

pub(crate) fn grid(scene: &Scene, across: f32) -> Grid {
    Grid::new(scene, 2.0 * scene.to_vlf.scale / across).unwrap()
}

/// A standard normal deviate from `rng` (Box–Muller).
fn gauss(rng: &mut Rng) -> f32 {
    let (u, v) = (1.0 - rng.next_f32(), rng.next_f32());
    (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
}

/// Synthetic gathered values: `mean(world centroid, face)` × (1 + blotches + white), the
/// blotches a standard normal per node of a lattice of 2-texel spacing (the indirect
/// grid), read bilinearly, times `coarse`; the white part `white` × a standard normal per
/// texel. Returns the values, the exact means and the variances of luminance.
pub(crate) fn synthetic(
    scene: &Scene,
    g: &Grid,
    mean: impl Fn(Vec3, usize) -> f32,
    coarse: f32,
    white: f32,
    seed: u32,
) -> (Vec<[f32; 4]>, Vec<f32>, Vec<f32>) {
    let n = g.atlas.texel_count();
    let node = |f: usize, s: u32, i: i64, j: i64| {
        let h = pcg_hash(
            (f as u32).wrapping_mul(0x9e37_79b9)
                ^ pcg_hash(s ^ pcg_hash(i as u32 ^ pcg_hash(j as u32))),
        );
        gauss(&mut Rng::for_path(seed, h, 3))
    };
    let (mut e, mut m, mut v) = (vec![[0.0; 4]; n], vec![0.0; n], vec![0.0; n]);
    for t in 0..n {
        if g.atlas.texel_area[t] <= 0.0 {
            continue;
        }
        let fi = g.tex_face[t] as usize;
        let f = &g.atlas.faces[fi];
        let side = (t as u32 - f.texel_base) / f.texels_per_side();
        let c = Vec4::from(g.atlas.texel_center[t]).truncate();
        let mu = mean(scene.to_vlf.inverse(c), fi);
        let q = chart_coords(f, c) * 0.5;
        let (i, j) = (q.x.floor() as i64, q.y.floor() as i64);
        let (fx, fy) = (q.x - i as f32, q.y - j as f32);
        let w = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        let b = w[0] * node(fi, side, i, j)
            + w[1] * node(fi, side, i + 1, j)
            + w[2] * node(fi, side, i, j + 1)
            + w[3] * node(fi, side, i + 1, j + 1);
        let z = gauss(&mut Rng::for_path(seed, t as u32, 4));
        let val = mu * (1.0 + coarse * b + white * z);
        e[t] = [val; 4];
        e[t][3] = 0.0;
        m[t] = mu;
        let sw: f32 = w.iter().map(|w| w * w).sum();
        v[t] = mu * mu * (coarse * coarse * sw + white * white);
    }
    (e, m, v)
}

fn floor(b: &mut SceneBuilder, x0: f32, x1: f32, y: f32, m: u32) {
    b.quad(
        [
            Vec3::new(x0, y, 1.0),
            Vec3::new(x1, y, 1.0),
            Vec3::new(x1, y, -1.0),
            Vec3::new(x0, y, -1.0),
        ],
        m,
    );
}

pub(crate) fn plane() -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.diffuse("grey", Vec3::splat(0.5), Vec3::ZERO);
    floor(&mut b, -1.0, 1.0, 0.0, grey);
    b.build("plane")
}

fn run(
    scene: &Scene,
    g: &Grid,
    e: &[[f32; 4]],
    v: &[f32],
    filled: &[bool],
    p: &DenoiseParams,
    threads: usize,
) -> (Vec<[f32; 4]>, DenoiseStats) {
    let ps = PreparedScene::new(scene);
    denoise(scene, &ps.bvh, g, e, v, filled, p, threads)
}

fn covered(g: &Grid) -> Vec<bool> {
    g.atlas.texel_area.iter().map(|a| *a > 0.0).collect()
}

/// Area-weighted mean of channel 0 over the covered texels of `face`'s front.
fn face_mean(g: &Grid, e: &[[f32; 4]], face: usize) -> f64 {
    let f = &g.atlas.faces[face];
    let r = f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize;
    let (mut s, mut a) = (0.0, 0.0);
    for t in r {
        let w = f64::from(g.atlas.texel_area[t]);
        s += f64::from(e[t][0]) * w;
        a += w;
    }
    s / a
}

/// Mean squared error of channel 0 against `m` over the front texels of face 0 that
/// `pick` selects.
fn mse(g: &Grid, e: &[[f32; 4]], m: &[f32], pick: impl Fn(usize) -> bool) -> f64 {
    let f = &g.atlas.faces[0];
    let (mut s, mut n) = (0.0, 0);
    for t in f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize {
        if g.atlas.texel_area[t] > 0.0 && pick(t) {
            s += f64::from(e[t][0] - m[t]).powi(2);
            n += 1;
        }
    }
    s / f64::from(n)
}

#[test]
fn noise_on_a_flat_plane_drops_four_fold_and_the_mean_stays() {
    let scene = plane();
    let g = grid(&scene, ACROSS);
    let (e, m, v) = synthetic(&scene, &g, |_, _| 1.0, 0.1, 0.05, 1);
    let (out, stats) = run(
        &scene,
        &g,
        &e,
        &v,
        &covered(&g),
        &DenoiseParams::default(),
        0,
    );
    let (before, after) = (mse(&g, &e, &m, |_| true), mse(&g, &out, &m, |_| true));
    let (mb, ma) = (face_mean(&g, &e, 0), face_mean(&g, &out, 0));
    eprintln!(
        "flat plane: MSE {before:.3e} -> {after:.3e} ({:.1}x), mean {mb:.5} -> {ma:.5}, power {:+.3e}, {stats:?}",
        before / after,
        stats.relative_power_change()
    );
    assert!(before / after >= 4.0, "MSE {before} -> {after}");
    assert!((ma / mb - 1.0).abs() < 0.01, "mean {mb} -> {ma}");
    assert!((ma - 1.0).abs() < 0.01, "mean {ma}");
    assert!(stats.relative_power_change().abs() < 0.01);
    assert_eq!(stats.occluded_pairs, 0);
    assert_eq!(stats.straddling_texels, 0);
}

#[test]
fn a_step_edge_far_above_the_noise_is_not_mixed() {
    let scene = plane();
    let g = grid(&scene, ACROSS);
    let ts = 2.0 / ACROSS;
    let level = |p: Vec3, _| if p.x < 0.0 { 1.0 } else { 0.1 };
    let (e, m, v) = synthetic(&scene, &g, level, 0.1, 0.05, 2);
    let (out, stats) = run(
        &scene,
        &g,
        &e,
        &v,
        &covered(&g),
        &DenoiseParams::default(),
        0,
    );
    let x = |t: usize| {
        scene
            .to_vlf
            .inverse(Vec4::from(g.atlas.texel_center[t]).truncate())
            .x
    };
    let near_dark = |t: usize| x(t) > 0.0 && x(t) < 3.0 * ts;
    let near_bright = |t: usize| x(t) < 0.0 && x(t) > -3.0 * ts;
    let f = &g.atlas.faces[0];
    let mut worst = (0.0f32, 0.0f32);
    let (mut sum_dark, mut count) = (0.0f64, 0);
    for t in f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize {
        let sd = v[t].sqrt();
        if near_dark(t) {
            worst.0 = worst.0.max((out[t][0] - 0.1) / sd);
            sum_dark += f64::from(out[t][0]);
            count += 1;
        }
        if near_bright(t) {
            worst.1 = worst.1.max((1.0 - out[t][0]) / sd);
        }
    }
    let dark_mean = sum_dark / f64::from(count);
    let far = |t: usize| x(t).abs() > 0.25;
    let (before, after) = (mse(&g, &e, &m, far), mse(&g, &out, &m, far));
    let (nb, na) = (mse(&g, &e, &m, near_dark), mse(&g, &out, &m, near_dark));
    eprintln!(
        "step: dark side within 3 texels of the edge: mean {dark_mean:.4}, worst excess {:.2} sd, \
         MSE {nb:.3e} -> {na:.3e}; bright side worst deficit {:.2} sd; away from the edge MSE \
         {before:.3e} -> {after:.3e}; rejected {:.3}",
        worst.0, worst.1, stats.rejected_share
    );
    // The dark side near the edge stays dark: within noise of 0.1 (its own noise, 0.011),
    // not pulled up towards 1 (0.9 is 80 of its standard deviations away).
    assert!(worst.0 < 4.0, "a dark texel {} sd above dark", worst.0);
    assert!((dark_mean - 0.1).abs() < 0.002, "dark mean {dark_mean}");
    assert!(worst.1 < 4.0, "a bright texel {} sd below bright", worst.1);
    assert!(
        na < nb,
        "the dark side near the edge is filtered too: {nb} -> {na}"
    );
    assert!(before / after >= 4.0);
}

/// A crate standing on the floor: four walls and a lid facing inwards, no bottom, so the
/// floor inside is open (it has an estimate) but sees nothing of the floor outside.
pub(crate) fn crate_on_floor() -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.diffuse("grey", Vec3::splat(0.5), Vec3::ZERO);
    floor(&mut b, -1.0, 1.0, 0.0, grey);
    let (lo, hi) = (Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 0.4, 0.3));
    let p =
        |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    for mut q in [
        [p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)],
        [p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1)],
        [p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0)],
        [p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0)],
        [p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)],
    ] {
        q.reverse();
        b.quad(q, grey);
    }
    b.build("crate on a floor")
}

/// Which texels hold an estimate, as the gather decides it: those with an open point.
pub(crate) fn gather_filled(scene: &Scene, g: &Grid) -> Vec<bool> {
    let ps = PreparedScene::new(scene);
    let pts = g.points(scene, &ps.bvh);
    (0..g.atlas.texel_count())
        .map(|t| {
            let mut rng = Rng::for_path(9, t as u32, 0);
            let mut v = Vec::new();
            pts.sample(t, 16, &mut rng, &mut v);
            !v.is_empty()
        })
        .collect()
}

/// No range weight: only the geometry stops the filter.
fn geometry_only() -> DenoiseParams {
    DenoiseParams {
        sigma_k: 1e6,
        ..DenoiseParams::default()
    }
}

fn crate_case(threads: usize) -> (Scene, Grid, Vec<[f32; 4]>, Vec<[f32; 4]>, DenoiseStats) {
    let scene = crate_on_floor();
    let g = grid(&scene, ACROSS);
    let inside = |p: Vec3| p.x.abs() < 0.3 && p.z.abs() < 0.3;
    let level = move |p: Vec3, f: usize| match f {
        0 if inside(p) => 0.05,
        0 => 1.0,
        _ => 0.5,
    };
    let (e, _, v) = synthetic(&scene, &g, level, 0.1, 0.05, 3);
    let filled = gather_filled(&scene, &g);
    let (out, stats) = run(&scene, &g, &e, &v, &filled, &geometry_only(), threads);
    (scene, g, e, out, stats)
}

#[test]
fn the_floor_inside_a_crate_never_receives_the_lit_floor_outside() {
    let (scene, g, e, out, stats) = crate_case(0);
    let f = &g.atlas.faces[0];
    let world = |t: usize| {
        scene
            .to_vlf
            .inverse(Vec4::from(g.atlas.texel_center[t]).truncate())
    };
    let front = f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize;
    let inside = |t: usize| world(t).x.abs() < 0.3 && world(t).z.abs() < 0.3;
    // Filtered values are convex combinations of what each texel may see: inside the crate,
    // of inside texels only.
    let max_in = front
        .clone()
        .filter(|&t| inside(t))
        .map(|t| e[t][0])
        .fold(0.0f32, f32::max);
    let min_out = front
        .clone()
        .filter(|&t| !inside(t))
        .map(|t| e[t][0])
        .fold(f32::MAX, f32::min);
    let (mut worst_in, mut worst_out, mut changed) = (0.0f32, f32::MAX, 0);
    for t in front {
        if g.atlas.texel_area[t] <= 0.0 {
            continue;
        }
        if inside(t) {
            worst_in = worst_in.max(out[t][0]);
        } else {
            worst_out = worst_out.min(out[t][0]);
        }
        changed += usize::from(out[t][0] != e[t][0]);
    }
    eprintln!(
        "crate: inside max {max_in:.4} -> {worst_in:.4}, outside min {min_out:.4} -> {worst_out:.4}, \
         {changed} floor texels changed, {stats:?}"
    );
    assert!(
        worst_in <= max_in,
        "the inside received {worst_in} (its own max {max_in})"
    );
    assert!(
        worst_out >= min_out,
        "the outside received {worst_out} (its own min {min_out})"
    );
    assert!(stats.occluded_pairs > 0 && stats.straddling_texels > 0);
    assert!(changed > 3000, "the floor was filtered");
}

#[test]
fn the_result_does_not_depend_on_the_thread_count() {
    let (_, _, _, one, s1) = crate_case(1);
    let (_, _, _, two, s2) = crate_case(2);
    let bits = |e: &[[f32; 4]]| e.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(bits(&one) == bits(&two), "1 and 2 threads differ");
    assert_eq!(s1, s2);
}

#[test]
fn a_crease_stops_the_filter_and_coplanar_faces_mix() {
    let mut b = SceneBuilder::new();
    let grey = b.diffuse("grey", Vec3::splat(0.5), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.5, 0.1, 0.1), Vec3::ZERO);
    // A floor in two coplanar faces of two materials (seam at x = 0), a wall at x = −1
    // facing +x (a 90° crease with the floor), and a platform a little above the floor
    // (parallel, not coplanar) beyond x = 1.
    floor(&mut b, -1.0, 0.0, 0.0, grey);
    floor(&mut b, 0.0, 1.0, 0.0, red);
    b.quad(
        [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::new(-1.0, 2.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
        ],
        grey,
    );
    floor(&mut b, 1.0, 2.0, 0.02, grey);
    let scene = b.build("crease");
    let g = grid(&scene, ACROSS);
    let face_of = |n: Vec3, x: f32| {
        (0..scene.faces.len())
            .find(|&f| {
                let t = &scene.face_triangles(f)[0];
                scene.faces[f].normal.dot(n) > 0.99 && (t.centroid().x - x).abs() < 0.5
            })
            .unwrap()
    };
    let (left, right, wall, platform) = (
        face_of(Vec3::Y, -0.5),
        face_of(Vec3::Y, 0.5),
        face_of(Vec3::X, -1.0),
        face_of(Vec3::Y, 1.5),
    );
    // Crease and platform: geometry only decides; the wall and platform are dark.
    let level = |_, f: usize| if f == wall || f == platform { 0.1 } else { 1.0 };
    let (e, m, v) = synthetic(&scene, &g, level, 0.1, 0.05, 4);
    let (out, stats) = run(&scene, &g, &e, &v, &covered(&g), &geometry_only(), 0);
    let range = |f: usize, e: &[[f32; 4]]| {
        let bf = &g.atlas.faces[f];
        (bf.texel_base as usize..(bf.texel_base + bf.texels_per_side()) as usize)
            .filter(|&t| g.atlas.texel_area[t] > 0.0)
            .map(|t| e[t][0])
            .fold((f32::MAX, 0.0f32), |a, x| (a.0.min(x), a.1.max(x)))
    };
    for f in [wall, platform] {
        assert!(
            range(f, &out).1 <= range(f, &e).1,
            "face {f} received light"
        );
    }
    for f in [left, right] {
        assert!(range(f, &out).0 >= range(f, &e).0, "face {f} received dark");
    }
    assert!(stats.cross_face_pairs > 0);
    // Along the seam the two floor faces mix as well as inside either.
    let x = |t: usize| {
        scene
            .to_vlf
            .inverse(Vec4::from(g.atlas.texel_center[t]).truncate())
            .x
    };
    let seam_err = |e: &[[f32; 4]]| {
        let (mut s, mut n) = (0.0f64, 0);
        for f in [left, right] {
            let bf = &g.atlas.faces[f];
            for t in bf.texel_base as usize..(bf.texel_base + bf.texels_per_side()) as usize {
                if g.atlas.texel_area[t] > 0.0 && x(t).abs() < 2.0 / ACROSS {
                    s += f64::from(e[t][0] - m[t]).powi(2);
                    n += 1;
                }
            }
        }
        s / f64::from(n)
    };
    let (before, after) = (seam_err(&e), seam_err(&out));
    eprintln!(
        "seam: MSE {before:.3e} -> {after:.3e} ({:.1}x), {stats:?}",
        before / after
    );
    assert!(before / after >= 4.0);
}

#[test]
fn an_exact_texel_is_kept_and_unestimated_ones_are_dilated() {
    let scene = plane();
    let g = grid(&scene, 16.0);
    let (e, _, mut v) = synthetic(&scene, &g, |_, _| 1.0, 0.1, 0.05, 5);
    let mut filled = covered(&g);
    v[40] = 0.0;
    filled[60] = false;
    let (out, stats) = run(&scene, &g, &e, &v, &filled, &DenoiseParams::default(), 0);
    assert_eq!(out[40], e[40]);
    assert_ne!(out[41], e[41]);
    assert_eq!(stats.exact_texels, 1);
    // Texel 60 is the mean of its 8 neighbours' filtered values.
    let f = &g.atlas.faces[0];
    let w = f.width as usize;
    let mean = [59, 61, 60 - w, 60 + w, 59 - w, 61 - w, 59 + w, 61 + w]
        .iter()
        .map(|&t| out[t][0])
        .sum::<f32>()
        / 8.0;
    assert!((out[60][0] - mean).abs() < 1e-6);
}

/// Cost: `cargo test -p vlf-core --release denoise_cost -- --ignored --nocapture`.
#[test]
#[ignore]
fn denoise_cost() {
    let crate_scene = crate_on_floor();
    let g = grid(&crate_scene, 512.0);
    cost("crate on a floor", &crate_scene, &g);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/cornell-box/cornell-box.gltf");
    let cornell = crate::scene::load(&path).unwrap();
    let g = Grid::new(&cornell, 0.0045).unwrap();
    cost("cornell-box", &cornell, &g);
}

fn cost(name: &str, scene: &Scene, g: &Grid) {
    let (e, _, v) = synthetic(scene, g, |_, _| 1.0, 0.1, 0.05, 6);
    let filled = covered(g);
    let ps = PreparedScene::new(scene);
    for threads in [1, 2] {
        let t0 = std::time::Instant::now();
        let (_, s) = denoise(
            scene,
            &ps.bvh,
            g,
            &e,
            &v,
            &filled,
            &DenoiseParams::default(),
            threads,
        );
        let dt = t0.elapsed().as_secs_f64();
        eprintln!(
            "{name}: {} texels ({} estimated), {threads} thread(s): {dt:.2} s, {:.2} s per million texels, {} rays",
            s.texels,
            s.estimated_texels,
            dt / s.texels as f64 * 1e6,
            s.rays
        );
    }
}

/// Settings against MSE on a flat plane, near a step and on a 4-texel ramp (a penumbra):
/// `cargo test -p vlf-core --lib denoise_sweep -- --ignored --nocapture`.
#[test]
#[ignore]
fn denoise_sweep() {
    let scene = plane();
    let g = grid(&scene, ACROSS);
    let ts = 2.0 / ACROSS;
    let x = |t: usize| {
        scene
            .to_vlf
            .inverse(Vec4::from(g.atlas.texel_center[t]).truncate())
            .x
    };
    for (c, w) in [(0.1, 0.05), (0.25, 0.1)] {
        let flat = synthetic(&scene, &g, |_, _| 1.0, c, w, 1);
        let step = synthetic(
            &scene,
            &g,
            |p: Vec3, _| if p.x < 0.0 { 1.0 } else { 0.1 },
            c,
            w,
            2,
        );
        let ramp_f = |p: Vec3| 1.0 - 0.9 * ((p.x / (4.0 * ts)) + 0.5).clamp(0.0, 1.0);
        let ramp = synthetic(&scene, &g, move |p: Vec3, _| ramp_f(p), c, w, 3);
        for r in [2.0, 3.0, 4.0] {
            for k in [2.0, 3.0, 4.0] {
                for passes in [1, 2, 3, 4] {
                    let p = DenoiseParams {
                        radius_texels: r,
                        sigma_k: k,
                        passes,
                    };
                    let f = |(e, m, v): &(Vec<[f32; 4]>, Vec<f32>, Vec<f32>),
                             pick: &dyn Fn(usize) -> bool| {
                        let (out, _) = run(&scene, &g, e, v, &covered(&g), &p, 1);
                        (mse(&g, e, m, pick), mse(&g, &out, m, pick))
                    };
                    let a = f(&flat, &|_| true);
                    let s = f(&step, &|t| x(t).abs() < 3.0 * ts);
                    let rr = f(&ramp, &|t| x(t).abs() < 4.0 * ts);
                    eprintln!(
                        "noise {c}/{w} R {r} k {k} passes {passes}: flat {:.1}x, step near edge {:.2}x, ramp {:.2}x",
                        a.0 / a.1,
                        s.0 / s.1,
                        rr.0 / rr.1
                    );
                }
            }
        }
    }
}
