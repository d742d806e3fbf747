//! The items of a [`MemoryPlan`]: host memory of either path, and on the GPU path the buffers
//! of the propagator's own `BakePlan` (formulas in the module documentation of `memory`).

use vlf_core::bake::BakeScene;
use vlf_core::bake::glossy::SpecularModel;
use vlf_core::bake::reference::{self, ReflectJob, SpecularSetup};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::BakeParams;
use vlf_core::psf::PsfGrid;
use vlf_core::scene::Scene;
use vlf_gpu::bake::{BakePlan, MirrorCounts};

use super::{
    BASELINE_BYTES, Budget, CROSSING_BYTES, MemoryPlan, PlanItem, SOFTWARE_DRIVER_BYTES, Split,
};

fn item(name: &str, place: &'static str, count: u64, each: u64, copies: u64) -> PlanItem {
    PlanItem {
        name: name.to_string(),
        place,
        count,
        bytes_each: each,
        copies,
        bytes: count * each * copies,
        split: None,
    }
}

/// The GPU items of `plan`: one per buffer, one per chunked buffer with its chunks summed.
fn gpu_items(plan: &BakePlan) -> Vec<PlanItem> {
    use vlf_gpu::bake::BakeBuffer;
    let mut items = Vec::new();
    for kind in [
        BakeBuffer::BinStart,
        BakeBuffer::BinTris,
        BakeBuffer::ReflectItems,
    ] {
        let parts: Vec<_> = plan.buffers.iter().filter(|b| b.buffer == kind).collect();
        let each = parts.first().map_or(1, |b| b.element_bytes);
        items.push(PlanItem {
            name: format!("{} (all directions)", kind.name()),
            place: "gpu",
            count: parts.iter().map(|b| b.elements).sum(),
            bytes_each: each,
            copies: 1,
            bytes: parts.iter().map(|b| b.size).sum(),
            split: Some(Split {
                part: format!("{}[k]", kind.name()),
                buffers: parts.len() as u64,
                largest: parts.iter().map(|b| b.size).max().unwrap_or(0),
                cap: plan.chunk_cap,
            }),
        });
    }
    items.extend(
        plan.buffers
            .iter()
            .filter(|b| !b.buffer.chunked())
            .map(|b| PlanItem {
                bytes: b.size,
                ..item(b.buffer.name(), "gpu", b.elements, b.element_bytes, 1)
            }),
    );
    items
}

/// The GPU final gather's buffers (`vlf_gpu::gather::GatherPlan`, at its peak: the shared
/// buffers and the larger grid's), from counts estimated before propagating: its grids'
/// texels counted as [`super::texel_count`] counts the propagation's, at the gather's texel
/// sizes; the BVH at its bound of two nodes per triangle; every triangle of an emissive
/// material an emitter; per-corner attributes for every triangle with any. They are allocated
/// after the propagation's are freed, so adding them to the GPU total overestimates the peak a
/// little.
fn gather_items(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    gp: &vlf_core::lightfield::GatherParams,
    (set, mirror): (&DirectionSet, &MirrorCounts),
    budget: &Budget,
) -> Vec<PlanItem> {
    use vlf_gpu::gather::{GatherCounts, GatherOptions, GatherPlan};
    let at = |scale: f32| {
        super::texel_count(
            scene,
            &BakeParams {
                texel_scale: scale,
                ..params.clone()
            },
        )
    };
    let count = |f: &dyn Fn(&vlf_core::scene::Triangle) -> bool| {
        scene.triangles.iter().filter(|t| f(t)).count() as u64
    };
    let triangles = scene.triangles.len() as u64;
    let tiled = mirror.tile_values > 0;
    let counts = GatherCounts {
        indirect_texels: at(gp.indirect_texel_scale),
        direct_texels: at(gp.texel_scale),
        faces: prep.faces.len() as u64,
        triangles,
        bvh_nodes: 2 * triangles,
        smooth_triangles: count(&|t| t.normals.is_some()),
        attributed_triangles: count(&|t| {
            t.normals.is_some() || t.colors.is_some() || t.uv1.is_some()
        }),
        mask_words: prep.masks.word_count() as u64,
        materials: scene.materials.len() as u64,
        emitters: count(&|t| scene.materials[t.material as usize].is_emissive()),
        delta_lights: (scene.suns.len() + scene.lights.len()) as u64,
        textures: scene.textures.len() as u64,
        texture_texels: scene.textures.iter().map(|t| t.pixels.len() as u64).sum(),
        direction_mesh: (set.sphere_vertices().len() + set.sphere_triangles().len()) as u64,
        field_texels: prep.texel_count() as u64,
        tile_values: mirror.tile_values,
        tile_index_words: if tiled { mirror.index_words } else { 0 },
        tile_directions: if tiled { set.len() as u64 } else { 0 },
    };
    let limit = budget.buffer.as_ref().map_or(u64::MAX, |l| l.bytes);
    let plan = GatherPlan::new(&counts, gp, &GatherOptions::default(), limit, 256);
    plan.peak()
        .into_iter()
        .map(|b| PlanItem {
            bytes: b.bytes,
            ..item(
                &format!("final gather: {}", b.name),
                "gpu",
                b.elements,
                b.element_bytes,
                1,
            )
        })
        .collect()
}

