//! An unbiased reference path tracer on the CPU, following exactly the conventions of the
//! shared Mitsuba references (`shared/reference/README.md`), so that a bake can be validated
//! without any other tool.
//!
//! * **Geometry**: a binned-SAH [`Bvh`] over the scene's world-space triangles (32-byte nodes,
//!   depth-first layout, stack traversal) with the watertight ray–triangle test of Woop et al.
//!   and self-intersection-free ray origins ([`geometry`]).
//! * **Shading normals** (a triangle's [`normals`](crate::scene::Triangle::normals), flat
//!   where it has none): the BSDF is evaluated and sampled about the interpolated normal,
//!   turned to the side the ray arrived at (the geometric normal decides the side, and
//!   emission stays one-sided by winding). Rays leave from the geometric surface (offset along
//!   its normal); a direction below the geometric surface (the shading normal's hemisphere
//!   reaches under it) ends the path, and a light sample there counts nothing: the ray would
//!   enter the solid the surface bounds. `--flat-normals` (`Scene::flatten_normals`) renders
//!   every face flat, as the shared references other than lamp-room are.
//! * **Vertex colours** multiply the base colour (the Lambertian albedo and the metal's C);
//!   each texture is read with the texture coordinate set its slot names.
//! * **Pixels**: the mean radiance over the pixel square (box filter): each sample picks a
//!   uniform point of the pixel. Row 0 is the top. Pinhole camera, `yfov` vertical, aspect =
//!   width / height.
//! * **Materials**: [`material`] (Lambert / perfect mirror / GGX metal and their mix, from the
//!   metallic and roughness factors; both sides reflect alike).
//! * **Light**: emission `emissiveFactor × strength × texture` from the front (CCW) face only;
//!   constant sky radiance for escaping rays; suns give irradiance `color × intensity`; point
//!   and spot lights intensity `color × intensity` (irradiance I·cos θ/d², spot cones and
//!   ranges as [`crate::scene::PunctualLight::attenuation`]), invisible to camera and BSDF rays.
//! * **Estimator**: unidirectional path tracing with next-event estimation (one light sample per
//!   vertex: an emissive triangle chosen ∝ power and sampled by area, or a delta light — sun,
//!   point or spot, chosen uniformly — by one shadow ray, without MIS), multiple
//!   importance sampling with the power heuristic between light and BSDF sampling of emitters,
//!   cosine sampling for Lambert, GGX visible-normal sampling for rough metal, the mirror as a
//!   delta lobe, unlimited depth with Russian roulette from the fifth vertex on (unbiased).
//! * **Determinism**: every path has its own random stream seeded by (seed, pixel, sample),
//!   so images do not depend on the thread count or scheduling.
//!
//! The GPU ray engine in `vlf-gpu::raytrace` uploads the very same [`Bvh`], triangles and
//! lights and implements the same estimator in WGSL.

pub mod bvh;
pub mod geometry;
pub mod lights;
pub mod material;
pub mod sampling;
mod walk;

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec2, Vec3};

pub use bvh::{Bvh, BvhNode};
pub use geometry::{Hit, NONE, Ray, RtTriangle};
pub use lights::LightSet;
pub use material::SurfaceMaterial;
pub use sampling::Rng;

use crate::image::Image;
use crate::scene::Scene;
use geometry::offset_ray_origin;

/// Russian roulette starts after this many bounces (the path keeps at least this many).
pub const RR_DEPTH: u32 = 4;
/// Highest survival probability of Russian roulette.
pub const RR_MAX_SURVIVAL: f32 = 0.95;

/// Russian roulette on a path of throughput `beta` after `depth` bounces: whether it goes on
/// (not once its throughput is zero or not finite), `beta` divided by its survival probability.
fn survives(beta: &mut Vec3, depth: u32, rng: &mut Rng) -> bool {
    if depth >= RR_DEPTH {
        let q = beta.max_element().min(RR_MAX_SURVIVAL);
        if rng.next_f32() >= q {
            return false;
        }
        *beta /= q;
    }
    *beta != Vec3::ZERO && beta.is_finite()
}

