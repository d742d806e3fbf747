//! Memory budget of a bake: plan the memory a bake will need from the prepared scene and the
//! parameters, compare it with the budget (`--max-memory`, or what the machine and adapter
//! report), lower `--resolution` until it fits or refuse with a message that says what to
//! change; and turn GPU out-of-memory / device-lost errors into such messages instead of panics.
//!
//! # The plan
//!
//! With `T` triangles, `F` faces, `X` texels (both sides of every chart), `V` mirror tile values
//! (`TileIndex::value_len`, one copy), `N` rays per side, `m` cells per tile, `l` fixed and `D`
//! transport directions, `B_d` the triangle entries binned into the tiles of direction `d`
//! (`reference::bin_triangles`) and `k_max` the longest tile bin over all directions (an upper
//! bound on the faces one ray crosses):
//!
//! * both paths, host: a process baseline (8 MiB; 96 MiB more for a software GPU driver), the
//!   loaded scene (world triangles, decoded textures at 16 B per texel), and 10 % on top of
//!   every host item for the allocator;
//! * CPU path (host memory; one direction at a time):
//!   `52 X` prepared texel arrays (area, centre, albedo, emission) + `3 × 16 X` radiance (unshot,
//!   next, total) + `36 X` accumulators and face ids + `3 × 16 V` tile values + tile index +
//!   reflect jobs + `40 × min(N² k_max, m² max_d B_d, max_d C_d)` crossing lists (per
//!   crossing a depth entry of 8 B and the arriving radiance, 28 B on the CPU and 32 B on the
//!   GPU; `C_d` = Σ over triangles of the cells their projected bounding box covers, widened by
//!   one cell as the bins are) + `4 ((N/m)² + 1 + max_d B_d) + 36 T` bins and projections +
//!   `48 T` triangles + the encoded output file;
//! * GPU path (GPU buffers, each checked against the adapter's binding limit): `48 T + 80 F`
//!   geometry, `16 X` texel centres, `4 X` active texel list, `4 Σ_d ((N/m)² + 1 + B_d)` bins of
//!   every direction, `16 (X + V)` unshot, `16 V` next tiles, `32 X` accumulators,
//!   `N² (16 + 4)` escape and count buffers, `40 N² min(k_max, 256)` crossing lists (8 B entry +
//!   32 B interface), tile index, frames and reflect items; plus host memory for the CPU-side
//!   copies (prepared arrays, radiance, tiles, reflect jobs and items, one direction's bins, the
//!   upload staging, read-backs, the encoded file).
//!   On a software adapter (lavapipe) the GPU buffers live in system RAM and count against host
//!   memory too.
//!
//! The buffers with something for every transport direction (tile bins `4 B_d`, tile starts
//! `4 ((N/m)² + 1)`, reflect items) are split into chunks of whole directions
//! (`vlf_gpu::bake::chunks`, the same greedy split the propagator makes), each at most
//! min(128 MiB, binding limit): their total counts against memory, their largest chunk against
//! the binding limit. Only a single direction larger than the limit makes such a buffer too
//! large (then `--resolution` is halved, or the bake refused, as for any other buffer). The
//! host bins one direction at a time and writes it into its chunk (staging flushed every
//! 32 MiB), so it never holds the bins of every direction.
//!
//! The plan is an upper bound: the crossing lists assume that every ray meets every triangle
//! whose bounding box (GPU: whose tile bin) it passes through.

use std::fmt;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use serde::Serialize;
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, ReflectJob, SpecularSetup};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::BakeParams;
use vlf_core::psf::PsfGrid;
use vlf_core::scene::Scene;
use vlf_gpu::bake::{ChunkBytes, Chunker};

use crate::Compute;

/// `--resolution` is never lowered below this.
pub const MIN_RESOLUTION: u32 = 8;
/// Bytes per ray crossing: depth entry (8) + arriving radiance (32).
pub const CROSSING_BYTES: u64 = 40;
/// Default share of the system RAM (MemTotal) one batch may use: 3/4.
const RAM_SHARE: (u64, u64) = (3, 4);
/// Resident memory of the process before any scene (measured: 5–7 MiB for `vlf-bake`).
const BASELINE_BYTES: u64 = 8 << 20;
/// Resident memory of a software adapter's driver (Mesa, LLVM, the compiled shaders): measured
/// 93 MiB peak for a GPU bake of the Cornell box on lavapipe against 8 MiB on the CPU path.
const SOFTWARE_DRIVER_BYTES: u64 = 96 << 20;
/// Cap on crossings per ray on the GPU (`vlf_gpu::bake::MAX_CROSSINGS`).
const GPU_MAX_CROSSINGS: u32 = vlf_gpu::bake::MAX_CROSSINGS;

/// Parses `--max-memory`: a number of bytes with an optional binary suffix `K`, `M`, `G`, `T`
/// (also `KB`/`KiB`…, all powers of 1024), e.g. `2G`, `512M`, `1.5G`, `1048576`.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let unit = unit.trim().to_ascii_uppercase();
    let shift = match unit.trim_end_matches('B').trim_end_matches('I') {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("unknown size unit in `{s}` (use K, M, G or T)")),
    };
    if (unit.ends_with("IB") && shift == 0) || unit == "I" {
        return Err(format!("unknown size unit in `{s}` (use K, M, G or T)"));
    }
    let value: f64 = num
        .parse()
        .map_err(|_| format!("expected a size such as 2G or 512M, got `{s}`"))?;
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes < 1.0 || bytes > u64::MAX as f64 / 2.0 {
        return Err(format!("size `{s}` is out of range (at least 1 byte)"));
    }
    Ok(bytes as u64)
}

/// `1.5 GiB`-style text for byte counts.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// One limit of a [`Budget`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Limit {
    pub bytes: u64,
    /// Where it comes from (`--max-memory 2.0 GiB`, `3/4 of MemTotal …`, an adapter limit).
    pub source: String,
}

/// What one bake may use.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Budget {
    /// Host RAM: everything on the CPU path; host-side copies on the GPU path (plus the GPU
    /// buffers on a software adapter, whose "GPU memory" is system RAM).
    pub host: Option<Limit>,
    /// All GPU buffers together (GPU path with `--max-memory` on a hardware adapter; wgpu does
    /// not report the size of device memory, so there is no default).
    pub device: Option<Limit>,
    /// One GPU buffer: the adapter's `max_storage_buffer_binding_size` (≤ `max_buffer_size`).
    pub buffer: Option<Limit>,
}

