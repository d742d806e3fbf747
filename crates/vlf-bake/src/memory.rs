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
//!   next) and irradiance + `36 X` accumulators and face ids + `3 × 16 V` tile values + tile index +
//!   reflect jobs + `40 × min(N² k_max, m² max_d B_d, max_d C_d)` crossing lists (per
//!   crossing a depth entry of 8 B and the arriving radiance, 28 B on the CPU and 32 B on the
//!   GPU; `C_d` = Σ over triangles of the cells their projected bounding box covers, widened by
//!   one cell as the bins are) + `4 ((N/m)² + 1 + max_d B_d) + 36 T` bins and projections +
//!   `48 T` triangles + the encoded output file;
//! * GPU path: the GPU buffers are those of `vlf_gpu::bake::BakePlan`, the one list the
//!   propagator allocates from (sizes from the `#[repr(C)]` element types: geometry, texel
//!   centres, active texels, unshot `16 (X + V)`, next tiles, accumulators, escape and count
//!   buffers, `N² min(k_max, 256)` depth entries and crossings, tile index, frames, the
//!   overflow counter, the per-direction uniforms, and the chunked tile starts, tile bins and
//!   reflect items), each storage buffer checked against the adapter's binding limit; plus
//!   host memory for the CPU-side copies (prepared arrays, radiance, tiles, reflect jobs and
//!   items, one direction's bins, the upload staging, read-backs, the encoded file).
//!   On a software adapter (lavapipe) the GPU buffers live in system RAM and count against host
//!   memory too.
//!
//! The buffers with something for every transport direction (tile bins `4 B_d`, tile starts
//! `4 ((N/m)² + 1)`, reflect items) are split into chunks of whole directions
//! (`vlf_gpu::bake::chunks`; the plan makes the split the propagator uses), each at most
//! min(128 MiB, binding limit): their total counts against memory, their largest chunk against
//! the binding limit. Only a single direction larger than the limit makes such a buffer too
//! large (then `--resolution` is halved, or the bake refused, as for any other buffer). The
//! host bins one direction at a time and writes it into its chunk (staging flushed every
//! 32 MiB), so it never holds the bins of every direction. The GPU plan made here is handed
//! to the propagator ([`Planned::params`] and `MemoryPlan::gpu`), which therefore bins every
//! direction only once more, to upload it.
//!
//! The reflect jobs are counted without being made (`SpecularSetup::counted`: a glossy face's
//! lobe is walked but not normalised, nothing is kept), on both paths, and later made at
//! exactly that length; while they are made, the lobe of one glossy face at a time is their
//! working memory (`LOBE_BYTES_PER_JOB` per job of the face with the most). A glossy lobe's
//! jobs grow with its faces × the directions (~25 per incoming direction and side, against 3
//! for a mirror), not with the resolution: when the plan does not fit, the glossy lobes are
//! first modelled as mirrors (a warning; `--json`'s `materials` say `mirror`), and only then
//! is `--resolution` lowered.
//!
//! The plan is an upper bound: the crossing lists assume that every ray meets every triangle
//! whose bounding box (GPU: whose tile bin) it passes through.

mod budget;
mod plan;

use std::fmt;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;
use vlf_core::bake::BakeScene;
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::BakeParams;
use vlf_core::scene::Scene;
use vlf_gpu::bake::BakePlan;
use vlf_gpu::device::GpuFault;

pub use budget::{Budget, Limit, human, parse_size, system_ram};
pub use plan::plan_prepared;

use crate::Compute;

/// `--resolution` is never lowered below this.
pub const MIN_RESOLUTION: u32 = 8;
/// Bytes per ray crossing: depth entry (8) + arriving radiance (32).
pub const CROSSING_BYTES: u64 = 40;
/// Resident memory of the process before any scene (measured: 5–7 MiB for `vlf-bake`).
const BASELINE_BYTES: u64 = 8 << 20;
/// Resident memory of a software adapter's driver (Mesa, LLVM, the compiled shaders): measured
/// 93 MiB peak for a GPU bake of the Cornell box on lavapipe against 8 MiB on the CPU path.
const SOFTWARE_DRIVER_BYTES: u64 = 96 << 20;

/// One line of a [`MemoryPlan`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanItem {
    pub name: String,
    /// `host` or `gpu`.
    pub place: &'static str,
    /// Elements (texels, values, crossings, …) in one copy.
    pub count: u64,
    pub bytes_each: u64,
    pub copies: u64,
    /// `count × bytes_each × copies`; a GPU buffer's allocated size, which pads an empty
    /// array (one element, or 16 bytes).
    pub bytes: u64,
    /// A GPU item split into several buffers (chunks of whole directions); `bytes` is their sum.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split: Option<Split>,
}

