//! `--quality auto` on the shared scenes: the parameters docs/QUALITY.md lists, so a change of
//! the rules shows up here and in that table together.

use std::path::PathBuf;

use vlf_core::bake::{Quality, refine};

fn shared(rel: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes"
    ))
    .join(rel)
}

#[test]
fn auto_preset_without_the_gather_on_the_shared_scenes_matches_the_quality_table() {
    // (scene, rays per side, tile, perturbed copies, whether the sun rule fired)
    let table = [
        ("cornell-box/cornell.gltf", 64, 4, 0, false),
        ("cornell-box-mirror/cornell-mirror.gltf", 64, 4, 0, false),
        (
            "cornell-suzanne/cornellBox-2.80-Eevee-gltf.gltf",
            64,
            1,
            0,
            false,
        ),
        ("fog-room/VolumetricFogExample.glb", 128, 4, 0, true),
        ("lava-circuit/DepthOfFieldExample.glb", 256, 4, 0, false),
        ("sphere-room/room.glb", 64, 1, 0, false),
    ];
    for (rel, n, m, perturb, sun_rule) in table {
        let scene = vlf_core::scene::load(&shared(rel)).unwrap();
        let r = refine::refine(&scene, Quality::Auto, false);
        assert_eq!(r.params.final_gather, None);
        let got = (r.params.resolution, r.params.tile, r.params.perturb);
        assert_eq!(got, (n, m, perturb), "{rel}: {:#?}", r.reasons);
        assert_eq!(r.params.directions, 512, "{rel}");
        let fired = r.reasons.iter().any(|x| x.contains("sun's sharp shadows"));
        // lava-circuit has a sun too, but its resolution is already the preset's maximum.
        assert_eq!(fired, sun_rule, "{rel}: {:#?}", r.reasons);
        r.params.validate().unwrap();
    }
}

#[test]
fn auto_preset_with_the_gather_on_the_shared_scenes_matches_the_quality_table() {
    // (scene, rays per side, tile, stored atlas texel in ray spacings)
    let table = [
        ("cornell-box/cornell.gltf", 64, 4, 0.5),
        ("cornell-box-mirror/cornell-mirror.gltf", 64, 4, 0.5),
        (
            "cornell-suzanne/cornellBox-2.80-Eevee-gltf.gltf",
            64,
            1,
            0.5,
        ),
        // Sunlit: half the texel for sharp shadows; no doubling of the rays.
        ("fog-room/VolumetricFogExample.glb", 64, 4, 0.25),
        // Sunlit, and capped by the texel budget.
        ("lava-circuit/DepthOfFieldExample.glb", 256, 4, 0.305),
        ("sphere-room/room.glb", 64, 1, 0.5),
        // Lit by a point and a spot light: half the texel, and half the indirect grid's.
        ("lamp-room/lamp-room.glb", 64, 2, 0.25),
    ];
    for (rel, n, m, texel) in table {
        let scene = vlf_core::scene::load(&shared(rel)).unwrap();
        let r = refine::refine(&scene, Quality::Auto, true);
        let g = r.params.final_gather.expect("gather chosen");
        let got = (r.params.resolution, r.params.tile, r.params.perturb);
        assert_eq!(got, (n, m, 0), "{rel}: {:#?}", r.reasons);
        assert_eq!(r.params.directions, 246, "{rel}");
        assert!((g.texel_scale - texel).abs() < 1e-3, "{rel}: {g:?}");
        let indirect = if rel.starts_with("lamp-room") {
            0.5
        } else {
            1.0
        };
        assert_eq!(g.indirect_texel_scale, indirect, "{rel}: {g:?}");
        assert_eq!(
            (g.light_samples, g.direct_rays, g.indirect_rays),
            (64, 16, 256)
        );
        r.params.validate().unwrap();
    }
}

#[test]
fn presets_grow_monotonically() {
    let scene = vlf_core::scene::load(&shared("cornell-box/cornell.gltf")).unwrap();
    for gather in [false, true] {
        let d = refine::refine(&scene, Quality::Draft, gather).params;
        let a = refine::refine(&scene, Quality::Auto, gather).params;
        let h = refine::refine(&scene, Quality::High, gather).params;
        assert!(d.directions < a.directions && a.directions < h.directions);
        assert!(d.resolution <= a.resolution && a.resolution <= h.resolution);
    }
}

#[test]
fn rooms_lit_by_a_sky_through_openings_get_twice_the_rays() {
    // window-room: a 6 m room in 84 m of ground (visibility distance 0.066 < 0.1). Without a
    // sky the visibility rule's 256; under one the rays double to the preset's 512 for rooms
    // lit by a sky (docs/QUALITY.md), and the gather's grids follow the ray spacing.
    for rel in [
        "window-room/window-room.glb",
        "window-room-glazed/window-room-glazed.glb",
    ] {
        let scene = vlf_core::scene::load(&shared(rel)).unwrap();
        let plain = refine::refine(&scene, Quality::Auto, true);
        let lit = refine::refine_under_sky(&scene, Quality::Auto, true, glam::Vec3::ONE);
        assert_eq!(plain.params.resolution, 256, "{rel}: {:#?}", plain.reasons);
        assert_eq!(lit.params.resolution, 512, "{rel}: {:#?}", lit.reasons);
        assert_eq!(lit.params.sky, glam::Vec3::ONE);
        assert!(lit.reasons.iter().any(|x| x.contains("lit by the sky")));
        // Without the gather (not measured there) and at draft (its most is 64) nothing moves.
        let alone = refine::refine_under_sky(&scene, Quality::Auto, false, glam::Vec3::ONE);
        assert_eq!(alone.params.resolution, 256, "{rel}");
        let draft = refine::refine_under_sky(&scene, Quality::Draft, true, glam::Vec3::ONE);
        assert_eq!(draft.params.resolution, 64, "{rel}");
    }
    // The Cornell box under a sky (visibility distance 0.632) keeps its rays.
    let scene = vlf_core::scene::load(&shared("cornell-box/cornell.gltf")).unwrap();
    let lit = refine::refine_under_sky(&scene, Quality::Auto, true, glam::Vec3::ONE);
    assert_eq!(lit.params.resolution, 64);
}
