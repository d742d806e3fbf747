//! Bake parameters: everything that controls a bake, stored in the file (the presets that
//! choose them are `bake::Quality`).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// When to stop iterating (one iteration = one bounce of light).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Iterations {
    /// Exactly this many propagation iterations (the paper uses 3).
    Fixed(u32),
    /// Until the unshot power falls below `threshold` × the emitted power, at most `max`.
    Converge { threshold: f32, max: u32 },
}

/// Everything that controls a bake. Stored in the output file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeParams {
    /// Requested number of directions l (the set uses the smallest geodesic set with ≥ l).
    pub directions: u32,
    /// Rays per PSF side (N).
    pub resolution: u32,
    /// Cells per tile side (m); `resolution % tile == 0`.
    pub tile: u32,
    /// Texel edge length relative to the ray spacing (1 = one texel per ray cell).
    pub texel_scale: f32,
    /// Stopping rule.
    pub iterations: Iterations,
    /// Constant sky radiance entering every ray from outside the scene.
    pub sky: Vec3,
    /// Perturbed (virtual) directions per fixed direction used for transport (0 = none).
    pub perturb: u32,
    /// Seed of every pseudo-random choice (perturbations); bakes are deterministic.
    pub seed: u64,
    /// The final gather run once propagation has converged (`None`: the light field alone).
    #[serde(default)]
    pub final_gather: Option<GatherParams>,
}

/// Settings of the final gather (`crate::gather`): texel sizes relative to the ray spacing, like
/// [`BakeParams::texel_scale`], and ray counts per texel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GatherParams {
    /// Texel edge of the gathered (stored) atlas: the resolution of direct light.
    pub texel_scale: f32,
    /// Texel edge of the indirect-light grid (at least `texel_scale`).
    pub indirect_texel_scale: f32,
    /// Light samples per texel of the stored atlas (a point of the texel paired with a point of
    /// an emitter; one shadow ray per sun as well).
    pub light_samples: u32,
    /// Cosine-distributed rays per texel of the stored atlas for the direct light they see:
    /// the sky, and emitters (weighted against the light samples by multiple importance
    /// sampling, which keeps emitters next to the texel from being undersampled).
    pub direct_rays: u32,
    /// Gather rays per texel of the indirect grid.
    pub indirect_rays: u32,
    /// Guided and adaptive sampling of the stored atlas' direct light.
    #[serde(default)]
    pub sampling: Sampling,
    /// Which filter runs over the gathered atlas (`gather::denoise`), if any.
    #[serde(default)]
    pub denoise: Denoiser,
}

/// The filter run over the gathered atlas (`docs/GATHER.md`, *Denoising the atlas*).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Denoiser {
    /// None: the gathered estimates as they are.
    #[default]
    Off,
    /// vlf's edge-aware filter (`gather::denoise::denoise`; `--denoise on`).
    Edge,
    /// Intel Open Image Denoise's `RTLightmap` filter over the atlas packed into an image
    /// (`gather::denoise::oidn`; `--denoise oidn`), in builds with the `oidn` feature only.
    Oidn,
}

impl Denoiser {
    /// Whether a filter runs.
    pub fn is_on(self) -> bool {
        self != Denoiser::Off
    }

    /// Whether this build can run it: OIDN only with the `oidn` feature.
    pub fn available(self) -> bool {
        self != Denoiser::Oidn || cfg!(feature = "oidn")
    }

    /// What `vlf-bake info` calls it.
    pub fn describe(self) -> &'static str {
        match self {
            Denoiser::Off => "none",
            Denoiser::Edge => "vlf's edge-aware filter",
            Denoiser::Oidn => "OIDN RTLightmap",
        }
    }

    /// The command line's name (`--denoise on|off|oidn`).
    pub fn name(self) -> &'static str {
        match self {
            Denoiser::Off => "off",
            Denoiser::Edge => "on",
            Denoiser::Oidn => "oidn",
        }
    }
}

/// How the final gather spends its rays on the stored atlas (`docs/GATHER.md`, *Guided rays*
/// and *Rays where the noise is*).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sampling {
    /// Draw three quarters of the cosine rays from the guide the indirect grid's rays measured
    /// (where they saw the sky), weighted against cosine rays and light samples by MIS.
    pub guided: bool,
    /// Keep sampling a texel, a round (`light_samples` + `direct_rays`) at a time, while the
    /// estimated standard error of its irradiance is above this fraction of its value
    /// (0: one round).
    pub target_error: f32,
    /// Most rounds per texel.
    pub max_rounds: u32,
}

impl Sampling {
    /// One round of cosine rays and light samples per texel, as before guiding.
    pub const FIXED: Sampling = Sampling {
        guided: false,
        target_error: 0.0,
        max_rounds: 1,
    };