/// Invalid render settings.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum PathTraceError {
    /// Width, height or samples per pixel is zero, or the image is too large.
    #[error("invalid render settings: {0}")]
    Settings(String),
    /// The requested camera does not exist.
    #[error("camera {index} does not exist (the scene has {count} camera(s)): {path}")]
    NoCamera {
        /// Requested index.
        index: usize,
        /// Cameras in the scene.
        count: usize,
        /// Scene file.
        path: std::path::PathBuf,
    },
    /// A look-at camera whose eye equals its target, or a field of view outside (0°, 180°).
    #[error("invalid camera: {0}")]
    Camera(String),
}

/// What to render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of the random streams.
    pub seed: u32,
    /// Constant sky radiance seen by rays that leave the scene.
    pub sky: Vec3,
    /// Worker threads (0 = all available cores).
    pub threads: usize,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 256,
            height: 256,
            spp: 64,
            seed: 0,
            sky: Vec3::ZERO,
            threads: 0,
        }
    }
}

impl RenderSettings {
    /// Checks sizes and counts.
    pub fn validate(&self) -> Result<(), PathTraceError> {
        if self.width == 0 || self.height == 0 {
            return Err(PathTraceError::Settings(format!(
                "image size {}×{} is empty",
                self.width, self.height
            )));
        }
        if u64::from(self.width) * u64::from(self.height) > 1 << 28 {
            return Err(PathTraceError::Settings(format!(
                "image size {}×{} is too large",
                self.width, self.height
            )));
        }
        if self.spp == 0 {
            return Err(PathTraceError::Settings("0 samples per pixel".into()));
        }
        if !self.sky.is_finite() || self.sky.min_element() < 0.0 {
            return Err(PathTraceError::Settings(format!(
                "sky radiance {} must be finite and non-negative",
                self.sky
            )));
        }
        Ok(())
    }
}

/// A pinhole camera (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    /// Eye position.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit right vector.
    pub right: Vec3,
    /// Unit up vector.
    pub up: Vec3,
    /// `tan(yfov / 2)`.
    pub tan_half_y: f32,
    /// Width / height of the image.
    pub aspect: f32,
}

impl PinholeCamera {
    /// Camera `index` of the scene, for an image of `width × height` (aspect = width / height,
    /// whatever the file says, as the references do).
    pub fn from_scene(
        scene: &Scene,
        index: usize,
        width: u32,
        height: u32,
    ) -> Result<Self, PathTraceError> {
        let cam = scene.cameras.get(index).ok_or(PathTraceError::NoCamera {
            index,
            count: scene.cameras.len(),
            path: scene.source.clone(),
        })?;
        if !(cam.yfov > 0.0 && cam.yfov < std::f32::consts::PI) {
            return Err(PathTraceError::Camera(format!(
                "camera {index} has yfov {} rad",
                cam.yfov
            )));
        }
        let forward = cam.forward().normalize();
        let up = cam.up().normalize();
        Ok(Self {
            position: cam.position,
            forward,
            right: forward.cross(up).normalize(),
            up,
            tan_half_y: (0.5 * cam.yfov).tan(),
            aspect: width as f32 / height as f32,
        })
    }

