//! Subsurface scattering (`docs/SUBSURFACE.md`, issue 28): the dipole against its closed forms,
//! the hierarchical links against the analytic answers of a semi-infinite slab of Jensen's
//! marble, and thin diffuse transmission in a whole propagation.

use crate::bakes;
use std::time::Instant;

use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::subsurface::{LinkParams, ObjectTree, Subsurface, links};
use vlf_core::scene::dipole::{self, Dipole};
use vlf_core::scene::{Scene, SceneBuilder, Translucency};

/// Jensen et al. 2001, table 2, marble: per millimetre.
const MARBLE_SIGMA_S_PRIME: [f64; 3] = [2.19, 2.62, 3.00];
const MARBLE_SIGMA_A: [f64; 3] = [0.0021, 0.0041, 0.0071];
const MARBLE_ETA: f64 = 1.5;

/// Marble per metre (the scenes' unit).
fn marble() -> Translucency {
    let per_m = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32) * 1000.0;
    Translucency::Dipole {
        sigma_s_prime: per_m(MARBLE_SIGMA_S_PRIME),
        sigma_a: per_m(MARBLE_SIGMA_A),
        eta: MARBLE_ETA as f32,
    }
}

fn marble_mm() -> [Dipole; 3] {
    std::array::from_fn(|c| Dipole::new(MARBLE_SIGMA_S_PRIME[c], MARBLE_SIGMA_A[c], MARBLE_ETA))
}

/// The profile integrates to the closed form (Jensen's eq. for R_d, numerically over r by
/// the midpoint rule on a geometric grid), and the tail formula is its integral from r0.
#[test]
fn dipole_closed_forms() {
    for d in marble_mm() {
        let total = d.total_reflectance();
        assert!((d.reflectance_beyond(0.0) - total).abs() < 1e-12 * total);
        let mut sum = 0.0;
        let (mut r, f) = (1e-6f64, 1.0005f64);
        while r < 500.0 {
            let r1 = r * f;
            let m = 0.5 * (r + r1);
            sum += d.profile(m) * 2.0 * std::f64::consts::PI * m * (r1 - r);
            r = r1;
        }
        let rest = d.reflectance_beyond(500.0) + d.profile(1e-6) * std::f64::consts::PI * 1e-12;
        assert!(
            ((sum + rest) - total).abs() < 1e-5 * total,
            "numeric {} vs closed form {total}",
            sum + rest
        );
    }
    // The diffuse Fresnel reflectance of glass from outside (0.0918 for η = 1.5, e.g. d'Eon's
    // tables) and the albedo inversion round trip.
    let f = dipole::fresnel_diffuse_external(1.5);
    assert!((f - 0.0918).abs() < 5e-4, "F_dr,ext(1.5) = {f}");
    for r in [0.05, 0.3, 0.7] {
        let a = dipole::albedo_for_reflectance(r, 1.3);
        let fdr = dipole::fresnel_diffuse_internal(1.3);
        let back = dipole::total_reflectance(a, (1.0 + fdr) / (1.0 - fdr));
        assert!((back - r).abs() < 1e-9, "{r} → α′ {a} → {back}");
    }
}

/// The side-0 texel of `face` containing world point `p`.
fn texel_at(scene: &Scene, prep: &BakeScene, face: usize, p: Vec3) -> u32 {
    prep.faces[face].texel_at(scene.to_vlf.apply(p), 0)
}