/// What the CPU path's plan needs from every transport direction's bins: the longest tile
/// bin (≥ 1), the most triangle entries binned in one direction, and the most cells the
/// triangles' projected bounding boxes of one direction cover (widened by one cell, as the
/// bins are), an upper bound on the rays that can cross them.
fn scan_directions(
    prep: &BakeScene,
    dirs: &[reference::TransportDir],
    grid: &PsfGrid,
) -> (u32, u64, u64) {
    let mut k_max = 1u32;
    let mut binned_max = 0u64;
    let mut box_cells_max = 0u64;
    let (cell, n) = (grid.cell_size(), grid.n as i64);
    let first = |x: f32| ((((x + 1.0) / cell - 0.5).floor() - 1.0) as i64).clamp(0, n - 1);
    let last = |x: f32| ((((x + 1.0) / cell - 0.5).ceil() + 1.0) as i64).clamp(0, n - 1);
    for d in dirs {
        let proj = reference::project(prep, &d.frame);
        let bins = reference::bin_triangles(&proj, grid);
        k_max = k_max.max(bins.max_len());
        binned_max = binned_max.max(bins.tris.len() as u64);
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
    (k_max, binned_max, box_cells_max)
}

/// What the propagation will hold at its peak, counted before it runs.
struct Counts {
    /// The GPU propagator's own plan (GPU path only).
    gpu_plan: Option<BakePlan>,
    mirror: MirrorCounts,
    transport: usize,
    k_max: u32,
    binned_max: u64,
    box_cells_max: u64,
}

/// The GPU path: the propagator's own plan (it bins every direction once, makes the chunks
/// and the mirror tile index, and counts the reflect jobs). The CPU path: the mirror tile
/// index and the reflect jobs counted as SpecularSetup::new makes them (glossy lobes walked,
/// not normalised, nothing kept), and the bins and bounding boxes of every direction.
fn counts(
    prep: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    gpu: bool,
    budget: &Budget,
    grid: &PsfGrid,
) -> Counts {
    if gpu {
        let limit = budget.buffer.as_ref().map_or(u64::MAX, |l| l.bytes);
        let plan = BakePlan::new(prep, set, params, limit, None);
        let binned_max = plan.direction_bytes.iter().map(|b| b.bin_tris / 4).max();
        Counts {
            mirror: plan.mirror.clone(),
            transport: plan.transport_directions,
            k_max: plan.k_max,
            binned_max: binned_max.unwrap_or(0),
            box_cells_max: 0,
            gpu_plan: Some(plan),
        }
    } else {
        let (dirs, _quadrature) = reference::all_directions(prep, set, params);
        // Counted, not made (as the GPU plan does): the reflect jobs may be what does not fit.
        let counted = SpecularSetup::counted(prep, set, grid, &dirs);
        let mirror = MirrorCounts::counted(counted.as_ref(), set.len(), dirs.len());
        let (k_max, binned_max, box_cells_max) = scan_directions(prep, &dirs, grid);
        Counts {
            gpu_plan: None,
            mirror,
            transport: dirs.len(),
            k_max,
            binned_max,
            box_cells_max,
        }
    }
}

/// The items that do not depend on the parameters: the process, the scene, a software driver.
fn fixed_items(scene: &Scene, gpu: bool, software: bool) -> Vec<PlanItem> {
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
    items
}

/// The propagation's own host items on the GPU path (beside `gpu_items`, the device's).
fn gpu_host_items(
    plan: &BakePlan,
    c: &Counts,
    x: u64,
    tris: u64,
    tiles2: u64,
    file: u64,
) -> Vec<PlanItem> {
    let (mirror, binned_max) = (&c.mirror, c.binned_max);
    let (tile_values, jobs) = (mirror.tile_values, mirror.reflect_jobs);
    let job_bytes = size_of::<ReflectJob>() as u64;
    let item_bytes = size_of::<vlf_gpu::layout::ReflectItem>() as u64;
    // The propagator bins one direction at a time and writes it to its chunk; the writes'
    // staging copies live until the next submission, every UPLOAD_FLUSH_BYTES.
    let upload_max = plan.direction_bytes.iter().map(|b| b.sum()).max();
    let total: u64 = plan.chunks.iter().map(|c| c.bytes.sum()).sum();
    let staging = total.min(vlf_gpu::bake::UPLOAD_FLUSH_BYTES + upload_max.unwrap_or(0));
    vec![
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
        item(
            "reflect items",
            "host",
            mirror.reflect_items(),
            item_bytes,
            1,
        ),
        item("encoded output file", "host", file, 1, 1),
    ]
}

/// The propagation's host items on the CPU path.
fn cpu_items(
    params: &BakeParams,
    c: &Counts,
    x: u64,
    tris: u64,
    tiles2: u64,
    file: u64,
) -> Vec<PlanItem> {
    let (mirror, k_max, binned_max, box_cells_max) =
        (&c.mirror, c.k_max, c.binned_max, c.box_cells_max);
    let (tile_values, index_words, jobs) =
        (mirror.tile_values, mirror.index_words, mirror.reflect_jobs);
    let job_bytes = size_of::<ReflectJob>() as u64;
    let n2 = u64::from(params.resolution).pow(2);
    let m2 = u64::from(params.tile).pow(2);
    let crossings = (n2 * u64::from(k_max))
        .min(m2 * binned_max)
        .min(box_cells_max);
    vec![
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
    ]
}

/// The reflect jobs of the glossy face with the most: its lobe is held while they are made
/// (one face at a time); 0 without glossy tiles.
fn glossy_lobe_jobs(prep: &BakeScene, mirror: &MirrorCounts) -> u64 {
    let glossy = (prep.lobes.iter()).any(|l| matches!(l, SpecularModel::Tiles { .. }));
    if glossy { mirror.face_jobs_max } else { 0 }
}

/// Adds the allocator's overhead to `items` and returns the host and device sums, the sum of
/// the first `fixed` items (with the overhead's share) and the largest device buffer.
fn totals(items: &mut Vec<PlanItem>, fixed: usize) -> (u64, u64, u64, Option<PlanItem>) {
    // Every item's count fits easily; saturate anyway so absurd inputs cannot wrap.
    let sum = |items: &[PlanItem], place: &str| {
        items
            .iter()
            .filter(|i| i.place == place)
            .fold(0u64, |s, i| s.saturating_add(i.bytes))
    };
    // Heap fragmentation and freed-but-resident memory (measured: the peak resident size of
    // CPU bakes of the shared scenes is within +6 % of the items above).
    let overhead = sum(items, "host") / 10;
    items.push(item(
        "allocator overhead (10 % of the above)",
        "host",
        overhead,
        1,
        1,
    ));
    let host_bytes = sum(items, "host");
    let device_bytes = sum(items, "gpu");
    let fixed_bytes = items[..fixed].iter().map(|i| i.bytes).sum::<u64>() * 11 / 10;
    let largest_buffer = items
        .iter()
        .filter(|i| i.place == "gpu")
        .map(PlanItem::largest_buffer)
        .max_by_key(|i| i.bytes);
    (host_bytes, device_bytes, fixed_bytes, largest_buffer)
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
    let tiles2 = u64::from(grid.tiles_per_side()).pow(2);
    let tris = prep.triangles.len() as u64;
    let faces = prep.faces.len() as u64;
    let x = prep.texel_count() as u64;
    let c = counts(prep, set, params, gpu, budget, &grid);
    let lobe_jobs = glossy_lobe_jobs(prep, &c.mirror);
    let (tile_values, index_words) = (c.mirror.tile_values, c.mirror.index_words);
    let enc = vlf_core::lightfield::DEFAULT_ENCODING.bytes_per_texel() as u64;
    let file = (x + tile_values) * enc + tris * 48 + faces * 80 + index_words * 4 + 16 * 1024;
    let mut items = fixed_items(scene, gpu, software);
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
        item(
            "texel radiance (unshot, next) and irradiance",
            "host",
            x,
            16,
            3,
        ),
    ]);
    if let Some(plan) = &c.gpu_plan {
        items.extend(gpu_host_items(plan, &c, x, tris, tiles2, file));
        items.extend(gpu_items(plan));
        // The GPU gather's buffers only where it runs: otherwise the bake gathers on the CPU.
        if let Some(gp) = params
            .final_gather
            .as_ref()
            .filter(|g| vlf_gpu::gather::implements(scene, g))
        {
            items.extend(gather_items(
                scene,
                prep,
                params,
                gp,
                (set, &c.mirror),
                budget,
            ));
        }
    } else {
        items.extend(cpu_items(params, &c, x, tris, tiles2, file));
    }
    if lobe_jobs > 0 {
        items.push(item(
            "glossy lobe (one face, while the jobs are made)",
            "host",
            lobe_jobs,
            reference::LOBE_BYTES_PER_JOB,
            1,
        ));
    }
    let (host_bytes, device_bytes, fixed_bytes, largest_buffer) = totals(&mut items, fixed);
    MemoryPlan {
        path: if gpu { "gpu" } else { "cpu" },
        resolution: params.resolution,
        tile: params.tile,
        directions: set.len(),
        transport_directions: c.transport,
        triangles: tris,
        faces,
        texels: x,
        tile_values,
        k_max: c.k_max,
        binned_max: c.binned_max,
        items,
        host_bytes,
        fixed_bytes,
        device_bytes,
        largest_buffer,
        budget: budget.clone(),
        over_budget: Vec::new(),
        lowered_from: None,
        plan_s: 0.0,
        gpu: c.gpu_plan,
    }
}
