//! `cargo xtask gpu-timing [--quick] [--frames N] [--size WxH] [--scene SCENE]`: the bake and
//! the walkthrough timed on whatever adapter the machine has, for the figures a hardware GPU
//! gives (`docs/PERFORMANCE.md`, "Timing on a GPU"). Bakes the Cornell box on the GPU
//! path (`--device gpu`) and on the CPU path (`--device cpu`), renders `--bench-frames` of the
//! GPU bake at 1024×768, and prints a short table with the adapter and its driver, next to the
//! paper's marks (Cornell box baked in 4.07 s, 121 fps at 1024×768 on an 8800 GTX).
//!
//! By default the release binaries and the default quality; `--quick` (the step of `cargo
//! xtask ci`) takes the binaries the test step built, a draft bake and a few small frames, so
//! that it checks the script end to end in seconds, not the figures.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::ci::{cargo, command, step, target_dir};

/// The paper's figures (VLF 2004, Cornell box on an 8800 GTX).
const PAPER_BAKE_S: f64 = 4.07;
const PAPER_FPS: f64 = 121.0;

/// What to time.
struct Options {
    quick: bool,
    frames: u32,
    size: String,
    scene: PathBuf,
}

impl Options {
    fn parse(root: &Path, args: &[String]) -> Result<Self> {
        let quick = args.iter().any(|a| a == "--quick");
        let mut o = Options {
            quick,
            frames: if quick { 5 } else { 200 },
            size: if quick { "256x192" } else { "1024x768" }.into(),
            scene: root.join("assets/cornell-box/cornell-box.gltf"),
        };
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut value = || it.next().with_context(|| format!("{a} needs a value"));
            match a.as_str() {
                "--quick" => {}
                "--frames" => o.frames = value()?.parse().context("--frames")?,
                "--size" => o.size = value()?.clone(),
                "--scene" => o.scene = PathBuf::from(value()?),
                _ => bail!(
                    "unknown argument {a}: cargo xtask gpu-timing [--quick] [--frames N] \
                     [--size WxH] [--scene SCENE]"
                ),
            }
        }
        Ok(o)
    }
}

/// One bake's figures, from `vlf-bake --json`.
struct Bake {
    device: String,
    adapter: String,
    total_s: f64,
    propagate_s: f64,
    /// `gpu_propagation` of the report (GPU path only).
    gpu: Option<serde_json::Value>,
}

pub fn gpu_timing(root: &Path, args: &[String]) -> Result<()> {
    let o = Options::parse(root, args)?;
    let bin = if o.quick {
        // The binaries as the test step builds them (a no-op after it, as in `browser`).
        step(
            "build vlf-bake and vlf-view (test profile)",
            cargo(root).args(["test", "--workspace", "--no-run", "--quiet"]),
        )?;
        target_dir(root).join("debug")
    } else {
        step(
            "build vlf-bake and vlf-view (release)",
            cargo(root).args(["build", "--release", "-p", "vlf-bake", "-p", "vlf-view"]),
        )?;
        target_dir(root).join("release")
    };
    let exe = |name: &str| bin.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    let out = target_dir(root).join("gpu-timing");
    std::fs::create_dir_all(&out)?;
    let scene = o.scene.to_str().context("non-UTF-8 scene path")?;
    let quality = if o.quick { "draft" } else { "auto" };

    let bake = |device: &str| -> Result<Bake> {
        let vlf = out.join(format!("{device}.vlf"));
        let mut c = command(exe("vlf-bake"), root);
        c.args([
            "-q",
            "bake",
            scene,
            "--quality",
            quality,
            "--device",
            device,
        ])
        .arg("-o")
        .arg(&vlf)
        .arg("--json");
        let report = run(&format!("bake on the {device} path"), &mut c)?;
        let v: serde_json::Value = serde_json::from_str(&report)
            .with_context(|| format!("vlf-bake --json printed no JSON: {report}"))?;
        let text = |k: &str| v[k].as_str().map(str::to_owned);
        Ok(Bake {
            device: text("device").context("no device in the bake report")?,
            adapter: text("adapter").unwrap_or_default(),
            total_s: v["total_s"]
                .as_f64()
                .context("no total_s in the bake report")?,
            propagate_s: v["phases_s"]
                .as_array()
                .and_then(|p| p.iter().find(|x| x[0] == "propagate"))
                .and_then(|x| x[1].as_f64())
                .context("no propagate phase in the bake report")?,
            gpu: Some(v["gpu_propagation"].clone()).filter(|g| !g.is_null()),
        })
    };
    let gpu = bake("gpu")?;
    let cpu = bake("cpu")?;
    if gpu.device != "gpu" {
        bail!("--device gpu baked on the {} path", gpu.device);
    }

    let mut c = command(exe("vlf-view"), root);
    c.arg(out.join("gpu.vlf"))
        .args(["--bench-frames", &o.frames.to_string(), "--size", &o.size]);
    let bench = run("walkthrough benchmark", &mut c)?;
    let (adapter, median_ms) = parse_bench(&bench)
        .with_context(|| format!("unexpected vlf-view --bench-frames output: {bench}"))?;

    println!("gpu-timing: {} ({quality} quality)", o.scene.display());
    println!("adapter (driver): {adapter}");
    if !adapter.starts_with(&gpu.adapter) {
        println!("the GPU bake's adapter: {}", gpu.adapter);
    }
    println!("| what | this machine | paper (8800 GTX) |");
    println!("|---|---|---|");
    println!(
        "| bake, GPU path | {:.2} s | {PAPER_BAKE_S} s |",
        gpu.total_s
    );
    println!("| bake, CPU path | {:.2} s | |", cpu.total_s);
    println!(
        "| propagation, GPU path / CPU path | {:.2} s / {:.2} s | |",
        gpu.propagate_s, cpu.propagate_s
    );
    println!(
        "| walkthrough {}, median of {} frames | {median_ms:.2} ms ({:.0} fps) | {:.2} ms ({PAPER_FPS} fps) |",
        o.size,
        o.frames,
        1000.0 / median_ms,
        1000.0 / PAPER_FPS
    );
    println!("per pass: {}", bench.lines().nth(1).unwrap_or("").trim());
    let g = gpu
        .gpu
        .as_ref()
        .context("the GPU bake's report has no gpu_propagation")?;
    println!("{}", propagation_summary(g)?);
    if o.quick {
        println!("(--quick: small sizes, the script checked end to end; not the figures)");
    }
    Ok(())
}