impl Budget {
    /// The budget of one of `jobs` concurrent bakes on `compute`, `--max-memory` = `max_memory`.
    pub fn new(max_memory: Option<u64>, compute: &Compute, jobs: u32) -> Budget {
        let jobs = u64::from(jobs.max(1));
        let ram = system_ram().map(|total| {
            let share = total / RAM_SHARE.1 * RAM_SHARE.0;
            Limit {
                bytes: share / jobs,
                source: if jobs > 1 {
                    format!(
                        "3/4 of the system RAM ({} MemTotal) shared by {jobs} jobs",
                        human(total)
                    )
                } else {
                    format!("3/4 of the system RAM ({} MemTotal)", human(total))
                },
            }
        });
        let given = max_memory.map(|b| Limit {
            bytes: b,
            source: format!("--max-memory {}", human(b)),
        });
        match compute {
            Compute::Cpu(_) => Budget {
                host: given.or(ram),
                device: None,
                buffer: None,
            },
            Compute::Gpu(ctx) => {
                let limits = ctx.device.limits();
                let buffer = Some(Limit {
                    bytes: limits
                        .max_storage_buffer_binding_size
                        .min(limits.max_buffer_size),
                    source: format!("max_storage_buffer_binding_size of {}", ctx.summary.name),
                });
                if ctx.summary.is_software() {
                    // lavapipe: GPU buffers are system RAM.
                    Budget {
                        host: given.or(ram),
                        device: None,
                        buffer,
                    }
                } else {
                    Budget {
                        host: ram,
                        device: given,
                        buffer,
                    }
                }
            }
        }
    }
}

/// MemTotal from /proc/meminfo, in bytes.
pub fn system_ram() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo(&text)
}

fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let value: u64 = parts.next()?.parse().ok()?;
    let scale = match parts.next() {
        Some("kB") | Some("KB") | Some("kiB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    Some(value * scale)
}

/// One line of a [`MemoryPlan`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanItem {
    pub name: &'static str,
    /// `host` or `gpu`.
    pub place: &'static str,
    /// Elements (texels, values, crossings, …) in one copy.
    pub count: u64,
    pub bytes_each: u64,
    pub copies: u64,
    pub bytes: u64,
    /// A GPU item split into several buffers (chunks of whole directions); `bytes` is their sum.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<Split>,
}

/// How a [`PlanItem`] is split into GPU buffers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Split {
    /// One buffer's name in messages (`Bake::bin_tris[k]`).
    pub part: &'static str,
    /// Number of buffers.
    pub buffers: u64,
    /// Bytes of the largest buffer.
    pub largest: u64,
    /// Cap on one buffer (exceeded only by a single direction larger than it).
    pub cap: u64,
}

impl PlanItem {
    /// The largest single buffer of this item: itself, or its largest part when split.
    fn largest_buffer(&self) -> PlanItem {
        match &self.split {
            None => self.clone(),
            Some(s) => PlanItem {
                name: s.part,
                place: self.place,
                count: s.largest / self.bytes_each.max(1),
                bytes_each: self.bytes_each,
                copies: 1,
                bytes: s.largest,
                split: None,
            },
        }
    }
}

/// The memory a bake will need (see the module documentation for the formulas).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MemoryPlan {
    /// `cpu` or `gpu`.
    pub path: &'static str,
    pub resolution: u32,
    pub tile: u32,
    /// Fixed directions l.
    pub directions: usize,
    /// Transport directions (perturbed copies and suns included).
    pub transport_directions: usize,
    pub triangles: u64,
    pub faces: u64,
    /// Texels, both sides of every chart.
    pub texels: u64,
    /// Mirror tile values in one copy (0 without mirror/mixed faces).
    pub tile_values: u64,
    /// Longest tile bin over every direction (upper bound on the faces one ray crosses).
    pub k_max: u32,
    /// Largest number of binned triangle entries of one direction.
    pub binned_max: u64,
    pub items: Vec<PlanItem>,
    pub host_bytes: u64,
    /// Host memory no parameter changes: the process and the loaded scene (overhead included).
    pub fixed_bytes: u64,
    /// GPU buffers (0 on the CPU path).
    pub device_bytes: u64,
    /// The largest single GPU buffer (GPU path; of a split item, its largest part).
    pub largest_buffer: Option<PlanItem>,
    pub budget: Budget,
    /// Each limit the plan exceeds (empty when it fits).
    pub over_budget: Vec<String>,
    /// The requested `--resolution` when it was lowered to fit.
    pub lowered_from: Option<u32>,
    /// Seconds spent planning (binning every direction, building the tile index).
    pub plan_s: f64,
}

impl MemoryPlan {
    pub fn fits(&self) -> bool {
        self.over_budget.is_empty()
    }

    /// Host memory counted against the host budget (GPU buffers too on a software adapter).
    fn host_charged(&self, software: bool) -> u64 {
        if software {
            self.host_bytes + self.device_bytes
        } else {
            self.host_bytes
        }
    }

    fn check(&mut self, software: bool) {
        let b = &self.budget;
        let mut over = Vec::new();
        if let Some(l) = &b.host {
            let need = self.host_charged(software);
            if need > l.bytes {
                over.push(format!(
                    "{} of {} > budget {} ({})",
                    human(need),
                    if software && self.device_bytes > 0 {
                        "host memory (GPU buffers of the software adapter included)"
                    } else {
                        "host memory"
                    },
                    human(l.bytes),
                    l.source
                ));
            }
        }
        if let Some(l) = &b.device
            && self.device_bytes > l.bytes
        {
            over.push(format!(
                "{} of GPU buffers > budget {} ({})",
                human(self.device_bytes),
                human(l.bytes),
                l.source
            ));
        }
        if let (Some(l), Some(big)) = (&b.buffer, &self.largest_buffer)
            && big.bytes > l.bytes
        {
            over.push(format!(
                "GPU buffer `{}` of {} > {} ({})",
                big.name,
                human(big.bytes),
                human(l.bytes),
                l.source
            ));
        }
        self.over_budget = over;
    }

