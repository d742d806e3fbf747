//! Final gather (issue 14, `docs/GATHER.md`): once propagation has converged, every texel's
//! irradiance is computed once more by backward ray tracing, into an atlas that may be finer
//! than the propagation's:
//!
//! * **direct light, sampled explicitly** at the stored atlas' resolution: area emitters
//!   (textured ones too) by samples over their surface paired with stratified points of the
//!   texel, with shadow rays; suns by shadow rays along their exact direction;
//! * **indirect light by gather rays** on a coarser grid (it varies slowly): stratified
//!   cosine-distributed rays from stratified points of the texel read the converged light field
//!   at their first hit ([`field`]: the propagation's irradiance times the hit point's albedo,
//!   the mirror tiles in the ray's direction), or the sky when they leave the scene. Emission
//!   seen by a gather ray is not counted: it is the direct part.
//!
//! Sample points lie on the texel's own face where the texel is open ([`points`]), rays start
//! a few ulps off the surface, and every texel has its own random stream, so the result does
//! not depend on the thread count. This module is the specification of the GPU gather.

pub mod denoise;
pub mod field;
pub mod points;

use glam::{Vec2, Vec3, Vec4};
use serde::Serialize;

use crate::bake::prep::BakeScene;
use crate::bake::reference::texel_faces;
use crate::directions::DirectionSet;
use crate::lightfield::{GatherParams, ParamsError, TileIndex};
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::sampling::{self, Rng};
use crate::pathtrace::{Bvh, Hit, PreparedScene, Ray};
use crate::scene::Scene;
pub use field::Charts;
use field::{Field, Tiles, chart_bilinear};
pub use points::{Openness, TexelPoints};

/// The propagated light field the gather reads.
pub struct Converged<'a> {
    /// The propagation's atlas.
    pub prep: &'a BakeScene,
    /// Its total irradiance per texel (rgb), as propagated (not dilated).
    pub irradiance: &'a [[f32; 4]],
    /// Mirror tiles and their total outgoing radiance, if the scene has non-diffuse faces.
    pub tiles: Option<(&'a TileIndex, &'a [[f32; 4]])>,
    pub directions: &'a DirectionSet,
    /// Sky radiance.
    pub sky: Vec3,
    /// Ray spacing of the propagation (VLF units): the unit of the gather's texel scales.
    pub ray_spacing: f32,
}

/// What the gather produced.
pub struct Gathered {
    /// The gathered atlas (charts of edge [`GatherParams::texel_scale`] × the ray spacing).
    pub atlas: BakeScene,
    /// Irradiance per texel of `atlas` (rgb, a = 0), direct + indirect; texels that are off
    /// their face or enclosed are filled from open neighbours.
    pub irradiance: Vec<[f32; 4]>,
    pub stats: GatherStats,
}

/// Bookkeeping of a gather (`vlf-bake bake --json`, `gather`). Powers are Σ E·area over texel
/// sides (VLF units², summed over r, g, b).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct GatherStats {
    /// Texels of the gathered atlas, covered ones, and covered ones found entirely enclosed.
    pub texels: usize,
    pub covered_texels: usize,
    pub enclosed_texels: usize,
    /// Texels of the indirect grid.
    pub indirect_texels: usize,
    pub direct_power: f64,
    pub indirect_power: f64,
    /// The same sum over the propagation's atlas (what the light field alone would store).
    pub propagated_power: f64,
}

impl GatherStats {
    /// (direct + indirect) / propagated − 1: how far the gather moved the received power.
    pub fn relative_difference(&self) -> f64 {
        if self.propagated_power <= 0.0 {
            return 0.0;
        }
        (self.direct_power + self.indirect_power) / self.propagated_power - 1.0
    }
}

/// Texels handed to a worker at a time.
const CHUNK: usize = 64;
/// Stream selectors of the per-texel random generators (`Rng::for_path(SEED, texel, stream)`;
/// the GPU gather uses the same).
pub const STREAM_INDIRECT: u32 = 1;
pub const STREAM_DIRECT: u32 = 2;
pub const SEED: u32 = 0x6a7e_5eed;

struct Gatherer<'a> {
    ps: &'a PreparedScene<'a>,
    /// The propagated light field.
    field: Field<'a>,
    sky: Vec3,
}