    /// A camera at `from` looking at `at` (+Y up unless the view is vertical, then −Z), with a
    /// vertical field of view of `yfov_deg` degrees.
    pub fn look_at(
        from: Vec3,
        at: Vec3,
        yfov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, PathTraceError> {
        let forward = (at - from).normalize_or_zero();
        if forward == Vec3::ZERO || !forward.is_finite() || !from.is_finite() {
            return Err(PathTraceError::Camera(format!(
                "look-from {from} and look-at {at} must be distinct finite points"
            )));
        }
        if !(yfov_deg > 0.0 && yfov_deg < 180.0) {
            return Err(PathTraceError::Camera(format!(
                "field of view {yfov_deg}° is outside (0°, 180°)"
            )));
        }
        let hint = if forward.cross(Vec3::Y).length() < 1e-4 {
            Vec3::NEG_Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(hint).normalize();
        Ok(Self {
            position: from,
            forward,
            right,
            up: right.cross(forward),
            tan_half_y: (0.5 * yfov_deg.to_radians()).tan(),
            aspect: width as f32 / height as f32,
        })
    }

    /// Unit direction through the image point `(px, py)` given in `[0, 1]²` (x right, y down).
    pub fn direction(&self, px: f32, py: f32) -> Vec3 {
        let sx = (2.0 * px - 1.0) * self.tan_half_y * self.aspect;
        let sy = (1.0 - 2.0 * py) * self.tan_half_y;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }
}

/// The scene prepared for path tracing: BVH, materials, per-triangle texture coordinates and
/// the light list. The GPU ray engine uploads these arrays as they are.
#[derive(Clone, Debug)]
pub struct PreparedScene<'a> {
    /// The imported scene (textures are read from it).
    pub scene: &'a Scene,
    /// Hierarchy and triangles in leaf order.
    pub bvh: Bvh,
    /// One per scene material.
    pub materials: Vec<SurfaceMaterial>,
    /// Texture coordinates of each leaf-order triangle's corners.
    pub uvs: Vec<[Vec2; 3]>,
    /// NEE lights.
    pub lights: LightSet,
}

impl<'a> PreparedScene<'a> {
    /// Builds the BVH and light list.
    pub fn new(scene: &'a Scene) -> Self {
        let materials: Vec<SurfaceMaterial> = scene
            .materials
            .iter()
            .map(SurfaceMaterial::from_scene)
            .collect();
        let tris: Vec<RtTriangle> = scene
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| RtTriangle {
                p0: t.p[0].into(),
                material: t.material,
                p1: t.p[1].into(),
                prim: i as u32,
                p2: t.p[2].into(),
                light: NONE,
            })
            .collect();
        let mut bvh = Bvh::build(tris).with_masks(std::sync::Arc::new(
            crate::lightfield::AlphaMasks::from_scene(scene),
        ));
        let lights = LightSet::build(scene, &materials, &mut bvh.triangles);
        let uvs = bvh
            .triangles
            .iter()
            .map(|t| scene.triangles[t.prim as usize].uv)
            .collect();
        Self {
            scene,
            bvh,
            materials,
            uvs,
            lights,
        }
    }

    /// Whether a material has a thin glass pane (rays may then pass surfaces).
    pub fn has_panes(&self) -> bool {
        self.materials.iter().any(|m| m.w_pane > 0.0)
    }

    fn texture(&self, index: Option<u32>, uv: Vec2) -> Vec3 {
        match index.and_then(|i| self.scene.textures.get(i as usize)) {
            Some(t) => t.bilinear(uv).truncate(),
            None => Vec3::ONE,
        }
    }

    /// Texture coordinates of set `set` of leaf-order triangle `tri` at barycentrics
    /// `(b1, b2)`.
    fn uv_at(&self, tri: u32, set: u32, b1: f32, b2: f32) -> Vec2 {
        if set == 1 {
            let t = &self.bvh.triangles[tri as usize];
            return self.scene.triangles[t.prim as usize].uv_at(1, b1, b2);
        }
        let uv = &self.uvs[tri as usize];
        uv[0] * (1.0 - b1 - b2) + uv[1] * b1 + uv[2] * b2
    }

    /// Emitted radiance of leaf-order triangle `tri` at barycentrics `(b1, b2)` (front face;
    /// none where its alpha mask leaves no surface).
    pub fn emission(&self, tri: u32, b1: f32, b2: f32) -> Vec3 {
        let t = &self.bvh.triangles[tri as usize];
        let m = &self.materials[t.material as usize];
        if m.emission == Vec3::ZERO || self.bvh.masks().cuts_at(t.prim, b1, b2) {
            return Vec3::ZERO;
        }
        m.emission
            * self.texture(
                m.emissive_texture,
                self.uv_at(tri, m.emissive_texcoord, b1, b2),
            )
    }

