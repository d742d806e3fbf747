//! The glossy reflect weights (`docs/PROPAGATION.md`): how light arriving on a face with a GGX metal lobe
//! from each transport direction is spread over the fixed directions of the lobe.
//!
//! For a face with unit normal n, take the side that faces +n (the other side is its point
//! reflection: every direction below maps to its antipode, with the same weights). A *column*
//! is an incoming transport direction t (travelling towards the face, `cos_t = −n·t > 0`,
//! quadrature weight `ω_t`: its solid angle, or 1 for a sun, whose arriving value is an
//! irradiance); a *row* is a sphere vertex v above the face: the fixed direction `v mod l`,
//! sense `v div l`, that reflected light leaves in (`cos_v = n·v`, solid angle `ΔΩ_v`).
//!
//! 1. **Lobe.** `M₀[v][t] = f(v, −t)·cos_v·ΔΩ_v · cos_t·ω_t`, the lobe
//!    (`pathtrace::material::ggx_metal`, the path tracer's) at the vertex times its cell, for
//!    the vertices a breadth-first walk over the direction mesh reaches from the mirror
//!    direction while they hold at least [`EXPAND`] of the column's largest value; then the
//!    smallest are dropped until the kept ones hold [`KEEP`] of the column (GGX has long
//!    tails; what they held goes to the rest in step 2).
//!    **Reciprocity of the support** (when the transport directions are the set's own, no
//!    perturbed copies: every column is then also a vertex): entry `(v, from u)` is kept
//!    whenever `(u, from v)` is, with the same value (M₀ is symmetric). Each column's
//!    truncation alone left rows near the horizon that a single column reached, and step 2
//!    could then never meet their targets (cornell-suzanne at 606 directions: rows 0.2–61 %
//!    off after 1000 iterations on 144 of Suzanne's 3,883 faces); with it, every one of them
//!    converges (24 % more entries there).
//! 2. **Normalisation** (Sinkhorn's alternating scaling): every column sums to
//!    `A(cos_t)·cos_t·ω_t`, what the lobe reflects of the light arriving from t (A: its
//!    directional albedo, `pathtrace::material::GgxAlbedo`), so energy is conserved to the
//!    albedo; and every row to `A(cos_v)·cos_v·ΔΩ_v`, so that uniform radiance L leaves as
//!    `A(cos_v)·L` in every direction (the furnace). When the transport directions are the
//!    fixed ones, M₀ is symmetric (reciprocity) and both sets of sums are the same numbers.
//!    Suns are outside the quadrature: their columns get the energy normalisation only.
//! 3. **Weight** of row v in column t: `M[v][t] / (cos_v·ΔΩ_v)`, the radiance leaving along v
//!    per unit of radiance (sun: irradiance) arriving from t, per unit reflectance.
//!
//! A perfect mirror is the limit the reflect jobs keep separately (`tiles::reflect_jobs`):
//! three vertices with barycentric weights, normalised per destination.

use glam::Vec3;

use super::MIN_COS;
use super::transport::TransportDir;
use crate::directions::DirectionSet;
use crate::pathtrace::material::{GgxAlbedo, ggx_metal};

/// The walk over the mesh continues past a vertex holding at least this fraction of the
/// column's largest value.
pub const EXPAND: f32 = 1e-3;
/// Fraction of a column's (point-sampled) lobe kept; the smallest entries beyond it are
/// dropped.
pub const KEEP: f32 = 0.9;
/// Sinkhorn stops when every row sum is within this relative tolerance of its target.
pub const TOLERANCE: f64 = 1e-5;
/// Sinkhorn's iteration cap.
pub const MAX_ITERATIONS: usize = 1000;

/// The neighbours of every sphere vertex in the direction mesh.
pub struct Adjacency(Vec<Vec<u32>>);

impl Adjacency {
    pub fn new(set: &DirectionSet) -> Adjacency {
        let mut adj = vec![Vec::new(); set.sphere_vertex_count()];
        for t in set.sphere_triangles() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                adj[a as usize].push(b);
                adj[b as usize].push(a);
            }
        }
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        Adjacency(adj)
    }
}

