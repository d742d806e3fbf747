//! Bake scaffolding shared by vlf-core's integration tests (included with `#[path]`) and the GPU
//! suite (`vlf_tests::bakes`): the small parameter set most tests start from, the fixed-count
//! final gather the CPU and GPU compare draw for draw, a CPU reference propagation with its
//! prepared scene and direction set, and its view as the final gather's converged field.

use glam::Vec3;
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, Propagated};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::Converged;
use vlf_core::lightfield::{BakeParams, Denoiser, GatherParams, Iterations, Sampling};
use vlf_core::scene::Scene;

/// The paper's parameters at `directions`, `resolution`² rays and `iterations`, tile 8.
pub fn params(directions: u32, resolution: u32, iterations: Iterations) -> BakeParams {
    BakeParams {
        directions,
        resolution,
        tile: 8,
        iterations,
        ..BakeParams::paper()
    }
}

/// The propagation the final-gather tests read: 126 directions, 32² rays, tile 4, texels of one
/// ray spacing, no perturbation, `iterations` under `sky`.
pub fn under_gather(sky: Vec3, iterations: Iterations) -> BakeParams {
    BakeParams {
        directions: 126,
        resolution: 32,
        tile: 4,
        texel_scale: 1.0,
        iterations,
        sky,
        perturb: 0,
        ..BakeParams::paper()
    }
}

/// Prepares `scene` at `params` and propagates it on the CPU (all threads).
pub fn propagate(scene: &Scene, params: &BakeParams) -> (BakeScene, DirectionSet, Propagated) {
    let prep = BakeScene::new(scene, params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let out = reference::propagate(&prep, &set, params);
    (prep, set, out)
}

/// A fixed-count final gather with no denoiser (the estimates the CPU and GPU compare draw for
/// draw): texels of `texel_scale` ray spacings, the indirect grid's of `indirect_texel_scale`,
/// and `[light_samples, direct_rays, indirect_rays]`.
pub fn fixed_gather(texel_scale: f32, indirect_texel_scale: f32, counts: [u32; 3]) -> GatherParams {
    let [light_samples, direct_rays, indirect_rays] = counts;
    GatherParams {
        texel_scale,
        indirect_texel_scale,
        light_samples,
        direct_rays,
        indirect_rays,
        sampling: Sampling::FIXED,
        denoise: Denoiser::Off,
    }
}

/// The final gather of the pane tests (`check_pane_gather`'s callers): texels twice the ray
/// spacing, indirect grid four times, 16 light samples, 256 direct and 4 indirect rays, fixed
/// sampling, no denoiser.
pub fn pane_gather() -> GatherParams {
    fixed_gather(2.0, 4.0, [16, 256, 4])
}

/// A CPU reference propagation of a scene: its prepared scene, direction set and result.
pub struct Propagation {
    pub prep: BakeScene,
    pub set: DirectionSet,
    pub out: Propagated,
}

impl Propagation {
    /// [`propagate`] as one value.
    pub fn new(scene: &Scene, params: &BakeParams) -> Propagation {
        let (prep, set, out) = propagate(scene, params);
        Propagation { prep, set, out }
    }

    /// The result as the final gather's converged field under `sky`, with the first bounce and
    /// tiles the propagation kept, at `ray_spacing` (the field's ray spacing in the units the
    /// gather's texel sizes are given in).
    pub fn converged(&self, sky: Vec3, ray_spacing: f32) -> Converged<'_> {
        Converged {
            prep: &self.prep,
            irradiance: &self.out.irradiance,
            first_bounce: self.out.first_bounce.as_deref(),
            tiles: self.out.tiles.as_ref().map(|(i, v)| (i, v.as_slice())),
            directions: &self.set,
            sky,
            ray_spacing,
        }
    }
}