    /// The base colour C (factor × texture × vertex colour) of leaf-order triangle `tri` at
    /// barycentrics `(b1, b2)`.
    pub fn base_color(&self, tri: u32, b1: f32, b2: f32) -> Vec3 {
        let t = &self.bvh.triangles[tri as usize];
        let m = &self.materials[t.material as usize];
        let st = &self.scene.triangles[t.prim as usize];
        m.base_color
            * self.texture(m.base_texture, self.uv_at(tri, m.base_texcoord, b1, b2))
            * st.color_at(b1, b2)
    }

    /// The unit shading normal of leaf-order triangle `tri` at barycentrics `(b1, b2)` on the
    /// side whose unit geometric normal is `n` (`n` itself for a flat triangle).
    pub fn shading_normal(&self, tri: u32, b1: f32, b2: f32, n: Vec3) -> Vec3 {
        let t = &self.bvh.triangles[tri as usize];
        match self.scene.triangles[t.prim as usize].shading_normal_at(b1, b2) {
            Some(m) if m.dot(n) < 0.0 => -m,
            Some(m) => m,
            None => n,
        }
    }

    /// Radiance arriving at the camera along one path starting with `origin + t·dir`.
    pub fn radiance(&self, origin: Vec3, dir: Vec3, sky: Vec3, rng: &mut Rng) -> Vec3 {
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut ray = Ray::new(origin, dir, f32::INFINITY);
        let mut prev_pdf = 0.0f32;
        let mut prev_delta = true;
        let mut depth = 0u32;
        loop {
            let hit = self.bvh.closest_hit(&ray);
            let d = Vec3::from(ray.dir);
            if !hit.is_hit() {
                l += beta * sky;
                break;
            }
            let tri = self.bvh.triangles[hit.tri as usize];
            let [p0, p1, p2] = tri.corners();
            let ng = (p1 - p0).cross(p2 - p0).normalize();
            let cos_d = d.dot(ng);
            let front = cos_d < 0.0;
            let m = &self.materials[tri.material as usize];
            // Emission (front face), MIS-weighted against light sampling.
            if front && m.emission != Vec3::ZERO {
                let le = self.emission(hit.tri, hit.u, hit.v);
                let w = if prev_delta {
                    1.0
                } else {
                    let pdf_light = self.lights.emitter_pdf(tri.light, hit.t, -cos_d);
                    sampling::power_heuristic(prev_pdf, pdf_light)
                };
                l += beta * le * w;
            }
            let ng = if front { ng } else { -ng };
            let n = self.shading_normal(hit.tri, hit.u, hit.v, ng);
            let wo = -d;
            let p = p0 * (1.0 - hit.u - hit.v) + p1 * hit.u + p2 * hit.v;
            let color = self.base_color(hit.tri, hit.u, hit.v);
            // Translucent surfaces (`walk`): transmission or a random walk inside.
            if let Some(x) = walk::cross(self, tri.material, color, p, ng, d, rng) {
                let walk::Crossing::Continue {
                    origin,
                    dir,
                    weight,
                } = x
                else {
                    break;
                };
                beta *= weight;
                if !survives(&mut beta, depth, rng) {
                    break;
                }
                depth += 1;
                prev_delta = true;
                ray = Ray::new(origin, dir, f32::INFINITY);
                continue;
            }
            let origin = offset_ray_origin(p, ng);
            // Next-event estimation: one light sample.
            let u_class = rng.next_f32();
            let u_light = rng.next_f32();
            let u_point = rng.next_2d();
            if m.has_smooth_part() {
                let at = Vertex { p, n, ng, origin };
                l += beta * self.sample_light(m, color, &at, wo, u_class, u_light, u_point);
            }
            // Continue the path.
            let u_lobe = rng.next_f32();
            let u_dir = rng.next_2d();
            let Some(s) = material::sample(m, color, n, wo, u_lobe, u_dir) else {
                break;
            };
            // Below the geometric surface (a smooth vertex only): into the solid.
            if n != ng && s.wi.dot(ng) <= 0.0 {
                break;
            }
            beta *= s.weight;
            // Through a pane the path goes on from the surface's other side.
            let origin = if s.transmitted {
                offset_ray_origin(p, -n)
            } else {
                origin
            };
            if !survives(&mut beta, depth, rng) {
                break;
            }
            depth += 1;
            prev_pdf = s.pdf;
            prev_delta = s.delta;
            ray = Ray::new(origin, s.wi, f32::INFINITY);
        }
        l
    }

