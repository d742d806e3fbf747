//! A whole bake on the host, above `bake`, `gather` and `resample`: the CPU propagation (or one
//! handed in by the GPU propagator), the final gather and the mirror tiles' resampling when the
//! parameters ask for them, and the assembled light field.

use crate::bake::reference::{self, Propagated};
use crate::bake::subsurface::{LinkParams, Subsurface};
use crate::bake::{BakeError, BakeScene, try_assemble};
use crate::directions::DirectionSet;
use crate::gather::{Converged, GatherError, GatherStats, Gathered, final_gather};
use crate::lightfield::{BakeParams, BakeStats, LightField};
use crate::resample::{ResampleStats, resample_tiles};
use crate::scene::Scene;

/// A finished bake.
pub struct Finished {
    pub light_field: LightField,
    /// The gather's bookkeeping, when it ran.
    pub gather: Option<GatherStats>,
    /// The mirror tiles' resampling, when it ran (with the gather, on scenes with mirrors).
    pub resample: Option<ResampleStats>,
}

/// Finishes a propagation of `prep`: runs the final gather (`params.final_gather`, on `threads`
/// workers, 0 = all cores) and assembles the light field, failing on a non-finite value.
pub fn finish(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    propagated: Propagated,
    stats: BakeStats,
    threads: usize,
) -> Result<Finished, BakeError> {
    let Some(gp) = params.final_gather else {
        let light_field = try_assemble(scene, prep, params, directions, propagated, stats)?;
        return Ok(Finished {
            light_field,
            gather: None,
            resample: None,
        });
    };
    let g = final_gather(
        scene,
        &converged(prep, params, &directions, &propagated),
        &gp,
        threads,
    )
    .map_err(|e| match e {
        GatherError::Params(e) => BakeError::Params(e),
        GatherError::Oidn(e) => BakeError::Denoiser(e.to_string()),
    })?;
    finish_gathered(
        scene, prep, params, directions, propagated, stats, threads, g,
    )
}

/// The converged field of a propagation of `prep` as the final gather reads it.
pub fn converged<'a>(
    prep: &'a BakeScene,
    params: &BakeParams,
    directions: &'a DirectionSet,
    propagated: &'a Propagated,
) -> Converged<'a> {
    Converged {
        prep,
        irradiance: &propagated.irradiance,
        first_bounce: propagated.first_bounce.as_deref(),
        tiles: propagated.tiles.as_ref().map(|(i, v)| (i, v.as_slice())),
        directions,
        sky: params.sky,
        ray_spacing: 2.0 / params.resolution as f32,
    }
}

/// [`finish`] once the final gather has run (on the CPU here, or elsewhere: the GPU gather,
/// `vlf_gpu::gather`, over [`converged`]): the mirror tiles' resampling (on `threads` workers)
/// and the assembled light field.
#[allow(clippy::too_many_arguments)]
pub fn finish_gathered(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    propagated: Propagated,
    stats: BakeStats,
    threads: usize,
    mut g: Gathered,
) -> Result<Finished, BakeError> {
    // Translucent texels gathered their true irradiance: their effective irradiance on the
    // gather's atlas, through its own links (`docs/SUBSURFACE.md`).
    if let Some(s) = Subsurface::new(&g.atlas, &LinkParams::default(), threads) {
        s.effective(&g.atlas, &mut g.irradiance);
    }
    // The mirror tiles, resampled by tracing true reflected rays into the gathered field.
    let mut resample = None;
    let tiles = propagated.tiles.as_ref().map(|(index, values)| {
        let (new, stats) = resample_tiles(
            scene,
            prep,
            &g.atlas,
            &g.irradiance,
            index,
            values,
            &directions,
            params.sky,
            threads,
        );
        resample = Some(stats);
        (index.clone(), new)
    });
    // The light field stores the gathered atlas and its irradiance (the renderer applies
    // albedo and emission per pixel).
    let gathered = Propagated {
        irradiance: g.irradiance,
        first_bounce: None,
        tiles,
        ..propagated
    };
    let light_field = try_assemble(scene, &g.atlas, params, directions, gathered, stats)?;
    Ok(Finished {
        light_field,
        gather: Some(g.stats),
        resample,
    })
}

/// Bakes on the CPU: the reference propagator, then [`finish`] on all cores.
pub fn bake_cpu(scene: &Scene, params: &BakeParams) -> Result<LightField, BakeError> {
    let prep = BakeScene::new(scene, params)?;
    let directions = DirectionSet::at_least(params.directions)?;
    let out = reference::propagate(&prep, &directions, params);
    // No timings in the stats: equal inputs must give bit-identical files.
    let mut stats = BakeStats {
        iterations: out.iterations,
        device: "cpu".into(),
        adapter: "CPU reference".into(),
        ..Default::default()
    };
    out.energy.copy_into(&mut stats);
    Ok(finish(scene, &prep, params, directions, out, stats, 0)?.light_field)
}
