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
//!    in from rays that hit another face), weighted by |cos θ| × the direction's solid angle.
//!
//! The gather is per texel, so no float atomics and the result is bit-reproducible.

use glam::{Vec2, Vec3, Vec4};
use serde::Serialize;

use super::params::{BakeParams, Iterations};
use super::prep::{BakeScene, FACE_DIFFUSE};
use super::tiles;
use crate::directions::DirectionSet;
use crate::psf::{PsfFrame, PsfGrid, twist_angle};

/// One transport direction: a PSF frame, its quadrature weight, and whether it carries both
/// senses (`w` and `−w`, the fixed and perturbed directions) or only `+w` (a sun).
#[derive(Clone, Copy, Debug)]
pub struct TransportDir {
    pub frame: PsfFrame,
    /// Solid angle per sense (steradians) for quadrature directions; 1 for suns.
    pub weight: f32,
    /// For suns: the irradiance entering along `+w`. `None` for quadrature directions.
    pub sun: Option<Vec3>,
}

/// The transport directions of a bake: every direction of the set (both senses), each with
/// `perturb` jittered copies inside its solid-angle cell (weights split evenly).
pub fn transport_directions(set: &DirectionSet, params: &BakeParams) -> Vec<TransportDir> {
    let mut out = Vec::with_capacity(set.len() * (1 + params.perturb as usize));
    let mut rng = SplitMix64(params.seed);
    for i in 0..set.len() {
        let w = set.direction(i);
        let omega = set.solid_angle(i as u32);
        if params.perturb == 0 {
            out.push(TransportDir {
                frame: fixed_frame(set, i),
                weight: omega,
                sun: None,
            });
            continue;
        }
        let n = params.perturb as usize;
        // Jitter inside the spherical cap of the same solid angle around ω_i: it covers the
        // direction's share of the sphere and is symmetric, so the mean stays at ω_i.
        let frame = PsfFrame::new(w);
        let cos_max = 1.0 - omega / (2.0 * std::f32::consts::PI);
        for s in 0..n {
            // Stratified in the cap's area: radius by sqrt-free area fraction, angle by a
            // golden-ratio sequence.
            let u = (s as f32 + rng.next_f32()) / n as f32;
            let phi = 2.0 * std::f32::consts::PI * fract(s as f32 * 0.618_034 + rng.next_f32());
            let cos_t = 1.0 - u * (1.0 - cos_max);
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let d = frame.w * cos_t + (frame.u * phi.cos() + frame.v * phi.sin()) * sin_t;
            out.push(TransportDir {
                frame: PsfFrame::new(d).twisted(twist_angle(set.len() + out.len())),
                weight: omega / n as f32,
                sun: None,
            });
        }
    }
    out
}

/// The PSF frame of fixed direction `i`: the canonical frame twisted by [`twist_angle`]`(i)`.
/// Everything that addresses a fixed direction's ray grid (propagation, mirror tiles, the
/// renderer's lookup) uses this frame.
pub fn fixed_frame(set: &DirectionSet, i: usize) -> PsfFrame {
    PsfFrame::new(set.direction(i)).twisted(twist_angle(i))
}

fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// Tiny deterministic PRNG (SplitMix64).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Energy bookkeeping of a bake (powers in VLF units², summed over r, g, b).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct EnergyStats {
    /// Σ π·L_e·area of emitting texels.
    pub emitted: f64,
    /// Power received directly from the sky and suns (first iteration).
    pub injected: f64,
    /// Power absorbed by surfaces, all iterations.
    pub absorbed: f64,
    /// Power that left the scene (rays reaching the unit sphere), all iterations.
    pub escaped: f64,
    /// Power still unshot after the last iteration.
    pub unshot: f64,
    /// Unshot power after each iteration.
    pub unshot_history: Vec<f64>,
}

