//! Matrix radiosity: a baseline for diffuse scenes to compare the virtual light field with
//! (issue #8; the GPU radiosity paper of 2003, `shared/papers/004_*`, §3).
//!
//! * **Patches** are the covered diffuse-atlas texels of the prepared scene
//!   ([`BakeScene`]), both sides of every face, so a solution is a per-texel radiance array in
//!   the atlas layout of a propagation ([`BakeScene::outgoing_radiance`] of its irradiance);
//!   its irradiance becomes a [`LightField`] through [`bake::assemble`]: the renderer shows it
//!   as it shows a VLF bake and images compare like for like.
//! * **Form factors** ([`form_factors`]) are estimated by ray casting ("the ray engine"): from
//!   each patch, stratified cosine-weighted rays with origins jittered over the texel's covered
//!   area, traced in VLF space with the path tracer's [`Bvh`](crate::pathtrace::Bvh);
//!   `F_ij = hits_j / N`. Rays that escape see the sky; suns are direct light found with shadow
//!   rays (irradiance × cos × visible fraction, as the baker injects them); point and spot
//!   lights are the propagation's injected direct light (`bake::punctual`).
//! * **The system**, in radiance, RGB: `L_i = S_i + ρ_i Σ_j F_ij L_j` with the source
//!   `S_i = E_i + ρ_i (sky · F_i,sky + (E_sun,i + E_lamp,i) / π)`.
//! * **Solvers**: [`solve_gauss_seidel`] (in place, row order) and [`solve_jacobi`] on the CPU;
//!   Jacobi on the GPU lives in `vlf_gpu::radiosity` and is checked against [`solve_jacobi`].
//!
//! Only diffuse reflection is modelled. Mirror and mixed faces are listed in
//! [`FormFactors::non_diffuse_faces`] (their diffuse part alone is used: a pure mirror is a
//! black absorber), and [`bake`] refuses such scenes with [`RadiosityError::NonDiffuse`].
//! See `docs/RADIOSITY.md` for measurements.

mod form_factors;
mod solve;

pub use form_factors::{FormFactors, form_factors};
pub use solve::{
    IterationCallback, Solution, jacobi_sweep, residual, solve_gauss_seidel, solve_jacobi, stops,
};

use std::time::Instant;

use glam::Vec4;
use serde::Serialize;

use crate::bake::{self, BakeScene, reference};
use crate::directions::{DirectionError, DirectionSet};
use crate::lightfield::{BakeParams, BakeStats, FACE_DIFFUSE, LightField, ParamsError};
use crate::scene::Scene;

/// What controls a radiosity solution. `Default` gives the values used in `docs/RADIOSITY.md`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RadiositySettings {
    /// Form-factor rays per patch (cosine-weighted, stratified). Also the shadow rays per sun.
    pub rays_per_patch: u32,
    /// Seed of the ray directions and origins; form factors are deterministic.
    pub seed: u64,
    /// Upper bound on solver sweeps.
    pub max_iterations: u32,
    /// Stop when the largest change of a sweep, relative to the largest radiance, falls below
    /// this (0 = always run `max_iterations`).
    pub threshold: f32,
    /// Worker threads for form factors and the CPU Jacobi solver (0 = all cores). The result
    /// does not depend on it.
    pub threads: usize,
}

impl Default for RadiositySettings {
    fn default() -> Self {
        Self {
            rays_per_patch: 1024,
            seed: 0x5eed_0008,
            max_iterations: 1000,
            threshold: 1e-5,
            threads: 0,
        }
    }
}

impl RadiositySettings {
    /// Checks ranges.
    pub fn validate(&self) -> Result<(), RadiosityError> {
        if !(1..=1 << 20).contains(&self.rays_per_patch) {
            return Err(RadiosityError::Settings(format!(
                "rays_per_patch = {} is out of range (1..=1048576)",
                self.rays_per_patch
            )));
        }
        if !(self.threshold.is_finite() && (0.0..1.0).contains(&self.threshold)) {
            return Err(RadiosityError::Settings(format!(
                "threshold = {} is out of range ([0, 1))",
                self.threshold
            )));
        }
        Ok(())
    }

    /// The thread count to use (resolves 0 to the available parallelism).
    pub fn worker_threads(&self) -> usize {
        crate::par::threads(self.threads)
    }
}

/// Errors of a radiosity solution.
#[derive(Debug, thiserror::Error)]
pub enum RadiosityError {
    #[error("invalid bake parameters: {0}")]
    Params(#[from] ParamsError),
    #[error("invalid direction count: {0}")]
    Directions(#[from] DirectionError),
    #[error("invalid radiosity settings: {0}")]
    Settings(String),
    #[error(
        "radiosity models diffuse reflection only, but {} face(s) are mirrors or mixed (first: {:?}); bake this scene with the VLF instead",
        faces.len(),
        &faces[..faces.len().min(8)]
    )]
    NonDiffuse { faces: Vec<u32> },
    #[error("the form-factor matrix has {nonzeros} non-zeros, more than the {max} supported")]
    TooLarge { nonzeros: u64, max: u64 },
}

/// Faces that are not purely diffuse (mirror or mixed).
pub fn non_diffuse_faces(prep: &BakeScene) -> Vec<u32> {
    (0..prep.faces.len() as u32)
        .filter(|&f| prep.faces[f as usize].kind != FACE_DIFFUSE)
        .collect()
}

