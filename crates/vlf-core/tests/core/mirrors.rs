//! Mirrors and mixed surfaces in the CPU reference propagator against analytic answers.

use crate::bakes::{params, propagate};
use crate::scenes::{hquad, hrect};
use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::scene::{Scene, SceneBuilder};

/// A mirror facing a uniformly emitting plane returns reflectance × emission along the
/// reflected rays.
#[test]
fn mirror_facing_uniform_emitter_reflects_rho_times_emission() {
    let (le, rho) = (Vec3::new(2.0, 1.0, 0.5), 0.8);
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, le);
    let m = b.mirror("mirror", Vec3::splat(rho));
    hquad(&mut b, 0.2, 3.0, false, light); // large emitter just above, facing down
    hquad(&mut b, 0.0, 0.5, true, m); // mirror facing up
    let scene = b.build("mirror under emitter");
    let (prep, set, out) = propagate(&scene, &params(126, 64, Iterations::Fixed(2)));
    let (index, values) = out.tiles.as_ref().expect("tiles for the mirror");
    let mirror_face = prep.faces.iter().position(|f| f.kind != 0).unwrap() as u32;
    let (mut checked, mut worst) = (0, 0.0f32);
    for j in 0..set.len() as u32 {
        let w = set.direction(j as usize);
        // Directions leaving the mirror upward within 40° of its normal: their reflected rays
        // come from the emitter, which covers everything within ~86° of the mirror's centre.
        let (sense, up) = if w.y > 0.0 { (0, w) } else { (1, -w) };
        if up.y < 40f32.to_radians().cos() {
            continue;
        }
        let frame = vlf_core::psf::fixed_frame(&set, j as usize);
        // The ray through the mirror's centre.
        let q = frame.to_psf(scene.to_vlf.apply(Vec3::ZERO));
        let (ci, cj) = vlf_core::psf::cell_at(q.x, q.y, index.n);
        let i = index
            .value_index(mirror_face, j, sense, ci, cj)
            .expect("centre cell stored");
        let got = Vec4::from(values[i]).truncate();
        let dev = ((got - le * rho).abs() / (le * rho)).max_element();
        worst = worst.max(dev);
        checked += 1;
    }
    assert!(checked > 5, "only {checked} directions checked");
    // Exact by construction (splat weights are normalised per destination direction); the
    // bound only absorbs f32 rounding.
    assert!(
        worst < 1e-3,
        "worst relative deviation {worst} over {checked} directions"
    );
}

/// Point-to-rectangle form factor (parallel planes): from a point facing the rectangle
/// [x0, x1] × [y0, y1] at distance d (coordinates relative to the point's foot).
fn ff_rect(x0: f64, x1: f64, y0: f64, y1: f64, d: f64) -> f64 {
    let corner = |a: f64, b: f64| {
        // signed: rectangle [0, a] × [0, b]
        let sa = (a * a + d * d).sqrt();
        let sb = (b * b + d * d).sqrt();
        ((a / sa) * (b / sa).atan() + (b / sb) * (a / sb).atan()) / (2.0 * std::f64::consts::PI)
    };
    corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)
}

