//! Light sources for next-event estimation: emissive triangles (chosen in proportion to their
//! power, then sampled uniformly by area) and delta lights (suns, point and spot lights: no
//! extent, one shadow ray each, chosen uniformly). One light sample is taken per vertex: an
//! emitter with probability [`LightSet::p_emitters`], else a delta light.

use glam::{Vec2, Vec3};

use super::geometry::{Ray, RtTriangle};
use super::material::SurfaceMaterial;
use crate::scene::{PunctualKind, PunctualLight, Scene, Similarity};

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

/// The kinds of [`DeltaLight`] (their values are the GPU's, `shaders/common/rt_scene.wgsl`).
pub const DELTA_SUN: u32 = 0;
pub const DELTA_POINT: u32 = 1;
pub const DELTA_SPOT: u32 = 2;

/// A light with no extent, reached by one shadow ray: a sun (directional) or a point or spot
/// light ([`crate::scene::PunctualLight`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeltaLight {
    /// [`DELTA_SUN`], [`DELTA_POINT`] or [`DELTA_SPOT`].
    pub kind: u32,
    /// Sun: the unit direction towards it; point and spot: the position.
    pub position: Vec3,
    /// Sun: irradiance at normal incidence; point and spot: radiant intensity (W/sr).
    pub intensity: Vec3,
    /// Spot: the unit axis the light points along.
    pub axis: Vec3,
    /// Spot: the falloff `clamp(cos α · cone_scale + cone_offset, 0, 1)²`
    /// ([`crate::scene::PunctualLight::cone`]); (0, 1) otherwise.
    pub cone_scale: f32,
    pub cone_offset: f32,
    /// 1 / range, or 0 for no range (the window `clamp(1 − (d/range)⁴, 0, 1)`).
    pub inv_range: f32,
    /// Probability of choosing it among the delta lights.
    pub pdf: f32,
    /// Cumulative probability.
    pub cdf: f32,
}

/// What a delta light brings to a point: the unit direction towards it, the distance (∞ for a
/// sun) and the irradiance on a surface facing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    pub wi: Vec3,
    pub dist: f32,
    pub irradiance: Vec3,
}

impl DeltaLight {
    /// A sun travelling along `direction` with irradiance `irradiance`.
    pub fn sun(direction: Vec3, irradiance: Vec3) -> DeltaLight {
        DeltaLight {
            kind: DELTA_SUN,
            position: -direction.normalize(),
            intensity: irradiance,
            axis: Vec3::ZERO,
            cone_scale: 0.0,
            cone_offset: 1.0,
            inv_range: 0.0,
            pdf: 0.0,
            cdf: 0.0,
        }
    }

    /// A point or spot light, its position and range mapped by `xf` (and its intensity scaled
    /// by `xf.scale²`, so that irradiance I/d² is unchanged): world space for
    /// [`crate::scene::Similarity::IDENTITY`].
    pub fn punctual(l: &PunctualLight, xf: &Similarity) -> DeltaLight {
        let (cone_scale, cone_offset) = l.cone();
        DeltaLight {
            kind: match l.kind {
                PunctualKind::Point => DELTA_POINT,
                PunctualKind::Spot { .. } => DELTA_SPOT,
            },
            position: xf.apply(l.position),
            intensity: l.intensity * (xf.scale * xf.scale),
            axis: l.direction.normalize(),
            cone_scale,
            cone_offset,
            inv_range: l.range.map_or(0.0, |r| 1.0 / xf.apply_length(r)),
            pdf: 0.0,
            cdf: 0.0,
        }
    }

    /// The light arriving at point `p` (before the surface's cosine and any occluder). The GPU
    /// evaluates the same expression (`delta_incident` in `shaders/common/rt_scene.wgsl`).
    pub fn incident(&self, p: Vec3) -> Incident {
        if self.kind == DELTA_SUN {
            return Incident {
                wi: self.position,
                dist: f32::INFINITY,
                irradiance: self.intensity,
            };
        }
        let none = Incident {
            wi: Vec3::Z,
            dist: 0.0,
            irradiance: Vec3::ZERO,
        };
        let to = self.position - p;
        let d2 = to.dot(to);
        if d2.is_nan() || d2 <= 0.0 {
            return none;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let t = (-wi.dot(self.axis) * self.cone_scale + self.cone_offset).clamp(0.0, 1.0);
        let x = dist * self.inv_range;
        let x2 = x * x;
        let window = (1.0 - x2 * x2).clamp(0.0, 1.0);
        let irradiance = self.intensity * (t * t * window / d2);
        if !irradiance.is_finite() {
            return none;
        }
        Incident {
            wi,
            dist,
            irradiance,
        }
    }

    /// The shadow ray from `origin` (a point offset off its surface) towards the light: to
    /// infinity along a sun's direction, the segment to a point light's position (`tmax` 1).
    pub fn shadow_ray(&self, origin: Vec3, inc: &Incident) -> Ray {
        if self.kind == DELTA_SUN {
            Ray::new(origin, inc.wi, f32::INFINITY)
        } else {
            Ray::new(origin, self.position - origin, 1.0)
        }
    }

    /// The weight with which next-event estimation picks it among the delta lights: 1 for
    /// every light (uniform, as Mitsuba picks its emitters). A light's power says little about
    /// what it brings where: a spot's narrow disc is as bright as a much stronger lamp's walls,
    /// so power-proportional picks starve it.
    fn weight(&self) -> f32 {
        if self.intensity.max_element() > 0.0 {
            1.0
        } else {
            0.0
        }
    }
}

/// All lights NEE can sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSet {
    /// Emissive triangles with positive power.
    pub emitters: Vec<Emitter>,
    /// Suns, then point and spot lights, with positive intensity.
    pub delta: Vec<DeltaLight>,
    /// Probability of sampling an emitter rather than a delta light (1 without delta lights,
    /// 0 without emitters, ½ with both).
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
        let delta = delta_lights(scene, &Similarity::IDENTITY);
        let p_emitters = match (emitters.is_empty(), delta.is_empty()) {
            (false, false) => 0.5,
            (false, true) => 1.0,
            _ => 0.0,
        };
        LightSet {
            emitters,
            delta,
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

    /// Index of the delta light whose CDF interval holds `u`.
    pub fn pick_delta(&self, u: f32) -> usize {
        self.delta
            .iter()
            .position(|s| s.cdf > u)
            .unwrap_or(self.delta.len() - 1)
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

/// The scene's suns, then its point and spot lights, mapped by `xf` (positions, ranges; the
/// intensities scaled by `xf.scale²`), those that bring no light left out, with their
/// selection probabilities ([`DeltaLight::weight`]).
pub fn delta_lights(scene: &Scene, xf: &Similarity) -> Vec<DeltaLight> {
    let suns = scene
        .suns
        .iter()
        .filter(|s| s.direction.length_squared() > 0.0)
        .map(|s| DeltaLight::sun(s.direction, s.irradiance));
    let punctual = scene.lights.iter().map(|l| DeltaLight::punctual(l, xf));
    let mut delta: Vec<DeltaLight> = suns
        .chain(punctual)
        .filter(|l| l.weight() > 0.0 && l.intensity.is_finite())
        .collect();
    let total: f32 = delta.iter().map(DeltaLight::weight).sum();
    let mut acc = 0.0;
    for l in &mut delta {
        l.pdf = l.weight() / total;
        acc += l.weight();
        l.cdf = acc / total;
    }
    if let Some(last) = delta.last_mut() {
        last.cdf = 1.0;
    }
    delta
}