    /// One NEE sample at vertex `at` (MIS-weighted against BSDF sampling), unoccluded
    /// contribution already tested; to be multiplied by the path throughput.
    #[allow(clippy::too_many_arguments)]
    fn sample_light(
        &self,
        m: &SurfaceMaterial,
        color: Vec3,
        at: &Vertex,
        wo: Vec3,
        u_class: f32,
        u_light: f32,
        u_point: Vec2,
    ) -> Vec3 {
        let Vertex { p, n, ng, origin } = *at;
        // A direction below the geometric surface (smooth vertices only) brings nothing.
        let below = |wi: Vec3| n != ng && wi.dot(ng) <= 0.0;
        let lights = &self.lights;
        if u_class < lights.p_emitters {
            let e = lights.emitters[lights.pick_emitter(u_light)];
            let t = &self.bvh.triangles[e.tri as usize];
            let [a, b, c] = t.corners();
            let bary = sampling::triangle_barycentrics(u_point);
            let x = a * (1.0 - bary.x - bary.y) + b * bary.x + c * bary.y;
            let nl = (b - a).cross(c - a).normalize();
            let to = x - p;
            let dist2 = to.length_squared();
            let dist = dist2.sqrt();
            let wi = to / dist;
            let cos_l = -wi.dot(nl);
            if cos_l <= 0.0 || n.dot(wi) <= 0.0 || below(wi) {
                return Vec3::ZERO;
            }
            let (f, pdf_bsdf) = material::eval(m, color, n, wo, wi);
            if f == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let pdf_light = lights.p_emitters * e.pdf * dist2 / (e.area * cos_l);
            let le = self.emission(e.tri, bary.x, bary.y);
            let contrib =
                f * le * (n.dot(wi) * sampling::power_heuristic(pdf_light, pdf_bsdf) / pdf_light);
            if contrib == Vec3::ZERO {
                return Vec3::ZERO;
            }
            // Move the light point off the emitter, towards `p` (its front side).
            let target = offset_ray_origin(x, nl);
            let shadow = Ray::new(origin, target - origin, 1.0);
            if self.bvh.occluded(&shadow) {
                Vec3::ZERO
            } else {
                contrib
            }
        } else if !lights.delta.is_empty() {
            // A delta light (sun, point or spot): no MIS, BSDF sampling never hits it.
            let s = lights.delta[lights.pick_delta(u_light)];
            let inc = s.incident(p);
            let cos_i = n.dot(inc.wi);
            if cos_i <= 0.0 || below(inc.wi) {
                return Vec3::ZERO;
            }
            let (f, _) = material::eval(m, color, n, wo, inc.wi);
            let contrib = f * inc.irradiance * (cos_i / ((1.0 - lights.p_emitters) * s.pdf));
            if contrib == Vec3::ZERO {
                return Vec3::ZERO;
            }
            // A delta light reaches through panes (no path could find it otherwise: a delta
            // light behind a delta transmission); emitters' light reaches through them by BSDF
            // sampling only, so their shadow rays stop at a pane.
            contrib * self.shadow_transmittance(&s.shadow_ray(origin, &inc))
        } else {
            Vec3::ZERO
        }
    }

