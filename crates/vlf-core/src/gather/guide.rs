//! Where a texel's light comes from, over the cosine-warped hemisphere, which an estimator
//! samples its rays from (mixed with plain cosine rays and weighted against them and the light
//! samples by multiple importance sampling; `docs/GATHER.md`, *Guided rays*).
//!
//! A ray of direction `to_world(cosine_hemisphere(u), n)` lies in cell (⌊u.x·g⌋, ⌊u.y·g⌋) of a
//! g × g grid over the unit square: u.x = sin²θ, u.y = φ / 2π, so every cell holds the same
//! share of the cosine-weighted hemisphere. Two guides use it:
//! * the indirect grid's second pass, from its neighbours' first passes ([`Cells`], [`G`] = 8:
//!   each cell holds 4 of the default 256 stratified rays);
//! * the stored atlas' direct estimator, from where the indirect grid's texels see the sky
//!   ([`SkyMask`], [`SKY_G`] = 16, measured finer at an opening's rim) and, for a texel the
//!   mask missed, where its own rays of the rounds before found light ([`round_guide`]).

use glam::{Vec2, Vec3};

use crate::pathtrace::sampling;

/// Cells per side of the indirect grid's guide ([`Cells`]).
pub const G: u32 = 8;
/// Cells of that guide.
pub const CELLS: usize = (G * G) as usize;
/// Cells per side of the sky guide ([`SkyMask`]): each [`G`]-cell split in 2 × 2, so that a
/// window a few degrees wide seen from across a room fills most of the cells it lies in.
pub const SKY_G: u32 = 2 * G;

/// Cells of the sky guide.
pub const SKY_CELLS: usize = (SKY_G * SKY_G) as usize;

/// The cell of square point `u` in the [`G`] × [`G`] grid.
pub fn cell_of(u: Vec2) -> usize {
    cell_in(u, G)
}

/// The cell of square point `u` in a `g` × `g` grid.
pub fn cell_in(u: Vec2, g: u32) -> usize {
    let cx = ((u.x * g as f32) as u32).min(g - 1);
    let cy = ((u.y * g as f32) as u32).min(g - 1);
    (cy * g + cx) as usize
}

/// The cells next to cell `c` of a `g` × `g` grid (left, right, below, above): u.x = sin²θ
/// ends at the grid's edges, φ wraps round.
pub fn neighbours(c: usize, g: u32) -> impl Iterator<Item = usize> {
    let (x, y, g) = ((c as u32 % g) as i32, (c as u32 / g) as i32, g as i32);
    [(-1, 0), (1, 0), (0, -1), (0, 1)]
        .into_iter()
        .filter_map(move |(dx, dy)| {
            let nx = x + dx;
            (0..g)
                .contains(&nx)
                .then(|| ((y + dy).rem_euclid(g) * g + nx) as usize)
        })
}

/// The square point of unit direction `w` (world) about unit normal `n`: the inverse of
/// `to_world(cosine_hemisphere(u), n)`.
pub fn square_of(w: Vec3, n: Vec3) -> Vec2 {
    let l = sampling::to_local(w, n);
    let ux = (l.x * l.x + l.y * l.y).clamp(0.0, 1.0);
    let mut phi = l.y.atan2(l.x) / std::f32::consts::TAU;
    if phi < 0.0 {
        phi += 1.0;
    }
    Vec2::new(ux, phi.min(0.999_999_9))
}

/// A sampling distribution over the cells of a `side` × `side` grid: `cdf[c]` = Σ of the
/// normalised weights of cells before and at `c`; `density[c]` = the cell's probability × the
/// cell count (1 = cosine).
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    pub side: u32,
    pub cdf: Vec<f32>,
    pub density: Vec<f32>,
}

impl Guide {
    /// The guide of the cell weights `w` of a square grid (any scale; `w.len()` a square), or
    /// `None` when they are all 0. Each cell is first raised to half the largest of its four
    /// neighbours (φ wraps round), so that a texel a little off the one that measured the
    /// weights still samples the rim of an opening.
    pub fn new(w: &[f32]) -> Option<Guide> {
        let side = (w.len() as f32).sqrt().round() as u32;
        debug_assert_eq!((side * side) as usize, w.len());
        let mut spread = vec![0.0f32; w.len()];
        let mut total = 0.0f64;
        for (c, v) in spread.iter_mut().enumerate() {
            let n = neighbours(c, side).map(|k| w[k]).fold(0.0f32, f32::max);
            *v = w[c].max(0.5 * n);
            total += f64::from(*v);
        }
        if total <= 0.0 || !total.is_finite() {
            return None;
        }
        let cells = w.len();
        let mut cdf = vec![0.0f32; cells];
        let mut density = vec![0.0f32; cells];
        let mut acc = 0.0f64;
        for c in 0..cells {
            let p = f64::from(spread[c]) / total;
            acc += p;
            cdf[c] = acc as f32;
            density[c] = (p * cells as f64) as f32;
        }
        cdf[cells - 1] = 1.0;
        Some(Guide { side, cdf, density })
    }

    /// The density (relative to cosine sampling) at square point `u`.
    pub fn density_at(&self, u: Vec2) -> f32 {
        self.density[cell_in(u, self.side)]
    }

    /// A square point drawn from the guide with `v` uniform in [0, 1) (the cell, by the cdf)
    /// and `j` uniform in [0, 1)² (where in the cell).
    pub fn sample(&self, v: f32, j: Vec2) -> Vec2 {
        let c = self
            .cdf
            .partition_point(|&x| x <= v)
            .min(self.cdf.len() - 1) as u32;
        let (cx, cy) = ((c % self.side) as f32, (c / self.side) as f32);
        ((Vec2::new(cx, cy) + j) / self.side as f32).min(Vec2::splat(0.999_999_9))
    }
}

