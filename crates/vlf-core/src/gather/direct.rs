//! The stored atlas' direct light: where the indirect grid's texels see the sky (the guide's
//! mask), and each texel's estimator by rounds of light samples, cosine and guided rays and
//! shadow rays of delta lights (`docs/GATHER.md`, *Guided rays* and *Rays where the noise is*).

use glam::{Vec2, Vec3};

use super::{
    DirectTexel, GatherPoint, Gatherer, Moments, SEED, STREAM_DIRECT, STREAM_SKY_GUIDE,
    TexelPoints, below, guide, luminance, shuffled_strata, spread_point, through,
};
use crate::lightfield::GatherParams;
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::sampling::{self, Rng};

/// Rays of a guided texel's direct estimator that must have found light before its estimated
/// error may stop it (a round in which every ray missed the opening estimates no spread).
const MIN_FOUND: u32 = 4;
impl Gatherer<'_> {
    /// Where texel `t` sees the sky ([`guide::SkyMask`]), by occlusion rays in two steps:
    /// `rays` stratified cosine rays over the [`guide::G`]-cell grid, then, unless every one
    /// of them left the scene, one ray in each [`guide::SKY_G`]-cell quarter of the cells
    /// that saw the sky and of their four neighbours (φ wraps round), where an opening's rim
    /// lies. `None` without an open point or a ray that left.
    pub(super) fn sky_mask(
        &self,
        pts: &TexelPoints,
        t: usize,
        rays: u32,
    ) -> Option<guide::SkyMask> {
        use guide::{G, SKY_G};
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_SKY_GUIDE);
        let mut points = Vec::with_capacity(rays as usize);
        let n = pts.sample(t, rays, &mut rng, &mut points);
        let cells = (SKY_G * SKY_G) as usize;
        let (mut hits, mut sent) = (vec![0u32; cells], vec![0u32; cells]);
        let mut lit = [false; guide::CELLS];
        let cast = |q: GatherPoint, u: Vec2, hits: &mut [u32], sent: &mut [u32]| {
            let c = guide::cell_in(u, SKY_G);
            sent[c] += 1;
            let dir = sampling::to_world(sampling::cosine_hemisphere(u), q.n);
            let open = !below(q, n, dir)
                && through::ray_transmittance(self.ps, offset_ray_origin(q.p, n), dir)
                    != Vec3::ZERO;
            hits[c] += u32::from(open);
            open
        };
        let strata = shuffled_strata(rays, &mut rng);
        for (k, &q) in points.iter().enumerate() {
            let u = strata.point(k, &mut rng);
            if cast(q, u, &mut hits, &mut sent) {
                lit[guide::cell_of(u)] = true;
            }
        }
        let lit_count = lit.iter().filter(|&&l| l).count();
        if lit_count == 0 {
            return None;
        }
        if lit_count < guide::CELLS {
            let near = |c: usize| lit[c] || guide::neighbours(c, G).any(|k| lit[k]);
            let refine: Vec<usize> = (0..guide::CELLS).filter(|&c| near(c)).collect();
            let mut more = Vec::with_capacity(refine.len() * 4);
            pts.sample(t, refine.len() as u32 * 4, &mut rng, &mut more);
            if !more.is_empty() {
                for (k, &c) in refine.iter().enumerate() {
                    let (x, y) = (c as u32 % G, c as u32 / G);
                    for s in 0..4u32 {
                        let corner = Vec2::new((2 * x + s % 2) as f32, (2 * y + s / 2) as f32);
                        let u =
                            ((corner + rng.next_2d()) / SKY_G as f32).min(Vec2::splat(0.999_999_9));
                        let q = more[(4 * k + s as usize) % more.len()];
                        cast(q, u, &mut hits, &mut sent);
                    }
                }
            }
        }
        // A refined cell's quarters hold their own rays' share; any other cell's share (its
        // one stratified ray) holds for all four of its quarters.
        let mut w = vec![0.0f32; cells];
        for c in 0..guide::CELLS as u32 {
            let (x, y) = (c % G, c / G);
            let quarters = (0..4u32).map(|s| ((2 * y + s / 2) * SKY_G + 2 * x + s % 2) as usize);
            let (h, n, refined) = quarters.clone().fold((0, 0, true), |(h, n, r), f| {
                (h + hits[f], n + sent[f], r && sent[f] > 0)
            });
            for f in quarters {
                w[f] = if refined {
                    hits[f] as f32 / sent[f] as f32
                } else if n > 0 {
                    h as f32 / n as f32
                } else {
                    0.0
                };
            }
        }
        Some(guide::SkyMask { w })
    }

    /// Direct irradiance of texel `t`: emitters by light samples and cosine rays combined with
    /// the power heuristic, suns, point and spot lights by shadow rays, the sky by the cosine rays; `None` when the
    /// texel has no open point.
    pub(super) fn direct(&self, pts: &TexelPoints, t: usize, gp: &GatherParams) -> Option<Vec3> {
        self.direct_texel(pts, t, gp, None, 0.0).map(|d| d.e)
    }

    /// [`Gatherer::direct`] by rounds of `light_samples` + `direct_rays` samples, with three
    /// quarters of the rays drawn from each round's guide when there is one
    /// (`gp.sampling.guided`: [`guide::round_guide`] of `sky`, the blended sky mask of the
    /// indirect grid round the texel), until the estimated standard error is below
    /// `gp.sampling.target_error` × (the estimate + `floor`, the texel's indirect light) and,
    /// where the mask says the texel sees the sky, its rays found light [`MIN_FOUND`] times;
    /// or `max_rounds` rounds ran. Each round is an unbiased estimate under its own guide;
    /// the texel's value is their mean.
    pub(super) fn direct_texel(
        &self,
        pts: &TexelPoints,
        t: usize,
        gp: &GatherParams,
        sky: Option<&[f32]>,
        floor: f32,
    ) -> Option<DirectTexel> {
        let lights = &self.ps.lights;
        let mut rng = Rng::for_path(SEED, t as u32, STREAM_DIRECT);
        let count = gp.light_samples.max(gp.direct_rays).max(1);
        let mut points = Vec::with_capacity(count as usize);
        let has_emitters = !lights.emitters.is_empty();
        let (n_l, n_b) = if has_emitters {
            (gp.light_samples, gp.direct_rays)
        } else {
            (0, gp.direct_rays)
        };
        // Guided: each round's guide is the indirect grid's sky mask and where this texel's
        // own rays of the rounds before found light.
        let learn = gp.sampling.guided && n_b >= 2;
        let mut own = if learn {
            vec![0.0f32; guide::SKY_CELLS]
        } else {
            Vec::new()
        };
        let (fl, fb) = (n_l as f32, n_b as f32);
        let s = &gp.sampling;
        let max_rounds = if s.target_error > 0.0 {
            s.max_rounds.max(1)
        } else {
            1
        };
        let (mut total, mut rounds, mut rays, mut found) = (Vec3::ZERO, 0u32, 0u32, 0u32);
        let (mut m_l, mut m_b, mut m_s) =
            (Moments::default(), Moments::default(), Moments::default());
        while rounds < max_rounds {
            let guide = if learn {
                guide::round_guide(sky, &own)
            } else {
                None
            };
            let guide = guide.as_ref();
            // Cosine rays first, then the guided ones.
            let n_u = if guide.is_some() {
                (n_b / 4).max(1)
            } else {
                n_b
            };
            points.clear();
            let n = pts.sample(t, count, &mut rng, &mut points);
            if points.is_empty() {
                if rounds == 0 {
                    return None;
                }
                break;
            }
            let mut sum = Vec3::ZERO;
            // Light samples (stratified over the emitters' sample space, paired at random with
            // the point strata).
            let strata = shuffled_strata(n_l, &mut rng);
            for k in 0..n_l as usize {
                let q = points[spread_point(k, n_l as usize, points.len(), &mut rng)];
                let p = q.p;
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
                let (cos_r, cos_l) = (q.n.dot(wi), -wi.dot(nl));
                let mut value = Vec3::ZERO;
                if cos_r > 0.0 && cos_l > 0.0 && !below(q, n, wi) {
                    let pdf_l = e.pdf / e.area * d2 / cos_l;
                    let m = guide::mixture(guide, n_u, n_b, guide::square_of(wi, q.n));
                    let pdf_b = m * cos_r * std::f32::consts::FRAC_1_PI;
                    let w = sampling::power_heuristic(fl * pdf_l, fb * pdf_b);
                    let origin = offset_ray_origin(p, n);
                    let target = offset_ray_origin(x, nl);
                    // Through panes, attenuated.
                    let pass = if w > 0.0 {
                        through::segment_transmittance(self.ps, origin, target - origin)
                    } else {
                        Vec3::ZERO
                    };
                    if pass != Vec3::ZERO {
                        let le = self.ps.emission(e.tri, bary.x, bary.y);
                        value = le * (w * cos_r / (pdf_l * fl)) * pass;
                    }
                }
                sum += value;
                m_l.add(luminance(value) * fl);
            }
            // Cosine rays (the first `n_u`) and guided ones: the sky, and emitters weighted
            // against the light samples.
            let strata = shuffled_strata(n_u, &mut rng);
            for k in 0..n_b as usize {
                let q = points[spread_point(k, n_b as usize, points.len(), &mut rng)];
                let u = match guide {
                    Some(g) if k >= n_u as usize => {
                        let v = ((k - n_u as usize) as f32 + rng.next_f32()) / (n_b - n_u) as f32;
                        g.sample(v, rng.next_2d())
                    }
                    _ => strata.point(k, &mut rng),
                };
                let m = guide::mixture(guide, n_u, n_b, u);
                let value = self.direct_ray(q, n, u, m, fl, fb);
                sum += value;
                m_b.add(luminance(value) * fb);
                if value != Vec3::ZERO {
                    found += 1;
                    if learn {
                        own[guide::cell_in(u, guide::SKY_G)] += 1.0;
                    }
                }
            }
            rays += n_l + n_b;
            // Delta lights (suns, point and spot lights): one shadow ray per point and light.
            if !lights.delta.is_empty() {
                let mut sun = Vec3::ZERO;
                for &q in &points {
                    let origin = offset_ray_origin(q.p, n);
                    let mut value = Vec3::ZERO;
                    for s in &lights.delta {
                        let inc = s.incident(q.p);
                        let cos = q.n.dot(inc.wi);
                        if cos > 0.0 && !below(q, n, inc.wi) {
                            let pass =
                                through::shadow_transmittance(self.ps, &s.shadow_ray(origin, &inc));
                            if pass != Vec3::ZERO {
                                value += inc.irradiance * cos * pass;
                            }
                        }
                    }
                    sun += value;
                    m_s.add(luminance(value));
                }
                rays += (points.len() * lights.delta.len()) as u32;
                sum += sun / points.len() as f32;
            }
            total += sum;
            rounds += 1;
            if rounds < max_rounds {
                let se = (m_l.variance_of_mean() + m_b.variance_of_mean() + m_s.variance_of_mean())
                    .sqrt();
                let value = luminance(total / rounds as f32) + floor;
                // Rays that found nothing measure no spread: a texel whose guide says it sees
                // the sky does not stop before its rays found light a few times.
                let evidence = sky.is_none() || found >= MIN_FOUND;
                if evidence && se <= s.target_error * value {
                    break;
                }
            }
        }
        Some(DirectTexel {
            e: total / rounds as f32,
            variance: m_l.variance_of_mean() + m_b.variance_of_mean() + m_s.variance_of_mean(),
            rays,
        })
    }

    /// What one ray of the direct estimator from point `q` (geometric normal `n`) at square
    /// point `u` about its shading normal adds: the sky if it leaves the scene, an emitter's
    /// front weighted against the light samples, with the rays' density `m` relative to cosine
    /// sampling; nothing below the geometric surface.
    fn direct_ray(&self, q: GatherPoint, n: Vec3, u: Vec2, m: f32, fl: f32, fb: f32) -> Vec3 {
        let lights = &self.ps.lights;
        let dir = sampling::to_world(sampling::cosine_hemisphere(u), q.n);
        if below(q, n, dir) {
            return Vec3::ZERO;
        }
        // Through panes, attenuated (`hit.t` the whole distance, for the light samples' pdf).
        let traced = through::trace(self.ps, offset_ray_origin(q.p, n), dir, &mut |_, _| {});
        let (hit, pass) = (traced.hit, traced.throughput);
        if !hit.is_hit() {
            return self.sky * (std::f32::consts::PI / (fb * m)) * pass;
        }
        let tri = &self.ps.bvh.triangles[hit.tri as usize];
        if tri.light == crate::pathtrace::NONE {
            return Vec3::ZERO;
        }
        let [a, b, c] = tri.corners();
        let cos_l = -dir.dot((b - a).cross(c - a).normalize());
        if cos_l <= 0.0 {
            return Vec3::ZERO; // the back of an emitter
        }
        let pdf_b = m * q.n.dot(dir) * std::f32::consts::FRAC_1_PI;
        let pdf_l = lights.emitter_pdf(tri.light, hit.t, cos_l) / lights.p_emitters;
        let w = sampling::power_heuristic(fb * pdf_b, fl * pdf_l);
        let le = self.ps.emission(hit.tri, hit.u, hit.v);
        le * (w * std::f32::consts::PI / (fb * m)) * pass
    }
}
