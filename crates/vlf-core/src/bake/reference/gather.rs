//! Step 4 for one direction and one texel: the mean radiance arriving on the texel's own
//! square from the rays that cross its face.

use glam::{Vec2, Vec3};

use super::MIN_COS;
use super::cells::CellLists;
use super::interface::Interface;
use crate::bake::BakeScene;
use crate::psf::{PsfFrame, PsfGrid};

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
    /// The side that faces −w: light travelling +w (a sun's) reaches only this side.
    pub upstream_side: usize,
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
            upstream_side: usize::from(ndw >= 0.0),
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
        upstream_side: usize::from(ndw >= 0.0),
        valid: true,
    }
}

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