impl EnergyStats {
    /// Adds one finished iteration's terms (shared by the CPU and GPU propagators).
    pub fn record(&mut self, e: &IterationEnergy) {
        self.injected += e.injected;
        self.absorbed += e.absorbed;
        self.escaped += e.escaped;
        self.unshot = e.next;
        self.unshot_history.push(e.next);
    }

    /// Whether the unshot power is at most `threshold` × (emitted + injected); never for a
    /// threshold of 0 (fixed iteration counts).
    pub fn converged(&self, threshold: f32) -> bool {
        let src = self.emitted + self.injected;
        threshold > 0.0 && (src <= 0.0 || self.unshot <= f64::from(threshold) * src)
    }

    /// (emitted + injected) − (absorbed + escaped + unshot), relative to emitted + injected.
    pub fn relative_imbalance(&self) -> f64 {
        let src = self.emitted + self.injected;
        if src <= 0.0 {
            return 0.0;
        }
        (src - (self.absorbed + self.escaped + self.unshot)) / src
    }
}

/// The result of a propagation: outgoing radiance per texel (both sides), emission included.
#[derive(Clone, Debug)]
pub struct Propagated {
    /// Total outgoing radiance per texel (rgb, a = 0).
    pub radiance: Vec<[f32; 4]>,
    /// Sparse tiles of non-diffuse faces and their total outgoing radiance (specular part).
    pub tiles: Option<(tiles::TileIndex, Vec<[f32; 4]>)>,
    pub iterations: u32,
    pub energy: EnergyStats,
}

/// Per-direction cell lists: for cell `c`, crossings `start[c]..start[c+1]` of `entries`,
/// sorted by depth along `+w`.
#[derive(Clone, Debug, Default)]
pub struct CellLists {
    pub n: u32,
    pub start: Vec<u32>,
    /// (depth along w, face)
    pub entries: Vec<(f32, u32)>,
}

