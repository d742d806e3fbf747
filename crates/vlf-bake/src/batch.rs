//! `vlf-bake batch DIR -o OUTDIR`: bakes every `.gltf`/`.glb` under DIR into OUTDIR, keeping
//! relative paths, with one line per scene, an overall progress bar and a JSON report.
//!
//! * Discovery: recursive, sorted by path, symbolic links (files and directories) not followed.
//! * Up to date: an output is skipped when it is newer than both its scene file and the
//!   `vlf-bake` executable and its header says it was baked with the requested parameters (or
//!   with a resolution the memory budget lowered); `--force` bakes it anyway.
//! * Failures: a failing scene is recorded (error text and the exit code `bake` would have
//!   given) and the batch goes on; the batch then exits with [`ExitCode::BatchFailed`].
//! * Concurrency (`--jobs J`): J worker threads on the CPU path; with a GPU the device is shared
//!   and scenes are baked one at a time (J is ignored).
//! * Ctrl-C: the main thread stops waiting, removes the temporary files of the scenes in
//!   progress (their output name never holds a partial file: `write_atomic` renames only a
//!   complete, synced file), records them as `interrupted`, writes the report and exits with
//!   130. A second Ctrl-C exits at once.
//! * Stale temporary files `.NAME.tmp.PID.N` of killed runs next to an output are removed
//!   before the scene is considered, when process PID no longer exists.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant, SystemTime};

use serde::Serialize;
use vlf_core::lightfield::BakeParams;

mod scan;

use scan::up_to_date;
pub use scan::{discover, remove_stale_temps, shard};

use crate::ExitCode;
use crate::bake::{BakeReport, bake_scene, params_from_args, resolve_params};
use crate::cli::{BakeArgs, DeviceArg, Shard};
use crate::memory::{Budget, MemoryError, human};
use crate::{Compute, open_device};

/// Everything `vlf-bake batch` was given.
pub struct BatchOptions {
    pub dir: PathBuf,
    pub output: PathBuf,
    pub jobs: u32,
    /// `--json REPORT`.
    pub report: Option<PathBuf>,
    pub force: bool,
    /// `--shard I/N`: bake only this shard of the scenes.
    pub shard: Option<Shard>,
    pub args: BakeArgs,
    pub device: DeviceArg,
    pub quiet: bool,
}

/// How a batch ends when it does not succeed.
#[derive(Debug)]
pub enum BatchError {
    /// The batch cannot start (no such directory, no scene in it, output not writable).
    Input(String),
    /// Some scenes failed; the others were baked.
    Failed {
        failed: usize,
        total: usize,
        report: Option<PathBuf>,
    },
    /// Ctrl-C.
    Interrupted {
        finished: usize,
        total: usize,
        report: Option<PathBuf>,
    },
}

impl BatchError {
    pub fn exit_code(&self) -> ExitCode {
        match self {
            BatchError::Input(_) => ExitCode::BadInput,
            BatchError::Failed { .. } => ExitCode::BatchFailed,
            BatchError::Interrupted { .. } => ExitCode::Interrupted,
        }
    }
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let see = |r: &Option<PathBuf>| match r {
            Some(p) => format!(" (report: {})", p.display()),
            None => String::new(),
        };
        match self {
            BatchError::Input(msg) => f.write_str(msg),
            BatchError::Failed {
                failed,
                total,
                report,
            } => write!(
                f,
                "{failed} of {total} scenes failed; the others were baked{}",
                see(report)
            ),
            BatchError::Interrupted {
                finished,
                total,
                report,
            } => write!(
                f,
                "interrupted after {finished} of {total} scenes; finished outputs are kept, the scene in progress left no output{}",
                see(report)
            ),
        }
    }
}

impl std::error::Error for BatchError {}

/// Outcome of one scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Ok,
    Skipped,
    Failed,
    /// It was being baked when Ctrl-C came; no output was written for it.
    Interrupted,
    /// Ctrl-C came before it started.
    NotStarted,
    /// Waiting (only in reports written while the batch runs).
    Pending,
    /// Being baked (only in reports written while the batch runs).
    Running,
}

