//! Form factors by ray casting (the "ray engine" of the 2003 GPU radiosity paper, on the CPU
//! with the path tracer's BVH), stored as a sparse CSR matrix over patches.
//!
//! Estimator: from patch i, N rays with cosine-weighted directions (a Hammersley set with a
//! per-patch Cranley–Patterson rotation: stratified in both the radial and the angular
//! coordinate) and origins uniform over the texel's covered area. A cosine-weighted direction
//! hits patch j with probability exactly F_ij, so `F_ij = hits_j / N` is unbiased; its relative
//! standard deviation is about `sqrt((1 − F_ij) / (N · F_ij))` (less with stratification).
//! Rows sum to 1 − (escaping fraction) − (lost fraction).

use glam::{Vec2, Vec3, Vec4};

use super::{RadiosityError, RadiositySettings, non_diffuse_faces};
use crate::bake::BakeScene;
use crate::bake::reference::{SplitMix64, texel_faces};
use crate::lightfield::BakeFace;
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::sampling::{cosine_hemisphere, to_world};
use crate::pathtrace::{Bvh, NONE, Ray, RtTriangle};

/// The radiosity system `L = S + ρ ⊙ (F L)` over patches, F in CSR form.
#[derive(Clone, Debug, PartialEq)]
pub struct FormFactors {
    /// Texels in the atlas (the length of a per-texel radiance array).
    pub texel_count: usize,
    /// Atlas texel of each patch (the covered texels, ascending).
    pub patch_texel: Vec<u32>,
    /// Row `i` is `columns[row_start[i]..row_start[i + 1]]` (length patches + 1).
    pub row_start: Vec<u32>,
    /// Column (patch index) of each non-zero, ascending within a row, no duplicates.
    pub columns: Vec<u32>,
    /// F_ij of each non-zero.
    pub values: Vec<f32>,
    /// Diffuse albedo ρ per patch (rgb, a = 0).
    pub albedo: Vec<[f32; 4]>,
    /// Emitted radiance E per patch (rgb, a = 0).
    pub emission: Vec<[f32; 4]>,
    /// Reflected direct light per patch: ρ ⊙ (sky · F_i,sky + sun irradiance / π) (rgb).
    pub direct: Vec<[f32; 4]>,
    /// Source term S = E + direct per patch (rgb): the right-hand side of the system.
    pub source: Vec<[f32; 4]>,
    /// Fraction of each patch's cosine-weighted rays that escape the scene (F_i,sky).
    pub sky_fraction: Vec<f32>,
    pub rays_per_patch: u32,
    /// Rays that hit a face where no covered texel lies within two texels of the hit point.
    pub lost_rays: u64,
    /// Mirror and mixed faces: radiosity used only their diffuse part (a pure mirror absorbs).
    pub non_diffuse_faces: Vec<u32>,
}

impl FormFactors {
    pub fn patches(&self) -> usize {
        self.patch_texel.len()
    }

    pub fn nonzeros(&self) -> usize {
        self.values.len()
    }

    /// Bytes held: the CSR arrays (8 bytes per non-zero + 4 per row) and the per-patch vectors.
    pub fn memory_bytes(&self) -> usize {
        self.row_start.len() * 4
            + self.columns.len() * 4
            + self.values.len() * 4
            + self.patch_texel.len() * 4
            + (self.albedo.len() + self.emission.len() + self.direct.len() + self.source.len()) * 16
            + self.sky_fraction.len() * 4
    }

    /// Row `i` as (columns, values).
    pub fn row(&self, i: usize) -> (&[u32], &[f32]) {
        let r = self.row_start[i] as usize..self.row_start[i + 1] as usize;
        (&self.columns[r.clone()], &self.values[r])
    }

    /// Σ_j F_ij.
    pub fn row_sum(&self, i: usize) -> f32 {
        self.row(i).1.iter().sum()
    }

