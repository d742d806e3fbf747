//! Intel Open Image Denoise's lightmap filter over the gathered atlas (`--denoise oidn`,
//! `docs/GATHER.md`, *OIDN's lightmap filter*): the industry's choice, run in place of vlf's own
//! filter ([`super::denoise`]) to compare the two on the same bakes. The library is prebuilt and
//! optional: only builds with the `oidn` feature (and `OIDN_DIR` pointing at it) can run it;
//! the others refuse `--denoise oidn` ([`crate::lightfield::BakeParams::validate`], and
//! [`OidnError::NotBuilt`] here).
//!
//! OIDN filters a 2-D image and knows nothing of faces, charts or contacts. [`Packing`] lays the
//! atlas' charts (each side of a face that holds an estimate) out side by side in one RGB
//! image, each surrounded by [`PADDING`] pixels that repeat its border texels (clamp to edge),
//! so the filter meets neither black nor another chart next to a chart's border; further away
//! (its receptive field spans tens of pixels) it does see the neighbouring charts. Inside a
//! chart, texels without an estimate (uncovered, or enclosed: under a box, inside a wall) are
//! filled from the estimated ones before packing ([`fill_chart`]), ring by ring and without a
//! limit, where the gather's own dilation stops after two rings: otherwise the filter would pull
//! their black into the lit texels around them. After filtering, the estimated texels take the
//! filter's output and the others are dilated from them ([`crate::bake::dilate_where`]), as
//! [`super::denoise`] leaves them.
//!
//! What it cannot know: a chart is one face side, so the filter never mixes across a crease or
//! between two coplanar faces (it may leave a seam there, where vlf's filter mixes); but within
//! a chart it sees only colours, so a contact (a wall standing on a floor face that runs on
//! under it) is an edge only as far as the light differs across it.

#[cfg(feature = "oidn")]
mod ffi;

use glam::{Vec3, Vec4};
use serde::Serialize;

use crate::bake::prep::BakeScene;
use crate::lightfield::params::OIDN_MISSING;

/// Pixels of padding around each chart in the image (its border texels repeated).
pub const PADDING: u32 = 4;

/// Where a chart (one side of a face) lies in the image: its texel (i, j) is the pixel in
/// column `x + i` of row `y + j`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PackedChart {
    pub face: u32,
    pub side: u32,
    pub x: u32,
    pub y: u32,
}

/// The atlas' charts laid out in one image (shelves of charts sorted by height).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Packing {
    pub width: u32,
    pub height: u32,
    pub padding: u32,
    pub charts: Vec<PackedChart>,
}

impl Packing {
    /// Lays out the charts of `atlas` that hold an estimated texel (`estimated`, per texel), each
    /// with `padding` pixels round it, on shelves of an image about as wide as it is tall.
    pub fn new(atlas: &BakeScene, estimated: &[bool], padding: u32) -> Packing {
        let mut items: Vec<(u32, u32, u32, u32)> = Vec::new(); // (face, side, padded w, h)
        for (fi, f) in atlas.faces.iter().enumerate() {
            for side in 0..2 {
                let base = (f.texel_base + side * f.texels_per_side()) as usize;
                if estimated[base..base + f.texels_per_side() as usize]
                    .iter()
                    .any(|e| *e)
                {
                    let pad = 2 * padding;
                    items.push((fi as u32, side, f.width + pad, f.height + pad));
                }
            }
        }
        let area: u64 = items.iter().map(|i| u64::from(i.2) * u64::from(i.3)).sum();
        let widest = items.iter().map(|i| i.2).max().unwrap_or(0);
        let width = widest.max((area as f64).sqrt().ceil() as u32);
        // Tallest first, then widest, then atlas order: deterministic.
        items.sort_by(|a, b| {
            b.3.cmp(&a.3)
                .then(b.2.cmp(&a.2))
                .then((a.0, a.1).cmp(&(b.0, b.1)))
        });
        let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
        let mut charts = Vec::with_capacity(items.len());
        for (face, side, w, h) in items {
            if x + w > width {
                y += shelf;
                x = 0;
                shelf = 0;
            }
            charts.push(PackedChart {
                face,
                side,
                x: x + padding,
                y: y + padding,
            });
            x += w;
            shelf = shelf.max(h);
        }
        Packing {
            width,
            height: y + shelf,
            padding,
            charts,
        }
    }