/// One incoming direction's reflection: the destination sphere vertices with their weights
/// (outgoing radiance per unit arriving, per unit reflectance) and the lobe's directional
/// albedo for it (what it keeps of the arriving light; the rest is absorbed).
#[derive(Clone, Debug, PartialEq)]
pub struct LobeColumn {
    /// Index of the transport direction.
    pub dir: usize,
    /// Incoming sense (0 = travelling +w).
    pub sense: u32,
    pub albedo: f32,
    pub targets: Vec<(u32, f32)>,
}

/// Result of the normalisation of one face (for tests and logs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Normalisation {
    /// Sinkhorn iterations run.
    pub iterations: usize,
    /// Largest relative deviation of a row sum from its target after the last column step.
    pub row_error: f64,
    /// Σ row targets / Σ column targets before the rows were scaled to match.
    pub target_ratio: f64,
}

struct Column {
    dir: usize,
    /// Sense in the +n-side problem.
    sense: u32,
    /// The face is lit on its −n side: targets and sense map to the antipodes.
    flipped: bool,
    sun: bool,
    /// The sphere vertex the light comes from (`−t`, above the face) when the direction is
    /// one of the set's (no perturbed copies): the column is then also that vertex's row.
    source: Option<u32>,
    albedo: f32,
    target: f64,
    entries: Vec<(u32, f64)>,
}

/// The glossy lobe of one face: its columns for every transport direction that reaches it
/// (both sides), normalised.
pub fn face_lobe(
    set: &DirectionSet,
    adjacency: &Adjacency,
    dirs: &[TransportDir],
    normal: Vec3,
    albedo: &GgxAlbedo,
) -> (Vec<LobeColumn>, Normalisation) {
    face_lobe_with(set, adjacency, dirs, normal, albedo, true)
}

/// [`face_lobe`]'s columns with their targets as it makes them (steps 1 and 1b), without
/// the normalisation (step 2), which changes no target but costs the most: what the memory
/// plan counts (`tiles::reflect_counts`). Their weights are not the lobe's.
pub fn face_lobe_support(
    set: &DirectionSet,
    adjacency: &Adjacency,
    dirs: &[TransportDir],
    normal: Vec3,
    albedo: &GgxAlbedo,
) -> Vec<LobeColumn> {
    face_lobe_with(set, adjacency, dirs, normal, albedo, false).0
}

fn face_lobe_with(
    set: &DirectionSet,
    adjacency: &Adjacency,
    dirs: &[TransportDir],
    normal: Vec3,
    albedo: &GgxAlbedo,
    normalised: bool,
) -> (Vec<LobeColumn>, Normalisation) {
    let n2 = set.sphere_vertex_count();
    let l = set.len() as u32;
    let mut walk = Walk::new(n2);
    let mut cols = Vec::with_capacity(dirs.len() + 1);
    // The quadrature directions are the set's own (no perturbed copies), in its order.
    let own = dirs.iter().filter(|d| d.sun.is_none()).count() == set.len();
    for (di, d) in dirs.iter().enumerate() {
        // In the +n-side problem: the sense travelling against n (or, for a sun lighting the
        // −n side, its direction flipped).
        let c = -normal.dot(d.frame.w);
        if c.abs() <= MIN_COS {
            continue;
        }
        let (sense, flipped) = match (d.sun.is_some(), c > 0.0) {
            (false, true) => (0, false),
            (false, false) => (1, false),
            (true, lit_front) => (0, !lit_front),
        };
        let t = if c > 0.0 { d.frame.w } else { -d.frame.w };
        let cos_t = c.abs();
        let omega = if d.sun.is_some() { 1.0 } else { d.weight };
        let a = albedo.at(cos_t);
        let mut entries = walk.column(set, adjacency, normal, -t, albedo.alpha);
        let source = (own && d.sun.is_none())
            .then(|| [di as u32, di as u32 + l])
            .and_then(|c| {
                c.into_iter()
                    .find(|&v| set.sphere_vertex(v).dot(-t) > 1.0 - 1e-6)
            });
        let scale = f64::from(cos_t) * f64::from(omega);
        for e in &mut entries {
            e.1 *= scale;
        }
        cols.push(Column {
            dir: di,
            sense,
            flipped,
            sun: d.sun.is_some(),
            source,
            albedo: a,
            target: f64::from(a) * scale,
            entries,
        });
    }
    symmetrise(&mut cols, n2);
    let norm = if normalised {
        normalise(set, normal, albedo, &mut cols)
    } else {
        Normalisation::default()
    };
    let out = cols
        .into_iter()
        .flat_map(|c| {
            let weights: Vec<(u32, f32)> = c
                .entries
                .iter()
                .map(|&(v, m)| {
                    let cell =
                        f64::from(normal.dot(set.sphere_vertex(v))) * f64::from(set.solid_angle(v));
                    (v, (m / cell) as f32)
                })
                .collect();
            let antipodes = |w: &[(u32, f32)]| -> Vec<(u32, f32)> {
                w.iter().map(|&(v, x)| ((v + l) % (2 * l), x)).collect()
            };
            let column = |sense, targets| LobeColumn {
                dir: c.dir,
                sense,
                albedo: c.albedo,
                targets,
            };
            if c.sun {
                let targets = if c.flipped {
                    antipodes(&weights)
                } else {
                    weights
                };
                vec![column(0, targets)]
            } else {
                // The −n side is lit by the other sense, reflecting to the antipodes.
                let other = antipodes(&weights);
                vec![column(c.sense, weights), column(1 - c.sense, other)]
            }
        })
        .collect();
    (out, norm)
}

