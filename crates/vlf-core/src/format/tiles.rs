//! The `tile_index` section: the mirror tile index as little-endian u32 words.
//!
//! Layout: 8 header words `[m, n, directions, faces (all faces), mirror faces, index_start len,
//! tile_ids len, coverage len]`, then `face_slot` (one word per face), `faces`, `index_start`,
//! `tile_ids`, `coverage`. Every count is checked against the section's length before anything
//! is allocated, and every index against what it indexes.

use crate::lightfield::TileIndex;
use crate::lightfield::tiles::words_per_slot;

const HEADER_WORDS: usize = 8;

pub fn pack(ix: &TileIndex) -> Vec<u32> {
    let mut w = vec![
        ix.m,
        ix.n,
        ix.directions,
        ix.face_slot.len() as u32,
        ix.faces.len() as u32,
        ix.index_start.len() as u32,
        ix.tile_ids.len() as u32,
        ix.coverage.len() as u32,
    ];
    for part in [
        &ix.face_slot,
        &ix.faces,
        &ix.index_start,
        &ix.tile_ids,
        &ix.coverage,
    ] {
        w.extend_from_slice(part);
    }
    w
}

pub fn unpack(words: &[u32]) -> Result<TileIndex, String> {
    if words.len() < HEADER_WORDS {
        return Err(format!(
            "{} words, fewer than its {HEADER_WORDS}-word header",
            words.len()
        ));
    }
    let counts: Vec<usize> = words[3..HEADER_WORDS].iter().map(|&c| c as usize).collect();
    let total = counts
        .iter()
        .try_fold(HEADER_WORDS, |acc, &c| acc.checked_add(c));
    if total != Some(words.len()) {
        return Err(format!(
            "part lengths {counts:?} plus the header do not add up to the section's {} words",
            words.len()
        ));
    }
    let mut at = HEADER_WORDS;
    let mut take = |n: usize| {
        let part = words[at..at + n].to_vec();
        at += n;
        part
    };
    Ok(TileIndex {
        m: words[0],
        n: words[1],
        directions: words[2],
        face_slot: take(counts[0]),
        faces: take(counts[1]),
        index_start: take(counts[2]),
        tile_ids: take(counts[3]),
        coverage: take(counts[4]),
    })
}

/// Checks internal consistency and against `faces` faces and `values` tile values.
pub fn validate(ix: &TileIndex, faces: usize, values: usize) -> Result<(), String> {
    if ix.m == 0 || ix.n == 0 || !ix.n.is_multiple_of(ix.m) || ix.n > 4096 || ix.m > 64 {
        return Err(format!(
            "grid of {} rays in {}-cell tiles is invalid",
            ix.n, ix.m
        ));
    }
    if ix.face_slot.len() != faces {
        return Err(format!(
            "{} face slots for {faces} faces",
            ix.face_slot.len()
        ));
    }
    for (f, &s) in ix.face_slot.iter().enumerate() {
        if s != u32::MAX && (s as usize >= ix.faces.len() || ix.faces[s as usize] as usize != f) {
            return Err(format!("face {f} has inconsistent slot {s}"));
        }
    }
    if ix.faces.iter().any(|&f| f as usize >= faces) {
        return Err("a mirror face index is out of range".into());
    }
    let expect_starts = ix.faces.len() as u64 * u64::from(ix.directions) + 1;
    if ix.index_start.len() as u64 != expect_starts {
        return Err(format!(
            "{} slot offsets, expected {expect_starts}",
            ix.index_start.len()
        ));
    }
    if ix.index_start.first() != Some(&0)
        || ix.index_start.windows(2).any(|w| w[0] > w[1])
        || ix.index_start.last().map(|&l| l as usize) != Some(ix.tile_ids.len())
    {
        return Err("slot offsets are not a non-decreasing run from 0 to the slot count".into());
    }
    let tiles = u64::from(ix.n / ix.m).pow(2);
    for w in ix.index_start.windows(2) {
        let ids = &ix.tile_ids[w[0] as usize..w[1] as usize];
        if ids.iter().any(|&t| u64::from(t) >= tiles) || ids.windows(2).any(|p| p[0] >= p[1]) {
            return Err("tile ids out of range or not strictly increasing within a range".into());
        }
    }
    let slots = ix.tile_ids.len();
    if ix.coverage.len() as u64 != slots as u64 * words_per_slot(ix.m) as u64 {
        return Err(format!(
            "{} coverage words for {slots} slots",
            ix.coverage.len()
        ));
    }
    if values as u64 != slots as u64 * 2 * u64::from(ix.m * ix.m) {
        return Err(format!(
            "{values} tile values for {slots} slots of {}×{} cells, two senses",
            ix.m, ix.m
        ));
    }
    Ok(())
}
