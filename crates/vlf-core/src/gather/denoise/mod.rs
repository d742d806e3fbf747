//! Denoising the gathered atlas (`docs/GATHER.md`, *Denoising the atlas*): a deterministic,
//! edge-aware filter over the stored atlas, guided by what the bake knows exactly, which never
//! mixes texels across a contact, a crease or an occluder's shadow edge.
//!
//! A texel of the gathered atlas is a Monte Carlo estimate (tens of rays); on big flat walls
//! its noise shows as blotches a few texels wide. [`denoise`] replaces each texel's value by a
//! weighted mean over its *neighbours*, over a few passes:
//!
//! * **Who may be a neighbour** (fixed for all passes, [`Neighbours`]): texels of the same face
//!   side within `radius_texels` (grid distance), and texels of other faces whose lit side lies
//!   in the same plane with the same normal (within [`COPLANAR_COS`] and [`COPLANAR_TEXELS`]),
//!   within the same radius (world distance between the texels' covered centroids). Faces meet
//!   at an angle only across a crease, which so stops the filter. Both texels must be
//!   *eligible*: covered, holding an estimate (`filled`: not enclosed), and not straddling a
//!   contact (the centroid of their covered part sees each of their inset corners that lie on
//!   the face). Finally their centroids, lifted [`CONTACT_LIFT`] of a texel off the side (as
//!   [`super::field::Contacts`] lifts its segments), must see each other: a wall standing on the
//!   floor, a box's foot, a thin partition all cut the segment. Each pair's segment is traced
//!   once, from the lower texel index to the higher, so the relation is symmetric.
//! * **How much it weighs** (per pass): w = s(d) · r, with s(d) = exp(−2 d²/R²) of the distance
//!   d (texels) and the range weight r = (1 − x)² for x = ΔY² / (k² (σ²_a + σ²_b)) < 1, else 0,
//!   where ΔY is the difference of the two texels' current luminances and σ² the variances of
//!   their estimates given in `variance` (of luminance, per texel): two texels whose values
//!   differ by more than k standard errors of their difference (a shadow edge, the lit patch of
//!   a window) do not mix at all. Weights are symmetric (w_ab = w_ba), the texel itself weighs 1.
//!
//! A texel with variance 0 (an exact estimate) is kept as it is (it may still serve its
//! neighbours); ineligible texels are kept as they are and give nothing; texels without an
//! estimate (`!filled`, or uncovered) are refilled at the end by [`crate::bake::dilate_where`],
//! so the result is dilated like the gather's. Every texel is computed independently from the
//! previous pass' buffer in a fixed neighbour order, so the result is bit-identical on any
//! number of threads.

use glam::{Vec2, Vec3, Vec4};
use serde::Serialize;

use super::Grid;
use super::field::{CONTACT_LIFT, chart_coords};
use crate::lightfield::BakeFace;
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::{Bvh, Ray};
use crate::scene::{Scene, Similarity};

/// Settings of [`denoise`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DenoiseParams {
    /// Neighbourhood radius R (texels of the atlas): texels at most this far apart may mix,
    /// with spatial weight exp(−2 d²/R²).
    pub radius_texels: f32,
    /// k: how many standard errors the luminance difference of two texels may reach before they
    /// stop mixing (the range weight falls smoothly from 1 at 0 to 0 at k).
    pub sigma_k: f32,
    /// Passes of the filter (each reads the previous pass' result).
    pub passes: u32,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        Self {
            radius_texels: 3.0,
            sigma_k: 3.0,
            passes: 3,
        }
    }
}