    /// A per-patch array spread to the texel layout (uncovered texels 0).
    pub fn scatter(&self, patch_values: &[[f32; 4]]) -> Vec<[f32; 4]> {
        let mut out = vec![[0f32; 4]; self.texel_count];
        for (p, &t) in self.patch_texel.iter().enumerate() {
            out[t as usize] = patch_values[p];
        }
        out
    }
}

/// One patch's row before assembly.
#[derive(Default)]
struct Row {
    entries: Vec<(u32, f32)>,
    sky: f32,
    sun: Vec3,
    lost: u64,
}

/// Read-only data shared by the workers.
struct Ctx<'a> {
    prep: &'a BakeScene,
    bvh: Bvh,
    tex_face: Vec<u32>,
    texel_patch: Vec<u32>,
    patch_texel: &'a [u32],
    /// Per face: its triangles in chart coordinates (texel units), for the coverage test.
    charts: Vec<Vec<[Vec2; 3]>>,
    rays: u32,
    seed: u64,
}

/// Computes the form factors and source terms of every covered texel of `prep`, with constant
/// sky radiance `sky` for escaping rays (`BakeParams::sky`), the prepared scene's suns and its
/// point and spot lights (their direct light as the propagation injects it,
/// [`crate::bake::punctual`]).
/// Deterministic for a given seed, whatever the thread count.
pub fn form_factors(
    prep: &BakeScene,
    sky: Vec3,
    settings: &RadiositySettings,
) -> Result<FormFactors, RadiosityError> {
    settings.validate()?;
    let patch_texel: Vec<u32> = (0..prep.texel_count() as u32)
        .filter(|&t| prep.texel_area[t as usize] > 0.0)
        .collect();
    let mut texel_patch = vec![NONE; prep.texel_count()];
    for (p, &t) in patch_texel.iter().enumerate() {
        texel_patch[t as usize] = p as u32;
    }
    // The BVH over the prepared (VLF-space) triangles; `material` holds the face.
    let tris: Vec<RtTriangle> = (prep.triangles.iter().enumerate())
        .map(|(i, t)| RtTriangle::of_baked(i, t))
        .collect();
    let mut charts = vec![Vec::new(); prep.faces.len()];
    for t in &prep.triangles {
        let f = &prep.faces[t.face as usize];
        let (o, u, v) = (Vec3::from(f.origin), Vec3::from(f.u), Vec3::from(f.v));
        let chart = |p: [f32; 3]| {
            let d = Vec3::from(p) - o;
            Vec2::new(d.dot(u), d.dot(v)) / f.texel_size
        };
        charts[t.face as usize].push([chart(t.p0), chart(t.p1), chart(t.p2)]);
    }
    let ctx = Ctx {
        prep,
        bvh: Bvh::build(tris),
        tex_face: texel_faces(prep),
        texel_patch,
        patch_texel: &patch_texel,
        charts,
        rays: settings.rays_per_patch,
        seed: settings.seed,
    };

    // Blocks of patches handed out dynamically; each block's rows are kept with its index and
    // concatenated in order, so the result does not depend on the schedule.
    const BLOCK: usize = 64;
    let n = patch_texel.len();
    let blocks = n.div_ceil(BLOCK);
    let done: Vec<(usize, Vec<Row>)> = crate::par::map(blocks, settings.threads, 1, |b| {
        let rows = (b * BLOCK..((b + 1) * BLOCK).min(n))
            .map(|p| patch_row(&ctx, p))
            .collect();
        (b, rows)
    });

    let nonzeros: u64 = done
        .iter()
        .flat_map(|(_, rows)| rows.iter().map(|r| r.entries.len() as u64))
        .sum();
    if nonzeros > u64::from(u32::MAX) {
        return Err(RadiosityError::TooLarge {
            nonzeros,
            max: u64::from(u32::MAX),
        });
    }
    let mut ff = FormFactors {
        texel_count: prep.texel_count(),
        patch_texel: Vec::new(),
        row_start: Vec::with_capacity(n + 1),
        columns: Vec::with_capacity(nonzeros as usize),
        values: Vec::with_capacity(nonzeros as usize),
        albedo: Vec::with_capacity(n),
        emission: Vec::with_capacity(n),
        direct: Vec::with_capacity(n),
        source: Vec::with_capacity(n),
        sky_fraction: Vec::with_capacity(n),
        rays_per_patch: settings.rays_per_patch,
        lost_rays: 0,
        non_diffuse_faces: non_diffuse_faces(prep),
    };
    ff.row_start.push(0);
    // Point and spot lights: the propagation's injected direct light, per texel.
    let lamps = crate::bake::punctual::injected_irradiance(prep, settings.threads);
    for (p, row) in done.into_iter().flat_map(|(_, rows)| rows).enumerate() {
        let t = patch_texel[p] as usize;
        for (c, v) in row.entries {
            ff.columns.push(c);
            ff.values.push(v);
        }
        ff.row_start.push(ff.columns.len() as u32);
        let rho = Vec4::from(prep.albedo[t]).truncate();
        let e = Vec4::from(prep.emission[t]).truncate();
        let lamp = lamps
            .as_ref()
            .map_or(Vec3::ZERO, |l| Vec4::from(l[t]).truncate());
        let direct = rho * (sky * row.sky + (row.sun + lamp) / std::f32::consts::PI);
        ff.albedo.push(rho.extend(0.0).into());
        ff.emission.push(e.extend(0.0).into());
        ff.direct.push(direct.extend(0.0).into());
        ff.source.push((e + direct).extend(0.0).into());
        ff.sky_fraction.push(row.sky);
        ff.lost_rays += row.lost;
    }
    ff.patch_texel = patch_texel;
    Ok(ff)
}

