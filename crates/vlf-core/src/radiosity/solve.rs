//! CPU solvers of `L = S + ρ ⊙ (F L)`: Gauss–Seidel (in place, row order; serial) and Jacobi
//! (ping-pong, rows split over threads; the specification of the GPU solver).
//!
//! Both start from `L⁰ = S` (emission and direct light: one bounce) and stop after
//! `max_iterations` sweeps or when the sweep's residual `max |L_new − L_old| / max |L_new|`
//! (over patches and channels) falls below the threshold. Sums run in `f32` in column order,
//! as on the GPU.

use glam::{Vec3, Vec4};

use super::{FormFactors, RadiositySettings};

/// Called after every sweep with the sweep number (1-based) and the current radiance in the
/// per-texel layout of [`Solution::radiance`] (for iterations-vs-error curves).
pub type IterationCallback<'a> = Option<&'a mut dyn FnMut(u32, &[[f32; 4]])>;

/// A solved (or stopped) system.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// Outgoing radiance per atlas texel, emission included (rgb, a = 0; uncovered texels 0):
    /// the atlas layout of `BakeScene::outgoing_radiance`.
    pub radiance: Vec<[f32; 4]>,
    /// Sweeps run.
    pub iterations: u32,
    /// Residual of every sweep: max |ΔL| / max |L| over patches and channels.
    pub residual_history: Vec<f32>,
    /// Whether the residual fell below the threshold (false with threshold 0).
    pub converged: bool,
}

/// `max |a − b|` and `max |a|` over channels.
pub(crate) fn change(new: Vec3, old: Vec3) -> (f32, f32) {
    ((new - old).abs().max_element(), new.abs().max_element())
}

/// Residual from the sweep's maxima.
pub fn residual(max_delta: f32, max_value: f32) -> f32 {
    if max_value > 0.0 {
        max_delta / max_value
    } else {
        0.0
    }
}

/// Whether a sweep with this residual stops the solver.
pub fn stops(residual: f32, threshold: f32) -> bool {
    threshold > 0.0 && residual < threshold
}

#[inline]
fn gather(ff: &FormFactors, i: usize, l: &[[f32; 4]]) -> Vec3 {
    let (cols, vals) = ff.row(i);
    let mut acc = Vec3::ZERO;
    for (&c, &v) in cols.iter().zip(vals) {
        acc += Vec4::from(l[c as usize]).truncate() * v;
    }
    acc
}

#[inline]
fn update(ff: &FormFactors, i: usize, l: &[[f32; 4]]) -> Vec3 {
    let s = Vec4::from(ff.source[i]).truncate();
    let rho = Vec4::from(ff.albedo[i]).truncate();
    s + rho * gather(ff, i, l)
}

/// Gauss–Seidel: each sweep updates patches in row order, in place (later rows already see
/// this sweep's values). Serial.
pub fn solve_gauss_seidel(
    ff: &FormFactors,
    settings: &RadiositySettings,
    mut on_iteration: IterationCallback,
) -> Solution {
    let mut l = ff.source.clone();
    let mut history = Vec::new();
    let mut converged = false;
    for it in 1..=settings.max_iterations {
        let (mut dmax, mut vmax) = (0f32, 0f32);
        for i in 0..ff.patches() {
            let new = update(ff, i, &l);
            let (d, v) = change(new, Vec4::from(l[i]).truncate());
            dmax = dmax.max(d);
            vmax = vmax.max(v);
            l[i] = new.extend(0.0).into();
        }
        let r = residual(dmax, vmax);
        history.push(r);
        if let Some(cb) = on_iteration.as_mut() {
            cb(it, &ff.scatter(&l));
        }
        if stops(r, settings.threshold) {
            converged = true;
            break;
        }
    }
    Solution {
        radiance: ff.scatter(&l),
        iterations: history.len() as u32,
        residual_history: history,
        converged,
    }
}

/// One Jacobi sweep `dst = S + ρ ⊙ (F src)` over rows split among `threads`; returns
/// (max |ΔL|, max |L|).
pub fn jacobi_sweep(
    ff: &FormFactors,
    src: &[[f32; 4]],
    dst: &mut [[f32; 4]],
    threads: usize,
) -> (f32, f32) {
    let n = ff.patches();
    let chunk = n.div_ceil(threads.max(1)).max(1);
    let sweep = |first: usize, out: &mut [[f32; 4]]| {
        let (mut dmax, mut vmax) = (0f32, 0f32);
        for (k, o) in out.iter_mut().enumerate() {
            let i = first + k;
            let new = update(ff, i, src);
            let (d, v) = change(new, Vec4::from(src[i]).truncate());
            dmax = dmax.max(d);
            vmax = vmax.max(v);
            *o = new.extend(0.0).into();
        }
        (dmax, vmax)
    };
    if threads <= 1 || n < 2 * chunk {
        return sweep(0, dst);
    }
    use rayon::prelude::*;
    crate::par::pool(threads).install(|| {
        let parts: Vec<(f32, f32)> = dst
            .par_chunks_mut(chunk)
            .enumerate()
            .map(|(c, out)| sweep(c * chunk, out))
            .collect();
        // max is exact and order-free: the result does not depend on the split.
        parts
            .into_iter()
            .fold((0f32, 0f32), |a, b| (a.0.max(b.0), a.1.max(b.1)))
    })
}

/// Jacobi: each sweep computes every patch from the previous sweep's values (ping-pong), rows
/// split over `settings.threads` (the result does not depend on the count).
pub fn solve_jacobi(
    ff: &FormFactors,
    settings: &RadiositySettings,
    mut on_iteration: IterationCallback,
) -> Solution {
    let threads = settings.worker_threads();
    let mut src = ff.source.clone();
    let mut dst = vec![[0f32; 4]; ff.patches()];
    let mut history = Vec::new();
    let mut converged = false;
    for it in 1..=settings.max_iterations {
        let (dmax, vmax) = jacobi_sweep(ff, &src, &mut dst, threads);
        std::mem::swap(&mut src, &mut dst);
        let r = residual(dmax, vmax);
        history.push(r);
        if let Some(cb) = on_iteration.as_mut() {
            cb(it, &ff.scatter(&src));
        }
        if stops(r, settings.threshold) {
            converged = true;
            break;
        }
    }
    Solution {
        radiance: ff.scatter(&src),
        iterations: history.len() as u32,
        residual_history: history,
        converged,
    }
}