impl CellLists {
    fn cell(&self, c: usize) -> &[(f32, u32)] {
        &self.entries[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// Triangles binned into the tiles of one direction's grid: tile `t` holds
/// `tris[start[t]..start[t + 1]]`. Shared by the CPU reference and the GPU propagator (which
/// uploads these arrays), so both see identical candidate lists.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    pub start: Vec<u32>,
    pub tris: Vec<u32>,
}

impl Bins {
    /// Longest tile list: an upper bound on the crossings of any ray of this direction.
    pub fn max_len(&self) -> u32 {
        self.start
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(0)
    }
}

/// Projects every triangle into the PSF plane (`(a, b, depth)` per corner).
pub fn project(scene: &BakeScene, frame: &PsfFrame) -> Vec<[Vec3; 3]> {
    scene
        .triangles
        .iter()
        .map(|t| [t.p0, t.p1, t.p2].map(|p| frame.to_psf(Vec3::from(p))))
        .collect()
}

/// Step 1: lists every triangle in each tile whose cell centres its projected bounding box
/// may contain (conservative).
pub fn bin_triangles(proj: &[[Vec3; 3]], grid: &PsfGrid) -> Bins {
    let n = grid.n as usize;
    let tiles = grid.tiles_per_side() as usize;
    let cell = grid.cell_size();
    let m = grid.tile as usize;
    let mut counts = vec![0u32; tiles * tiles + 1];
    let mut ranges = Vec::with_capacity(proj.len());
    for q in proj {
        let lo = q[0].min(q[1]).min(q[2]);
        let hi = q[0].max(q[1]).max(q[2]);
        // cells whose centre (−1 + (i + 0.5)·cell) lies in [lo, hi], widened by one cell
        // against rounding differences between the CPU and GPU projections.
        let first =
            |x: f32| ((((x + 1.0) / cell - 0.5).floor() - 1.0).max(0.0) as usize).min(n - 1);
        let last = |x: f32| ((((x + 1.0) / cell - 0.5).ceil() + 1.0).max(0.0) as usize).min(n - 1);
        let (i0, j0, i1, j1) = (first(lo.x), first(lo.y), last(hi.x), last(hi.y));
        let r = (i0 / m, j0 / m, i1 / m, j1 / m);
        for tj in r.1..=r.3 {
            for ti in r.0..=r.2 {
                counts[tj * tiles + ti] += 1;
            }
        }
        ranges.push(r);
    }
    let mut start = Vec::with_capacity(tiles * tiles + 1);
    let mut acc = 0u32;
    for c in &counts[..tiles * tiles] {
        start.push(acc);
        acc += c;
    }
    start.push(acc);
    let mut fill = start.clone();
    let mut tris = vec![0u32; acc as usize];
    for (ti, r) in ranges.iter().enumerate() {
        for tj in r.1..=r.3 {
            for tx in r.0..=r.2 {
                let slot = &mut fill[tj * tiles + tx];
                tris[*slot as usize] = ti as u32;
                *slot += 1;
            }
        }
    }
    Bins { start, tris }
}

/// Steps 1–2: bin triangles into tiles and build the exact per-ray depth lists.
pub fn build_cell_lists(scene: &BakeScene, grid: &PsfGrid, frame: &PsfFrame) -> CellLists {
    let n = grid.n as usize;
    let tiles = grid.tiles_per_side() as usize;
    let m = grid.tile as usize;
    let proj = project(scene, frame);
    let bins = bin_triangles(&proj, grid);
    // 2. exact crossings per cell.
    let mut start = Vec::with_capacity(n * n + 1);
    let mut entries = Vec::new();
    let mut hits: Vec<(f32, u32)> = Vec::new();
    for j in 0..n {
        for i in 0..n {
            start.push(entries.len() as u32);
            let (a, b) = grid.cell_center(i as u32, j as u32);
            let p = Vec2::new(a, b);
            hits.clear();
            let tile = (j / m) * tiles + i / m;
            for &ti in &bins.tris[bins.start[tile] as usize..bins.start[tile + 1] as usize] {
                if let Some(depth) = ray_hit(&proj[ti as usize], p) {
                    hits.push((depth, scene.triangles[ti as usize].face));
                }
            }
            hits.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            // A planar face is crossed once: drop duplicates from shared triangle edges.
            for &h in &hits {
                if !entries[*start.last().unwrap() as usize..]
                    .iter()
                    .any(|e: &(f32, u32)| e.1 == h.1)
                {
                    entries.push(h);
                }
            }
        }
    }
    start.push(entries.len() as u32);
    CellLists {
        n: grid.n,
        start,
        entries,
    }
}

/// Depth at which the ray through `p` (PSF plane) crosses triangle `q` (PSF coords), if it does.
/// Edges are inclusive; both windings accepted.
pub fn ray_hit(q: &[Vec3; 3], p: Vec2) -> Option<f32> {
    let a = q[0].truncate();
    let b = q[1].truncate();
    let c = q[2].truncate();
    let area = (b - a).perp_dot(c - a);
    if area == 0.0 {
        return None; // seen edge-on: crossing has no extent
    }
    let w0 = (b - p).perp_dot(c - p) / area;
    let w1 = (c - p).perp_dot(a - p) / area;
    let w2 = 1.0 - w0 - w1;
    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
        return None;
    }
    Some(w0 * q[0].z + w1 * q[1].z + w2 * q[2].z)
}

/// Per crossing: unshot radiance arriving from neighbouring surfaces travelling +w (from below)
/// and −w (from above); and whether it is the first/last crossing of its ray. A first (last)
/// crossing is *open* below (above): sky and sun light enter there, and light leaving it
/// downward (upward) escapes the scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct Interface {
    pub from_below: Vec3,
    pub from_above: Vec3,
    pub first: bool,
    pub last: bool,
}

