//! The path tracer's translucent surfaces (`pathtrace::walk`, `docs/SUBSURFACE.md`): the
//! random walk inside a dipole material's medium, against conservation (a white furnace) and
//! against the dipole's total diffuse reflectance; thin diffuse transmission against its
//! albedos.

use crate::bakes;
use glam::{Vec2, Vec3};
use vlf_core::pathtrace::{PreparedScene, Rng, sampling};
use vlf_core::scene::{Scene, SceneBuilder, Translucency, dipole};

/// The albedo of the surface point `p` (normal `n`) under a uniform sky of radiance 1: the
/// mean radiance seen along cosine-distributed directions towards it (reciprocity), with its
/// standard error.
fn albedo(scene: &Scene, p: Vec3, n: Vec3, paths: u32, jitter: f32) -> (Vec3, Vec3) {
    let ps = PreparedScene::new(scene);
    let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for i in 0..paths {
        let mut rng = Rng::for_path(7, i, 0);
        let w = sampling::to_world(sampling::cosine_hemisphere(rng.next_2d()), n);
        let (t1, t2) = sampling::basis(n);
        let u = rng.next_2d() - Vec2::splat(0.5);
        let target = p + (t1 * u.x + t2 * u.y) * jitter;
        let origin = target + w * 0.01;
        let l = ps.radiance(origin, -w, Vec3::ONE, &mut rng).as_dvec3();
        sum += l;
        sum2 += l * l;
    }
    let n = f64::from(paths);
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(glam::DVec3::ZERO);
    (mean.as_vec3(), (var / n).sqrt().as_vec3())
}

/// A white (non-absorbing) scattering cube under a uniform sky returns all the light that
/// enters it, whatever its boundary: the furnace. With η = 1.5 the paths meet Fresnel
/// reflection and total internal reflection inside; with η = 1 none.
#[test]
fn white_medium_furnace() {
    for eta in [1.0f32, 1.5] {
        let mut b = SceneBuilder::new();
        let m = b.diffuse("milk", Vec3::ONE, Vec3::ZERO);
        b.translucent(
            m,
            Translucency::Dipole {
                sigma_s_prime: Vec3::new(5.0, 10.0, 20.0),
                sigma_a: Vec3::ZERO,
                eta,
            },
        );
        b.aabox(Vec3::splat(-0.5), Vec3::splat(0.5), false, m);
        let scene = b.build("white cube");
        let (a, se) = albedo(&scene, Vec3::new(0.0, 0.5, 0.0), Vec3::Y, 20000, 0.9);
        eprintln!("η {eta}: albedo {a:?} ± {se:?}");
        for c in 0..3 {
            // 4 standard errors, and the paths of a furnace carry exactly 1 each where no
            // spectral weights differ: the error is the walk's if any.
            assert!(
                (a[c] - 1.0).abs() < 4.0 * se[c] + 1e-3,
                "η {eta} channel {c}: {}",
                a[c]
            );
        }
    }
}

/// A thick slab of Jensen's marble (50 × 50 × 20 cm: over 20 diffusion lengths 1/σ_tr each
/// way) under a uniform sky: the walk's albedo against the bake's model of it,
/// F_dr,ext + (1 − F_dr,ext)·R_d,total. The dipole's diffusion approximation is accurate at
/// marble's reduced albedo (0.999); the tolerance, 3 %, allows for the remaining difference of
/// the two physics (measured below) and the walk's noise (4 standard errors).
#[test]
fn marble_slab_walk_against_dipole() {
    let sp = [2.19f32, 2.62, 3.00];
    let sa = [0.0021f32, 0.0041, 0.0071];
    let mut b = SceneBuilder::new();
    let m = b.diffuse("marble", Vec3::ONE, Vec3::ZERO);
    b.translucent(
        m,
        Translucency::Dipole {
            sigma_s_prime: Vec3::from_array(sp) * 1000.0,
            sigma_a: Vec3::from_array(sa) * 1000.0,
            eta: 1.5,
        },
    );
    b.aabox(
        Vec3::new(-0.25, -0.2, -0.25),
        Vec3::new(0.25, 0.0, 0.25),
        false,
        m,
    );
    let scene = b.build("marble slab");
    let (a, se) = albedo(&scene, Vec3::ZERO, Vec3::Y, 40000, 0.01);
    let f = dipole::fresnel_diffuse_external(1.5);
    for c in 0..3 {
        let d = dipole::Dipole::new(f64::from(sp[c]), f64::from(sa[c]), 1.5);
        let model = f + (1.0 - f) * d.total_reflectance();
        let err = f64::from(a[c]) / model - 1.0;
        eprintln!(
            "channel {c}: walk {:.4} ± {:.4}, dipole model {model:.4} ({:+.2} %)",
            a[c],
            se[c],
            100.0 * err
        );
        assert!(
            (f64::from(a[c]) - model).abs() < 0.03 * model + 4.0 * f64::from(se[c]),
            "channel {c}"
        );
    }
}