/// The density, relative to cosine sampling, of `n_b` rays of which `n_u` are cosine rays and
/// the rest drawn from `guide`, at square point `u`: the one-sample mixture the balance
/// heuristic weighs them by (so the ray estimator is Σ L·π / (n_b · mixture)).
pub fn mixture(guide: Option<&Guide>, n_u: u32, n_b: u32, u: Vec2) -> f32 {
    match guide {
        None => 1.0,
        Some(g) => (n_u as f32 + (n_b - n_u) as f32 * g.density_at(u)) / n_b as f32,
    }
}

/// A round's guide for the direct estimator of a stored texel: the blended sky mask of the
/// indirect grid's texels round it (`sky`, [`SKY_CELLS`] weights) and the cells in which the
/// texel's own rays of the rounds before found light (`own`), each normalised, so that the
/// rays go where the texel itself sees the opening once it has found it, and the mask's
/// parallax (its texels are two to four of the stored ones wide) costs one round, not all.
/// `None` when neither holds anything.
pub fn round_guide(sky: Option<&[f32]>, own: &[f32]) -> Option<Guide> {
    let norm = |w: &[f32]| {
        let total: f32 = w.iter().sum();
        (total > 0.0).then_some(1.0 / total)
    };
    let k_sky = sky.and_then(norm);
    // Where the mask holds something, the texel's few hits would only pull its rays off the
    // rest of the opening: they guide texels the mask missed.
    let k_own = if k_sky.is_some() { None } else { norm(own) };
    if k_sky.is_none() && k_own.is_none() {
        return None;
    }
    let w: Vec<f32> = (0..SKY_CELLS)
        .map(|c| sky.zip(k_sky).map_or(0.0, |(s, k)| s[c] * k) + k_own.map_or(0.0, |k| own[c] * k))
        .collect();
    Guide::new(&w)
}

/// Where an indirect-grid texel sees the sky, in [`SKY_G`] × [`SKY_G`] cells: the share of
/// the rays in each cell that left the scene (0 in cells no ray was sent to).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyMask {
    pub w: Vec<f32>,
}

impl SkyMask {
    /// The masks of several texels blended with weights `k`.
    pub fn blend<'a>(parts: impl Iterator<Item = (&'a SkyMask, f32)>) -> Vec<f32> {
        let mut out = vec![0.0f32; SKY_CELLS];
        for (m, k) in parts {
            for (o, w) in out.iter_mut().zip(&m.w) {
                *o += w * k;
            }
        }
        out
    }
}

/// Accumulates a guide's cell weights and the estimate's spread while a texel's rays are traced.
#[derive(Clone, Debug)]
pub struct Cells {
    pub w: [f32; CELLS],
}

impl Default for Cells {
    fn default() -> Self {
        Cells { w: [0.0; CELLS] }
    }
}

impl Cells {
    pub fn add(&mut self, u: Vec2, weight: f32) {
        self.w[cell_of(u)] += weight;
    }

    /// The cells of several texels blended with weights `k`.
    pub fn blend<'a>(parts: impl Iterator<Item = (&'a Cells, f32)>) -> Cells {
        let mut out = Cells::default();
        for (c, k) in parts {
            for (o, w) in out.w.iter_mut().zip(&c.w) {
                *o += w * k;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_of_inverts_the_cosine_map() {
        let n = Vec3::new(0.3, -0.8, 0.52).normalize();
        for &(x, y) in &[(0.1, 0.2), (0.5, 0.99), (0.93, 0.47), (0.01, 0.75)] {
            let u = Vec2::new(x, y);
            let w = sampling::to_world(sampling::cosine_hemisphere(u), n);
            let back = square_of(w, n);
            assert!((back - u).abs().max_element() < 1e-4, "{u} -> {back}");
        }
    }

    #[test]
    fn a_guide_samples_its_cells_by_their_density() {
        let mut w = [0.0; CELLS];
        w[9] = 3.0;
        w[40] = 1.0;
        let g = Guide::new(&w).unwrap();
        let total: f32 = g.density.iter().sum();
        assert!((total - CELLS as f32).abs() < 1e-3);
        // Draw a fine stratified sequence and count the cells.
        let mut count = [0u32; CELLS];
        let m = 64_000;
        for k in 0..m {
            let v = (k as f32 + 0.5) / m as f32;
            count[cell_of(g.sample(v, Vec2::splat(0.5)))] += 1;
        }
        for c in 0..CELLS {
            let want = g.density[c] / CELLS as f32;
            let got = count[c] as f32 / m as f32;
            assert!((got - want).abs() < 1e-3, "cell {c}: {got} vs {want}");
        }
        // The spread: neighbours of cell 9 hold half its weight.
        assert!((g.density[10] / g.density[9] - 0.5).abs() < 1e-6);
        assert!(Guide::new(&[0.0; CELLS]).is_none());
    }

    #[test]
    fn the_mixture_is_a_density() {
        let mut w = [0.0; CELLS];
        w[3] = 1.0;
        let g = Guide::new(&w).unwrap();
        let centre = |c: usize| {
            Vec2::new((c as u32 % G) as f32 + 0.5, (c as u32 / G) as f32 + 0.5) / G as f32
        };
        let mean: f32 = (0..CELLS)
            .map(|c| mixture(Some(&g), 4, 16, centre(c)))
            .sum::<f32>()
            / CELLS as f32;
        assert!((mean - 1.0).abs() < 1e-5);
    }
}