/// The GPU propagation's counts per iteration (the most over the iterations) and its device
/// time per pass, from the report's `gpu_propagation`.
fn propagation_summary(g: &serde_json::Value) -> Result<String> {
    let m = &g["max_per_iteration"];
    let d = m["dispatches"]
        .as_object()
        .context("no dispatches in gpu_propagation")?;
    let dispatches: Vec<String> = d.iter().map(|(k, v)| format!("{k} {v}")).collect();
    let mut out = format!(
        "GPU propagation per iteration (most): dispatches {}; {} submit(s), {} host wait(s), {} bytes read back; {} direction(s) per dispatch",
        dispatches.join(", "),
        m["submits"],
        m["waits"],
        m["readback_bytes"],
        g["directions_per_dispatch"],
    );
    if g["timestamps"].as_bool() == Some(true) {
        let times: Vec<String> = g["device_ms"]
            .as_array()
            .context("no device_ms in gpu_propagation")?
            .iter()
            .map(|p| {
                format!(
                    "{} {:.1} ms",
                    p[0].as_str().unwrap_or("?"),
                    p[1].as_f64().unwrap_or(0.0)
                )
            })
            .collect();
        out += &format!(
            "\nGPU propagation device time (timestamp queries, all iterations): {}",
            times.join(", ")
        );
    } else {
        out += "\nGPU propagation device time: the adapter has no timestamp queries";
    }
    Ok(out)
}

/// Runs `cmd`, echoing it on stderr, and returns its stdout; fails naming `name`.
fn run(name: &str, cmd: &mut Command) -> Result<String> {
    eprintln!("==> {name}: {cmd:?}");
    let output = cmd
        .output()
        .with_context(|| format!("cannot start {name}"))?;
    if !output.status.success() {
        bail!(
            "{name} failed ({}): {}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
    }
    Ok(String::from_utf8(output.stdout)?)
}

/// The adapter and the median frame time of `vlf-view --bench-frames`'s first line
/// ("N frames at W×H on ADAPTER, mirror tracing …: mean … ms, median M ms, …").
fn parse_bench(out: &str) -> Option<(String, f64)> {
    let line = out.lines().next()?;
    let adapter = line
        .split_once(" on ")?
        .1
        .rsplit_once(", mirror tracing")?
        .0;
    let median = line.split_once("median ")?.1.split_once(" ms")?.0;
    Some((adapter.to_owned(), median.parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::parse_bench;

    #[test]
    fn reads_the_adapter_and_median_of_a_bench_report() {
        let out = "40 frames at 1024×768 on llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, \
                   llvmpipe Mesa 22.3.6 (LLVM 15.0.6)), mirror tracing off: mean 45.10 ms, \
                   median 41.25 ms, min 30.00 ms, max 60.00 ms (22.2 fps)\nGPU pass times";
        let (adapter, median) = parse_bench(out).unwrap();
        assert_eq!(
            adapter,
            "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, llvmpipe Mesa 22.3.6 (LLVM 15.0.6))"
        );
        assert_eq!(median, 41.25);
        assert_eq!(parse_bench("no report"), None);
    }
}
