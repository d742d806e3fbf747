//! The converged light field as a gather ray reads it at its first hit: the propagation's
//! irradiance atlas (times the hit point's own albedo, texture included) for the diffuse part,
//! and the sparse mirror tiles in the ray's direction for the specular part — the same lookups
//! the renderer's pass 5 does ([`Tiles::radiance_towards`] is its CPU form).

use glam::{Vec2, Vec3, Vec4};

use crate::directions::DirectionSet;
use crate::lightfield::{BakeFace, TileIndex};
use crate::psf::PsfFrame;

/// Continuous chart coordinates (texel units) of plane point `p` on face `f`.
pub fn chart_coords(f: &BakeFace, p: Vec3) -> Vec2 {
    let d = p - Vec3::from(f.origin);
    Vec2::new(d.dot(Vec3::from(f.u)), d.dot(Vec3::from(f.v))) / f.texel_size
}

/// A per-texel quantity of face `f` on `side`, read bilinearly at plane point `p` with texel
/// indices clamped to the chart (never across faces or sides): the filter the renderer applies
/// to the atlas (`render_final_radiance.wgsl`, `diffuse_radiance`).
pub fn chart_bilinear(f: &BakeFace, values: &[[f32; 4]], side: u32, p: Vec3) -> Vec3 {
    let c = chart_coords(f, p) - Vec2::splat(0.5);
    let (x0, y0) = (c.x.floor(), c.y.floor());
    let (fx, fy) = (c.x - x0, c.y - y0);
    let ci = |i: f32| (i as i32).clamp(0, f.width as i32 - 1) as u32;
    let cj = |j: f32| (j as i32).clamp(0, f.height as i32 - 1) as u32;
    let base = f.texel_base + side * f.width * f.height;
    let at = |i: u32, j: u32| Vec4::from(values[(base + j * f.width + i) as usize]).truncate();
    let (i0, i1, j0, j1) = (ci(x0), ci(x0 + 1.0), cj(y0), cj(y0 + 1.0));
    let top = at(i0, j0).lerp(at(i1, j0), fx);
    let bottom = at(i0, j1).lerp(at(i1, j1), fx);
    top.lerp(bottom, fy)
}

/// The sparse per-direction tiles of the non-diffuse faces, with the fixed directions' frames.
pub struct Tiles<'a> {
    pub index: &'a TileIndex,
    /// Total outgoing radiance per tile value (rgb).
    pub values: &'a [[f32; 4]],
    pub set: &'a DirectionSet,
    frames: Vec<PsfFrame>,
}

impl<'a> Tiles<'a> {
    pub fn new(index: &'a TileIndex, values: &'a [[f32; 4]], set: &'a DirectionSet) -> Self {
        let frames = crate::psf::fixed_frames(set);
        Self {
            index,
            values,
            set,
            frames,
        }
    }

    /// Value index of face slot `mf`, fixed direction `j`, cell `(ci, cj)` and `sense`, or
    /// `None` when the face stores no tile there or the cell is not covered.
    fn value_index(&self, mf: u32, j: usize, ci: i64, cj: i64, sense: u32) -> Option<usize> {
        let ix = self.index;
        let n = i64::from(ix.n);
        if ci < 0 || cj < 0 || ci >= n || cj >= n {
            return None;
        }
        let (ci, cj) = (ci as u32, cj as u32);
        let k = mf as usize * ix.directions as usize + j;
        let range = ix.index_start[k] as usize..ix.index_start[k + 1] as usize;
        let m = ix.m;
        let tile = (cj / m) * (ix.n / m) + ci / m;
        let slot = range.start + ix.tile_ids[range].binary_search(&tile).ok()?;
        let local = (cj % m) * m + ci % m;
        let words = crate::lightfield::tiles::words_per_slot(m);
        let cov = ix.coverage[slot * words + (local / 32) as usize];
        if (cov >> (local % 32)) & 1 == 0 {
            return None;
        }
        Some(((slot as u32 * 2 + sense) * m * m + local) as usize)
    }

    /// Specular radiance leaving non-diffuse face `face` (unit `normal`) at `p` along the unit
    /// direction `out`, interpolated as the renderer does: the three sphere vertices around
    /// the direction of travel towards `p` (taken in the opposite sense) with their
    /// barycentric weights; per vertex, bilinear over the covered cells around `p` in that
    /// direction's ray grid. Zero for diffuse faces.
    pub fn radiance_towards(&self, face: u32, normal: Vec3, p: Vec3, out: Vec3) -> Vec3 {
        let mf = self.index.face_slot[face as usize];
        if mf == u32::MAX {
            return Vec3::ZERO;
        }
        let l = self.set.len() as u32;
        let n = self.index.n as f32;
        let lk = self.set.lookup(-out);
        let mut sum = Vec3::ZERO;
        for (&v, &w) in lk.vertices.iter().zip(&lk.weights) {
            let j = (v % l) as usize;
            let sense = 1 - v / l;
            let frame = &self.frames[j];
            let dir = if sense == 1 { -frame.w } else { frame.w };
            if dir.dot(normal) * out.dot(normal) <= 0.0 {
                continue;
            }
            let cx = (p.dot(frame.u) + 1.0) * 0.5 * n - 0.5;
            let cy = (p.dot(frame.v) + 1.0) * 0.5 * n - 0.5;
            let (x0, y0) = (cx.floor(), cy.floor());
            let (fx, fy) = (cx - x0, cy - y0);
            let (mut acc, mut wsum) = (Vec3::ZERO, 0.0f32);
            for c in 0..4u32 {
                let (dx, dy) = ((c & 1) as i64, (c >> 1) as i64);
                let wc = if dx == 1 { fx } else { 1.0 - fx } * if dy == 1 { fy } else { 1.0 - fy };
                if wc <= 0.0 {
                    continue;
                }
                if let Some(i) = self.value_index(mf, j, x0 as i64 + dx, y0 as i64 + dy, sense) {
                    acc += Vec4::from(self.values[i]).truncate() * wc;
                    wsum += wc;
                }
            }
            if wsum > 0.0 {
                sum += acc / wsum * w;
            }
        }
        sum
    }
}
