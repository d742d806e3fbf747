//! Light sources for next-event estimation: emissive triangles (chosen in proportion to their
//! power, then sampled uniformly by area) and suns (directional lights, chosen in proportion to
//! their irradiance). One light sample is taken per vertex: an emitter with probability
//! [`LightSet::p_emitters`], else a sun.

use glam::{Vec2, Vec3};

use super::geometry::RtTriangle;
use super::material::SurfaceMaterial;
use crate::scene::Scene;

/// An emissive triangle of the light list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Index of the triangle in BVH leaf order.
    pub tri: u32,
    /// Area (world units²).
    pub area: f32,
    /// Probability of choosing it among the emitters.
    pub pdf: f32,
    /// Cumulative probability up to and including it (the last is exactly 1).
    pub cdf: f32,
}

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunLight {
    /// Unit direction towards the sun.
    pub to_sun: Vec3,
    /// Irradiance at normal incidence.
    pub irradiance: Vec3,
    /// Probability of choosing it among the suns.
    pub pdf: f32,
    /// Cumulative probability.
    pub cdf: f32,
}

/// All lights NEE can sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSet {
    /// Emissive triangles with positive power.
    pub emitters: Vec<Emitter>,
    /// Suns with positive irradiance.
    pub suns: Vec<SunLight>,
    /// Probability of sampling an emitter rather than a sun (1 without suns, 0 without
    /// emitters, ½ with both).
    pub p_emitters: f32,
}

fn mean3(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

impl LightSet {
    /// Builds the light list over `triangles` (BVH leaf order) and sets each emitter
    /// triangle's `light` index (others get [`super::geometry::NONE`]).
    pub fn build(
        scene: &Scene,
        materials: &[SurfaceMaterial],
        triangles: &mut [RtTriangle],
    ) -> LightSet {
        // Mean emitted radiance of each material (texture mean included).
        let radiance: Vec<f32> = materials
            .iter()
            .map(|m| {
                let tex = m
                    .emissive_texture
                    .and_then(|t| scene.textures.get(t as usize))
                    .map_or(Vec3::ONE, |t| t.mean().truncate());
                mean3(m.emission * tex).max(0.0)
            })
            .collect();
        let mut emitters = Vec::new();
        let mut total = 0.0f64;
        for (i, t) in triangles.iter_mut().enumerate() {
            t.light = super::geometry::NONE;
            let le = radiance.get(t.material as usize).copied().unwrap_or(0.0);
            let [a, b, c] = t.corners();
            let area = 0.5 * (b - a).cross(c - a).length();
            let power = f64::from(le) * f64::from(area);
            if power > 0.0 && power.is_finite() {
                t.light = emitters.len() as u32;
                emitters.push(Emitter {
                    tri: i as u32,
                    area,
                    pdf: power as f32,
                    cdf: 0.0,
                });
                total += power;
            }
        }
        let mut acc = 0.0f64;
        for e in &mut emitters {
            acc += f64::from(e.pdf);
            e.pdf = (f64::from(e.pdf) / total) as f32;
            e.cdf = (acc / total) as f32;
        }
        if let Some(last) = emitters.last_mut() {
            last.cdf = 1.0;
        }
        let mut suns: Vec<SunLight> = scene
            .suns
            .iter()
            .filter(|s| mean3(s.irradiance) > 0.0 && s.direction.length_squared() > 0.0)
            .map(|s| SunLight {
                to_sun: -s.direction.normalize(),
                irradiance: s.irradiance,
                pdf: mean3(s.irradiance),
                cdf: 0.0,
            })
            .collect();
        let total: f32 = suns.iter().map(|s| s.pdf).sum();
        let mut acc = 0.0;
        for s in &mut suns {
            acc += s.pdf;
            s.pdf /= total;
            s.cdf = acc / total;
        }
        if let Some(last) = suns.last_mut() {
            last.cdf = 1.0;
        }
        let p_emitters = match (emitters.is_empty(), suns.is_empty()) {
            (false, false) => 0.5,
            (false, true) => 1.0,
            _ => 0.0,
        };
        LightSet {
            emitters,
            suns,
            p_emitters,
        }
    }

    /// Index of the emitter whose CDF interval holds `u` (binary search, like the WGSL code).
    pub fn pick_emitter(&self, u: f32) -> usize {
        let (mut lo, mut hi) = (0usize, self.emitters.len() - 1);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.emitters[mid].cdf > u {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo
    }

    /// The emitter whose CDF interval holds `u.x`, and `u` with `u.x` rescaled to `[0, 1)`
    /// within that interval: a stratified `u` stays stratified over all the emitters' area.
    pub fn pick_emitter_remapped(&self, u: Vec2) -> (Emitter, Vec2) {
        let i = self.pick_emitter(u.x);
        let e = self.emitters[i];
        let lo = e.cdf - e.pdf;
        let x = ((u.x - lo) / e.pdf).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        (e, Vec2::new(x, u.y))
    }

    /// Index of the sun whose CDF interval holds `u`.
    pub fn pick_sun(&self, u: f32) -> usize {
        self.suns
            .iter()
            .position(|s| s.cdf > u)
            .unwrap_or(self.suns.len() - 1)
    }

    /// Solid-angle pdf with which NEE samples the point of emitter `light` seen at distance
    /// `dist` under cosine `cos_light` (0 if it cannot be sampled).
    pub fn emitter_pdf(&self, light: u32, dist: f32, cos_light: f32) -> f32 {
        match self.emitters.get(light as usize) {
            Some(e) if cos_light > 0.0 => {
                self.p_emitters * e.pdf * dist * dist / (e.area * cos_light)
            }
            _ => 0.0,
        }
    }
}
