//! CPU reference propagator: clear and deterministic, used by tests, by `--device cpu`, and as
//! the specification of the GPU propagator (which runs the same three steps per direction).
//!
//! One iteration shoots the unshot radiance once along every transport direction. Per direction
//! (a PSF: frame + N×N ray grid cut into m×m tiles):
//! 1. **bin**: each triangle is listed in every tile its projection's bounding box touches;
//! 2. **cell lists**: every ray (cell centre) is intersected exactly with its tile's triangles,
//!    giving the faces it crosses sorted by depth: an exact per-ray depth list, so cyclic
//!    overlaps and interpenetrating faces cannot be mis-ordered (no painter's sort);
//! 3. **interface**: walking each list, the radiance arriving at every crossing from below
//!    (travelling +w) and from above (travelling −w) is the unshot radiance leaving the
//!    neighbouring crossing (or the sky, in the first iteration);
//! 4. **gather**: every texel reads, at its sample point, the arriving radiance of the nearby
//!    rays that cross *its own face* (tent filter over the 2×2 nearest cells, so no light leaks
//!    in from rays that hit another face), weighted by |cos θ| × the direction's solid angle;
//! 5. **finish**: from the gathered irradiance, the next unshot radiance of every texel and the
//!    iteration's energy terms.
//!
//! Non-diffuse (mirror and mixed) faces also send from and receive into sparse per-direction
//! tiles: **reflect** gathers the light arriving on them into the tiles of the reflected
//! directions.
//!
//! The gather is per texel, so no float atomics and the result is bit-reproducible.
//!
//! One file per step, each using only those before it: `transport` (the transport directions),
//! `cells` (steps 1–2), `energy` (step 5 and the energy bookkeeping), `tiles` (the mirror
//! tiles: their index, sending, the reflect jobs), `interface` (step 3), `gather` (step 4),
//! `reflect`; this file drives them ([`propagate`], [`gather_direction`]).

mod cells;
mod energy;
mod gather;
mod interface;
mod lobe;
mod reflect;
mod tiles;
mod transport;

pub use cells::{Bins, CellLists, bin_triangles, build_cell_lists, project, ray_hit};
pub use energy::{
    EnergyStats, IterationEnergy, TexelAccum, accumulate, finish_iteration, stopping,
    take_tile_loss, tile_power,
};
pub use gather::{FALLBACK_RADIUS, TexelSample, sample_texel};
pub use interface::{Interface, interface};
pub use lobe::{Adjacency, LobeColumn, Normalisation, face_lobe};
pub use reflect::{nearest_crossing, reflect};
pub use tiles::{
    ReflectJob, Specular, SpecularSetup, SpecularStep, reflect_jobs, specular_outgoing, tile_index,
};
pub use transport::{SplitMix64, TransportDir, all_directions, transport_directions};

use glam::{Vec3, Vec4};

use crate::bake::BakeScene;
use crate::directions::DirectionSet;
use crate::lightfield::{BakeParams, TileIndex};
use crate::psf::PsfGrid;
use energy::power;

/// Directions closer than this to a face's plane (|cos θ|) carry no light to it.
pub const MIN_COS: f32 = 1e-6;

/// The result of a propagation: irradiance per texel (both sides) and the mirror tiles.
#[derive(Clone, Debug)]
pub struct Propagated {
    /// Total irradiance per texel (rgb, a = 0), all iterations: what arrived at each texel side
    /// from surfaces, sky and suns. The light field stores it (the renderer applies albedo and
    /// emission per pixel); the final gather reads the converged field through it. The
    /// texels' outgoing radiance is [`BakeScene::outgoing_radiance`] of it.
    pub irradiance: Vec<[f32; 4]>,
    /// Sparse tiles of non-diffuse faces and their total outgoing radiance (specular part).
    pub tiles: Option<(TileIndex, Vec<[f32; 4]>)>,
    pub iterations: u32,
    pub energy: EnergyStats,
}