/// A large thick box of marble (12 × 5 × 12 cm, 2 mm texels) under uniform light: the light
/// the centre of its top scatters out, per unit flux entering, is the dipole's total diffuse
/// reflectance within 1 % per channel (the bound; the texels within 5 cm of it
/// are all on the top face, and the dipole's reflectance beyond 5 cm is below 2e-4 of its
/// total for marble).
#[test]
fn marble_slab_total_reflectance() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("marble", Vec3::ONE, Vec3::ZERO);
    b.translucent(m, marble());
    b.aabox(
        Vec3::new(-0.06, 0.0, -0.06),
        Vec3::new(0.06, 0.05, 0.06),
        false,
        m,
    );
    let scene = b.build("marble box");
    let h = 0.002 * scene.to_vlf.scale;
    let prep = BakeScene::with_texel_size(&scene, h).unwrap();
    let t0 = Instant::now();
    let sss = Subsurface::new(&prep, &LinkParams::default(), 0).expect("translucent");
    let built = t0.elapsed();
    let st = sss.stats();
    eprintln!(
        "marble box: {} texels, {} links ({:.1} MiB, {:.0} per texel), built in {:.2?}, dropped ≤ {:.1e}",
        st.dipole_texels,
        st.links,
        st.link_bytes as f64 / 1048576.0,
        st.links as f64 / st.dipole_texels as f64,
        built,
        st.dropped
    );
    assert_eq!(st.dipole_objects, 1, "one connected box");
    let ob = &sss.objects[0];
    let fresnel = f64::from(ob.fresnel);
    // Uniform irradiance 1: the scattered exitance per unit entering flux density.
    let t1 = Instant::now();
    let out = sss.exitance(&prep, |_| Vec3::ONE);
    eprintln!("one scatter step: {:.2?}", t1.elapsed());
    let top = (0..scene.faces.len())
        .find(|&f| scene.faces[f].normal.y > 0.99)
        .unwrap();
    let total = marble_mm().map(|d| d.total_reflectance());
    for p in [
        Vec3::new(0.001, 0.05, 0.001),
        Vec3::new(-0.009, 0.05, 0.005),
        Vec3::new(0.007, 0.05, -0.009),
    ] {
        let t = texel_at(&scene, &prep, top, p);
        let m = out.iter().find(|(x, _)| *x == t).unwrap().1;
        for c in 0..3 {
            let r = f64::from(m[c]) / (1.0 - fresnel);
            let err = r / total[c] - 1.0;
            eprintln!(
                "  {p:?} channel {c}: {r:.5} vs closed form {:.5} ({:+.3} %)",
                total[c],
                100.0 * err
            );
            assert!(err.abs() < 0.01, "channel {c}: {r} vs {}", total[c]);
        }
    }
}

/// A narrow beam: the flux entering one texel (0.05 mm) of a marble surface comes out with
/// the dipole's radial profile: within 5 % of R_d(r) wherever R_d is above 1 % of its peak
/// (the bound), along a row of receivers through the beam.
#[test]
fn marble_beam_profile() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("marble", Vec3::ONE, Vec3::ZERO);
    b.translucent(m, marble());
    let s = 0.004; // ±4 mm: the profile is above 1 % of its peak within 3 mm (red)
    crate::scenes::hquad(&mut b, 0.0, s, true, m);
    let scene = b.build("marble beam");
    let scale = scene.to_vlf.scale;
    let h_mm = 0.05;
    let prep = BakeScene::with_texel_size(&scene, h_mm * 1e-3 * scale).unwrap();
    let texels: Vec<u32> = (0..prep.faces[0].texels_per_side())
        .map(|t| prep.faces[0].texel_base + t)
        .filter(|&t| prep.texel_area[t as usize] > 0.0)
        .collect();
    let faces = vec![0u32; texels.len()];
    let mm_per_vlf = 1e3 / f64::from(scale);
    let vlf: [Dipole; 3] = std::array::from_fn(|c| {
        Dipole::new(
            MARBLE_SIGMA_S_PRIME[c] * mm_per_vlf,
            MARBLE_SIGMA_A[c] * mm_per_vlf,
            MARBLE_ETA,
        )
    });
    // Links are built for one row of receivers only: no memory budget to narrow the near field.
    let params = LinkParams {
        max_links: u64::MAX,
        ..LinkParams::default()
    };
    let tree = ObjectTree::new(&prep, &texels, &faces, vlf, params);
    let beam = texel_at(&scene, &prep, 0, Vec3::new(0.0001, 0.0, 0.0001));
    let bi = texels.iter().position(|&t| t == beam).unwrap();
    let mut flux = vec![Vec3::ZERO; texels.len()];
    flux[bi] = Vec3::ONE;
    let nf = tree.node_flux(&flux);
    let mm = marble_mm();
    let peak = mm.map(|d| d.profile(0.0));
    let beam_pos = Vec4::from(prep.texel_center[beam as usize]).truncate();
    let (mut checked, mut worst) = (0, 0f64);
    for (i, &t) in texels.iter().enumerate() {
        let p = Vec4::from(prep.texel_center[t as usize]).truncate();
        // The row through the beam (along the chart's u).
        if (p - beam_pos).dot(Vec3::from(prep.faces[0].v)).abs() > 0.5 * prep.texel_size {
            continue;
        }
        let r_mm = f64::from(p.distance(beam_pos)) * mm_per_vlf;
        let (l, _) = tree.links_for(&prep, i);
        let m = links::gather(&l, &nf);
        for c in 0..3 {
            let want = mm[c].profile(r_mm);
            if want < 0.01 * peak[c] {
                continue;
            }
            // Per unit flux, in VLF units⁻²; the profile in mm⁻².
            let got = f64::from(m[c]) * mm_per_vlf.powi(-2);
            let err = got / want - 1.0;
            worst = worst.max(err.abs());
            checked += 1;
            assert!(
                err.abs() < 0.05,
                "r {r_mm:.3} mm channel {c}: {got:.5} vs R_d {want:.5}"
            );
        }
    }
    eprintln!(
        "beam: {checked} receiver-channels checked, worst {:.2} %",
        100.0 * worst
    );
    assert!(checked > 150, "{checked}");
}

