//! What each iteration shoots (`docs/PROPAGATION.md`): the texels' unshot (residual) radiance, accelerated
//! by Chebyshev semi-iteration once the iteration's contraction is measured. Shared by the CPU
//! and GPU propagators, on the host, after [`super::finish_iteration`].
//!
//! An iteration shoots `s` and the surfaces receive `g = M s` (ρE/π of what arrives; M is the
//! transport with the albedos). The unshot radiance left is then `r' = r − s + g`: with `s = r`
//! (plain progressive shooting, every texel at once: Jacobi) `r' = M r`, which falls like the
//! transport's spectral radius λ per iteration: 0.7 in a closed room of albedo 0.7, but close to
//! the albedo of two surfaces facing each other across a sliver, whatever the rest of the room
//! does. Shooting more than the unshot radiance, `s = ω r + (ω − 1) s_prev` (ω from
//! the Chebyshev recurrence for eigenvalues in [−σ, σ]), makes the error fall like
//! σ / (1 + √(1 − σ²)) instead (0.41 for σ 0.7, 0.63 for 0.9). A texel that has shot
//! more than it had keeps a negative residual: light that will arrive later pays it back.
//!
//! The bookkeeping is exact whatever `s` is: an iteration sends P(s), the surfaces absorb and
//! re-emit what arrives, and the unshot power left is P(r) − P(s) + P(g); the energy terms sum
//! as before. Convergence is judged on Σ |r| (a residual of mixed sign could cancel).
//!
//! σ is measured, per colour channel: from the second iteration on (the first carries sky and
//! suns), P(|g|) / P(|s|), the iteration's contraction, kept at its largest so far and at most
//! the largest albedo (the quadrature is normalised per texel, so no texel receives more than
//! the mean of what its directions bring: the transport's rows sum to at most 1). A residual
//! that grew restarts the recurrence (ω = 1). Diffuse transport is reciprocal, so its
//! eigenvalues are real and the recurrence converges for every |λ| < 1 whatever σ is; a
//! measured σ below λ only costs speed. Scenes with mirror or glossy tiles shoot plainly: light
//! circling round mirrors can have complex eigenvalues, for which over-relaxation can diverge.
//! So do fixed iteration counts ([`Iterations::Fixed`]): n iterations are n bounces there.

use glam::{Vec3, Vec4};

use super::energy::{IterationEnergy, sum3};
use crate::bake::BakeScene;
use crate::lightfield::{BakeParams, Iterations};

/// Whether a bake over-relaxes its shots: only when it iterates to convergence and has no
/// mirror or glossy tiles (`tiles`).
pub fn accelerates(params: &BakeParams, tiles: bool) -> bool {
    !tiles && matches!(params.iterations, Iterations::Converge { .. })
}

/// σ is capped below 1: with σ → 1 the recurrence's ω → 2 and the error falls no faster.
const SIGMA_MAX: f32 = 0.995;

/// The residual radiance of the texels and what the next iteration shoots.
#[derive(Clone, Debug)]
pub struct Shooting {
    /// Unshot radiance per texel (rgb, a = 0) after the last finished iteration.
    residual: Vec<[f32; 4]>,
    /// What the current (or last) iteration shoots.
    shot: Vec<[f32; 4]>,
    accelerate: bool,
    /// Iterations finished.
    done: u32,
    /// Chebyshev steps since the last (re)start; 0: the next shot is plain.
    steps: u32,
    /// The largest albedo per channel (σ's bound).
    bound: Vec3,
    /// Measured contraction per channel (0 until measured).
    sigma: Vec3,
    /// ω of the current shot per channel.
    omega: Vec3,
    /// Σ π·area·|r| of the residual (for the restart test).
    magnitude: f64,
}

impl Shooting {
    /// Before the first iteration: the emission is unshot. `accelerate`: whether to
    /// over-relax ([`accelerates`]; if not, every shot is the residual).
    pub fn new(scene: &BakeScene, accelerate: bool) -> Shooting {
        let mut bound = Vec3::ZERO;
        for (a, area) in scene.albedo.iter().zip(&scene.texel_area) {
            if *area > 0.0 {
                bound = bound.max(Vec4::from(*a).truncate());
            }
        }
        Shooting {
            residual: scene.emission.clone(),
            shot: scene.emission.clone(),
            accelerate,
            done: 0,
            steps: 0,
            bound: bound.min(Vec3::splat(SIGMA_MAX)),
            sigma: Vec3::ZERO,
            omega: Vec3::ONE,
            magnitude: f64::INFINITY,
        }
    }

