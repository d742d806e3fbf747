//! Helpers shared by the test suite (`tests/suite`): one GPU context per test binary, the paths
//! of the shared scenes and references, and the `VLF_REQUIRE_GPU` policy.
//!
//! Policy: a GPU test calls [`gpu()`]. Without an adapter it is skipped with a message on stderr,
//! unless `VLF_REQUIRE_GPU=1` (set by `.ci/run`), in which case it fails. CI therefore can never
//! count a skipped GPU test as passed.

use std::path::PathBuf;
use std::sync::OnceLock;
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
