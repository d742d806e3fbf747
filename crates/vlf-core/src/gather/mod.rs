//! Final gather (`docs/GATHER.md`): once propagation has converged, every texel's
//! irradiance is computed once more by backward ray tracing, into an atlas that may be finer
//! than the propagation's:
//!
//! * **direct light, sampled explicitly** at the stored atlas' resolution: area emitters
//!   (textured ones too) by samples over their surface paired with stratified points of the
//!   texel, with shadow rays; suns, point and spot lights by a shadow ray from each point;
//! * **indirect light by gather rays** on a coarser grid (it varies slowly): stratified
//!   cosine-distributed rays from stratified points of the texel read the converged light field
//!   at their first hit ([`field`]: the propagation's irradiance times the hit point's albedo,
//!   the mirror tiles in the ray's direction), or the sky when they leave the scene. Emission
//!   seen by a gather ray is not counted: it is the direct part.
//!
//! Sample points lie on the texel's own face where the texel is open ([`points`]), rays start
//! a few ulps off the surface, and every texel has its own random stream, so the result does
//! not depend on the thread count. This module is the specification of the GPU gather.
//!
//! **Shading normals.** Where a texel's triangle is smooth, every sample point carries the
//! interpolated normal there ([`GatherPoint::n`]) and the irradiance is gathered about it:
//! cosine rays and the cosine of light samples, suns and the guide's cells are taken about the
//! shading normal. The rays still start on the geometric face (offset along its normal), and a
//! direction below the geometric surface brings nothing: its ray would enter the solid the
//! face bounds (the renderers that use shading normals meet the inside of the object there:
//! dark for a closed one). A flat point's shading normal is the face's own normal, and then
//! nothing changes.

pub mod denoise;
mod direct;
pub mod field;
pub mod guide;
pub mod points;
mod sampled;
mod strata;
pub mod through;

use glam::{Vec2, Vec3, Vec4};
use serde::Serialize;

use crate::bake::prep::BakeScene;
use crate::bake::reference::texel_faces;
use crate::directions::DirectionSet;
use crate::lightfield::{GatherParams, ParamsError, TileIndex};
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::sampling::{self, Rng};
use crate::pathtrace::{Bvh, Hit, PreparedScene};
use crate::scene::Scene;
pub use field::Charts;
use field::{Field, Tiles};
use guide::{Cells, Guide};
pub use points::{GatherPoint, Openness, TexelPoints};
use sampled::final_gather_sampled;
pub use sampled::{Distribution, SamplingStats};
use strata::shuffled_strata;
pub use strata::{spread_point, strata_side};

/// The propagated light field the gather reads.
pub struct Converged<'a> {
    /// The propagation's atlas.
    pub prep: &'a BakeScene,
    /// Its total irradiance per texel (rgb), as propagated (not dilated).
    pub irradiance: &'a [[f32; 4]],
    /// The first iteration's irradiance alone, when the propagation kept it (guided sampling
    /// then reads the field without it and adds its own direct light instead).
    pub first_bounce: Option<&'a [[f32; 4]]>,
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
    /// The estimated variance (luminance) of each stored texel's irradiance, when guided or
    /// adaptive sampling ran (what the denoiser weighs differences by).
    pub variance: Option<Vec<f32>>,
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
    /// How the direct light was sampled, when guided or adaptive sampling ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling: Option<SamplingStats>,
    /// What the atlas denoiser did, when it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise: Option<denoise::DenoiseStats>,
    /// What OIDN's lightmap filter did, when it ran instead (`--denoise oidn`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oidn: Option<denoise::oidn::OidnStats>,
    /// Wall-clock seconds the denoiser took (either), when one ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise_s: Option<f64>,
}

