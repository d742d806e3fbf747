//! The reflection model of `shared/reference/README.md`, evaluated and sampled.
//!
//! With m = metallic, r = roughness and C = base colour (× texture):
//! m ≤ 0.01 → Lambert(C); m ≥ 0.99 → metal(C); otherwise (1 − m)·Lambert(C) + m·metal(C), where
//! metal is a perfect mirror of reflectance C (no Fresnel) when r ≤ 0.05 and a GGX microfacet
//! metal with α = r² and reflectance C (Smith G1·G1, no Fresnel) otherwise. A thin glass pane
//! (`KHR_materials_transmission`) takes transmissionFactor of the non-metal part: it reflects
//! R(θ) as an untinted perfect mirror and passes T(θ) = 1 − R(θ) × C straight through
//! (`scene::pane_reflectance`, Mitsuba's thindielectric). Surfaces reflect alike from both
//! sides: callers pass the normal flipped towards `wo`.

use glam::{Vec2, Vec3};

use super::sampling::{
    cosine_hemisphere, ggx_d, ggx_g1, ggx_sample_vndf, reflect, to_local, to_world,
};
use crate::scene::Material;

pub use crate::scene::{DIFFUSE_MAX_METALLIC, METAL_MIN_METALLIC, MIRROR_MAX_ROUGHNESS, lobes};

/// A material reduced to what the path tracer needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// Base colour factor (linear RGB).
    pub base_color: Vec3,
    /// Index into `Scene::textures` of the base-colour texture.
    pub base_texture: Option<u32>,
    /// Emitted radiance factor (front face only).
    pub emission: Vec3,
    /// Index into `Scene::textures` of the emissive texture.
    pub emissive_texture: Option<u32>,
    /// The texture coordinate sets (0 or 1) of the base-colour and emissive textures.
    pub base_texcoord: u32,
    pub emissive_texcoord: u32,
    /// Weight of the Lambertian lobe; the metal lobe has `1 − w_diffuse − w_pane`.
    pub w_diffuse: f32,
    /// GGX α of the metal lobe; 0 = perfect mirror.
    pub alpha: f32,
    /// Weight of the thin glass pane (0: none).
    pub w_pane: f32,
    /// The pane's index of refraction.
    pub ior: f32,
}

impl SurfaceMaterial {
    /// From an imported material (its metallic and roughness factors, not its
    /// [`MaterialKind`](crate::scene::MaterialKind), which is the baker's approximation).
    pub fn from_scene(m: &Material) -> Self {
        let (non_metal, alpha) = lobes(m.metallic, m.roughness);
        let w_pane = non_metal * m.transparency.transmission;
        Self {
            base_color: m.base_color,
            base_texture: m.base_color_texture.map(|t| t.index),
            emission: m.emission,
            emissive_texture: m.emissive_texture.map(|t| t.index),
            base_texcoord: m.base_color_texture.map_or(0, |t| t.texcoord.min(1)),
            emissive_texcoord: m.emissive_texture.map_or(0, |t| t.texcoord.min(1)),
            w_diffuse: non_metal - w_pane,
            alpha,
            w_pane,
            ior: m.transparency.ior,
        }
    }

    /// Weight of the metal lobe.
    pub fn w_metal(&self) -> f32 {
        1.0 - self.w_diffuse - self.w_pane
    }

    /// Whether the BSDF has a non-delta part (so light sampling can help).
    pub fn has_smooth_part(&self) -> bool {
        self.w_diffuse > 0.0 || (self.alpha > 0.0 && self.w_metal() > 0.0)
    }

    /// What the pane passes straight through at incidence cosine `cos`, `w_pane × T(θ)` (times
    /// C, the caller's); 0 without a pane.
    pub fn pane_transmission(&self, cos: f32) -> f32 {
        if self.w_pane <= 0.0 {
            return 0.0;
        }
        self.w_pane * (1.0 - crate::scene::pane_reflectance(cos, self.ior))
    }
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident (light-side) direction, unit length, on the side of the normal.
    pub wi: Vec3,
    /// `f · cos θ_i / pdf` (for the delta lobe: its reflectance).
    pub weight: Vec3,
    /// Solid-angle pdf of the non-delta part at `wi` (for MIS); 0 for a delta sample.
    pub pdf: f32,
    /// Whether the sample came from the perfect mirror or the pane.
    pub delta: bool,
    /// Whether it passed through the pane (`wi = −wo`, on the other side of the surface).
    pub transmitted: bool,
}