/// One scene in the report.
#[derive(Clone, Debug, Serialize)]
pub struct SceneRecord {
    pub input: String,
    /// Path of the scene relative to DIR.
    pub relative: String,
    pub output: String,
    pub status: Status,
    pub error: Option<String>,
    /// The exit code `vlf-bake bake` would have given for this error.
    pub error_code: Option<u8>,
    /// Why the scene was skipped, or why an existing output was baked again.
    pub reason: Option<String>,
    /// Seconds per phase (load, plan, prepare, propagate, write).
    pub phases_s: BTreeMap<String, f64>,
    pub total_s: f64,
    /// Memory: the plan (under `plan`) and the sizes of the radiance arrays.
    pub memory: Option<serde_json::Value>,
    /// Parameters used (the file's for a skipped scene, the requested ones for a failure).
    pub params: BakeParams,
    pub output_bytes: Option<u64>,
    pub directions: Option<usize>,
    pub iterations: Option<u32>,
    pub energy: Option<serde_json::Value>,
    pub warnings: Vec<String>,
}

#[derive(Serialize)]
struct Totals {
    scenes: usize,
    ok: usize,
    skipped: usize,
    failed: usize,
    interrupted: usize,
    not_started: usize,
    /// Bytes of every output that exists after the batch (baked and skipped ones).
    output_bytes: u64,
    /// Σ of the scenes' bake times (more than `wall_s` with --jobs > 1).
    bake_s: f64,
}

#[derive(Serialize)]
struct Report<'a> {
    report: &'static str,
    version: u32,
    input_dir: String,
    output_dir: String,
    device: &'static str,
    /// Why `--device` chose it.
    device_reason: String,
    adapter: String,
    jobs: u32,
    jobs_requested: u32,
    /// Worker threads of each bake's CPU work.
    threads: usize,
    force: bool,
    /// `--shard I/N`, and how many scenes DIR holds in all (`totals.scenes` are the shard's).
    shard: Option<String>,
    scenes_in_dir: usize,
    /// Requested parameters (a scene's own may have a lower resolution, see its `params`).
    params: &'a BakeParams,
    budget: &'a Budget,
    /// False while the batch runs (the report is rewritten after every scene).
    finished: bool,
    interrupted: bool,
    wall_s: f64,
    totals: Totals,
    scenes: &'a [SceneRecord],
}

/// A scene to bake.
struct Job {
    index: usize,
    input: PathBuf,
    output: PathBuf,
}

enum Event {
    Started(usize),
    Progress(usize, u64, u64, String),
    Done(usize, Box<SceneRecord>),
    Interrupt,
}

/// Ctrl-C presses seen by this process.
static CTRL_C: AtomicUsize = AtomicUsize::new(0);

