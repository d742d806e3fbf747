//! Sparse per-direction radiance tiles of non-diffuse (mirror and mixed) faces (VLF-GPU §3.1,
//! §3.4; original VLF §4.3).
//!
//! A mirror's outgoing radiance depends on direction, so for every fixed direction j of the set
//! a non-diffuse face stores its outgoing radiance per *ray* of PSF j — aligned with the ray
//! grid, so sending is a copy — for both senses (+ω_j leaves the side facing +ω_j, −ω_j the
//! other side). Only the m×m tiles its projection touches are stored. Layout:
//!
//! * `index_start[mf · l + j] .. index_start[mf · l + j + 1]` is the range of *slots* of
//!   non-diffuse face number `mf` in direction j; `tile_ids[slot]` is the tile (`ty·T + tx`),
//!   sorted within the range;
//! * the values of a slot are `2 × m²` RGBA entries: sense-major, then the tile's cells in
//!   row-major order: `(slot · 2 + sense) · m² + cy · m + cx`.
//!
//! Receiving (the reflect step) is a gather: every destination cell of the three directions
//! around the reflected direction maps through the face plane back into the current PSF and
//! reads the radiance arriving there. No float atomics.

use glam::{Vec3, Vec4};
use serde::{Deserialize, Serialize};

use super::prep::{BakeScene, FACE_DIFFUSE};
use super::reference::{TransportDir, fixed_frame};
use crate::directions::DirectionSet;
use crate::psf::{PsfFrame, PsfGrid};

/// Index of the sparse tiles (geometry only; values live in separate arrays).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileIndex {
    /// Cells per tile side (m).
    pub m: u32,
    /// Rays per PSF side (N).
    pub n: u32,
    /// Fixed directions (l).
    pub directions: u32,
    /// For every face: its index among the non-diffuse faces, or `u32::MAX`.
    pub face_slot: Vec<u32>,
    /// The non-diffuse faces, in order.
    pub faces: Vec<u32>,
    /// `faces.len() · l + 1` slot offsets.
    pub index_start: Vec<u32>,
    /// Tile id of every slot.
    pub tile_ids: Vec<u32>,
    /// Per slot, `words_per_slot()` bit words: bit `cy·m + cx` is set when the ray of that cell
    /// crosses the face (the same exact test as the per-ray depth lists). Only covered cells are
    /// ever written, sent or counted.
    pub coverage: Vec<u32>,
}

impl TileIndex {
    /// Allocates the tiles every non-diffuse face's projection touches in every fixed direction.
    pub fn new(scene: &BakeScene, set: &DirectionSet, grid: &PsfGrid) -> Self {
        let l = set.len();
        let mut face_slot = vec![u32::MAX; scene.faces.len()];
        let mut faces = Vec::new();
        for (fi, f) in scene.faces.iter().enumerate() {
            if f.kind != FACE_DIFFUSE {
                face_slot[fi] = faces.len() as u32;
                faces.push(fi as u32);
            }
        }
        // Triangles of each non-diffuse face.
        let mut tris: Vec<Vec<[Vec3; 3]>> = vec![Vec::new(); faces.len()];
        for t in &scene.triangles {
            let s = face_slot[t.face as usize];
            if s != u32::MAX {
                tris[s as usize].push([t.p0, t.p1, t.p2].map(Vec3::from));
            }
        }
        let tiles = grid.tiles_per_side() as usize;
        let mut index_start = Vec::with_capacity(faces.len() * l + 1);
        let mut tile_ids = Vec::new();
        let m = grid.tile;
        let words = words_per_slot(m);
        let mut coverage = Vec::new();
        // Per tile of the current (face, direction): its coverage bits while being built.
        let mut bits: Vec<Option<Vec<u32>>> = vec![None; tiles * tiles];
        for face_tris in &tris {
            for j in 0..l {
                index_start.push(tile_ids.len() as u32);
                let frame = fixed_frame(set, j);
                let mut touched = Vec::new();
                for t in face_tris {
                    let q = t.map(|p| frame.to_psf(p));
                    let (i0, j0, i1, j1) = cell_range(&q, grid);
                    for cj in j0..=j1 {
                        for ci in i0..=i1 {
                            let (a, b) = grid.cell_center(ci, cj);
                            if super::reference::ray_hit(&q, glam::Vec2::new(a, b)).is_none() {
                                continue;
                            }
                            let id = ((cj / m) * grid.tiles_per_side() + ci / m) as usize;
                            let entry = bits[id].get_or_insert_with(|| {
                                touched.push(id as u32);
                                vec![0u32; words]
                            });
                            let bit = (cj % m) * m + ci % m;
                            entry[(bit / 32) as usize] |= 1 << (bit % 32);
                        }
                    }
                }
                touched.sort_unstable();
                for id in touched {
                    tile_ids.push(id);
                    coverage.extend(bits[id as usize].take().expect("touched tile has bits"));
                }
            }
        }
        index_start.push(tile_ids.len() as u32);
        TileIndex {
            m: grid.tile,
            n: grid.n,
            directions: l as u32,
            face_slot,
            faces,
            index_start,
            tile_ids,
            coverage,
        }
    }

