//! Translucent surfaces in the path tracer (`docs/SUBSURFACE.md`): the independent check of the
//! bake's subsurface transport.
//!
//! * **Thin diffuse transmission**: a Lambertian reflection of albedo (1 − t) ρ on the side
//!   the path arrived at and a Lambertian transmission t C w_d to the other side, sampled by
//!   their albedos' luminance.
//! * **Dipole materials** are simulated, not approximated: a smooth dielectric boundary of
//!   relative index η (Fresnel reflection or Snell refraction, total internal reflection
//!   inside) around a homogeneous medium with extinction σ_t = σ_s′ + σ_a and isotropic
//!   scattering of albedo σ_s′/σ_t (the similarity relation: the reduced coefficients stand
//!   for the anisotropic ones), walked by free-flight sampling in a colour channel chosen at
//!   random for the walk (spectral MIS over whole walks) until the path leaves the object. The bake's dipole models this same medium with the diffusion approximation on a
//!   flat semi-infinite surface, and its surface reflection diffusely: their differences are
//!   the dipole's assumptions.
//!
//! No light sampling at translucent surfaces: a path leaving one continues as after a specular
//! bounce (an emitter it hits counts in full).

use glam::Vec3;

use super::sampling::{self, Rng};
use super::{PreparedScene, Ray};
use crate::pathtrace::geometry::offset_ray_origin;
use crate::scene::Translucency;
use crate::scene::dipole::fresnel;

/// A walk longer than this many scattering events is ended (its light counted as absorbed: a
/// bias below e^{−(1 − α)·MAX_EVENTS}-ish of what such long walks carry, nil for any albedo
/// below 0.9999).
const MAX_EVENTS: u32 = 1_000_000;
/// Russian roulette inside a medium starts after this many events, and only kills a walk whose
/// throughput has fallen below 1 (with survival probability its throughput).
const WALK_RR: u32 = 64;

/// How a path continues at a translucent surface.
pub(super) enum Crossing {
    /// A new ray (`origin`, `dir`) and the factor of the path's throughput.
    Continue {
        origin: Vec3,
        dir: Vec3,
        weight: Vec3,
    },
    /// The path ends (absorbed inside).
    Absorbed,
}

/// The continuation of a path travelling along `d` that hits, at `p` with geometric normal
/// `ng`, a surface of material `material` and diffuse colour `color` (base colour × texture);
/// `None` for opaque materials.
pub(super) fn cross(
    ps: &PreparedScene,
    material: u32,
    color: Vec3,
    p: Vec3,
    ng: Vec3,
    d: Vec3,
    rng: &mut Rng,
) -> Option<Crossing> {
    let model = ps.scene.translucency_of(material);
    // The side the path arrived at.
    let n = if d.dot(ng) < 0.0 { ng } else { -ng };
    match model {
        Translucency::None => None,
        Translucency::ThinDiffuseTransmission { factor, color: c } => {
            let w = ps.scene.materials[material as usize].diffuse_weight();
            let reflect = color * (w * (1.0 - factor));
            let transmit = c * (w * factor);
            let lum = |v: Vec3| v.dot(Vec3::new(0.2126, 0.7152, 0.0722));
            let (lr, lt) = (lum(reflect), lum(transmit));
            if lr + lt <= 0.0 {
                return Some(Crossing::Absorbed);
            }
            let pr = lr / (lr + lt);
            let u = rng.next_f32();
            let local = sampling::cosine_hemisphere(rng.next_2d());
            let (side, weight) = if u < pr {
                (n, reflect / pr)
            } else {
                (-n, transmit / (1.0 - pr))
            };
            Some(Crossing::Continue {
                origin: offset_ray_origin(p, side),
                dir: sampling::to_world(local, side),
                weight,
            })
        }
        Translucency::Dipole {
            sigma_s_prime,
            sigma_a,
            eta,
        } => Some(medium(
            ps,
            p,
            n,
            d,
            sigma_s_prime,
            sigma_s_prime + sigma_a,
            eta,
            rng,
        )),
    }
}

