//! The final gather with guided and adaptive sampling (`docs/GATHER.md`, *Guided and adaptive
//! sampling*): the sky guide, direct light by rounds to a target error, the field read without
//! its first bounce, the guided indirect grid, then the atlas denoiser; and the sampling's
//! bookkeeping for `--json`.

use glam::{Vec3, Vec4};
use serde::Serialize;

use super::field::{Field, Quad, Tiles, chart_bilinear};
use super::guide::{Cells, Guide, SkyMask};
use super::{
    CHUNK, Converged, DirectTexel, FirstPass, GatherError, Gathered, Gatherer, Grid, Grids,
    IndirectTexel, TexelPoints, assemble, denoise, luminance,
};
use crate::lightfield::{Denoiser, GatherParams};
use crate::pathtrace::PreparedScene;
use crate::scene::Scene;

/// The final gather with guided and adaptive sampling (`gp.sampling`), in four steps:
/// 1. where each texel of the indirect grid sees the sky (a quarter of its rays, cosine,
///    occlusion only, then four rays in each quarter cell round the cells that saw it): the
///    direct estimator's guide;
/// 2. direct light on the stored atlas, guided, by rounds until its estimated error is below
///    the target;
/// 3. where the propagation kept its first bounce, the field the gather rays read becomes the
///    light after the first bounce plus the direct light of step 2 (read on the stored atlas):
///    the field's own first bounce of a sky seen through an opening is a sum of a few hundred
///    parallel projections of the opening, blotchy at the scale of texels, and the gather's
///    rays would carry those blotches to every receiver;
/// 4. indirect light on the indirect grid: a first pass of cosine rays, then a second guided
///    by the neighbours' first passes, all weighted by the balance heuristic.
pub(super) fn final_gather_sampled(
    scene: &Scene,
    ps: &PreparedScene,
    field: &Converged,
    gp: &GatherParams,
    grids: Grids,
    threads: usize,
) -> Result<Gathered, GatherError> {
    let s = gp.sampling;
    let later: Option<Vec<[f32; 4]>> = field.first_bounce.map(|first| {
        field
            .irradiance
            .iter()
            .zip(first)
            .map(|(e, f)| {
                [
                    (e[0] - f[0]).max(0.0),
                    (e[1] - f[1]).max(0.0),
                    (e[2] - f[2]).max(0.0),
                    0.0,
                ]
            })
            .collect()
    });
    let mut g = Gatherer {
        ps,
        field: Field::new(
            ps,
            field.prep,
            later.as_deref().unwrap_or(field.irradiance),
            field
                .tiles
                .map(|(index, values)| Tiles::new(index, values, field.directions)),
        )
        .with_contacts(ps, threads),
        sky: field.sky,
    };
    let coarse = &grids.indirect;
    let coarse_pts = coarse.points(scene, &ps.bvh);
    // 1. The sky guide.
    let sky_masks: Vec<Option<SkyMask>> = if s.guided && field.sky != Vec3::ZERO {
        crate::par::map(coarse.atlas.texel_count(), threads, CHUNK, |t| {
            g.sky_mask(&coarse_pts, t, (gp.indirect_rays / 4).max(1))
        })
    } else {
        Vec::new()
    };
    // 2. Direct light; the adaptive estimator's floor is the field's light after the first
    // bounce (or all of it) at the texel.
    let fine = &grids.direct;
    let fine_pts = fine.points(scene, &ps.bvh);
    let dir = crate::par::map(fine.atlas.texel_count(), threads, CHUNK, |t| {
        let (fi, side, p) = fine.locate(t);
        let guide = if sky_masks.is_empty() {
            None
        } else {
            let quad = Quad::at(&coarse.atlas.faces[fi], side, p);
            let parts = (0..4).filter_map(|c| {
                let mask = sky_masks[quad.texel[c] as usize].as_ref()?;
                Some((mask, quad.weight(c)))
            });
            let w = SkyMask::blend(parts);
            w.iter().any(|&x| x > 0.0).then_some(w)
        };
        let floor = luminance(chart_bilinear(
            &field.prep.faces[fi],
            &g.field.irradiance,
            side,
            p,
        ));
        g.direct_texel(&fine_pts, t, gp, guide.as_deref(), floor)
    });
    // 3. The field read with the gathered direct light.
    if later.is_some() {
        let filled: Vec<bool> = dir.iter().map(Option::is_some).collect();
        let mut e: Vec<[f32; 4]> = dir
            .iter()
            .map(|d| d.as_ref().map_or(Vec3::ZERO, |d| d.e).extend(0.0).into())
            .collect();
        crate::bake::dilate_where(&fine.atlas, &mut e, &filled);
        g.field.direct = Some((&fine.atlas, e));
    }
    // 4. Indirect light. Under adaptive sampling a texel keeps its first pass alone where
    // that is already within the target of the texel's whole light (the field's, direct
    // included) and agrees with what the field predicts for it (the light after the first
    // bounce): open ground under a sky, whose indirect light is a sliver of its sky light.
    // Only under a sky, whose open ground it is for: on the Cornell box the rule kept the first
    // pass alone on 1 % of the texels, and relMSE went 2.94e-4 → 3.02e-4.
    let adaptive =
        s.max_rounds > 1 && s.target_error > 0.0 && later.is_some() && field.sky != Vec3::ZERO;
    // Per indirect texel, the error its first pass must be within and the mean it must reach
    // (`FirstPass::enough`), read once for every pass.
    let limits: Vec<(f32, f32)> = if adaptive {
        (0..coarse.atlas.texel_count())
            .map(|t| {
                let (fi, side, p) = coarse.locate(t);
                let face = &field.prep.faces[fi];
                let total = luminance(chart_bilinear(face, field.irradiance, side, p));
                let predicted = luminance(chart_bilinear(face, &g.field.irradiance, side, p));
                (0.25 * s.target_error * total, 0.5 * predicted)
            })
            .collect()
    } else {
        Vec::new()
    };
    let enough = |t: usize, first: &FirstPass| {
        limits
            .get(t)
            .is_some_and(|&(error, expected)| first.enough(error, expected))
    };
    let mut ind = indirect_guided(&g, coarse, &coarse_pts, gp.indirect_rays, &enough, threads);
    // 5. Under a sky, more passes of the indirect grid, each reading the previous one's
    // gathered light (plus the direct light) where its rays land instead of the propagated
    // field's, whose light after the first bounce is a few per cent low in rooms lit through
    // openings (`EXTRA_INDIRECT_PASSES`). The grid's contacts are found once for all passes.
    let passes = if adaptive { EXTRA_INDIRECT_PASSES } else { 0 };
    let mut contacts = None;
    for _ in 0..passes {
        let e: Vec<Option<Vec3>> = ind.iter().map(|e| e.as_ref().map(|e| e.e)).collect();
        let c = contacts
            .take()
            .unwrap_or_else(|| super::field::Contacts::new(&ps.bvh, scene, &coarse.atlas, threads));
        let mut read = super::indirect_field(ps, &coarse.atlas, &e, c);
        read.tiles = field
            .tiles
            .map(|(index, values)| Tiles::new(index, values, field.directions));
        read.direct = g.field.direct.clone();
        let g2 = Gatherer {
            ps,
            field: read,
            sky: field.sky,
        };
        ind = indirect_guided(&g2, coarse, &coarse_pts, gp.indirect_rays, &enough, threads);
        contacts = Some(g2.field.contacts);
    }
    drop(g);
    let var_ind: Vec<[f32; 4]> = ind
        .iter()
        .map(|e| [e.as_ref().map_or(0.0, |e| e.variance), 0.0, 0.0, 0.0])
        .collect();
    let var: Vec<f32> = dir
        .iter()
        .enumerate()
        .map(|(t, d)| {
            d.as_ref().map_or(0.0, |d| {
                let (fi, side, p) = fine.locate(t);
                d.variance + chart_bilinear(&coarse.atlas.faces[fi], &var_ind, side, p).x
            })
        })
        .collect();
    let ind_e: Vec<Option<Vec3>> = ind.iter().map(|e| e.as_ref().map(|e| e.e)).collect();
    let dir_e: Vec<Option<Vec3>> = dir.iter().map(|d| d.as_ref().map(|d| d.e)).collect();
    let fine_texel = grids.direct.texel_size;
    let mut gathered = assemble(ps, field, grids, &ind_e, &dir_e, threads);
    gathered.stats.sampling = Some(SamplingStats::of(&dir, &ind, &var, &gathered.irradiance));
    let filled: Vec<bool> = dir.iter().map(Option::is_some).collect();
    let t0 = std::time::Instant::now();
    match gp.denoise {
        Denoiser::Off => {}
        Denoiser::Edge => {
            // The stored atlas' grid again (the same atlas, deterministic), for its charts.
            let grid = Grid::new(scene, fine_texel)?;
            let (e, stats) = denoise::denoise(
                scene,
                &ps.bvh,
                &grid,
                &gathered.irradiance,
                &var,
                &filled,
                &denoise::DenoiseParams::default(),
                threads,
            );
            gathered.irradiance = e;
            gathered.stats.denoise = Some(stats);
        }
        Denoiser::Oidn => {
            let (e, stats) =
                denoise::oidn::denoise(&gathered.atlas, &gathered.irradiance, &filled, threads)?;
            gathered.irradiance = e;
            gathered.stats.oidn = Some(stats);
        }
    }
    if gp.denoise.is_on() {
        gathered.stats.denoise_s = Some(t0.elapsed().as_secs_f64());
    }
    gathered.variance = Some(var);
    Ok(gathered)
}

