//! End-to-end tests of the `vlf-bake` binary on the CPU path (`--device cpu`, tiny parameters):
//! subcommands, exit codes, `batch` (failures, skipping, `--force`, report, Ctrl-C), the memory
//! budget, reproducibility, and atomic writes under SIGKILL; and one `batch` on the GPU
//! (skipped without an adapter under the suite's policy, `vlf_tests::gpu`).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Fast parameters: the whole bake of a Cornell box takes milliseconds.
const TINY: [&str; 10] = [
    "--device",
    "cpu",
    "--directions",
    "6",
    "--resolution",
    "8",
    "--tile",
    "4",
    "--iterations",
    "1",
];

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vlf-bake"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("vlf-bake runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn asset(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets")
        .join(rel)
}

fn box_scene() -> PathBuf {
    asset("cornell-box/cornell-box.gltf")
}

fn mirror_scene() -> PathBuf {
    asset("cornell-mirror/cornell-mirror.gltf")
}

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vlf-bake-cli-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

fn code(o: &Output) -> i32 {
    o.status.code().expect("exited normally")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&fs::read(path).unwrap()).expect("valid JSON")
}

#[test]
fn help_lists_the_subcommands_and_exit_codes() {
    let o = run(&["--help"]);
    assert_eq!(code(&o), 0);
    let out = text(&o.stdout);
    for sub in ["bake", "batch", "info", "inspect", "compare", "selftest"] {
        assert!(
            out.lines()
                .any(|l| l.trim_start().starts_with(&format!("{sub} "))),
            "`{sub}` missing from --help:\n{out}"
        );
    }
    for code in [
        "3 bad input file",
        "5 batch",
        "6 the bake does not fit",
        "130 interrupted",
    ] {
        assert!(out.contains(code), "exit code `{code}` not documented");
    }
    let o = run(&["batch", "--help"]);
    assert_eq!(code(&o), 0);
    let out = text(&o.stdout);
    for opt in [
        "--jobs",
        "--json",
        "--force",
        "--max-memory",
        "--resolution",
    ] {
        assert!(out.contains(opt), "`batch --help` lacks {opt}");
    }
}

#[test]
fn bake_writes_a_file_that_info_describes() {
    let d = scratch("bake-info");
    let out = d.join("box.vlf");
    let scene = box_scene();
    let mut args = vec!["bake", s(&scene), "-o", s(&out), "-q"];
    args.extend(TINY);
    let o = run(&args);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let o = run(&["info", s(&out), "--json"]);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["params"]["resolution"], 8);
    assert_eq!(info["params"]["tile"], 4);
    assert_eq!(info["directions"], 6);
    assert_eq!(info["file_bytes"], fs::metadata(&out).unwrap().len());
    assert_eq!(info["stats"]["device"], "cpu");
    vlf_core::format::read(&out).expect("the file reads back");
    let _ = fs::remove_dir_all(&d);
}