    /// Whether cell `local` (`cy·m + cx`) of `slot` is crossed by the face.
    pub fn covered(&self, slot: usize, local: u32) -> bool {
        let w = words_per_slot(self.m);
        self.coverage[slot * w + (local / 32) as usize] & (1 << (local % 32)) != 0
    }

    pub fn slots(&self) -> usize {
        self.tile_ids.len()
    }

    /// RGBA entries of one copy (unshot, next or total) of the values.
    pub fn value_len(&self) -> usize {
        self.slots() * 2 * (self.m * self.m) as usize
    }

    /// Value index of `face`'s cell `(ci, cj)` in fixed direction `j`, sense `sense`, if stored.
    pub fn value_index(&self, face: u32, j: u32, sense: u32, ci: u32, cj: u32) -> Option<usize> {
        let mf = *self.face_slot.get(face as usize)?;
        if mf == u32::MAX {
            return None;
        }
        let k = mf as usize * self.directions as usize + j as usize;
        let (s, e) = (
            self.index_start[k] as usize,
            self.index_start[k + 1] as usize,
        );
        let tps = self.n / self.m;
        let tile = (cj / self.m) * tps + ci / self.m;
        let slot = s + self.tile_ids[s..e].binary_search(&tile).ok()?;
        let m2 = (self.m * self.m) as usize;
        Some((slot * 2 + sense as usize) * m2 + ((cj % self.m) * self.m + ci % self.m) as usize)
    }
}

/// Coverage bit words per slot.
pub fn words_per_slot(m: u32) -> usize {
    (m * m).div_ceil(32) as usize
}

/// Range of cells `(i0, j0, i1, j1)` whose centres a projected triangle's bounding box may
/// contain, widened by one cell (conservative against rounding).
fn cell_range(q: &[Vec3; 3], grid: &PsfGrid) -> (u32, u32, u32, u32) {
    let n = grid.n as f32;
    let lo = q[0].min(q[1]).min(q[2]);
    let hi = q[0].max(q[1]).max(q[2]);
    let c = |x: f32, d: f32| ((((x + 1.0) * 0.5 * n - 0.5).floor() + d).clamp(0.0, n - 1.0)) as u32;
    (
        c(lo.x, -1.0),
        c(lo.y, -1.0),
        c(hi.x + 2.0 / n, 1.0),
        c(hi.y + 2.0 / n, 1.0),
    )
}