/// What a [`denoise`] did. Powers are Σ E·area over the atlas' texels (VLF units², summed over
/// r, g, b), as [`super::GatherStats`] counts them.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DenoiseStats {
    pub texels: usize,
    /// Covered texels with an estimate (`filled`).
    pub estimated_texels: usize,
    /// Of those, texels straddling a contact (kept as they are, mixed with nothing).
    pub straddling_texels: usize,
    /// Eligible texels whose variance is 0 (kept as they are; they serve their neighbours).
    pub exact_texels: usize,
    /// Texels filtered: eligible, variance > 0, at least one neighbour.
    pub filtered_texels: usize,
    /// Mean number of neighbours of a filtered texel.
    pub mean_neighbours: f64,
    /// Neighbour pairs (each counted once), of which across two coplanar faces.
    pub pairs: usize,
    pub cross_face_pairs: usize,
    /// Candidate pairs (eligible, within the radius) whose lifted segment was blocked.
    pub occluded_pairs: usize,
    /// Visibility rays traced (the straddle test's and the pairs').
    pub rays: usize,
    /// Mean over filtered texels and passes of the neighbours' share of the total weight
    /// (Σ_b≠a w / Σ_b w): 0 = kept as is, near 1 = replaced by the neighbours' mean.
    pub mean_neighbour_weight: f64,
    /// Of the neighbour weights evaluated over all passes, the share that the range weight
    /// zeroed (differences beyond k standard errors).
    pub rejected_share: f64,
    pub power_before: f64,
    pub power_after: f64,
}

impl DenoiseStats {
    /// after / before − 1: how far the filter moved the received power.
    pub fn relative_power_change(&self) -> f64 {
        if self.power_before <= 0.0 {
            return 0.0;
        }
        self.power_after / self.power_before - 1.0
    }
}

/// Lit normals of two faces' sides are coplanar when their dot product exceeds this (0.5°)...
pub const COPLANAR_COS: f32 = 0.999_962;
/// ... and each texel's centroid lies within this many texels of the other's plane.
pub const COPLANAR_TEXELS: f32 = 0.05;

/// Texels handed to a worker at a time.
const CHUNK: usize = 256;

/// Rec. 709 luminance (what `variance` is the variance of).
pub fn luminance(e: [f32; 4]) -> f32 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// Where a texel lies: face, side, chart column and row.
#[derive(Clone, Copy)]
struct Loc {
    face: usize,
    side: u32,
    x: u32,
    y: u32,
}

/// The geometry the filter needs: every texel's location, lit normal, lifted centroid.
struct Geometry<'a> {
    grid: &'a Grid,
    bvh: &'a Bvh,
    xf: Similarity,
}

impl Geometry<'_> {
    fn loc(&self, t: usize) -> Loc {
        let face = self.grid.tex_face[t] as usize;
        let f = &self.grid.atlas.faces[face];
        let local = t as u32 - f.texel_base;
        let side = local / f.texels_per_side();
        let i = local % f.texels_per_side();
        Loc {
            face,
            side,
            x: i % f.width,
            y: i / f.width,
        }
    }

    fn face(&self, fi: usize) -> &BakeFace {
        &self.grid.atlas.faces[fi]
    }

    /// Unit normal of `side` of face `fi` (VLF and world directions agree: a similarity).
    fn lit_normal(&self, fi: usize, side: u32) -> Vec3 {
        let n = self.face(fi).normal();
        if side == 0 { n } else { -n }
    }

    /// VLF centroid of texel `t`'s covered part.
    fn centroid(&self, t: usize) -> Vec3 {
        Vec4::from(self.grid.atlas.texel_center[t]).truncate()
    }

    /// World point `p` (VLF) lifted off a side with unit normal `n`, as `Contacts` lifts.
    fn lift(&self, p: Vec3, n: Vec3) -> Vec3 {
        let w = self.xf.inverse(p);
        offset_ray_origin(
            w + n * (CONTACT_LIFT * self.grid.texel_size / self.xf.scale),
            n,
        )
    }

    /// VLF point of face `f`'s plane at chart coordinates `c` (texels).
    fn chart_point(&self, f: &BakeFace, c: Vec2) -> Vec3 {
        let c = c * f.texel_size;
        Vec3::from(f.origin) + Vec3::from(f.u) * c.x + Vec3::from(f.v) * c.y
    }

    /// Whether nothing lies between world points `a` and `b`.
    fn sees(&self, a: Vec3, b: Vec3) -> bool {
        a == b || !self.bvh.occluded(&Ray::new(a, b - a, 1.0))
    }
}

/// Same-face neighbour offsets within the radius, (0, 0) excluded, and their spatial weights.
struct Offsets {
    d: Vec<(i32, i32)>,
    w: Vec<f32>,
    /// Index of the opposite offset.
    mirror: Vec<usize>,
    words: usize,
}