    /// The largest items, for messages: `crossing lists 12.0 MiB, texel radiance 3.0 MiB`.
    pub fn largest_items(&self, n: usize) -> String {
        let mut items: Vec<&PlanItem> = self.items.iter().collect();
        items.sort_by(|a, b| b.bytes.cmp(&a.bytes).then(a.name.cmp(b.name)));
        items
            .iter()
            .take(n)
            .map(|i| format!("{} ({}) {}", i.name, i.place, human(i.bytes)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for MemoryPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "memory plan ({} path, N = {}, m = {}, {} directions, {} transport directions, {} texels, {} tile values, k_max {}):",
            self.path,
            self.resolution,
            self.tile,
            self.directions,
            self.transport_directions,
            self.texels,
            self.tile_values,
            self.k_max
        )?;
        for i in &self.items {
            write!(
                f,
                "  {:<4} {:<44} {:>12} × {:>3} B × {} = {}",
                i.place,
                i.name,
                i.count,
                i.bytes_each,
                i.copies,
                human(i.bytes)
            )?;
            if let Some(s) = &i.split {
                write!(
                    f,
                    " in {} buffer{} of ≤ {} (largest {})",
                    s.buffers,
                    if s.buffers == 1 { "" } else { "s" },
                    human(s.cap),
                    human(s.largest)
                )?;
            }
            writeln!(f)?;
        }
        write!(f, "  host {}", human(self.host_bytes))?;
        if self.path == "gpu" {
            write!(f, ", GPU buffers {}", human(self.device_bytes))?;
            if let Some(b) = &self.largest_buffer {
                write!(f, " (largest: {} {})", b.name, human(b.bytes))?;
            }
        }
        let b = &self.budget;
        let mut limits = Vec::new();
        for (what, l) in [("host", &b.host), ("GPU", &b.device), ("buffer", &b.buffer)] {
            if let Some(l) = l {
                limits.push(format!("{what} {} ({})", human(l.bytes), l.source));
            }
        }
        if limits.is_empty() {
            write!(f, "; no budget")?;
        } else {
            write!(f, "; budget: {}", limits.join(", "))?;
        }
        if !self.fits() {
            write!(f, "; OVER: {}", self.over_budget.join("; "))?;
        }
        Ok(())
    }
}

/// Errors of the memory budget and of the GPU's memory.
#[derive(Debug)]
pub enum MemoryError {
    /// No resolution ≥ [`MIN_RESOLUTION`] (obtained by halving) fits the budget.
    OverBudget {
        scene: String,
        requested: u32,
        plan: Box<MemoryPlan>,
    },
    /// The GPU ran out of memory.
    GpuOutOfMemory { detail: String, planned: u64 },
    /// The GPU device was lost (driver reset, crash, …).
    DeviceLost { detail: String },
    /// Any other error reported by the GPU (a validation error is a bug in vlf).
    Gpu { detail: String },
}

impl fmt::Display for MemoryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MemoryError::OverBudget {
                scene,
                requested,
                plan,
            } => {
                let p = plan.as_ref();
                write!(
                    f,
                    "the bake of {scene} does not fit the memory budget: {}",
                    p.over_budget.join("; ")
                )?;
                if p.resolution < *requested {
                    write!(
                        f,
                        ", even with --resolution lowered from {requested} to {}",
                        p.resolution
                    )?;
                } else {
                    write!(f, " at --resolution {}", p.resolution)?;
                }
                let host_limit = p.budget.host.as_ref().map_or(u64::MAX, |l| l.bytes);
                if p.fixed_bytes >= host_limit {
                    return write!(
                        f,
                        " (largest parts: {}). The program and the loaded scene alone need {}: raise --max-memory above that",
                        p.largest_items(3),
                        human(p.fixed_bytes)
                    );
                }
                write!(
                    f,
                    " (largest parts: {}). Raise --max-memory, or lower --directions (now {}), or raise --texel-scale",
                    p.largest_items(3),
                    p.directions
                )?;
                if p.resolution >= 2 * MIN_RESOLUTION {
                    write!(f, ", or lower --resolution")?;
                } else {
                    write!(f, " (--resolution is not lowered below {MIN_RESOLUTION})")?;
                }
                Ok(())
            }
            MemoryError::GpuOutOfMemory { detail, planned } => write!(
                f,
                "the GPU ran out of memory ({detail}); this bake planned {} of GPU buffers: lower --resolution or --directions, or pass --max-memory below the GPU's free memory so that the resolution is lowered to fit",
                human(*planned)
            ),
            MemoryError::DeviceLost { detail } => write!(
                f,
                "the GPU device was lost during the bake ({detail}); a driver reset or a GPU hang can cause this: retry, use smaller parameters, or --device cpu"
            ),
            MemoryError::Gpu { detail } => write!(f, "GPU error during the bake: {detail}"),
        }
    }
}

impl std::error::Error for MemoryError {}

/// A plan with the prepared scene and the parameters it was made for.
pub struct Planned {
    /// The parameters to bake with (resolution and tile lowered when needed).
    pub params: BakeParams,
    pub prep: BakeScene,
    pub set: DirectionSet,
    pub plan: MemoryPlan,
}

