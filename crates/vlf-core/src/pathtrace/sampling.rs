//! Random numbers and the sampling routines of the path tracer.
//!
//! Everything here is written so that `shaders/raytrace_path.wgsl` can implement the very same
//! arithmetic with 32-bit integers and floats: the generator is PCG-RXS-M-XS 32/32 (O'Neill
//! 2014) with a per-path stream, seeded by hashing (seed, sample, pixel) with the PCG hash of
//! Jarzynski & Olano (JCGT 2020).

use glam::{Vec2, Vec3};

/// One round of the PCG hash (Jarzynski & Olano 2020, "Hash functions for GPU rendering").
pub fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A deterministic per-path random number generator (PCG-RXS-M-XS 32/32 with a per-path odd
/// increment, i.e. its own stream).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    /// LCG state.
    pub state: u32,
    /// Odd LCG increment (stream selector).
    pub inc: u32,
}

impl Rng {
    /// The generator of sample `sample` of pixel `pixel` (`y × width + x`) under `seed`.
    pub fn for_path(seed: u32, pixel: u32, sample: u32) -> Self {
        let a = pcg_hash(seed ^ 0x9e37_79b9);
        let b = pcg_hash(a ^ sample);
        let state = pcg_hash(b ^ pixel.wrapping_mul(0x85eb_ca6b));
        let inc = (pcg_hash(state ^ 0x68e3_1da4) << 1) | 1;
        let mut rng = Self { state, inc };
        rng.next_u32();
        rng
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(747_796_405).wrapping_add(self.inc);
        let word = ((old >> ((old >> 28) + 4)) ^ old).wrapping_mul(277_803_737);
        (word >> 22) ^ word
    }

    /// Uniform in `[0, 1)` with 24 bits of resolution.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms in `[0, 1)`.
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

/// An orthonormal basis `(t, b, n)` around the unit vector `n` (Duff et al. 2017).
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Local (z = normal) → world.
pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = basis(n);
    t * local.x + b * local.y + n * local.z
}

/// World → local (z = normal).
pub fn to_local(v: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = basis(n);
    Vec3::new(v.dot(t), v.dot(b), v.dot(n))
}

/// Cosine-weighted direction on the hemisphere around +z; pdf = z / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// Uniform barycentrics `(b1, b2)` of a point on a triangle (weights of p1 and p2).
pub fn triangle_barycentrics(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Power heuristic (β = 2) weight of a sample drawn with pdf `a` against another strategy of
/// pdf `b`.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// GGX (Trowbridge–Reitz) normal distribution `D(h)` for `cos θ_h = h_z`, isotropic `alpha`.
pub fn ggx_d(cos_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = cos_h * cos_h;
    let d = c2 * (a2 - 1.0) + 1.0;
    a2 / (std::f32::consts::PI * d * d)
}

/// Smith's masking term `G1(v)` for GGX, `cos θ_v = cos_v > 0`.
pub fn ggx_g1(cos_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    2.0 * cos_v / (cos_v + (a2 + (1.0 - a2) * cos_v * cos_v).sqrt())
}

/// Samples a GGX microfacet normal from the distribution of visible normals seen from `wo`
/// (local frame, `wo.z > 0`), Heitz 2018 ("Sampling the GGX distribution of visible normals").
pub fn ggx_sample_vndf(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-7)).normalize()
}

/// Mirror reflection of `v` about `n` (both pointing away from the surface).
pub fn reflect(v: Vec3, n: Vec3) -> Vec3 {
    2.0 * v.dot(n) * n - v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_deterministic_and_uniform() {
        let mut a = Rng::for_path(7, 1234, 5);
        let mut b = Rng::for_path(7, 1234, 5);
        let mut c = Rng::for_path(7, 1234, 6);
        let (mut sum, n) = (0.0f64, 100_000);
        let mut differ = 0;
        for _ in 0..n {
            let x = a.next_f32();
            assert_eq!(x, b.next_f32());
            assert!((0.0..1.0).contains(&x));
            if x != c.next_f32() {
                differ += 1;
            }
            sum += f64::from(x);
        }
        assert!(differ > n - 10);
        // Mean of n uniforms: sd = 1/sqrt(12 n) ≈ 9e-4; allow 5 sd.
        assert!((sum / n as f64 - 0.5).abs() < 4.6e-3);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let (t, b) = basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((to_world(to_local(v, n), n) - v).length() < 1e-5);
        }
    }

    /// The VNDF sampler's estimator `G1(wi)` must integrate the GGX BRDF cosine-weighted to the
    /// same directional albedo as a brute-force cosine-sampled estimate.
    #[test]
    fn vndf_estimator_matches_brute_force_albedo() {
        let alpha = 0.3;
        let wo = Vec3::new(0.5, 0.1, 0.7).normalize();
        let mut rng = Rng::for_path(1, 2, 3);
        let n = 400_000;
        let (mut vndf, mut brute) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let h = ggx_sample_vndf(wo, alpha, rng.next_2d());
            let wi = reflect(wo, h);
            if wi.z > 0.0 {
                vndf += f64::from(ggx_g1(wi.z, alpha));
            }
            let wi = cosine_hemisphere(rng.next_2d());
            let h = (wi + wo).normalize();
            let f =
                ggx_d(h.z, alpha) * ggx_g1(wo.z, alpha) * ggx_g1(wi.z, alpha) / (4.0 * wo.z * wi.z);
            brute += f64::from(f * std::f32::consts::PI);
        }
        let (vndf, brute) = (vndf / n as f64, brute / n as f64);
        assert!((vndf - brute).abs() < 0.01, "vndf {vndf} brute {brute}");
    }
}