/// Power per channel received (Σ E·A) by `side` of the faces `faces` over a propagation.
fn received(prep: &BakeScene, irr: &[[f32; 4]], faces: &[usize], side: usize) -> glam::DVec3 {
    let mut p = glam::DVec3::ZERO;
    for &f in faces {
        let face = prep.faces[f];
        let n = face.texels_per_side() as usize;
        let s = face.texel_base as usize + side * n;
        for t in s..s + n {
            p += Vec4::from(irr[t]).truncate().as_dvec3() * f64::from(prep.texel_area[t]);
        }
    }
    p
}

/// A black lamp (a glowing cube) inside a closed shade that transmits diffusely and reflects
/// nothing (diffuseTransmissionFactor 1, colour C), in a black room: the room receives exactly
/// the shade's transmittance C times the lamp's power, and nothing comes back. The issue's
/// bound, 2 % of the energy per channel, against the lamp's emitted power; what the shade shows
/// outside (albedo × its effective irradiance, as the renderer reads it) is what the room
/// received; and the propagation's energy bookkeeping balances.
#[test]
fn lamp_in_diffuse_transmitting_shade() {
    use vlf_core::lightfield::Iterations;
    let c = Vec3::new(0.9, 0.6, 0.3);
    let mut b = SceneBuilder::new();
    let room = b.diffuse("room", Vec3::ZERO, Vec3::ZERO);
    let shade = b.diffuse("shade", Vec3::splat(0.8), Vec3::ZERO);
    b.translucent(
        shade,
        Translucency::ThinDiffuseTransmission {
            factor: 1.0,
            color: c,
        },
    );
    let lamp = b.diffuse("lamp", Vec3::ZERO, Vec3::splat(2.0));
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, room);
    b.aabox(Vec3::splat(-0.4), Vec3::splat(0.4), false, shade);
    b.aabox(Vec3::splat(-0.25), Vec3::splat(0.25), false, lamp);
    let scene = b.build("lamp in shade");
    let params = bakes::params(
        126,
        64,
        Iterations::Converge {
            threshold: 1e-4,
            max: 20,
        },
    );
    let (prep, _, out) = crate::bakes::propagate(&scene, &params);
    let of = |m: u32| -> Vec<usize> {
        (0..scene.faces.len())
            .filter(|&f| scene.faces[f].material == m)
            .collect()
    };
    let emitted = prep.emitted_power().as_dvec3();
    let room_got = received(&prep, &out.irradiance, &of(room), 0);
    // The shade's texels hold their effective irradiance: × the albedo, their exitance.
    let shown = |side: usize| {
        let mut p = glam::DVec3::ZERO;
        for f in of(shade) {
            let face = prep.faces[f];
            let n = face.texels_per_side() as usize;
            let s = face.texel_base as usize + side * n;
            for t in s..s + n {
                p += (Vec4::from(out.irradiance[t]) * Vec4::from(prep.albedo[t]))
                    .truncate()
                    .as_dvec3()
                    * f64::from(prep.texel_area[t]);
            }
        }
        p
    };
    let (shade_out, shade_in) = (shown(0), shown(1));
    eprintln!(
        "iterations {}, emitted {emitted:.5?}, room {room_got:.5?}, shade's exitance outside {shade_out:.5?}, inside {shade_in:?}, imbalance {:.3e}",
        out.iterations,
        out.energy.relative_imbalance()
    );
    for k in 0..3 {
        let want = f64::from(c[k]) * emitted[k];
        let err = room_got[k] / want - 1.0;
        let shown = shade_out[k] / room_got[k] - 1.0;
        eprintln!(
            "channel {k}: room / (C × emitted) − 1 = {:+.3} %, shade's exitance / room − 1 = {:+.3} %",
            100.0 * err,
            100.0 * shown
        );
        // What the shade shows outside (its effective irradiance × albedo) is what reached the
        // room (black: it absorbs all of it).
        assert!(
            shown.abs() < 0.02,
            "channel {k}: shade shows {}",
            shade_out[k]
        );
        assert!(
            err.abs() < 0.02,
            "channel {k}: room {} vs {want}",
            room_got[k]
        );
    }
    // The inside reflects nothing (factor 1) and nothing comes back from the black room.
    assert!(shade_in.max_element() < 1e-9 * emitted.max_element());
    assert!(out.energy.relative_imbalance().abs() < 0.02);
}