/// `--denoise oidn` needs a build with the `oidn` feature (docs/GATHER.md, "OIDN's lightmap
/// filter"): without it the bake is refused before it starts, naming the feature (bad input,
/// exit 3); with it the file records the denoiser that ran.
#[test]
fn denoise_oidn_needs_a_build_with_oidn_and_is_recorded() {
    let d = scratch("oidn");
    let out = d.join("box.vlf");
    let scene = box_scene();
    let mut args = vec!["bake", s(&scene), "-o", s(&out), "--denoise", "oidn"];
    args.extend(TINY);
    let o = run(&args);
    if cfg!(feature = "oidn") {
        assert_eq!(code(&o), 0, "{}", text(&o.stderr));
        let o = run(&["info", s(&out), "--json"]);
        let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(info["params"]["final_gather"]["denoise"], "oidn");
        let o = run(&["info", s(&out)]);
        assert!(text(&o.stdout).contains("atlas denoiser OIDN RTLightmap"));
    } else {
        assert_eq!(code(&o), 3, "{}", text(&o.stderr));
        let err = text(&o.stderr);
        assert!(
            err.contains("denoise = oidn: this build has no Intel Open Image Denoise")
                && err.contains("--features oidn"),
            "{err}"
        );
        assert!(!out.exists(), "nothing written");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn bake_json_includes_the_memory_plan() {
    let d = scratch("bake-json");
    let out = d.join("m.vlf");
    let scene = mirror_scene();
    let mut args = vec!["bake", s(&scene), "-o", s(&out), "--json"];
    args.extend(TINY);
    let o = run(&args);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let plan = &r["memory"]["plan"];
    assert_eq!(plan["path"], "cpu");
    assert_eq!(plan["resolution"], 8);
    assert!(plan["host_bytes"].as_u64().unwrap() > 0);
    assert!(
        plan["tile_values"].as_u64().unwrap() > 0,
        "mirror tiles planned"
    );
    assert!(plan["k_max"].as_u64().unwrap() >= 1);
    assert!(plan["items"].as_array().unwrap().len() > 5);
    assert_eq!(plan["over_budget"].as_array().unwrap().len(), 0);
    assert_eq!(
        r["gather"]["device"], "cpu",
        "the CPU path gathers on the CPU"
    );
    // How each material's metal lobe is baked (issue 16).
    let models: Vec<_> = r["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["model"].as_str().unwrap())
        .collect();
    assert!(
        models.contains(&"mirror") && models.contains(&"none"),
        "{models:?}"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn bad_input_exits_3_naming_the_file() {
    let d = scratch("bad-input");
    let bad = d.join("broken.gltf");
    fs::write(&bad, "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [").unwrap();
    let out = d.join("broken.vlf");
    let mut args = vec!["bake", s(&bad), "-o", s(&out)];
    args.extend(TINY);
    let o = run(&args);
    assert_eq!(code(&o), 3, "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains(s(&bad)), "{}", text(&o.stderr));
    assert!(!out.exists());
    let missing = d.join("missing.gltf");
    let mut args = vec!["bake", s(&missing), "-o", s(&out)];
    args.extend(TINY);
    let o = run(&args);
    assert_eq!(code(&o), 3);
    assert!(text(&o.stderr).contains(s(&missing)));
    // A corrupt light-field file too.
    let o = run(&["info", s(&bad)]);
    assert_eq!(code(&o), 3);
    assert!(text(&o.stderr).contains(s(&bad)));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn batch_keeps_going_reports_failures_skips_and_forces() {
    let d = scratch("batch");
    let scenes = d.join("scenes");
    fs::create_dir_all(scenes.join("sub")).unwrap();
    fs::copy(box_scene(), scenes.join("box.gltf")).unwrap();
    fs::copy(mirror_scene(), scenes.join("sub/mirror.gltf")).unwrap();
    fs::write(scenes.join("sub/corrupt.gltf"), "not json at all").unwrap();
    fs::write(scenes.join("notes.txt"), "ignored").unwrap();
    let out = d.join("out");
    let report = d.join("report.json");
    let batch = |extra: &[&str]| {
        let mut args = vec!["batch", s(&scenes), "-o", s(&out), "--json", s(&report)];
        args.extend(TINY);
        args.extend(extra);
        run(&args)
    };

    let o = batch(&["--jobs", "2"]);
    assert_eq!(code(&o), 5, "a failed scene gives exit code 5");
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert!(stderr.contains("corrupt.gltf"), "{stderr}");
    assert!(stdout.contains("ok       box.gltf"), "{stdout}");
    assert!(stdout.contains("ok       sub/mirror.gltf"), "{stdout}");
    let r = json(&report);
    assert_eq!(r["finished"], true);
    assert_eq!(r["totals"]["scenes"], 3);
    assert_eq!(r["totals"]["ok"], 2);
    assert_eq!(r["totals"]["failed"], 1);
    let by_name = |r: &serde_json::Value, name: &str| {
        r["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["relative"] == name)
            .unwrap_or_else(|| panic!("{name} not in the report"))
            .clone()
    };
    let bad = by_name(&r, "sub/corrupt.gltf");
    assert_eq!(bad["status"], "failed");
    assert_eq!(bad["error_code"], 3);
    assert!(bad["error"].as_str().unwrap().contains("corrupt.gltf"));
    let good = by_name(&r, "sub/mirror.gltf");
    assert_eq!(good["status"], "ok");
    assert!(good["output_bytes"].as_u64().unwrap() > 0);
    assert!(good["phases_s"]["propagate"].as_f64().is_some());
    assert!(good["memory"]["plan"]["host_bytes"].as_u64().unwrap() > 0);
    assert_eq!(good["params"]["resolution"], 8);
    let box_out = out.join("box.vlf");
    let mirror_out = out.join("sub/mirror.vlf");
    vlf_core::format::read(&box_out).unwrap();
    vlf_core::format::read(&mirror_out).unwrap();
    assert!(!out.join("sub/corrupt.vlf").exists());
    let first = (fs::read(&box_out).unwrap(), fs::read(&mirror_out).unwrap());

    // The same bake through `bake` gives the same bytes (jobs do not change results).
    let single = d.join("single.vlf");
    let scene_box = scenes.join("box.gltf");
    let mut args = vec!["bake", "-q", s(&scene_box), "-o", s(&single)];
    args.extend(TINY);
    assert_eq!(code(&run(&args)), 0);
    assert_eq!(fs::read(&single).unwrap(), first.0);

    // Second run: both good scenes are up to date.
    let o = batch(&[]);
    assert_eq!(code(&o), 5);
    let r = json(&report);
    assert_eq!(r["totals"]["skipped"], 2, "{}", text(&o.stdout));
    assert_eq!(r["totals"]["ok"], 0);
    assert_eq!(by_name(&r, "box.gltf")["status"], "skipped");
    assert!(text(&o.stdout).contains("skipped  sub/mirror.gltf"));

    // Other parameters are not up to date.
    let mut other: Vec<&str> = TINY.to_vec();
    other[3] = "21";
    let mut args = vec!["batch", s(&scenes), "-o", s(&out), "--json", s(&report)];
    args.extend(other);
    let o = run(&args);
    assert_eq!(code(&o), 5);
    let r = json(&report);
    assert_eq!(r["totals"]["ok"], 2, "changed parameters rebake");
    assert_eq!(
        by_name(&r, "box.gltf")["reason"],
        "existing output baked with other parameters"
    );

    // --force bakes them again, and gives the same files as the first run.
    let o = batch(&["--force"]);
    assert_eq!(code(&o), 5);
    let r = json(&report);
    assert_eq!(r["totals"]["ok"], 2);
    assert_eq!(r["totals"]["skipped"], 0);
    assert_eq!(fs::read(&box_out).unwrap(), first.0);
    assert_eq!(fs::read(&mirror_out).unwrap(), first.1);

    // Without the corrupt scene the batch succeeds.
    fs::remove_file(scenes.join("sub/corrupt.gltf")).unwrap();
    let o = batch(&[]);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    // No temporary files anywhere.
    for e in walk(&d) {
        let name = e.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            !name.contains(".tmp."),
            "temporary file left: {}",
            e.display()
        );
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn batch_refuses_a_missing_or_empty_directory() {
    let d = scratch("batch-empty");
    let o = run(&[
        "batch",
        s(&d.join("nope")),
        "-o",
        s(&d.join("out")),
        "--device",
        "cpu",
    ]);
    assert_eq!(code(&o), 3);
    assert!(text(&o.stderr).contains("nope"));
    let o = run(&["batch", s(&d), "-o", s(&d.join("out")), "--device", "cpu"]);
    assert_eq!(code(&o), 3);
    assert!(text(&o.stderr).contains("no .gltf or .glb scene"));
    let _ = fs::remove_dir_all(&d);
}

/// The same bake on 1, 2 and 3 threads (and again on 2) gives byte-identical files: the
/// mirror box exercises the reflect step, whose writes are added in direction order.
#[test]
fn the_same_bake_is_byte_identical_whatever_the_thread_count() {
    let d = scratch("repro");
    let mut files = Vec::new();
    for threads in ["1", "2", "3", "2"] {
        let out = d.join(format!("t{threads}-{}.vlf", files.len()));
        let scene = mirror_scene();
        // Resolution 16: the mirror spans several tiles.
        let o = run(&[
            "bake",
            "-q",
            s(&scene),
            "-o",
            s(&out),
            "--device",
            "cpu",
            "--directions",
            "46",
            "--resolution",
            "16",
            "--tile",
            "4",
            "--iterations",
            "2",
            "--threads",
            threads,
        ]);
        assert_eq!(code(&o), 0, "{}", text(&o.stderr));
        files.push(fs::read(&out).unwrap());
    }
    assert!(files[0].len() > 1000);
    for (k, f) in files.iter().enumerate().skip(1) {
        assert!(*f == files[0], "bake {k} differs from the one-thread bake");
    }
    let _ = fs::remove_dir_all(&d);
}

/// `--device auto` bakes on a hardware adapter when there is one, else on the CPU path (the
/// only adapter a software rasterizer, or none), and `--json` and the summary line say which
/// and why.
#[test]
fn device_auto_takes_the_faster_path_and_says_why() {
    let d = scratch("auto");
    let out = d.join("box.vlf");
    let (device, why) = match vlf_gpu::GpuContext::new(&Default::default()) {
        Ok(ctx) if !ctx.summary.is_software() => ("gpu", "hardware GPU adapter"),
        Ok(_) => ("cpu", "is a software rasterizer"),
        Err(_) => ("cpu", "no usable GPU adapter"),
    };
    let scene = box_scene();
    let mut args = vec!["bake", s(&scene), "-o", s(&out), "--threads", "2"];
    args.extend(&TINY[2..]);
    let o = run(&[args.as_slice(), &["--json"]].concat());
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["device"], device);
    let reason = r["device_reason"].as_str().unwrap();
    assert!(reason.contains(why), "{reason}");
    assert_eq!(r["threads"], 2);
    let o = run(&args);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let line = text(&o.stdout);
    assert!(line.contains(reason), "{line}");
    if device == "cpu" {
        assert!(line.contains("on the CPU (2 threads)"), "{line}");
    }
    let _ = fs::remove_dir_all(&d);
}

/// A GPU batch of several scenes compiles the bake pipelines once: the device's pipelines are
/// shared by every scene (the log line is written where they are created).
#[test]
fn gpu_batch_creates_the_bake_pipelines_once() {
    if vlf_tests::gpu().is_none() {
        return;
    }
    let d = scratch("gpu-batch");
    let scenes = d.join("scenes");
    fs::create_dir_all(&scenes).unwrap();
    fs::copy(box_scene(), scenes.join("a-box.gltf")).unwrap();
    fs::copy(mirror_scene(), scenes.join("b-mirror.gltf")).unwrap();
    fs::copy(box_scene(), scenes.join("c-box.gltf")).unwrap();
    let out = d.join("out");
    let mut args = vec!["batch", s(&scenes), "-o", s(&out), "-v"];
    args.extend(&TINY[2..]);
    args.extend(["--device", "gpu"]);
    let o = bin()
        .args(&args)
        .env_remove("RUST_LOG")
        .output()
        .expect("vlf-bake runs");
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert_eq!(code(&o), 0, "{stderr}");
    assert_eq!(stdout.matches("ok       ").count(), 3, "{stdout}");
    let created = stderr.matches("created the bake pipelines").count();
    assert_eq!(created, 1, "pipelines created {created} times:\n{stderr}");
    let _ = fs::remove_dir_all(&d);
}

/// `--device gpu` with fixed-count sampling runs the final gather on the GPU
/// (`vlf_gpu::gather`, at the default 256 indirect rays per texel: no CPU fallback), plans its
/// buffers with the bake's, and `--json` says where it ran; the default's guided sampling
/// gathers on the CPU, and `--json` says so.
#[test]
fn gpu_bake_gathers_on_the_gpu_and_plans_its_buffers() {
    if vlf_tests::gpu().is_none() {
        return;
    }
    let d = scratch("gpu-gather");
    let out = d.join("m.vlf");
    let scene = mirror_scene();
    let mut args = vec!["bake", s(&scene), "-o", s(&out), "--json"];
    args.extend(&TINY[2..]);
    args.extend(["--device", "gpu"]);
    let o = run(&args);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["device"], "gpu");
    assert_eq!(
        r["gather"]["device"], "cpu",
        "guided sampling gathers on the CPU"
    );
    // ... so its plan holds no GPU gather buffers.
    let planned_gather = |r: &serde_json::Value| {
        r["memory"]["plan"]["items"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|i| i["name"].as_str().unwrap().starts_with("final gather: "))
            .cloned()
            .collect::<Vec<_>>()
    };
    assert!(planned_gather(&r).is_empty(), "{:?}", planned_gather(&r));
    args.extend(["--gather-sampling", "fixed", "--denoise", "off"]);
    let o = run(&args);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["device"], "gpu");
    assert_eq!(r["gather"]["device"], "gpu");
    assert!(r["gather"]["covered_texels"].as_u64().unwrap() > 0);
    assert!(
        r["params"]["final_gather"]["indirect_rays"]
            .as_u64()
            .unwrap()
            >= 256
    );
    let gather = planned_gather(&r);
    assert!(
        gather
            .iter()
            .any(|i| i["name"] == "final gather: FinalGather::scratch" && i["place"] == "gpu"),
        "{gather:?}"
    );
    assert!(gather.iter().all(|i| i["bytes"].as_u64().unwrap() > 0));
    assert!(out.exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn memory_budget_lowers_the_resolution_or_refuses() {
    let d = scratch("budget");
    let scene = box_scene();
    let bake = |out: &Path, budget: &str| {
        run(&[
            "bake",
            s(&scene),
            "-o",
            s(out),
            "--device",
            "cpu",
            "--directions",
            "6",
            "--resolution",
            "256",
            "--iterations",
            "1",
            "--max-memory",
            budget,
        ])
    };
    // 12 MiB (the process itself is planned at 8 MiB): resolution 256 needs about 30 MiB, 128
    // about 15 MiB, 64 about 10 MiB; it is lowered with a warning.
    let out = d.join("box.vlf");
    let o = bake(&out, "12M");
    let stderr = text(&o.stderr);
    assert_eq!(code(&o), 0, "{stderr}");
    assert!(
        stderr.contains("--resolution lowered from 256 to"),
        "{stderr}"
    );
    assert!(stderr.contains("--max-memory 12.0 MiB"), "{stderr}");
    let info = vlf_core::format::describe(&out).unwrap();
    assert!(info.params.resolution < 256 && info.params.resolution >= 8);
    assert!(info.params.resolution.is_multiple_of(info.params.tile));

    // 1 MiB: nothing fits, even at resolution 8; refused with exit code 6 and no file.
    let refused = d.join("refused.vlf");
    let o = bake(&refused, "1M");
    let stderr = text(&o.stderr);
    assert_eq!(code(&o), 6, "{stderr}");
    for part in [
        "does not fit the memory budget",
        "budget 1.0 MiB (--max-memory 1.0 MiB)",
        "lowered from 256 to 8",
        "The program and the loaded scene alone need",
        "raise --max-memory",
    ] {
        assert!(stderr.contains(part), "`{part}` missing: {stderr}");
    }
    assert!(!refused.exists());
    // Bad sizes are usage errors.
    let o = bake(&refused, "lots");
    assert_eq!(code(&o), 2);
    let _ = fs::remove_dir_all(&d);
}

/// Every file under `dir`, recursively.
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if e.file_type().unwrap().is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// Temporary files of `target` (`.NAME.tmp.PID.N`) in its directory.
fn temps_of(target: &Path) -> Vec<PathBuf> {
    let prefix = format!(".{}.tmp.", target.file_name().unwrap().to_string_lossy());
    let mut v: Vec<PathBuf> = fs::read_dir(target.parent().unwrap())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect();
    v.sort();
    v
}

/// SIGKILL `vlf-bake bake` over an existing valid file at delays spanning its run, and right
/// after its temporary file appears (the write phase): the target must always be either the old
/// file byte for byte or the complete new one, and nothing but stale `.NAME.tmp.PID.N` files may
/// remain. `bake` ignores stale temporary files (it never reads or reuses them: its own names
/// carry its pid); `batch` removes those whose process is gone.
#[test]
fn sigkill_during_a_bake_never_leaves_a_partial_file() {
    let d = scratch("kill");
    let target = d.join("m.vlf");
    let scene = mirror_scene();
    // ~3 MB of mirror tiles, ~1 s on the CPU path.
    let params = [
        "--device",
        "cpu",
        "--directions",
        "46",
        "--resolution",
        "128",
        "--iterations",
        "1",
    ];
    let bake = |out: &Path, extra: &[&str]| {
        let mut c = bin();
        c.args(["bake", "-q", s(&scene), "-o", s(out)])
            .args(params)
            .args(extra);
        c
    };
    // The old file: a small, different bake.
    let mut args = vec!["bake", "-q", s(&scene), "-o", s(&target)];
    args.extend(TINY);
    assert_eq!(code(&run(&args)), 0);
    let old = fs::read(&target).unwrap();

    // Calibration: the complete new file and the run's timing.
    let reference = d.join("reference.vlf");
    let t = Instant::now();
    let o = bake(&reference, &["--json"]).output().unwrap();
    let wall = t.elapsed();
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let new = fs::read(&reference).unwrap();
    assert!(new.len() > 1_000_000, "output of {} bytes", new.len());
    assert_ne!(old, new);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let write_s = report["phases_s"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p[0] == "write")
        .unwrap()[1]
        .as_f64()
        .unwrap();

    let mut outcomes = Vec::new();
    let mut during_write = 0;
    let trials = 20;
    for k in 0..trials {
        if fs::read(&target).unwrap() != old {
            fs::write(&target, &old).unwrap();
        }
        let before = temps_of(&target).len();
        let mut child = bake(&target, &[])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        if k < trials / 2 {
            // Delays spanning the whole run.
            std::thread::sleep(wall.mul_f64((k as f64 + 0.5) / (trials / 2) as f64));
        } else {
            // Aim at the write phase: wait for the temporary file, then a fraction of the
            // write time, spaced quadratically (the temporary file lives only for the last
            // part of the phase: encoding comes first).
            let start = Instant::now();
            while temps_of(&target).len() == before
                && start.elapsed() < wall * 4
                && child.try_wait().unwrap().is_none()
            {
                std::thread::sleep(Duration::from_micros(200));
            }
            let j = (k - trials / 2) as f64 / (trials / 2) as f64;
            std::thread::sleep(Duration::from_secs_f64(write_s * j * j));
        }
        let _ = child.kill();
        let status = child.wait().unwrap();
        let got = fs::read(&target).unwrap();
        let outcome = if got == old {
            "old"
        } else {
            assert!(
                got == new,
                "trial {k}: the target is neither the old nor the new file"
            );
            vlf_core::format::read(&target).expect("a complete new file reads");
            "new"
        };
        let stale = temps_of(&target).len() - before;
        during_write += usize::from(stale > 0);
        outcomes.push((k, outcome, stale, status.code()));
        // Nothing else appeared.
        for e in fs::read_dir(&d).unwrap().flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            assert!(
                n == "m.vlf" || n == "reference.vlf" || n.starts_with(".m.vlf.tmp."),
                "unexpected file {n}"
            );
        }
    }
    let olds = outcomes.iter().filter(|o| o.1 == "old").count();
    eprintln!(
        "kill test: {} kills: {olds} left the old file, {} the new one; {during_write} landed during the write (a stale temporary file left); run {:.2} s, write phase {:.3} s: {outcomes:?}",
        outcomes.len(),
        outcomes.len() - olds,
        wall.as_secs_f64(),
        write_s
    );
    assert!(
        outcomes.iter().any(|o| o.1 == "old"),
        "no kill landed before the rename"
    );

    // A later `bake` succeeds and ignores the stale temporary files.
    let stale = temps_of(&target);
    let o = bake(&target, &[]).output().unwrap();
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    assert_eq!(fs::read(&target).unwrap(), new);
    assert_eq!(
        temps_of(&target),
        stale,
        "bake leaves others' temporary files"
    );

    // `batch` removes those of dead processes (this scene is up to date: nothing is baked).
    let scenes = d.join("scenes");
    fs::create_dir_all(&scenes).unwrap();
    fs::copy(&scene, scenes.join("m.gltf")).unwrap();
    // Make the output newer than the copied scene.
    let o = bake(&target, &[]).output().unwrap();
    assert_eq!(code(&o), 0);
    let o = bin()
        .args(["batch", "-q", s(&scenes), "-o", s(&d)])
        .args(params)
        .output()
        .unwrap();
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    assert!(
        temps_of(&target).is_empty(),
        "batch removed stale temporary files"
    );
    assert_eq!(fs::read(&target).unwrap(), new);
    let _ = fs::remove_dir_all(&d);
}

/// Ctrl-C (SIGINT) during a batch: the finished scene stays, the one in progress leaves no file
/// (not even a temporary one), the report says so, exit code 130.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_batch_cleanly() {
    let d = scratch("ctrl-c");
    let scenes = d.join("scenes");
    fs::create_dir_all(&scenes).unwrap();
    for n in ["a", "b", "c"] {
        fs::copy(mirror_scene(), scenes.join(format!("{n}.gltf"))).unwrap();
    }
    let out = d.join("out");
    let report = d.join("report.json");
    let mut child = bin()
        .args(["batch", s(&scenes), "-o", s(&out), "--json", s(&report)])
        .args([
            "--device",
            "cpu",
            "--directions",
            "46",
            "--resolution",
            "128",
            "--iterations",
            "2",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !out.join("a.vlf").exists() {
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "a.vlf never appeared"
        );
        assert!(child.try_wait().unwrap().is_none(), "batch ended early");
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(300)); // well inside b's bake
    let pid = child.id().to_string();
    let kill = Command::new("sh")
        .args(["-c", &format!("kill -INT {pid}")])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let r = json(&report);
    assert_eq!(r["interrupted"], true);
    let status: Vec<&str> = r["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["status"].as_str().unwrap())
        .collect();
    assert_eq!(status, ["ok", "interrupted", "not_started"], "{r}");
    vlf_core::format::read(&out.join("a.vlf")).unwrap();
    let files: Vec<String> = fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(files, ["a.vlf"], "only the finished output remains");
    let _ = fs::remove_dir_all(&d);
}

/// `inspect` lists every material's subsurface model (`docs/SUBSURFACE.md`), in text and
/// under `translucency` in `--json`.
#[test]
fn inspect_lists_each_materials_subsurface_model() {
    let scene = asset("cornell-translucent/cornell-translucent.gltf");
    let o = run(&["inspect", "--json", s(&scene)]);
    assert_eq!(code(&o), 0, "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let list = v["translucency"].as_array().expect("translucency list");
    let model = |name: &str| {
        list.iter()
            .find(|m| m["material"] == name)
            .unwrap_or_else(|| panic!("{name} missing: {list:?}"))
    };
    assert_eq!(model("white")["model"], "none");
    assert_eq!(model("paper")["model"], "thin_diffuse_transmission");
    assert_eq!(model("paper")["factor"], 0.5);
    let marble = model("marble");
    assert_eq!(marble["model"], "dipole");
    assert_eq!(marble["eta"], 1.5);
    // Jensen's marble per metre, recovered from the file's attenuation and multiscatter
    // colours (printed to five digits): within 0.1 %.
    for (k, want) in [2190.0, 2620.0, 3000.0].into_iter().enumerate() {
        let got = marble["sigma_s_prime"][k].as_f64().unwrap();
        assert!((got / want - 1.0).abs() < 1e-3, "σ_s′[{k}] {got}");
    }
    let o = run(&["inspect", s(&scene)]);
    let out = text(&o.stdout);
    assert!(out.contains("material \"marble\": dipole"), "{out}");
    assert!(
        out.contains("material \"paper\": thin-diffuse-transmission"),
        "{out}"
    );
}
