//! `cargo xtask ci`: the whole test suite, exactly what `.ci/run` and the README run (the GPU
//! timing script among its steps, with small sizes: `crate::gpu_timing`).
//! `cargo xtask demo`: the main job on the bundled default scene.

use anyhow::{Context, Result, bail};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The crate whose module graph `ci` checks for import cycles (`cargo xtask check-modules`).
pub const LAYERED_CRATE: &str = "crates/vlf-core/src";

/// Runs one step, echoing it and its duration; fails naming the step.
pub fn step(name: &str, cmd: &mut Command) -> Result<()> {
    eprintln!("==> {name}: {cmd:?}");
    let t = Instant::now();
    let status = cmd
        .status()
        .with_context(|| format!("cannot start {name}"))?;
    eprintln!("<== {name}: {:.1} s", t.elapsed().as_secs_f64());
    if !status.success() {
        bail!("{name} failed ({status})");
    }
    Ok(())
}

pub fn cargo(root: &Path) -> Command {
    command(
        std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()),
        root,
    )
}

/// `program` run in `root`, with the environment every step gets.
pub fn command(program: impl AsRef<std::ffi::OsStr>, root: &Path) -> Command {
    let mut c = Command::new(program);
    c.current_dir(root);
    // A writable runtime dir silences winit/Mesa warnings under a bare root shell.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        let dir = std::env::temp_dir().join("vlf-xdg-runtime");
        if std::fs::create_dir_all(&dir).is_ok() {
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
            }
            c.env("XDG_RUNTIME_DIR", dir);
        }
    }
    c
}

/// Cargo's target directory: `CARGO_TARGET_DIR` (relative to `root`) or `root/target`.
pub fn target_dir(root: &Path) -> std::path::PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) if !d.is_empty() => root.join(d),
        _ => root.join("target"),
    }
}

pub fn ci(root: &Path) -> Result<()> {
    let t = Instant::now();
    if std::env::var("VLF_REQUIRE_GPU").as_deref() != Ok("1") {
        eprintln!(
            "note: VLF_REQUIRE_GPU is not 1: GPU tests will be skipped (not failed) if no adapter is found"
        );
    }
    step("rustfmt", cargo(root).args(["fmt", "--all", "--check"]))?;
    eprintln!("==> module layers");
    eprint!(
        "{}",
        crate::modgraph::check(root, Path::new(LAYERED_CRATE))?
    );
    crate::one_home::check(root)?;
    eprintln!("{}", crate::codemap::check(root)?);
    eprintln!("==> source file lengths");
    let n = crate::lengths::check(root)?;
    eprintln!(
        "{n} source files, none over {} lines",
        crate::lengths::MAX_LINES
    );
    step(
        "clippy",
        cargo(root).args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]),
    )?;
    let (passed, failed, ignored) = test_step(root)?;
    crate::assets::check(root)?;
    crate::validate::validate_gltf(root, &crate::assets::asset_files(&root.join("assets")))?;
    eprintln!("==> gpu-timing --quick (the GPU timing script, small sizes)");
    crate::gpu_timing::gpu_timing(root, &["--quick".into()])?;
    let t_browser = Instant::now();
    eprintln!("==> browser (glTF export in headless chromium)");
    crate::browser::browser(root)?;
    eprintln!("<== browser: {:.1} s", t_browser.elapsed().as_secs_f64());
    eprintln!("ci: all steps passed in {:.0} s", t.elapsed().as_secs_f64());
    // One closing line for the whole suite (cargo prints one per test binary).
    println!("ci: {passed} passed, {failed} failed, {ignored} skipped");
    Ok(())
}

/// Runs `cargo test --workspace --no-fail-fast`, echoing its output, and sums the per-binary
/// "test result" lines.
fn test_step(root: &Path) -> Result<(u64, u64, u64)> {
    use std::io::{BufRead, BufReader};
    let mut cmd = cargo(root);
    cmd.args(["test", "--workspace", "--no-fail-fast"])
        .stdout(std::process::Stdio::piped());
    eprintln!("==> tests: {cmd:?}");
    let t = Instant::now();
    let mut child = cmd.spawn().context("cannot start tests")?;
    let out = child.stdout.take().context("no stdout")?;
    let (mut passed, mut failed, mut ignored) = (0u64, 0u64, 0u64);
    for line in BufReader::new(out).lines() {
        let line = line?;
        println!("{line}");
        if let Some(rest) = line.strip_prefix("test result: ") {
            let num = |key: &str| -> u64 {
                rest.split(';')
                    .find(|p| p.trim_end().ends_with(key))
                    .and_then(|p| p.split_whitespace().rev().nth(1)?.parse().ok())
                    .unwrap_or(0)
            };
            passed += num("passed");
            failed += num("failed");
            ignored += num("ignored");
        }
    }
    let status = child.wait()?;
    eprintln!("<== tests: {:.1} s", t.elapsed().as_secs_f64());
    if !status.success() {
        println!("ci: {passed} passed, {failed} failed, {ignored} skipped");
        bail!("tests failed ({status})");
    }
    Ok((passed, failed, ignored))
}