/// A closed 2-unit room facing in (grey 0.5) with a square lamp of half-side `lamp` (radiance 5)
/// just under its ceiling, around a 0.6 × 0.6 × 0.6 box above its floor made of the material
/// `box_material` adds (the third); the scene and that material.
fn room_with_a_box(
    name: &str,
    lamp: f32,
    box_material: impl FnOnce(&mut SceneBuilder) -> u32,
) -> (Scene, u32) {
    let mut b = SceneBuilder::new();
    let room = b.diffuse("room", Vec3::splat(0.5), Vec3::ZERO);
    let light = b.diffuse("lamp", Vec3::ZERO, Vec3::splat(5.0));
    let m = box_material(&mut b);
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, room);
    crate::scenes::down_square(&mut b, 0.99, lamp, light);
    b.aabox(
        Vec3::new(-0.3, -0.9, -0.3),
        Vec3::new(0.3, -0.3, 0.3),
        false,
        m,
    );
    (b.build(name), m)
}

/// A marble cube lit by a lamp in a grey room, baked twice: translucent, and as an opaque
/// diffuse cube. The energy bookkeeping with the scattered light (moved from absorbed to
/// unshot each iteration) balances as well as the opaque bake's does (whose imbalance, about
/// −1.8 % at 32² rays and 46 directions, is the propagation's own aliasing: the transport adds
/// none), and the cube sends on more than its surface alone reflects (F_dr,ext E).
#[test]
fn marble_cube_in_room_balances_energy() {
    use vlf_core::lightfield::Iterations;
    let bake = |translucent: bool| {
        let (scene, _) = room_with_a_box("marble cube", 0.2, |b| {
            let cube = b.diffuse("marble", Vec3::splat(0.8), Vec3::ZERO);
            if translucent {
                b.translucent(cube, marble());
            }
            cube
        });
        let params = bakes::params(
            46,
            32,
            Iterations::Converge {
                threshold: 1e-3,
                max: 40,
            },
        );
        let (prep, _, out) = crate::bakes::propagate(&scene, &params);
        let e = &out.energy;
        eprintln!(
            "translucent {translucent}: iterations {}, emitted {:.4}, absorbed {:.4}, escaped {:.4}, unshot {:.2e}, imbalance {:.3e}",
            out.iterations,
            e.emitted,
            e.absorbed,
            e.escaped,
            e.unshot,
            e.relative_imbalance()
        );
        (prep, out)
    };
    let (_, opaque) = bake(false);
    let (prep, out) = bake(true);
    let (a, b) = (
        out.energy.relative_imbalance(),
        opaque.energy.relative_imbalance(),
    );
    assert!((a - b).abs() < 0.005, "imbalance {a} vs opaque {b}");
    let sss = Subsurface::new(&prep, &LinkParams::default(), 0).unwrap();
    assert_eq!(sss.stats().dipole_objects, 1);
    // What the cube's top sends out, ρ × its effective irradiance (as the renderer reads it),
    // against the opaque cube of albedo 0.8 under the same light: the marble's surface reflects
    // F_dr,ext ≈ 0.09 of what arrives and R_d,total ≈ 0.8 of the rest comes back out, less what
    // reaches the cube's edges from inside: an effective reflectance between 0.5 and 0.85.
    let top = prep
        .faces
        .iter()
        .position(|f| f.material == 2 && f.normal[1] > 0.99)
        .unwrap();
    let f = prep.faces[top];
    let shown = |irr: &[[f32; 4]]| {
        let mut s = Vec3::ZERO;
        for t in f.texel_base..f.texel_base + f.texels_per_side() {
            let t = t as usize;
            s += (Vec4::from(irr[t]) * Vec4::from(prep.albedo[t])).truncate() * prep.texel_area[t];
        }
        s
    };
    let (marble_out, opaque_out) = (shown(&out.irradiance), shown(&opaque.irradiance));
    for c in 0..3 {
        let ratio = marble_out[c] / opaque_out[c] * 0.8;
        eprintln!("channel {c}: the marble top's effective reflectance {ratio:.4}");
        assert!(
            ratio > 0.5 && ratio < 0.85,
            "channel {c}: effective reflectance {ratio}"
        );
    }
}