impl Offsets {
    fn new(radius: f32) -> Self {
        let r = radius.max(0.0);
        let n = r.floor() as i32;
        let mut d = Vec::new();
        for dy in -n..=n {
            for dx in -n..=n {
                if (dx, dy) != (0, 0) && ((dx * dx + dy * dy) as f32) <= r * r {
                    d.push((dx, dy));
                }
            }
        }
        let w = d
            .iter()
            .map(|&(dx, dy)| spatial((dx * dx + dy * dy) as f32, r))
            .collect();
        let mirror = d
            .iter()
            .map(|&(dx, dy)| d.iter().position(|&o| o == (-dx, -dy)).unwrap())
            .collect();
        let words = d.len().div_ceil(64).max(1);
        Self {
            d,
            w,
            mirror,
            words,
        }
    }

    /// Offsets towards higher texel indices: the ones a texel traces itself.
    fn forward(&self, k: usize) -> bool {
        let (dx, dy) = self.d[k];
        dy > 0 || (dy == 0 && dx > 0)
    }
}

/// Spatial weight at squared distance `d2` (texels²) for radius `r`.
fn spatial(d2: f32, r: f32) -> f32 {
    (-2.0 * d2 / (r * r)).exp()
}

/// Range weight of a luminance difference `dy` against `s2` = k² (σ²_a + σ²_b).
fn range(dy: f32, s2: f32) -> f32 {
    if s2 <= 0.0 {
        return 0.0;
    }
    let x = dy * dy / s2;
    if x < 1.0 { (1.0 - x) * (1.0 - x) } else { 0.0 }
}

fn bit(mask: &[u64], k: usize) -> bool {
    mask[k / 64] >> (k % 64) & 1 == 1
}

/// Who may mix with whom: per texel a bit mask over [`Offsets`] (same face side) and a list of
/// (texel, spatial weight) on coplanar faces; both symmetric.
struct Neighbours {
    offsets: Offsets,
    /// `offsets.words` words per texel.
    masks: Vec<u64>,
    cross: Vec<Vec<(u32, f32)>>,
}

/// Faces whose lit side `side` lies in the plane of face `f`'s side 0 with the same normal,
/// per face, and near enough (chart rectangles within `reach`, VLF) to hold neighbours:
/// `(face, side of it whose lit normal is f's front normal)`.
fn coplanar_faces(g: &Geometry, reach: f32) -> Vec<Vec<(usize, u32)>> {
    let faces = &g.grid.atlas.faces;
    let tol = COPLANAR_TEXELS * g.grid.texel_size;
    // Canonical plane offset (normal flipped to a fixed hemisphere) to find candidates by a
    // sorted sweep.
    let canon = |f: &BakeFace| {
        let n = f.normal();
        let flip = n.x < 0.0 || (n.x == 0.0 && (n.y < 0.0 || (n.y == 0.0 && n.z < 0.0)));
        if flip { -f.offset } else { f.offset }
    };
    let bounds = |f: &BakeFace| {
        let (w, h) = (f.width as f32, f.height as f32);
        let c = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .map(|(x, y)| g.chart_point(f, Vec2::new(x, y)));
        let lo = c.iter().fold(Vec3::INFINITY, |a, &b| a.min(b));
        let hi = c.iter().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
        (lo, hi)
    };
    let boxes: Vec<(Vec3, Vec3)> = faces.iter().map(bounds).collect();
    let mut order: Vec<usize> = (0..faces.len()).collect();
    order.sort_by(|&a, &b| {
        canon(&faces[a])
            .total_cmp(&canon(&faces[b]))
            .then(a.cmp(&b))
    });
    let keys: Vec<f32> = order.iter().map(|&f| canon(&faces[f])).collect();
    faces
        .iter()
        .enumerate()
        .map(|(fi, f)| {
            let k = canon(f);
            let start = keys.partition_point(|&x| x < k - tol);
            let mut out = Vec::new();
            for &gi in order[start..]
                .iter()
                .take_while(|&&gi| canon(&faces[gi]) <= k + tol)
            {
                if gi == fi {
                    continue;
                }
                let c = f.normal().dot(faces[gi].normal());
                let side = if c > COPLANAR_COS {
                    0
                } else if c < -COPLANAR_COS {
                    1
                } else {
                    continue;
                };
                let ((alo, ahi), (blo, bhi)) = (boxes[fi], boxes[gi]);
                let gap = (blo - ahi).max(alo - bhi).max(Vec3::ZERO);
                if gap.length() <= reach {
                    out.push((gi, side));
                }
            }
            out.sort_unstable();
            out
        })
        .collect()
}