/// The non-diffuse state of an iteration: tile index, fixed-direction frames and the unshot
/// tile radiance that senders read.
pub struct Specular<'a> {
    pub index: &'a tiles::TileIndex,
    pub set: &'a DirectionSet,
    pub frames: &'a [PsfFrame],
    pub unshot: &'a [[f32; 4]],
}

/// Step 3: arriving radiance at every crossing. Also returns the specular power that leaves
/// through open ends of rays (escapes), for the energy bookkeeping.
pub fn interface(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    lists: &CellLists,
    unshot: &[[f32; 4]],
    spec: Option<&Specular>,
) -> (Vec<Interface>, f64) {
    let frame = &dir.frame;
    let n = grid.n as usize;
    let w = frame.w;
    let mut out = vec![Interface::default(); lists.entries.len()];
    let cell_power = f64::from(grid.cell_size() * grid.cell_size() * dir.weight);
    let mut escaped = 0f64;
    // Unshot radiance leaving crossing `e` of `cell` in direction `toward`·w.
    let outgoing = |cell: (u32, u32), e: (f32, u32), toward: f32| -> (Vec3, Vec3) {
        let f = &scene.faces[e.1 as usize];
        let (a, b) = grid.cell_center(cell.0, cell.1);
        let y = frame.from_psf(Vec3::new(a, b, e.0));
        let side = u32::from(f.normal().dot(w) * toward <= 0.0);
        let diffuse = Vec4::from(unshot[f.texel_at(y, side) as usize]).truncate();
        let specular = match spec {
            Some(sp) if f.kind != FACE_DIFFUSE => {
                tiles::specular_outgoing(sp.index, sp.unshot, sp.set, sp.frames, e.1, y, w * toward)
            }
            _ => Vec3::ZERO,
        };
        (diffuse, specular)
    };
    for c in 0..n * n {
        let cell = ((c % n) as u32, (c / n) as u32);
        let s = lists.start[c] as usize;
        let list = lists.cell(c);
        for k in 0..list.len() {
            let first = k == 0;
            let last = k + 1 == list.len();
            let sum = |(d, s): (Vec3, Vec3)| d + s;
            out[s + k] = Interface {
                from_below: if first {
                    Vec3::ZERO
                } else {
                    sum(outgoing(cell, list[k - 1], 1.0))
                },
                from_above: if last {
                    Vec3::ZERO
                } else {
                    sum(outgoing(cell, list[k + 1], -1.0))
                },
                first,
                last,
            };
            // Specular light leaving through an open end escapes (diffuse escapes are counted
            // per texel from the open fractions).
            if spec.is_some()
                && dir.sun.is_none()
                && scene.faces[list[k].1 as usize].kind != FACE_DIFFUSE
            {
                if last {
                    escaped += sum3(outgoing(cell, list[k], 1.0).1) * cell_power;
                }
                if first {
                    escaped += sum3(outgoing(cell, list[k], -1.0).1) * cell_power;
                }
            }
        }
    }
    (out, escaped)
}

/// What one direction's gather needs for non-diffuse faces: the sender state, this direction's
/// reflect jobs, and the next-iteration tiles they write.
pub type SpecularStep<'a, 'b> = (
    &'a Specular<'a>,
    &'b [tiles::ReflectJob],
    &'b mut [[f32; 4]],
);

