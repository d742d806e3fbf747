//! The scene rules: every preset ([`super::quality::Preset`]) refined from the scene it bakes.
//! They run for every `--quality`, not only `auto`; what they measure and why (with figures) is
//! in `docs/QUALITY.md`. In short:
//!
//! * **Ray spacing** follows what the directions can resolve where light travels: a texel at
//!   distance d from the surfaces it sees resolves them at d·δ, δ ≈ √(4π / 2l) the spacing of
//!   the l directions. d is the median open-space distance between consecutive crossings along
//!   rays of a few probe directions; N = 2 / (d·δ) rounded up to a power of two within the
//!   preset's range, doubled once for a sun without the final gather.
//! * **Tile size**: the largest m ≤ 4 dividing N whose tiles hold at most 24 triangles on
//!   average.
//! * **Perturbed directions** against direction holes when the brightest emitter subtends less
//!   than four directions' solid angle (up to the preset's cap; none with the final gather).
//! * **The final gather's texels**: halved for the sharp shadows of suns, point and spot
//!   lights, the indirect grid halved for lamps' contact shadows, coarsened to the preset's
//!   texel budget.
//!
//! The preset's directions, stopping rule, ray counts and sampling are used as they are.

use glam::Vec3;
use serde::Serialize;

use super::prep::BakeScene;
use super::quality::{Preset, Quality};
use super::reference::{bin_triangles, build_cell_lists, project};
use crate::directions::DirectionSet;
use crate::lightfield::{BakeParams, GatherParams};
use crate::psf::{PsfFrame, PsfGrid};
use crate::scene::Scene;

/// What the scene rules measured and chose (printed with `-v` and in `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct Refinement {
    pub quality: String,
    /// Median distance between consecutive crossings along rays (VLF units, sphere radius 1).
    pub visibility_distance: f32,
    /// Angular spacing of the direction set (radians).
    pub angular_spacing: f32,
    /// Largest emitter solid angle seen from `visibility_distance` (steradians).
    pub emitter_solid_angle: f32,
    pub mean_bin_length: f32,
    pub params: BakeParams,
    pub reasons: Vec<String>,
}

/// The preset of `quality` refined for `scene`, with or without the final gather, without a
/// sky (the seed is left to the caller).
pub fn refine(scene: &Scene, quality: Quality, final_gather: bool) -> Refinement {
    refine_under_sky(scene, quality, final_gather, Vec3::ZERO)
}

/// [`refine`] for `scene` under a constant sky of radiance `sky` (`--sky`; zero: none).
pub fn refine_under_sky(
    scene: &Scene,
    quality: Quality,
    final_gather: bool,
    sky: Vec3,
) -> Refinement {
    let preset = quality.preset();
    let mut p = preset.params(final_gather);
    let mut reasons = Vec::new();
    if final_gather {
        reasons.push(format!(
            "directions: {} (the final gather samples direct light and averages the propagated field over each hemisphere)",
            p.directions
        ));
    }
    let l = DirectionSet::at_least(p.directions).map_or(p.directions as usize, |s| s.len());
    let delta = (4.0 * std::f32::consts::PI / (2.0 * l as f32)).sqrt();

    // Probe the scene with a coarse grid (64², 8×8 tiles) along a few directions.
    let probe = BakeParams {
        resolution: 64,
        tile: 8,
        ..p.clone()
    };
    let prep = BakeScene::new(scene, &probe).ok();
    let d = prep.as_ref().map_or(1.0, visibility_distance);
    let mut n = rays_per_side(scene, preset, final_gather, d, delta, &mut reasons);
    if sky != Vec3::ZERO
        && final_gather
        && d < SKY_INTERIOR_DISTANCE
        && n < preset.sky_interior_rays
    {
        n = (2 * n).min(preset.sky_interior_rays);
        reasons.push(format!(
            "rays: doubled to {n} for rooms lit by the sky through their openings (visibility \
             distance {d:.3} < {SKY_INTERIOR_DISTANCE}: the openings and the rooms are a few ray \
             cells wide)"
        ));
    }
    p.resolution = n;
    p.sky = sky;

    let mut mean_bin = 0.0;
    if let Some(prep) = &prep {
        (p.tile, mean_bin) = tile_size(prep, n);
        reasons.push(format!(
            "tiles: {0}×{0} cells, {mean_bin:.1} triangles per non-empty tile on average",
            p.tile
        ));
    }

    let omega_e;
    (p.perturb, omega_e) = perturbation(scene, preset, final_gather, d, l, &mut reasons);
    reasons.push(format!(
        "stopping: unshot power below {:e} of the emitted power",
        preset.threshold
    ));
    if final_gather {
        p.final_gather = Some(refine_gather(scene, preset, n, &mut reasons));
    }
    Refinement {
        quality: quality.name().to_string(),
        visibility_distance: d,
        angular_spacing: delta,
        emitter_solid_angle: omega_e,
        mean_bin_length: mean_bin,
        params: p,
        reasons,
    }
}