/// Passes of the indirect grid after the first under a sky with adaptive sampling, each reading
/// the previous pass's gathered light where its rays land (`docs/GATHER.md`, *More passes of the
/// indirect grid*). window-room (256×256 at 16 spp against Mitsuba; CPU-seconds of the bake):
/// 0 passes 2.72e-4 / FLIP 0.0681 (52 s), 1: 2.55e-4 / 0.0617 (54 s), 2: 2.53e-4 / 0.0599
/// (60 s), 3: 2.55e-4 / 0.0594 (66 s). Without a sky it is not on: the Cornell box gained
/// 2.94e-4 / 0.0507 → 2.86e-4 / 0.0482 from 2 passes in 1.5× its CPU time (no open ground whose
/// texels the first-pass rule spares).
pub const EXTRA_INDIRECT_PASSES: u32 = 2;

/// The indirect grid by the guided estimator: a first pass of cosine rays everywhere, then each
/// texel's second pass guided by its neighbours' first passes (the same side of the same face,
/// one texel away in each of the four directions).
fn indirect_guided(
    g: &Gatherer,
    grid: &Grid,
    pts: &TexelPoints,
    rays: u32,
    enough: &(impl Fn(usize, &FirstPass) -> bool + Sync),
    threads: usize,
) -> Vec<Option<IndirectTexel>> {
    let atlas = &grid.atlas;
    let first = crate::par::map(atlas.texel_count(), threads, CHUNK, |t| {
        g.indirect_first(pts, t, rays)
    });
    crate::par::map(atlas.texel_count(), threads, CHUNK, |t| {
        let own = first[t].as_ref()?;
        if enough(t, own) {
            return Some(own.alone());
        }
        let f = &atlas.faces[grid.tex_face[t] as usize];
        let local = t as u32 - f.texel_base;
        let (i, j) = (local % f.width, local % f.texels_per_side() / f.width);
        let mut parts = Vec::with_capacity(4);
        for (di, dj) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
            let (ni, nj) = (i as i32 + di, j as i32 + dj);
            if ni < 0 || nj < 0 || ni >= f.width as i32 || nj >= f.height as i32 {
                continue;
            }
            let n = (t as i64 + i64::from(di) + i64::from(dj) * i64::from(f.width)) as usize;
            if let Some(p) = &first[n] {
                parts.push((&p.luminance, 1.0));
            }
        }
        let guide = Guide::new(&Cells::blend(parts.into_iter()).w);
        Some(g.indirect_second(pts, t, rays, own, guide.as_ref()))
    })
}

