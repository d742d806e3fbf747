//! Point and spot lights (`KHR_lights_punctual`) against analytic answers, in every stage that
//! lights a scene: the propagation's injected first bounce (`bake::punctual`), the final
//! gather (fixed and guided/adaptive estimators), the path tracer, and the energy bookkeeping.
//!
//! A point light of intensity I at height h over a plane gives the irradiance
//! E = I·cos θ/d² = I·h/d³; a spot multiplies it by the extension's falloff
//! (`PunctualLight::attenuation`). Texels are compared with E's mean over the texel's square,
//! integrated here by a 32 × 32 midpoint rule (its own error is far below 1e-4 at these sizes);
//! the tolerance the issue sets is 1 %.

use crate::bakes::Propagation;
use glam::{Vec3, Vec4};
use vlf_core::bake::{BakeScene, punctual, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::{Converged, Gathered, final_gather};
use vlf_core::lightfield::{BakeParams, GatherParams, Iterations};
use vlf_core::pathtrace::{PinholeCamera, PreparedScene, RenderSettings, render};
use vlf_core::scene::{PunctualKind, PunctualLight, Scene, SceneBuilder};

/// Half the plane's edge (world units): large against the light's height 1.
const HALF: f32 = 2.0;

fn light(kind: PunctualKind, position: Vec3, intensity: f32) -> PunctualLight {
    PunctualLight {
        name: None,
        kind,
        position,
        direction: Vec3::NEG_Y,
        intensity: Vec3::new(1.0, 0.5, 0.25) * intensity,
        range: None,
    }
}

/// A square plane y = 0 facing +Y of albedo `albedo`, lit by `lights` alone.
fn plane_scene(albedo: f32, lights: Vec<PunctualLight>) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("plane", Vec3::splat(albedo), Vec3::ZERO);
    crate::scenes::up_square(&mut b, 0.0, HALF, m);
    let mut scene = b.build("lit plane");
    scene.lights = lights;
    scene
}

/// The irradiance of `l` at world point `p` of a surface of normal `n`, unoccluded.
fn analytic(l: &PunctualLight, p: Vec3, n: Vec3) -> Vec3 {
    let to = l.position - p;
    let d = to.length();
    let wi = to / d;
    let cos = n.dot(wi).max(0.0);
    l.intensity * (l.attenuation(-wi.dot(l.direction), d) * cos / (d * d))
}

/// The mean of [`analytic`] (red channel) over atlas texel `t`'s square, in world space.
fn texel_mean(prep: &BakeScene, scene: &Scene, t: usize, l: &PunctualLight) -> f32 {
    let fi = prep
        .faces
        .iter()
        .position(|f| {
            let base = f.texel_base as usize;
            (base..base + 2 * f.texels_per_side() as usize).contains(&t)
        })
        .unwrap();
    let f = &prep.faces[fi];
    let i = (t as u32 - f.texel_base) % f.texels_per_side();
    let (x, y) = ((i % f.width) as f32, (i / f.width) as f32);
    let k = 32;
    let mut sum = 0.0f64;
    for a in 0..k {
        for b in 0..k {
            let c = glam::Vec2::new(
                x + (a as f32 + 0.5) / k as f32,
                y + (b as f32 + 0.5) / k as f32,
            ) * f.texel_size;
            let q = Vec3::from(f.origin) + Vec3::from(f.u) * c.x + Vec3::from(f.v) * c.y;
            let p = scene.to_vlf.inverse(q);
            sum += f64::from(analytic(l, p, Vec3::Y).x);
        }
    }
    (sum / f64::from(k * k)) as f32
}

/// Side-0 texels of face 0 whose square lies wholly on the plane: (texel, world centre).
fn full_texels(prep: &BakeScene, scene: &Scene) -> Vec<(usize, Vec3)> {
    let f = &prep.faces[0];
    (0..f.texels_per_side())
        .map(|i| (f.texel_base + i) as usize)
        .filter(|&t| prep.texel_area[t] >= 0.999 * f.texel_size * f.texel_size)
        .map(|t| {
            let c = Vec4::from(prep.texel_center[t]).truncate();
            (t, scene.to_vlf.inverse(c))
        })
        .collect()
}

