//! Steps 1–2 for one direction: triangles binned into the tiles of the ray grid, then the
//! exact per-ray depth lists (every ray intersected with its tile's triangles).

use glam::{Vec2, Vec3};

use crate::bake::BakeScene;
use crate::psf::{PsfFrame, PsfGrid};

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
    pub(super) fn cell(&self, c: usize) -> &[(f32, u32)] {
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

/// Steps 1–2: bin triangles into tiles and build the exact per-ray depth lists. A crossing
/// where a triangle's alpha mask leaves no surface ([`AlphaMasks::cuts`](crate::lightfield::AlphaMasks::cuts)) is not listed.
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
                if let Some((depth, w)) = ray_crossing(&proj[ti as usize], p) {
                    // No surface where the triangle's alpha mask cuts it: the ray passes.
                    if scene.masks.cuts(ti, w) {
                        continue;
                    }
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
    ray_crossing(q, p).map(|c| c.0)
}

/// [`ray_hit`] with the crossing's barycentric weights (of corners 0, 1, 2): the weights of
/// the projected triangle, which a parallel projection keeps.
pub fn ray_crossing(q: &[Vec3; 3], p: Vec2) -> Option<(f32, [f32; 3])> {
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
    Some((w0 * q[0].z + w1 * q[1].z + w2 * q[2].z, [w0, w1, w2]))
}
