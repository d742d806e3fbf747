//! Accuracy acceptance, end to end: default-quality bakes (propagation on the GPU, then the
//! final gather as `vlf-bake bake` runs it), rendered at 256×256 with 16 samples per pixel from
//! the views of the Mitsuba 3 references in ../shared/reference, compared by relMSE.
//!
//! Bounds (issue 24: no shared scene worse than before its guided gather, denoiser and leak
//! fixes; each measured figure is the 2-core VM's, lavapipe, at the commit that last moved it):
//! * diffuse Cornell box ≤ 3.3e-4 (measured 2.94e-4; 3.24e-4 before issue 24); the light field
//!   alone (`--final-gather off`) ≤ 3e-3 (measured 1.56e-3);
//! * mirror Cornell box, mirror pixels traced in pass 5 (the default) ≤ 1e-3 (measured 7.15e-4);
//!   with the tiles resampled after propagation ≤ 2.6e-3 (measured 2.28e-3; 3.08e-3 as
//!   propagated);
//! * fog-room ≤ 1.6e-2 (measured 1.30e-2; the reference's own noise ~3e-3);
//! * cornell-suzanne (glossy Suzanne, lobe sampled in pass 5) ≤ 1.8e-4 (measured 1.30e-4);
//! * lava-circuit by mean HDR-FLIP, whose reference's noise near black pixels makes relMSE
//!   meaningless (`reference/README.md`), ≤ 0.11 (measured 0.104), its mean radiance within 2 %
//!   of the reference's (measured 0.5 %);
//! * window-room (issue 24) ≤ 2.8e-4, mean FLIP ≤ 0.06, the goal (measured 2.53e-4,
//!   0.0599);
//! * window-room-glazed (issue 25) ≤ 2.9e-4, mean FLIP ≤ 0.066 (measured 2.63e-4, 0.0631);
//! * lamp-room (issue 25) ≤ 8.5e-3, mean FLIP ≤ 0.045 (measured 7.73e-3, 0.037; the
//!   reference's shadows of the masked screen are solid, `docs/TRANSMISSION.md`).

use glam::Vec3;
use vlf_core::bake::{BakeScene, Quality, refine};
use vlf_core::directions::DirectionSet;
use vlf_core::image::{self, Image};
use vlf_core::lightfield::BakeStats;
use vlf_gpu::render::{CameraView, Renderer};
use vlf_tests::{gpu, shared_dir};

/// The still's view: camera 0, or a look-at (eye, target, vertical fov in degrees, world).
enum View {
    Camera0,
    LookAt(Vec3, Vec3, f32),
}

/// Where a test's bake propagates: on the GPU (the adapter of the suite), or with the CPU
/// reference (bit-identical on lavapipe) where a scene's buffers exceed lavapipe's binding
/// limit.
#[derive(Clone, Copy, PartialEq)]
enum Propagation {
    Gpu,
    Cpu,
}