fn params(iterations: Iterations) -> BakeParams {
    BakeParams {
        directions: 46,
        resolution: 64,
        tile: 4,
        texel_scale: 1.0,
        iterations,
        perturb: 0,
        ..BakeParams::paper()
    }
}

/// The propagation's injected first bounce: every fully covered texel of a plane under a point
/// light holds the texel's mean of I·cos θ/d² within 1 %, the plane's underside nothing, and
/// the propagated irradiance (one plane cannot light itself) is exactly that.
#[test]
fn a_point_light_over_a_plane_injects_i_cos_over_d_squared() {
    let l = light(PunctualKind::Point, Vec3::new(0.4, 1.0, -0.3), 5.0);
    let scene = plane_scene(0.5, vec![l.clone()]);
    let p = params(Iterations::Fixed(2));
    let prep = BakeScene::new(&scene, &p).unwrap();
    let injected = punctual::injected_irradiance(&prep, 0).expect("the scene has a lamp");
    let texels = full_texels(&prep, &scene);
    assert!(texels.len() > 100, "{} texels", texels.len());
    let mut worst = 0.0f32;
    for &(t, _) in &texels {
        let want = texel_mean(&prep, &scene, t, &l);
        let got = Vec4::from(injected[t]);
        worst = worst.max((got.x / want - 1.0).abs());
        // The colour is the light's: (1, 0.5, 0.25) × intensity.
        assert!((got.y / got.x - 0.5).abs() < 1e-5 && (got.z / got.x - 0.25).abs() < 1e-5);
        let back = t + prep.faces[0].texels_per_side() as usize;
        assert_eq!(injected[back], [0.0; 4], "the underside faces away");
    }
    eprintln!("point light, injected: worst texel relative error {worst:.2e}");
    assert!(worst < 0.01, "worst texel {worst}");
    // Thread-count independent.
    assert_eq!(
        punctual::injected_irradiance(&prep, 1),
        Some(injected.clone())
    );
    assert_eq!(
        punctual::injected_irradiance(&prep, 3),
        Some(injected.clone())
    );
    // Propagated: the first iteration's injected light, nothing else.
    let set = DirectionSet::at_least(p.directions).unwrap();
    let out = reference::propagate(&prep, &set, &p);
    assert_eq!(out.irradiance, injected);
    assert_eq!(out.first_bounce.as_deref(), Some(&injected[..]));
    let power: f64 = injected
        .iter()
        .zip(&prep.texel_area)
        .map(|(e, a)| f64::from(e[0] + e[1] + e[2]) * f64::from(*a))
        .sum();
    assert!(
        (out.energy.injected / power - 1.0).abs() < 1e-6,
        "{:?}",
        out.energy
    );
}

/// Energy bookkeeping and the later bounces: a closed box of albedo ρ with a point light
/// inside. All of the light's 4πI reaches the walls (Σ E·A of the injected light), and at
/// convergence the walls receive 4πI/(1 − ρ) in all (each bounce re-emits ρ of what arrives):
/// the propagation carries the lamp's later bounces.
#[test]
fn a_point_light_in_a_closed_box_conserves_energy() {
    let rho = 0.5;
    let mut b = SceneBuilder::new();
    let m = b.diffuse("walls", Vec3::splat(rho), Vec3::ZERO);
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, m);
    let mut scene = b.build("lamp in a box");
    let i = 2.0f32;
    scene.lights = vec![PunctualLight {
        intensity: Vec3::splat(i),
        ..light(PunctualKind::Point, Vec3::new(0.2, 0.3, -0.1), 1.0)
    }];
    let p = params(Iterations::Converge {
        threshold: 1e-5,
        max: 100,
    });
    let (prep, _, out) = crate::bakes::propagate(&scene, &p);
    let s2 = f64::from(scene.to_vlf.scale).powi(2);
    let sum = |e: &[[f32; 4]]| -> f64 {
        e.iter()
            .zip(&prep.texel_area)
            .map(|(e, a)| f64::from(e[0]) * f64::from(*a))
            .sum::<f64>()
            / s2
    };
    let four_pi_i = 4.0 * std::f64::consts::PI * f64::from(i);
    let direct = sum(out.first_bounce.as_deref().unwrap());
    let total = sum(&out.irradiance);
    eprintln!(
        "lamp in a box: direct {:.4} (4πI {four_pi_i:.4}), total {:.4} (4πI/(1 − ρ) {:.4}), \
         imbalance {:.2e}, {} iterations",
        direct,
        total,
        four_pi_i / (1.0 - f64::from(rho)),
        out.energy.relative_imbalance(),
        out.iterations
    );
    assert!((direct / four_pi_i - 1.0).abs() < 0.005, "direct {direct}");
    assert!(
        (total / (four_pi_i / (1.0 - f64::from(rho))) - 1.0).abs() < 0.01,
        "total {total}"
    );
    // What the lamp injects is counted: emitted 0 + injected = absorbed + escaped + unshot.
    assert_eq!(out.energy.emitted, 0.0);
    assert!((out.energy.injected / (3.0 * direct * s2) - 1.0).abs() < 1e-6);
    assert!(
        out.energy.relative_imbalance().abs() < 1e-3,
        "{:?}",
        out.energy
    );
}

