//! Command-line interface of `vlf-view`.

use clap::{Parser, ValueEnum};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "vlf-view",
    version,
    about = "Walk through a baked virtual light field, or render stills of it",
    long_about = "Walk through a baked virtual light field (.vlf), or render stills of it.\n\n\
                  Without --still or --bench-frames a window opens: WASD to move, Q/E down/up, \
                  Shift faster, drag with the left or right mouse button to look around, F1 \
                  hides the panel, F12 saves a screenshot (PNG). With --still OUT.exr|OUT.png \
                  one image is rendered headless (no window, no display needed): each pixel is \
                  the mean radiance of --spp stratified sub-pixel samples, linear RGB (EXR) or \
                  exposed, tonemapped sRGB (PNG). Exit codes: 0 success, 1 internal error, \
                  2 usage error, 3 bad input file, 4 no usable GPU device."
)]
pub struct Cli {
    /// The light field to show (.vlf, written by vlf-bake).
    #[arg(
        required_unless_present = "bake_preview",
        conflicts_with = "bake_preview"
    )]
    pub file: Option<PathBuf>,

    /// Development aid: bake this glTF scene with the CPU reference at tiny settings (46
    /// directions, 32×32 rays, 2 iterations; about a second) and show that instead of a .vlf.
    #[arg(long, value_name = "SCENE.gltf")]
    pub bake_preview: Option<PathBuf>,

    /// Render one still headless to OUT.exr (linear float RGB) or OUT.png (exposed, tonemapped,
    /// sRGB) and exit.
    #[arg(long, value_name = "OUT.exr|OUT.png", conflicts_with = "bench_frames")]
    pub still: Option<PathBuf>,

    /// glTF camera (index or name) for stills and the window's start view [default: 0; a view
    /// of the whole scene when the file has no camera].
    #[arg(long, value_name = "C", conflicts_with = "look_from")]
    pub camera: Option<String>,

    /// Eye `x,y,z` (world space) of a look-at camera, for scenes without a glTF camera (the
    /// view the shared references of such scenes were rendered from). Up is +Y.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, requires = "look_at", allow_hyphen_values = true)]
    pub look_from: Option<glam::Vec3>,

    /// Target `x,y,z` (world space) of the look-at camera.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, requires = "look_from", allow_hyphen_values = true)]
    pub look_at: Option<glam::Vec3>,

    /// Vertical field of view of the look-at camera, degrees.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 60.0,
        requires = "look_from"
    )]
    pub fov: f32,

    /// Image / window size in pixels [default: 512x512 for stills, 1024x768 otherwise].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,

    /// Samples per pixel of a still (stratified, box-filtered).
    #[arg(long, value_name = "S", default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub spp: u32,

    /// Exposure in stops (radiance × 2^E) for PNG output and the window; EXR stays linear.
    #[arg(
        long,
        value_name = "E",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub exposure: f32,

    /// Tone curve for PNG output and the window.
    #[arg(long, value_enum, default_value_t = TonemapArg::Clamp)]
    pub tonemap: TonemapArg,

    /// Mirror and mixed faces trace their reflection through the scene (on; glossy metals
    /// trace 4 directions of their GGX lobe per sample) or read their baked tiles (off):
    /// stills, --bench-frames and the window's start state (its panel has the switch).
    #[arg(long, value_enum, value_name = "on|off", default_value_t = OnOffArg::On)]
    pub mirror_tracing: OnOffArg,

    /// Show (or write, with --still) a pass output instead of the final image.
    #[arg(long, value_enum, default_value_t = DebugViewArg::FinalRadiance)]
    pub debug_view: DebugViewArg,

    /// Window: render this many frames, then exit (with --screenshot: save it first). For CI.
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,

    /// With --frames: where the window saves its screenshot (PNG) before exiting.
    #[arg(long, value_name = "OUT.png", requires = "frames")]
    pub screenshot: Option<PathBuf>,

    /// Headless benchmark: render N interactive frames (the five passes + display, one sample
    /// per pixel) at --size along a recorded camera path (a full turn in place from --camera),
    /// print frame times (median and spread) and GPU pass times, and exit.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub bench_frames: Option<u32>,

    /// More log output (-v: info, -vv: debug, -vvv: trace). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count)]
    pub verbose: u8,

    /// Only errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `x,y,z`: three finite numbers.
fn parse_point(s: &str) -> Result<glam::Vec3, String> {
    let v: Result<Vec<f32>, _> = s.split(',').map(|x| x.trim().parse::<f32>()).collect();
    match v.as_deref() {
        Ok([x, y, z]) if [x, y, z].iter().all(|c| c.is_finite()) => Ok(glam::Vec3::new(*x, *y, *z)),
        _ => Err(format!("expected x,y,z (three finite numbers), got `{s}`")),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOffArg {
    On,
    Off,
}

impl From<OnOffArg> for bool {
    fn from(v: OnOffArg) -> bool {
        v == OnOffArg::On
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TonemapArg {
    /// Linear, clamped to [0, 1].
    Clamp,
    /// Fitted ACES filmic curve (as HDR-FLIP uses).
    Aces,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DebugViewArg {
    DirectionIds,
    Barycentrics,
    FaceId,
    Position,
    FinalRadiance,
}

impl From<DebugViewArg> for vlf_gpu::render::Pass {
    fn from(v: DebugViewArg) -> Self {
        use vlf_gpu::render::Pass;
        match v {
            DebugViewArg::DirectionIds => Pass::DirectionIds,
            DebugViewArg::Barycentrics => Pass::Barycentrics,
            DebugViewArg::FaceId => Pass::FaceId,
            DebugViewArg::Position => Pass::Position,
            DebugViewArg::FinalRadiance => Pass::FinalRadiance,
        }
    }
}

/// Parses `WxH`, e.g. `1024x768`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WxH (e.g. 1024x768), got {s:?}"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| (1..=16384).contains(&n))
            .ok_or_else(|| format!("{v:?} is not a size in 1..=16384"))
    };
    Ok((parse(w)?, parse(h)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("1024x768"), Ok((1024, 768)));
        assert_eq!(parse_size("64X32"), Ok((64, 32)));
        assert!(parse_size("0x10").is_err());
        assert!(parse_size("64").is_err());
    }

    #[test]
    fn file_or_preview_is_required() {
        assert!(Cli::try_parse_from(["vlf-view"]).is_err());
        assert!(Cli::try_parse_from(["vlf-view", "a.vlf", "--bake-preview", "b.gltf"]).is_err());
        let cli =
            Cli::try_parse_from(["vlf-view", "a.vlf", "--still", "o.png", "--exposure", "-2"])
                .unwrap();
        assert_eq!(cli.exposure, -2.0);
        assert_eq!(cli.mirror_tracing, OnOffArg::On);
        let cli = Cli::try_parse_from([
            "vlf-view",
            "a.vlf",
            "--still",
            "o.exr",
            "--mirror-tracing",
            "off",
        ])
        .unwrap();
        assert!(!bool::from(cli.mirror_tracing));
        assert!(Cli::try_parse_from(["vlf-view", "a.vlf", "--screenshot", "s.png"]).is_err());
    }
}
