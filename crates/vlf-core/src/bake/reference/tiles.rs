//! The mirror tiles in the propagation: which tiles a non-diffuse face's projection touches
//! ([`tile_index`]; the index itself is `lightfield::TileIndex`), the specular radiance a
//! face sends from them, and the reflect jobs that receive into them.
//!
//! Receiving (the reflect step) is a gather: every destination cell of a job's direction (the
//! three directions around the reflected one for a mirror, the lobe's for a glossy face) maps
//! through the face plane back into the current PSF and reads the radiance arriving there. No
//! float atomics.

use glam::{Vec2, Vec3, Vec4};

use super::MIN_COS;
use super::cells::ray_hit;
use super::lobe;
use super::transport::TransportDir;
use crate::bake::BakeScene;
use crate::bake::glossy::SpecularModel;
use crate::directions::DirectionSet;
use crate::lightfield::{FACE_DIFFUSE, TileIndex, tiles::words_per_slot};
use crate::pathtrace::material::GgxAlbedo;
use crate::psf::{PsfFrame, PsfGrid, cell_at, fixed_frame, fixed_frames};

/// Allocates the tiles every non-diffuse face's projection touches in every fixed direction.
pub fn tile_index(scene: &BakeScene, set: &DirectionSet, grid: &PsfGrid) -> TileIndex {
    let l = set.len();
    let mut face_slot = vec![u32::MAX; scene.faces.len()];
    let mut faces = Vec::new();
    for (fi, f) in scene.faces.iter().enumerate() {
        if f.kind != FACE_DIFFUSE {
            face_slot[fi] = faces.len() as u32;
            faces.push(fi as u32);
        }
    }
    let tris = slot_triangles(scene, &face_slot, faces.len());
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
                        if ray_hit(&q, Vec2::new(a, b)).is_none() {
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

/// The triangles of every non-diffuse face, by its slot (`face_slot`).
fn slot_triangles(scene: &BakeScene, face_slot: &[u32], slots: usize) -> Vec<Vec<[Vec3; 3]>> {
    let mut tris: Vec<Vec<[Vec3; 3]>> = vec![Vec::new(); slots];
    for t in &scene.triangles {
        let s = face_slot[t.face as usize];
        if s != u32::MAX {
            tris[s as usize].push([t.p0, t.p1, t.p2].map(Vec3::from));
        }
    }
    tris
}

/// Per non-diffuse face (by slot): the share of the quadrature that reaches it, Σ|n·w|·ΔΩ over
/// the quadrature directions in which a ray of the grid crosses the face, divided by the same
/// sum over all of them (1 for a face that no direction meets at |n·w| ≥ `MIN_COS`).
///
/// A face smaller than a ray cell is crossed by a ray only in some directions, with a chance
/// of about its projected area in cells. Its texels' irradiance is the mean over the directions
/// that reach it (`finish_iteration` divides by Σ|cos|·ΔΩ of the valid directions: what the
/// missing directions bring is taken to be the mean of the others); the reflect step can carry
/// into the tiles only the light of the directions that reach it, about this share of what the
/// texels receive. `finish_iteration` therefore reserves only this share of the specular part
/// for the tiles and re-emits the rest with the diffuse part ([`SpecularSetup::unresolved`]).
/// Scaling the reflect jobs up by its inverse instead diverged on cornell-suzanne (a sub-cell
/// face sends its tiles along the one ray that crosses it, and faces facing each other
/// amplified each other's).
pub fn reach_factors(
    scene: &BakeScene,
    grid: &PsfGrid,
    dirs: &[TransportDir],
    index: &TileIndex,
) -> Vec<f32> {
    let tris = slot_triangles(scene, &index.face_slot, index.faces.len());
    index
        .faces
        .iter()
        .zip(&tris)
        .map(|(&face, face_tris)| {
            let n = scene.faces[face as usize].normal();
            let (mut all, mut reached) = (0f64, 0f64);
            for d in dirs.iter().filter(|d| d.sun.is_none()) {
                let c = n.dot(d.frame.w).abs();
                if c < MIN_COS {
                    continue;
                }
                let wgt = f64::from(c * d.weight);
                all += wgt;
                if crosses(face_tris, &d.frame, grid) {
                    reached += wgt;
                }
            }
            if all > 0.0 {
                (reached / all) as f32
            } else {
                1.0
            }
        })
        .collect()
}

/// Whether a ray of `grid` in `frame` crosses one of `tris` (the exact test of the cell lists).
fn crosses(tris: &[[Vec3; 3]], frame: &PsfFrame, grid: &PsfGrid) -> bool {
    tris.iter().any(|t| {
        let q = t.map(|p| frame.to_psf(p));
        let (i0, j0, i1, j1) = cell_range(&q, grid);
        (j0..=j1).any(|cj| {
            (i0..=i1).any(|ci| {
                let (a, b) = grid.cell_center(ci, cj);
                ray_hit(&q, Vec2::new(a, b)).is_some()
            })
        })
    })
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
/// fixed direction `j`, sense `sense`, with weight ρ_s × `weight` (mirror: barycentric ×
/// ΔΩ_t / W_v; glossy: the lobe's weight, `lobe`), ρ_s the face's specular reflectance
/// (`BakeScene::specular`, [`ReflectJob::rgb_weight`]).
///
/// 20 bytes: a glossy face has ~25 jobs per incoming direction and side, so the jobs are most
/// of a glossy bake's memory (the reflectance, the same for all of a face's jobs, is not
/// repeated in each; 32 bytes before).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectJob {
    pub face: u32,
    pub j: u32,
    /// Times ρ_s, multiplies the arriving radiance (or the sun's irradiance).
    pub weight: f32,
    /// What the lobe absorbs per unit it reflects here, `(1 − A)/A` with A its directional
    /// albedo for the incoming direction (0 for a perfect mirror): the reflect step adds
    /// `loss × Σ rgb` of what it writes to the destination's fourth component, which the
    /// energy bookkeeping counts as absorbed (`energy::take_tile_loss`).
    pub loss: f32,
    pub incoming_sense: u8,
    pub sense: u8,
}

impl ReflectJob {
    /// The weight per colour: ρ_s of the face × [`ReflectJob::weight`] (`specular`: the
    /// scene's, per face), the same product on the CPU and in the GPU's reflect items.
    pub fn rgb_weight(&self, specular: &[[f32; 4]]) -> Vec3 {
        Vec4::from(specular[self.face as usize]).truncate() * self.weight
    }
}

/// Reflect jobs of every transport direction (outer index = direction, including suns last).
///
/// Mirrors ([`SpecularModel::Mirror`]): every incoming direction splats to the three vertices
/// around its reflection; the weight of destination vertex v of face f is normalised by
/// W(f, v) = Σ_t w_v(reflect(t))·ΔΩ_t over all quadrature directions and senses, so a uniform
/// incoming radiance L reflects to exactly ρ·L in every direction (a lobe narrower than the
/// direction spacing, α > 0, is further scaled by its directional albedo); a sun's three
/// destinations are normalised to conserve its reflected power instead. Glossy faces
/// ([`SpecularModel::Tiles`]): the lobe's weights ([`lobe::face_lobe`]).
///
/// Each direction's list is allocated at its final length ([`reflect_counts`] first, which
/// walks the glossy lobes without normalising them), so the jobs take exactly what the
/// memory plan counts for them, not what a growing vector over-allocates (up to twice).
pub fn reflect_jobs(
    scene: &BakeScene,
    set: &DirectionSet,
    dirs: &[TransportDir],
    index: &TileIndex,
) -> Vec<Vec<ReflectJob>> {
    let counts = reflect_counts(scene, set, dirs, index);
    let mut out: Vec<Vec<ReflectJob>> = counts
        .jobs
        .iter()
        .map(|&n| Vec::with_capacity(n as usize))
        .collect();
    visit_reflect_jobs(scene, set, dirs, index, true, &mut |di, job| {
        out[di].push(job)
    });
    out
}

/// What the reflect jobs of a bake take, counted without making them ([`reflect_jobs`]
/// makes exactly these).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReflectCounts {
    /// Jobs per transport direction.
    pub jobs: Vec<u64>,
    /// Per transport direction: Σ over its jobs of the tile slots of the job's face and fixed
    /// direction (the GPU's reflect items).
    pub slots: Vec<u64>,
    /// Jobs of the face with the most: with glossy faces, a bound on the working memory of
    /// the lobe [`reflect_jobs`] makes at a time besides the jobs ([`LOBE_BYTES_PER_JOB`]).
    pub face_jobs_max: u64,
}

impl ReflectCounts {
    pub fn total_jobs(&self) -> u64 {
        self.jobs.iter().sum()
    }
}

/// Bytes per reflect job of a glossy face's lobe while it is made: its (vertex, f32) target
/// (8), and for every other job (the two sides share a column) the column entry (vertex, f64
/// value: 16) and the sorted vertex list of the support's symmetrisation (4), rounded up for
/// the vectors' growth.
pub const LOBE_BYTES_PER_JOB: u64 = 24;

/// Counts the reflect jobs of every transport direction ([`reflect_jobs`]) without making
/// them: glossy lobes are walked but not normalised.
pub fn reflect_counts(
    scene: &BakeScene,
    set: &DirectionSet,
    dirs: &[TransportDir],
    index: &TileIndex,
) -> ReflectCounts {
    let mut out = ReflectCounts {
        jobs: vec![0; dirs.len()],
        slots: vec![0; dirs.len()],
        face_jobs_max: 0,
    };
    let mut face = u32::MAX;
    let mut face_jobs = 0u64;
    visit_reflect_jobs(scene, set, dirs, index, false, &mut |di, job| {
        out.jobs[di] += 1;
        let mf = index.face_slot[job.face as usize] as usize;
        let k = mf * index.directions as usize + job.j as usize;
        out.slots[di] += u64::from(index.index_start[k + 1] - index.index_start[k]);
        // A face's jobs come one after the other.
        if job.face != face {
            face = job.face;
            face_jobs = 0;
        }
        face_jobs += 1;
        out.face_jobs_max = out.face_jobs_max.max(face_jobs);
    });
    out
}

/// Every reflect job, face after face, handed to `sink` with its transport direction;
/// `normalised` false skips the glossy lobes' normalisation (the jobs are then the right
/// ones with wrong weights, for counting).
fn visit_reflect_jobs(
    scene: &BakeScene,
    set: &DirectionSet,
    dirs: &[TransportDir],
    index: &TileIndex,
    normalised: bool,
    sink: &mut dyn FnMut(usize, ReflectJob),
) {
    let l = set.len() as u32;
    let mut albedos: Vec<GgxAlbedo> = Vec::new();
    let mut adjacency = None;
    for &face in &index.faces {
        let f = &scene.faces[face as usize];
        let n = f.normal();
        let model = scene.lobes[face as usize];
        let alpha = model.alpha();
        if alpha > 0.0 && !albedos.iter().any(|a| a.alpha == alpha) {
            albedos.push(GgxAlbedo::new(alpha));
        }
        let albedo = albedos.iter().find(|a| alpha > 0.0 && a.alpha == alpha);
        if let (SpecularModel::Tiles { .. }, Some(albedo)) = (model, albedo) {
            let adjacency = adjacency.get_or_insert_with(|| lobe::Adjacency::new(set));
            let columns = if normalised {
                let (columns, norm) = lobe::face_lobe(set, adjacency, dirs, n, albedo);
                if norm.row_error > 1e-3 {
                    log::warn!(
                        "glossy face {face}: lobe normalisation left rows {:.2e} off after {} iterations",
                        norm.row_error,
                        norm.iterations
                    );
                }
                columns
            } else {
                lobe::face_lobe_support(set, adjacency, dirs, n, albedo)
            };
            for c in columns {
                let loss = (1.0 - c.albedo) / c.albedo;
                for &(v, w) in &c.targets {
                    sink(
                        c.dir,
                        ReflectJob {
                            face,
                            j: v % l,
                            weight: w,
                            loss,
                            incoming_sense: c.sense as u8,
                            sense: (v / l) as u8,
                        },
                    );
                }
            }
            continue;
        }
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
        let pane_ior = match model {
            SpecularModel::Pane { ior } => Some(ior),
            _ => None,
        };
        for (di, sense, verts, weights) in splats {
            let d = &dirs[di];
            let cos_t = n.dot(d.frame.w).abs();
            // A lobe narrower than the spacing keeps its directional albedo; a pane reflects
            // R(θ) of what arrives (the rest passes through it in the interface step, so
            // nothing is lost here).
            let (keep, loss) = match (pane_ior, albedo) {
                (Some(ior), _) => (crate::scene::pane_reflectance(cos_t, ior), 0.0),
                (None, Some(a)) => {
                    let a = a.at(cos_t);
                    (a, (1.0 - a) / a)
                }
                (None, None) => (1.0, 0.0),
            };
            // A sun is a single direction outside the quadrature: its three destinations are
            // normalised to conserve its power (Σ_k L_k·ΔΩ_k·cos_k = ρ·E·cos_t) rather than by
            // W(f, v), which makes uniform radiance reflect exactly and leaves a sun's
            // reflection off by the spread of W around ΔΩ.
            let sun_norm = d.sun.is_some().then(|| {
                (0..3)
                    .map(|k| {
                        let cos_v = n.dot(set.sphere_vertex(verts[k])).abs();
                        if weights[k] > 0.0 && cos_v >= MIN_COS {
                            weights[k] * set.solid_angle(verts[k]) * cos_v
                        } else {
                            0.0
                        }
                    })
                    .sum::<f32>()
            });
            for k in 0..3 {
                let v = verts[k] as usize;
                let weight = match sun_norm {
                    Some(s) if s > 0.0 && weights[k] > 0.0 => weights[k] * cos_t / s,
                    None if weights[k] > 0.0 && norm[v] > 0.0 => {
                        // Quadrature directions carry radiance × ΔΩ.
                        weights[k] * d.weight / norm[v] as f32
                    }
                    _ => continue,
                };
                let weight = if albedo.is_some() || pane_ior.is_some() {
                    weight * keep
                } else {
                    weight
                };
                sink(
                    di,
                    ReflectJob {
                        face,
                        j: verts[k] % l,
                        weight,
                        loss,
                        incoming_sense: sense as u8,
                        sense: (verts[k] / l) as u8,
                    },
                );
            }
        }
    }
}

/// The non-diffuse state of an iteration: tile index, fixed-direction frames and the unshot
/// tile radiance that senders read.
pub struct Specular<'a> {
    pub index: &'a TileIndex,
    pub set: &'a DirectionSet,
    pub frames: &'a [PsfFrame],
    pub unshot: &'a [[f32; 4]],
}