    /// Pixels of the image.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// The values a chart of `w` × `h` texels shows the filter: estimated texels as they are, every
/// other texel the mean of its 8 neighbours filled in the ring before it (rings grow out of the
/// estimated texels until the chart is full). `None` when no texel is estimated.
pub fn fill_chart(values: &[Vec3], estimated: &[bool], w: usize, h: usize) -> Option<Vec<Vec3>> {
    assert_eq!(values.len(), w * h, "a value per texel of the chart");
    assert_eq!(
        estimated.len(),
        w * h,
        "an estimate flag per texel of the chart"
    );
    if !estimated.iter().any(|e| *e) {
        return None;
    }
    let mut out = values.to_vec();
    let mut filled = estimated.to_vec();
    let neighbours = |i: usize| {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        (-1i64..=1)
            .flat_map(move |dy| (-1i64..=1).map(move |dx| (x + dx, y + dy)))
            .filter(move |&(xx, yy)| {
                (xx, yy) != (x, y) && xx >= 0 && yy >= 0 && xx < w as i64 && yy < h as i64
            })
            .map(move |(xx, yy)| yy as usize * w + xx as usize)
    };
    // Texels of the next ring: unfilled, next to a filled one (in index order).
    let mut queued = filled.clone();
    let mut ring: Vec<usize> = Vec::new();
    for i in 0..w * h {
        if !queued[i] && neighbours(i).any(|j| filled[j]) {
            queued[i] = true;
            ring.push(i);
        }
    }
    while !ring.is_empty() {
        let means: Vec<Vec3> = ring
            .iter()
            .map(|&i| {
                let (sum, n) = neighbours(i)
                    .filter(|&j| filled[j])
                    .fold((Vec3::ZERO, 0u32), |(s, n), j| (s + out[j], n + 1));
                sum / n as f32
            })
            .collect();
        for (&i, m) in ring.iter().zip(means) {
            out[i] = m;
            filled[i] = true;
        }
        let mut next = Vec::new();
        for &i in &ring {
            for j in neighbours(i) {
                if !queued[j] {
                    queued[j] = true;
                    next.push(j);
                }
            }
        }
        next.sort_unstable();
        ring = next;
    }
    Some(out)
}

/// The RGB image (3 floats a pixel, row 0 first) of `packing` for `irradiance` on `atlas`:
/// every packed chart filled ([`fill_chart`]) and padded by repeating its border texels;
/// pixels between charts are 0. Returns it and how many texels the fill gave a value.
pub fn pack(
    atlas: &BakeScene,
    packing: &Packing,
    irradiance: &[[f32; 4]],
    estimated: &[bool],
) -> (Vec<f32>, usize) {
    let iw = packing.width as usize;
    let mut image = vec![0.0f32; 3 * packing.pixels()];
    let mut filled = 0;
    let p = packing.padding as i64;
    for c in &packing.charts {
        let f = &atlas.faces[c.face as usize];
        let (w, h) = (f.width as usize, f.height as usize);
        let base = (f.texel_base + c.side * f.texels_per_side()) as usize;
        let values: Vec<Vec3> = irradiance[base..base + w * h]
            .iter()
            .map(|e| Vec4::from(*e).truncate())
            .collect();
        let est = &estimated[base..base + w * h];
        filled += est.iter().filter(|e| !**e).count();
        let Some(v) = fill_chart(&values, est, w, h) else {
            continue;
        };
        for py in -p..h as i64 + p {
            for px in -p..w as i64 + p {
                let (x, y) = (
                    px.clamp(0, w as i64 - 1) as usize,
                    py.clamp(0, h as i64 - 1) as usize,
                );
                let (ix, iy) = (
                    (i64::from(c.x) + px) as usize,
                    (i64::from(c.y) + py) as usize,
                );
                let at = 3 * (iy * iw + ix);
                image[at..at + 3].copy_from_slice(&v[y * w + x].to_array());
            }
        }
    }
    (image, filled)
}

/// The atlas after filtering: estimated texels of packed charts read from `image` (negative
/// values as 0; a non-finite pixel keeps the texel's own value), every other texel as in
/// `irradiance`, then the texels without an estimate dilated from the estimated ones
/// ([`crate::bake::dilate_where`]). The fourth component is kept.
pub fn unpack(
    atlas: &BakeScene,
    packing: &Packing,
    image: &[f32],
    irradiance: &[[f32; 4]],
    estimated: &[bool],
) -> Vec<[f32; 4]> {
    assert_eq!(
        image.len(),
        3 * packing.pixels(),
        "an RGB image of the packing"
    );
    let iw = packing.width as usize;
    let mut out = irradiance.to_vec();
    for c in &packing.charts {
        let f = &atlas.faces[c.face as usize];
        let (w, h) = (f.width as usize, f.height as usize);
        let base = (f.texel_base + c.side * f.texels_per_side()) as usize;
        for y in 0..h {
            for x in 0..w {
                let t = base + y * w + x;
                if !estimated[t] {
                    continue;
                }
                let at = 3 * ((c.y as usize + y) * iw + c.x as usize + x);
                let v = Vec3::from_slice(&image[at..at + 3]);
                if v.is_finite() {
                    out[t] = v.max(Vec3::ZERO).extend(irradiance[t][3]).into();
                }
            }
        }
    }
    crate::bake::dilate_where(atlas, &mut out, estimated);
    out
}

/// What a run of OIDN's filter did (`vlf-bake bake --json`, `gather.oidn`). Powers as in
/// [`super::DenoiseStats`].
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct OidnStats {
    pub texels: usize,
    /// Covered texels with an estimate: the ones the filter's output replaces.
    pub estimated_texels: usize,
    /// Charts (face sides with an estimate) in the image, and its size (pixels).
    pub charts: usize,
    pub image_width: u32,
    pub image_height: u32,
    pub padding: u32,
    /// Texels of those charts without an estimate, filled for the image ([`fill_chart`]).
    pub filled_texels: usize,
    /// Share of the image's pixels that are chart texels (the rest is padding and gaps).
    pub occupancy: f64,
    pub power_before: f64,
    pub power_after: f64,
}

impl OidnStats {
    /// after / before − 1.
    pub fn relative_power_change(&self) -> f64 {
        if self.power_before <= 0.0 {
            return 0.0;
        }
        self.power_after / self.power_before - 1.0
    }
}

/// Why OIDN's filter did not run.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum OidnError {
    /// The build has no OIDN (the `oidn` feature is off).
    #[error("--denoise oidn: {OIDN_MISSING}")]
    NotBuilt,
    /// The library reported an error (e.g. no device module beside it, out of memory).
    #[error("Intel Open Image Denoise failed in {call}: {message}")]
    Library { call: &'static str, message: String },
}

/// Runs OIDN's `RTLightmap` filter (HDR irradiance, not directional) over `irradiance` (per
/// texel of `atlas`, rgb) packed into an image ([`Packing`], [`pack`]), on `threads` of OIDN's
/// worker threads (0: its default, every core), and returns the atlas read back ([`unpack`]).
/// `filled` says which texels hold an estimate (covered and not enclosed), as for
/// [`super::denoise`]. Fails without the `oidn` feature ([`OidnError::NotBuilt`]).
pub fn denoise(
    atlas: &BakeScene,
    irradiance: &[[f32; 4]],
    filled: &[bool],
    threads: usize,
) -> Result<(Vec<[f32; 4]>, OidnStats), OidnError> {
    if !cfg!(feature = "oidn") {
        return Err(OidnError::NotBuilt);
    }
    let n = atlas.texel_count();
    assert_eq!(irradiance.len(), n, "irradiance per texel of the atlas");
    assert_eq!(filled.len(), n, "filled per texel of the atlas");
    let estimated: Vec<bool> = (0..n)
        .map(|t| filled[t] && atlas.texel_area[t] > 0.0)
        .collect();
    let packing = Packing::new(atlas, &estimated, PADDING);
    let (mut image, filled_texels) = pack(atlas, &packing, irradiance, &estimated);
    let chart_texels: usize = packing
        .charts
        .iter()
        .map(|c| atlas.faces[c.face as usize].texels_per_side() as usize)
        .sum();
    if packing.pixels() > 0 {
        run_filter(&mut image, packing.width, packing.height, threads)?;
    }
    let out = unpack(atlas, &packing, &image, irradiance, &estimated);
    let stats = OidnStats {
        texels: n,
        estimated_texels: estimated.iter().filter(|e| **e).count(),
        charts: packing.charts.len(),
        image_width: packing.width,
        image_height: packing.height,
        padding: packing.padding,
        filled_texels,
        occupancy: chart_texels as f64 / packing.pixels().max(1) as f64,
        power_before: super::super::power(atlas, irradiance),
        power_after: super::super::power(atlas, &out),
    };
    Ok((out, stats))
}

#[cfg(feature = "oidn")]
fn run_filter(image: &mut [f32], width: u32, height: u32, threads: usize) -> Result<(), OidnError> {
    ffi::rt_lightmap(image, width as usize, height as usize, threads)
}

#[cfg(not(feature = "oidn"))]
fn run_filter(_: &mut [f32], _: u32, _: u32, _: usize) -> Result<(), OidnError> {
    Err(OidnError::NotBuilt)
}

#[cfg(test)]
mod tests;
