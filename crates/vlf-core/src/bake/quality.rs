//! Quality presets: every number a preset sets, in one table ([`Preset`]), from which a bake
//! starts; the scene rules ([`super::refine`]) refine it for every preset, and explicit options
//! override the result. `docs/QUALITY.md` states the same table (a test compares them).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::lightfield::params::{BakeParams, DEFAULT_SEED, GatherParams, Iterations};
use crate::lightfield::{Denoiser, Sampling};

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

/// Every number a quality preset sets. The scene rules choose the rays per side within
/// `resolution`, the tile size (at most 4, from the triangle density), the perturbed directions
/// (up to `perturb_cap`) and the final gather's texels (from the lights and `gather_texel_budget`);
/// the rest is used as is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Preset {
    /// Directions requested without the final gather (the bake uses the smallest geodesic set
    /// with at least as many, `DirectionSet::at_least`).
    pub directions: u32,
    /// Directions requested with the final gather, which samples direct light itself and reads
    /// the propagated field only through rays that each average it over a hemisphere, so the
    /// propagation needs fewer (Cornell box with the gather, relMSE: 126 directions 3.5e-4,
    /// 246 3.1e-4, 606 3.0e-4 in 2.4× the time of 246; docs/GATHER.md).
    pub gather_directions: u32,
    /// Rays per PSF side: the least and most the scene rules choose (powers of two); a bake
    /// starts from the least.
    pub resolution: (u32, u32),
    /// Most rays per side for rooms lit by a sky through their openings (the scene rules
    /// double the rays there, up to this; `super::refine`).
    pub sky_interior_rays: u32,
    /// Cells per tile side before the scene rules choose one from the triangle density (kept
    /// when the scene cannot be probed).
    pub tile: u32,
    /// Texel edge of the propagation's atlas relative to the ray spacing. 2: texels span 2×2
    /// rays, so each averages ~4 rays per direction, which removes most of the per-texel
    /// aliasing noise (Cornell box, 512 directions, 64² rays: relMSE against the path-traced
    /// reference 2.9e-3 with 1 ray per texel, 1.4e-3 with 2×2).
    pub texel_scale: f32,
    /// Propagation stops when the unshot power is below this fraction of the emitted power ...
    pub threshold: f32,
    /// ... or after this many iterations.
    pub max_iterations: u32,
    /// Most perturbed (jittered) copies per direction for small emitters (none with the gather).
    pub perturb_cap: u32,
    /// The final gather before the scene rules halve its texels for sharp shadows or coarsen
    /// them to the budget. The stored atlas' texels are half (draft), a quarter (auto) or an
    /// eighth (high) of the propagation's 2×2-ray texels; indirect light, which varies slowly,
    /// is gathered on a grid of one ray cell (draft: two). Measured on the Cornell box (246
    /// directions, 64² rays; relMSE against the Mitsuba reference): 16 light samples and 64
    /// gather rays 5.3e-4, 64 and 256 3.1e-4 (a finer stored atlas or gather grid buys less:
    /// `docs/GATHER.md`).
    pub gather: GatherParams,
    /// Most texels of the gathered atlas (both sides of every face): past this the stored
    /// atlas gets coarser rather than the bake slower and the file larger.
    pub gather_texel_budget: f64,
}

impl Quality {
    /// Every preset, from the fastest.
    pub const ALL: [Quality; 3] = [Quality::Draft, Quality::Auto, Quality::High];

    /// The preset's numbers.
    pub fn preset(self) -> &'static Preset {
        match self {
            Quality::Draft => &Preset::DRAFT,
            Quality::Auto => &Preset::AUTO,
            Quality::High => &Preset::HIGH,
        }
    }

    /// The name `--quality` takes.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Auto => "auto",
            Quality::High => "high",
        }
    }
}

impl Preset {
    pub const DRAFT: Preset = Preset {
        directions: 126,
        gather_directions: 126,
        resolution: (32, 64),
        sky_interior_rays: 64,
        tile: 8,
        texel_scale: 2.0,
        threshold: 1e-2,
        max_iterations: 8,
        perturb_cap: 4,
        gather: GatherParams {
            texel_scale: 1.0,
            indirect_texel_scale: 2.0,
            light_samples: 16,
            direct_rays: 4,
            indirect_rays: 64,
            sampling: Sampling {
                guided: true,
                target_error: 0.0,
                max_rounds: 1,
            },
            denoise: Denoiser::Edge,
        },
        gather_texel_budget: 250e3,
    };

    pub const AUTO: Preset = Preset {
        directions: 512,
        gather_directions: 246,
        resolution: (64, 256),
        sky_interior_rays: 512,
        tile: 8,
        texel_scale: 2.0,
        threshold: 1e-3,
        max_iterations: 64,
        perturb_cap: 16,
        gather: GatherParams {
            texel_scale: 0.5,
            indirect_texel_scale: 1.0,
            light_samples: 64,
            direct_rays: 16,
            indirect_rays: 256,
            sampling: Sampling {
                guided: true,
                target_error: 0.05,
                max_rounds: 8,
            },
            denoise: Denoiser::Edge,
        },
        gather_texel_budget: 1e6,
    };

    pub const HIGH: Preset = Preset {
        directions: 2048,
        gather_directions: 606,
        resolution: (128, 512),
        sky_interior_rays: 512,
        tile: 16,
        texel_scale: 2.0,
        threshold: 1e-4,
        max_iterations: 128,
        perturb_cap: 32,
        gather: GatherParams {
            texel_scale: 0.25,
            indirect_texel_scale: 0.5,
            light_samples: 256,
            direct_rays: 64,
            indirect_rays: 1024,
            sampling: Sampling {
                guided: true,
                target_error: 0.02,
                max_rounds: 16,
            },
            denoise: Denoiser::Edge,
        },
        gather_texel_budget: 4e6,
    };

    /// The parameters a bake starts from, before the scene rules: the least rays per side, the
    /// preset's tile, no perturbation, no sky, and the final gather when `final_gather`.
    pub fn params(&self, final_gather: bool) -> BakeParams {
        BakeParams {
            directions: if final_gather {
                self.gather_directions
            } else {
                self.directions
            },
            resolution: self.resolution.0,
            tile: self.tile,
            texel_scale: self.texel_scale,
            iterations: Iterations::Converge {
                threshold: self.threshold,
                max: self.max_iterations,
            },
            sky: Vec3::ZERO,
            perturb: 0,
            seed: DEFAULT_SEED,
            final_gather: final_gather.then_some(self.gather),
        }
    }
}
