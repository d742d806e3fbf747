//! Tests of the memory plan, the budget and the fit loop.

use super::budget::parse_meminfo;
use super::*;
use vlf_core::bake::reference;

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

/// A GPU context of the test's own (it destroys the device), or `None` (skip) under the
/// suite's policy (`vlf_tests::gpu`).
fn gpu() -> Option<vlf_gpu::GpuContext> {
    vlf_tests::gpu()?;
    Some(vlf_gpu::GpuContext::new(&Default::default()).expect("a second device on the adapter"))
}

fn gpu_plan(ctx: vlf_gpu::GpuContext) -> (Compute, MemoryPlan) {
    let scene = cornell();
    let p = BakeParams {
        directions: 6,
        resolution: 16,
        tile: 8,
        ..BakeParams::paper()
    };
    let compute = Compute::Gpu(Box::new(ctx), "test".into());
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
    let Compute::Gpu(ctx, _) = &compute else {
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
    let Some(MemoryError::OverBudget { plan: at8, .. }) = err.downcast_ref::<MemoryError>() else {
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
    let layout = |limit| vlf_gpu::bake::BakePlan::new(&prep, &set, &p, limit, None).chunks;

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

/// The bundled mirror Cornell box with its mirror made a glossy metal (α 0.25: directional
/// tiles at 46 directions).
fn glossy_cornell() -> Scene {
    let mut scene = cornell();
    let mirror = scene
        .materials
        .iter_mut()
        .find(|m| m.name == "mirror")
        .expect("the mirror material");
    mirror.metallic = 1.0;
    mirror.roughness = 0.5;
    scene
}

/// Issue 16: the glossy lobes' reflect jobs are in the plan before they are made — counted
/// without making them, the figure equals what `SpecularSetup::new` then allocates (CPU jobs,
/// exact capacities; GPU reflect items per direction) — and a budget they do not fit makes the
/// lobes mirrors, with a warning, rather than lowering the resolution or running out.
#[test]
fn glossy_lobes_are_planned_before_they_are_made_and_become_mirrors_to_fit() {
    use vlf_core::bake::glossy::SpecularModel;
    let scene = glossy_cornell();
    let p = BakeParams {
        directions: 46,
        resolution: 16,
        tile: 8,
        ..BakeParams::paper()
    };
    let cpu = Compute::Cpu("test".into());
    let planned = plan_and_prepare(&scene, &p, &cpu, &Budget::default(), Path::new("t")).unwrap();
    let (prep, set, plan) = (&planned.prep, &planned.set, &planned.plan);
    let glossy = |prep: &BakeScene| {
        prep.lobes
            .iter()
            .filter(|l| matches!(l, SpecularModel::Tiles { .. }))
            .count()
    };
    assert!(glossy(prep) > 0, "{:?}", prep.lobes);
    let item = |plan: &MemoryPlan, name: &str| {
        plan.items
            .iter()
            .find(|i| i.name == name)
            .unwrap_or_else(|| panic!("no {name} in {plan}"))
            .clone()
    };
    let grid = vlf_core::psf::PsfGrid::new(p.resolution, p.tile).unwrap();
    let (dirs, _) = reference::all_directions(prep, set, &p);
    let setup = reference::SpecularSetup::new(prep, set, &grid, &dirs).unwrap();
    let made: u64 = setup.jobs.iter().map(|j| j.len() as u64).sum();
    let allocated: u64 = setup.jobs.iter().map(|j| j.capacity() as u64).sum();
    let jobs = item(plan, "reflect jobs");
    assert_eq!(jobs.count, made);
    assert_eq!(
        allocated, made,
        "the job lists are allocated at their length"
    );
    assert_eq!(jobs.bytes, made * size_of::<reference::ReflectJob>() as u64);
    let lobe = item(plan, "glossy lobe (one face, while the jobs are made)");
    assert!(lobe.count > 0 && lobe.count < made, "{lobe:?}");
    // The GPU plan's counts (items per direction) are those of the made jobs.
    let gpu = vlf_gpu::bake::BakePlan::new(prep, set, &p, u64::MAX, None);
    let from_jobs = vlf_gpu::bake::MirrorCounts::new(Some(&setup), dirs.len());
    assert_eq!(gpu.mirror, from_jobs);
    assert_eq!(gpu.mirror.reflect_jobs, made);

    // A budget one byte short: the lobes become mirrors, the resolution stays.
    let tight = Budget {
        host: Some(Limit {
            bytes: plan.host_bytes - 1,
            source: "test".into(),
        }),
        ..Budget::default()
    };
    let fitted = plan_and_prepare(&scene, &p, &cpu, &tight, Path::new("t")).unwrap();
    assert!(fitted.plan.fits(), "{}", fitted.plan);
    assert_eq!(fitted.params, p);
    assert_eq!(glossy(&fitted.prep), 0);
    let mirrored = fitted
        .prep
        .materials
        .iter()
        .zip(&scene.materials)
        .find(|(_, m)| m.name == "mirror")
        .map(|(b, _)| b.model);
    assert_eq!(mirrored, Some(SpecularModel::Mirror { alpha: 0.25 }));
    assert!(item(&fitted.plan, "reflect jobs").count < made / 2);
    assert!(
        fitted
            .prep
            .warnings
            .iter()
            .any(|w| w.contains("glossy lobes modelled as mirrors (materials: mirror)")),
        "{:?}",
        fitted.prep.warnings
    );
}
