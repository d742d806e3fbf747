//! Helpers shared by the test suite (`tests/suite`): one GPU context per test binary, the paths
//! of the shared scenes and references, and the `VLF_REQUIRE_GPU` policy.
//!
//! Policy: a GPU test calls [`gpu()`]. Without an adapter it is skipped with a message on stderr,
//! unless `VLF_REQUIRE_GPU=1` (set by `.ci/run`), in which case it fails. CI therefore can never
//! count a skipped GPU test as passed.

pub mod bakes;
pub mod scenes;

use std::path::PathBuf;
use std::sync::OnceLock;
use vlf_gpu::render::targets::read_texture;
use vlf_gpu::render::{CameraView, Renderer, Tonemap};
use vlf_gpu::{DeviceOptions, GpuContext};

/// True when GPU tests must fail rather than skip without an adapter.
pub fn gpu_required() -> bool {
    std::env::var("VLF_REQUIRE_GPU").is_ok_and(|v| v != "0" && !v.is_empty())
}

/// The shared GPU context, or `None` (after printing why) when no adapter exists and the GPU is
/// not required. Panics with the device error when `VLF_REQUIRE_GPU=1`.
pub fn gpu() -> Option<&'static GpuContext> {
    static CTX: OnceLock<Result<GpuContext, String>> = OnceLock::new();
    let ctx =
        CTX.get_or_init(|| GpuContext::new(&DeviceOptions::default()).map_err(|e| e.to_string()));
    match ctx {
        Ok(ctx) => Some(ctx),
        Err(e) if gpu_required() => panic!("VLF_REQUIRE_GPU is set but no usable GPU adapter: {e}"),
        Err(e) => {
            eprintln!("SKIPPED (no GPU adapter; set VLF_REQUIRE_GPU=1 to fail instead): {e}");
            None
        }
    }
}

/// `../shared` next to the repository checkout.
pub fn shared_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared")
}

/// Root of the repository.
pub fn repo_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The window's final image of `r` from `cam` (`width × height`, raw linear values: exposure 1,
/// no tonemap, float target), read back.
pub fn window_frame(
    ctx: &GpuContext,
    r: &mut Renderer,
    cam: &CameraView,
    width: u32,
    height: u32,
) -> Vec<[f32; 4]> {
    let format = wgpu::TextureFormat::Rgba32Float;
    let target = vlf_gpu::render::targets::readback_target(
        &ctx.device,
        "Test::view_target",
        width,
        height,
        format,
    );
    let view = target.create_view(&Default::default());
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    r.render_to_view(
        ctx,
        &mut encoder,
        cam,
        &view,
        format,
        width,
        height,
        1.0,
        Tonemap::None,
    )
    .unwrap();
    ctx.queue.submit(Some(encoder.finish()));
    r.frame_submitted(ctx);
    read_texture(&ctx.device, &ctx.queue, &target, 16).unwrap()
}