/// `vlf-bake batch`.
pub fn batch_command(opts: &BatchOptions) -> anyhow::Result<()> {
    let t_batch = Instant::now();
    let params = params_from_args(&opts.args)?;
    let all = discover(&opts.dir)?;
    let in_dir = all.len();
    let scenes = shard(all, opts.shard);
    if let Some(sh) = opts.shard
        && !opts.quiet
    {
        eprintln!(
            "shard {sh}: {} of the {in_dir} scenes under {}",
            scenes.len(),
            opts.dir.display()
        );
    }
    fs::create_dir_all(&opts.output).map_err(|e| {
        BatchError::Input(format!(
            "cannot create the output directory {}: {e}",
            opts.output.display()
        ))
    })?;
    let compute = open_device(opts.device)?;
    let (device, adapter) = match &compute {
        Compute::Gpu(ctx, _) => ("gpu", ctx.summary.to_string()),
        Compute::Cpu(_) => ("cpu", "CPU reference".to_string()),
    };
    let jobs = match &compute {
        Compute::Gpu(..) => {
            if opts.jobs > 1 && !opts.quiet {
                eprintln!(
                    "note: --jobs {} ignored: with a GPU the scenes are baked one at a time on the shared device",
                    opts.jobs
                );
            }
            1
        }
        Compute::Cpu(_) => opts.jobs.min(scenes.len().max(1) as u32),
    };
    // Every bake uses all cores unless --threads says otherwise: J jobs share them.
    let mut args = opts.args.clone();
    if args.threads == 0 {
        args.threads = (vlf_core::par::threads(0) / jobs as usize).max(1);
    }
    if !opts.quiet {
        eprintln!(
            "baking on {} ({}), {jobs} job(s) of {} thread(s)",
            match &compute {
                Compute::Gpu(ctx, _) => ctx.summary.name.clone(),
                Compute::Cpu(_) => "the CPU".into(),
            },
            compute.why(),
            args.threads
        );
    }
    let budget = Budget::new(opts.args.max_memory, &compute, jobs);
    let exe_time = std::env::current_exe()
        .and_then(fs::metadata)
        .and_then(|m| m.modified())
        .unwrap_or(SystemTime::UNIX_EPOCH);

    // Outputs, collisions, stale temporary files, up-to-date checks.
    let mut records = Vec::with_capacity(scenes.len());
    let mut queue = VecDeque::new();
    let mut owners: HashMap<PathBuf, usize> = HashMap::new();
    for (index, rel) in scenes.iter().enumerate() {
        let input = opts.dir.join(rel);
        let output = opts.output.join(rel).with_extension("vlf");
        let mut rec = SceneRecord {
            input: input.display().to_string(),
            relative: rel.display().to_string(),
            output: output.display().to_string(),
            status: Status::Pending,
            error: None,
            error_code: None,
            reason: None,
            phases_s: BTreeMap::new(),
            total_s: 0.0,
            memory: None,
            params: params.clone(),
            output_bytes: None,
            directions: None,
            iterations: None,
            energy: None,
            warnings: Vec::new(),
        };
        if let Some(&first) = owners.get(&output) {
            rec.status = Status::Failed;
            rec.error = Some(format!(
                "its output {} is also the output of {}: rename one of the two scenes",
                output.display(),
                scenes[first].display()
            ));
            rec.error_code = Some(ExitCode::BadInput as u8);
            records.push(rec);
            continue;
        }
        owners.insert(output.clone(), index);
        let removed = remove_stale_temps(&output, None);
        if removed > 0 {
            log::info!(
                "removed {removed} stale temporary file(s) of {}",
                output.display()
            );
        }
        // The parameters this scene would get (`--quality` refines them per scene); a scene that
        // does not load is never up to date (its bake reports the error).
        let want = vlf_core::scene::load(&input)
            .ok()
            .and_then(|s| resolve_params(&opts.args, &s).ok())
            .map(|(p, _)| p);
        let fresh = match &want {
            Some(w) => up_to_date(&input, &output, exe_time, w),
            None => Err(None),
        };
        match fresh {
            Ok(info) if !opts.force => {
                rec.status = Status::Skipped;
                rec.reason = Some("up to date".into());
                rec.params = info.params;
                rec.output_bytes = Some(info.file_bytes);
                rec.directions = Some(info.directions as usize);
                rec.iterations = Some(info.stats.iterations);
            }
            Ok(_) => {
                rec.reason = Some("up to date, baked again (--force)".into());
                queue.push_back(index);
            }
            Err(why) => {
                rec.reason = why;
                queue.push_back(index);
            }
        }
        records.push(rec);
    }

    let total = records.len();
    let bar = overall_bar(total as u64, opts.quiet);
    let mut finished = 0usize;
    let line = |bar: &indicatif::ProgressBar, rec: &SceneRecord, finished: usize| {
        let text = scene_line(rec, finished, total);
        if rec.status == Status::Failed {
            bar.suspend(|| eprintln!("{text}"));
        } else if !opts.quiet {
            bar.suspend(|| println!("{text}"));
        }
    };
    for rec in &records {
        if matches!(rec.status, Status::Skipped | Status::Failed) {
            finished += 1;
            line(&bar, rec, finished);
            bar.inc(1);
        }
    }

    let mut ctx = ReportCtx {
        path: opts.report.clone(),
        opts,
        params: &params,
        budget: &budget,
        device,
        device_reason: compute.why().to_string(),
        adapter: adapter.clone(),
        jobs,
        threads: args.threads,
        scenes_in_dir: in_dir,
        started: t_batch,
    };
    ctx.write(&records, false, false);

    // Workers.
    let (tx, rx) = mpsc::channel::<Event>();
    {
        let tx = tx.clone();
        if let Err(e) = ctrlc::set_handler(move || {
            if CTRL_C.fetch_add(1, Ordering::SeqCst) == 0 {
                let _ = tx.send(Event::Interrupt);
            } else {
                std::process::exit(ExitCode::Interrupted as i32);
            }
        }) {
            log::warn!("cannot install the Ctrl-C handler: {e}");
        }
    }
    let to_bake = queue.len();
    let compute = Arc::new(compute);
    let jobs_queue: Arc<Mutex<VecDeque<Job>>> = Arc::new(Mutex::new(
        queue
            .iter()
            .map(|&i| Job {
                index: i,
                input: PathBuf::from(&records[i].input),
                output: PathBuf::from(&records[i].output),
            })
            .collect(),
    ));
    let stop = Arc::new(AtomicBool::new(false));
    for k in 0..jobs.min(to_bake as u32) {
        let (compute, queue, stop, tx) = (
            compute.clone(),
            jobs_queue.clone(),
            stop.clone(),
            tx.clone(),
        );
        let (args, budget) = (args.clone(), budget.clone());
        std::thread::Builder::new()
            .name(format!("bake-{k}"))
            .stack_size(16 << 20)
            .spawn(move || {
                loop {
                    if stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let Some(job) = queue.lock().unwrap_or_else(|p| p.into_inner()).pop_front()
                    else {
                        break;
                    };
                    let _ = tx.send(Event::Started(job.index));
                    let rec = bake_one(&job, &args, &compute, &budget, &tx);
                    let _ = tx.send(Event::Done(job.index, Box::new(rec)));
                }
            })
            .map_err(|e| anyhow::anyhow!("cannot start a worker thread: {e}"))?;
    }

    let mut running: BTreeMap<usize, (String, Instant)> = BTreeMap::new();
    let mut remaining = to_bake;
    while remaining > 0 {
        let Ok(event) = rx.recv() else { break };
        match event {
            Event::Started(i) => {
                records[i].status = Status::Running;
                running.insert(i, (records[i].relative.clone(), Instant::now()));
                bar.set_message(running_message(&running));
            }
            Event::Progress(i, done, of, msg) => {
                if let Some(r) = running.get(&i) {
                    let pct = (100 * done).checked_div(of).unwrap_or(0);
                    bar.set_message(format!("{} ({msg}, {pct}%)", r.0));
                }
            }
            Event::Done(i, rec) => {
                running.remove(&i);
                let mut rec = *rec;
                rec.relative = std::mem::take(&mut records[i].relative);
                if rec.reason.is_none() {
                    rec.reason = records[i].reason.take();
                }
                records[i] = rec;
                remaining -= 1;
                finished += 1;
                line(&bar, &records[i], finished);
                bar.inc(1);
                bar.set_message(running_message(&running));
                ctx.write(&records, false, false);
            }
            Event::Interrupt => {
                stop.store(true, Ordering::SeqCst);
                bar.finish_and_clear();
                for (&i, (_, since)) in &running {
                    let out = PathBuf::from(&records[i].output);
                    let removed = remove_stale_temps(&out, Some(std::process::id()));
                    let rec = &mut records[i];
                    rec.status = Status::Interrupted;
                    rec.total_s = since.elapsed().as_secs_f64();
                    rec.error = Some(format!(
                        "interrupted by Ctrl-C during the bake; no output was written under its name{}",
                        if removed > 0 {
                            format!(" ({removed} temporary file(s) removed)")
                        } else {
                            String::new()
                        }
                    ));
                    rec.error_code = Some(ExitCode::Interrupted as u8);
                }
                for rec in &mut records {
                    if rec.status == Status::Pending {
                        rec.status = Status::NotStarted;
                    }
                }
                ctx.write(&records, true, true);
                if !opts.quiet {
                    eprintln!("interrupted: {}", summary(&records, t_batch));
                }
                return Err(BatchError::Interrupted {
                    finished,
                    total,
                    report: opts.report.clone(),
                }
                .into());
            }
        }
    }
    bar.finish_and_clear();
    let failed = records
        .iter()
        .filter(|r| r.status == Status::Failed)
        .count();
    if !ctx.write(&records, true, false)
        && let Some(p) = &opts.report
    {
        anyhow::bail!("cannot write the batch report {}", p.display());
    }
    if !opts.quiet {
        println!("batch: {}", summary(&records, t_batch));
    }
    if failed > 0 {
        return Err(BatchError::Failed {
            failed,
            total,
            report: opts.report.clone(),
        }
        .into());
    }
    Ok(())
}

