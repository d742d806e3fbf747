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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use vlf_core::lightfield::BakeParams;

mod plan;
mod report;
mod run;
mod scan;

pub use report::{write_bytes_atomic, write_json_atomic};
pub use scan::{discover, remove_stale_temps, shard};

use crate::ExitCode;
use crate::bake::params_from_args;
use crate::cli::{BakeArgs, DeviceArg, Shard};

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

impl SceneRecord {
    /// A scene not baked yet: `params` until a bake or the existing output says otherwise.
    fn pending(input: &Path, relative: String, output: &Path, params: BakeParams) -> Self {
        SceneRecord {
            input: input.display().to_string(),
            relative,
            output: output.display().to_string(),
            status: Status::Pending,
            error: None,
            error_code: None,
            reason: None,
            phases_s: BTreeMap::new(),
            total_s: 0.0,
            memory: None,
            params,
            output_bytes: None,
            directions: None,
            iterations: None,
            energy: None,
            warnings: Vec::new(),
        }
    }
}

/// `vlf-bake batch`, step by step: the scenes to bake ([`plan`]), the device and workers, a
/// record per scene (collisions, stale temporary files, up-to-date outputs), the bakes
/// ([`run`]), the report ([`report`]).
pub fn batch_command(opts: &BatchOptions) -> anyhow::Result<()> {
    let started = Instant::now();
    let params = params_from_args(&opts.args)?;
    let (scenes, scenes_in_dir) = plan::select_scenes(opts)?;
    let setup = plan::Setup::new(opts, scenes.len())?;
    let (mut records, queue) = plan::records(opts, &scenes, &params);
    let mut lines = report::Lines::new(records.len(), opts.quiet);
    lines.settled(&records);
    let mut ctx = report::ReportCtx::new(opts, &params, &setup, scenes_in_dir, started);
    ctx.write(&records, false, false);
    let interrupted = run::bake_all(&setup, &mut records, &queue, &mut lines, &mut ctx)?;
    if interrupted {
        ctx.write(&records, true, true);
        if !opts.quiet {
            eprintln!("interrupted: {}", report::summary(&records, started));
        }
        return Err(BatchError::Interrupted {
            finished: lines.finished(),
            total: records.len(),
            report: opts.report.clone(),
        }
        .into());
    }
    lines.finish();
    if !ctx.write(&records, true, false)
        && let Some(p) = &opts.report
    {
        anyhow::bail!("cannot write the batch report {}", p.display());
    }
    if !opts.quiet {
        println!("batch: {}", report::summary(&records, started));
    }
    let failed = records
        .iter()
        .filter(|r| r.status == Status::Failed)
        .count();
    if failed > 0 {
        return Err(BatchError::Failed {
            failed,
            total: records.len(),
            report: opts.report.clone(),
        }
        .into());
    }
    Ok(())
}

#[cfg(test)]
mod tests;
