//! Where a texel's light comes from, as the indirect grid's gather rays saw it: a histogram
//! over the cosine-warped hemisphere of each indirect texel, which the stored atlas' direct
//! estimator samples its rays from (mixed with plain cosine rays and weighted against them and
//! the light samples by multiple importance sampling; `docs/GATHER.md`, *Guided rays*).
//!
//! A gather ray of direction `to_world(cosine_hemisphere(u), n)` lies in cell
//! (⌊u.x·G⌋, ⌊u.y·G⌋) of a G × G grid over the unit square: u.x = sin²θ, u.y = φ / 2π, so every
//! cell holds the same share of the cosine-weighted hemisphere and a cell of the indirect grid's
//! 16 × 16 direction strata falls in exactly one cell. A cell's weight is the light the rays in
//! it found that the direct estimator has to find again: the sky seen through an opening.
//! Those rays are stratified, so each cell of an 8 × 8 grid holds exactly 4 of the default 256.

use glam::{Vec2, Vec3};

use crate::pathtrace::sampling;

/// Cells per side of a guide.
pub const G: u32 = 8;
/// Cells of a guide.
pub const CELLS: usize = (G * G) as usize;

/// The cell of square point `u`.
pub fn cell_of(u: Vec2) -> usize {
    let cx = ((u.x * G as f32) as u32).min(G - 1);
    let cy = ((u.y * G as f32) as u32).min(G - 1);
    (cy * G + cx) as usize
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

/// A sampling distribution over the cells: `cdf[c]` = Σ of the normalised weights of cells
/// before and at `c`; `density[c]` = the cell's probability × CELLS (1 = cosine).
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    pub cdf: [f32; CELLS],
    pub density: [f32; CELLS],
}

impl Guide {
    /// The guide of cell weights `w` (any scale), or `None` when they are all 0. Each cell is
    /// first raised to half the largest of its four neighbours (φ wraps round), so that a
    /// texel a little off the one that measured the weights still samples the rim of an
    /// opening.
    pub fn new(w: &[f32; CELLS]) -> Option<Guide> {
        let at = |x: i32, y: i32| -> f32 {
            if !(0..G as i32).contains(&x) {
                return 0.0;
            }
            let y = y.rem_euclid(G as i32);
            w[(y as u32 * G + x as u32) as usize]
        };
        let mut spread = [0.0f32; CELLS];
        let mut total = 0.0f64;
        for y in 0..G as i32 {
            for x in 0..G as i32 {
                let n = at(x - 1, y)
                    .max(at(x + 1, y))
                    .max(at(x, y - 1))
                    .max(at(x, y + 1));
                let v = at(x, y).max(0.5 * n);
                spread[(y as u32 * G + x as u32) as usize] = v;
                total += f64::from(v);
            }
        }
        if total <= 0.0 || !total.is_finite() {
            return None;
        }
        let mut cdf = [0.0f32; CELLS];
        let mut density = [0.0f32; CELLS];
        let mut acc = 0.0f64;
        for c in 0..CELLS {
            let p = f64::from(spread[c]) / total;
            acc += p;
            cdf[c] = acc as f32;
            density[c] = (p * CELLS as f64) as f32;
        }
        cdf[CELLS - 1] = 1.0;
        Some(Guide { cdf, density })
    }

    /// A square point drawn from the guide with `v` uniform in [0, 1) (the cell, by the cdf)
    /// and `j` uniform in [0, 1)² (where in the cell).
    pub fn sample(&self, v: f32, j: Vec2) -> Vec2 {
        let c = self.cdf.partition_point(|&x| x <= v).min(CELLS - 1);
        let (cx, cy) = ((c as u32 % G) as f32, (c as u32 / G) as f32);
        ((Vec2::new(cx, cy) + j) / G as f32).min(Vec2::splat(0.999_999_9))
    }
}

/// The density, relative to cosine sampling, of `n_b` rays of which `n_u` are cosine rays and
/// the rest drawn from `guide`, at the cell `c`: the one-sample mixture the balance heuristic
/// weighs them by (so the ray estimator is Σ L·π / (n_b · mixture)).
pub fn mixture(guide: Option<&Guide>, n_u: u32, n_b: u32, c: usize) -> f32 {
    match guide {
        None => 1.0,
        Some(g) => (n_u as f32 + (n_b - n_u) as f32 * g.density[c]) / n_b as f32,
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
        let mean: f32 = (0..CELLS).map(|c| mixture(Some(&g), 4, 16, c)).sum::<f32>() / CELLS as f32;
        assert!((mean - 1.0).abs() < 1e-5);
    }
}
