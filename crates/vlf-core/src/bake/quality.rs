//! Quality presets: the parameters a bake starts from before any scene-driven adjustment
//! ([`super::auto`]).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::lightfield::params::{BakeParams, DEFAULT_SEED, GatherParams, Iterations};

/// Parameter presets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Quality {
    /// Fast preview.
    Draft,
    /// The default.
    Auto,
    /// Slow, for references and final bakes.
    High,
}

impl Quality {
    /// The preset's parameters (before any scene-driven adjustment).
    pub fn params(self) -> BakeParams {
        // Texels span 2×2 rays: each texel then averages ~4 rays per direction, which removes
        // most of the per-texel aliasing noise (Cornell box, 512 directions, 64² rays: relMSE
        // against the path-traced reference 2.9e-3 with 1 ray per texel, 1.4e-3 with 2×2).
        let (directions, resolution, tile, max) = match self {
            Quality::Draft => (126, 32, 8, 8),
            Quality::Auto => (512, 64, 8, 64),
            Quality::High => (2048, 128, 16, 128),
        };
        BakeParams {
            directions,
            resolution,
            tile,
            texel_scale: 2.0,
            iterations: Iterations::Converge {
                threshold: 1e-3,
                max,
            },
            sky: Vec3::ZERO,
            perturb: 0,
            seed: DEFAULT_SEED,
            final_gather: None,
        }
    }

    /// The preset's final gather (before any scene-driven adjustment). The stored atlas' texels
    /// are half (draft), a quarter (auto) or an eighth (high) of the propagation's 2×2-ray
    /// texels; indirect light, which varies slowly, is gathered on a grid of one ray cell
    /// (draft: two). Measured on the Cornell box (246 directions, 64² rays; relMSE against the
    /// Mitsuba reference): 16 light samples and 64 gather rays 5.3e-4, 64 and 256 3.1e-4 (a
    /// finer stored atlas or gather grid buys less: `docs/GATHER.md`).
    pub fn gather(self) -> GatherParams {
        let (texel_scale, indirect_texel_scale, light_samples, direct_rays, indirect_rays) =
            match self {
                Quality::Draft => (1.0, 2.0, 16, 4, 64),
                Quality::Auto => (0.5, 1.0, 64, 16, 256),
                Quality::High => (0.25, 0.5, 256, 64, 1024),
            };
        let (target_error, max_rounds) = match self {
            Quality::Draft => (0.0, 1),
            Quality::Auto => (0.05, 8),
            Quality::High => (0.02, 16),
        };
        GatherParams {
            texel_scale,
            indirect_texel_scale,
            light_samples,
            direct_rays,
            indirect_rays,
            sampling: crate::lightfield::Sampling {
                guided: true,
                target_error,
                max_rounds,
            },
            denoise: true,
        }
    }
}