/// Non-delta BSDF value `f(wo, wi)` and the solid-angle pdf with which [`sample`] produces `wi`
/// from its non-delta lobes. `n` faces `wo`; `color` is C.
pub fn eval(m: &SurfaceMaterial, color: Vec3, n: Vec3, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    let cos_i = n.dot(wi);
    let cos_o = n.dot(wo);
    if cos_i <= 0.0 || cos_o <= 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let mut f = color * (m.w_diffuse * std::f32::consts::FRAC_1_PI);
    let mut pdf = m.w_diffuse * cos_i * std::f32::consts::FRAC_1_PI;
    let w_metal = m.w_metal();
    if m.alpha > 0.0 && w_metal > 0.0 {
        let h = (wi + wo).normalize();
        let d = ggx_d(n.dot(h).max(0.0), m.alpha);
        let g1o = ggx_g1(cos_o, m.alpha);
        f += color * (w_metal * ggx_metal(n, wo, wi, m.alpha));
        pdf += w_metal * g1o * d / (4.0 * cos_o);
    }
    (f, pdf)
}

/// The GGX metal lobe per unit reflectance, `f(wo, wi) = D(h)·G1(wo)·G1(wi) / (4 cos_o cos_i)`
/// (Smith's separable masking, no Fresnel), for unit `wo`, `wi` and normal `n`; 0 when either
/// direction is not above the surface. Symmetric in `wo` and `wi`. The one definition of the
/// lobe that [`eval`] and the bake's glossy weights (`bake::reference::lobe`) share.
pub fn ggx_metal(n: Vec3, wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let (cos_o, cos_i) = (n.dot(wo), n.dot(wi));
    if cos_o <= 0.0 || cos_i <= 0.0 {
        return 0.0;
    }
    let h = (wi + wo).normalize();
    let d = ggx_d(n.dot(h).max(0.0), alpha);
    d * ggx_g1(cos_o, alpha) * ggx_g1(cos_i, alpha) / (4.0 * cos_o * cos_i)
}

/// Directional albedo of the GGX metal lobe per unit reflectance,
/// `A(μ) = ∫ f(wo, wi) cos θ_i dω_i` for `cos θ_o = μ` (< 1 for α > 0: single scattering loses
/// the light that masking and shadowing stop), by numerical integration over the half vector:
/// with `wi` the reflection of `wo` about h, `dω_i = 4 (wo·h) dω_h`, so
/// `A = ∫ D(h) cos θ_h · G1(wo) G1(wi) (wo·h) / (μ cos θ_h) dω_h`, and `D cos θ_h` is a density
/// whose θ_h is `tan² θ_h = α² ξ / (1 − ξ)` for uniform ξ. Midpoint rule over u (512) with
/// `ξ = 1 − (1 − u)³`, which crowds the nodes near ξ = 1 where, at grazing angles, the
/// reflected direction drops below the surface (uniform ξ was 0.3 % low at α 0.05, μ 0.1),
/// and over φ (256 over the half circle, the integrand being symmetric): within 1e-5 of a
/// four times finer rule.
pub fn ggx_directional_albedo(mu: f32, alpha: f32) -> f32 {
    const XI: usize = 512;
    const PHI: usize = 256;
    if alpha <= 0.0 {
        return 1.0;
    }
    let mu = mu.clamp(1e-4, 1.0);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1o = ggx_g1(mu, alpha);
    let a2 = f64::from(alpha) * f64::from(alpha);
    let mut sum = 0f64;
    for i in 0..XI {
        let u = (i as f64 + 0.5) / XI as f64;
        let xi = 1.0 - (1.0 - u).powi(3);
        let dxi = 3.0 * (1.0 - u) * (1.0 - u);
        let tan2 = a2 * xi / (1.0 - xi);
        let cos_h = 1.0 / (1.0 + tan2).sqrt();
        let sin_h = (tan2.sqrt() * cos_h) as f32;
        let mut row = 0f64;
        for j in 0..PHI {
            let phi = std::f32::consts::PI * (j as f32 + 0.5) / PHI as f32;
            let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h as f32);
            let oh = wo.dot(h);
            if oh <= 0.0 {
                continue;
            }
            let wi = 2.0 * oh * h - wo;
            if wi.z <= 0.0 {
                continue;
            }
            row += f64::from(g1o * ggx_g1(wi.z, alpha) * oh) / (f64::from(mu) * cos_h);
        }
        sum += row / PHI as f64 * dxi;
    }
    (sum / XI as f64) as f32
}

/// [`ggx_directional_albedo`] of one α tabulated over μ (nodes at `μ = (k/64)²`, denser at
/// grazing angles where it changes fastest), read with linear interpolation.
#[derive(Clone, Debug, PartialEq)]
pub struct GgxAlbedo {
    pub alpha: f32,
    values: Vec<f32>,
}

impl GgxAlbedo {
    const NODES: usize = 64;

    pub fn new(alpha: f32) -> GgxAlbedo {
        let values = (0..=Self::NODES)
            .map(|k| {
                let s = k as f32 / Self::NODES as f32;
                ggx_directional_albedo(s * s, alpha)
            })
            .collect();
        GgxAlbedo { alpha, values }
    }