    /// Whether every texel gets exactly one unguided round.
    pub fn is_fixed(&self) -> bool {
        !self.guided && (self.target_error <= 0.0 || self.max_rounds <= 1)
    }
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling::FIXED
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamsError {
    /// A setting this build cannot honour (an optional feature it was built without).
    #[error("{name} = {value}: {reason}")]
    Unavailable {
        name: &'static str,
        value: &'static str,
        reason: &'static str,
    },
    #[error("--resolution {resolution} is not a multiple of --tile {tile}")]
    TileMismatch { resolution: u32, tile: u32 },
    #[error("{name} = {value} is out of range ({range})")]
    OutOfRange {
        name: &'static str,
        value: String,
        range: &'static str,
    },
}

/// Why `--denoise oidn` is refused by a build without the `oidn` feature.
pub const OIDN_MISSING: &str = "this build has no Intel Open Image Denoise: build with \
     `--features oidn` and OIDN_DIR set (docs/GATHER.md, \"OIDN's lightmap filter\")";

/// Default seed for perturbed directions.
pub const DEFAULT_SEED: u64 = 0x5eed_0001;

impl BakeParams {
    /// The paper's Cornell-box settings: 512 directions, 64×64 rays, 8×8 tiles, 3 iterations.
    pub fn paper() -> Self {
        BakeParams {
            directions: 512,
            resolution: 64,
            tile: 8,
            texel_scale: 1.0,
            iterations: Iterations::Fixed(3),
            sky: Vec3::ZERO,
            perturb: 0,
            seed: DEFAULT_SEED,
            final_gather: None,
        }
    }

    /// Whether this build can bake with these parameters: `--denoise oidn` needs the `oidn`
    /// feature. What a baker checks before it starts; [`Self::validate`] does not, so a file
    /// baked with OIDN reads (and renders) in every build.
    pub fn check_available(&self) -> Result<(), ParamsError> {
        match &self.final_gather {
            Some(g) if !g.denoise.available() => Err(ParamsError::Unavailable {
                name: "denoise",
                value: g.denoise.name(),
                reason: OIDN_MISSING,
            }),
            _ => Ok(()),
        }
    }

    /// Checks ranges and consistency.
    pub fn validate(&self) -> Result<(), ParamsError> {
        let range = |name, ok: bool, value: String, range| {
            if ok {
                Ok(())
            } else {
                Err(ParamsError::OutOfRange { name, value, range })
            }
        };
        range(
            "directions",
            (1..=20_481).contains(&self.directions),
            self.directions.to_string(),
            "1..=20481",
        )?;
        range(
            "resolution",
            (1..=4096).contains(&self.resolution),
            self.resolution.to_string(),
            "1..=4096",
        )?;
        range(
            "tile",
            (1..=self.resolution.max(1)).contains(&self.tile),
            self.tile.to_string(),
            "1..=resolution",
        )?;
        if !self.resolution.is_multiple_of(self.tile) {
            return Err(ParamsError::TileMismatch {
                resolution: self.resolution,
                tile: self.tile,
            });
        }
        range(
            "texel_scale",
            self.texel_scale.is_finite() && (0.05..=64.0).contains(&self.texel_scale),
            self.texel_scale.to_string(),
            "0.05..=64",
        )?;
        range(
            "sky",
            self.sky.is_finite() && self.sky.min_element() >= 0.0,
            format!("{:?}", self.sky),
            "finite, >= 0",
        )?;
        range(
            "perturb",
            self.perturb <= 256,
            self.perturb.to_string(),
            "0..=256",
        )?;
        if let Some(g) = &self.final_gather {
            let scale = |name, v: f32| {
                range(
                    name,
                    v.is_finite() && (0.01..=64.0).contains(&v),
                    v.to_string(),
                    "0.01..=64",
                )
            };
            scale("gather texel_scale", g.texel_scale)?;
            scale("gather indirect_texel_scale", g.indirect_texel_scale)?;
            for (name, v) in [
                ("gather light_samples", g.light_samples),
                ("gather direct_rays", g.direct_rays),
                ("gather indirect_rays", g.indirect_rays),
            ] {
                range(name, v <= 1 << 16, v.to_string(), "0..=65536")?;
            }
            let t = g.sampling.target_error;
            range(
                "gather target error",
                t.is_finite() && (0.0..1.0).contains(&t),
                t.to_string(),
                "[0, 1)",
            )?;
            range(
                "gather max rounds",
                (1..=256).contains(&g.sampling.max_rounds),
                g.sampling.max_rounds.to_string(),
                "1..=256",
            )?;
        }
        match self.iterations {
            Iterations::Fixed(n) => range("iterations", n <= 10_000, n.to_string(), "0..=10000"),
            Iterations::Converge { threshold, max } => {
                range(
                    "threshold",
                    threshold.is_finite() && threshold > 0.0 && threshold < 1.0,
                    threshold.to_string(),
                    "(0, 1)",
                )?;
                range(
                    "max iterations",
                    max <= 10_000,
                    max.to_string(),
                    "0..=10000",
                )
            }
        }
    }
}