impl Gatherer<'_> {
    /// Radiance arriving along `dir` from the first hit `hit` (world), emission excluded (the
    /// direct part).
    fn field_radiance(&self, dir: Vec3, hit: &Hit) -> Vec3 {
        let s = self.field.surface(self.ps, dir, hit);
        self.field.diffuse(&s) + self.field.specular(&s, dir)
    }

    /// Reflected irradiance of texel `t` of the grid behind `pts` (emission and sky, the direct
    /// part, are left out), or `None` when it has no open point.
    fn indirect(&self, pts: &TexelPoints, t: usize, rays: u32) -> Option<Vec3> {
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_INDIRECT);
        let mut points = Vec::with_capacity(rays as usize);
        let n = pts.sample(t, rays, &mut rng, &mut points);
        if points.is_empty() {
            return None;
        }
        let strata = shuffled_strata(rays, &mut rng);
        let mut sum = Vec3::ZERO;
        for (k, &p) in points.iter().enumerate() {
            let u = strata.point(k, &mut rng);
            let dir = sampling::to_world(sampling::cosine_hemisphere(u), n);
            let hit =
                self.ps
                    .bvh
                    .closest_hit(&Ray::new(offset_ray_origin(p, n), dir, f32::INFINITY));
            if hit.is_hit() {
                sum += self.field_radiance(dir, &hit);
            }
        }
        Some(sum * (std::f32::consts::PI / points.len() as f32))
    }

    /// Direct irradiance of texel `t`: emitters by light samples and cosine rays combined with
    /// the power heuristic, suns by shadow rays, the sky by the cosine rays; `None` when the
    /// texel has no open point.
    fn direct(&self, pts: &TexelPoints, t: usize, gp: &GatherParams) -> Option<Vec3> {
        let lights = &self.ps.lights;
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_DIRECT);
        let count = gp.light_samples.max(gp.direct_rays).max(1);
        let mut points = Vec::with_capacity(count as usize);
        let n = pts.sample(t, count, &mut rng, &mut points);
        if points.is_empty() {
            return None;
        }
        let has_emitters = !lights.emitters.is_empty();
        let (n_l, n_b) = if has_emitters {
            (gp.light_samples, gp.direct_rays)
        } else {
            (0, gp.direct_rays)
        };
        let (fl, fb) = (n_l as f32, n_b as f32);
        let mut sum = Vec3::ZERO;
        // Light samples (stratified over the emitters' sample space, paired at random with
        // the point strata).
        let strata = shuffled_strata(n_l, &mut rng);
        for k in 0..n_l as usize {
            let p = points[spread_point(k, n_l as usize, points.len(), &mut rng)];
            let u = strata.point(k, &mut rng);
            let (e, u) = lights.pick_emitter_remapped(u);
            let tri = &self.ps.bvh.triangles[e.tri as usize];
            let [a, b, c] = tri.corners();
            let bary = sampling::triangle_barycentrics(u);
            let x = a * (1.0 - bary.x - bary.y) + b * bary.x + c * bary.y;
            let nl = (b - a).cross(c - a).normalize();
            let to = x - p;
            let d2 = to.length_squared();
            let wi = to / d2.sqrt();
            let (cos_r, cos_l) = (n.dot(wi), -wi.dot(nl));
            if cos_r <= 0.0 || cos_l <= 0.0 {
                continue;
            }
            let pdf_l = e.pdf / e.area * d2 / cos_l;
            let pdf_b = cos_r * std::f32::consts::FRAC_1_PI;
            let w = sampling::power_heuristic(fl * pdf_l, fb * pdf_b);
            let origin = offset_ray_origin(p, n);
            let target = offset_ray_origin(x, nl);
            if w > 0.0
                && !self
                    .ps
                    .bvh
                    .occluded(&Ray::new(origin, target - origin, 1.0))
            {
                let le = self.ps.emission(e.tri, bary.x, bary.y);
                sum += le * (w * cos_r / (pdf_l * fl));
            }
        }
        // Cosine rays: the sky, and emitters weighted against the light samples.
        let strata = shuffled_strata(n_b, &mut rng);
        for k in 0..n_b as usize {
            let p = points[spread_point(k, n_b as usize, points.len(), &mut rng)];
            let u = strata.point(k, &mut rng);
            let dir = sampling::to_world(sampling::cosine_hemisphere(u), n);
            let hit =
                self.ps
                    .bvh
                    .closest_hit(&Ray::new(offset_ray_origin(p, n), dir, f32::INFINITY));
            if !hit.is_hit() {
                sum += self.sky * (std::f32::consts::PI / fb);
                continue;
            }
            let tri = &self.ps.bvh.triangles[hit.tri as usize];
            if tri.light == crate::pathtrace::NONE {
                continue;
            }
            let [a, b, c] = tri.corners();
            let cos_l = -dir.dot((b - a).cross(c - a).normalize());
            if cos_l <= 0.0 {
                continue; // the back of an emitter
            }
            let pdf_b = n.dot(dir) * std::f32::consts::FRAC_1_PI;
            let pdf_l = lights.emitter_pdf(tri.light, hit.t, cos_l) / lights.p_emitters;
            let w = sampling::power_heuristic(fb * pdf_b, fl * pdf_l);
            let le = self.ps.emission(hit.tri, hit.u, hit.v);
            sum += le * (w * std::f32::consts::PI / fb);
        }
        // Suns: one shadow ray per point.
        if !lights.suns.is_empty() {
            let mut sun = Vec3::ZERO;
            for &p in &points {
                let origin = offset_ray_origin(p, n);
                for s in &lights.suns {
                    let cos = n.dot(s.to_sun);
                    if cos > 0.0
                        && !self
                            .ps
                            .bvh
                            .occluded(&Ray::new(origin, s.to_sun, f32::INFINITY))
                    {
                        sun += s.irradiance * cos;
                    }
                }
            }
            sum += sun / points.len() as f32;
        }
        Some(sum)
    }
}