    /// A(μ) for `μ = |cos θ|` in [0, 1].
    pub fn at(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0).sqrt() * Self::NODES as f32;
        let k = (x as usize).min(Self::NODES - 1);
        let t = x - k as f32;
        self.values[k] * (1.0 - t) + self.values[k + 1] * t
    }

    /// The cosine-weighted mean `2 ∫ A(μ) μ dμ`: what the lobe reflects of uniform light,
    /// as a fraction (trapezoid rule over the table, in s = √μ: `4 ∫ A(s²) s³ ds`).
    pub fn hemispherical(&self) -> f32 {
        let n = Self::NODES as f32;
        let f = |k: usize| {
            let s = k as f32 / n;
            self.values[k] * s * s * s
        };
        let inner: f32 = (1..Self::NODES).map(f).sum();
        4.0 * (inner + 0.5 * (f(0) + f(Self::NODES))) / n
    }
}

/// Samples the BSDF: `u_lobe` picks the lobe (Lambert with probability `w_diffuse`, the pane
/// with `w_pane`, split into reflection and transmission by R(θ), else the metal), `u` the
/// direction. `None` when the sampled direction falls below the surface.
pub fn sample(
    m: &SurfaceMaterial,
    color: Vec3,
    n: Vec3,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
) -> Option<BsdfSample> {
    let wi = if u_lobe < m.w_diffuse {
        to_world(cosine_hemisphere(u), n)
    } else if u_lobe < m.w_diffuse + m.w_pane {
        // The pane: reflect with probability R(θ), else pass straight through (the lobe's
        // choice probabilities cancel its weights; the transmission is tinted).
        let r = crate::scene::pane_reflectance(n.dot(wo), m.ior);
        let reflected = (u_lobe - m.w_diffuse) < m.w_pane * r;
        return Some(BsdfSample {
            wi: if reflected {
                reflect(wo, n).normalize()
            } else {
                -wo
            },
            weight: if reflected { Vec3::ONE } else { color },
            pdf: 0.0,
            delta: true,
            transmitted: !reflected,
        });
    } else if m.alpha == 0.0 {
        return Some(BsdfSample {
            wi: reflect(wo, n).normalize(),
            weight: color,
            pdf: 0.0,
            delta: true,
            transmitted: false,
        });
    } else {
        let wo_l = to_local(wo, n);
        let h = ggx_sample_vndf(wo_l.normalize(), m.alpha, u);
        to_world(reflect(wo_l, h), n).normalize()
    };
    let cos_i = n.dot(wi);
    if cos_i <= 0.0 {
        return None;
    }
    let (f, pdf) = eval(m, color, n, wo, wi);
    if pdf <= 0.0 {
        return None;
    }
    Some(BsdfSample {
        wi,
        weight: f * (cos_i / pdf),
        pdf,
        delta: false,
        transmitted: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pathtrace::sampling::Rng;

    #[test]
    fn lobes_follow_the_reference_conventions() {
        assert_eq!(lobes(0.0, 1.0), (1.0, 1.0));
        assert_eq!(lobes(0.01, 0.3), (1.0, 0.09));
        assert_eq!(lobes(1.0, 0.0), (0.0, 0.0));
        assert_eq!(lobes(1.0, 0.05), (0.0, 0.0));
        let (w, a) = lobes(0.89, 0.15);
        assert!((w - 0.11).abs() < 1e-6 && (a - 0.0225).abs() < 1e-7);
    }

    /// White-furnace style check: the estimator's mean weight equals the brute-force
    /// directional albedo ∫ f cos, for a mixed rough material.
    #[test]
    fn sampling_weights_are_consistent_with_eval() {
        let m = SurfaceMaterial {
            base_color: Vec3::ONE,
            base_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            base_texcoord: 0,
            emissive_texcoord: 0,
            w_diffuse: 0.4,
            alpha: 0.2,
            w_pane: 0.0,
            ior: 1.5,
        };
        let n = Vec3::new(0.2, 0.9, -0.1).normalize();
        let wo = (n + Vec3::new(0.6, 0.0, 0.3)).normalize();
        let mut rng = Rng::for_path(9, 9, 9);
        let count = 300_000;
        let (mut est, mut brute) = (0.0f64, 0.0f64);
        for _ in 0..count {
            if let Some(s) = sample(&m, Vec3::ONE, n, wo, rng.next_f32(), rng.next_2d()) {
                est += f64::from(s.weight.x);
            }
            let wi = to_world(cosine_hemisphere(rng.next_2d()), n);
            let (f, _) = eval(&m, Vec3::ONE, n, wo, wi);
            brute += f64::from(f.x * std::f32::consts::PI);
        }
        let (est, brute) = (est / count as f64, brute / count as f64);
        assert!(
            (est - brute).abs() < 0.01,
            "estimator {est} vs brute force {brute}"
        );
        assert!(est < 1.0);
    }
}