/// The reflect step (receiving on non-diffuse faces) for one transport direction: every
/// destination cell of every job maps through the face plane into this direction's PSF and
/// gathers the radiance arriving there (`sky` enters through open ends).
#[allow(clippy::too_many_arguments)]
pub fn reflect(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    lists: &CellLists,
    iface: &[Interface],
    index: &tiles::TileIndex,
    frames: &[PsfFrame],
    jobs: &[tiles::ReflectJob],
    sky: Vec3,
    next: &mut [[f32; 4]],
) {
    let n = grid.n;
    let m = index.m;
    let tps = n / m;
    for job in jobs {
        let f = &scene.faces[job.face as usize];
        let normal = f.normal();
        let fr = &frames[job.j as usize];
        let ndw = normal.dot(fr.w);
        if ndw.abs() < MIN_COS {
            continue;
        }
        let mf = index.face_slot[job.face as usize] as usize;
        let k = mf * index.directions as usize + job.j as usize;
        for slot in index.index_start[k] as usize..index.index_start[k + 1] as usize {
            let tile = index.tile_ids[slot];
            let (tx, ty) = (tile % tps, tile / tps);
            for local in 0..m * m {
                if !index.covered(slot, local) {
                    continue;
                }
                let (ci, cj) = (tx * m + local % m, ty * m + local / m);
                let (a, b) = grid.cell_center(ci, cj);
                let o = fr.u * a + fr.v * b;
                let x = o + fr.w * ((f.offset - normal.dot(o)) / ndw);
                let q = dir.frame.to_psf(x);
                // The nearest ray of this direction that crosses the face (the destination
                // point may lie just outside the face as this grid samples it).
                let Some(k) = nearest_crossing(grid, lists, q.x, q.y, job.face) else {
                    continue;
                };
                let cr = &iface[k];
                let arriving = match (dir.sun, job.incoming_sense) {
                    (Some(irr), _) => irr * f32::from(u8::from(cr.first)),
                    (None, 0) => cr.from_below + sky * f32::from(u8::from(cr.first)),
                    (None, _) => cr.from_above + sky * f32::from(u8::from(cr.last)),
                };
                let i = (slot * 2 + job.sense as usize) * (m * m) as usize + local as usize;
                next[i] = (Vec4::from(next[i]) + (arriving * job.weight).extend(0.0)).into();
            }
        }
    }
}

/// Index into the crossing arrays of the crossing of `face` by the ray nearest to PSF point
/// `(a, b)` among the 3×3 cells around it, if any.
pub fn nearest_crossing(
    grid: &PsfGrid,
    lists: &CellLists,
    a: f32,
    b: f32,
    face: u32,
) -> Option<usize> {
    let n = grid.n as i64;
    let nf = grid.n as f32;
    let (cx, cy) = ((a + 1.0) * 0.5 * nf, (b + 1.0) * 0.5 * nf);
    let (ci, cj) = (cx.floor() as i64, cy.floor() as i64);
    let mut best: Option<(f32, usize)> = None;
    for dj in -1..=1i64 {
        for di in -1..=1i64 {
            let (i, j) = (ci + di, cj + dj);
            if i < 0 || j < 0 || i >= n || j >= n {
                continue;
            }
            let c = (j * n + i) as usize;
            if let Some(e) = lists.cell(c).iter().position(|e| e.1 == face) {
                let d2 = (i as f32 + 0.5 - cx).powi(2) + (j as f32 + 0.5 - cy).powi(2);
                if best.is_none_or(|b| d2 < b.0) {
                    best = Some((d2, lists.start[c] as usize + e));
                }
            }
        }
    }
    best.map(|b| b.1)
}

/// Power carried by tile radiance (Σ L × cell area × ΔΩ), summed over channels.
pub fn tile_power(
    index: &tiles::TileIndex,
    values: &[[f32; 4]],
    set: &DirectionSet,
    grid: &PsfGrid,
) -> f64 {
    let m2 = (index.m * index.m) as usize;
    let a = f64::from(grid.cell_size() * grid.cell_size());
    let mut p = 0f64;
    for k in 0..index.index_start.len() - 1 {
        let j = k % index.directions as usize;
        let omega = f64::from(set.solid_angle(j as u32));
        for slot in index.index_start[k] as usize..index.index_start[k + 1] as usize {
            for v in &values[slot * 2 * m2..(slot + 1) * 2 * m2] {
                p += sum3(Vec4::from(*v).truncate()) * a * omega;
            }
        }
    }
    p
}