/// The point that sample `k` of `n` starts from when a texel has `len` points: `k % len` when
/// the samples are as many as the points or more; otherwise a random one of the points in the
/// `k`-th of `n` equal runs of the point list (point `(k·len + j) / n`, j uniform in 0..len,
/// one draw), so that every point is equally likely and the samples stay spread over the
/// texel's strata. The points come in stratum order, so the first `n` of them would cover only
/// the first rows of the texel: a texel next to a steep source (the 1 cm emitting sides of a
/// lamp flush with the ceiling) saw it from one edge only, too bright or too dark by the edge's
/// orientation (cornell-suzanne's ceiling: 3.2× and 0.29× along two sides of its lamp;
/// `docs/GATHER.md`). The GPU gather draws the same (`spread_point` in
/// `shaders/gather_texels.wgsl`).
pub fn spread_point(k: usize, n: usize, len: usize, rng: &mut Rng) -> usize {
    if n >= len {
        return k % len;
    }
    let j = rng.next_u32() as usize % len;
    (k * len + j) / n
}

/// A g × g grid of 2-D strata over [0, 1)² in a random order (so that a texel's point strata and
/// its direction or light strata are paired at random).
struct Strata {
    g: u32,
    order: Vec<u32>,
}

/// Side g of the g × g strata that hold `count` samples: ⌈√count⌉ (1 for none), computed as
/// the CPU does it (the GPU gather is handed these values rather than taking its own root).
pub fn strata_side(count: u32) -> u32 {
    (count.max(1) as f32).sqrt().ceil() as u32
}

fn shuffled_strata(count: u32, rng: &mut Rng) -> Strata {
    let g = strata_side(count);
    let mut order: Vec<u32> = (0..g * g).collect();
    for i in (1..order.len()).rev() {
        let j = (rng.next_u32() as usize) % (i + 1);
        order.swap(i, j);
    }
    Strata { g, order }
}

impl Strata {
    /// A jittered point of the stratum paired with sample `k`.
    fn point(&self, k: usize, rng: &mut Rng) -> Vec2 {
        let s = self.order[k % self.order.len()];
        let j = rng.next_2d();
        Vec2::new((s % self.g) as f32 + j.x, (s / self.g) as f32 + j.y) / self.g as f32
    }
}

/// Σ E·area over an atlas' texels, summed over channels.
fn power(atlas: &BakeScene, irradiance: &[[f32; 4]]) -> f64 {
    irradiance
        .iter()
        .zip(&atlas.texel_area)
        .map(|(e, a)| {
            let e = Vec4::from(*e);
            (f64::from(e.x) + f64::from(e.y) + f64::from(e.z)) * f64::from(*a)
        })
        .sum()
}

/// One grid of a gather (the indirect grid or the stored atlas): its atlas, the face of every
/// texel and the faces' charts.
pub struct Grid {
    pub atlas: BakeScene,
    /// Face of every texel.
    pub tex_face: Vec<u32>,
    pub charts: Charts,
    /// Texel edge (VLF units).
    pub texel_size: f32,
}

impl Grid {
    fn new(scene: &Scene, texel_size: f32) -> Result<Grid, ParamsError> {
        let atlas = BakeScene::with_texel_size(scene, texel_size)?;
        Ok(Grid {
            tex_face: texel_faces(&atlas),
            charts: Charts::new(scene, &atlas),
            atlas,
            texel_size,
        })
    }

    /// Probes along the normal that hit anything closer than this close a sample point
    /// (world units): half a texel, the gap the atlas cannot resolve.
    pub fn r_close(&self, scene: &Scene) -> f32 {
        self.texel_size / scene.to_vlf.scale
    }

    /// The sample points of this grid's texels in the scene whose BVH is `bvh`.
    pub fn points<'a>(&'a self, scene: &Scene, bvh: &'a Bvh) -> TexelPoints<'a> {
        TexelPoints {
            atlas: &self.atlas,
            charts: &self.charts,
            open: Openness {
                bvh,
                r_close: self.r_close(scene),
            },
            xf: scene.to_vlf,
            tex_face: &self.tex_face,
        }
    }
}