/// Below this median visibility distance (VLF units: the scene's bounding sphere has radius 1)
/// a sky-lit scene's light reaches rooms small against the scene (window-room: a 6 m room in
/// the 84 m of ground round it, 0.066) through openings a few ray cells wide, and the rays per
/// side are doubled (up to the preset's `sky_interior_rays`). Measured on window-room at the
/// default (256 → 512 rays; relMSE and mean FLIP against Mitsuba): 5.18e-4 / 0.0915 → 2.87e-4 /
/// 0.0687; window-room-glazed 6.77e-4 / 0.0908 → 2.9e-4 / 0.068; the gain is the finer
/// propagation (the field's interreflected light 5.7 % low in the room at 256, 2.3 % at 512)
/// and the gather's grids, which follow the ray spacing. Without a sky it does not hold:
/// lava-circuit (0.050, lit by its own emitters) at 512 rays scored 0.1025 against 0.1041 in
/// 3.6× the time. `docs/QUALITY.md`.
const SKY_INTERIOR_DISTANCE: f32 = 0.1;

/// The median open-space distance between consecutive front-facing crossings along rays of
/// five probe directions (VLF units), within [0.01, 2]; 1 when nothing is crossed twice.
fn visibility_distance(prep: &BakeScene) -> f32 {
    let grid = PsfGrid::new(64, 8).expect("valid probe grid");
    let mut gaps = Vec::new();
    for w in [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::new(1.0, 1.0, 1.0).normalize(),
        Vec3::new(-1.0, 2.0, 0.5).normalize(),
    ] {
        let lists = build_cell_lists(prep, &grid, &PsfFrame::new(w));
        let front = |face: u32| prep.faces[face as usize].normal().dot(w);
        for c in 0..lists.start.len() - 1 {
            let e = &lists.entries[lists.start[c] as usize..lists.start[c + 1] as usize];
            // Only open space between front sides counts (light leaves the front of one
            // face towards the front of the next); gaps inside closed solids and wall
            // thicknesses say nothing about how far light travels.
            gaps.extend(
                e.windows(2)
                    .filter(|p| front(p[0].1) > 0.0 && front(p[1].1) < 0.0)
                    .map(|p| p[1].0 - p[0].0)
                    .filter(|g| *g > 1e-6),
            );
        }
    }
    gaps.sort_by(f32::total_cmp);
    gaps.get(gaps.len() / 2)
        .copied()
        .unwrap_or(1.0)
        .clamp(0.01, 2.0)
}

/// Rays per side: 2 / (d·δ) rounded up to a power of two within the preset's range, one more
/// doubling for a sun without the final gather.
fn rays_per_side(
    scene: &Scene,
    preset: &Preset,
    final_gather: bool,
    d: f32,
    delta: f32,
    reasons: &mut Vec<String>,
) -> u32 {
    let (n_min, n_max) = preset.resolution;
    let ideal = 2.0 / (d * delta);
    let mut n = n_min;
    while (n as f32) < ideal && n < n_max {
        n *= 2;
    }
    reasons.push(format!(
        "rays: median visibility distance {d:.3} × angular spacing {delta:.3} rad → {ideal:.0} rays per side, {n} within the preset's {n_min}–{n_max}"
    ));
    // Sunlight arrives along one exact direction: its shadows are as sharp as the ray grid,
    // not blurred by the direction set, and in a sunlit scene they carry most of the image's
    // contrast (fog-room: relMSE 0.26 at N = 64 and 0.11 at 128 whatever the direction count,
    // docs/ACCURACY.md). One more doubling for them.
    if !scene.suns.is_empty() && final_gather {
        reasons.push(
            "rays: not doubled for the sun: the final gather's shadow rays resolve its shadows"
                .into(),
        );
    } else if !scene.suns.is_empty() && n < n_max {
        n *= 2;
        reasons.push(format!(
            "rays: doubled to {n} for the sun's sharp shadows (exact direction, limited by the ray grid only)"
        ));
    }
    n
}