fn gather(scene: &Scene, gp: &GatherParams) -> Gathered {
    let p = params(Iterations::Fixed(2));
    let prop = Propagation::new(scene, &p);
    let field = Converged {
        tiles: None,
        ..prop.converged(Vec3::ZERO, 2.0 / p.resolution as f32)
    };
    final_gather(scene, &field, gp, 0).unwrap()
}

fn fixed() -> GatherParams {
    crate::bakes::fixed_gather(0.5, 2.0, [64, 16, 16])
}

/// The default guided and adaptive gather (with its denoiser), at the test's texel sizes.
fn guided() -> GatherParams {
    GatherParams {
        texel_scale: 0.5,
        indirect_texel_scale: 2.0,
        ..vlf_core::bake::Quality::Auto.preset().gather
    }
}

/// The final gather (fixed-count and the default guided/adaptive estimator): each stored texel
/// of a plane under a point light holds I·cos θ/d² (its texel mean) within 1 %.
#[test]
fn the_gather_samples_a_point_light_exactly() {
    let l = light(PunctualKind::Point, Vec3::new(-0.5, 1.0, 0.2), 5.0);
    let scene = plane_scene(0.5, vec![l.clone()]);
    for (name, gp) in [("fixed", fixed()), ("guided", guided())] {
        let g = gather(&scene, &gp);
        let texels = full_texels(&g.atlas, &scene);
        assert!(texels.len() > 1000, "{} texels", texels.len());
        let mut worst = 0.0f32;
        for &(t, _) in &texels {
            let want = texel_mean(&g.atlas, &scene, t, &l);
            worst = worst.max((g.irradiance[t][0] / want - 1.0).abs());
        }
        eprintln!("point light, {name} gather: worst texel relative error {worst:.2e}");
        assert!(worst < 0.01, "{name}: worst texel {worst}");
    }
}

