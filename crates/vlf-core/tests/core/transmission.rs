//! Surfaces that let light through, against analytic answers: an alpha-masked screen whose mask
//! removes half its area in fine stripes passes half the light of an emitter behind it (the
//! propagation, the final gather and the path tracer).

use crate::bakes;
use crate::bakes::Propagation;
use crate::scenes::{self, central_mean, receiver, striped_screen};
use glam::Vec3;
use vlf_core::bake::{BakeScene, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::{Converged, final_gather};
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::pathtrace::{PreparedScene, Rng};
use vlf_core::scene::Scene;

fn params() -> BakeParams {
    BakeParams {
        texel_scale: 2.0,
        perturb: 0,
        ..bakes::params(246, 64, Iterations::Fixed(1))
    }
}

/// The propagation's receiver irradiance (central mean), and its first-iteration light field
/// for the gather.
fn propagated(scene: &Scene) -> (f32, BakeScene, Vec<[f32; 4]>) {
    let params = params();
    let prep = BakeScene::new(scene, &params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let out = reference::propagate(&prep, &set, &params);
    let e = central_mean(scene, &prep, &out.irradiance, receiver(scene), 0.5);
    (e, prep, out.irradiance)
}

/// The propagation passes half the emitter's light through the half-cut screen (within 2 %:
/// the stripes are finer than the rays, which sample them at points the twisted grids spread
/// over both kinds of stripe), and the masked screen's texels keep half their area.
#[test]
fn a_half_cut_screen_passes_half_the_light_in_the_propagation() {
    let (open, _, _) = propagated(&striped_screen(false));
    let scene = striped_screen(true);
    let (half, prep, _) = propagated(&scene);
    let ratio = half / open;
    eprintln!("propagation: {half:.4} / {open:.4} = {ratio:.4}");
    assert!((ratio - 0.5).abs() < 0.01, "ratio {ratio}");
    // The screen's texels hold half the area its triangles cover.
    let screen = (0..scene.faces.len())
        .find(|&f| scene.faces[f].material == 2)
        .unwrap();
    let f = &prep.faces[screen];
    let area: f32 = (f.texel_base..f.texel_base + f.texels_per_side())
        .map(|t| prep.texel_area[t as usize])
        .sum();
    let whole = scene.to_vlf.apply_area(scene.faces[screen].area);
    assert!(
        (area / whole - 0.5).abs() < 0.01,
        "covered {area} of {whole}"
    );
}

/// The final gather's direct light (light samples with shadow rays, cosine rays) through the
/// screen: half, within 2 % (its own noise, 256 light samples per texel over the central
/// texels, is under 0.5 %).
#[test]
fn a_half_cut_screen_passes_half_the_light_in_the_final_gather() {
    let gp = crate::bakes::fixed_gather(2.0, 4.0, [256, 64, 4]);
    let mut means = Vec::new();
    for screen in [false, true] {
        let scene = striped_screen(screen);
        let (_, prep, irradiance) = propagated(&scene);
        let set = DirectionSet::at_least(params().directions).unwrap();
        let field = Converged {
            prep: &prep,
            irradiance: &irradiance,
            first_bounce: None,
            tiles: None,
            directions: &set,
            sky: Vec3::ZERO,
            ray_spacing: 2.0 / params().resolution as f32,
        };
        let g = final_gather(&scene, &field, &gp, 0).unwrap();
        means.push(central_mean(
            &scene,
            &g.atlas,
            &g.irradiance,
            receiver(&scene),
            0.5,
        ));
    }
    let ratio = means[1] / means[0];
    eprintln!(
        "final gather: {:.4} / {:.4} = {ratio:.4}",
        means[1], means[0]
    );
    assert!((ratio - 0.5).abs() < 0.01, "ratio {ratio}");
}

/// The path tracer sees the receiver (albedo ½) lit through the screen: half as bright,
/// within 2 % (4,096 paths per point over 64 points).
#[test]
fn a_half_cut_screen_passes_half_the_light_in_the_path_tracer() {
    let mut means = Vec::new();
    for screen in [false, true] {
        let scene = striped_screen(screen);
        let prep = PreparedScene::new(&scene);
        let mut sum = 0f64;
        let n = 8;
        for i in 0..n * n {
            // Points of the central 1 × 1 square, seen straight down from just above it.
            let x = -0.5 + ((i % n) as f32 + 0.5) / n as f32;
            let z = -0.5 + ((i / n) as f32 + 0.5) / n as f32;
            for s in 0..4096 {
                let mut rng = Rng::for_path(7, i, s);
                let l = prep.radiance(Vec3::new(x, 0.25, z), Vec3::NEG_Y, Vec3::ZERO, &mut rng);
                sum += f64::from(l.y);
            }
        }
        means.push(sum);
    }
    let ratio = (means[1] / means[0]) as f32;
    eprintln!("path tracer: ratio {ratio:.4}");
    assert!((ratio - 0.5).abs() < 0.01, "ratio {ratio}");
}

/// The thin pane's T(θ) = 1 − R(θ) of the shared conventions (Mitsuba's thindielectric:
/// R = r + (1 − r)² r / (1 − r²), r the Fresnel reflectance of one air–glass interface, IOR
/// 1.5): 0.92 at normal incidence, 0 at grazing.
#[test]
fn pane_transmittance_follows_the_thin_dielectric() {
    let t = |c: f32| 1.0 - vlf_core::scene::pane_reflectance(c, 1.5);
    // r(0°) = (0.5 / 2.5)² = 0.04: R = 0.08 / 1.04.
    assert!((t(1.0) - (1.0 - 0.08 / 1.04)).abs() < 1e-6, "{}", t(1.0));
    assert_eq!(t(0.0), 0.0);
    // r + (1 − r)² r / (1 − r²) against 2r / (1 + r), and monotone in the angle.
    let mut prev = -1.0;
    for i in 0..=100 {
        let c = i as f32 / 100.0;
        let ct = (1.0 - (1.0 - c * c) / 2.25).sqrt();
        let rs = (c - 1.5 * ct) / (c + 1.5 * ct);
        let rp = (1.5 * c - ct) / (1.5 * c + ct);
        let r = 0.5 * (rs * rs + rp * rp);
        let mitsuba = if r < 1.0 {
            r + (1.0 - r) * (1.0 - r) * r / (1.0 - r * r)
        } else {
            1.0
        };
        assert!((t(c) - (1.0 - mitsuba)).abs() < 1e-6, "at cos {c}");
        assert!(t(c) >= prev - 1e-7, "T rises with cos θ");
        prev = t(c);
    }
}

/// Propagated irradiance of the pane scene's receiver (central mean over |x|, |z| < 0.25).
fn pane_bake(scene: &Scene, sky: Vec3) -> f32 {
    let params = BakeParams { sky, ..params() };
    let prep = BakeScene::new(scene, &params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let out = reference::propagate(&prep, &set, &params);
    central_mean(scene, &prep, &out.irradiance, receiver(scene), 0.25)
}

/// A sun through a pane of transmission 1: the floor behind it receives T(θ) of what it
/// receives without the pane, at 0°, 45° and 70° (within 1 %: a sun is one direction, so only
/// the rays' sampling of the receiver's texels differs).
#[test]
fn a_pane_passes_t_of_theta_of_a_sun_in_the_propagation() {
    for deg in [0.0f32, 45.0, 70.0] {
        let th = deg.to_radians();
        let sun = vlf_core::scene::Sun {
            name: None,
            direction: Vec3::new(th.sin(), -th.cos(), 0.0),
            irradiance: Vec3::ONE,
        };
        let mut e = Vec::new();
        for pane in [false, true] {
            let mut scene = scenes::pane_over_floor(pane, 0.02);
            scene.suns.push(sun.clone());
            e.push(pane_bake(&scene, Vec3::ZERO));
        }
        let want = 1.0 - vlf_core::scene::pane_reflectance(th.cos(), 1.5);
        let ratio = e[1] / e[0];
        eprintln!(
            "sun at {deg}°: E {:.4} / {:.4} = {ratio:.4}, T = {want:.4}",
            e[1], e[0]
        );
        assert!(
            (e[0] - th.cos()).abs() < 0.01 * th.cos(),
            "unobstructed {}",
            e[0]
        );
        assert!(
            (ratio / want - 1.0).abs() < 0.01,
            "{deg}°: {ratio} vs {want}"
        );
    }
}

/// A uniform sky through a pane of transmission 1: the floor under it receives the sky's light
/// weighted by T(θ) over the directions through the pane (a quadrature of the convention's
/// T), within 1 %.
#[test]
fn a_pane_passes_t_of_theta_of_a_sky_in_the_propagation() {
    let scene = scenes::pane_over_floor(true, 0.02);
    let got = pane_bake(&scene, Vec3::ONE);
    let want = scenes::pane_sky_irradiance(0.02) as f32;
    eprintln!(
        "sky through a pane: E = {got:.4}, ∫ T cos dω = {want:.4} (π = {:.4})",
        std::f32::consts::PI
    );
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
}

/// The energy bookkeeping balances with panes: what their tints absorb, what leaves through
/// them and sunlight injected a second time behind them are accounted for (a grey tinted pane
/// over a grey floor under a sun and a sky, 3 iterations).
#[test]
fn panes_keep_the_energy_balance() {
    let scene = scenes::tinted_pane_in_sun();
    let params = BakeParams {
        sky: Vec3::new(0.3, 0.4, 0.5),
        iterations: Iterations::Fixed(3),
        ..params()
    };
    let (_, _, out) = crate::bakes::propagate(&scene, &params);
    let e = &out.energy;
    eprintln!(
        "pane energy: injected {:.4} absorbed {:.4} escaped {:.4} unshot {:.4}, imbalance {:+.3}%",
        e.injected,
        e.absorbed,
        e.escaped,
        e.unshot,
        100.0 * e.relative_imbalance()
    );
    assert!(
        e.relative_imbalance().abs() < 0.01,
        "{}",
        e.relative_imbalance()
    );
}

/// The final gather of the floor under the pane: the sky through the glass, weighted by T(θ)
/// (its cosine rays go on through panes), within 1 % of the quadrature of the convention's T;
/// and a sun through it, T(θ) of its unobstructed irradiance.
#[test]
fn a_pane_passes_t_of_theta_in_the_final_gather() {
    let gp = bakes::pane_gather();
    let gathered = |scene: &Scene, sky: Vec3| {
        let p = BakeParams { sky, ..params() };
        let out = Propagation::new(scene, &p);
        let field = Converged {
            first_bounce: None,
            ..out.converged(sky, 2.0 / p.resolution as f32)
        };
        let g = final_gather(scene, &field, &gp, 0).unwrap();
        central_mean(scene, &g.atlas, &g.irradiance, receiver(scene), 0.25)
    };
    scenes::check_pane_gather("final gather", gathered);
}

/// The path tracer looks at the sky through the pane from under it: T(θ) × the sky at 0°, 45°
/// and 70° (the pane reflects R(θ) of the view onto the black floor), within 1 % (20,000 paths
/// per angle: a standard error of 0.1–0.3 %).
#[test]
fn the_path_tracer_sees_t_of_theta_through_a_pane() {
    let scene = scenes::pane_over_floor(true, 0.02);
    let prep = PreparedScene::new(&scene);
    for deg in [0.0f32, 45.0, 70.0] {
        let th = deg.to_radians();
        let dir = Vec3::new(th.sin(), th.cos(), 0.0);
        let n = 20_000;
        let mut sum = 0f64;
        for s in 0..n {
            let mut rng = Rng::for_path(11, deg as u32, s);
            sum += f64::from(
                prep.radiance(Vec3::new(0.0, 0.01, 0.0), dir, Vec3::ONE, &mut rng)
                    .y,
            );
        }
        let got = (sum / f64::from(n)) as f32;
        let want = 1.0 - vlf_core::scene::pane_reflectance(th.cos(), 1.5);
        eprintln!("path tracer through a pane at {deg}°: {got:.4} vs T {want:.4}");
        assert!((got / want - 1.0).abs() < 0.01, "{deg}°: {got} vs {want}");
    }
}