/// Two parallel mirrors (reflectance ρ) between a light and a receiver: the receiver sees the
/// light and its images in the mirrors, the k-th image weakened by ρ^k (a geometric series).
#[test]
fn parallel_mirrors_give_the_geometric_series() {
    let (le, rho, rho_recv) = (1.0f32, 0.5f32, 0.5f32);
    let (len, h, depth) = (1.0f32, 0.5f32, 0.5f32); // corridor x ∈ [-len, len], y ∈ [0, h], z ∈ [-depth, depth]
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(le));
    let recv = b.diffuse("receiver", Vec3::splat(rho_recv), Vec3::ZERO);
    let m = b.mirror("mirror", Vec3::splat(rho));
    // Emitter at x = -len facing +x; receiver at x = +len facing −x.
    b.quad(
        [
            Vec3::new(-len, 0.0, -depth),
            Vec3::new(-len, h, -depth),
            Vec3::new(-len, h, depth),
            Vec3::new(-len, 0.0, depth),
        ],
        light,
    );
    b.quad(
        [
            Vec3::new(len, 0.0, -depth),
            Vec3::new(len, 0.0, depth),
            Vec3::new(len, h, depth),
            Vec3::new(len, h, -depth),
        ],
        recv,
    );
    // Floor mirror facing up, ceiling mirror facing down.
    hrect(&mut b, 0.0, (-len, len), (-depth, depth), true, m);
    hrect(&mut b, h, (-len, len), (-depth, depth), false, m);
    let scene = b.build("mirror corridor");
    let (prep, _set, out) = propagate(
        &scene,
        &params(
            501,
            64,
            Iterations::Converge {
                threshold: 1e-5,
                max: 40,
            },
        ),
    );
    // Analytic irradiance at the receiver's centre (x = len, y = h/2, z = 0): images k of the
    // emitter occupy y ∈ [k h, (k+1) h] in the unfolded corridor, weakened by ρ^|k|.
    let d = f64::from(2.0 * len);
    let mut f = 0.0;
    for k in -40i32..=40 {
        let y0 = f64::from(k as f32 * h - 0.5 * h);
        let y1 = y0 + f64::from(h);
        f += f64::from(rho).powi(k.abs()) * ff_rect(-f64::from(depth), f64::from(depth), y0, y1, d);
    }
    let want = rho_recv * le * f as f32; // receiver radiance = ρ_r · L_e · Σ ρ^|k| F_k
    let direct_only = rho_recv
        * le
        * ff_rect(
            -f64::from(depth),
            f64::from(depth),
            -f64::from(h) / 2.0,
            f64::from(h) / 2.0,
            d,
        ) as f32;
    let ri = scene.faces.iter().position(|f| f.normal.x < -0.5).unwrap();
    let rf = prep.faces[ri];
    // Mean over the receiver texels within 0.1 of its centre.
    let (mut sum, mut n) = (0.0, 0);
    let radiance = prep.outgoing_radiance(&out.irradiance);
    for t in rf.texel_base as usize..(rf.texel_base + rf.texels_per_side()) as usize {
        let p = scene
            .to_vlf
            .inverse(Vec4::from(prep.texel_center[t]).truncate());
        if prep.texel_area[t] > 0.0 && (p.y - h / 2.0).abs() < 0.1 && p.z.abs() < 0.1 {
            sum += radiance[t][0];
            n += 1;
        }
    }
    let got = sum / n as f32;
    eprintln!(
        "receiver radiance {got:.5}, analytic {want:.5} (direct only {direct_only:.5}), {} iterations",
        out.iterations
    );
    assert!(n > 0);
    // Measured: 0.7 % (0.04517 vs 0.04484). Bound 4 %: quadrature of 501 directions, and the
    // centre patch averages ±0.1 around the analytic point.
    assert!((got - want).abs() / want < 0.04, "got {got} want {want}");
    assert!(got > direct_only * 1.2, "the images must add light");
}

