//! What a batch will do before it bakes anything: the scenes (discovered, sharded), the device
//! and how many scenes bake at once, and a record per scene — failed when its output collides
//! with another's, skipped when its output is up to date, queued otherwise.

use std::collections::{HashMap, VecDeque};
use std::fs;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::SystemTime;

use vlf_core::lightfield::BakeParams;

use super::scan::{discover, remove_stale_temps, shard, up_to_date};
use super::{BatchError, BatchOptions, SceneRecord, Status};
use crate::ExitCode;
use crate::bake::resolve_params;
use crate::cli::BakeArgs;
use crate::memory::Budget;
use crate::{Compute, open_device};

/// The scenes of this batch (its shard of DIR's), relative to DIR, and how many DIR holds.
pub(super) fn select_scenes(opts: &BatchOptions) -> anyhow::Result<(Vec<PathBuf>, usize)> {
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
    Ok((scenes, in_dir))
}

/// Where and how the scenes bake.
pub(super) struct Setup {
    pub compute: Arc<Compute>,
    /// Scenes baked at once.
    pub jobs: u32,
    /// The bake options, with each bake's share of the cores as its thread count.
    pub args: BakeArgs,
    pub budget: Budget,
}

impl Setup {
    /// Opens the device and sizes the workers for `scenes` scenes: one at a time on a GPU (the
    /// device is shared), `--jobs` on the CPU path, sharing the cores.
    pub fn new(opts: &BatchOptions, scenes: usize) -> anyhow::Result<Setup> {
        let compute = open_device(opts.device)?;
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
            Compute::Cpu(_) => opts.jobs.min(scenes.max(1) as u32),
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
        Ok(Setup {
            compute: Arc::new(compute),
            jobs,
            args,
            budget,
        })
    }

    /// `gpu` or `cpu`, and the adapter's description.
    pub fn device(&self) -> (&'static str, String) {
        match &*self.compute {
            Compute::Gpu(ctx, _) => ("gpu", ctx.summary.to_string()),
            Compute::Cpu(_) => ("cpu", "CPU reference".to_string()),
        }
    }
}

/// A record per scene, and the indices of those to bake, in order.
pub(super) fn records(
    opts: &BatchOptions,
    scenes: &[PathBuf],
    params: &BakeParams,
) -> (Vec<SceneRecord>, VecDeque<usize>) {
    let exe_time = std::env::current_exe()
        .and_then(fs::metadata)
        .and_then(|m| m.modified())
        .unwrap_or(SystemTime::UNIX_EPOCH);
    let mut records = Vec::with_capacity(scenes.len());
    let mut queue = VecDeque::new();
    let mut owners: HashMap<PathBuf, usize> = HashMap::new();
    for (index, rel) in scenes.iter().enumerate() {
        let input = opts.dir.join(rel);
        let output = opts.output.join(rel).with_extension("vlf");
        let mut rec =
            SceneRecord::pending(&input, rel.display().to_string(), &output, params.clone());
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
        if consider(opts, &input, &output, exe_time, &mut rec) {
            queue.push_back(index);
        }
        records.push(rec);
    }
    (records, queue)
}

/// Whether the scene of `rec` must be baked; a skipped one gets its existing output's facts.
fn consider(
    opts: &BatchOptions,
    input: &std::path::Path,
    output: &std::path::Path,
    exe_time: SystemTime,
    rec: &mut SceneRecord,
) -> bool {
    // The parameters this scene would get (`--quality` refines them per scene); a scene that
    // does not load is never up to date (its bake reports the error).
    let want = vlf_core::scene::load(input)
        .ok()
        .and_then(|s| resolve_params(&opts.args, &s).ok())
        .map(|(p, _)| p);
    let fresh = match &want {
        Some(w) => up_to_date(input, output, exe_time, w),
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
            false
        }
        Ok(_) => {
            rec.reason = Some("up to date, baked again (--force)".into());
            true
        }
        Err(why) => {
            rec.reason = why;
            true
        }
    }
}
