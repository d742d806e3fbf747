//! What a batch tells: the JSON report (rewritten atomically after every scene), the lines and
//! progress bar on the terminal, the closing summary.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde::Serialize;
use vlf_core::lightfield::BakeParams;

use super::plan::Setup;
use super::{BatchOptions, SceneRecord, Status};
use crate::memory::{Budget, human};

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

/// Everything needed to (re)write the report.
pub(super) struct ReportCtx<'a> {
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

impl<'a> ReportCtx<'a> {
    pub fn new(
        opts: &'a BatchOptions,
        params: &'a BakeParams,
        setup: &'a Setup,
        scenes_in_dir: usize,
        started: Instant,
    ) -> Self {
        let (device, adapter) = setup.device();
        ReportCtx {
            path: opts.report.clone(),
            opts,
            params,
            budget: &setup.budget,
            device,
            device_reason: setup.compute.why().to_string(),
            adapter,
            jobs: setup.jobs,
            threads: setup.args.threads,
            scenes_in_dir,
            started,
        }
    }

    /// Writes the report atomically (if `--json` was given); false on failure (logged).
    pub fn write(&mut self, records: &[SceneRecord], finished: bool, interrupted: bool) -> bool {
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

pub(super) fn running_message(running: &BTreeMap<usize, (String, Instant)>) -> String {
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

pub(super) fn summary(records: &[SceneRecord], started: Instant) -> String {
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

/// What the terminal shows: a line per finished scene (failures on stderr, the rest on stdout
/// unless quiet) and the overall bar with the scenes in progress.
pub(super) struct Lines {
    bar: indicatif::ProgressBar,
    total: usize,
    finished: usize,
    quiet: bool,
}

impl Lines {
    pub fn new(total: usize, quiet: bool) -> Self {
        Lines {
            bar: overall_bar(total as u64, quiet),
            total,
            finished: 0,
            quiet,
        }
    }

    /// The lines of the scenes settled before any bake (skipped, or failed by a collision).
    pub fn settled(&mut self, records: &[SceneRecord]) {
        for rec in records {
            if matches!(rec.status, Status::Skipped | Status::Failed) {
                self.done(rec);
            }
        }
    }

    /// One more scene finished.
    pub fn done(&mut self, rec: &SceneRecord) {
        self.finished += 1;
        let text = scene_line(rec, self.finished, self.total);
        if rec.status == Status::Failed {
            self.bar.suspend(|| eprintln!("{text}"));
        } else if !self.quiet {
            self.bar.suspend(|| println!("{text}"));
        }
        self.bar.inc(1);
    }

    pub fn running(&self, running: &BTreeMap<usize, (String, Instant)>) {
        self.bar.set_message(running_message(running));
    }

    pub fn message(&self, msg: String) {
        self.bar.set_message(msg);
    }

    pub fn finished(&self) -> usize {
        self.finished
    }

    pub fn clear(&self) {
        self.bar.finish_and_clear();
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