    /// What of a delta light's light reaches the origin of its shadow `ray` (towards a sun: no
    /// end; to a point or spot light: `tmax` 1 with the light at `origin + dir`): 1 through
    /// nothing, the product of the panes' `w_pane × T(θ) × C` through panes only, 0 where
    /// anything else blocks it (at most 16 panes).
    pub fn shadow_transmittance(&self, ray: &Ray) -> Vec3 {
        let d = Vec3::from(ray.dir);
        let wi = d.normalize();
        let end = ray
            .tmax
            .is_finite()
            .then(|| Vec3::from(ray.origin) + d * ray.tmax);
        let mut t = Vec3::ONE;
        let mut ray = *ray;
        for _ in 0..16 {
            let hit = self.bvh.closest_hit(&ray);
            if !hit.is_hit() {
                return t;
            }
            let tri = self.bvh.triangles[hit.tri as usize];
            let m = &self.materials[tri.material as usize];
            let [p0, p1, p2] = tri.corners();
            let ng = (p1 - p0).cross(p2 - p0).normalize();
            let pass = m.pane_transmission(ng.dot(wi));
            if pass <= 0.0 {
                return Vec3::ZERO;
            }
            let uv = self.uv_at(hit.tri, m.base_texcoord, hit.u, hit.v);
            t *= m.base_color * self.texture(m.base_texture, uv) * pass;
            let p = p0 * (1.0 - hit.u - hit.v) + p1 * hit.u + p2 * hit.v;
            let from = offset_ray_origin(p, if ng.dot(wi) > 0.0 { ng } else { -ng });
            ray = match end {
                Some(end) => {
                    let rest = end - from;
                    // Past the segment's end (the pane lies within an ulp of it): done.
                    if rest.dot(d) <= 0.0 {
                        return t;
                    }
                    Ray::new(from, rest, 1.0)
                }
                None => Ray::new(from, wi, f32::INFINITY),
            };
        }
        Vec3::ZERO
    }
}

/// A path vertex: its point, shading normal `n` and geometric normal `ng` (both on the side
/// the path arrived at), and the offset origin of rays leaving it.
#[derive(Clone, Copy)]
struct Vertex {
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    origin: Vec3,
}

/// Side of a render tile in pixels (the unit of work handed to threads).
const TILE: u32 = 16;

/// Renders the mean radiance of every pixel with `settings.spp` samples, on
/// `settings.threads` threads. `progress(done, total)` is called (from worker threads) after
/// each finished tile, in samples.
pub fn render(
    prep: &PreparedScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Image, PathTraceError> {
    settings.validate()?;
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles = tiles_x * h.div_ceil(TILE);
    let done = AtomicU64::new(0);
    let total = u64::from(w) * u64::from(h) * u64::from(settings.spp);
    // Tiles on the worker pool; each returns its pixels, written in place afterwards (the
    // image does not depend on which worker rendered which tile).
    let rendered = crate::par::map(tiles as usize, settings.threads, 1, |tile| {
        let tile = tile as u32;
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
        let mut buf = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                buf.push(render_pixel(prep, camera, settings, x, y));
            }
        }
        let n = u64::from((x1 - x0) * (y1 - y0)) * u64::from(settings.spp);
        progress(done.fetch_add(n, Ordering::Relaxed) + n, total);
        buf
    });
    let mut image = Image::new(w, h, [0.0; 3]);
    for (tile, buf) in rendered.into_iter().enumerate() {
        let tile = tile as u32;
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
        let mut k = 0;
        for y in y0..y1 {
            for x in x0..x1 {
                image.pixels[(y * w + x) as usize] = buf[k];
                k += 1;
            }
        }
    }
    Ok(image)
}

/// Mean of `settings.spp` samples of pixel `(x, y)`.
pub fn render_pixel(
    prep: &PreparedScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    x: u32,
    y: u32,
) -> [f32; 3] {
    let (w, h) = (settings.width, settings.height);
    let pixel = y * w + x;
    let mut sum = [0.0f64; 3];
    for s in 0..settings.spp {
        let mut rng = Rng::for_path(settings.seed, pixel, s);
        let j = rng.next_2d();
        let dir = camera.direction((x as f32 + j.x) / w as f32, (y as f32 + j.y) / h as f32);
        let l = prep.radiance(camera.position, dir, settings.sky, &mut rng);
        if l.is_finite() {
            for c in 0..3 {
                sum[c] += f64::from(l[c]);
            }
        }
    }
    sum.map(|v| (v / f64::from(settings.spp)) as f32)
}