/// Non-diffuse state shared by the CPU and GPU propagators.
pub struct SpecularSetup {
    pub index: TileIndex,
    pub frames: Vec<PsfFrame>,
    /// Per transport direction (same order as [`all_directions`](super::all_directions)).
    pub jobs: Vec<Vec<ReflectJob>>,
    /// Per face (all faces, 0 for diffuse ones): the share of its specular part that the rays
    /// cannot carry into its tiles, 1 − [`reach_factors`], which `finish_iteration` re-emits
    /// diffusely. 0 for a face every direction reaches (all but the smallest faces).
    pub unresolved: Vec<f32>,
}

impl SpecularSetup {
    /// `None` when the scene has no mirror or mixed face.
    pub fn new(
        scene: &BakeScene,
        set: &DirectionSet,
        grid: &PsfGrid,
        dirs: &[TransportDir],
    ) -> Option<Self> {
        if scene.faces.iter().all(|f| f.kind == FACE_DIFFUSE) {
            return None;
        }
        let index = tile_index(scene, set, grid);
        let mut unresolved = vec![0f32; scene.faces.len()];
        for (&face, r) in index
            .faces
            .iter()
            .zip(reach_factors(scene, grid, dirs, &index))
        {
            // A pane's light that no ray carries passes by it anyway: nothing to re-emit.
            if scene.panes[face as usize].weight <= 0.0 {
                unresolved[face as usize] = 1.0 - r;
            }
        }
        let jobs = reflect_jobs(scene, set, dirs, &index);
        Some(Self {
            index,
            frames: fixed_frames(set),
            jobs,
            unresolved,
        })
    }

    /// The tile index and what [`SpecularSetup::new`]'s jobs will take, without making them
    /// (for a memory plan); `None` when the scene has no mirror or mixed face.
    pub fn counted(
        scene: &BakeScene,
        set: &DirectionSet,
        grid: &PsfGrid,
        dirs: &[TransportDir],
    ) -> Option<(TileIndex, ReflectCounts)> {
        if scene.faces.iter().all(|f| f.kind == FACE_DIFFUSE) {
            return None;
        }
        let index = tile_index(scene, set, grid);
        let counts = reflect_counts(scene, set, dirs, &index);
        Some((index, counts))
    }
}
