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
mod shooting;
mod tiles;
mod transport;

pub use cells::{Bins, CellLists, bin_triangles, build_cell_lists, project, ray_hit};
pub use energy::{
    EnergyStats, IterationEnergy, TexelAccum, accumulate, finish_iteration, stopping,
    take_tile_loss, tile_power,
};
pub use gather::{FALLBACK_RADIUS, TexelSample, sample_texel};
pub use interface::{Interface, PaneEnergy, interface};
pub use lobe::{Adjacency, LobeColumn, Normalisation, face_lobe, face_lobe_support};
pub use reflect::{nearest_crossing, reflect};
pub use shooting::{Shooting, accelerates};
pub use tiles::{
    LOBE_BYTES_PER_JOB, ReflectCounts, ReflectJob, Specular, SpecularSetup, reach_factors,
    reflect_counts, reflect_jobs, specular_outgoing, tile_index,
};
pub use transport::{SplitMix64, TransportDir, all_directions, transport_directions};

use glam::{Vec3, Vec4};

use crate::bake::BakeScene;
use crate::bake::subsurface::{LinkParams, Subsurface};
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
    /// from surfaces, sky, suns, point and spot lights. The light field stores it (the renderer applies albedo and
    /// emission per pixel); the final gather reads the converged field through it. The
    /// texels' outgoing radiance is [`BakeScene::outgoing_radiance`] of it. Translucent texels
    /// hold their effective irradiance instead, their exitance over their albedo
    /// (`docs/SUBSURFACE.md`), so that the same product gives their light.
    pub irradiance: Vec<[f32; 4]>,
    /// The irradiance of the first iteration alone (light straight from emitters, sky, suns,
    /// point and spot lights), where the propagation kept it: the final gather replaces it by its own direct
    /// light, sampled by rays, where its gather rays read the field (`docs/GATHER.md`).
    pub first_bounce: Option<Vec<[f32; 4]>>,
    /// Sparse tiles of non-diffuse faces and their total outgoing radiance (specular part).
    pub tiles: Option<(TileIndex, Vec<[f32; 4]>)>,
    pub iterations: u32,
    pub energy: EnergyStats,
}

/// What one transport direction contributes to an iteration (steps 1–4 and the reflect step),
/// computed on its own so that directions run in parallel; [`DirectionGather::add_to`] then
/// adds it to the iteration's sums, in direction order, with the same float operations in the
/// same order as a sequential loop: the sums do not depend on the thread count.
#[derive(Clone, Debug, Default)]
pub struct DirectionGather {
    /// (side-0 texel, its sample) for every texel that has a valid sample, in texel order.
    samples: Vec<(u32, TexelSample)>,
    /// (tile value index, radiance) the reflect step adds to the next tiles, in order.
    tiles: Vec<(u32, Vec4)>,
    /// Specular power escaping in this direction.
    pub escaped: f64,
    /// What panes did to this direction's light.
    pub pane: PaneEnergy,
}

/// Steps 1–4 for one direction and, with non-diffuse faces (`spec`: the sender state and this
/// direction's reflect jobs), the reflect step.
#[allow(clippy::too_many_arguments)]
pub fn gather_direction(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    unshot: &[[f32; 4]],
    tex_face: &[u32],
    spec: Option<(&Specular, &[ReflectJob])>,
    sky: Vec3,
) -> DirectionGather {
    let lists = build_cell_lists(scene, grid, &dir.frame);
    let (iface, escaped, pane) =
        interface(scene, grid, dir, &lists, unshot, spec.map(|s| s.0), sky);
    let mut tiles = Vec::new();
    if let Some((sp, jobs)) = spec {
        reflect(
            scene, grid, dir, &lists, &iface, sp.index, sp.frames, jobs, sky, &mut tiles,
        );
    }
    let mut samples = Vec::new();
    for (t, &face) in tex_face.iter().enumerate() {
        let f = &scene.faces[face as usize];
        let local = t as u32 - f.texel_base;
        if scene.texel_area[t] <= 0.0 || local >= f.texels_per_side() {
            continue; // unused texel, or side 1 (handled with side 0)
        }
        let texel = (local % f.width, local / f.width);
        let point = Vec4::from(scene.texel_center[t]).truncate();
        let s = sample_texel(scene, grid, &dir.frame, &lists, &iface, face, texel, point);
        if s.valid {
            samples.push((t as u32, s));
        }
    }
    DirectionGather {
        samples,
        tiles,
        escaped,
        pane,
    }
}