/// Step 4 result for one texel and one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexelSample {
    /// Mean unshot radiance arriving from surfaces at side 0 (front) and side 1 (back).
    pub arriving: [Vec3; 2],
    /// Fraction of the rays whose upstream is open for side 0 / side 1: sky and sun enter
    /// through them, and the side's own outgoing light escapes along them.
    pub open: [f32; 2],
    /// |n·w|.
    pub cos: f32,
    /// False when no nearby ray crosses the texel's face (direction missing for this texel).
    pub valid: bool,
}

/// Step 4 for one texel: the mean arriving radiance of the rays that cross the texel's own
/// square on its own face (a box filter that never reaches past the texel, so light cannot leak
/// across a contact edge by filtering). When no ray crosses the texel in this direction (small
/// texel, grazing angle) it falls back to the nearest crossing of the same face within two cells.
#[allow(clippy::too_many_arguments)]
pub fn sample_texel(
    scene: &BakeScene,
    grid: &PsfGrid,
    frame: &PsfFrame,
    lists: &CellLists,
    iface: &[Interface],
    face: u32,
    texel: (u32, u32),
    point: Vec3,
) -> TexelSample {
    let f = &scene.faces[face as usize];
    let w = frame.w;
    let normal = f.normal();
    let ndw = normal.dot(w);
    if ndw.abs() < MIN_COS {
        return TexelSample::default();
    }
    let n = grid.n as i64;
    let find = |i: i64, j: i64| -> Option<&Interface> {
        if i < 0 || j < 0 || i >= n || j >= n {
            return None;
        }
        let c = (j * n + i) as usize;
        let s = lists.start[c] as usize;
        lists
            .cell(c)
            .iter()
            .position(|e| e.1 == face)
            .map(|k| &iface[s + k])
    };
    // The texel square's corners in PSF coordinates → range of cell centres to test.
    let origin = Vec3::from(f.origin);
    let (u, v, t) = (Vec3::from(f.u), Vec3::from(f.v), f.texel_size);
    let corner = |dx: f32, dy: f32| {
        let p = origin + u * ((texel.0 as f32 + dx) * t) + v * ((texel.1 as f32 + dy) * t);
        let q = frame.to_psf(p);
        Vec2::from(grid.continuous(q.x, q.y))
    };
    let cs = [
        corner(0.0, 0.0),
        corner(1.0, 0.0),
        corner(0.0, 1.0),
        corner(1.0, 1.0),
    ];
    let lo = cs[0].min(cs[1]).min(cs[2]).min(cs[3]);
    let hi = cs[0].max(cs[1]).max(cs[2]).max(cs[3]);
    let mut acc = Accum::default();
    let (i0, j0) = ((lo.x - 0.5).ceil() as i64, (lo.y - 0.5).ceil() as i64);
    let (i1, j1) = ((hi.x - 0.5).floor() as i64, (hi.y - 0.5).floor() as i64);
    let cell = grid.cell_size();
    for j in j0.max(0)..=j1.min(n - 1) {
        for i in i0.max(0)..=i1.min(n - 1) {
            // Where does this ray cross the face's plane, and is that inside our texel?
            let a = -1.0 + (i as f32 + 0.5) * cell;
            let b = -1.0 + (j as f32 + 0.5) * cell;
            let o = frame.u * a + frame.v * b;
            let depth = (f.offset - normal.dot(o)) / ndw;
            let d = o + w * depth - origin;
            let (x, y) = ((d.dot(u) / t).floor(), (d.dot(v) / t).floor());
            if x != texel.0 as f32 || y != texel.1 as f32 {
                continue;
            }
            if let Some(e) = find(i, j) {
                acc.add(e, 1.0);
            }
        }
    }
    if acc.weight == 0.0 {
        let q = frame.to_psf(point);
        let (cx, cy) = grid.continuous(q.x, q.y);
        let (ci, cj) = (cx.floor() as i64, cy.floor() as i64);
        let mut best: Option<(f32, &Interface)> = None;
        for dj in -FALLBACK_RADIUS..=FALLBACK_RADIUS {
            for di in -FALLBACK_RADIUS..=FALLBACK_RADIUS {
                if let Some(e) = find(ci + di, cj + dj) {
                    let d2 = ((ci + di) as f32 + 0.5 - cx).powi(2)
                        + ((cj + dj) as f32 + 0.5 - cy).powi(2);
                    if best.is_none_or(|b| d2 < b.0) {
                        best = Some((d2, e));
                    }
                }
            }
        }
        if let Some((_, e)) = best {
            acc.add(e, 1.0);
        }
    }
    if acc.weight == 0.0 {
        return TexelSample {
            cos: ndw.abs(),
            ..Default::default()
        };
    }
    let inv = 1.0 / acc.weight;
    let (below, above) = (acc.below * inv, acc.above * inv);
    let (first, last) = (acc.first * inv, acc.last * inv);
    // The front side faces −w when n·w < 0: rays travelling +w (from below) hit it, and it is
    // open when the crossing is the first of its ray.
    let (arriving, open) = if ndw < 0.0 {
        ([below, above], [first, last])
    } else {
        ([above, below], [last, first])
    };
    TexelSample {
        arriving,
        open,
        cos: ndw.abs(),
        valid: true,
    }
}