    /// Prepares and returns what the next iteration shoots.
    pub fn prepare(&mut self) -> &[[f32; 4]] {
        self.omega = self.next_omega();
        if self.omega == Vec3::ONE {
            self.shot.copy_from_slice(&self.residual);
        } else {
            let (w, w1) = (self.omega, self.omega - Vec3::ONE);
            for (s, r) in self.shot.iter_mut().zip(&self.residual) {
                let v = w * Vec4::from(*r).truncate() + w1 * Vec4::from(*s).truncate();
                *s = v.extend(0.0).into();
            }
        }
        &self.shot
    }

    /// What the current iteration shoots (the last [`Shooting::prepare`]).
    pub fn shot(&self) -> &[[f32; 4]] {
        &self.shot
    }

    /// The unshot radiance after the last finished iteration.
    pub fn residual(&self) -> &[[f32; 4]] {
        &self.residual
    }

    /// ω of the current shot (1 in every channel for a plain shot).
    pub fn omega(&self) -> Vec3 {
        self.omega
    }

    /// After the iteration: `received` is what [`super::finish_iteration`] wrote as the next
    /// unshot radiance (ρE/π of what the shot brought), `e` its energy terms with the tiles'
    /// (which shoot plainly) already added. Updates the residual, adds to `e.next` the unshot
    /// power the shot left behind (P(r) − P(s): 0 for a plain shot) and sets `e.magnitude`.
    pub fn finish(&mut self, scene: &BakeScene, received: &[[f32; 4]], e: &mut IterationEnergy) {
        let plain = self.omega == Vec3::ONE;
        let pi = std::f64::consts::PI;
        let (mut left, mut signed, mut magnitude) = (0f64, 0f64, 0f64);
        let (mut sent_abs, mut got_abs) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
        for t in 0..self.residual.len() {
            let area = f64::from(scene.texel_area[t]);
            let s = Vec4::from(self.shot[t]).truncate();
            let g = Vec4::from(received[t]).truncate();
            let r = if plain {
                g
            } else {
                let r = Vec4::from(self.residual[t]).truncate();
                left += (sum3(r) - sum3(s)) * pi * area;
                r - s + g
            };
            self.residual[t] = r.extend(0.0).into();
            signed += sum3(r) * pi * area;
            magnitude += sum3(r.abs()) * pi * area;
            sent_abs += s.abs().as_dvec3() * area;
            got_abs += g.abs().as_dvec3() * area;
        }
        e.next += left;
        e.magnitude = e.next + (magnitude - signed);
        // The first iteration's `received` holds the sky and suns too: no contraction there.
        if self.accelerate && self.done > 0 {
            let ratio = |g: f64, s: f64| if s > 0.0 { (g / s) as f32 } else { 0.0 };
            let q = Vec3::new(
                ratio(got_abs.x, sent_abs.x),
                ratio(got_abs.y, sent_abs.y),
                ratio(got_abs.z, sent_abs.z),
            );
            self.sigma = self.sigma.max(q).min(self.bound);
        }
        let grew = magnitude > self.magnitude;
        self.magnitude = magnitude;
        self.done += 1;
        self.steps = if grew || self.sigma == Vec3::ZERO {
            0
        } else {
            self.steps + 1
        };
    }

    /// ω of the next shot: the Chebyshev recurrence ω₁ = 1, ω₂ = 1/(1 − σ²/2),
    /// ωₖ₊₁ = 1/(1 − σ²ωₖ/4), counted from the last (re)start.
    fn next_omega(&self) -> Vec3 {
        if !self.accelerate || self.steps == 0 {
            return Vec3::ONE;
        }
        let s2 = self.sigma * self.sigma;
        if self.steps == 1 {
            Vec3::ONE / (Vec3::ONE - s2 * 0.5)
        } else {
            Vec3::ONE / (Vec3::ONE - s2 * self.omega * 0.25)
        }
    }
}