/// The two grids of a gather: indirect light is estimated per texel of `indirect`, direct light
/// per texel of `direct` (the stored atlas), then [`assemble`] combines them. The CPU gather
/// ([`final_gather`]) and the GPU gather (`vlf_gpu::gather`) share everything but the texel
/// estimators.
pub struct Grids {
    pub indirect: Grid,
    pub direct: Grid,
}

impl Grids {
    pub fn new(scene: &Scene, field: &Converged, gp: &GatherParams) -> Result<Grids, ParamsError> {
        Ok(Grids {
            indirect: Grid::new(scene, gp.indirect_texel_scale * field.ray_spacing)?,
            direct: Grid::new(scene, gp.texel_scale * field.ray_spacing)?,
        })
    }
}

/// The propagation's irradiance dilated for bilinear reads: what a gather ray reads at its
/// first hit (with the hit point's albedo).
pub fn dilated_irradiance(field: &Converged) -> Vec<[f32; 4]> {
    let mut e = field.irradiance.to_vec();
    crate::bake::dilate(field.prep, &mut e);
    e
}

/// Runs the final gather over `field` on `threads` workers (0 = all cores).
pub fn final_gather(
    scene: &Scene,
    field: &Converged,
    gp: &GatherParams,
    threads: usize,
) -> Result<Gathered, ParamsError> {
    let prep = field.prep;
    let ps = PreparedScene::new(scene);
    let g = Gatherer {
        ps: &ps,
        field: Field::new(
            &ps,
            prep,
            field.irradiance,
            field
                .tiles
                .map(|(index, values)| Tiles::new(index, values, field.directions)),
        )
        .with_contacts(&ps, threads),
        sky: field.sky,
    };
    let grids = Grids::new(scene, field, gp)?;
    let pts = grids.indirect.points(scene, &g.ps.bvh);
    let ind = crate::par::map(grids.indirect.atlas.texel_count(), threads, CHUNK, |t| {
        g.indirect(&pts, t, gp.indirect_rays)
    });
    let pts = grids.direct.points(scene, &g.ps.bvh);
    let dir = crate::par::map(grids.direct.atlas.texel_count(), threads, CHUNK, |t| {
        g.direct(&pts, t, gp)
    });
    Ok(assemble(field, grids, &ind, &dir))
}

/// The gathered atlas from the texel estimates: `indirect` per texel of the indirect grid,
/// `direct` per texel of the stored atlas (`None`: no open point). The indirect grid is
/// dilated over its texels without a value and read bilinearly at each stored texel's centre;
/// the sum is dilated over the stored atlas' texels without a value.
pub fn assemble(
    field: &Converged,
    grids: Grids,
    indirect: &[Option<Vec3>],
    direct: &[Option<Vec3>],
) -> Gathered {
    let Grids {
        indirect: coarse,
        direct: Grid {
            atlas, tex_face, ..
        },
    } = grids;
    let coarse = coarse.atlas;
    let filled: Vec<bool> = indirect.iter().map(Option::is_some).collect();
    let mut e_ind: Vec<[f32; 4]> = indirect
        .iter()
        .map(|e| e.unwrap_or(Vec3::ZERO).extend(0.0).into())
        .collect();
    crate::bake::dilate_where(&coarse, &mut e_ind, &filled);
    // Direct light plus the indirect grid read at each texel.
    let dir: Vec<Option<(Vec3, Vec3)>> = direct
        .iter()
        .enumerate()
        .map(|(t, d)| {
            let direct = (*d)?;
            let fi = tex_face[t] as usize;
            let side = (t as u32 - atlas.faces[fi].texel_base) / atlas.faces[fi].texels_per_side();
            let p = Vec4::from(atlas.texel_center[t]).truncate();
            Some((direct, chart_bilinear(&coarse.faces[fi], &e_ind, side, p)))
        })
        .collect();
    let mut stats = GatherStats {
        texels: atlas.texel_count(),
        covered_texels: atlas.texel_area.iter().filter(|a| **a > 0.0).count(),
        indirect_texels: coarse.texel_count(),
        propagated_power: power(field.prep, field.irradiance),
        ..Default::default()
    };
    let filled: Vec<bool> = dir.iter().map(Option::is_some).collect();
    stats.enclosed_texels = stats.covered_texels - filled.iter().filter(|f| **f).count();
    let split = |pick: fn(&(Vec3, Vec3)) -> Vec3| -> Vec<[f32; 4]> {
        dir.iter()
            .map(|d| d.as_ref().map_or(Vec3::ZERO, pick).extend(0.0).into())
            .collect()
    };
    stats.direct_power = power(&atlas, &split(|d| d.0));
    stats.indirect_power = power(&atlas, &split(|d| d.1));
    let mut irradiance = split(|d| d.0 + d.1);
    crate::bake::dilate_where(&atlas, &mut irradiance, &filled);
    Gathered {
        atlas,
        irradiance,
        stats,
    }
}