impl Neighbours {
    fn new(
        g: &Geometry,
        eligible: &[bool],
        lifted: &[Vec3],
        radius: f32,
        threads: usize,
    ) -> (Self, [usize; 3]) {
        let offsets = Offsets::new(radius);
        let atlas = &g.grid.atlas;
        let n = atlas.texel_count();
        let ts = g.grid.texel_size;
        let coplanar = coplanar_faces(g, (radius + 1.0) * ts);
        // Same face side: the forward offsets' segments, traced by the lower texel.
        let forward = crate::par::map(n, threads, CHUNK, |t| {
            let mut mask = vec![0u64; offsets.words];
            let (mut tested, mut blocked) = (0usize, 0usize);
            if eligible[t] {
                let l = g.loc(t);
                let f = g.face(l.face);
                for (k, &(dx, dy)) in offsets.d.iter().enumerate() {
                    let (x, y) = (l.x as i64 + i64::from(dx), l.y as i64 + i64::from(dy));
                    if !offsets.forward(k)
                        || x < 0
                        || y < 0
                        || x >= i64::from(f.width)
                        || y >= i64::from(f.height)
                    {
                        continue;
                    }
                    let b =
                        (t as i64 + i64::from(dy) * i64::from(f.width) + i64::from(dx)) as usize;
                    if !eligible[b] {
                        continue;
                    }
                    tested += 1;
                    if g.sees(lifted[t], lifted[b]) {
                        mask[k / 64] |= 1 << (k % 64);
                    } else {
                        blocked += 1;
                    }
                }
            }
            (mask, tested, blocked)
        });
        // The backward offsets: the neighbour's forward bit.
        let masks: Vec<u64> = crate::par::map(n, threads, CHUNK, |t| {
            let mut mask = forward[t].0.clone();
            if eligible[t] {
                let l = g.loc(t);
                let f = g.face(l.face);
                for (k, &(dx, dy)) in offsets.d.iter().enumerate() {
                    let (x, y) = (l.x as i64 + i64::from(dx), l.y as i64 + i64::from(dy));
                    if offsets.forward(k)
                        || x < 0
                        || y < 0
                        || x >= i64::from(f.width)
                        || y >= i64::from(f.height)
                    {
                        continue;
                    }
                    let b =
                        (t as i64 + i64::from(dy) * i64::from(f.width) + i64::from(dx)) as usize;
                    if bit(&forward[b].0, offsets.mirror[k]) {
                        mask[k / 64] |= 1 << (k % 64);
                    }
                }
            }
            mask
        })
        .into_iter()
        .flatten()
        .collect();
        let (mut tested, mut blocked) = forward.iter().fold((0, 0), |a, f| (a.0 + f.1, a.1 + f.2));
        drop(forward);
        // Coplanar faces: pairs towards higher texel indices, traced by the lower texel.
        let reach2 = radius * radius;
        let plane_tol = COPLANAR_TEXELS * ts;
        let up = crate::par::map(n, threads, CHUNK, |t| {
            let mut out: Vec<(u32, f32)> = Vec::new();
            let (mut tested, mut blocked) = (0usize, 0usize);
            if !eligible[t] {
                return (out, tested, blocked);
            }
            let l = g.loc(t);
            let na = g.lit_normal(l.face, l.side);
            let ca = g.centroid(t);
            for &(gi, s) in &coplanar[l.face] {
                let f = g.face(gi);
                // The side of `gi` whose lit normal is this texel's.
                let side = if l.side == 0 { s } else { 1 - s };
                let c = chart_coords(f, ca);
                let (x0, x1) = ((c.x - radius - 1.0).floor(), (c.x + radius + 1.0).ceil());
                let (y0, y1) = ((c.y - radius - 1.0).floor(), (c.y + radius + 1.0).ceil());
                let x0 = x0.max(0.0) as u32;
                let y0 = y0.max(0.0) as u32;
                let x1 = (x1.max(0.0) as u32).min(f.width);
                let y1 = (y1.max(0.0) as u32).min(f.height);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let b =
                            (f.texel_base + side * f.texels_per_side() + y * f.width + x) as usize;
                        if b <= t || !eligible[b] {
                            continue;
                        }
                        let cb = g.centroid(b);
                        let d2 = (cb - ca).length_squared() / (ts * ts);
                        if d2 > reach2
                            || na.dot(cb - ca).abs() > plane_tol
                            || g.lit_normal(gi, side).dot(ca - cb).abs() > plane_tol
                        {
                            continue;
                        }
                        tested += 1;
                        if g.sees(lifted[t], lifted[b]) {
                            out.push((b as u32, spatial(d2, radius)));
                        } else {
                            blocked += 1;
                        }
                    }
                }
            }
            (out, tested, blocked)
        });
        let mut cross: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
        let mut cross_pairs = 0;
        for (t, (list, tt, bb)) in up.into_iter().enumerate() {
            tested += tt;
            blocked += bb;
            cross_pairs += list.len();
            for (b, w) in list {
                cross[t].push((b, w));
                cross[b as usize].push((t as u32, w));
            }
        }
        (
            Self {
                offsets,
                masks,
                cross,
            },
            [tested, blocked, cross_pairs],
        )
    }

    fn mask(&self, t: usize) -> &[u64] {
        let w = self.offsets.words;
        &self.masks[t * w..(t + 1) * w]
    }

    fn count(&self, t: usize) -> usize {
        self.mask(t)
            .iter()
            .map(|m| m.count_ones() as usize)
            .sum::<usize>()
            + self.cross[t].len()
    }
}