/// Why a final gather failed: its parameters, or the denoiser's library.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GatherError {
    #[error(transparent)]
    Params(#[from] ParamsError),
    #[error(transparent)]
    Oidn(#[from] denoise::oidn::OidnError),
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
/// The guided second pass of the indirect grid.
pub const STREAM_INDIRECT_GUIDED: u32 = 3;
/// Where the indirect grid's texels see the sky (the direct estimator's guide).
pub const STREAM_SKY_GUIDE: u32 = 4;
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
        for (k, &q) in points.iter().enumerate() {
            let u = strata.point(k, &mut rng);
            sum += self.gather_ray(q, n, u);
        }
        Some(sum * (std::f32::consts::PI / points.len() as f32))
    }

    /// The first pass of the guided indirect estimator: a quarter of the texel's `rays`
    /// (cosine, stratified in G × G cells, one ray a cell at the default 256), the radiance
    /// each cell's rays brought.
    fn indirect_first(&self, pts: &TexelPoints, t: usize, rays: u32) -> Option<FirstPass> {
        let n_a = (rays / 4).max(1);
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_INDIRECT);
        let mut points = Vec::with_capacity(n_a as usize);
        let n = pts.sample(t, n_a, &mut rng, &mut points);
        if points.is_empty() {
            return None;
        }
        let strata = shuffled_strata(n_a, &mut rng);
        let mut out = FirstPass {
            rays: points.len() as u32,
            radiance: Box::new([Vec3::ZERO; guide::CELLS]),
            luminance: Cells::default(),
            moments: Moments::default(),
        };
        for (k, &q) in points.iter().enumerate() {
            let u = strata.point(k, &mut rng);
            let l = self.gather_ray(q, n, u);
            out.radiance[guide::cell_of(u)] += l;
            out.luminance.add(u, luminance(l));
            out.moments.add(luminance(l) * std::f32::consts::PI);
        }
        Some(out)
    }

    /// The radiance of the field seen from point `q` (geometric normal `n`) along square point
    /// `u` about its shading normal; a ray that leaves the scene brings nothing (the sky is
    /// the direct part), nor one below the geometric surface.
    fn gather_ray(&self, q: GatherPoint, n: Vec3, u: Vec2) -> Vec3 {
        let dir = sampling::to_world(sampling::cosine_hemisphere(u), q.n);
        if below(q, n, dir) {
            return Vec3::ZERO;
        }
        // Through panes: each sends back what it reflects (`through`).
        let mut sum = Vec3::ZERO;
        let traced = through::trace(self.ps, offset_ray_origin(q.p, n), dir, &mut |h, thr| {
            sum += thr * self.field_radiance(dir, h)
        });
        if traced.hit.is_hit() {
            sum + traced.throughput * self.field_radiance(dir, &traced.hit)
        } else {
            sum
        }
    }

    /// The second pass of the guided indirect estimator for texel `t`: the rest of its `rays`,
    /// a quarter cosine and three quarters drawn from `guide` (the first passes of its
    /// neighbours, never its own, so the guide does not depend on the samples it weighs),
    /// and every ray of both passes weighted by the balance heuristic.
    fn indirect_second(
        &self,
        pts: &TexelPoints,
        t: usize,
        rays: u32,
        first: &FirstPass,
        guide: Option<&Guide>,
    ) -> IndirectTexel {
        let n_a = first.rays;
        let n_b = rays.saturating_sub(n_a).max(1);
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_INDIRECT_GUIDED);
        let mut points = Vec::with_capacity(n_b as usize);
        let n = pts.sample(t, n_b, &mut rng, &mut points);
        let n_u = if guide.is_some() {
            (n_b / 4).max(1)
        } else {
            n_b
        };
        let n_g = n_b - n_u;
        let total = (n_a + n_b) as f32;
        // Σ_k n_k p_k(u) in the unit square: cosine rays have density 1.
        let mix = |c: usize| (n_a + n_u) as f32 + guide.map_or(0.0, |g| n_g as f32 * g.density[c]);
        let mut sum = Vec3::ZERO;
        let mut moments = Moments::default();
        for (c, l) in first.radiance.iter().enumerate() {
            if first.luminance.w[c] > 0.0 || *l != Vec3::ZERO {
                let v = *l * (std::f32::consts::PI / mix(c));
                sum += v;
                moments.add(luminance(v) * total);
            }
        }
        // The first pass's rays that brought nothing count as zeros.
        for _ in moments.n..n_a {
            moments.add(0.0);
        }
        if !points.is_empty() {
            let strata = shuffled_strata(n_u, &mut rng);
            for k in 0..n_b as usize {
                let q = points[k % points.len()];
                let u = match guide {
                    Some(g) if k >= n_u as usize => {
                        let v = ((k - n_u as usize) as f32 + rng.next_f32()) / n_g as f32;
                        g.sample(v, rng.next_2d())
                    }
                    _ => strata.point(k, &mut rng),
                };
                let l = self.gather_ray(q, n, u);
                let v = l * (std::f32::consts::PI / mix(guide::cell_of(u)));
                sum += v;
                moments.add(luminance(v) * total);
            }
        }
        // Without a second pass (no open point drawn) the first pass alone, renormalised.
        let e = if points.is_empty() {
            sum * (total / n_a as f32)
        } else {
            sum
        };
        IndirectTexel {
            e,
            variance: moments.variance_of_mean(),
            rays: n_a + n_b,
        }
    }
}

