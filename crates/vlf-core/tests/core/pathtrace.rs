//! The CPU reference path tracer against the shared Mitsuba references
//! (`shared/reference/`, 256×256, 12,288 spp, camera 0 of the two Cornell boxes).
//!
//! Tolerances come from the reference README's table of Mitsuba's own error against these
//! references (mean of 3 seeds, relMSE = mean of (t − r)² / (r² + 0.01)):
//!
//! | spp | diffuse | mirror |
//! |---|---|---|
//! | 16 | 1.1e-2 | 1.7e-1 |
//! | 1024 | 1.9e-4 | 2.9e-3 |
//!
//! An unbiased path tracer with the same conventions and a comparable estimator (NEE + MIS)
//! lands near Mitsuba's row; we accept 1.5× the row (the acceptance criterion of issue 8).
//! A bias of a few percent would show up immediately: at 16 spp the row is dominated by
//! variance, so the second check compares image means, whose noise is tiny (the mean of
//! 65,536 pixels × spp paths).

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use vlf_core::image::{Image, read_exr, rel_mse};
use vlf_core::pathtrace::{PinholeCamera, PreparedScene, RenderSettings, render};
use vlf_core::scene::{self, SceneBuilder};

fn shared() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

/// `mean_rgb` of the reference's JSON sidecar (parsed by hand: no JSON dependency here).
fn reference_mean(json: &str) -> [f64; 3] {
    let text = std::fs::read_to_string(shared().join("reference").join(json)).unwrap();
    let start = text.find("\"mean_rgb\"").expect("mean_rgb in the JSON");
    let open = start + text[start..].find('[').unwrap();
    let close = open + text[open..].find(']').unwrap();
    let v: Vec<f64> = text[open + 1..close]
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    [v[0], v[1], v[2]]
}

/// CPU seconds used by this process so far (all threads; `/proc/self/stat` utime + stime),
/// or 0 where that file does not exist. The machine is shared, so wall time alone misleads.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap_or(0.0) + f[12].parse::<f64>().unwrap_or(0.0);
    ticks / 100.0
}

fn render_scene(scene_file: &str, spp: u32, seed: u32) -> (Image, f64) {
    let mut scene = scene::load(&shared().join("scenes").join(scene_file)).unwrap();
    // Rendered flat, as the references are (`reference/README.md`; the Cornell box's red wall,
    // a slightly twisted quad, has averaged NORMALs).
    scene.flatten_normals();
    let prep = PreparedScene::new(&scene);
    let settings = RenderSettings {
        width: 256,
        height: 256,
        spp,
        seed,
        ..Default::default()
    };
    let camera = PinholeCamera::from_scene(&scene, 0, settings.width, settings.height).unwrap();
    let t = Instant::now();
    let image = render(&prep, &camera, &settings, &|_, _| {}).unwrap();
    (image, t.elapsed().as_secs_f64())
}

fn check(scene_file: &str, reference: &str, json: &str, spp: u32, table_rel_mse: f64) {
    let (image, secs) = render_scene(scene_file, spp, 1);
    let reference_img = read_exr(shared().join("reference").join(reference)).unwrap();
    let err = rel_mse(&image, &reference_img);
    let mean = image.mean();
    let want = reference_mean(json);
    eprintln!(
        "{scene_file}: {spp} spp in {secs:.2} s: relMSE {err:.3e} (Mitsuba {table_rel_mse:.1e}), \
         mean {mean:?} vs reference {want:?}"
    );
    assert!(
        err <= 1.5 * table_rel_mse,
        "relMSE {err:.3e} above 1.5 × Mitsuba's {table_rel_mse:.1e} at {spp} spp"
    );
    // Bias: the image mean must match the reference's. Its statistical error is estimated from
    // the image itself: per channel, SE = sqrt(MSE_c / pixels), where MSE_c (against the
    // reference, whose own noise is ~100× smaller) is the per-pixel variance. We accept 5 SE
    // plus 0.1 % (float rounding of the sums); any convention mismatch (emission side,
    // Fresnel, pixel filter, a missing bounce) moves the mean by several percent.
    let n = image.pixels.len() as f64;
    for c in 0..3 {
        let mse_c: f64 = image
            .pixels
            .iter()
            .zip(&reference_img.pixels)
            .map(|(t, r)| (f64::from(t[c]) - f64::from(r[c])).powi(2))
            .sum::<f64>()
            / n;
        let se = (mse_c / n).sqrt();
        let tol = 5.0 * se + 1e-3 * want[c];
        eprintln!(
            "  channel {c}: |Δmean| {:.2e}, tolerance {tol:.2e} (SE {se:.2e})",
            (mean[c] - want[c]).abs()
        );
        assert!(
            (mean[c] - want[c]).abs() < tol,
            "channel {c}: mean {} vs reference {} (tolerance {tol:.2e})",
            mean[c],
            want[c]
        );
    }
}