/// Radical inverse in base 2 of `i` (the Hammersley set's second coordinate).
fn radical_inverse(i: u32) -> f32 {
    (f64::from(i.reverse_bits()) / 4_294_967_296.0) as f32
}

fn fract(x: f32) -> f32 {
    let f = x - x.floor();
    // x slightly below an integer can round up to 1.0.
    if f >= 1.0 { 0.0 } else { f }
}

fn inside(q: &[Vec2; 3], p: Vec2) -> bool {
    let d0 = (q[1] - q[0]).perp_dot(p - q[0]);
    let d1 = (q[2] - q[1]).perp_dot(p - q[1]);
    let d2 = (q[0] - q[2]).perp_dot(p - q[2]);
    (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
}

/// The row of patch `p`: hemisphere rays, sky fraction and sun irradiance.
fn patch_row(ctx: &Ctx, p: usize) -> Row {
    let prep = ctx.prep;
    let t = ctx.patch_texel[p] as usize;
    let fi = ctx.tex_face[t] as usize;
    let f = &prep.faces[fi];
    let tps = f.texels_per_side();
    let local = t as u32 - f.texel_base;
    let side = local / tps;
    let (x, y) = ((local % tps) % f.width, (local % tps) / f.width);
    let normal = if side == 0 { f.normal() } else { -f.normal() };
    let (origin, u, v, ts) = (
        Vec3::from(f.origin),
        Vec3::from(f.u),
        Vec3::from(f.v),
        f.texel_size,
    );
    let full = prep.texel_area[t] >= 0.9999 * ts * ts;
    let centroid = Vec4::from(prep.texel_center[t]).truncate();
    let chart = &ctx.charts[fi];
    // One stream per texel: the result does not depend on which thread computes the row.
    let mut rng = SplitMix64(ctx.seed ^ (t as u64 + 1).wrapping_mul(0xd1b5_4a32_d192_ed03));
    rng.next_u64();
    let rot = Vec2::new(rng.next_f32(), rng.next_f32());
    let suns: Vec<(Vec3, Vec3, f32)> = prep
        .suns
        .iter()
        .filter_map(|&(d, e)| {
            let cos = -normal.dot(d);
            (cos > 0.0).then_some((d, e, cos))
        })
        .collect();
    let mut sun_visible = vec![0u32; suns.len()];
    let mut hits: Vec<u32> = Vec::with_capacity(ctx.rays as usize);
    let mut row = Row::default();
    let mut escaped = 0u32;
    for k in 0..ctx.rays {
        // Origin: uniform over the covered part of the texel (rejection against the face's
        // triangles; the covered centroid after 16 misses, for slivers).
        let mut point = None;
        for _ in 0..16 {
            let c = Vec2::new(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
            if full || chart.iter().any(|q| inside(q, c)) {
                point = Some(origin + u * (c.x * ts) + v * (c.y * ts));
                break;
            }
        }
        let o = offset_ray_origin(point.unwrap_or(centroid), normal);
        let s = Vec2::new(
            fract((k as f32 + 0.5) / ctx.rays as f32 + rot.x),
            fract(radical_inverse(k) + rot.y),
        );
        let dir = to_world(cosine_hemisphere(s), normal);
        let hit = ctx.bvh.closest_hit(&Ray::new(o, dir, f32::INFINITY));
        if !hit.is_hit() {
            escaped += 1;
        } else {
            let g = ctx.bvh.triangles[hit.tri as usize].material as usize;
            let gf = &prep.faces[g];
            let hp = o + dir * hit.t;
            let hit_side = u32::from(dir.dot(gf.normal()) > 0.0);
            match covered_texel(prep, gf, hp, hit_side) {
                Some(texel) => hits.push(ctx.texel_patch[texel as usize]),
                None => row.lost += 1,
            }
        }
        for (j, &(d, _, _)) in suns.iter().enumerate() {
            if !ctx.bvh.occluded(&Ray::new(o, -d, f32::INFINITY)) {
                sun_visible[j] += 1;
            }
        }
    }
    let inv = 1.0 / ctx.rays as f32;
    hits.sort_unstable();
    let mut i = 0;
    while i < hits.len() {
        let mut j = i;
        while j < hits.len() && hits[j] == hits[i] {
            j += 1;
        }
        row.entries.push((hits[i], (j - i) as f32 * inv));
        i = j;
    }
    row.sky = escaped as f32 * inv;
    for (j, &(_, e, cos)) in suns.iter().enumerate() {
        row.sun += e * (cos * sun_visible[j] as f32 * inv);
    }
    row
}

/// The covered texel of face `f`, side `side`, containing plane point `p`, or the nearest
/// covered one within two texels (hits that round just outside the polygon's texels).
fn covered_texel(prep: &BakeScene, f: &BakeFace, p: Vec3, side: u32) -> Option<u32> {
    let t = f.texel_at(p, side);
    if prep.texel_area[t as usize] > 0.0 {
        return Some(t);
    }
    let d = p - Vec3::from(f.origin);
    let cx = d.dot(Vec3::from(f.u)) / f.texel_size;
    let cy = d.dot(Vec3::from(f.v)) / f.texel_size;
    let base = f.texel_base + side * f.texels_per_side();
    let mut best: Option<(f32, u32)> = None;
    let (x0, y0) = (cx.floor() as i64, cy.floor() as i64);
    for dy in -2..=2i64 {
        for dx in -2..=2i64 {
            let (xx, yy) = (x0 + dx, y0 + dy);
            if xx < 0 || yy < 0 || xx >= i64::from(f.width) || yy >= i64::from(f.height) {
                continue;
            }
            let k = base + yy as u32 * f.width + xx as u32;
            if prep.texel_area[k as usize] <= 0.0 {
                continue;
            }
            let d2 = (xx as f32 + 0.5 - cx).powi(2) + (yy as f32 + 0.5 - cy).powi(2);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, k));
            }
        }
    }
    best.map(|b| b.1)
}
