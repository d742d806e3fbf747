//! Packing the atlas charts into lightmap pages.
//!
//! Every chart side (`width × height` texels) gets a rectangle of `(width + 2g) × (height + 2g)`
//! texels on a page, the `g`-texel gutter filled by clamping to the chart's edge texels: a
//! bilinear lookup anywhere inside the chart, including on its border, then reads exactly what
//! the viewer's clamp-to-edge lookup reads, and never a neighbouring chart's texel. Rectangles
//! are placed on shelves (tallest first) on pages of at most `max_size × max_size`.

use crate::lightfield::BakeFace;

/// Where one chart side lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement {
    /// Page index.
    pub page: u32,
    /// Texel column of the chart's texel (0, 0) on the page (the gutter lies before it).
    pub x: u32,
    /// Texel row of the chart's texel (0, 0) on the page (row 0 = top of the image).
    pub y: u32,
}

/// The packed layout: one placement per (face, side), and the page sizes.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// `placements[2 * face + side]`.
    pub placements: Vec<Placement>,
    /// (width, height) of each page in texels.
    pub pages: Vec<(u32, u32)>,
    /// Gutter width in texels.
    pub gutter: u32,
}

/// A chart side too large for a page.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChartTooLarge {
    pub face: usize,
    pub width: u32,
    pub height: u32,
}

/// Packs both sides of every face's chart on pages of at most `max_size` texels a side.
pub fn pack(faces: &[BakeFace], max_size: u32, gutter: u32) -> Result<Layout, ChartTooLarge> {
    let g2 = 2 * gutter;
    let mut items: Vec<(usize, u32, u32)> = Vec::with_capacity(2 * faces.len());
    let mut area: u64 = 0;
    for (fi, f) in faces.iter().enumerate() {
        let (w, h) = (f.width + g2, f.height + g2);
        if w > max_size || h > max_size {
            return Err(ChartTooLarge {
                face: fi,
                width: f.width,
                height: f.height,
            });
        }
        for side in 0..2 {
            items.push((2 * fi + side, w, h));
            area += u64::from(w) * u64::from(h);
        }
    }
    // Tallest first, then widest, then in index order (deterministic).
    items.sort_by(|a, b| b.2.cmp(&a.2).then(b.1.cmp(&a.1)).then(a.0.cmp(&b.0)));
    let widest = items.iter().map(|i| i.1).max().unwrap_or(1);
    // Page width: the smallest power of two holding the area in a square (shelves waste
    // some), at least the widest chart, at most max_size.
    let side = ((area as f64 * 1.15).sqrt().ceil() as u32)
        .max(widest)
        .max(4);
    let width = side.next_power_of_two().min(max_size).max(widest);

    let mut placements = vec![
        Placement {
            page: 0,
            x: 0,
            y: 0
        };
        2 * faces.len()
    ];
    let mut pages: Vec<(u32, u32)> = Vec::new();
    let (mut page, mut x, mut y, mut shelf) = (0u32, 0u32, 0u32, 0u32);
    for (slot, w, h) in items {
        if x + w > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        if y + h > max_size {
            pages.push((width, y));
            page += 1;
            x = 0;
            y = 0;
            shelf = 0;
        }
        placements[slot] = Placement {
            page,
            x: x + gutter,
            y: y + gutter,
        };
        x += w;
        shelf = shelf.max(h);
    }
    pages.push((width, y + shelf));
    // Heights rounded up to a multiple of 4 (block-friendly for later GPU encodings).
    for p in &mut pages {
        p.1 = p.1.div_ceil(4) * 4;
    }
    Ok(Layout {
        placements,
        pages,
        gutter,
    })
}

/// Fills the pages: `value(face, side, i, j)` is the chart texel at column `i`, row `j`; the
/// gutter repeats the chart's edge texels; texels outside every chart are zero.
pub fn fill_pages(
    faces: &[BakeFace],
    layout: &Layout,
    mut value: impl FnMut(usize, u32, u32, u32) -> [f32; 3],
) -> Vec<Vec<[f32; 3]>> {
    let mut pages: Vec<Vec<[f32; 3]>> = layout
        .pages
        .iter()
        .map(|&(w, h)| vec![[0.0; 3]; w as usize * h as usize])
        .collect();
    let g = layout.gutter as i64;
    for (fi, f) in faces.iter().enumerate() {
        for side in 0..2u32 {
            let p = layout.placements[2 * fi + side as usize];
            let page_w = layout.pages[p.page as usize].0 as i64;
            let page = &mut pages[p.page as usize];
            for j in -g..f.height as i64 + g {
                let cj = j.clamp(0, f.height as i64 - 1) as u32;
                for i in -g..f.width as i64 + g {
                    let ci = i.clamp(0, f.width as i64 - 1) as u32;
                    let (px, py) = (p.x as i64 + i, p.y as i64 + j);
                    page[(py * page_w + px) as usize] = value(fi, side, ci, cj);
                }
            }
        }
    }
    pages
}