/// How a [`PlanItem`] is split into GPU buffers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Split {
    /// One buffer's name in messages (`Bake::bin_tris[k]`).
    pub part: String,
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
                name: s.part.clone(),
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
    /// The GPU path's buffers, which the propagator allocates (not in the JSON report: the
    /// GPU items above list them).
    #[serde(skip)]
    pub gpu: Option<BakePlan>,
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

    /// Bytes of the reflect jobs and the GPU's reflect items (host and GPU).
    fn reflect_bytes(&self) -> u64 {
        self.items
            .iter()
            .filter(|i| i.name.starts_with("reflect") || i.name.starts_with("Bake::reflect"))
            .map(|i| i.bytes)
            .sum()
    }

    /// The largest items, for messages: `crossing lists 12.0 MiB, texel radiance 3.0 MiB`.
    pub fn largest_items(&self, n: usize) -> String {
        let mut items: Vec<&PlanItem> = self.items.iter().collect();
        items.sort_by(|a, b| b.bytes.cmp(&a.bytes).then(a.name.cmp(&b.name)));
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
        Compute::Gpu(ctx, _) => (true, ctx.summary.is_software()),
    };
    let mut params = requested.clone();
    let mut prep_s = 0.0;
    // Why the requested resolution did not fit (for the warning).
    let mut first_over: Option<Vec<String>> = None;
    // Glossy lobes modelled as mirrors to fit: the materials, why, the glossy plan's host
    // bytes and its reflect jobs' and items' bytes.
    let mut as_mirrors: Option<(Vec<String>, Vec<String>, u64, u64)> = None;
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
        let mut prep = BakeScene::new(scene, &params).context("preparing the scene")?;
        if as_mirrors.is_some() {
            glossy_as_mirrors(scene, &mut prep);
        }
        prep_s += tp.elapsed().as_secs_f64();
        let mut plan = plan_prepared(scene, &prep, &set, &params, gpu, software, budget);
        plan.check(software);
        // A glossy lobe's reflect jobs grow with the faces and directions, not the resolution:
        // model its lobes as mirrors (three jobs per incoming direction) before lowering it.
        if !plan.fits() && as_mirrors.is_none() {
            let materials = glossy_as_mirrors(scene, &mut prep);
            if !materials.is_empty() {
                log::debug!("{}: {plan}", scene_path.display());
                as_mirrors = Some((
                    materials,
                    plan.over_budget.clone(),
                    plan.host_charged(software),
                    plan.reflect_bytes(),
                ));
                continue;
            }
        }
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
        // What the fitted plan needs, as the warnings below say it.
        let needs = |plan: &MemoryPlan| {
            let gpu = if plan.device_bytes > 0 {
                format!(" and {} of GPU buffers", human(plan.device_bytes))
            } else {
                String::new()
            };
            format!("{} of host memory{gpu}", human(plan.host_bytes))
        };
        if let Some((materials, why, glossy_bytes, glossy_jobs)) = &as_mirrors {
            prep.warnings.push(format!(
                "glossy lobes modelled as mirrors (materials: {}) to fit the memory budget: as directional tiles the bake needs {} ({} of it the reflect jobs): {}; now it needs {} (raise --max-memory, or lower --directions, to keep the lobes)",
                materials.join(", "),
                human(*glossy_bytes),
                human(*glossy_jobs),
                why.join("; "),
                needs(&plan),
            ));
        }
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
                "--resolution lowered from {} to {} (tile {}) to fit the memory budget: at {}, {}; now the bake needs {} ({hint})",
                requested.resolution,
                params.resolution,
                params.tile,
                requested.resolution,
                why.join("; "),
                needs(&plan),
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

/// Models every glossy lobe of `prep` (directional tiles) as a mirror, the model of a lobe
/// narrower than the direction spacing (`glossy::model`, scaled by its directional albedo);
/// the names of the materials it changed.
pub fn glossy_as_mirrors(scene: &Scene, prep: &mut BakeScene) -> Vec<String> {
    use vlf_core::bake::glossy::SpecularModel;
    let as_mirror = |model: &mut SpecularModel| match *model {
        SpecularModel::Tiles { alpha } => {
            *model = SpecularModel::Mirror { alpha };
            true
        }
        _ => false,
    };
    prep.lobes.iter_mut().for_each(|l| {
        as_mirror(l);
    });
    prep.materials
        .iter_mut()
        .zip(&scene.materials)
        .filter_map(|(b, m)| as_mirror(&mut b.model).then(|| m.name.clone()))
        .collect()
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

/// Runs `f` (a GPU propagation) with the GPU's errors trapped (`GpuContext::trap`): an
/// out-of-memory or validation error or a lost device becomes a [`MemoryError`] naming the
/// planned GPU memory instead of wgpu's default panic.
pub fn guard_gpu<T>(
    ctx: &vlf_gpu::GpuContext,
    plan: &MemoryPlan,
    f: impl FnOnce() -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let err = match ctx.trap(f) {
        Ok(result) => return result,
        Err(GpuFault::OutOfMemory { detail }) => MemoryError::GpuOutOfMemory {
            detail,
            planned: plan.device_bytes,
        },
        Err(GpuFault::DeviceLost { detail }) => MemoryError::DeviceLost { detail },
        Err(GpuFault::Error { kind, message }) => MemoryError::Gpu {
            detail: format!("{kind}: {message}"),
        },
    };
    Err(err.into())
}

#[cfg(test)]
mod tests;
