//! The bakes of a batch: worker threads take queued scenes in turn and report by events; the
//! main thread updates the records, the lines and the report, and handles Ctrl-C.

use std::collections::{BTreeMap, VecDeque};
use std::fs;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::Instant;

use super::plan::Setup;
use super::report::{Lines, ReportCtx};
use super::scan::remove_stale_temps;
use super::{SceneRecord, Status};
use crate::Compute;
use crate::ExitCode;
use crate::bake::{BakeReport, bake_scene, params_from_args};
use crate::memory::{Budget, MemoryError};

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

/// Bakes the queued scenes of `records` on `setup.jobs` workers, updating the records, the
/// lines and the report as they finish; true when Ctrl-C stopped it (the scenes in progress
/// are then recorded as interrupted, those not started as such).
pub(super) fn bake_all(
    setup: &Setup,
    records: &mut [SceneRecord],
    queue: &VecDeque<usize>,
    lines: &mut Lines,
    ctx: &mut ReportCtx,
) -> anyhow::Result<bool> {
    let (tx, rx) = mpsc::channel::<Event>();
    install_ctrl_c(tx.clone());
    let stop = Arc::new(AtomicBool::new(false));
    let jobs = queue
        .iter()
        .map(|&i| Job {
            index: i,
            input: PathBuf::from(&records[i].input),
            output: PathBuf::from(&records[i].output),
        })
        .collect();
    start_workers(setup, jobs, &stop, &tx)?;
    let mut running: BTreeMap<usize, (String, Instant)> = BTreeMap::new();
    let mut remaining = queue.len();
    while remaining > 0 {
        let Ok(event) = rx.recv() else { break };
        match event {
            Event::Started(i) => {
                records[i].status = Status::Running;
                running.insert(i, (records[i].relative.clone(), Instant::now()));
                lines.running(&running);
            }
            Event::Progress(i, done, of, msg) => {
                if let Some(r) = running.get(&i) {
                    let pct = (100 * done).checked_div(of).unwrap_or(0);
                    lines.message(format!("{} ({msg}, {pct}%)", r.0));
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
                lines.done(&records[i]);
                lines.running(&running);
                ctx.write(records, false, false);
            }
            Event::Interrupt => {
                stop.store(true, Ordering::SeqCst);
                lines.clear();
                interrupt(records, &running);
                return Ok(true);
            }
        }
    }
    Ok(false)
}

/// The first Ctrl-C becomes an [`Event::Interrupt`]; a second exits at once.
fn install_ctrl_c(tx: mpsc::Sender<Event>) {
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

/// `setup.jobs` worker threads (at most one per job) taking `jobs` in turn until they run out
/// or `stop` is set. A queue of whole bakes, not data parallelism: each worker needs a large
/// stack, reports through the channel and is stopped by Ctrl-C between scenes, and each bake
/// runs its own data parallelism on `vlf_core::par`'s pool (`docs/ARCHITECTURE.md`).
fn start_workers(
    setup: &Setup,
    jobs: VecDeque<Job>,
    stop: &Arc<AtomicBool>,
    tx: &mpsc::Sender<Event>,
) -> anyhow::Result<()> {
    let workers = setup.jobs.min(jobs.len() as u32);
    let (compute, args, budget) = (&setup.compute, &setup.args, &setup.budget);
    let queue = Arc::new(Mutex::new(jobs));
    for k in 0..workers {
        let (compute, queue, stop, tx) = (compute.clone(), queue.clone(), stop.clone(), tx.clone());
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
    Ok(())
}

/// After Ctrl-C: the scenes in progress lose their temporary files and are recorded as
/// interrupted, the queued ones as not started.
fn interrupt(records: &mut [SceneRecord], running: &BTreeMap<usize, (String, Instant)>) {
    for (&i, (_, since)) in running {
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
    for rec in records {
        if rec.status == Status::Pending {
            rec.status = Status::NotStarted;
        }
    }
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
    let mut rec = SceneRecord::pending(
        &job.input,
        String::new(),
        &job.output,
        params_from_args(args)
            .unwrap_or_else(|_| vlf_core::bake::Quality::Auto.preset().params(false)),
    );
    rec.status = Status::Ok;
    rec.total_s = t.elapsed().as_secs_f64();
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