/// Quantiles of a per-texel quantity over the stored atlas' open texels.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Distribution {
    pub mean: f64,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Distribution {
    pub fn of(mut v: Vec<f64>) -> Distribution {
        if v.is_empty() {
            return Distribution::default();
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        Distribution {
            mean: v.iter().sum::<f64>() / v.len() as f64,
            p50: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            max: v[v.len() - 1],
        }
    }
}

/// How the stored atlas' direct light was sampled (`--json`, `gather.sampling`): rays per
/// texel (light samples, cosine and guided rays, sun shadow rays) and the estimated relative
/// standard error of each texel's irradiance (direct and the indirect grid's, luminance).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SamplingStats {
    pub texels: usize,
    pub rays_per_texel: Distribution,
    /// Gather rays per texel of the indirect grid (its open texels).
    pub indirect_rays_per_texel: Distribution,
    pub relative_error: Distribution,
    /// Share of the texels that stopped before their last allowed round.
    pub converged_share: f64,
}

impl SamplingStats {
    fn of(
        dir: &[Option<DirectTexel>],
        ind: &[Option<IndirectTexel>],
        var: &[f32],
        irradiance: &[[f32; 4]],
    ) -> SamplingStats {
        let open: Vec<(usize, &DirectTexel)> = dir
            .iter()
            .enumerate()
            .filter_map(|(t, d)| Some((t, d.as_ref()?)))
            .collect();
        let most = open.iter().map(|(_, d)| d.rays).max().unwrap_or(0);
        SamplingStats {
            texels: open.len(),
            rays_per_texel: Distribution::of(open.iter().map(|(_, d)| f64::from(d.rays)).collect()),
            indirect_rays_per_texel: Distribution::of(
                ind.iter().flatten().map(|e| f64::from(e.rays)).collect(),
            ),
            relative_error: Distribution::of(
                open.iter()
                    .map(|(t, _)| {
                        let e = luminance(Vec4::from(irradiance[*t]).truncate());
                        f64::from(var[*t].sqrt()) / f64::from(e.max(1e-12))
                    })
                    .collect(),
            ),
            converged_share: if open.is_empty() {
                0.0
            } else {
                open.iter().filter(|(_, d)| d.rays < most).count() as f64 / open.len() as f64
            },
        }
    }
}
