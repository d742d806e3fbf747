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

#[derive(Subcommand, Debug)]
pub enum Command {
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