/// Step 1b, reciprocity of the support: where the columns are the set's own directions
/// (every quadrature column's source is a sphere vertex), entry (v, column from u) is kept
/// exactly when (u, column from v) is: each column's truncation keeps only its own largest
/// values, so a row near the horizon could be reached by a single column, whose other rows
/// then kept the normalisation from ever meeting that row's target (rows 0.2–61 % off after
/// 1000 iterations on 144 of cornell-suzanne's 3,883 glossy faces). The added entry is the
/// same number (M₀ is symmetric: `f(v, u)·cos_v·ΔΩ_v·cos_u·ΔΩ_u`).
fn symmetrise(cols: &mut [Column], vertices: usize) {
    let mut by_source = vec![u32::MAX; vertices];
    for (ci, c) in cols.iter().enumerate() {
        if let Some(u) = c.source {
            by_source[u as usize] = ci as u32;
        }
    }
    let mut kept: Vec<Vec<u32>> = cols
        .iter()
        .map(|c| {
            let mut v: Vec<u32> = c.entries.iter().map(|e| e.0).collect();
            v.sort_unstable();
            v
        })
        .collect();
    let mut added: Vec<(u32, u32, f64)> = Vec::new();
    for c in cols.iter() {
        let Some(u) = c.source else { continue };
        for &(v, m) in &c.entries {
            let other = by_source[v as usize];
            if other != u32::MAX && kept[other as usize].binary_search(&u).is_err() {
                added.push((other, u, m));
            }
        }
    }
    added.sort_by_key(|a| (a.0, a.1));
    added.dedup_by(|a, b| (a.0, a.1) == (b.0, b.1));
    for (other, u, m) in added {
        cols[other as usize].entries.push((u, m));
        kept[other as usize].push(u);
    }
}