/// Gathers one direction into the accumulators (steps 1–4) and, with non-diffuse faces, runs
/// the reflect step into `next_tiles`. Returns the specular power escaping in this direction.
#[allow(clippy::too_many_arguments)]
pub fn gather_direction(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    unshot: &[[f32; 4]],
    tex_face: &[u32],
    acc: &mut [TexelAccum],
    spec: Option<SpecularStep>,
    sky: Vec3,
) -> f64 {
    let lists = build_cell_lists(scene, grid, &dir.frame);
    let (iface, escaped) = interface(scene, grid, dir, &lists, unshot, spec.as_ref().map(|s| s.0));
    if let Some((sp, jobs, next_tiles)) = spec {
        reflect(
            scene, grid, dir, &lists, &iface, sp.index, sp.frames, jobs, sky, next_tiles,
        );
    }
    for (t, &face) in tex_face.iter().enumerate() {
        let f = &scene.faces[face as usize];
        let local = t as u32 - f.texel_base;
        if scene.texel_area[t] <= 0.0 || local >= f.texels_per_side() {
            continue; // unused texel, or side 1 (handled with side 0)
        }
        let texel = (local % f.width, local / f.width);
        let point = Vec4::from(scene.texel_center[t]).truncate();
        let s = sample_texel(scene, grid, &dir.frame, &lists, &iface, face, texel, point);
        if !s.valid {
            continue;
        }
        let back = t + f.texels_per_side() as usize;
        for (side, tx) in [(0usize, t), (1, back)] {
            let a = &mut acc[tx];
            match dir.sun {
                // A sun's light travels +w only: it reaches the side facing −w, through the
                // first crossing of its ray (`open` is then the "first" fraction).
                Some(e_sun) if side == s.upstream_side => {
                    a.open += (e_sun * s.cos * s.open[side]).extend(0.0)
                }
                Some(_) => {}
                None => {
                    let wgt = dir.weight * s.cos;
                    a.irradiance += (s.arriving[side] * wgt).extend(wgt);
                    a.open.w += s.open[side] * wgt;
                }
            }
        }
    }
    escaped
}

/// Runs the whole propagation on the CPU.
pub fn propagate(scene: &BakeScene, set: &DirectionSet, params: &BakeParams) -> Propagated {
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let (dirs, quadrature) = all_directions(scene, set, params);
    let spec = SpecularSetup::new(scene, set, &grid, &dirs);
    let n_tex = scene.texel_count();
    let tex_face = texel_faces(scene);
    let mut unshot = scene.emission.clone();
    let mut next = vec![[0f32; 4]; n_tex];
    let mut irradiance = vec![[0f32; 4]; n_tex];
    let tile_len = spec.as_ref().map_or(0, |s| s.index.value_len());
    let mut unshot_tiles = vec![[0f32; 4]; tile_len];
    let mut next_tiles = vec![[0f32; 4]; tile_len];
    let mut total_tiles = vec![[0f32; 4]; tile_len];
    let mut energy = EnergyStats {
        emitted: power(&scene.emission, &scene.texel_area),
        ..Default::default()
    };
    let (max_iter, threshold) = stopping(params.iterations);
    let mut iterations = 0;
    for it in 0..max_iter {
        let first = it == 0;
        let sky = if first { params.sky } else { Vec3::ZERO };
        let mut acc = vec![TexelAccum::default(); n_tex];
        next_tiles.fill([0.0; 4]);
        let mut spec_escaped = 0f64;
        for (di, dir) in dirs.iter().enumerate() {
            if di >= quadrature && !first {
                break; // suns shine in the first iteration only
            }
            let sp = spec.as_ref().map(|s| {
                (
                    Specular {
                        index: &s.index,
                        set,
                        frames: &s.frames,
                        unshot: &unshot_tiles,
                    },
                    s.jobs[di].as_slice(),
                )
            });
            spec_escaped += gather_direction(
                scene,
                &grid,
                dir,
                &unshot,
                &tex_face,
                &mut acc,
                sp.as_ref().map(|(s, j)| (s, *j, next_tiles.as_mut_slice())),
                sky,
            );
        }
        let mut e = finish_iteration(
            scene,
            &tex_face,
            &acc,
            &unshot,
            sky,
            &mut next,
            &mut irradiance,
        );
        if let Some(s) = &spec {
            e.sent += tile_power(&s.index, &unshot_tiles, set, &grid);
            e.absorbed += take_tile_loss(&s.index, &mut next_tiles, set, &grid);
            e.next += tile_power(&s.index, &next_tiles, set, &grid);
            e.escaped += spec_escaped;
        }
        log::debug!(
            "iteration {it}: sent {:.5} received {:.5} escaped {:.5} injected {:.5} next {:.5}; sent − received − escaped = {:.3}%",
            e.sent,
            e.received,
            e.escaped,
            e.injected,
            e.next,
            100.0 * (e.sent - e.received - e.escaped) / e.sent.max(1e-30)
        );
        energy.record(&e);
        accumulate(&mut total_tiles, &next_tiles);
        std::mem::swap(&mut unshot, &mut next);
        std::mem::swap(&mut unshot_tiles, &mut next_tiles);
        iterations = it + 1;
        if energy.converged(threshold) {
            break;
        }
    }
    Propagated {
        irradiance,
        tiles: spec.map(|s| (s.index, total_tiles)),
        iterations,
        energy,
    }
}

/// Face index of every texel.
pub fn texel_faces(scene: &BakeScene) -> Vec<u32> {
    let mut out = vec![0u32; scene.texel_count()];
    for (fi, f) in scene.faces.iter().enumerate() {
        let s = f.texel_base as usize;
        out[s..s + 2 * f.texels_per_side() as usize].fill(fi as u32);
    }
    out
}
