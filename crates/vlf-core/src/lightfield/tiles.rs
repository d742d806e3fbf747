//! The index of the sparse per-direction radiance tiles of non-diffuse (mirror and mixed)
//! faces (VLF-GPU §3.1, §3.4; original VLF §4.3). The propagator builds it
//! (`bake::reference`), the file stores it (`format`'s `tile_index` section) and the renderer
//! reads through it.
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

use serde::{Deserialize, Serialize};

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