/// The cell of PSF point `(a, b)` in an `n`-grid, clamped (same f32 arithmetic as the shaders).
pub fn cell_at(a: f32, b: f32, n: u32) -> (u32, u32) {
    let nf = n as f32;
    let c = |x: f32| ((x + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    (c(a), c(b))
}

/// Specular unshot radiance leaving `face` at VLF point `y` travelling `t`: the three fixed
/// directions around `t`, weighted by their barycentric weights.
#[allow(clippy::too_many_arguments)]
pub fn specular_outgoing(
    index: &TileIndex,
    values: &[[f32; 4]],
    set: &DirectionSet,
    frames: &[PsfFrame],
    face: u32,
    y: Vec3,
    t: Vec3,
) -> Vec3 {
    let lk = set.lookup(t);
    let l = set.len() as u32;
    let mut out = Vec3::ZERO;
    for k in 0..3 {
        let w = lk.weights[k];
        if w <= 0.0 {
            continue;
        }
        let (j, sense) = (lk.vertices[k] % l, lk.vertices[k] / l);
        let q = frames[j as usize].to_psf(y);
        let (ci, cj) = cell_at(q.x, q.y, index.n);
        if let Some(i) = index.value_index(face, j, sense, ci, cj) {
            out += Vec4::from(values[i]).truncate() * w;
        }
    }
    out
}

/// One destination of the reflect step: incoming light of transport direction `dir` (sense
/// `incoming_sense`: 0 = travelling +w, 1 = −w) on non-diffuse face `face` goes, reflected, to
/// fixed direction `j`, sense `sense`, with weight `weight` (ρ_s × barycentric × ΔΩ_t / W_v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectJob {
    pub face: u32,
    pub incoming_sense: u32,
    pub j: u32,
    pub sense: u32,
    /// Multiplies the arriving radiance (or the sun's irradiance).
    pub weight: Vec3,
}

/// Reflect jobs of every transport direction (outer index = direction, including suns last).
/// The weight of destination vertex v of face f is normalised by
/// W(f, v) = Σ_t w_v(reflect(t))·ΔΩ_t over all quadrature directions and senses, so a uniform
/// incoming radiance L reflects to exactly ρ·L in every direction.
pub fn reflect_jobs(
    scene: &BakeScene,
    set: &DirectionSet,
    dirs: &[TransportDir],
    index: &TileIndex,
) -> Vec<Vec<ReflectJob>> {
    let l = set.len() as u32;
    let mut out = vec![Vec::new(); dirs.len()];
    for &face in &index.faces {
        let f = &scene.faces[face as usize];
        let n = f.normal();
        let rho = Vec4::from(scene.specular[face as usize]).truncate();
        // Splat every incoming direction (both senses) to its 3 reflected vertices.
        let mut norm = vec![0f64; 2 * l as usize];
        let mut splats: Vec<(usize, u32, [u32; 3], [f32; 3])> = Vec::new();
        for (di, d) in dirs.iter().enumerate() {
            for sense in 0..2u32 {
                if d.sun.is_some() && sense == 1 {
                    continue; // suns travel along +w only
                }
                let t = if sense == 0 { d.frame.w } else { -d.frame.w };
                let r = t - 2.0 * t.dot(n) * n;
                let lk = set.lookup(r);
                if d.sun.is_none() {
                    for k in 0..3 {
                        norm[lk.vertices[k] as usize] += f64::from(lk.weights[k] * d.weight);
                    }
                }
                splats.push((di, sense, lk.vertices, lk.weights));
            }
        }
        for (di, sense, verts, weights) in splats {
            let d = &dirs[di];
            for k in 0..3 {
                let v = verts[k] as usize;
                if weights[k] <= 0.0 || norm[v] <= 0.0 {
                    continue;
                }
                // Quadrature directions carry radiance × ΔΩ; a sun carries irradiance.
                let omega = if d.sun.is_some() { 1.0 } else { d.weight };
                out[di].push(ReflectJob {
                    face,
                    incoming_sense: sense,
                    j: verts[k] % l,
                    sense: verts[k] / l,
                    weight: rho * (weights[k] * omega / norm[v] as f32),
                });
            }
        }
    }
    out
}

/// Frames of every fixed direction (as used by the tiles).
pub fn fixed_frames(set: &DirectionSet) -> Vec<PsfFrame> {
    (0..set.len()).map(|j| fixed_frame(set, j)).collect()
}