/// The tile size for `n` rays per side and the mean number of triangles per non-empty tile.
fn tile_size(prep: &BakeScene, n: u32) -> (u32, f32) {
    let frame = PsfFrame::new(Vec3::new(0.3, 0.8, 0.5).normalize());
    let proj = project(prep, &frame);
    let (mut chosen, mut mean_bin) = (1, 0.0);
    // At most 4×4: the sweep (docs/ACCURACY.md) found 4×4 tiles 11–34 % faster than 16×16
    // with identical images (Cornell boxes, fog-room), and the mirror box's sparse tiles, which
    // are allocated per tile a mirror projects into, 3.4× smaller (86 MB against 296 MB).
    for m in [4u32, 2, 1] {
        if !n.is_multiple_of(m) {
            continue;
        }
        let bins = bin_triangles(&proj, &PsfGrid::new(n, m).expect("m divides n"));
        let non_empty = bins.start.windows(2).filter(|w| w[1] > w[0]).count().max(1);
        mean_bin = bins.tris.len() as f32 / non_empty as f32;
        chosen = m;
        if mean_bin <= 24.0 {
            break;
        }
    }
    (chosen, mean_bin)
}

/// Perturbed copies per direction for small emitters, and the largest emitter's solid angle
/// seen from `d`.
fn perturbation(
    scene: &Scene,
    preset: &Preset,
    final_gather: bool,
    d: f32,
    l: usize,
    reasons: &mut Vec<String>,
) -> (u32, f32) {
    let scale = scene.to_vlf.scale;
    let mut emitter_area = 0f32;
    for f in &scene.faces {
        let m = &scene.materials[f.material as usize];
        if m.is_emissive() {
            emitter_area = emitter_area.max(f.area * scale * scale);
        }
    }
    let omega_dir = 4.0 * std::f32::consts::PI / (2.0 * l as f32);
    let omega_e = if emitter_area > 0.0 {
        (emitter_area / (d * d)).min(2.0 * std::f32::consts::PI)
    } else {
        0.0
    };
    let mut perturb = 0;
    if final_gather {
        reasons.push("perturbation: none (the final gather samples emitters directly)".into());
    } else if omega_e > 0.0 && omega_e < 4.0 * omega_dir {
        perturb = ((4.0 * omega_dir / omega_e).ceil() as u32).clamp(1, preset.perturb_cap);
        reasons.push(format!(
            "perturbation: the largest emitter subtends {omega_e:.4} sr < 4 × {omega_dir:.4} sr per direction → {perturb} jittered copies per direction"
        ));
    } else if !scene.suns.is_empty() && omega_e == 0.0 {
        reasons.push("perturbation: none (lit by suns, which are exact directions)".into());
    }
    (perturb, omega_e)
}

/// The preset's final gather refined for `scene` propagated with `n` rays per side.
fn refine_gather(
    scene: &Scene,
    preset: &Preset,
    n: u32,
    reasons: &mut Vec<String>,
) -> GatherParams {
    let mut g = preset.gather;
    if !scene.suns.is_empty() || !scene.lights.is_empty() {
        // Shadows of suns, point and spot lights have no penumbra (nor has a hard spot's
        // cone): their edges are as sharp as the stored atlas.
        g.texel_scale *= 0.5;
        let what = if scene.suns.is_empty() {
            "the point and spot lights' sharp shadows"
        } else {
            "the sun's sharp shadows"
        };
        reasons.push(format!(
            "gather: texels of {} ray spacings for {what} (half the preset's)",
            g.texel_scale
        ));
    }
    if !scene.lights.is_empty() {
        // A lamp's hard shadow leaves the contact regions next to what it lights (under a
        // sphere on the floor) lit by indirect light alone, which darkens towards the contact
        // at the scale of the gap: the indirect grid at one ray spacing smeared lamp-room's
        // contact shadow over a tenth of a metre (relMSE against the path tracer 1.56e-3; at
        // half a spacing 0.66e-3, in 1.7× the bake time; docs/LIGHTS.md).
        g.indirect_texel_scale *= 0.5;
        reasons.push(format!(
            "gather: indirect grid of {} ray spacings for the contact shadows next to the point \
             and spot lights' hard shadows (half the preset's)",
            g.indirect_texel_scale
        ));
    }
    let cell = 2.0 / n as f64;
    let s2 = f64::from(scene.to_vlf.scale).powi(2);
    let area: f64 = scene
        .faces
        .iter()
        .map(|f| 2.0 * f64::from(f.area) * s2)
        .sum();
    let texels = area / (f64::from(g.texel_scale) * cell).powi(2);
    let budget = preset.gather_texel_budget;
    if texels > budget {
        let k = (texels / budget).sqrt() as f32;
        g.texel_scale *= k;
        g.indirect_texel_scale = g.indirect_texel_scale.max(g.texel_scale);
        reasons.push(format!(
            "gather: texels coarsened {k:.2}× to {:.3} ray spacings: {texels:.0} texels would exceed the preset's {budget:.0}",
            g.texel_scale
        ));
    }
    reasons.push(format!(
        "gather: stored atlas {} and indirect grid {} ray spacings, {} light samples and {} cosine rays per texel, {} gather rays per indirect texel",
        g.texel_scale, g.indirect_texel_scale, g.light_samples, g.direct_rays, g.indirect_rays
    ));
    g
}
