//! Jensen's dipole (Jensen, Marschner, Levoy, Hanrahan 2001), the diffuse BSSRDF of a
//! semi-infinite homogeneous medium that `docs/SUBSURFACE.md` describes: the radial profile
//! [`Dipole::profile`] R_d(r), its closed-form integral over the plane
//! [`Dipole::total_reflectance`], the boundary's diffuse Fresnel reflectances, and the inversion
//! of the total reflectance for the reduced albedo the glTF import needs.
//!
//! Lengths are in whatever unit the coefficients are per (the scene's, or VLF units once
//! scaled); the profile is per unit area of that unit.

use std::f64::consts::PI;

/// Unpolarised Fresnel reflectance of a dielectric boundary for light arriving from the medium
/// of index 1 at `cos_i` onto a medium of relative index `eta` (> 0; total internal reflection
/// gives 1 when `eta` < 1).
pub fn fresnel(eta: f64, cos_i: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Quadrature points of [`fresnel_diffuse_external`] (midpoint rule in cos θ: the integrand is
/// smooth for light entering a denser medium, error below 1e-7).
const FDR_POINTS: usize = 4096;

/// Diffuse (cosine-weighted hemispherical) Fresnel reflectance of the boundary for light
/// arriving from outside (index 1) onto a medium of index `eta` ≥ 1: 2∫ F(μ) μ dμ.
/// 0.0918 for η = 1.5.
pub fn fresnel_diffuse_external(eta: f64) -> f64 {
    let n = FDR_POINTS as f64;
    (0..FDR_POINTS)
        .map(|k| {
            let mu = (k as f64 + 0.5) / n;
            2.0 * fresnel(eta, mu) * mu / n
        })
        .sum()
}

/// Diffuse Fresnel reflectance of the boundary seen from inside the medium of index `eta`
/// (total internal reflection included): 1 − (1 − F_dr,ext)/η² (the two sides' reciprocity).
pub fn fresnel_diffuse_internal(eta: f64) -> f64 {
    1.0 - (1.0 - fresnel_diffuse_external(eta)) / (eta * eta)
}

/// One colour channel of the dipole: reduced scattering σ_s′ and absorption σ_a (per length
/// unit), relative index η.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dipole {
    /// Reduced albedo α′ = σ_s′/σ_t′.
    pub albedo: f64,
    /// Effective transport coefficient σ_tr = √(3 σ_a σ_t′).
    pub sigma_tr: f64,
    /// Depth of the real source, 1/σ_t′.
    pub z_r: f64,
    /// Height of the virtual source, z_r (1 + 4A/3).
    pub z_v: f64,
    /// Jensen's boundary term A = (1 + F_dr,int)/(1 − F_dr,int).
    pub a: f64,
}

impl Dipole {
    /// The dipole of a medium with reduced scattering `sigma_s_prime` and absorption `sigma_a`
    /// (both ≥ 0, their sum > 0) and relative index `eta` ≥ 1.
    pub fn new(sigma_s_prime: f64, sigma_a: f64, eta: f64) -> Dipole {
        let sigma_t = sigma_s_prime + sigma_a;
        let fdr = fresnel_diffuse_internal(eta);
        let a = (1.0 + fdr) / (1.0 - fdr);
        let z_r = 1.0 / sigma_t;
        Dipole {
            albedo: sigma_s_prime / sigma_t,
            sigma_tr: (3.0 * sigma_a * sigma_t).sqrt(),
            z_r,
            z_v: z_r * (1.0 + 4.0 * a / 3.0),
            a,
        }
    }

    /// R_d(r): the radiant exitance at distance `r` from a unit flux entering the surface at a
    /// point (per unit area).
    pub fn profile(&self, r: f64) -> f64 {
        let r2 = r * r;
        let term = |z: f64| {
            let d = (r2 + z * z).sqrt();
            z * (self.sigma_tr * d + 1.0) * (-self.sigma_tr * d).exp() / (d * d * d)
        };
        self.albedo / (4.0 * PI) * (term(self.z_r) + term(self.z_v))
    }

    /// ∫ R_d over the plane: the total diffuse reflectance of the flux that enters.
    pub fn total_reflectance(&self) -> f64 {
        total_reflectance(self.albedo, self.a)
    }

    /// ∫ R_d(r) 2πr dr over r ≥ `r0`, in closed form (each source's term integrates to
    /// (α′/2)·z·e^{−σ_tr d₀}/d₀ with d₀ = √(r0² + z²)): the flux that leaves farther than `r0`.
    pub fn reflectance_beyond(&self, r0: f64) -> f64 {
        let tail = |z: f64| {
            let d = (r0 * r0 + z * z).sqrt();
            z * (-self.sigma_tr * d).exp() / d
        };
        0.5 * self.albedo * (tail(self.z_r) + tail(self.z_v))
    }
}

/// Jensen's closed form of the total diffuse reflectance for reduced albedo `albedo` and
/// boundary term `a`: (α′/2)(1 + e^{−(4/3)A√(3(1−α′))}) e^{−√(3(1−α′))}.
pub fn total_reflectance(albedo: f64, a: f64) -> f64 {
    let s = (3.0 * (1.0 - albedo)).sqrt();
    0.5 * albedo * (1.0 + (-4.0 / 3.0 * a * s).exp()) * (-s).exp()
}

/// The reduced albedo α′ ∈ [0, 1] whose total diffuse reflectance at relative index `eta` is
/// `reflectance` (bisection: the closed form rises monotonically from 0 at α′ = 0 to its value
/// at α′ = 1). A reflectance above that maximum gives 1.
pub fn albedo_for_reflectance(reflectance: f64, eta: f64) -> f64 {
    let fdr = fresnel_diffuse_internal(eta);
    let a = (1.0 + fdr) / (1.0 - fdr);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    if reflectance >= total_reflectance(1.0, a) {
        return 1.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if total_reflectance(mid, a) < reflectance {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
