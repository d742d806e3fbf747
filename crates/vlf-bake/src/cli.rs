//! Command-line interface of `vlf-bake`.

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "vlf-bake",
    version,
    about = "Bake global illumination of a glTF 2.0 scene into a virtual light field",
    long_about = "Bake global illumination of a glTF 2.0 scene into a virtual light field.\n\n\
                  Light is propagated on the GPU (wgpu compute) along a hemisphere of directions, \
                  each a grid of parallel rays. Exit codes: 0 success, 1 internal error, \
                  2 usage error, 3 bad input file, 4 no usable GPU device."
)]
pub struct Cli {
    /// More log output (-v: info, -vv: debug, -vvv: trace). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Where to run: `auto` (GPU if an adapter exists, else the CPU reference path with a
    /// warning), `gpu` (fail without an adapter), `cpu` (the CPU reference path).
    #[arg(long, global = true, value_enum, default_value_t = DeviceArg::Auto)]
    pub device: DeviceArg,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DeviceArg {
    Auto,
    Gpu,
    Cpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QualityArg {
    /// Fast preview: 126 directions, 64² rays.
    Draft,
    /// The default: 512 directions, 128² rays, iterate to convergence.
    Auto,
    /// 2,048 directions, 256² rays.
    High,
}

/// `--iterations K` or `--iterations auto` (until the unshot power is below the threshold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IterationsArg {
    Fixed(u32),
    Auto,
}

impl std::str::FromStr for IterationsArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Self::Auto);
        }
        s.parse()
            .map(Self::Fixed)
            .map_err(|_| format!("expected a number or `auto`, got `{s}`"))
    }
}

/// `R,G,B` radiance (or one value for grey).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rgb(pub [f32; 3]);

impl std::str::FromStr for Rgb {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let v: Result<Vec<f32>, _> = s.split(',').map(|x| x.trim().parse::<f32>()).collect();
        match v.as_deref() {
            Ok([g]) if g.is_finite() && *g >= 0.0 => Ok(Rgb([*g; 3])),
            Ok([r, g, b]) if [r, g, b].iter().all(|x| x.is_finite() && **x >= 0.0) => {
                Ok(Rgb([*r, *g, *b]))
            }
            _ => Err(format!(
                "expected R,G,B (three non-negative numbers) or one number, got `{s}`"
            )),
        }
    }
}

/// Parameters of a bake; unset ones come from `--quality`.
#[derive(clap::Args, Debug, Clone)]
pub struct BakeArgs {
    /// Parameter preset; explicit options below override it.
    #[arg(long, value_enum, default_value_t = QualityArg::Auto)]
    pub quality: QualityArg,
    /// Number of directions l (rounded up to the next geodesic set, 5k²+1).
    #[arg(long)]
    pub directions: Option<u32>,
    /// Rays per PSF side N (N×N parallel rays per direction).
    #[arg(long)]
    pub resolution: Option<u32>,
    /// Cells per tile side m (N must be a multiple of m).
    #[arg(long)]
    pub tile: Option<u32>,
    /// Propagation iterations (bounces), or `auto` to stop when the unshot power falls below
    /// --threshold of the emitted power.
    #[arg(long)]
    pub iterations: Option<IterationsArg>,
    /// Convergence threshold for `--iterations auto`.
    #[arg(long, default_value_t = 1e-3)]
    pub threshold: f32,
    /// Perturbed (virtual) transport directions per fixed direction.
    #[arg(long)]
    pub perturb: Option<u32>,
    /// Texel edge relative to the ray spacing.
    #[arg(long)]
    pub texel_scale: Option<f32>,
    /// Constant sky radiance `R,G,B` entering every ray from outside the scene.
    #[arg(long)]
    pub sky: Option<Rgb>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Bake a glTF scene into a light-field file.
    Bake {
        /// The scene (.gltf or .glb).
        scene: PathBuf,
        /// Output light-field file (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        params: BakeArgs,
        /// Print a machine-readable JSON summary (times per phase, memory, energy, parameters)
        /// on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Compare a rendered image with a reference (both linear EXR of equal size): MSE,
    /// relMSE = mean((t−r)²/(r²+0.01)) over pixels and channels, and mean HDR-FLIP.
    Compare {
        /// The image under test.
        test: PathBuf,
        /// The reference image.
        reference: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also write a false-colour FLIP error map (PNG).
        #[arg(long)]
        diff: Option<PathBuf>,
    },
    /// Describe a light-field file: parameters, counts, memory by section, bake statistics.
    Info {
        /// The light-field file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Load a glTF scene and report what the baker sees: counts, materials, emitters, cameras,
    /// suns, planar faces, the VLF transform and every warning.
    Inspect {
        /// The scene (.gltf or .glb).
        scene: PathBuf,
        /// Print a machine-readable JSON summary on stdout instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Probe the compute device: pick the adapter as `--device` says, create it with the
    /// features and limits vlf needs, and run a compute self-test checked on the CPU.
    Selftest {
        /// Print a machine-readable JSON summary on stdout instead of text.
        #[arg(long)]
        json: bool,
    },
}