impl DirectionGather {
    /// Adds this direction's samples into the accumulators and its reflected radiance into
    /// `next_tiles`.
    pub fn add_to(
        &self,
        scene: &BakeScene,
        dir: &TransportDir,
        tex_face: &[u32],
        acc: &mut [TexelAccum],
        next_tiles: &mut [[f32; 4]],
    ) {
        for &(i, v) in &self.tiles {
            let i = i as usize;
            next_tiles[i] = (Vec4::from(next_tiles[i]) + v).into();
        }
        for &(t, s) in &self.samples {
            let t = t as usize;
            let back = t + scene.faces[tex_face[t] as usize].texels_per_side() as usize;
            for (side, tx) in [(0usize, t), (1, back)] {
                let a = &mut acc[tx];
                match dir.sun {
                    // A sun's light travels +w only: it reaches the side facing −w, through the
                    // first crossing of its ray (`open` is then the "first" fraction).
                    // Through the first crossing of its ray, or through panes (`arriving`
                    // along a sun's direction is the sun that passed them).
                    Some(e_sun) if side == s.upstream_side => {
                        a.open +=
                            (e_sun * (s.cos * s.open[side]) + s.arriving[side] * s.cos).extend(0.0)
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
    }
}

/// Progress of a propagation (CPU or GPU), for a binary's progress bar.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub iteration: u32,
    pub max_iterations: u32,
    pub directions_done: usize,
    pub directions: usize,
}

/// Directions gathered ahead of the one being added, per worker thread: enough to keep every
/// worker busy while one direction takes longer, few enough to bound their memory.
const DIRECTIONS_AHEAD_PER_THREAD: usize = 2;

/// Runs the whole propagation on the CPU, on every core.
pub fn propagate(scene: &BakeScene, set: &DirectionSet, params: &BakeParams) -> Propagated {
    propagate_with(scene, set, params, 0, &mut |_| {})
}

/// Runs the whole propagation on the CPU on `threads` workers (0 = all cores), reporting
/// progress after every direction. The directions of an iteration are gathered in parallel
/// and added to the sums in direction order ([`DirectionGather`]), so the result is
/// bit-identical whatever the thread count, and the order of additions is the GPU
/// propagator's (one direction after the other).
pub fn propagate_with(
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    threads: usize,
    progress: &mut dyn FnMut(Progress),
) -> Propagated {
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let (dirs, quadrature) = all_directions(scene, set, params);
    let spec = SpecularSetup::new(scene, set, &grid, &dirs);
    let n_tex = scene.texel_count();
    let tex_face = texel_faces(scene);
    // Translucent materials (`docs/SUBSURFACE.md`): their links, built once; none otherwise.
    let sss = Subsurface::new(scene, &LinkParams::default(), threads);
    // Over-relaxation's bound is the largest albedo, which the light crossing translucent
    // surfaces is not in: plain shooting for them.
    let mut shooting = Shooting::new(scene, accelerates(params, spec.is_some() || sss.is_some()));
    let punctual = crate::bake::punctual::injected_irradiance(scene, threads);
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
    let window = DIRECTIONS_AHEAD_PER_THREAD * crate::par::threads(threads);
    let mut iterations = 0;
    let mut first_bounce = None;
    for it in 0..max_iter {
        let first = it == 0;
        let sky = if first { params.sky } else { Vec3::ZERO };
        let mut acc = vec![TexelAccum::default(); n_tex];
        next_tiles.fill([0.0; 4]);
        let mut spec_escaped = 0f64;
        let mut pane = PaneEnergy::default();
        let unshot = shooting.prepare();
        // Suns shine in the first iteration only.
        let active = if first { dirs.len() } else { quadrature };
        let sender = spec.as_ref().map(|s| Specular {
            index: &s.index,
            set,
            frames: &s.frames,
            unshot: &unshot_tiles,
        });
        crate::par::ordered(
            active,
            threads,
            window,
            |di| {
                let sp = sender
                    .as_ref()
                    .zip(spec.as_ref())
                    .map(|(sender, s)| (sender, s.jobs[di].as_slice()));
                gather_direction(scene, &grid, &dirs[di], unshot, &tex_face, sp, sky)
            },
            |di, g| {
                g.add_to(scene, &dirs[di], &tex_face, &mut acc, &mut next_tiles);
                spec_escaped += g.escaped;
                pane.absorbed += g.pane.absorbed;
                pane.escaped += g.pane.escaped;
                pane.sun_through += g.pane.sun_through;
                progress(Progress {
                    iteration: it,
                    max_iterations: max_iter,
                    directions_done: di + 1,
                    directions: active,
                });
            },
        );
        let before = sss.as_ref().map(|s| s.snapshot(&irradiance));
        let mut e = finish_iteration(
            scene,
            &tex_face,
            spec.as_ref().map_or(&[][..], |s| &s.unresolved),
            &acc,
            unshot,
            sky,
            punctual.as_deref().filter(|_| first),
            &mut next,
            &mut irradiance,
        );
        pane.apply(&mut e);
        if let (Some(s), Some(b)) = (&sss, &before) {
            // Translucent texels send on their exitance (transmitted and scattered light
            // included) instead of ρE: the difference leaves `absorbed` for the unshot.
            let moved = s.apply(scene, b, &irradiance, &mut next);
            e.next += moved;
            e.absorbed -= moved;
            e.magnitude = e.next;
        }
        if let Some(s) = &spec {
            e.sent += tile_power(&s.index, &unshot_tiles, set, &grid);
            e.absorbed += take_tile_loss(&s.index, &mut next_tiles, set, &grid);
            e.next += tile_power(&s.index, &next_tiles, set, &grid);
            e.escaped += spec_escaped;
        }
        shooting.finish(scene, &next, &mut e);
        log::debug!(
            "iteration {it}: ω {:.3} sent {:.5} received {:.5} escaped {:.5} injected {:.5} next {:.5} (|next| {:.5}); sent − received − escaped = {:.3}%",
            shooting.omega(),
            e.sent,
            e.received,
            e.escaped,
            e.injected,
            e.next,
            e.magnitude,
            100.0 * (e.sent - e.received - e.escaped) / e.sent.max(1e-30)
        );
        energy.record(&e);
        if first {
            first_bounce = Some(irradiance.clone());
        }
        accumulate(&mut total_tiles, &next_tiles);
        std::mem::swap(&mut unshot_tiles, &mut next_tiles);
        iterations = it + 1;
        if energy.converged(threshold) {
            break;
        }
    }
    // Translucent texels keep the effective irradiance (their exitance over their albedo), what
    // every reader multiplies by the albedo (`Subsurface::effective`). The first bounce stays
    // the irradiance that arrived: the guided gather's field subtracts it where it adds its own
    // direct light on the same side, which stands for it, so the light the direct light sent
    // through a translucent surface stays in the field.
    if let Some(s) = &sss {
        s.effective(scene, &mut irradiance);
    }
    Propagated {
        irradiance,
        first_bounce,
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