/// The main job on the bundled default scene: bake the Cornell box, render stills from its
/// camera (PNG to look at, EXR with linear radiance), and compare with the path-traced
/// reference when `../shared/reference` is there.
pub fn demo(root: &Path) -> Result<()> {
    let scene = root.join("assets/cornell-box/cornell-box.gltf");
    let out = root.join("out");
    std::fs::create_dir_all(&out)?;
    let vlf = out.join("cornell-box.vlf");
    let s = |p: &Path| p.to_str().map(str::to_owned).context("non-UTF-8 path");
    // Both binaries in one cargo invocation (one dependency graph, both linked in parallel),
    // in the release profile: the bake runs several times faster than in the dev profile, and
    // the build costs about the same since the dev profile optimises dependencies too.
    step(
        "build vlf-bake and vlf-view (release)",
        cargo(root).args(["build", "--release", "-p", "vlf-bake", "-p", "vlf-view"]),
    )?;
    let bin = target_dir(root).join("release");
    let run = |name: &str, args: &[String]| {
        let exe = format!("{name}{}", std::env::consts::EXE_SUFFIX);
        let mut c = command(bin.join(exe), root);
        c.args(args);
        c
    };
    step(
        "bake the Cornell box (default quality)",
        &mut run(
            "vlf-bake",
            &["bake".into(), s(&scene)?, "-o".into(), s(&vlf)?],
        ),
    )?;
    step(
        "describe the light field",
        &mut run("vlf-bake", &["info".into(), s(&vlf)?]),
    )?;
    let png = out.join("cornell-box.png");
    let exr = out.join("cornell-box-256.exr");
    step(
        "render a still from the scene's camera",
        &mut run(
            "vlf-view",
            &[
                s(&vlf)?,
                "--still".into(),
                s(&png)?,
                "--camera".into(),
                "0".into(),
                "--size".into(),
                "512x512".into(),
                "--spp".into(),
                "16".into(),
            ],
        ),
    )?;
    step(
        "render the reference's view as linear EXR",
        &mut run(
            "vlf-view",
            &[
                s(&vlf)?,
                "--still".into(),
                s(&exr)?,
                "--camera".into(),
                "0".into(),
                "--size".into(),
                "256x256".into(),
                "--spp".into(),
                "16".into(),
            ],
        ),
    )?;
    let reference = root.join("../shared/reference/cornell-ref.exr");
    if reference.exists() {
        step(
            "compare with the path-traced reference (Mitsuba 3, 12,288 spp)",
            &mut run(
                "vlf-bake",
                &[
                    "compare".into(),
                    s(&exr)?,
                    s(&reference)?,
                    "--diff".into(),
                    s(&out.join("cornell-box-error.png"))?,
                ],
            ),
        )?;
    }
    eprintln!(
        "demo: open {} to see the result (light field: {})",
        png.display(),
        vlf.display()
    );
    Ok(())
}

/// Bake benchmarks in a release build; the CSV lands in docs/bench/ with the adapter in it.
pub fn bench(root: &Path, quick: bool) -> Result<()> {
    let dir = root.join("docs/bench");
    std::fs::create_dir_all(&dir)?;
    let out = dir.join(if quick { "bake-quick.csv" } else { "bake.csv" });
    let mut c = cargo(root);
    c.args([
        "run",
        "--release",
        "-p",
        "vlf-gpu",
        "--example",
        "bake_bench",
        "--",
    ])
    .arg("--out")
    .arg(&out);
    if quick {
        c.arg("--quick");
    }
    step("bake benchmark", &mut c)?;
    eprintln!("wrote {}", out.display());
    Ok(())
}
