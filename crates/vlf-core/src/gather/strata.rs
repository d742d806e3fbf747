//! Stratified sample positions of the final gather: jittered strata over the unit square in a
//! random order, and the spread of samples over a texel's points (both mirrored by
//! `shaders/gather_texels.wgsl`).

use glam::Vec2;

use crate::pathtrace::sampling::Rng;

/// The point that sample `k` of `n` starts from when a texel has `len` points: `k % len` when
/// the samples are as many as the points or more; otherwise a random one of the points in the
/// `k`-th of `n` equal runs of the point list (point `(k·len + j) / n`, j uniform in 0..len,
/// one draw), so that every point is equally likely and the samples stay spread over the
/// texel's strata. The points come in stratum order, so the first `n` of them would cover only
/// the first rows of the texel: a texel next to a steep source (the 1 cm emitting sides of a
/// lamp flush with the ceiling) saw it from one edge only, too bright or too dark by the edge's
/// orientation (cornell-suzanne's ceiling: 3.2× and 0.29× along two sides of its lamp;
/// `docs/GATHER.md`). The GPU gather draws the same (`spread_point` in
/// `shaders/gather_texels.wgsl`).
pub fn spread_point(k: usize, n: usize, len: usize, rng: &mut Rng) -> usize {
    if n >= len {
        return k % len;
    }
    let j = rng.next_u32() as usize % len;
    (k * len + j) / n
}

/// A g × g grid of 2-D strata over [0, 1)² in a random order (so that a texel's point strata and
/// its direction or light strata are paired at random).
pub(super) struct Strata {
    g: u32,
    order: Vec<u32>,
}

/// Side g of the g × g strata that hold `count` samples: ⌈√count⌉ (1 for none), computed as
/// the CPU does it (the GPU gather is handed these values rather than taking its own root).
pub fn strata_side(count: u32) -> u32 {
    (count.max(1) as f32).sqrt().ceil() as u32
}

pub(super) fn shuffled_strata(count: u32, rng: &mut Rng) -> Strata {
    let g = strata_side(count);
    let mut order: Vec<u32> = (0..g * g).collect();
    for i in (1..order.len()).rev() {
        let j = (rng.next_u32() as usize) % (i + 1);
        order.swap(i, j);
    }
    Strata { g, order }
}

impl Strata {
    /// A jittered point of the stratum paired with sample `k`.
    pub(super) fn point(&self, k: usize, rng: &mut Rng) -> Vec2 {
        let s = self.order[k % self.order.len()];
        let j = rng.next_2d();
        Vec2::new((s % self.g) as f32 + j.x, (s / self.g) as f32 + j.y) / self.g as f32
    }
}