/// Step 2 on the +n-side problem: quadrature columns and rows by alternate scaling, then
/// suns' columns to their targets.
fn normalise(
    set: &DirectionSet,
    normal: Vec3,
    albedo: &GgxAlbedo,
    cols: &mut [Column],
) -> Normalisation {
    let n2 = set.sphere_vertex_count();
    let mut row_target = vec![0f64; n2];
    let mut present = vec![false; n2];
    let mut col_total = 0f64;
    for c in cols.iter().filter(|c| !c.sun) {
        col_total += c.target;
        for &(v, _) in &c.entries {
            present[v as usize] = true;
        }
    }
    let mut row_total = 0f64;
    for v in 0..n2 {
        if present[v] {
            let cos_v = normal.dot(set.sphere_vertex(v as u32));
            let cell = f64::from(cos_v) * f64::from(set.solid_angle(v as u32));
            row_target[v] = f64::from(albedo.at(cos_v)) * cell;
            row_total += row_target[v];
        }
    }
    let mut out = Normalisation {
        target_ratio: if col_total > 0.0 {
            row_total / col_total
        } else {
            1.0
        },
        ..Default::default()
    };
    // Both sets of sums must have the same total (they differ only by quadrature aliasing,
    // or rows no column reaches).
    if row_total > 0.0 {
        let k = col_total / row_total;
        row_target.iter_mut().for_each(|r| *r *= k);
    }
    let scale_columns = |cols: &mut [Column], suns: bool| {
        for c in cols.iter_mut().filter(|c| c.sun == suns) {
            let s: f64 = c.entries.iter().map(|e| e.1).sum();
            if s > 0.0 {
                let k = c.target / s;
                c.entries.iter_mut().for_each(|e| e.1 *= k);
            }
        }
    };
    let mut row_sum = vec![0f64; n2];
    for it in 0..MAX_ITERATIONS {
        scale_columns(cols, false);
        row_sum.fill(0.0);
        for c in cols.iter().filter(|c| !c.sun) {
            for &(v, m) in &c.entries {
                row_sum[v as usize] += m;
            }
        }
        out.iterations = it + 1;
        out.row_error = (0..n2)
            .filter(|&v| present[v] && row_target[v] > 0.0)
            .map(|v| (row_sum[v] / row_target[v] - 1.0).abs())
            .fold(0.0, f64::max);
        // End on a column step whatever happens: energy conservation is exact, the furnace
        // (rows) to the tolerance where the sparse lobe allows it.
        if out.row_error < TOLERANCE || it + 1 == MAX_ITERATIONS {
            break;
        }
        for c in cols.iter_mut().filter(|c| !c.sun) {
            for e in &mut c.entries {
                let s = row_sum[e.0 as usize];
                if s > 0.0 {
                    e.1 *= row_target[e.0 as usize] / s;
                }
            }
        }
    }
    scale_columns(cols, true);
    out
}

/// The breadth-first walk over the direction mesh that collects a column (reusable scratch).
struct Walk {
    stamp: Vec<u32>,
    generation: u32,
    queue: std::collections::VecDeque<u32>,
}

impl Walk {
    fn new(vertices: usize) -> Walk {
        Walk {
            stamp: vec![0; vertices],
            generation: 0,
            queue: std::collections::VecDeque::new(),
        }
    }

    /// Step 1 for light arriving from `wi` (unit, pointing away from the face, `n·wi > 0`):
    /// `(v, f(v, wi)·cos_v·ΔΩ_v)` over the kept vertices, largest first.
    fn column(
        &mut self,
        set: &DirectionSet,
        adjacency: &Adjacency,
        n: Vec3,
        wi: Vec3,
        alpha: f32,
    ) -> Vec<(u32, f64)> {
        self.generation += 1;
        let g = self.generation;
        let r = 2.0 * n.dot(wi) * n - wi;
        let start = set.lookup(r).vertices;
        for &v in &start {
            if self.stamp[v as usize] != g {
                self.stamp[v as usize] = g;
                self.queue.push_back(v);
            }
        }
        let mut entries: Vec<(u32, f64)> = Vec::new();
        let mut max = 0f32;
        while let Some(v) = self.queue.pop_front() {
            let p = set.sphere_vertex(v);
            let cos_v = n.dot(p);
            let val = if cos_v > MIN_COS {
                ggx_metal(n, p, wi, alpha) * cos_v * set.solid_angle(v)
            } else {
                0.0
            };
            if val > 0.0 {
                entries.push((v, f64::from(val)));
                max = max.max(val);
            }
            if start.contains(&v) || (val > 0.0 && val >= EXPAND * max) {
                for &nb in &adjacency.0[v as usize] {
                    if self.stamp[nb as usize] != g {
                        self.stamp[nb as usize] = g;
                        self.queue.push_back(nb);
                    }
                }
            }
        }
        entries.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let total: f64 = entries.iter().map(|e| e.1).sum();
        let mut kept = 0f64;
        let mut len = 0;
        for e in &entries {
            if kept >= f64::from(KEEP) * total {
                break;
            }
            kept += e.1;
            len += 1;
        }
        entries.truncate(len);
        entries
    }
}