/// Plans the bake of `scene` with `requested` on `compute` within `budget`: prepares the scene,
/// plans its memory and, while the plan exceeds the budget, halves `--resolution` (keeping the
/// tile a divisor) down to [`MIN_RESOLUTION`], with a warning added to `prep.warnings`. Fails
/// with [`MemoryError::OverBudget`] when nothing fits. The plan is logged at info level (`-v`).
pub fn plan_and_prepare(
    scene: &Scene,
    requested: &BakeParams,
    compute: &Compute,
    budget: &Budget,
    scene_path: &Path,
) -> anyhow::Result<Planned> {
    use anyhow::Context as _;
    let t = Instant::now();
    let set = DirectionSet::at_least(requested.directions).context("direction set")?;
    let (gpu, software) = match compute {
        Compute::Cpu(_) => (false, false),
        Compute::Gpu(ctx) => (true, ctx.summary.is_software()),
    };
    let mut params = requested.clone();
    let mut prep_s = 0.0;
    // Why the requested resolution did not fit (for the warning).
    let mut first_over: Option<Vec<String>> = None;
    loop {
        // Cheap check first so a huge texel count is never allocated by the preparation.
        let quick = texel_floor(scene, &params, gpu);
        if let Some(l) = budget.host.as_ref().filter(|l| quick > l.bytes)
            && let Some(lower) = halve(&params)
        {
            first_over.get_or_insert_with(|| {
                vec![format!(
                    "its texel arrays alone need {} of host memory > budget {} ({})",
                    human(quick),
                    human(l.bytes),
                    l.source
                )]
            });
            params = lower;
            continue;
        }
        let tp = Instant::now();
        let prep = BakeScene::new(scene, &params).context("preparing the scene")?;
        prep_s += tp.elapsed().as_secs_f64();
        let mut plan = plan_prepared(scene, &prep, &set, &params, gpu, software, budget);
        plan.check(software);
        if !plan.fits()
            && let Some(lower) = halve(&params)
        {
            log::debug!("{}: {plan}", scene_path.display());
            first_over.get_or_insert_with(|| plan.over_budget.clone());
            params = lower;
            continue;
        }
        plan.plan_s = (t.elapsed().as_secs_f64() - prep_s).max(0.0);
        if !plan.fits() {
            log::info!("{}: {plan}", scene_path.display());
            return Err(MemoryError::OverBudget {
                scene: scene_path.display().to_string(),
                requested: requested.resolution,
                plan: Box::new(plan),
            }
            .into());
        }
        let mut prep = prep;
        if params.resolution != requested.resolution {
            plan.lowered_from = Some(requested.resolution);
            let why = first_over.unwrap_or_default();
            // The adapter's buffer limit cannot be raised; the budget can.
            let hint = if why.iter().all(|w| w.starts_with("GPU buffer `")) {
                "lower --directions or --resolution yourself to choose the trade-off"
            } else {
                "raise --max-memory to keep the resolution"
            };
            prep.warnings.push(format!(
                "--resolution lowered from {} to {} (tile {}) to fit the memory budget: at {}, {}; now the bake needs {} of host memory{} ({hint})",
                requested.resolution,
                params.resolution,
                params.tile,
                requested.resolution,
                why.join("; "),
                human(plan.host_bytes),
                if plan.device_bytes > 0 {
                    format!(" and {} of GPU buffers", human(plan.device_bytes))
                } else {
                    String::new()
                }
            ));
        }
        log::info!("{}: {plan}", scene_path.display());
        return Ok(Planned {
            params,
            prep,
            set,
            plan,
        });
    }
}

/// The next lower resolution: half of it, the tile lowered to the largest divisor of the new
/// resolution not above the current tile. `None` below [`MIN_RESOLUTION`] or for odd ones.
pub fn halve(p: &BakeParams) -> Option<BakeParams> {
    if !p.resolution.is_multiple_of(2) || p.resolution / 2 < MIN_RESOLUTION {
        return None;
    }
    let n = p.resolution / 2;
    let tile = (1..=p.tile.min(n))
        .rev()
        .find(|t| n.is_multiple_of(*t))
        .unwrap_or(1);
    Some(BakeParams {
        resolution: n,
        tile,
        ..p.clone()
    })
}

/// Texels the preparation will allocate (same chart sizes as `BakeScene::new`).
pub fn texel_count(scene: &Scene, params: &BakeParams) -> u64 {
    let texel_size = 2.0 / params.resolution as f32 * params.texel_scale;
    scene
        .faces
        .iter()
        .map(|f| {
            let extent = f.extent * scene.to_vlf.scale;
            let w = ((extent.x / texel_size).ceil() as u32).max(1);
            let h = ((extent.y / texel_size).ceil() as u32).max(1);
            2 * u64::from(w) * u64::from(h)
        })
        .sum()
}

/// Host bytes of the texel arrays alone: a lower bound of the plan, known before preparing.
fn texel_floor(scene: &Scene, params: &BakeParams, gpu: bool) -> u64 {
    let x = texel_count(scene, params);
    // prepared arrays 52 + radiance 3 × 16 (+ accumulators 36 on the CPU path)
    x * (52 + 48 + if gpu { 0 } else { 36 })
}

fn item(name: &'static str, place: &'static str, count: u64, each: u64, copies: u64) -> PlanItem {
    PlanItem {
        name,
        place,
        count,
        bytes_each: each,
        copies,
        bytes: count * each * copies,
        split: None,
    }
}

/// A GPU item split into the chunks of `chunker`; `largest` and `total` in bytes.
fn split_item(
    name: &'static str,
    part: &'static str,
    each: u64,
    total: u64,
    largest: u64,
    chunker: &Chunker,
) -> PlanItem {
    PlanItem {
        split: Some(Split {
            part,
            buffers: chunker.chunks().len() as u64,
            largest,
            cap: chunker.cap(),
        }),
        ..item(name, "gpu", total / each, each, 1)
    }
}

