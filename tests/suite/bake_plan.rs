//! The GPU bake allocates exactly its plan, and compiles its pipelines once per device.
//!
//! Both tests make a private device (after `gpu()` has applied the skip policy): its instance
//! then counts only their own buffers and pipelines (wgpu's hub report), which the shared
//! context of the suite cannot promise while other tests run.

use vlf_core::bake::BakeScene;
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_gpu::bake::{
    BakePipelines, BakePlan, GpuBakeOptions, SceneResources, binding_limit, propagate_with,
};
use vlf_gpu::{DeviceOptions, GpuContext};
use vlf_tests::bakes;
use vlf_tests::{gpu, repo_dir};

/// A device of its own, or `None` when GPU tests are skipped.
fn private_device() -> Option<GpuContext> {
    gpu()?;
    Some(GpuContext::new(&DeviceOptions::default()).expect("a second device on the adapter"))
}

/// wgpu's count of the live (not dropped) objects of `ctx`'s instance: (buffers, compute
/// pipelines).
fn live(ctx: &GpuContext) -> (usize, usize) {
    let report = ctx
        .instance
        .generate_report()
        .expect("wgpu-core backend")
        .hub;
    (
        report.buffers.num_kept_from_user,
        report.compute_pipelines.num_kept_from_user,
    )
}

fn load(asset: &str, params: &BakeParams) -> (BakeScene, DirectionSet) {
    let scene = vlf_core::scene::load(&repo_dir().join(asset)).unwrap();
    let prep = BakeScene::new(&scene, params).unwrap();
    (prep, DirectionSet::at_least(params.directions).unwrap())
}

fn params() -> BakeParams {
    bakes::params(46, 32, Iterations::Fixed(1))
}

/// Every buffer the propagator allocates is a buffer of its plan, with the planned label,
/// size and usage, and there is no other: on the diffuse and the mirror Cornell box, with the
/// tile bins in one chunk and in several.
#[test]
fn gpu_bake_allocates_exactly_its_plan() {
    let Some(ctx) = private_device() else {
        return;
    };
    let ctx = &ctx;
    let limit = binding_limit(&ctx.device);
    let pipelines = BakePipelines::of(ctx);
    for asset in [
        "assets/cornell-box/cornell-box.gltf",
        "assets/cornell-mirror/cornell-mirror.gltf",
    ] {
        let p = params();
        let (prep, set) = load(asset, &p);
        let whole = BakePlan::new(&prep, &set, &p, limit, None);
        let quarter = whole.chunks[0].bytes.largest() / 4;
        for cap in [None, Some(quarter)] {
            let plan = BakePlan::new(&prep, &set, &p, limit, cap);
            let what = format!("{asset}, {} chunk(s)", plan.chunks.len());
            assert_eq!(plan.chunks.len() > 1, cap.is_some(), "{what}");
            // 18 whole buffers and three per chunk; labels name each once.
            assert_eq!(plan.buffers.len(), 18 + 3 * plan.chunks.len(), "{what}");
            let mut want: Vec<_> = plan
                .buffers
                .iter()
                .map(|b| (b.label(), b.size, b.usage))
                .collect();
            want.sort_by(|a, b| a.0.cmp(&b.0));
            assert!(
                want.windows(2).all(|w| w[0].0 != w[1].0),
                "{what}: {want:?}"
            );

            // The resources as the propagator builds them: what wgpu made is the plan.
            let before = live(ctx).0;
            let res = SceneResources::new(ctx, &pipelines, &plan, &prep, &set, &p).unwrap();
            let mut got: Vec<_> = res
                .allocated()
                .iter()
                .map(|b| (b.label.clone(), b.size, b.usage))
                .collect();
            got.sort_by(|a, b| a.0.cmp(&b.0));
            assert_eq!(got, want, "{what}");
            assert_eq!(live(ctx).0 - before, plan.buffers.len(), "{what}");
            drop(res);
            assert_eq!(
                live(ctx).0,
                before,
                "{what}: the resources own their buffers"
            );

            // The propagator itself: while it runs, the buffers alive on the device are the
            // plan's (checked at every progress report, between submissions).
            let mut seen = Vec::new();
            let options = GpuBakeOptions {
                max_chunk_bytes: cap,
            };
            propagate_with(ctx, &prep, &set, &p, &options, &mut |_| {
                seen.push(live(ctx).0 - before)
            })
            .unwrap();
            assert!(!seen.is_empty(), "{what}: progress was reported");
            assert!(
                seen.iter().all(|&n| n == plan.buffers.len()),
                "{what}: live buffers {seen:?}, planned {}",
                plan.buffers.len()
            );
        }
    }
}

/// A device compiles the bake pipelines once, however many scenes it bakes (as `vlf-bake
/// batch` does: one device, several scenes).
#[test]
fn bake_pipelines_are_created_once_per_device() {
    let Some(ctx) = private_device() else {
        return;
    };
    let ctx = &ctx;
    assert_eq!(live(ctx).1, 0, "a fresh device has no pipeline");
    let p = params();
    for (i, asset) in [
        "assets/cornell-box/cornell-box.gltf",
        "assets/cornell-mirror/cornell-mirror.gltf",
        "assets/cornell-box/cornell-box.gltf",
    ]
    .into_iter()
    .enumerate()
    {
        let (prep, set) = load(asset, &p);
        vlf_gpu::bake::propagate(ctx, &prep, &set, &p, &mut |_| {}).unwrap();
        // Cells, Interface, Gather, Reflect: four pipelines, made by the first bake.
        assert_eq!(live(ctx).1, 4, "after scene {i} ({asset})");
    }
    assert!(std::sync::Arc::ptr_eq(
        &BakePipelines::of(ctx),
        &BakePipelines::of(ctx)
    ));
}
