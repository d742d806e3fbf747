//! Surfaces that let light through, against analytic answers: an alpha-masked screen whose mask
//! removes half its area in fine stripes passes half the light of an emitter behind it (the
//! propagation, the final gather and the path tracer).

#[path = "../../../tests/src/scenes.rs"]
mod scenes;

use glam::Vec3;
use scenes::{central_mean, receiver, striped_screen};
use vlf_core::bake::{BakeScene, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::{Converged, final_gather};
use vlf_core::lightfield::{BakeParams, GatherParams, Iterations, Sampling};
use vlf_core::pathtrace::{PreparedScene, Rng};
use vlf_core::scene::Scene;

fn params() -> BakeParams {
    BakeParams {
        directions: 246,
        resolution: 64,
        tile: 8,
        texel_scale: 2.0,
        iterations: Iterations::Fixed(1),
        perturb: 0,
        ..BakeParams::paper()
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
    let gp = GatherParams {
        texel_scale: 2.0,
        indirect_texel_scale: 4.0,
        light_samples: 256,
        direct_rays: 64,
        indirect_rays: 4,
        sampling: Sampling::FIXED,
        denoise: false,
    };
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
