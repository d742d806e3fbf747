//! Rays through thin glass panes (`docs/GATHER.md`, `docs/TRANSMISSION.md`): a pane passes `w_pane × T(θ) ×
//! C` of the light along a ray straight through (no refraction) and reflects the rest, which
//! its mirror tiles hold. The gather's rays therefore go on through panes: a direct ray sees
//! the sky or an emitter behind a window weighted by the panes' transmittance, a shadow ray
//! (light samples, suns) is attenuated instead of stopped, and a gather ray reads what each
//! pane it crosses reflects towards it (its tiles and diffuse part) as well as the field behind
//! it.

use glam::Vec3;

use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::{Hit, PreparedScene, Ray};

/// Panes a ray passes before it gives up (its light is negligible by then).
pub const MAX_PANES: u32 = 16;

/// The first hit along a ray that is not a pane, and what the panes before it did.
pub struct Traced {
    /// The first non-pane hit (`Hit::MISS` when the ray leaves the scene).
    pub hit: Hit,
    /// The ray's direction.
    pub dir: Vec3,
    /// Distance from the ray's origin to `hit` (through the panes).
    pub t: f32,
    /// The panes' transmittance product up to `hit`.
    pub throughput: Vec3,
}

/// What pane crossing `hit` of a ray along `dir` passes straight through (rgb: `w_pane ×
/// T(θ) × C` at the hit's uv), or `None` when the hit is not on a pane.
pub fn pane_pass(ps: &PreparedScene, hit: &Hit, dir: Vec3) -> Option<Vec3> {
    let tri = &ps.bvh.triangles[hit.tri as usize];
    let m = &ps.materials[tri.material as usize];
    if m.w_pane <= 0.0 {
        return None;
    }
    let [a, b, c] = tri.corners();
    let ng = (b - a).cross(c - a).normalize();
    let pass = m.pane_transmission(ng.dot(dir));
    let uv = ps.uvs[hit.tri as usize];
    let uv = uv[0] * (1.0 - hit.u - hit.v) + uv[1] * hit.u + uv[2] * hit.v;
    let color = m.base_color
        * m.base_texture
            .and_then(|t| ps.scene.textures.get(t as usize))
            .map_or(Vec3::ONE, |t| t.bilinear(uv).truncate());
    Some(color * pass)
}

/// The point of `hit` moved off its surface to the side `dir` leaves towards.
fn beyond(ps: &PreparedScene, hit: &Hit, dir: Vec3) -> Vec3 {
    let tri = &ps.bvh.triangles[hit.tri as usize];
    let [a, b, c] = tri.corners();
    let ng = (b - a).cross(c - a).normalize();
    let p = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
    offset_ray_origin(p, if ng.dot(dir) > 0.0 { ng } else { -ng })
}

/// Follows the ray from `origin` along unit `dir` through panes to its first other hit;
/// `seen(hit, throughput)` is called at each pane crossed with the transmittance before it
/// (for what the pane itself sends back). Panes beyond [`MAX_PANES`] stop the ray (zero
/// throughput).
pub fn trace(
    ps: &PreparedScene,
    origin: Vec3,
    dir: Vec3,
    seen: &mut dyn FnMut(&Hit, Vec3),
) -> Traced {
    let mut throughput = Vec3::ONE;
    let mut ray = Ray::new(origin, dir, f32::INFINITY);
    let mut t = 0.0;
    for _ in 0..MAX_PANES {
        let hit = ps.bvh.closest_hit(&ray);
        if !hit.is_hit() {
            return Traced {
                hit,
                dir,
                t,
                throughput,
            };
        }
        let Some(pass) = pane_pass(ps, &hit, dir) else {
            return Traced {
                hit: Hit {
                    t: t + hit.t,
                    ..hit
                },
                dir,
                t: t + hit.t,
                throughput,
            };
        };
        seen(&hit, throughput);
        throughput *= pass;
        t += hit.t;
        ray = Ray::new(beyond(ps, &hit, dir), dir, f32::INFINITY);
    }
    Traced {
        hit: Hit::MISS,
        dir,
        t,
        throughput: Vec3::ZERO,
    }
}

/// What reaches `origin` from the end of the segment `origin + s·d`, s in (0, 1) (`d` not
/// normalised): 1 through nothing, the panes' transmittance product through panes only, 0 where
/// anything else blocks it.
pub fn segment_transmittance(ps: &PreparedScene, origin: Vec3, d: Vec3) -> Vec3 {
    transmittance(ps, origin, d, true)
}

/// [`segment_transmittance`] of a ray without an end (towards a sun) along unit `dir`: the
/// panes' product when it leaves the scene, else 0.
pub fn ray_transmittance(ps: &PreparedScene, origin: Vec3, dir: Vec3) -> Vec3 {
    transmittance(ps, origin, dir, false)
}

/// The one loop of [`segment_transmittance`] (`end`: the segment `origin + s·d` ends at s = 1)
/// and [`ray_transmittance`] (no end: `d` is the unit direction, used as given).
/// `shaders/common/pane_trace.wgsl`'s `transmittance_past_panes` is its port.
fn transmittance(ps: &PreparedScene, origin: Vec3, d: Vec3, end: bool) -> Vec3 {
    let tmax = if end { 1.0 } else { f32::INFINITY };
    if !ps.has_panes() {
        return if ps.bvh.occluded(&Ray::new(origin, d, tmax)) {
            Vec3::ZERO
        } else {
            Vec3::ONE
        };
    }
    let dir = if end { d.normalize() } else { d };
    let mut throughput = Vec3::ONE;
    let mut ray = Ray::new(origin, d, tmax);
    for _ in 0..MAX_PANES {
        let hit = ps.bvh.closest_hit(&ray);
        if !hit.is_hit() {
            return throughput;
        }
        let Some(pass) = pane_pass(ps, &hit, dir) else {
            return Vec3::ZERO;
        };
        throughput *= pass;
        let from = beyond(ps, &hit, dir);
        ray = if end {
            let rest = origin + d - from;
            // Past the segment's end (the pane lies within an ulp of it): done.
            if rest.dot(d) <= 0.0 {
                return throughput;
            }
            Ray::new(from, rest, 1.0)
        } else {
            Ray::new(from, dir, f32::INFINITY)
        };
    }
    Vec3::ZERO
}

impl Traced {
    /// The throughput when the ray left the scene, else 0.
    pub fn transmitted(&self) -> Vec3 {
        if self.hit.is_hit() {
            Vec3::ZERO
        } else {
            self.throughput
        }
    }
}

/// What a shadow ray towards a delta light passes ([`crate::pathtrace::DeltaLight::shadow_ray`]):
/// [`ray_transmittance`] towards a sun (no end), [`segment_transmittance`] up to a point or
/// spot light.
pub fn shadow_transmittance(ps: &PreparedScene, ray: &Ray) -> Vec3 {
    let (origin, d) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
    if ray.tmax.is_finite() {
        segment_transmittance(ps, origin, d * ray.tmax)
    } else {
        ray_transmittance(ps, origin, d)
    }
}
