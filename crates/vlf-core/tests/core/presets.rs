//! The quality presets as resolved on every shared scene, pinned: what `vlf-bake bake --quality Q`
//! bakes (before explicit options) must not move unless a change means it to.
//!
//! `tests/data/resolved_presets.txt` holds one line per preset, with and without the final
//! gather, per scene: the parameters `refine::refine` resolves, written with `{:?}` (floats print
//! their shortest round-trip form, so equal text is equal numbers). It was written by the code
//! before the presets moved into one table and is compared line by line here (the three
//! lines before any scene then moved on purpose: they now carry the preset's own threshold and,
//! with the gather, its gather directions, as the scene rules always did). After a
//! change that is meant to move the parameters, rewrite it with `VLF_BLESS_PRESETS=1 cargo test
//! -p vlf-core --test core presets::` and let the diff show what moved.
//!
//! The same test binary writes and checks the preset tables of `docs/QUALITY.md` from
//! [`Quality::preset`], so the documentation states each number once and true.

use std::path::PathBuf;

use vlf_core::bake::{Quality, refine};

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
    for q in Quality::ALL {
        let p = q.preset().params(true);
        lines.push(format!("(no scene) {q:?} gather=on {p:?}"));
    }
    for rel in SCENES {
        let scene = vlf_core::scene::load(&shared(rel)).unwrap();
        for q in Quality::ALL {
            for gather in [false, true] {
                let r = refine::refine(&scene, q, gather);
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

fn quality_md() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/QUALITY.md"
    ))
}

const BEGIN: &str = "<!-- presets: generated from vlf_core::bake::quality::Preset, checked by \
                     crates/vlf-core/tests/core/presets.rs (VLF_BLESS_PRESETS=1 rewrites it) -->";
const END: &str = "<!-- end of presets -->";

/// `1000000` as `1,000,000`.
fn thousands(v: f64) -> String {
    let digits = format!("{}", v.round() as u64);
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The set size a requested direction count gives (what the bake propagates along).
fn set_len(requested: u32) -> String {
    let l = vlf_core::directions::DirectionSet::at_least(requested)
        .unwrap()
        .len();
    thousands(l as f64)
}

/// The presets' tables as docs/QUALITY.md shows them, from [`Quality::preset`].
fn presets_markdown() -> String {
    let mut s = String::from(
        "| preset | directions with / without the final gather | rays per side | tile before \
         the scene rules | texel | stop when unshot < | most iterations | perturbation cap \
         (without the gather) |\n|---|---|---|---|---|---|---|---|\n",
    );
    for q in Quality::ALL {
        let p = q.preset();
        s += &format!(
            "| {} | {} / {} | {}–{}{} | {} | {}×{} rays | {:e} of emitted | {} | {} |\n",
            q.name(),
            set_len(p.gather_directions),
            set_len(p.directions),
            p.resolution.0,
            p.resolution.1,
            if p.sky_interior_rays > p.resolution.1 {
                format!(" (rooms lit by a sky: up to {})", p.sky_interior_rays)
            } else {
                String::new()
            },
            p.tile,
            p.texel_scale,
            p.texel_scale,
            p.threshold,
            p.max_iterations,
            p.perturb_cap
        );
    }
    s += "\nThe final gather (texels in ray spacings, before the scene rules):\n\n\
          | preset | stored atlas texel | indirect grid texel | light samples / cosine rays per \
          texel | gather rays per indirect texel | sampling of direct light | denoiser | most \
          stored texels |\n|---|---|---|---|---|---|---|---|\n";
    for q in Quality::ALL {
        let g = q.preset().gather;
        let guided = if g.sampling.guided { "guided" } else { "fixed" };
        let sampling = if g.sampling.target_error > 0.0 {
            format!(
                "{guided}, adaptive: rounds until {} % relative standard error, at most {}",
                g.sampling.target_error * 100.0,
                g.sampling.max_rounds
            )
        } else {
            format!("{guided}, {} round(s)", g.sampling.max_rounds)
        };
        s += &format!(
            "| {} | {} | {} | {} / {} | {} | {sampling} | {} | {} |\n",
            q.name(),
            g.texel_scale,
            g.indirect_texel_scale,
            g.light_samples,
            g.direct_rays,
            thousands(g.indirect_rays as f64),
            g.denoise.name(),
            thousands(q.preset().gather_texel_budget),
        );
    }
    s
}

#[test]
fn quality_md_states_the_presets() {
    let text = std::fs::read_to_string(quality_md()).unwrap();
    let (start, end) = (
        text.find(BEGIN).expect("begin marker in docs/QUALITY.md") + BEGIN.len(),
        text.find(END).expect("end marker in docs/QUALITY.md"),
    );
    let want = format!("\n{}", presets_markdown());
    if std::env::var_os("VLF_BLESS_PRESETS").is_some() {
        let new = format!("{}{want}{}", &text[..start], &text[end..]);
        std::fs::write(quality_md(), new).unwrap();
        return;
    }
    assert_eq!(
        &text[start..end],
        want,
        "docs/QUALITY.md's preset tables differ from vlf_core::bake::quality::Preset"
    );
}