/// Measurements of one radiosity bake (what a sweep tool records next to VLF bakes).
#[derive(Clone, Debug, Default, Serialize)]
pub struct RadiosityReport {
    /// `"gauss-seidel (cpu)"`, `"jacobi (cpu)"` or `"jacobi (gpu)"`.
    pub solver: String,
    /// Patches (covered texels, both sides).
    pub patches: usize,
    /// Non-zero form factors.
    pub nonzeros: usize,
    /// Bytes of the matrix and the per-patch vectors ([`FormFactors::memory_bytes`]).
    pub memory_bytes: usize,
    pub rays_per_patch: u32,
    /// Rays that hit geometry with no covered texel near the hit point (lost light).
    pub lost_rays: u64,
    pub form_factor_seconds: f64,
    pub solve_seconds: f64,
    pub iterations: u32,
    pub converged: bool,
    /// Relative change of every sweep (see [`Solution::residual_history`]).
    pub residual_history: Vec<f32>,
}

impl RadiosityReport {
    /// The report's matrix figures for `ff` (timings and solver fields left for the caller).
    pub fn for_form_factors(ff: &FormFactors) -> Self {
        Self {
            patches: ff.patches(),
            nonzeros: ff.nonzeros(),
            memory_bytes: ff.memory_bytes(),
            rays_per_patch: ff.rays_per_patch,
            lost_rays: ff.lost_rays,
            ..Default::default()
        }
    }

    /// Records a solver's result.
    pub fn set_solution(&mut self, solver: &str, solution: &Solution, seconds: f64) {
        self.solver = solver.into();
        self.solve_seconds = seconds;
        self.iterations = solution.iterations;
        self.converged = solution.converged;
        self.residual_history = solution.residual_history.clone();
    }
}

/// Builds the [`LightField`] of a solution through [`bake::assemble`] (dilation and every other
/// field exactly as for a VLF bake). `stats.device` is `"cpu"`; GPU callers may overwrite it.
pub fn to_light_field(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    solution: &Solution,
) -> LightField {
    let emitted = prep
        .emission
        .iter()
        .zip(&prep.texel_area)
        .map(|(e, a)| {
            let e = Vec4::from(*e);
            f64::from(e.x + e.y + e.z) * std::f64::consts::PI * f64::from(*a)
        })
        .sum();
    // Irradiance from the solved radiance: B = L_e + ρE/π (zero where the albedo is zero).
    let irradiance = solution
        .radiance
        .iter()
        .zip(&prep.emission)
        .zip(&prep.albedo)
        .map(|((b, e), rho)| {
            let (b, e, rho) = (Vec4::from(*b), Vec4::from(*e), Vec4::from(*rho));
            let r = (b - e).max(Vec4::ZERO) * std::f32::consts::PI;
            let div = |x: f32, y: f32| if y > 0.0 { x / y } else { 0.0 };
            [div(r.x, rho.x), div(r.y, rho.y), div(r.z, rho.z), 0.0]
        })
        .collect();
    let propagated = reference::Propagated {
        irradiance,
        first_bounce: None,
        tiles: None,
        iterations: solution.iterations,
        energy: reference::EnergyStats {
            emitted,
            ..Default::default()
        },
    };
    let mut stats = BakeStats {
        iterations: solution.iterations,
        device: "cpu".into(),
        adapter: "matrix radiosity".into(),
        ..Default::default()
    };
    propagated.energy.copy_into(&mut stats);
    bake::assemble(scene, prep, params, directions, propagated, stats)
}

/// Prepares `scene` at `params` (atlas and sky as for a VLF bake), computes form factors,
/// solves with Gauss–Seidel on the CPU and assembles the light field. Refuses scenes with
/// mirror or mixed faces ([`RadiosityError::NonDiffuse`]).
pub fn bake(
    scene: &Scene,
    params: &BakeParams,
    settings: &RadiositySettings,
) -> Result<(LightField, RadiosityReport), RadiosityError> {
    let prep = BakeScene::new(scene, params)?;
    let directions = DirectionSet::at_least(params.directions)?;
    let faces = non_diffuse_faces(&prep);
    if !faces.is_empty() {
        return Err(RadiosityError::NonDiffuse { faces });
    }
    let t0 = Instant::now();
    let ff = form_factors(&prep, params.sky, settings)?;
    let mut report = RadiosityReport::for_form_factors(&ff);
    report.form_factor_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let solution = solve_gauss_seidel(&ff, settings, None);
    report.set_solution("gauss-seidel (cpu)", &solution, t1.elapsed().as_secs_f64());
    let lf = to_light_field(scene, &prep, params, directions, &solution);
    Ok((lf, report))
}

/// Area-weighted mean of |a − b|₁ / |b|₁ over covered texels that receive light (|b|₁ above
/// 1 % of the area-weighted mean: the closed insides of solids and the outsides of walls are
/// left out). Compares two per-texel radiance arrays of `prep`'s atlas (radiosity against a VLF
/// bake, or two seeds).
pub fn mean_texel_difference(prep: &BakeScene, a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let rgb = |v: [f32; 4]| Vec4::from(v).truncate();
    let (mut sum, mut wsum) = (0f64, 0f64);
    for t in 0..prep.texel_count() {
        sum += f64::from(prep.texel_area[t] * rgb(b[t]).element_sum());
        wsum += f64::from(prep.texel_area[t]);
    }
    let floor = 0.01 * sum / wsum;
    let (mut num, mut den) = (0f64, 0f64);
    for t in 0..prep.texel_count() {
        let w = f64::from(prep.texel_area[t]);
        let bb = f64::from(rgb(b[t]).element_sum());
        if w <= 0.0 || bb < floor {
            continue;
        }
        num += w * f64::from((rgb(a[t]) - rgb(b[t])).abs().element_sum()) / bb;
        den += w;
    }
    num / den
}