/// Σ E·area over an atlas' texels, summed over channels.
fn power(grid: &Grid, e: &[[f32; 4]]) -> f64 {
    super::power(&grid.atlas, e)
}

/// Denoises `irradiance` (per texel of `grid`'s atlas, rgb) of `scene`, whose BVH (world
/// space) is `bvh`, given the variance of each texel's estimate (of its luminance,
/// [`luminance`]) and which texels hold an estimate (`filled`: covered and not enclosed), on
/// `threads` workers (0 = all cores). Returns the filtered atlas, dilated over the texels
/// without an estimate ([`crate::bake::dilate_where`]), and what the filter did.
#[allow(clippy::too_many_arguments)]
pub fn denoise(
    scene: &Scene,
    bvh: &Bvh,
    grid: &Grid,
    irradiance: &[[f32; 4]],
    variance: &[f32],
    filled: &[bool],
    params: &DenoiseParams,
    threads: usize,
) -> (Vec<[f32; 4]>, DenoiseStats) {
    let atlas = &grid.atlas;
    let n = atlas.texel_count();
    assert_eq!(irradiance.len(), n, "irradiance per texel of the atlas");
    assert_eq!(variance.len(), n, "variance per texel of the atlas");
    assert_eq!(filled.len(), n, "filled per texel of the atlas");
    let g = Geometry {
        grid,
        bvh,
        xf: scene.to_vlf,
    };
    let estimated: Vec<bool> = (0..n)
        .map(|t| filled[t] && atlas.texel_area[t] > 0.0)
        .collect();
    // Eligibility: an estimate, and the covered centroid sees the inset corners on the face.
    let probe = crate::par::map(n, threads, CHUNK, |t| {
        if !estimated[t] {
            return (false, Vec3::ZERO, 0);
        }
        let l = g.loc(t);
        let f = g.face(l.face);
        let nrm = g.lit_normal(l.face, l.side);
        let from = g.lift(g.centroid(t), nrm);
        let corner = Vec2::new(l.x as f32, l.y as f32);
        let mut rays = 0;
        for (a, b) in [(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)] {
            let q = corner + Vec2::new(a, b);
            if !grid.charts.inside(l.face, q) {
                continue;
            }
            rays += 1;
            if !g.sees(from, g.lift(g.chart_point(f, q), nrm)) {
                return (false, from, rays);
            }
        }
        (true, from, rays)
    });
    let eligible: Vec<bool> = probe.iter().map(|p| p.0).collect();
    let lifted: Vec<Vec3> = probe.iter().map(|p| p.1).collect();
    let mut stats = DenoiseStats {
        texels: n,
        estimated_texels: estimated.iter().filter(|e| **e).count(),
        rays: probe.iter().map(|p| p.2).sum(),
        power_before: power(grid, irradiance),
        ..Default::default()
    };
    drop(probe);
    stats.straddling_texels = stats.estimated_texels - eligible.iter().filter(|e| **e).count();
    let (nb, [tested, blocked, cross_pairs]) =
        Neighbours::new(&g, &eligible, &lifted, params.radius_texels, threads);
    stats.rays += tested;
    stats.occluded_pairs = blocked;
    stats.cross_face_pairs = cross_pairs;
    stats.pairs = tested - blocked;
    let sigma2: Vec<f32> = variance
        .iter()
        .map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 })
        .collect();
    let k2 = params.sigma_k * params.sigma_k;
    let filtered: Vec<bool> = (0..n)
        .map(|t| eligible[t] && sigma2[t] > 0.0 && nb.count(t) > 0)
        .collect();
    stats.exact_texels = (0..n).filter(|&t| eligible[t] && sigma2[t] == 0.0).count();
    stats.filtered_texels = filtered.iter().filter(|f| **f).count();
    if stats.filtered_texels > 0 {
        stats.mean_neighbours = (0..n)
            .filter(|&t| filtered[t])
            .map(|t| nb.count(t) as f64)
            .sum::<f64>()
            / stats.filtered_texels as f64;
    }
    let mut cur = irradiance.to_vec();
    let (mut share, mut evaluated, mut rejected) = (0.0f64, 0usize, 0usize);
    for _ in 0..params.passes {
        let lum: Vec<f32> = cur.iter().map(|&e| luminance(e)).collect();
        let next = crate::par::map(n, threads, CHUNK, |a| {
            if !filtered[a] {
                return (cur[a], 0.0f32, 0usize, 0usize);
            }
            let (ya, va) = (lum[a], sigma2[a]);
            let mut sum = Vec4::from(cur[a]);
            let (mut wsum, mut evaluated, mut rejected) = (1.0f32, 0usize, 0usize);
            let mut add = |b: usize, s: f32| {
                let w = s * range(ya - lum[b], k2 * (va + sigma2[b]));
                evaluated += 1;
                if w > 0.0 {
                    sum += Vec4::from(cur[b]) * w;
                    wsum += w;
                } else {
                    rejected += 1;
                }
            };
            let l = g.loc(a);
            let width = g.face(l.face).width as i64;
            let mask = nb.mask(a);
            for (k, &(dx, dy)) in nb.offsets.d.iter().enumerate() {
                if bit(mask, k) {
                    let b = (a as i64 + i64::from(dy) * width + i64::from(dx)) as usize;
                    add(b, nb.offsets.w[k]);
                }
            }
            for &(b, s) in &nb.cross[a] {
                add(b as usize, s);
            }
            let mut e: [f32; 4] = (sum / wsum).into();
            e[3] = cur[a][3];
            (e, 1.0 - 1.0 / wsum, evaluated, rejected)
        });
        for (t, (e, s, ev, rj)) in next.into_iter().enumerate() {
            cur[t] = e;
            share += f64::from(s);
            evaluated += ev;
            rejected += rj;
        }
    }
    if stats.filtered_texels > 0 && params.passes > 0 {
        stats.mean_neighbour_weight =
            share / (stats.filtered_texels as f64 * f64::from(params.passes));
    }
    if evaluated > 0 {
        stats.rejected_share = rejected as f64 / evaluated as f64;
    }
    crate::bake::dilate_where(atlas, &mut cur, &estimated);
    stats.power_after = power(grid, &cur);
    (cur, stats)
}

pub mod oidn;

#[cfg(test)]
mod tests;