/// Bakes one scene on a worker thread; never panics (a panic becomes a failed record).
fn bake_one(
    job: &Job,
    args: &crate::cli::BakeArgs,
    compute: &Compute,
    budget: &Budget,
    tx: &mpsc::Sender<Event>,
) -> SceneRecord {
    let t = Instant::now();
    let index = job.index;
    let result = job
        .output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or(Ok(()), fs::create_dir_all)
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot create the output directory of {}: {e}",
                job.output.display()
            )
        })
        .and_then(|()| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                bake_scene(
                    &job.input,
                    &job.output,
                    args,
                    compute,
                    budget,
                    &mut |done, total, msg| {
                        let _ = tx.send(Event::Progress(index, done, total, msg.to_string()));
                    },
                )
            }))
            .unwrap_or_else(|panic| {
                let msg = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                Err(anyhow::anyhow!("internal error (panic): {msg}"))
            })
        });
    let mut rec = SceneRecord {
        input: job.input.display().to_string(),
        relative: String::new(),
        output: job.output.display().to_string(),
        status: Status::Ok,
        error: None,
        error_code: None,
        reason: None,
        phases_s: BTreeMap::new(),
        total_s: t.elapsed().as_secs_f64(),
        memory: None,
        params: params_from_args(args).unwrap_or_else(|_| vlf_core::bake::Quality::Auto.params()),
        output_bytes: None,
        directions: None,
        iterations: None,
        energy: None,
        warnings: Vec::new(),
    };
    match result {
        Ok(report) => fill_from_report(&mut rec, report),
        Err(err) => {
            rec.status = Status::Failed;
            rec.error = Some(format!("{err:#}"));
            rec.error_code = Some(crate::exit_code(&err) as u8);
            if let Some(MemoryError::OverBudget { plan, .. }) = err.downcast_ref::<MemoryError>() {
                rec.memory = Some(serde_json::json!({ "plan": plan }));
            }
        }
    }
    rec
}

