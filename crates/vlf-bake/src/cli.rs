//! Command-line interface of `vlf-bake`.

use clap::{Parser, Subcommand, ValueEnum};
use glam::Vec3;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "vlf-bake",
    version,
    about = "Bake global illumination of a glTF 2.0 scene into a virtual light field",
    long_about = "Bake global illumination of a glTF 2.0 scene into a virtual light field.\n\n\
                  Light is propagated along a hemisphere of directions, each a grid of parallel \
                  rays, on a hardware GPU (wgpu compute) or on every CPU core.\n\n\
                  Exit codes: 0 success, 1 internal error, 2 usage error, 3 bad input file, \
                  4 no usable GPU device (or the device was lost), 5 batch: some scenes failed \
                  (the others were baked; see the report), 6 the bake does not fit the memory \
                  budget (--max-memory) or the GPU ran out of memory, 130 interrupted (Ctrl-C)."
)]
pub struct Cli {
    /// More log output (-v: info, -vv: debug, -vvv: trace). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Where to run: `auto` (a hardware GPU adapter when there is one; the CPU path, on every
    /// core, when the only adapter is a software rasterizer such as lavapipe, or none), `gpu`
    /// (any adapter, software included; fail without one), `cpu` (the CPU path).
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

/// `--quality`: the presets' numbers are `vlf_core::bake::quality::Preset`, tabled in
/// docs/QUALITY.md.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QualityArg {
    /// Fast preview.
    Draft,
    /// The default.
    Auto,
    /// Slow, for references and final bakes.
    High,
}

impl From<QualityArg> for vlf_core::bake::Quality {
    fn from(q: QualityArg) -> Self {
        match q {
            QualityArg::Draft => Self::Draft,
            QualityArg::Auto => Self::Auto,
            QualityArg::High => Self::High,
        }
    }
}

/// `--gather-sampling`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GatherSampling {
    Fixed,
    Guided,
    Adaptive,
}

/// `--final-gather on|off`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

/// `--denoise on|off|oidn`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DenoiseArg {
    On,
    Off,
    Oidn,
}