#[test]
fn cornell_diffuse_matches_mitsuba() {
    check(
        "cornell-box/cornell.gltf",
        "cornell-ref.exr",
        "cornell-ref.json",
        16,
        1.1e-2,
    );
}

#[test]
fn cornell_mirror_matches_mitsuba() {
    check(
        "cornell-box-mirror/cornell-mirror.gltf",
        "cornell-mirror-ref.exr",
        "cornell-mirror-ref.json",
        16,
        1.7e-1,
    );
}

#[test]
fn renders_are_deterministic_and_seed_dependent() {
    let scene = scene::load(&shared().join("scenes/cornell-box/cornell.gltf")).unwrap();
    let prep = PreparedScene::new(&scene);
    let mut settings = RenderSettings {
        width: 24,
        height: 16,
        spp: 2,
        seed: 5,
        threads: 2,
        ..Default::default()
    };
    let camera = PinholeCamera::from_scene(&scene, 0, 24, 16).unwrap();
    let a = render(&prep, &camera, &settings, &|_, _| {}).unwrap();
    settings.threads = 1;
    let b = render(&prep, &camera, &settings, &|_, _| {}).unwrap();
    assert_eq!(a, b, "the thread count must not change the image");
    settings.seed = 6;
    let c = render(&prep, &camera, &settings, &|_, _| {}).unwrap();
    assert_ne!(a, c);
}

fn look_down(width: u32, height: u32, from_below: bool) -> PinholeCamera {
    let (from, at) = if from_below {
        (Vec3::new(0.0, -2.0, 0.0), Vec3::ZERO)
    } else {
        (Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO)
    };
    PinholeCamera::look_at(from, at, 30.0, width, height).unwrap()
}

fn settings(spp: u32, sky: Vec3) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp,
        seed: 3,
        sky,
        threads: 0,
    }
}

/// `prep` rendered `size`² from [`look_down`] (from below when `from_below`) at `spp` under
/// `sky`.
fn look_down_at(prep: &PreparedScene, size: u32, from_below: bool, spp: u32, sky: Vec3) -> Image {
    render(
        prep,
        &look_down(size, size, from_below),
        &settings(spp, sky),
        &|_, _| {},
    )
    .unwrap()
}

/// A Lambertian square of albedo a under a constant sky L reads exactly a·L (README: "a fully
/// exposed diffuse surface of albedo a reads a × sky"), seen from either side; every sample
/// gives exactly that value (the reflected ray always escapes), so the tolerance is rounding.
#[test]
fn sky_furnace_is_exact_from_both_sides() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("grey", Vec3::new(0.5, 0.25, 0.8), Vec3::ZERO);
    crate::scenes::hquad(&mut b, 0.0, 1.0, true, m);
    let scene = b.build("sky furnace");
    let prep = PreparedScene::new(&scene);
    let sky = Vec3::new(2.0, 1.0, 0.5);
    for below in [false, true] {
        let img = look_down_at(&prep, 16, below, 4, sky);
        // The square fills the view (half-width at distance 2 with 30° fov ≈ 0.54 < 1).
        for p in &img.pixels {
            let want = [1.0f32, 0.25, 0.4];
            for c in 0..3 {
                assert!((p[c] - want[c]).abs() < 1e-5, "pixel {p:?}, want {want:?}");
            }
        }
    }
}

