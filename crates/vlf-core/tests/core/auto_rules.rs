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