impl From<DenoiseArg> for vlf_core::lightfield::Denoiser {
    fn from(d: DenoiseArg) -> Self {
        match d {
            DenoiseArg::On => Self::Edge,
            DenoiseArg::Off => Self::Off,
            DenoiseArg::Oidn => Self::Oidn,
        }
    }
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
    /// Parameter preset (its numbers: docs/QUALITY.md), refined from the scene (ray spacing
    /// from the distances between mutually visible faces, tile size from the triangle density,
    /// perturbed directions for small emitters, the final gather's texels for sharp shadows);
    /// explicit options below override it.
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
    /// Convergence threshold for `--iterations auto` (default from --quality,
    /// docs/QUALITY.md).
    #[arg(long)]
    pub threshold: Option<f32>,
    /// Perturbed (virtual) transport directions per fixed direction.
    #[arg(long)]
    pub perturb: Option<u32>,
    /// Texel edge of the propagation's atlas, relative to the ray spacing.
    #[arg(long)]
    pub texel_scale: Option<f32>,
    /// Once propagation has converged, compute every texel's irradiance again by backward ray
    /// tracing (direct light sampled explicitly, indirect light gathered from the light field)
    /// into a finer atlas (docs/GATHER.md). `off` keeps the light field alone.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub final_gather: OnOff,
    /// Texel edge of the gathered atlas, relative to the ray spacing (default from --quality
    /// and the scene, docs/QUALITY.md).
    #[arg(long, value_name = "S")]
    pub gather_texel_scale: Option<f32>,
    /// Gather rays per texel of the final gather's indirect grid (default from --quality,
    /// docs/QUALITY.md).
    #[arg(long, value_name = "R")]
    pub gather_rays: Option<u32>,
    /// How the final gather samples direct light (default from --quality, docs/QUALITY.md):
    /// `fixed` one round of cosine rays and light samples per texel; `guided` three quarters
    /// of the rays drawn where the indirect grid's rays saw the sky; `adaptive` guided, and
    /// more rounds where a texel's estimated error is above --gather-target (docs/GATHER.md).
    #[arg(long, value_enum, value_name = "MODE")]
    pub gather_sampling: Option<GatherSampling>,
    /// Relative standard error that adaptive sampling stops at (default from --quality,
    /// docs/QUALITY.md).
    #[arg(long, value_name = "E")]
    pub gather_target: Option<f32>,
    /// Most rounds of samples per texel under adaptive sampling (default from --quality,
    /// docs/QUALITY.md).
    #[arg(long, value_name = "N")]
    pub gather_max_rounds: Option<u32>,
    /// The atlas denoiser after the final gather (docs/GATHER.md): `on` vlf's edge-aware
    /// filter, `off` none, `oidn` Intel Open Image Denoise's lightmap filter (only in builds
    /// with the `oidn` feature). The file records which ran.
    #[arg(long, value_enum)]
    pub denoise: Option<DenoiseArg>,
    /// Constant sky radiance `R,G,B` entering every ray from outside the scene.
    #[arg(long)]
    pub sky: Option<Rgb>,
    /// Sky radiance to use only for scenes with no emitter, no light (sun, point, spot) and no --sky (which would
    /// otherwise be refused as unlit). `batch` defaults it to 1,1,1; `bake` has no default.
    #[arg(long, value_name = "R,G,B")]
    pub sky_if_unlit: Option<Rgb>,
    /// Ignore the meshes' NORMALs: every face shades flat (the gather gathers about the
    /// faces' own normals, mirrors reflect about them), as the shared references other than
    /// lamp-room are rendered. By default NORMALs are shading normals.
    #[arg(long)]
    pub flat_normals: bool,
    /// Memory budget of one bake, e.g. `2G`, `512M` (K, M, G, T are powers of 1024). The bake's
    /// memory is planned before propagating (print it with -v); when the plan exceeds the
    /// budget, --resolution is halved (with a warning) until it fits, and the bake is refused
    /// (exit code 6) when no resolution down to 8 fits. Default: on the CPU path 3/4 of the
    /// system RAM (/proc/meminfo MemTotal), divided by --jobs in `batch`; on a GPU, every
    /// buffer within the adapter's max_storage_buffer_binding_size and the host side within
    /// 3/4 of the RAM (on a hardware GPU, --max-memory bounds the GPU buffers).
    #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
    pub max_memory: Option<u64>,
    /// Worker threads of the CPU work: the propagation on the CPU path, the final gather and
    /// the mirror tiles' resampling (0 = every core; `batch` divides the cores between its
    /// --jobs). The file is bit-identical whatever the number.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub threads: usize,
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
    /// Bake every .gltf/.glb scene under a directory (recursively, in sorted order, symbolic
    /// links not followed) into an output directory that mirrors it.
    #[command(
        long_about = "Bake every .gltf/.glb scene under DIR (recursively, in sorted order, \
                      symbolic links not followed) into OUTDIR, keeping relative paths: \
                      DIR/a/b/scene.gltf is baked to OUTDIR/a/b/scene.vlf.\n\n\
                      A scene is skipped when its output is newer than both the scene file and \
                      the vlf-bake executable and was baked with the same parameters (a lower \
                      --resolution chosen by the memory budget counts as the same); --force \
                      bakes it again. Only the scene file's own time is compared: after editing \
                      a .bin or texture next to a .gltf, use --force. A failing scene is \
                      reported and the batch goes on. One line per scene on stdout, an overall \
                      progress bar on stderr (on a terminal), and with --json a report written \
                      atomically after every scene.\n\n\
                      The device is opened once for the whole batch. Scenes without emitters, \
                      lights or --sky fail with a clear message (no sky is added silently: pass \
                      --sky R,G,B to light them). Ctrl-C stops cleanly: finished outputs stay, \
                      the scene in progress leaves no file under its name (its temporary file \
                      is removed), the report marks it `interrupted`, exit code 130. Stale \
                      temporary files (.NAME.tmp.PID.N) of killed runs next to an output are \
                      removed when their process is gone.\n\n\
                      Exit codes: 0 every scene baked or up to date, 5 some scenes failed \
                      (the others were baked), 130 interrupted; 2, 3 and 4 as for `bake` \
                      when the batch itself cannot start (usage, missing DIR or no scene, no \
                      device)."
    )]
    Batch {
        /// Directory searched for scenes.
        dir: PathBuf,
        /// Output directory (created if missing).
        #[arg(short, long = "output", value_name = "OUTDIR")]
        output: PathBuf,
        /// Scenes baked at the same time on the CPU path (the cores are divided between them
        /// unless --threads is given, and so is the memory budget; one job on all cores is
        /// usually fastest). With a GPU every scene runs on the one shared device, one at a
        /// time: --jobs is then ignored (one bake already fills the GPU, and two would need
        /// twice its memory).
        #[arg(short, long, value_name = "J", default_value_t = 1,
              value_parser = clap::value_parser!(u32).range(1..=256))]
        jobs: u32,
        /// Write a JSON report to REPORT (atomically): per scene the input, output, status
        /// (ok, skipped, failed, interrupted, not_started), error, times per phase, memory plan,
        /// parameters and output size; plus totals.
        #[arg(long, value_name = "REPORT")]
        json: Option<PathBuf>,
        /// Bake scenes whose output is up to date too.
        #[arg(long)]
        force: bool,
        /// Refuse scenes with no emitter, no light (sun, point, spot) and no --sky instead of lighting them with a
        /// white sky of radiance 1 (the batch default for --sky-if-unlit).
        #[arg(long)]
        no_default_sky: bool,
        /// Bake only shard I of N (1 ≤ I ≤ N): the scenes at positions I, I + N, I + 2N, … of
        /// the sorted list. The N shards partition DIR and every machine that sees the same
        /// DIR computes the same shards, so N independent jobs (a Slurm array, GNU parallel,
        /// a Kubernetes indexed Job) bake the whole folder between them with no coordination:
        /// `--shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT` with `--array=1-N`.
        #[arg(long, value_name = "I/N")]
        shard: Option<Shard>,
        #[command(flatten)]
        params: BakeArgs,
    },
    /// Compare a rendered image with a reference (both linear EXR of equal size, or both 8-bit
    /// sRGB PNG, compared as the linear values a display shows): MSE,
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
    /// Render an unbiased path-traced reference image (EXR) with the conventions of the shared
    /// Mitsuba references, to validate bakes without any other tool.
    Reference(ReferenceArgs),
    /// Speed against accuracy on one scene: bake over a grid of parameters, render one view of
    /// each, compare with a reference image; the path tracer's error-vs-time curve and the
    /// matrix radiosity baseline on the same view. Writes one CSV row per point (see
    /// docs/ACCURACY.md; `cargo xtask chart` runs it over the shared scenes and draws charts).
    Sweep(SweepArgs),
    /// Describe a light-field file: parameters, counts, memory by section, bake statistics.
    Info {
        /// The light-field file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Export a light-field file as a glTF binary with lightmaps for other engines: the scene's
    /// triangles with their lightmap coordinates in TEXCOORD_1, the diffuse atlas as irradiance
    /// packed into one or a few lightmap textures, materials carrying MOZ_lightmap (see
    /// docs/ENGINES.md). Mirror and glossy light is not exported.
    Export {
        /// The light-field file.
        file: PathBuf,
        /// Output glTF binary (.glb, written atomically).
        #[arg(short, long)]
        output: PathBuf,
        /// Lightmap encoding: exr (linear half float, with an RGBM PNG fallback), png-rgbm,
        /// ktx2 (not implemented: refused).
        #[arg(long, value_enum, default_value_t = TextureArg::Exr)]
        texture: TextureArg,
        /// Largest lightmap texture edge in texels; more charts go to further textures.
        #[arg(long, value_name = "N", default_value_t = vlf_core::export::DEFAULT_MAX_SIZE)]
        max_size: u32,
        /// The scene the light field was baked from (default: the source path the file records).
        #[arg(long, value_name = "SCENE.gltf")]
        scene: Option<PathBuf>,
        /// Print a JSON summary on stdout.
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

/// `vlf-bake export --texture`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TextureArg {
    Exr,
    PngRgbm,
    Ktx2,
}

/// `I/N`: shard I (1-based) of N (`vlf-bake batch --shard`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 1..=count.
    pub index: u32,
    pub count: u32,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected I/N with 1 ≤ I ≤ N (e.g. 2/4), got `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u32 = i.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// `WxH` image size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size(pub u32, pub u32);

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected WIDTHxHEIGHT (e.g. 256x256), got `{s}`");
        let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
        let w: u32 = w.trim().parse().map_err(|_| bad())?;
        let h: u32 = h.trim().parse().map_err(|_| bad())?;
        if w == 0 || h == 0 || w > 16_384 || h > 16_384 {
            return Err(format!(
                "image size {w}x{h} must be between 1 and 16384 on each side"
            ));
        }
        Ok(Size(w, h))
    }
}

/// `x,y,z` point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point(pub Vec3);

impl std::str::FromStr for Point {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let v: Result<Vec<f32>, _> = s.split(',').map(|x| x.trim().parse::<f32>()).collect();
        match v.as_deref() {
            Ok([x, y, z]) if [x, y, z].iter().all(|c| c.is_finite()) => {
                Ok(Point(Vec3::new(*x, *y, *z)))
            }
            _ => Err(format!("expected x,y,z (three finite numbers), got `{s}`")),
        }
    }
}

/// GPU kernel organisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum KernelArg {
    /// Generate / intersect / shade / shadow kernels per bounce over compacted ray queues.
    Wavefront,
    /// One invocation traces a whole path.
    Megakernel,
}

/// Arguments of `vlf-bake reference` (`crate::reference`).
#[derive(clap::Args, Debug, Clone)]
pub struct ReferenceArgs {
    /// The scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Output image: OpenEXR, float32 linear R, G, B, row 0 at the top (written atomically).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = 1024)]
    pub spp: u32,
    /// Index of the glTF camera to render from (default 0).
    #[arg(long, conflicts_with = "look_from")]
    pub camera: Option<usize>,
    /// Image size WIDTHxHEIGHT; the aspect ratio is width/height whatever the camera says.
    #[arg(long, default_value = "256x256")]
    pub size: Size,
    /// Constant sky radiance `R,G,B` (or one value) seen by rays that leave the scene.
    #[arg(long)]
    pub sky: Option<Rgb>,
    /// Ignore the meshes' NORMALs and shade every face flat (the shared references other than
    /// lamp-room are rendered so); by default NORMALs are shading normals.
    #[arg(long)]
    pub flat_normals: bool,
    /// Seed of the random streams (the image is deterministic for a given seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Eye position `x,y,z` of a look-at camera (for scenes without a glTF camera).
    #[arg(long, requires = "look_at")]
    pub look_from: Option<Point>,
    /// Target point `x,y,z` of the look-at camera.
    #[arg(long, requires = "look_from")]
    pub look_at: Option<Point>,
    /// Vertical field of view of the look-at camera, in degrees.
    #[arg(long, default_value_t = 60.0, requires = "look_from")]
    pub fov: f32,
    /// GPU kernel organisation (when the GPU is used).
    #[arg(long, value_enum, default_value_t = KernelArg::Wavefront)]
    pub gpu_kernel: KernelArg,
    /// Worker threads of the CPU path tracer (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Print a machine-readable JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// How many parameter sets to bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GridArg {
    /// The presets (draft, auto) and directions {126, 606} × resolution {32, 64}.
    Quick,
    /// Quick plus directions {246, 1126}, resolution 128, and variations of iterations,
    /// perturbed directions and tile size around the default.
    Full,
}

/// Arguments of `vlf-bake sweep` (`crate::sweep`).
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// The scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Reference image (linear EXR, e.g. from `vlf-bake reference` or ../shared/reference);
    /// every render is made at its size.
    #[arg(long)]
    pub reference: PathBuf,
    /// Output CSV (written atomically after every point).
    #[arg(long)]
    pub csv: PathBuf,
    /// Parameter grid.
    #[arg(long, value_enum, default_value_t = GridArg::Full)]
    pub grid: GridArg,
    /// Index of the glTF camera to render (default 0).
    #[arg(long, conflicts_with = "look_from")]
    pub camera: Option<usize>,
    /// Eye `x,y,z` of a look-at camera (world space, for scenes without a glTF camera).
    #[arg(long, requires = "look_at")]
    pub look_from: Option<Point>,
    /// Target `x,y,z` of the look-at camera.
    #[arg(long, requires = "look_from")]
    pub look_at: Option<Point>,
    /// Vertical field of view of the look-at camera, degrees.
    #[arg(long, default_value_t = 60.0, requires = "look_from")]
    pub fov: f32,
    /// Constant sky radiance `R,G,B` for the bakes, the path tracer and radiosity alike.
    #[arg(long)]
    pub sky: Option<Rgb>,
    /// Ignore the meshes' NORMALs: bakes and the path tracer shade every face flat.
    #[arg(long)]
    pub flat_normals: bool,
    /// Path tracer curve: 1, 2, 4, … up to this many samples per pixel (0: no path tracer).
    #[arg(long, default_value_t = 256)]
    pub spp_max: u32,
    /// Seed of the path tracer's curve (use one that differs from the reference's).
    #[arg(long, default_value_t = 1)]
    pub seed: u32,
    /// Jittered samples per pixel of the light-field renders (the reference's pixel is an
    /// average over the pixel square).
    #[arg(long, default_value_t = 16)]
    pub render_spp: u32,
    /// Also bake the high preset (slow; its numbers: docs/QUALITY.md).
    #[arg(long)]
    pub with_high: bool,
    /// Bake only the grid points with these labels (comma-separated, e.g. `auto,l=126 N=128`).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Skip the matrix radiosity baseline.
    #[arg(long)]
    pub no_radiosity: bool,
    /// Also write every rendered image as EXR and as a PNG preview (exposed so that the
    /// reference's mean luminance is 0.18, ACES tone map) into this directory.
    #[arg(long)]
    pub images: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sizes_and_points() {
        assert_eq!("256x128".parse::<Size>(), Ok(Size(256, 128)));
        assert_eq!("64×64".parse::<Size>(), Ok(Size(64, 64)));
        assert!("0x5".parse::<Size>().is_err());
        assert!("256".parse::<Size>().is_err());
        assert_eq!(
            "1,2.5,-3".parse::<Point>(),
            Ok(Point(Vec3::new(1.0, 2.5, -3.0)))
        );
        assert!("1,2".parse::<Point>().is_err());
        assert!("1,nan,2".parse::<Point>().is_err());
        assert_eq!("2/4".parse::<Shard>(), Ok(Shard { index: 2, count: 4 }));
        assert_eq!(" 1 / 1".parse::<Shard>(), Ok(Shard { index: 1, count: 1 }));
        for bad in ["0/4", "5/4", "1/0", "2", "a/b", "-1/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