/// Directions closer than this to a face's plane (|cos θ|) carry no light to it.
pub const MIN_COS: f32 = 1e-6;
/// Cells searched around a texel that no ray crosses.
pub const FALLBACK_RADIUS: i64 = 2;

#[derive(Default)]
struct Accum {
    below: Vec3,
    above: Vec3,
    first: f32,
    last: f32,
    weight: f32,
}

impl Accum {
    fn add(&mut self, e: &Interface, w: f32) {
        self.below += e.from_below * w;
        self.above += e.from_above * w;
        self.first += f32::from(u8::from(e.first)) * w;
        self.last += f32::from(u8::from(e.last)) * w;
        self.weight += w;
    }
}

/// Per texel-side accumulators of one iteration (the GPU gather pass keeps the same two vec4s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexelAccum {
    /// Σ |cos|·ΔΩ·L over valid quadrature directions (rgb) and Σ |cos|·ΔΩ of them (w).
    pub irradiance: Vec4,
    /// Σ E_sun·|cos|·open over suns (rgb) and Σ |cos|·ΔΩ·open over quadrature directions (w).
    pub open: Vec4,
}

/// Per-iteration energy terms computed by [`finish_iteration`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IterationEnergy {
    pub sent: f64,
    pub received: f64,
    pub injected: f64,
    pub absorbed: f64,
    pub escaped: f64,
    pub next: f64,
}