/// Thin diffuse transmission: a sheet seen from the sky's side returns its reflected albedo
/// (1 − t)ρ, and from below, with the sky above it only, its transmittance t·C.
#[test]
fn thin_sheet_reflects_and_transmits() {
    let (t, c, rho) = (0.4f32, Vec3::new(1.0, 0.5, 0.25), 0.8f32);
    let mut b = SceneBuilder::new();
    let m = b.diffuse("paper", Vec3::splat(rho), Vec3::ZERO);
    b.translucent(
        m,
        Translucency::ThinDiffuseTransmission {
            factor: t,
            color: c,
        },
    );
    crate::scenes::hquad(&mut b, 0.0, 1.0, true, m);
    let scene = b.build("paper");
    // From above: the sky lights both sides (the sheet is alone), so reflected + transmitted.
    let (a, se) = albedo(&scene, Vec3::ZERO, Vec3::Y, 4000, 0.5);
    let want = Vec3::splat(rho * (1.0 - t)) + c * t;
    eprintln!("sheet: {a:?} ± {se:?}, want {want:?}");
    for k in 0..3 {
        assert!((a[k] - want[k]).abs() < 4.0 * se[k] + 1e-3, "channel {k}");
    }
}

/// The whole pipeline against the walk: a marble block (16 × 33 × 16 cm) under a uniform sky,
/// baked with the final gather; what the renderer reads at the middle of its front face,
/// albedo × effective irradiance / π, against the walk's radiance seen along the normal. The
/// two models agree there to the dipole's own error on a flat thick surface (the slab test
/// above: about 1.3 %) plus the directional Fresnel terms at normal view, which vlf averages
/// over the hemisphere; bound 3 %.
#[test]
fn marble_block_under_sky_pipeline_against_walk() {
    use glam::Vec4;
    use vlf_core::lightfield::{BakeParams, Iterations};
    let mut b = SceneBuilder::new();
    let m = b.diffuse("marble", Vec3::splat(0.9), Vec3::ZERO);
    b.translucent(
        m,
        Translucency::Dipole {
            sigma_s_prime: Vec3::new(2190.0, 2620.0, 3000.0),
            sigma_a: Vec3::new(2.1, 4.1, 7.1),
            eta: 1.5,
        },
    );
    b.aabox(
        Vec3::new(-0.08, 0.0, -0.08),
        Vec3::new(0.08, 0.33, 0.08),
        false,
        m,
    );
    let scene = b.build("marble under the sky");
    let params = BakeParams {
        sky: Vec3::ONE,
        final_gather: Some(crate::bakes::fixed_gather(0.5, 2.0, [16, 64, 64])),
        ..bakes::params(
            46,
            32,
            Iterations::Converge {
                threshold: 1e-3,
                max: 40,
            },
        )
    };
    let lf = vlf_core::pipeline::bake_cpu(&scene, &params).unwrap();
    let irr = lf.irradiance.to_f32();
    let (mut bake, mut k) = (Vec3::ZERO, 0.0);
    for f in lf.faces.iter().filter(|f| f.normal[2] < -0.99) {
        for t in f.texel_base..f.texel_base + f.texels_per_side() {
            let local = t - f.texel_base;
            let (x, y) = ((local % f.width) as f32, (local / f.width) as f32);
            let c = Vec3::from(f.origin)
                + Vec3::from(f.u) * (x + 0.5) * f.texel_size
                + Vec3::from(f.v) * (y + 0.5) * f.texel_size;
            let w = lf.to_vlf.inverse(c);
            if w.y > 0.1 && w.y < 0.23 && w.x.abs() < 0.05 {
                bake += Vec4::from(irr[t as usize]).truncate() * 0.9 / std::f32::consts::PI;
                k += 1.0;
            }
        }
    }
    let bake = bake / k;
    let ps = PreparedScene::new(&scene);
    let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    let n = 20000;
    for i in 0..n {
        let mut rng = Rng::for_path(3, i, 0);
        let u = rng.next_2d();
        let target = Vec3::new(-0.05 + 0.1 * u.x, 0.1 + 0.13 * u.y, -0.08);
        let l = ps
            .radiance(target - Vec3::Z * 0.5, Vec3::Z, Vec3::ONE, &mut rng)
            .as_dvec3();
        sum += l;
        sum2 += l * l;
    }
    let mean = sum / f64::from(n);
    let se = ((sum2 / f64::from(n) - mean * mean) / f64::from(n))
        .max(glam::DVec3::ZERO)
        .sqrt();
    eprintln!("front face: bake {bake:?} over {k} texels, walk {mean:?} ± {se:?}");
    for c in 0..3 {
        let (b, w) = (f64::from(bake[c]), mean[c]);
        assert!(
            (b - w).abs() < 0.03 * w + 4.0 * se[c],
            "channel {c}: bake {b} walk {w}"
        );
    }
}