/// A mirror sending light onto a diffuse wall: the caustic's total power equals the power the
/// mirror reflects (ρ × incident) within 2 %. The mirror is tilted 45° so the reflected beam
/// leaves sideways (nothing but the wall is in its way).
#[test]
fn caustic_energy_matches_reflected_energy() {
    let (le, rho, wall_albedo) = (Vec3::splat(10.0), 0.9f32, 0.5f32);
    let build = |mirror_kind: Option<f32>| {
        let mut b = SceneBuilder::new();
        let light = b.diffuse("light", Vec3::ZERO, le);
        let wall = b.diffuse("wall", Vec3::splat(wall_albedo), Vec3::ZERO);
        let mm = match mirror_kind {
            Some(r) => b.mirror("mirror", Vec3::splat(r)),
            None => b.diffuse("white", Vec3::ONE, Vec3::ZERO),
        };
        hquad(&mut b, 0.0, 0.15, true, light); // light facing up
        // Mirror centred 1.5 above the light, normal (1, −1, 0)/√2: up-going light → +x; the
        // reflected beam passes right of the light (which would absorb it).
        let (c, s) = (0.5f32, 0.7f32);
        b.quad(
            [
                Vec3::new(-c, 1.5 - c, -s),
                Vec3::new(c, 1.5 + c, -s),
                Vec3::new(c, 1.5 + c, s),
                Vec3::new(-c, 1.5 - c, s),
            ],
            mm,
        );
        // Wall at x = 2.5 facing −x.
        b.quad(
            [
                Vec3::new(2.5, -3.0, -3.0),
                Vec3::new(2.5, -3.0, 3.0),
                Vec3::new(2.5, 3.0, 3.0),
                Vec3::new(2.5, 3.0, -3.0),
            ],
            wall,
        );
        b.build("caustic")
    };
    let p = params(501, 128, Iterations::Fixed(2));
    // Power arriving at the mirror: the same face as a white diffuser (L = E/π after 1 bounce).
    let white_scene = build(None);
    let (prep_w, _, white) = propagate(
        &white_scene,
        &BakeParams {
            iterations: Iterations::Fixed(1),
            ..p.clone()
        },
    );
    let wf = white_scene
        .faces
        .iter()
        .position(|f| f.normal.x > 0.5 && f.normal.y < -0.5)
        .unwrap();
    let incident = face_power(
        &prep_w,
        &prep_w.outgoing_radiance(&white.irradiance),
        wf,
        1.0,
    );
    // Wall power with the mirror minus with an absorbing mirror = the caustic.
    let mirror_scene = build(Some(rho));
    let (prep_m, _, with_mirror) = propagate(&mirror_scene, &p);
    let (_, _, black) = propagate(&build(Some(0.0)), &p);
    let ff = mirror_scene
        .faces
        .iter()
        .position(|f| f.normal.x < -0.5)
        .unwrap();
    let caustic = face_power(
        &prep_m,
        &prep_m.outgoing_radiance(&with_mirror.irradiance),
        ff,
        wall_albedo,
    ) - face_power(
        &prep_m,
        &prep_m.outgoing_radiance(&black.irradiance),
        ff,
        wall_albedo,
    );
    let reflected = f64::from(rho) * incident;
    eprintln!("incident {incident:.5}, reflected {reflected:.5}, caustic {caustic:.5}");
    // Measured: −0.9 % (0.02300 vs 0.02320).
    assert!(
        (caustic - reflected).abs() / reflected < 0.02,
        "caustic {caustic} vs reflected {reflected}"
    );
}

/// Received power of a face's front side: Σ π·L/albedo·area (L = ρE/π).
fn face_power(prep: &BakeScene, rad: &[[f32; 4]], face: usize, albedo: f32) -> f64 {
    let f = prep.faces[face];
    (f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize)
        .map(|t| {
            f64::from(rad[t][0]) * std::f64::consts::PI / f64::from(albedo)
                * f64::from(prep.texel_area[t])
        })
        .sum()
}

/// `n³` small square mirrors (ρ = 1, side `side`) on a lattice of spacing 1 centred on the
/// origin, each turned its own way (normals spread by golden-ratio angles).
fn mirror_cloud(n: usize, side: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.mirror("mirror", Vec3::ONE);
    let c = (n as f32 - 1.0) / 2.0;
    for i in 0..n * n * n {
        let centre = Vec3::new((i % n) as f32, (i / n % n) as f32, (i / (n * n)) as f32) - c;
        let cos_t = 1.0 - 2.0 * ((i as f32 * 0.618_034 + 0.3) % 1.0);
        let phi = i as f32 * 2.399_963;
        let normal = Vec3::new(
            (1.0 - cos_t * cos_t).sqrt() * phi.cos(),
            cos_t,
            (1.0 - cos_t * cos_t).sqrt() * phi.sin(),
        );
        let u = normal.any_orthonormal_vector() * (side / 2.0);
        let v = normal.cross(u);
        b.quad(
            [
                centre - u - v,
                centre + u - v,
                centre + u + v,
                centre - u + v,
            ],
            m,
        );
    }
    b.build("mirror cloud")
}