/// Stills of a default bake of `scene` rendered from `view`, once per entry of
/// `mirror_tracing` (pass 5 tracing mirror pixels or reading their tiles), and `reference`.
fn stills_and_reference(
    scene: &str,
    reference: &str,
    view: View,
    final_gather: bool,
    mirror_tracing: &[bool],
    propagation: Propagation,
    sky: Vec3,
) -> Option<(Vec<Image>, Image)> {
    let ctx = gpu()?;
    let mut scene = vlf_core::scene::load(&shared_dir().join("scenes").join(scene)).unwrap();
    // The references shade every face flat except lamp-room's (`reference/README.md`): what
    // `vlf-bake bake --flat-normals` bakes.
    if !scene.source.to_string_lossy().contains("lamp-room") {
        scene.flatten_normals();
    }
    // What `vlf-bake bake` does by default: the auto preset refined from the scene.
    let params = refine::refine_under_sky(&scene, Quality::Auto, final_gather, sky).params;
    let prep = BakeScene::new(&scene, &params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let out = match propagation {
        Propagation::Gpu => {
            vlf_gpu::bake::propagate(ctx, &prep, &set, &params, &mut |_| {}).unwrap()
        }
        Propagation::Cpu => vlf_core::bake::reference::propagate(&prep, &set, &params),
    };
    let lf = vlf_core::pipeline::finish(&scene, &prep, &params, set, out, BakeStats::default(), 0)
        .unwrap()
        .light_field;
    let mut renderer = Renderer::new(ctx, &lf).unwrap();
    let cam = match view {
        View::Camera0 => CameraView::from_gltf(&lf.cameras[0], &lf.to_vlf),
        View::LookAt(eye, target, fov) => CameraView::look_at(
            lf.to_vlf.apply(eye),
            lf.to_vlf.apply(target),
            fov.to_radians(),
        ),
    };
    let refimg = image::read_exr(shared_dir().join("reference").join(reference)).unwrap();
    let stills = mirror_tracing.iter().map(|&tracing| {
        renderer.set_mirror_tracing(tracing);
        let pixels = renderer.render_still(ctx, &cam, 256, 256, 16).unwrap();
        Image {
            width: 256,
            height: 256,
            pixels,
        }
    });
    Some((stills.collect(), refimg))
}

/// relMSE of a default bake of `scene` rendered from `view` against `reference`, once per
/// entry of `mirror_tracing`.
fn rel_mse_against_reference_with(
    scene: &str,
    reference: &str,
    view: View,
    final_gather: bool,
    mirror_tracing: &[bool],
) -> Option<Vec<f64>> {
    let (stills, refimg) = stills_and_reference(
        scene,
        reference,
        view,
        final_gather,
        mirror_tracing,
        Propagation::Gpu,
        Vec3::ZERO,
    )?;
    Some(stills.iter().map(|t| image::rel_mse(t, &refimg)).collect())
}

fn rel_mse_against_reference(
    scene: &str,
    reference: &str,
    view: View,
    final_gather: bool,
) -> Option<f64> {
    rel_mse_against_reference_with(scene, reference, view, final_gather, &[true]).map(|e| e[0])
}

#[test]
fn default_quality_diffuse_cornell_box_matches_path_traced_reference() {
    let Some(e) = rel_mse_against_reference(
        "cornell-box/cornell.gltf",
        "cornell-ref.exr",
        View::Camera0,
        true,
    ) else {
        return;
    };
    eprintln!("diffuse Cornell box, default quality (final gather): relMSE {e:.3e}");
    assert!(e <= 3.3e-4, "relMSE {e:.3e} > 3.3e-4");
}

#[test]
fn light_field_alone_diffuse_cornell_box_matches_path_traced_reference() {
    let Some(e) = rel_mse_against_reference(
        "cornell-box/cornell.gltf",
        "cornell-ref.exr",
        View::Camera0,
        false,
    ) else {
        return;
    };
    eprintln!("diffuse Cornell box, default quality, light field alone: relMSE {e:.3e}");
    assert!(e <= 3e-3, "relMSE {e:.3e} > 3e-3");
}

#[test]
fn default_quality_mirror_cornell_box_matches_path_traced_reference() {
    let Some(e) = rel_mse_against_reference_with(
        "cornell-box-mirror/cornell-mirror.gltf",
        "cornell-mirror-ref.exr",
        View::Camera0,
        true,
        &[true, false],
    ) else {
        return;
    };
    let (traced, tiles) = (e[0], e[1]);
    eprintln!(
        "mirror Cornell box, default quality (final gather): relMSE {traced:.3e} with mirror \
         tracing, {tiles:.3e} with the tiles"
    );
    assert!(traced <= 1e-3, "mirror tracing: relMSE {traced:.3e} > 1e-3");
    assert!(tiles <= 2.6e-3, "tiles: relMSE {tiles:.3e} > 2.6e-3");
}

#[test]
fn default_quality_fog_room_matches_path_traced_reference() {
    // The view of ../shared/reference/fog-room-ref.json (the reference's own noise: ~3e-3).
    let view = View::LookAt(Vec3::new(2.8, 3.0, 0.0), Vec3::new(-3.0, 1.0, 0.0), 75.0);
    let Some(e) = rel_mse_against_reference(
        "fog-room/VolumetricFogExample.glb",
        "fog-room-ref.exr",
        view,
        true,
    ) else {
        return;
    };
    eprintln!("fog-room, default quality (final gather): relMSE {e:.3e}");
    assert!(e <= 0.016, "relMSE {e:.3e} > 0.016");
}

#[test]
fn default_quality_cornell_suzanne_matches_path_traced_reference() {
    // The view of ../shared/reference/cornell-suzanne-ref.json.
    let view = View::LookAt(Vec3::new(0.0, 1.5, 6.5), Vec3::new(0.0, 1.4, 0.0), 40.0);
    let Some(e) = rel_mse_against_reference(
        "cornell-suzanne/cornellBox-2.80-Eevee-gltf.gltf",
        "cornell-suzanne-ref.exr",
        view,
        true,
    ) else {
        return;
    };
    eprintln!("cornell-suzanne, default quality (final gather, lobe traced): relMSE {e:.3e}");
    assert!(e <= 1.8e-4, "relMSE {e:.3e} > 1.8e-4");
}

#[test]
fn default_quality_lava_circuit_matches_path_traced_reference_by_flip() {
    // The view of ../shared/reference/lava-circuit-ref.json.
    let view = View::LookAt(Vec3::new(0.0, 1.6, 4.6), Vec3::new(0.0, 0.4, 0.0), 50.0);
    let Some((stills, refimg)) = stills_and_reference(
        "lava-circuit/DepthOfFieldExample.glb",
        "lava-circuit-ref.exr",
        view,
        true,
        &[true],
        // Its unshot radiance (129 MiB) exceeds lavapipe's 128 MiB storage binding.
        Propagation::Cpu,
        Vec3::ZERO,
    ) else {
        return;
    };
    let flip = image::flip(&stills[0], &refimg).mean;
    let (got, want) = (stills[0].mean(), refimg.mean());
    let ratio: Vec<f64> = (0..3).map(|c| got[c] / want[c]).collect();
    eprintln!(
        "lava-circuit, default quality: mean HDR-FLIP {flip:.4}, mean radiance / reference's {ratio:.3?}"
    );
    assert!(flip <= 0.11, "mean HDR-FLIP {flip:.4} > 0.11");
    for r in ratio {
        assert!(
            (r - 1.0).abs() <= 0.02,
            "mean radiance / reference's {r:.3}"
        );
    }
}

/// Default bake of `scene` (camera 0, the final gather, traced mirrors) against `reference` by
/// relMSE and mean HDR-FLIP, both bounded.
fn relmse_and_flip_within(
    scene: &str,
    reference: &str,
    propagation: Propagation,
    sky: Vec3,
    (max_rel_mse, max_flip): (f64, f32),
) {
    let Some((stills, refimg)) = stills_and_reference(
        scene,
        reference,
        View::Camera0,
        true,
        &[true],
        propagation,
        sky,
    ) else {
        return;
    };
    let e = image::rel_mse(&stills[0], &refimg);
    let flip = image::flip(&stills[0], &refimg).mean;
    eprintln!("{scene}, default quality: relMSE {e:.3e}, mean HDR-FLIP {flip:.4}");
    assert!(e <= max_rel_mse, "relMSE {e:.3e} > {max_rel_mse:.1e}");
    assert!(flip <= max_flip, "mean HDR-FLIP {flip:.4} > {max_flip}");
}

#[test]
fn default_quality_window_room_matches_path_traced_reference() {
    // Sky (1, 1, 1) only, through two windows (issue 24: 9.4e-3 and mean FLIP 0.35 at the
    // issue; guided and adaptive sampling, the local stopping rule and the denoiser: 1.25e-3
    // and 0.108; no light across the window wall's head: 6.67e-4 and 0.104; the sky guide
    // refined at the openings, no adaptive stop on rounds that found nothing: 5.18e-4 and
    // 0.0915; twice the rays for rooms lit by a sky through openings: 2.72e-4 and 0.0681; two
    // more passes of the indirect grid: measured 2.53e-4 and 0.0599). The FLIP bound is the
    // issue's goal. Propagated by the CPU reference (bit-identical).
    relmse_and_flip_within(
        "window-room/window-room.glb",
        "window-room-ref.exr",
        Propagation::Cpu,
        Vec3::ONE,
        (2.8e-4, 0.06),
    );
}

#[test]
fn default_quality_window_room_glazed_matches_path_traced_reference() {
    // window-room with a thin glass pane in each opening (issue 25: black inside before panes;
    // 7.54e-4 and 0.101 before the refined sky guide, 6.77e-4 and 0.0908 before twice the rays
    // for rooms lit by a sky through openings, 2.77e-4 and 0.0688 before two more passes of the
    // indirect grid; measured 2.63e-4 and mean FLIP 0.0631, against goals of 3e-3 and 0.08).
    // Gathered on the CPU, as the
    // default's guided sampling is; propagated by the CPU reference (bit-identical; lavapipe's
    // 128 MiB bindings would halve the ray resolution).
    relmse_and_flip_within(
        "window-room-glazed/window-room-glazed.glb",
        "window-room-glazed-ref.exr",
        Propagation::Cpu,
        Vec3::ONE,
        (2.9e-4, 0.066),
    );
}

#[test]
fn default_quality_lamp_room_matches_path_traced_reference() {
    // A point and a spot light, an alpha-masked screen, a smooth sphere (issue 25: refused
    // before). Measured 7.73e-3 and mean FLIP 0.037 (goals 1e-3 and 0.06): the reference's
    // shadows of the screen are solid where the mask convention lets light through its holes
    // (docs/TRANSMISSION.md: Mitsuba's path integrator tests shadow rays as opaque at a mask);
    // outside the pixels where the two path tracers disagree the bake scores 3.8e-4. The
    // bounds keep what was reached.
    relmse_and_flip_within(
        "lamp-room/lamp-room.glb",
        "lamp-room-ref.exr",
        Propagation::Gpu,
        Vec3::ZERO,
        (8.5e-3, 0.045),
    );
}