/// A spot pointing straight down from height h lights a disc of radius h·tan(outer) on the
/// plane, in the propagation's injection and in the gather: texels wholly inside the inner
/// cone get the analytic irradiance (1 %), texels wholly outside the outer cone nothing, and
/// Σ E·area is the power the cone carries, I·2π∫₀^outer falloff(α)·sin α dα (1 %). A soft cone
/// follows the extension's falloff between its angles (every texel within 1 % of the peak of
/// its texel mean); a hard one's edge crosses texels, which its sample points resolve to a
/// sixteenth of the injection's texels.
#[test]
fn a_spot_lights_a_disc_of_the_cones_radius_with_the_smooth_falloff() {
    let h = 1.0;
    for (inner, outer) in [(0.345f32, 0.35f32), (0.2, 0.5)] {
        let l = light(
            PunctualKind::Spot { inner, outer },
            Vec3::new(0.1, h, -0.2),
            5.0,
        );
        let scene = plane_scene(0.0, vec![l.clone()]);
        let radius = h * outer.tan();
        let peak = l.intensity.x / (h * h);
        let steps = 100_000;
        let cone_power: f64 = (0..steps)
            .map(|k| {
                let a = (k as f32 + 0.5) / steps as f32 * outer;
                f64::from(l.attenuation(a.cos(), 1.0) * a.sin() * outer / steps as f32)
            })
            .sum::<f64>()
            * 2.0
            * std::f64::consts::PI
            * f64::from(l.intensity.x);
        let p = params(Iterations::Fixed(1));
        let prep = BakeScene::new(&scene, &p).unwrap();
        let injected = punctual::injected_irradiance(&prep, 0).unwrap();
        let g = gather(&scene, &fixed());
        for (stage, atlas, e) in [
            ("injected", &prep, &injected),
            ("gathered", &g.atlas, &g.irradiance),
        ] {
            let half_diag = atlas.texel_size / scene.to_vlf.scale * std::f32::consts::SQRT_2 / 2.0;
            let (mut inside, mut outside, mut worst) = (0, 0, 0.0f32);
            for (t, c) in full_texels(atlas, &scene) {
                let r = (c - l.position).with_y(0.0).length();
                let got = e[t][0];
                let want = texel_mean(atlas, &scene, t, &l);
                worst = worst.max((got - want).abs() / peak);
                if r + half_diag < h * inner.tan() {
                    inside += 1;
                    assert!(
                        (got / want - 1.0).abs() < 0.01,
                        "{stage}: {got} vs {want} at {c}"
                    );
                } else if r - half_diag > radius {
                    outside += 1;
                    assert_eq!(got, 0.0, "{stage}: light outside the cone at {c}");
                }
            }
            let f = &atlas.faces[0];
            let front = f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize;
            let power = front
                .map(|t| f64::from(e[t][0]) * f64::from(atlas.texel_area[t]))
                .sum::<f64>()
                / f64::from(scene.to_vlf.scale).powi(2);
            eprintln!(
                "spot {inner}–{outer} rad, {stage}: {inside} texels inside, {outside} outside, \
                 worst |E − texel mean| / peak {worst:.2e}; power {power:.5} vs the cone's \
                 {cone_power:.5}"
            );
            assert!(inside > 4 && outside > 100, "{stage}: {inside} {outside}");
            assert!(
                (power / cone_power - 1.0).abs() < 0.01,
                "{stage}: power {power}"
            );
            if inner < outer - 0.1 {
                assert!(worst < 0.01, "{stage}: worst {worst}");
            }
        }
    }
}

/// The path tracer's next-event estimation: a pixel seeing a small patch of a Lambertian plane
/// of albedo a under a point light reads a/π · I·cos θ/d² within 1 %, and one under a spot the
/// falloff between the cone's angles and nothing outside it (the lights themselves are
/// invisible: the camera looks through them).
#[test]
fn the_path_tracer_reads_point_and_spot_lights_radiometrically() {
    let a = 0.6;
    let point = light(PunctualKind::Point, Vec3::new(0.3, 1.0, 0.0), 5.0);
    let spot = light(
        PunctualKind::Spot {
            inner: 0.2,
            outer: 0.5,
        },
        Vec3::new(0.0, 1.0, 0.0),
        5.0,
    );
    for l in [point, spot] {
        let scene = plane_scene(a, vec![l.clone()]);
        let prep = PreparedScene::new(&scene);
        for r in [0.0f32, 0.3, 0.45, 0.8] {
            let at = Vec3::new(r, 0.0, 0.0);
            // One pixel 0.02° wide seen from 3 above: a patch 1 mm across.
            let camera =
                PinholeCamera::look_at(at + Vec3::new(0.0, 3.0, 0.0), at, 0.02, 1, 1).unwrap();
            let settings = RenderSettings {
                width: 1,
                height: 1,
                spp: 16,
                seed: 5,
                sky: Vec3::ZERO,
                threads: 1,
            };
            let img = render(&prep, &camera, &settings, &|_, _| {}).unwrap();
            let got = img.pixels[0][0];
            let want = a / std::f32::consts::PI * analytic(&l, at, Vec3::Y).x;
            eprintln!("{:?} at r = {r}: {got} vs {want}", l.kind);
            if want == 0.0 {
                assert_eq!(got, 0.0, "{:?} at r = {r}", l.kind);
            } else {
                assert!(
                    (got / want - 1.0).abs() < 0.01,
                    "{:?} at r = {r}: {got} vs {want}",
                    l.kind
                );
            }
        }
    }
}