/// Step 5: from the accumulators, the next unshot radiance per texel, and the energy terms.
/// Normalises the quadrature so that Σ|cos|ΔΩ over a texel's valid directions is π (uniform
/// incoming radiance L then gives irradiance exactly πL: furnace-exact).
pub fn finish_iteration(
    scene: &BakeScene,
    tex_face: &[u32],
    acc: &[TexelAccum],
    unshot: &[[f32; 4]],
    sky: Vec3,
    next: &mut [[f32; 4]],
) -> IterationEnergy {
    let mut e = IterationEnergy::default();
    for t in 0..scene.texel_count() {
        let area = f64::from(scene.texel_area[t]);
        let u = Vec4::from(unshot[t]).truncate();
        e.sent += sum3(u) * std::f64::consts::PI * area;
        let a = acc[t];
        if area <= 0.0 || a.irradiance.w <= 0.0 {
            next[t] = [0.0; 4];
            continue;
        }
        let k = std::f32::consts::PI / a.irradiance.w;
        let e_surf = a.irradiance.truncate() * k;
        let e_inj = sky * (a.open.w * k) + a.open.truncate();
        let irr = e_surf + e_inj;
        let rho = Vec4::from(scene.albedo[t]).truncate();
        let b = rho * irr;
        // The specular part leaves through the tiles (their power is counted from the tiles).
        let spec = Vec4::from(scene.specular[tex_face[t] as usize]).truncate() * irr;
        next[t] = (b / std::f32::consts::PI).extend(0.0).into();
        e.received += sum3(e_surf) * area;
        e.injected += sum3(e_inj) * area;
        e.absorbed += sum3(irr - b - spec) * area;
        e.next += sum3(b) * area;
        e.escaped += sum3(u) * f64::from(a.open.w * k) * area;
    }
    e
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
                Some(e_sun) => a.open += (e_sun * s.cos * s.open[side]).extend(0.0),
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

/// Transport directions followed by one per sun (the order reflect jobs are indexed in).
pub fn all_directions(
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
) -> (Vec<TransportDir>, usize) {
    let mut dirs = transport_directions(set, params);
    let quadrature = dirs.len();
    dirs.extend(scene.suns.iter().map(|&(d, e)| TransportDir {
        frame: PsfFrame::new(d),
        weight: 1.0,
        sun: Some(e),
    }));
    (dirs, quadrature)
}

/// Non-diffuse state shared by the CPU and GPU propagators.
pub struct SpecularSetup {
    pub index: tiles::TileIndex,
    pub frames: Vec<PsfFrame>,
    /// Per transport direction (same order as [`all_directions`]).
    pub jobs: Vec<Vec<tiles::ReflectJob>>,
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
        let index = tiles::TileIndex::new(scene, set, grid);
        let jobs = tiles::reflect_jobs(scene, set, dirs, &index);
        Some(Self {
            index,
            frames: tiles::fixed_frames(set),
            jobs,
        })
    }
}

/// Runs the whole propagation on the CPU.
pub fn propagate(scene: &BakeScene, set: &DirectionSet, params: &BakeParams) -> Propagated {
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let (dirs, quadrature) = all_directions(scene, set, params);
    let spec = SpecularSetup::new(scene, set, &grid, &dirs);
    let n_tex = scene.texel_count();
    let tex_face = texel_faces(scene);
    let mut unshot = scene.emission.clone();
    let mut total = scene.emission.clone();
    let mut next = vec![[0f32; 4]; n_tex];
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
        let mut e = finish_iteration(scene, &tex_face, &acc, &unshot, sky, &mut next);
        if let Some(s) = &spec {
            e.sent += tile_power(&s.index, &unshot_tiles, set, &grid);
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
        accumulate(&mut total, &next);
        accumulate(&mut total_tiles, &next_tiles);
        std::mem::swap(&mut unshot, &mut next);
        std::mem::swap(&mut unshot_tiles, &mut next_tiles);
        iterations = it + 1;
        if energy.converged(threshold) {
            break;
        }
    }
    Propagated {
        radiance: total,
        tiles: spec.map(|s| (s.index, total_tiles)),
        iterations,
        energy,
    }
}

fn sum3(v: Vec3) -> f64 {
    f64::from(v.x) + f64::from(v.y) + f64::from(v.z)
}

/// (maximum iterations, convergence threshold or 0) of a stopping rule.
pub fn stopping(rule: Iterations) -> (u32, f32) {
    match rule {
        Iterations::Fixed(n) => (n, 0.0),
        Iterations::Converge { threshold, max } => (max, threshold),
    }
}

/// `total += next`, element by element.
pub fn accumulate(total: &mut [[f32; 4]], next: &[[f32; 4]]) {
    for (t, n) in total.iter_mut().zip(next) {
        *t = (Vec4::from(*t) + Vec4::from(*n)).into();
    }
}

/// Σ π·L·area over texels, summed over channels.
fn power(radiance: &[[f32; 4]], area: &[f32]) -> f64 {
    radiance
        .iter()
        .zip(area)
        .map(|(l, a)| sum3(Vec4::from(*l).truncate()) * std::f64::consts::PI * f64::from(*a))
        .sum()
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