/// Refraction of the unit direction `d` through a boundary with normal `n` facing the incoming
/// side (`d·n < 0`), `ratio` = n_incident / n_transmitted; `None` on total internal reflection.
fn refract(d: Vec3, n: Vec3, ratio: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = ratio * ratio * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((ratio * d + (ratio * cos_i - (1.0 - sin2_t).sqrt()) * n).normalize())
}

/// Mirror direction of `d` about the plane of normal `n`.
fn mirror(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Uniform direction on the sphere.
fn sphere(u: glam::Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A path meeting the boundary of a medium at `p` (outside normal `n`, facing the path),
/// travelling along `d`: Fresnel reflection, or refraction and a random walk inside until it
/// leaves through the boundary.
#[allow(clippy::too_many_arguments)]
fn medium(
    ps: &PreparedScene,
    p: Vec3,
    n: Vec3,
    d: Vec3,
    sigma_s: Vec3,
    sigma_t: Vec3,
    eta: f32,
    rng: &mut Rng,
) -> Crossing {
    let cos_i = -d.dot(n);
    if rng.next_f32() < fresnel(f64::from(eta), f64::from(cos_i)) as f32 {
        return Crossing::Continue {
            origin: offset_ray_origin(p, n),
            dir: mirror(d, n),
            weight: Vec3::ONE,
        };
    }
    let Some(mut dir) = refract(d, n, 1.0 / eta) else {
        return Crossing::Absorbed; // not reached: entering a denser medium never reflects totally
    };
    let mut pos = offset_ray_origin(p, -n);
    // Distances are sampled in one colour channel, chosen once for the walk; the estimate is
    // the path's contribution over the mean of its pdfs under the three channels' sampling
    // (one-sample MIS, balance heuristic, over whole walks: per-event weights would multiply
    // into a variance that grows with the walk's length). Both are kept relative to the
    // chosen channel's pdf.
    let c = ((rng.next_f32() * 3.0) as usize).min(2);
    let (mut f, mut pdf) = (Vec3::ONE, Vec3::ONE);
    let weight = |f: Vec3, pdf: Vec3| f * (3.0 / pdf.dot(Vec3::ONE));
    for event in 0..MAX_EVENTS {
        let t = -(1.0 - rng.next_f32()).ln() / sigma_t[c];
        let hit = ps.bvh.closest_hit(&Ray::new(pos, dir, t));
        if hit.is_hit() {
            // Reached the boundary: the probability of flying that far.
            let tr = (-sigma_t * hit.t).exp();
            f *= tr;
            pdf *= tr;
            let k = pdf[c];
            if k.is_nan() || k <= 0.0 {
                return Crossing::Absorbed;
            }
            (f, pdf) = (f / k, pdf / k);
            let tri = ps.bvh.triangles[hit.tri as usize];
            let [p0, p1, p2] = tri.corners();
            let ng = (p1 - p0).cross(p2 - p0).normalize();
            let out = if ng.dot(dir) > 0.0 { ng } else { -ng };
            let q = p0 * (1.0 - hit.u - hit.v) + p1 * hit.u + p2 * hit.v;
            let cos = dir.dot(out);
            let fr = fresnel(1.0 / f64::from(eta), f64::from(cos)) as f32;
            if rng.next_f32() < fr {
                dir = mirror(dir, out);
                pos = offset_ray_origin(q, -out);
                continue;
            }
            return match refract(dir, -out, eta) {
                Some(o) => Crossing::Continue {
                    origin: offset_ray_origin(q, out),
                    dir: o,
                    weight: weight(f, pdf),
                },
                None => Crossing::Absorbed, // fr = 1 then: not reached
            };
        }
        // A scattering event at distance t.
        let tr = (-sigma_t * t).exp();
        f *= sigma_s * tr;
        pdf *= sigma_t * tr;
        let k = pdf[c];
        if k.is_nan() || k <= 0.0 {
            return Crossing::Absorbed;
        }
        (f, pdf) = (f / k, pdf / k);
        pos += dir * t;
        dir = sphere(rng.next_2d());
        if event >= WALK_RR {
            let q = weight(f, pdf).max_element().min(1.0);
            if q < 1.0 {
                if rng.next_f32() >= q {
                    return Crossing::Absorbed;
                }
                f /= q;
            }
        }
    }
    Crossing::Absorbed
}