/// The plan for `scene` prepared as `prep` (not yet checked against the budget); `software`:
/// the GPU path on a software adapter (whose driver lives in the process).
pub fn plan_prepared(
    scene: &Scene,
    prep: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    gpu: bool,
    software: bool,
    budget: &Budget,
) -> MemoryPlan {
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let (dirs, _quadrature) = reference::all_directions(prep, set, params);
    let n2 = u64::from(params.resolution).pow(2);
    let m2 = u64::from(params.tile).pow(2);
    let tiles2 = u64::from(grid.tiles_per_side()).pow(2);
    let tris = prep.triangles.len() as u64;
    let faces = prep.faces.len() as u64;
    let x = prep.texel_count() as u64;

    // Mirror tiles, exactly as SpecularSetup::new builds them.
    let spec = SpecularSetup::new(prep, set, &grid, &dirs);
    let mut items_per_dir = vec![0u64; dirs.len()];
    let (tile_values, index_words, jobs, reflect_items) = match &spec {
        None => (0, 0, 0, 0),
        Some(s) => {
            let ix = &s.index;
            let words = ix.face_slot.len() + ix.index_start.len() + ix.tile_ids.len();
            let words = words + ix.coverage.len();
            let mut jobs = 0u64;
            for (per_dir, items) in s.jobs.iter().zip(&mut items_per_dir) {
                jobs += per_dir.len() as u64;
                for job in per_dir {
                    let mf = ix.face_slot[job.face as usize] as usize;
                    let k = mf * ix.directions as usize + job.j as usize;
                    *items += u64::from(ix.index_start[k + 1] - ix.index_start[k]);
                }
            }
            let items = items_per_dir.iter().sum();
            (ix.value_len() as u64, words as u64, jobs, items)
        }
    };
    drop(spec);

    // Bins of every transport direction, as both propagators build them, and the chunks the
    // GPU propagator splits them (with the reflect items) into; and the cells each triangle's
    // projected bounding box covers (widened by one cell, as the bins are), an upper bound on
    // the rays that can cross it.
    let limit = budget.buffer.as_ref().map_or(u64::MAX, |l| l.bytes);
    let mut chunker = Chunker::new(vlf_gpu::bake::chunk_cap(limit, None));
    let item_bytes = size_of::<vlf_gpu::layout::ReflectItem>() as u64;
    let mut k_max = 1u32;
    let mut binned_max = 0u64;
    let mut box_cells_max = 0u64;
    // The most bytes one direction uploads.
    let mut upload_max = 0u64;
    let (cell, n) = (grid.cell_size(), params.resolution as i64);
    let first = |x: f32| ((((x + 1.0) / cell - 0.5).floor() - 1.0) as i64).clamp(0, n - 1);
    let last = |x: f32| ((((x + 1.0) / cell - 0.5).ceil() + 1.0) as i64).clamp(0, n - 1);
    for (d, items) in dirs.iter().zip(&items_per_dir) {
        let proj = reference::project(prep, &d.frame);
        let bins = reference::bin_triangles(&proj, &grid);
        k_max = k_max.max(bins.max_len());
        binned_max = binned_max.max(bins.tris.len() as u64);
        let bytes = ChunkBytes {
            bin_start: bins.start.len() as u64 * 4,
            bin_tris: bins.tris.len() as u64 * 4,
            reflect_items: items * item_bytes,
        };
        upload_max = upload_max.max(bytes.sum());
        chunker.push(bytes);
        let box_cells: u64 = proj
            .iter()
            .map(|q| {
                let lo = q[0].min(q[1]).min(q[2]);
                let hi = q[0].max(q[1]).max(q[2]);
                let w = last(hi.x) - first(lo.x) + 1;
                let h = last(hi.y) - first(lo.y) + 1;
                (w.max(0) * h.max(0)) as u64
            })
            .sum();
        box_cells_max = box_cells_max.max(box_cells);
    }

    let enc = vlf_core::lightfield::DEFAULT_ENCODING.bytes_per_texel() as u64;
    let file = (x + tile_values) * enc + tris * 48 + faces * 80 + index_words * 4 + 16 * 1024;
    let job_bytes = size_of::<ReflectJob>() as u64;
    let texture_texels: u64 = scene.textures.iter().map(|t| t.pixels.len() as u64).sum();
    let mut items = vec![
        item(
            "process baseline (program, libraries)",
            "host",
            BASELINE_BYTES,
            1,
            1,
        ),
        item(
            "scene triangles (world)",
            "host",
            scene.triangles.len() as u64,
            size_of::<vlf_core::scene::Triangle>() as u64,
            1,
        ),
        item(
            "scene textures (decoded, RGBA f32)",
            "host",
            texture_texels,
            16,
            1,
        ),
    ];
    if gpu && software {
        items.push(item(
            "software GPU driver (Mesa, LLVM, shaders)",
            "host",
            SOFTWARE_DRIVER_BYTES,
            1,
            1,
        ));
    }
    // The items above do not depend on the parameters.
    let fixed = items.len();
    items.extend([
        item("triangles (prepared)", "host", tris, 48, 1),
        item(
            "texel arrays (area, centre, albedo, emission)",
            "host",
            x,
            52,
            1,
        ),
        item("texel radiance (unshot, next, total)", "host", x, 16, 3),
    ]);
    if gpu {
        let k_gpu = u64::from(k_max.min(GPU_MAX_CROSSINGS));
        let active = prep
            .faces
            .iter()
            .map(|f| {
                let base = f.texel_base as usize;
                prep.texel_area[base..base + f.texels_per_side() as usize]
                    .iter()
                    .filter(|a| **a > 0.0)
                    .count() as u64
            })
            .sum::<u64>();
        let (total, largest) = (chunker.total(), chunker.largest());
        // The propagator bins one direction at a time and writes it to its chunk; the writes'
        // staging copies live until the next submission, every UPLOAD_FLUSH_BYTES.
        let staging = total
            .sum()
            .min(vlf_gpu::bake::UPLOAD_FLUSH_BYTES + upload_max);
        items.extend([
            item("texel centres (upload copy)", "host", x, 16, 1),
            item("accumulators (read back)", "host", x, 32, 2),
            item(
                "tile values (unshot, next, total)",
                "host",
                tile_values,
                16,
                3,
            ),
            item(
                "tile bins and starts (one direction)",
                "host",
                2 * (tiles2 + 1) + binned_max,
                4,
                1,
            ),
            item("projected triangles (one direction)", "host", tris, 36, 1),
            item("upload staging (bins, items)", "host", staging, 1, 1),
            item(
                "reflect jobs (until the items are built)",
                "host",
                jobs,
                job_bytes,
                1,
            ),
            item("reflect items", "host", reflect_items, item_bytes, 1),
            item("encoded output file", "host", file, 1, 1),
            item("Bake::triangles", "gpu", tris, 48, 1),
            item("Bake::faces", "gpu", faces, 80, 1),
            item("Bake::texel_center", "gpu", x, 16, 1),
            item("Bake::active_texels", "gpu", active, 4, 1),
            split_item(
                "Bake::bin_start (all directions)",
                "Bake::bin_start[k]",
                4,
                total.bin_start,
                largest.bin_start,
                &chunker,
            ),
            split_item(
                "Bake::bin_tris (all directions)",
                "Bake::bin_tris[k]",
                4,
                total.bin_tris,
                largest.bin_tris,
                &chunker,
            ),
            item(
                "Bake::unshot (texels + tiles)",
                "gpu",
                x + tile_values,
                16,
                1,
            ),
            item("Bake::next_tiles", "gpu", tile_values, 16, 1),
            item("Bake::accumulators", "gpu", x, 32, 1),
            item("Bake::spec_escape", "gpu", n2, 16, 1),
            item("Bake::cell_count", "gpu", n2, 4, 1),
            item(
                "Bake::cells (N² × k_max depth entries)",
                "gpu",
                n2 * k_gpu,
                8,
                1,
            ),
            item("Bake::crossings (N² × k_max)", "gpu", n2 * k_gpu, 32, 1),
            item("Bake::tile_index", "gpu", index_words, 4, 1),
            item("Bake::frames", "gpu", set.len() as u64 * 3, 16, 1),
            split_item(
                "Bake::reflect_items (all directions)",
                "Bake::reflect_items[k]",
                item_bytes,
                total.reflect_items,
                largest.reflect_items,
                &chunker,
            ),
            item(
                "Bake::directions (uniforms)",
                "gpu",
                dirs.len() as u64,
                256,
                1,
            ),
        ]);
    } else {
        let crossings = (n2 * u64::from(k_max))
            .min(m2 * binned_max)
            .min(box_cells_max);
        items.extend([
            item("accumulators and texel faces", "host", x, 36, 1),
            item(
                "tile values (unshot, next, total)",
                "host",
                tile_values,
                16,
                3,
            ),
            item("tile index", "host", index_words, 4, 1),
            item("reflect jobs", "host", jobs, job_bytes, 1),
            item(
                "ray crossing lists (one direction)",
                "host",
                crossings,
                CROSSING_BYTES,
                1,
            ),
            item(
                "tile bins (one direction)",
                "host",
                tiles2 + 1 + binned_max,
                4,
                1,
            ),
            item("projected triangles (one direction)", "host", tris, 36, 1),
            item("encoded output file", "host", file, 1, 1),
        ]);
    }
    // Every item's count fits easily; saturate anyway so absurd inputs cannot wrap.
    let sum = |items: &[PlanItem], place: &str| {
        items
            .iter()
            .filter(|i| i.place == place)
            .fold(0u64, |s, i| s.saturating_add(i.bytes))
    };
    // Heap fragmentation and freed-but-resident memory (measured: the peak resident size of
    // CPU bakes of the shared scenes is within +6 % of the items above).
    let overhead = sum(&items, "host") / 10;
    items.push(item(
        "allocator overhead (10 % of the above)",
        "host",
        overhead,
        1,
        1,
    ));
    let host_bytes = sum(&items, "host");
    let device_bytes = sum(&items, "gpu");
    let fixed_bytes = items[..fixed].iter().map(|i| i.bytes).sum::<u64>() * 11 / 10;
    let largest_buffer = items
        .iter()
        .filter(|i| i.place == "gpu")
        .map(PlanItem::largest_buffer)
        .max_by_key(|i| i.bytes);
    MemoryPlan {
        path: if gpu { "gpu" } else { "cpu" },
        resolution: params.resolution,
        tile: params.tile,
        directions: set.len(),
        transport_directions: dirs.len(),
        triangles: tris,
        faces,
        texels: x,
        tile_values,
        k_max,
        binned_max,
        items,
        host_bytes,
        fixed_bytes,
        device_bytes,
        largest_buffer,
        budget: budget.clone(),
        over_budget: Vec::new(),
        lowered_from: None,
        plan_s: 0.0,
    }
}