/// The first pass of the guided indirect estimator at one texel: its rays, their radiance and
/// luminance per cell.
pub(super) struct FirstPass {
    rays: u32,
    radiance: Box<[Vec3; guide::CELLS]>,
    luminance: Cells,
    /// Of each ray's irradiance estimate (luminance × π: cosine rays).
    moments: Moments,
}

impl FirstPass {
    /// Whether the first pass alone will do: the standard error of its mean is at most `error`
    /// and the mean at least `expected` (a first pass that missed what the field sees there,
    /// a bright patch its few rays did not hit, says nothing of its error).
    fn enough(&self, error: f32, expected: f32) -> bool {
        let mean = (self.moments.sum / f64::from(self.moments.n.max(1))) as f32;
        error > 0.0 && self.moments.variance_of_mean().sqrt() <= error && mean >= expected
    }

    /// The first pass alone as the texel's estimate (its cosine rays' mean).
    fn alone(&self) -> IndirectTexel {
        let sum: Vec3 = self.radiance.iter().copied().sum();
        IndirectTexel {
            e: sum * (std::f32::consts::PI / self.rays as f32),
            variance: self.moments.variance_of_mean(),
            rays: self.rays,
        }
    }
}

/// A texel of the indirect grid: its irradiance, the variance of that estimate (luminance)
/// and the rays it took.
struct IndirectTexel {
    e: Vec3,
    variance: f32,
    rays: u32,
}

/// A texel of the stored atlas: its direct irradiance, the variance of that estimate
/// (luminance) and the rays it took.
pub struct DirectTexel {
    pub e: Vec3,
    pub variance: f32,
    pub rays: u32,
}

/// Whether direction `dir` from a point `q` with a shading normal of its own lies below the
/// geometric surface (unit normal `n` of the lit side): such a ray would enter the solid
/// behind the face, and brings nothing. Never for a flat point (its rays are drawn about `n`).
pub fn below(q: GatherPoint, n: Vec3, dir: Vec3) -> bool {
    q.n != n && dir.dot(n) <= 0.0
}

/// Rec. 709 luminance.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Running sums of one estimator's samples, for the variance of their mean.
#[derive(Clone, Copy, Default)]
struct Moments {
    n: u32,
    sum: f64,
    sum2: f64,
}

impl Moments {
    fn add(&mut self, x: f32) {
        self.n += 1;
        self.sum += f64::from(x);
        self.sum2 += f64::from(x) * f64::from(x);
    }