/// Emission is one-sided (front = counter-clockwise) and read as is; the back of an emitter
/// reflects like any surface.
#[test]
fn emission_is_one_sided_and_exact() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("lamp", Vec3::ZERO, Vec3::new(17.0, 12.0, 4.0));
    // Front (CCW seen from +y) faces up.
    crate::scenes::hquad(&mut b, 0.0, 1.0, true, m);
    let scene = b.build("lamp");
    let prep = PreparedScene::new(&scene);
    let top = look_down_at(&prep, 8, false, 2, Vec3::ZERO);
    assert!(
        top.pixels.iter().all(|p| *p == [17.0, 12.0, 4.0]),
        "{:?}",
        top.pixels[0]
    );
    let bottom = look_down_at(&prep, 8, true, 2, Vec3::ZERO);
    assert!(bottom.pixels.iter().all(|p| *p == [0.0; 3]));
}

/// A sun of irradiance E at 60° from the normal of a Lambertian plane of albedo a: the plane
/// reads a·E·cos 60°/π exactly (direct light only; the sun is sampled deterministically).
#[test]
fn sun_irradiance_is_radiometric() {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("white", Vec3::splat(0.6), Vec3::ZERO);
    crate::scenes::hquad(&mut b, 0.0, 1.0, true, m);
    let mut scene = b.build("sun");
    let theta = 60f32.to_radians();
    scene.suns.push(scene::Sun {
        name: None,
        direction: -Vec3::new(theta.sin(), theta.cos(), 0.0),
        irradiance: Vec3::splat(1000.0),
    });
    let prep = PreparedScene::new(&scene);
    let img = look_down_at(&prep, 8, false, 2, Vec3::ZERO);
    let want = 0.6 * 1000.0 * 0.5 / std::f32::consts::PI;
    for p in &img.pixels {
        assert!((p[0] - want).abs() < 1e-3 * want, "{} vs {want}", p[0]);
    }
    // Lit from above, seen from below: the plane shadows itself.
    let img = look_down_at(&prep, 8, true, 2, Vec3::ZERO);
    assert!(img.pixels.iter().all(|p| *p == [0.0; 3]));
}

/// Closed furnace: a cube whose inner walls all emit L_e and have albedo a. The radiance
/// everywhere is L_e / (1 − a) (all bounces). This exercises NEE, MIS, unlimited depth and
/// Russian roulette together: any bias in one of them moves the mean. 64 spp over 16×16 pixels
/// give a standard error of the mean below 0.3 % (per-path sd ≈ 0.6·L measured); 1.5 % is
/// five standard errors.
#[test]
fn closed_furnace_converges_to_geometric_series() {
    let mut b = SceneBuilder::new();
    let a = 0.5;
    let m = b.diffuse("wall", Vec3::splat(a), Vec3::splat(1.0));
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, m);
    let scene = b.build("furnace");
    let prep = PreparedScene::new(&scene);
    let camera = PinholeCamera::look_at(
        Vec3::new(0.1, 0.2, 0.3),
        Vec3::new(1.0, 0.5, -0.2),
        80.0,
        16,
        16,
    )
    .unwrap();
    let img = render(&prep, &camera, &settings(64, Vec3::ZERO), &|_, _| {}).unwrap();
    let mean = img.mean();
    let want = 1.0 / (1.0 - a as f64);
    for c in 0..3 {
        assert!(
            (mean[c] - want).abs() < 0.015 * want,
            "furnace mean {} vs {want}",
            mean[c]
        );
    }
}

/// The acceptance measurement (run with `cargo test --release -p vlf-core --test core pathtrace:: --
/// --ignored --nocapture`): 1024 spp against both references.
#[test]
#[ignore = "takes about a minute in release"]
fn acceptance_1024_spp() {
    let spp: u32 = std::env::var("VLF_PT_SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1024);
    for (scene_file, reference, table) in [
        ("cornell-box/cornell.gltf", "cornell-ref.exr", 1.9e-4),
        (
            "cornell-box-mirror/cornell-mirror.gltf",
            "cornell-mirror-ref.exr",
            2.9e-3,
        ),
    ] {
        let cpu0 = cpu_seconds();
        let (image, secs) = render_scene(scene_file, spp, 1);
        let cpu = cpu_seconds() - cpu0;
        let reference_img = read_exr(shared().join("reference").join(reference)).unwrap();
        let err = rel_mse(&image, &reference_img);
        eprintln!(
            "{scene_file}: {spp} spp in {secs:.1} s wall, {cpu:.1} CPU-s: relMSE {err:.3e} \
             (Mitsuba at 1024 spp: {table:.1e}); mean {:?}",
            image.mean()
        );
    }
}
