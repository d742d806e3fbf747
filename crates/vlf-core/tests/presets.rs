//! The quality presets as resolved on every shared scene, pinned: what `vlf-bake bake --quality Q`
//! bakes (before explicit options) must not move unless a change means it to.
//!
//! `tests/data/resolved_presets.txt` holds one line per preset, with and without the final
//! gather, per scene: the parameters `auto::choose` resolves, written with `{:?}` (floats print
//! their shortest round-trip form, so equal text is equal numbers). It was written by the code
//! before the presets moved into one table (issue 26) and is compared line by line here. After a
//! change that is meant to move the parameters, rewrite it with `VLF_BLESS_PRESETS=1 cargo test
//! -p vlf-core --test presets` and let the diff show what moved.

use std::path::PathBuf;

use vlf_core::bake::{Quality, auto};

const SCENES: [&str; 9] = [
    "cornell-box/cornell.gltf",
    "cornell-box-mirror/cornell-mirror.gltf",
    "cornell-suzanne/cornellBox-2.80-Eevee-gltf.gltf",
    "fog-room/VolumetricFogExample.glb",
    "lamp-room/lamp-room.glb",
    "lava-circuit/DepthOfFieldExample.glb",
    "sphere-room/room.glb",
    "window-room/window-room.glb",
    "window-room-glazed/window-room-glazed.glb",
];

const QUALITIES: [Quality; 3] = [Quality::Draft, Quality::Auto, Quality::High];

fn shared(rel: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes"
    ))
    .join(rel)
}

fn pinned_path() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/resolved_presets.txt"
    ))
}

/// One line per preset before any scene (`vlf-bake`'s `params_from_args`: what `batch` reports
/// as requested), then one per scene × preset × gather: `scene quality gather=on|off params`.
fn resolved_lines() -> Vec<String> {
    let mut lines = Vec::new();
    for q in QUALITIES {
        let mut p = q.params();
        p.final_gather = Some(q.gather());
        lines.push(format!("(no scene) {q:?} gather=on {p:?}"));
    }
    for rel in SCENES {
        let scene = vlf_core::scene::load(&shared(rel)).unwrap();
        for q in QUALITIES {
            for gather in [false, true] {
                let r = auto::choose(&scene, q, gather);
                r.params.validate().unwrap();
                let on = if gather { "on" } else { "off" };
                lines.push(format!("{rel} {q:?} gather={on} {:?}", r.params));
            }
        }
    }
    lines
}

#[test]
fn every_preset_on_every_shared_scene_resolves_to_the_pinned_parameters() {
    let got = resolved_lines();
    if std::env::var_os("VLF_BLESS_PRESETS").is_some() {
        std::fs::write(pinned_path(), got.join("\n") + "\n").unwrap();
        return;
    }
    let text = std::fs::read_to_string(pinned_path()).unwrap();
    let want: Vec<&str> = text.lines().collect();
    assert_eq!(
        got.len(),
        want.len(),
        "lines in {}",
        pinned_path().display()
    );
    let moved: Vec<String> = got
        .iter()
        .zip(&want)
        .filter(|(g, w)| g != w)
        .map(|(g, w)| format!("want {w}\n got {g}"))
        .collect();
    assert!(
        moved.is_empty(),
        "resolved parameters moved:\n{}",
        moved.join("\n")
    );
}
