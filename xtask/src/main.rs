//! Project chores, run as `cargo xtask <task>`.
//!

mod assets;
mod browser;
mod chart;
mod ci;
mod codemap;
mod gpu_timing;
mod lengths;
mod modgraph;
mod one_home;
mod validate;

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};

const USAGE: &str = "usage: cargo xtask <task>

tasks:
  ci            the whole test suite: rustfmt, module layers, clippy, all tests, asset checks,
                gpu-timing --quick, the browser check (what .ci/run runs)
  browser       the glTF export (vlf-bake export) validated and rendered in headless chromium,
                compared with vlf-view's still (needs node/npm and chromium)
  demo          the main job on the bundled Cornell box
  bench [--quick]  bake benchmarks (release build) → docs/bench/bake.csv
  gpu-timing [--quick] [--frames N] [--size WxH] [--scene SCENE]  the Cornell box baked on the
                GPU and CPU paths and its walkthrough benchmarked (release build), with the
                adapter's name and driver: the figures to take when a GPU is lent
  chart [--quick] [--redraw] [SCENE...]  speed against accuracy on the shared scenes: references,
                `vlf-bake sweep`, SVG charts and summary → docs/bench/chart/
  assets        regenerate the Cornell box scenes under assets/
  check-assets  fail if assets/ is stale, then run Khronos glTF-Validator on it
  validate-gltf FILE...  run Khronos glTF-Validator on the given files
  check-modules  fail on an import cycle between vlf-core's modules (print their layers), on
                 wgpu boilerplate outside vlf-gpu's wgpu_util.rs, or where the code map of
                 docs/ARCHITECTURE.md and the crates' modules disagree
  check-lengths  fail on a non-test source file over 800 lines under crates/ and xtask/";

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives one level below the repository root")
        .to_path_buf()
}

fn main() -> Result<()> {
    let root = repo_root();
    let task = std::env::args().nth(1);
    match task.as_deref() {
        Some("assets") => {
            for path in assets::generate(&root.join("assets"))? {
                println!("wrote {}", path.display());
            }
        }
        Some("check-assets") => {
            assets::check(&root)?;
            println!("assets/ is up to date");
            validate::validate_gltf(&root, &assets::asset_files(&root.join("assets")))?;
        }
        Some("validate-gltf") => {
            let files: Vec<PathBuf> = std::env::args_os().skip(2).map(PathBuf::from).collect();
            if files.is_empty() {
                bail!("{USAGE}");
            }
            validate::validate_gltf(&root, &files)?;
        }
        Some("check-modules") => {
            print!("{}", modgraph::check(&root, Path::new(ci::LAYERED_CRATE))?);
            let n = one_home::check(&root)?;
            println!("vlf-gpu: wgpu boilerplate only in wgpu_util.rs ({n} files read)");
            println!("{}", codemap::check(&root)?);
        }
        Some("check-lengths") => {
            let n = lengths::check(&root)?;
            println!("{n} source files, none over {} lines", lengths::MAX_LINES);
        }
        Some("ci") => ci::ci(&root)?,
        Some("browser") => browser::browser(&root)?,
        Some("demo") => ci::demo(&root)?,
        Some("bench") => ci::bench(&root, std::env::args().any(|a| a == "--quick"))?,
        Some("gpu-timing") => {
            gpu_timing::gpu_timing(&root, &std::env::args().skip(2).collect::<Vec<_>>())?
        }
        Some("chart") => chart::chart(&root, &std::env::args().skip(2).collect::<Vec<_>>())?,
        Some("-h" | "--help" | "help") => println!("{USAGE}"),
        _ => bail!("{USAGE}"),
    }
    Ok(())
}
