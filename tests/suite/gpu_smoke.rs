//! First GPU test: a compute dispatch whose result is checked on the CPU.

use vlf_gpu::smoke::SmokePass;
use vlf_tests::{gpu, gpu_required};

#[test]
fn smoke_compute_matches_cpu() {
    let Some(ctx) = gpu() else { return };
    if gpu_required() {
        // wgpu falls back to GL when no Vulkan driver is present; CI must run on Vulkan (lavapipe).
        assert_ne!(
            ctx.summary.backend, "Gl",
            "CI expects a Vulkan adapter, got {}",
            ctx.summary
        );
    }
    let pass = SmokePass::new(&ctx.device);
    // More than one row of workgroups on small-limit adapters, odd count to exercise the tail.
    let n = 100_003usize;
    let xs: Vec<f32> = (0..n).map(|i| (i as f32).sin() * 1000.0).collect();
    let (a, b) = (1.5f32, -2.25f32);
    let ys = pass
        .run(&ctx.device, &ctx.queue, a, b, &xs)
        .expect("readback");
    assert_eq!(ys.len(), n);
    for (i, (x, y)) in xs.iter().zip(&ys).enumerate() {
        let want = a * x + b;
        // The GPU may fuse into an FMA: allow one rounding of difference.
        let tol = want.abs().max(1.0) * 2.0 * f32::EPSILON;
        assert!(
            (y[0] - want).abs() <= tol,
            "element {i}: gpu {} cpu {want}",
            y[0]
        );
        assert_eq!(
            y[1], i as f32,
            "element {i} written by the wrong invocation"
        );
    }
}