/// What the GPU reported while a bake ran.
#[derive(Default)]
struct GpuTrap {
    /// First uncaptured error: (kind from the variant name, message).
    error: Option<(String, String)>,
    lost: Option<String>,
}

/// Runs `f` (a GPU propagation) with wgpu's error reporting redirected: an uncaptured error
/// (out of memory, validation) or a lost device no longer panics inside wgpu but is turned into
/// a [`MemoryError`] naming the planned GPU memory. wgpu's default uncaptured-error handler
/// panics; this replaces it for the device (bakes on one device are serialised by the caller).
pub fn guard_gpu<T>(
    ctx: &vlf_gpu::GpuContext,
    plan: &MemoryPlan,
    f: impl FnOnce() -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let trap = Arc::new(Mutex::new(GpuTrap::default()));
    let t = trap.clone();
    ctx.device.on_uncaptured_error(Arc::new(move |e| {
        let kind = format!("{e:?}");
        let kind = kind
            .split(|c: char| !c.is_alphanumeric())
            .next()
            .unwrap_or_default()
            .to_string();
        let msg = e.to_string();
        log::debug!("wgpu uncaptured error ({kind}): {msg}");
        let mut g = t.lock().unwrap_or_else(|p| p.into_inner());
        if g.error.is_none() {
            g.error = Some((kind, msg));
        }
    }));
    let t = trap.clone();
    ctx.device.set_device_lost_callback(move |reason, msg| {
        let mut g = t.lock().unwrap_or_else(|p| p.into_inner());
        g.lost.get_or_insert_with(|| format!("{reason:?}: {msg}"));
    });
    let result = f();
    let g = trap.lock().unwrap_or_else(|p| p.into_inner());
    let planned = plan.device_bytes;
    if let Some(detail) = &g.lost {
        return Err(MemoryError::DeviceLost {
            detail: detail.clone(),
        }
        .into());
    }
    if let Some((kind, msg)) = &g.error {
        let err = if kind == "OutOfMemory" || msg.to_ascii_lowercase().contains("out of memory") {
            MemoryError::GpuOutOfMemory {
                detail: msg.clone(),
                planned,
            }
        } else {
            MemoryError::Gpu {
                detail: format!("{kind}: {msg}"),
            }
        };
        return Err(err.into());
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("512"), Ok(512));
        assert_eq!(parse_size("1K"), Ok(1024));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("2G"), Ok(2 << 30));
        assert_eq!(parse_size("2g"), Ok(2 << 30));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        assert_eq!(parse_size("2GB"), Ok(2 << 30));
        assert_eq!(parse_size("1.5G"), Ok(3 << 29));
        assert_eq!(parse_size(" 1 T "), Ok(1 << 40));
        for bad in ["", "G", "2X", "-1G", "0", "1.2.3M", "2Gi x", "5i"] {
            assert!(parse_size(bad).is_err(), "{bad:?} should be rejected");
        }
    }

    #[test]
    fn human_sizes() {
        assert_eq!(human(1000), "1000 B");
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(human(3 << 30), "3.0 GiB");
    }

    #[test]
    fn meminfo_parses() {
        let text = "MemTotal:       24596120 kB\nMemFree:         1000 kB\n";
        assert_eq!(parse_meminfo(text), Some(24_596_120 * 1024));
        assert_eq!(parse_meminfo("MemFree: 3 kB\n"), None);
    }

    #[test]
    fn halving_keeps_the_tile_a_divisor() {
        let p = BakeParams {
            resolution: 64,
            tile: 8,
            ..BakeParams::paper()
        };
        let h = halve(&p).unwrap();
        assert_eq!((h.resolution, h.tile), (32, 8));
        let p = BakeParams {
            resolution: 24,
            tile: 8,
            ..p
        };
        let h = halve(&p).unwrap();
        assert_eq!((h.resolution, h.tile), (12, 6));
        h.validate().unwrap();
        let p = BakeParams {
            resolution: 16,
            tile: 16,
            ..p
        };
        let h = halve(&p).unwrap();
        assert_eq!((h.resolution, h.tile), (8, 8));
        assert!(halve(&h).is_none(), "never below MIN_RESOLUTION");
        let odd = BakeParams {
            resolution: 30,
            tile: 5,
            ..p
        };
        assert_eq!(halve(&odd).map(|p| (p.resolution, p.tile)), Some((15, 5)));
        let odd = BakeParams {
            resolution: 15,
            tile: 5,
            ..p
        };
        assert!(halve(&odd).is_none());
    }

    /// The GPU context for tests, or `None` (skip) when there is no adapter and
    /// `VLF_REQUIRE_GPU` is not `1` (as `vlf_tests::gpu()` does).
    fn gpu() -> Option<vlf_gpu::GpuContext> {
        match vlf_gpu::GpuContext::new(&Default::default()) {
            Ok(ctx) => Some(ctx),
            Err(e) if std::env::var("VLF_REQUIRE_GPU").as_deref() != Ok("1") => {
                eprintln!("skipping GPU test: {e}");
                None
            }
            Err(e) => panic!("VLF_REQUIRE_GPU=1 but no GPU: {e}"),
        }
    }

    fn gpu_plan(ctx: vlf_gpu::GpuContext) -> (Compute, MemoryPlan) {
        let scene = cornell();
        let p = BakeParams {
            directions: 6,
            resolution: 16,
            tile: 8,
            ..BakeParams::paper()
        };
        let compute = Compute::Gpu(Box::new(ctx));
        let budget = Budget::new(None, &compute, 1);
        assert!(budget.buffer.is_some() && budget.host.is_some());
        let planned = plan_and_prepare(&scene, &p, &compute, &budget, Path::new("t")).unwrap();
        assert!(planned.plan.device_bytes > 0 && planned.plan.largest_buffer.is_some());
        (compute, planned.plan)
    }

    #[test]
    fn gpu_errors_become_messages_not_panics() {
        let Some(ctx) = gpu() else { return };
        let (compute, plan) = gpu_plan(ctx);
        let Compute::Gpu(ctx) = &compute else {
            unreachable!()
        };
        // An unbalanced debug group is a validation error, which wgpu's default handler turns
        // into a panic.
        let err = guard_gpu(ctx, &plan, || {
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            enc.pop_debug_group();
            ctx.queue.submit(Some(enc.finish()));
            Ok(())
        })
        .expect_err("the validation error is reported");
        let e = err.downcast_ref::<MemoryError>().expect("a MemoryError");
        assert!(matches!(e, MemoryError::Gpu { .. }), "{e}");
        // The device is still usable afterwards, and a clean run passes.
        guard_gpu(ctx, &plan, || Ok(())).unwrap();
        // A lost device is reported as such.
        let err = guard_gpu(ctx, &plan, || {
            ctx.device.destroy();
            ctx.wait_idle();
            Ok(())
        })
        .expect_err("device loss is reported");
        let e = err.downcast_ref::<MemoryError>().expect("a MemoryError");
        assert!(matches!(e, MemoryError::DeviceLost { .. }), "{e}");
        assert!(e.to_string().contains("device was lost"), "{e}");
    }

    fn cornell() -> Scene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../assets/cornell-mirror/cornell-mirror.gltf");
        vlf_core::scene::load(&path).expect("bundled asset loads")
    }

    #[test]
    fn texel_count_matches_the_preparation() {
        let scene = cornell();
        for (n, s) in [(16, 1.0), (64, 1.0), (48, 0.7)] {
            let p = BakeParams {
                resolution: n,
                tile: 8,
                texel_scale: s,
                ..BakeParams::paper()
            };
            let prep = BakeScene::new(&scene, &p).unwrap();
            assert_eq!(texel_count(&scene, &p), prep.texel_count() as u64);
        }
    }

    #[test]
    fn plan_matches_the_cpu_propagator_and_lowers_to_fit() {
        let scene = cornell();
        let p = BakeParams {
            directions: 6,
            resolution: 32,
            tile: 8,
            ..BakeParams::paper()
        };
        let cpu = Compute::Cpu("test".into());
        let unlimited = Budget::default();
        let planned = plan_and_prepare(&scene, &p, &cpu, &unlimited, Path::new("t")).unwrap();
        let plan = &planned.plan;
        assert!(plan.fits());
        assert_eq!(planned.params, p);
        assert_eq!(plan.texels, planned.prep.texel_count() as u64);
        // The tile values are what the propagator allocates.
        let out = reference::propagate(&planned.prep, &planned.set, &p);
        let (_, values) = out.tiles.expect("mirror scene has tiles");
        assert_eq!(plan.tile_values, values.len() as u64);
        assert!(plan.k_max >= 1 && plan.host_bytes > 0 && plan.device_bytes == 0);

        // A budget just below the plan lowers the resolution once, with a warning.
        let tight = Budget {
            host: Some(Limit {
                bytes: plan.host_bytes - 1,
                source: "test".into(),
            }),
            ..Budget::default()
        };
        let lowered = plan_and_prepare(&scene, &p, &cpu, &tight, Path::new("t")).unwrap();
        assert_eq!(lowered.params.resolution, 16);
        assert_eq!(lowered.plan.lowered_from, Some(32));
        let variable = |p: &MemoryPlan| p.host_bytes - p.fixed_bytes;
        assert!(variable(&lowered.plan) < variable(plan) / 2);
        assert!(
            lowered
                .prep
                .warnings
                .iter()
                .any(|w| w.contains("lowered from 32 to 16"))
        );

        // Nothing fits in 1 KiB: a refusal naming the budget and what to change.
        let tiny = Budget {
            host: Some(Limit {
                bytes: 1024,
                source: "--max-memory 1.0 KiB".into(),
            }),
            ..Budget::default()
        };
        let err = plan_and_prepare(&scene, &p, &cpu, &tiny, Path::new("scene.gltf"))
            .err()
            .expect("refused");
        let msg = format!("{err:#}");
        assert!(msg.contains("does not fit the memory budget"), "{msg}");
        assert!(msg.contains("--max-memory 1.0 KiB"), "{msg}");
        assert!(msg.contains("from 32 to 8"), "{msg}");
        assert!(msg.contains("alone need"), "{msg}");
        let Some(MemoryError::OverBudget { plan: at8, .. }) = err.downcast_ref::<MemoryError>()
        else {
            panic!("not an OverBudget error: {msg}")
        };
        assert_eq!(at8.resolution, 8);

        // Above what the program and scene need but below the smallest bake: the message says
        // which parameters to change.
        let small = Budget {
            host: Some(Limit {
                bytes: at8.fixed_bytes + 1000,
                source: "--max-memory".into(),
            }),
            ..Budget::default()
        };
        assert!(at8.host_bytes > at8.fixed_bytes + 1000);
        let err = plan_and_prepare(&scene, &p, &cpu, &small, Path::new("scene.gltf"))
            .err()
            .expect("refused");
        let msg = format!("{err:#}");
        assert!(msg.contains("lower --directions (now 6)"), "{msg}");
        assert!(msg.contains("Raise --max-memory"), "{msg}");
    }

    #[test]
    fn gpu_plan_splits_the_bins_into_chunks_as_the_propagator_does() {
        let scene = cornell();
        let p = BakeParams {
            directions: 46,
            resolution: 32,
            tile: 8,
            ..BakeParams::paper()
        };
        let prep = BakeScene::new(&scene, &p).unwrap();
        let set = DirectionSet::at_least(p.directions).unwrap();
        let with_limit = |bytes: u64| Budget {
            buffer: Some(Limit {
                bytes,
                source: "test".into(),
            }),
            ..Budget::default()
        };
        let plan = |limit: u64| {
            let mut plan = plan_prepared(&scene, &prep, &set, &p, true, true, &with_limit(limit));
            plan.check(true);
            plan
        };
        let find = |plan: &MemoryPlan, name: &str| {
            plan.items
                .iter()
                .find(|i| i.name == name)
                .unwrap_or_else(|| panic!("no {name} in {plan}"))
                .clone()
        };
        let split_names = [
            "Bake::bin_start (all directions)",
            "Bake::bin_tris (all directions)",
            "Bake::reflect_items (all directions)",
        ];
        let layout = |limit| vlf_gpu::bake::chunk_layout(&prep, &set, &p, limit, None);

        // Default cap (128 MiB): one buffer each, as the propagator makes them.
        let whole = plan(128 << 20);
        assert!(whole.fits(), "{whole}");
        let chunks = layout(128 << 20);
        assert_eq!(chunks.len(), 1);
        let tris = find(&whole, split_names[1]);
        let s = tris.split.clone().expect("split item");
        assert_eq!((s.buffers, s.largest, s.cap), (1, tris.bytes, 128 << 20));
        assert_eq!(tris.bytes, chunks[0].bytes.bin_tris);
        assert_eq!(
            find(&whole, split_names[2]).bytes,
            chunks[0].bytes.reflect_items
        );
        assert!(find(&whole, split_names[2]).bytes > 0, "mirror scene");
        let host_bins = find(&whole, "tile bins and starts (one direction)").bytes;

        // A limit of a quarter of the bins: several buffers with the propagator's split, the
        // same totals, every part within the limit; the host fills one chunk at a time.
        let limit = tris.bytes / 4;
        let split = plan(limit);
        let chunks = layout(limit);
        assert!(chunks.len() >= 4, "{chunks:?}");
        for (name, part) in split_names.iter().zip([
            chunks.iter().map(|c| c.bytes.bin_start).max(),
            chunks.iter().map(|c| c.bytes.bin_tris).max(),
            chunks.iter().map(|c| c.bytes.reflect_items).max(),
        ]) {
            let (a, b) = (find(&whole, name), find(&split, name));
            assert_eq!(a.bytes, b.bytes, "{name}: same total");
            let s = b.split.expect("split item");
            assert_eq!(s.buffers, chunks.len() as u64, "{name}");
            assert_eq!(Some(s.largest), part, "{name}");
            assert!(s.largest <= limit, "{name}: {s:?}");
        }
        assert_eq!(split.device_bytes, whole.device_bytes);
        // The host side does not depend on the split.
        assert_eq!(
            find(&split, "tile bins and starts (one direction)").bytes,
            host_bins
        );
        assert_eq!(split.host_bytes, whole.host_bytes);
        assert!(
            split.over_budget.iter().all(|o| !o.contains("Bake::bin_")),
            "{:?}",
            split.over_budget
        );
        // The largest buffer is a whole item or the largest part of a split one.
        let biggest = split
            .items
            .iter()
            .filter(|i| i.place == "gpu")
            .map(|i| i.split.as_ref().map_or(i.bytes, |s| s.largest))
            .max();
        assert_eq!(split.largest_buffer.as_ref().map(|b| b.bytes), biggest);
        assert!(split.to_string().contains(&format!(
            "in {} buffers of ≤ {}",
            chunks.len(),
            human(limit)
        )));

        // Below one direction's bins: one direction per chunk, and that is still too large for
        // one buffer (halving or refusal, as for any other buffer).
        let one_dir = layout(1).iter().map(|c| c.bytes.bin_tris).max().unwrap();
        let tiny = plan(one_dir - 4);
        let s = find(&tiny, split_names[1]).split.unwrap();
        assert_eq!(s.buffers as usize, layout(1).len());
        assert_eq!(s.largest, one_dir);
        assert!(!tiny.fits());
        let big = tiny.largest_buffer.as_ref().unwrap();
        assert!(big.bytes >= one_dir && big.bytes > one_dir - 4, "{big:?}");
    }
}