fn fill_from_report(rec: &mut SceneRecord, r: BakeReport) {
    rec.phases_s = r.phases_s.into_iter().collect();
    rec.total_s = r.total_s;
    rec.memory = serde_json::to_value(&r.memory).ok();
    rec.params = r.params;
    rec.output_bytes = Some(r.output_bytes);
    rec.directions = Some(r.directions);
    rec.iterations = Some(r.iterations);
    rec.energy = serde_json::to_value(&r.energy).ok();
    rec.warnings = r.warnings;
}

/// Everything needed to (re)write the report.
struct ReportCtx<'a> {
    path: Option<PathBuf>,
    opts: &'a BatchOptions,
    params: &'a BakeParams,
    budget: &'a Budget,
    device: &'static str,
    device_reason: String,
    adapter: String,
    jobs: u32,
    threads: usize,
    scenes_in_dir: usize,
    started: Instant,
}

impl ReportCtx<'_> {
    /// Writes the report atomically (if `--json` was given); false on failure (logged).
    fn write(&mut self, records: &[SceneRecord], finished: bool, interrupted: bool) -> bool {
        let Some(path) = &self.path else { return true };
        let count = |s: Status| records.iter().filter(|r| r.status == s).count();
        let report = Report {
            report: "vlf-bake batch",
            version: 1,
            input_dir: self.opts.dir.display().to_string(),
            output_dir: self.opts.output.display().to_string(),
            device: self.device,
            device_reason: self.device_reason.clone(),
            adapter: self.adapter.clone(),
            jobs: self.jobs,
            jobs_requested: self.opts.jobs,
            threads: self.threads,
            force: self.opts.force,
            shard: self.opts.shard.map(|s| s.to_string()),
            scenes_in_dir: self.scenes_in_dir,
            params: self.params,
            budget: self.budget,
            finished,
            interrupted,
            wall_s: self.started.elapsed().as_secs_f64(),
            totals: Totals {
                scenes: records.len(),
                ok: count(Status::Ok),
                skipped: count(Status::Skipped),
                failed: count(Status::Failed),
                interrupted: count(Status::Interrupted),
                not_started: count(Status::NotStarted),
                output_bytes: records
                    .iter()
                    .filter(|r| matches!(r.status, Status::Ok | Status::Skipped))
                    .filter_map(|r| r.output_bytes)
                    .sum(),
                bake_s: records
                    .iter()
                    .filter(|r| matches!(r.status, Status::Ok | Status::Failed))
                    .map(|r| r.total_s)
                    .sum(),
            },
            scenes: records,
        };
        match write_json_atomic(path, &report) {
            Ok(()) => true,
            Err(e) => {
                log::error!("cannot write the batch report {}: {e:#}", path.display());
                false
            }
        }
    }
}