/// Scenes without translucent materials build nothing.
#[test]
fn opaque_scenes_build_no_links() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("grey", Vec3::splat(0.5), Vec3::ZERO);
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, m);
    let scene = b.build("grey box");
    let prep = BakeScene::with_texel_size(&scene, 0.05).unwrap();
    assert!(prep.translucency.is_empty());
    assert!(Subsurface::new(&prep, &LinkParams::default(), 0).is_none());
}

/// A closed paper box (diffuseTransmissionFactor 0.5) lit from above, baked with and without
/// the final gather: the light it shows outside (albedo × effective irradiance, as the renderer
/// reads it) agrees. The gather's sample points must count the box's inside as open (light
/// crosses its walls); when they did not, the inside gathered nothing and the walls showed a
/// fraction of the light the lit top passes through them.
#[test]
fn paper_box_through_the_final_gather() {
    use vlf_core::lightfield::{BakeParams, Iterations};
    let (scene, paper) = room_with_a_box("paper box", 0.3, |b| {
        let paper = b.diffuse("paper", Vec3::splat(0.8), Vec3::ZERO);
        b.translucent(
            paper,
            Translucency::ThinDiffuseTransmission {
                factor: 0.5,
                color: Vec3::ONE,
            },
        );
        paper
    });
    let params = |gather: bool| BakeParams {
        final_gather: gather.then_some(crate::bakes::fixed_gather(1.0, 2.0, [16, 16, 64])),
        ..bakes::params(
            46,
            32,
            Iterations::Converge {
                threshold: 1e-3,
                max: 40,
            },
        )
    };
    // Mean exitance of the paper's four vertical faces' outsides.
    let shown = |gather: bool| {
        let lf = vlf_core::pipeline::bake_cpu(&scene, &params(gather)).unwrap();
        let irr = lf.irradiance.to_f32();
        let (mut s, mut n) = (Vec3::ZERO, 0.0);
        for f in lf
            .faces
            .iter()
            .filter(|f| f.material == paper && f.normal[1].abs() < 0.5)
        {
            for t in f.texel_base..f.texel_base + f.texels_per_side() {
                s += Vec4::from(irr[t as usize]).truncate() * 0.8;
                n += 1.0;
            }
        }
        s / n
    };
    let (with, without) = (shown(true), shown(false));
    eprintln!("paper walls' exitance: gathered {with:?}, propagated {without:?}");
    for c in 0..3 {
        let r = with[c] / without[c];
        // The gather's own estimate differs from the propagation's by its better sampling; the
        // bug this guards against was a factor of 8.
        assert!(
            (0.8..1.25).contains(&r),
            "channel {c}: gathered / propagated = {r}"
        );
    }
}