    /// The sample variance / n (0 below two samples): the variance of the samples' mean; with
    /// stratified samples an overestimate.
    fn variance_of_mean(&self) -> f32 {
        if self.n < 2 {
            return 0.0;
        }
        let n = f64::from(self.n);
        let mean = self.sum / n;
        (((self.sum2 / n - mean * mean).max(0.0)) * n / (n - 1.0) / n) as f32
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
    /// Face, side and centre (VLF) of texel `t`.
    pub fn locate(&self, t: usize) -> (usize, u32, Vec3) {
        let fi = self.tex_face[t] as usize;
        let f = &self.atlas.faces[fi];
        let side = (t as u32 - f.texel_base) / f.texels_per_side();
        (fi, side, Vec4::from(self.atlas.texel_center[t]).truncate())
    }

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
                panes: scene
                    .materials
                    .iter()
                    .map(|m| m.pane_weight() > 0.0)
                    .collect(),
                see_through: (0..scene.materials.len() as u32)
                    .map(|m| {
                        matches!(
                            scene.translucency_of(m),
                            crate::scene::Translucency::ThinDiffuseTransmission { .. }
                        )
                    })
                    .collect(),
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

/// Runs the final gather over `field` on `threads` workers (0 = all cores). Fails before
/// gathering when this build cannot run the denoiser asked for (`--denoise oidn` without the
/// `oidn` feature).
pub fn final_gather(
    scene: &Scene,
    field: &Converged,
    gp: &GatherParams,
    threads: usize,
) -> Result<Gathered, GatherError> {
    if !gp.denoise.available() {
        return Err(denoise::oidn::OidnError::NotBuilt.into());
    }
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
    if gp.sampling.is_fixed() && !gp.denoise.is_on() {
        let ind = crate::par::map(grids.indirect.atlas.texel_count(), threads, CHUNK, |t| {
            g.indirect(&pts, t, gp.indirect_rays)
        });
        let pts = grids.direct.points(scene, &g.ps.bvh);
        let dir = crate::par::map(grids.direct.atlas.texel_count(), threads, CHUNK, |t| {
            g.direct(&pts, t, gp)
        });
        return Ok(assemble(&ps, field, grids, &ind, &dir, threads));
    }
    drop(g);
    final_gather_sampled(scene, &ps, field, gp, grids, threads)
}

/// The indirect grid's estimates (`None`: no open point) as a field to read, dilated over the
/// texels without one, with the grid's `contacts`: how `assemble` reads it at the stored texels
/// and the extra indirect passes at their rays' hits.
fn indirect_field<'a>(
    ps: &'a PreparedScene<'a>,
    coarse: &'a BakeScene,
    indirect: &[Option<Vec3>],
    contacts: field::Contacts<'a>,
) -> Field<'a> {
    let filled: Vec<bool> = indirect.iter().map(Option::is_some).collect();
    let mut e: Vec<[f32; 4]> = indirect
        .iter()
        .map(|e| e.unwrap_or(Vec3::ZERO).extend(0.0).into())
        .collect();
    crate::bake::dilate_where(coarse, &mut e, &filled);
    Field {
        scene: ps.scene,
        atlas: coarse,
        irradiance: e,
        tiles: None,
        direct: None,
        contacts,
    }
}

/// The gathered atlas from the texel estimates: `indirect` per texel of the indirect grid,
/// `direct` per texel of the stored atlas (`None`: no open point). The indirect grid is
/// dilated over its texels without a value and read at each stored texel's centre bilinearly,
/// except that the read stops at contacts as the field's does ([`Field::irradiance_at`]): an
/// indirect texel is coarser than a wall is thick, and one straddling a wall's foot holds light
/// from both of its sides (a ceiling over a window wall read the sky-lit eaves). The sum is
/// dilated over the stored atlas' texels without a value. Contacts are found on `threads`
/// workers (0 = all cores).
pub fn assemble(
    ps: &PreparedScene,
    field: &Converged,
    grids: Grids,
    indirect: &[Option<Vec3>],
    direct: &[Option<Vec3>],
    threads: usize,
) -> Gathered {
    let Grids {
        indirect: coarse,
        direct: fine,
    } = grids;
    let coarse_field = indirect_field(
        ps,
        &coarse.atlas,
        indirect,
        field::Contacts::new(&ps.bvh, ps.scene, &coarse.atlas, threads),
    );
    // Direct light plus the indirect grid read at each texel: at its covered centroid where
    // the coarse quad there is clear, else at the centroid of its open part.
    let fine_pts = fine.points(ps.scene, &ps.bvh);
    let dir: Vec<Option<(Vec3, Vec3)>> = crate::par::map(direct.len(), threads, 1024, |t| {
        let direct = direct[t]?;
        let (fi, side, mut p) = fine.locate(t);
        if !coarse_field.clear_at(fi as u32, side, p)
            && let Some(w) = fine_pts.open_centroid(t)
        {
            p = ps.scene.to_vlf.apply(w);
        }
        let world = ps.scene.to_vlf.inverse(p);
        Some((
            direct,
            coarse_field.irradiance_on(fi as u32, side, p, world),
        ))
    });
    drop(coarse_field);
    let Grid { atlas, .. } = fine;
    let mut stats = GatherStats {
        texels: atlas.texel_count(),
        covered_texels: atlas.texel_area.iter().filter(|a| **a > 0.0).count(),
        indirect_texels: coarse.atlas.texel_count(),
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
        variance: None,
    }
}