/// Writes `value` as pretty JSON to `path` through a synced temporary file and a rename.
pub fn write_json_atomic(path: &Path, value: &impl Serialize) -> anyhow::Result<()> {
    let mut bytes = serde_json::to_vec_pretty(value)?;
    bytes.push(b'\n');
    write_bytes_atomic(path, &bytes)
}

/// Writes `bytes` to `path` atomically ([`vlf_core::atomic_file`]: a synced temporary file in
/// the same directory and a rename), creating the directory: readers see the old file or the
/// new one, never a partial one.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    fs::create_dir_all(dir)?;
    vlf_core::atomic_file::write_bytes(path, bytes)
        .map_err(|e| anyhow::anyhow!("cannot write file ({e}): {}", path.display()))
}

fn overall_bar(total: u64, quiet: bool) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(total),
        indicatif::ProgressDrawTarget::stderr(),
    );
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "batch [{bar:30}] {pos}/{len} scenes, {elapsed} elapsed, ETA {eta} {wide_msg}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    bar.enable_steady_tick(Duration::from_millis(500));
    bar
}

fn running_message(running: &BTreeMap<usize, (String, Instant)>) -> String {
    running
        .values()
        .map(|(name, _)| name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

fn scene_line(r: &SceneRecord, finished: usize, total: usize) -> String {
    let w = total.to_string().len();
    let head = format!("[{finished:>w$}/{total}]");
    match r.status {
        Status::Ok => format!(
            "{head} ok       {} → {} ({:.2} s, {}, N = {}, {} iterations){}",
            r.relative,
            r.output,
            r.total_s,
            human(r.output_bytes.unwrap_or(0)),
            r.params.resolution,
            r.iterations.unwrap_or(0),
            if r.warnings.is_empty() {
                String::new()
            } else {
                format!(", {} warning(s)", r.warnings.len())
            }
        ),
        Status::Skipped => format!(
            "{head} skipped  {} ({}: {}, {})",
            r.relative,
            r.reason.as_deref().unwrap_or("up to date"),
            r.output,
            human(r.output_bytes.unwrap_or(0))
        ),
        _ => format!(
            "{head} FAILED   {} ({:.2} s): {}",
            r.relative,
            r.total_s,
            r.error.as_deref().unwrap_or("unknown error")
        ),
    }
}

fn summary(records: &[SceneRecord], started: Instant) -> String {
    let count = |s: Status| records.iter().filter(|r| r.status == s).count();
    let mut parts = vec![
        format!("{} baked", count(Status::Ok)),
        format!("{} up to date", count(Status::Skipped)),
        format!("{} failed", count(Status::Failed)),
    ];
    for (s, what) in [
        (Status::Interrupted, "interrupted"),
        (Status::NotStarted, "not started"),
    ] {
        if count(s) > 0 {
            parts.push(format!("{} {what}", count(s)));
        }
    }
    format!(
        "{} of {} scenes in {:.1} s",
        parts.join(", "),
        records.len(),
        started.elapsed().as_secs_f64()
    )
}

#[cfg(test)]
mod tests;