/// Mirrors smaller than a ray cell (issue 16: cornell-suzanne's Suzanne, 3,883 faces most
/// smaller than a cell): perfect mirrors (ρ = 1) under a uniform sky reflect all they receive,
/// so after the first iteration the unshot power (tiles and texels) equals the injected
/// power, and every later iteration sends on what it received. A ray crosses a sub-cell face
/// in only some directions: its texels' irradiance is normalised over those, but the tiles
/// receive only their light, so these mirrors kept 5.6 % of what they received (imbalance
/// +94 %); the share the rays cannot carry into the tiles now leaves diffusely. Mirrors four
/// cells wide are reached from all but grazing directions and keep their tiles.
#[test]
fn sub_cell_mirrors_reflect_all_they_receive() {
    let p = |iterations| BakeParams {
        sky: Vec3::ONE,
        ..params(126, 32, iterations)
    };
    let grid = vlf_core::psf::PsfGrid::new(32, 8).unwrap();
    // Lattice 4 × 4 × 4 in a scene of radius ≈ 2.6 (cells ≈ 0.16 wide): sides 0.04 and 0.65.
    for (side, sub_cell) in [(0.04f32, true), (0.65, false)] {
        let scene = mirror_cloud(4, side);
        let (prep, set, out) = propagate(&scene, &p(Iterations::Fixed(1)));
        let cell = grid.cell_size();
        let face_side = side * scene.to_vlf.scale;
        assert_eq!(
            sub_cell,
            face_side < cell,
            "side {face_side} against cell {cell}"
        );
        let (dirs, _) = reference::all_directions(&prep, &set, &p(Iterations::Fixed(1)));
        let spec = reference::SpecularSetup::new(&prep, &set, &grid, &dirs).unwrap();
        let unresolved = spec.unresolved.iter().sum::<f32>() / prep.faces.len() as f32;
        if sub_cell {
            assert!(
                unresolved > 0.5,
                "sub-cell mirrors: unresolved {unresolved}"
            );
        } else {
            // Missed only by rays at grazing angles.
            assert!(
                unresolved < 0.01,
                "mirrors four cells wide: unresolved {unresolved}"
            );
        }
        // A sub-cell face's tiles hold its reflection in whole cells, in the directions whose
        // grid has a cell centre on it: right on average over faces and directions, but with
        // 64 faces 1.8 % over (scans of 64–512 faces of sides 0.1–0.7 cells: −1.1 to +3.4 %).
        let bound = if sub_cell { 0.05 } else { 0.02 };
        let e = &out.energy;
        assert!(
            e.injected > 0.0 && e.absorbed.abs() < 1e-6 * e.injected,
            "{e:?}"
        );
        eprintln!("side {side}: first iteration {:.4}", e.unshot / e.injected);
        assert!(
            e.relative_imbalance().abs() < bound,
            "side {side}: the first iteration keeps {:.3} of what it received: {e:?}",
            e.unshot / e.injected
        );
        let (_, _, out) = propagate(&scene, &p(Iterations::Fixed(4)));
        let e = &out.energy;
        eprintln!("side {side}: 4 iterations {:.4}", e.relative_imbalance());
        assert!(
            e.relative_imbalance().abs() < bound,
            "side {side}, 4 iterations: imbalance {:.3} %: {e:?}",
            100.0 * e.relative_imbalance()
        );
    }
}

/// The same sub-cell mirrors under a sun instead of the sky balance too. A sun's light is not
/// renormalised over the directions that reach a texel, but the sun's reflect jobs reach a
/// sub-cell face's tiles as rarely as the quadrature's do, so the unresolved share of it must
/// leave diffusely as well (taking it from the sky's light only lost ~100 % here).
#[test]
fn sub_cell_mirrors_under_a_sun_keep_what_they_receive() {
    let p = |iterations| BakeParams {
        sky: Vec3::ZERO,
        ..params(126, 32, iterations)
    };
    for side in [0.04f32, 0.65] {
        let mut scene = mirror_cloud(4, side);
        scene.suns.push(vlf_core::scene::Sun {
            name: None,
            direction: Vec3::new(0.3, -1.0, -0.4).normalize(),
            irradiance: Vec3::splat(2.0),
        });
        let (_, _, out) = propagate(&scene, &p(Iterations::Fixed(1)));
        let e = &out.energy;
        eprintln!(
            "side {side} under a sun: first iteration {:.4}",
            e.unshot / e.injected
        );
        assert!(e.injected > 0.0, "{e:?}");
        assert!(
            e.relative_imbalance().abs() < 0.05,
            "side {side}: the first iteration keeps {:.3} of what it received: {e:?}",
            e.unshot / e.injected
        );
    }
}
