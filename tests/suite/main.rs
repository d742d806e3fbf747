//! The cross-crate test suite: one binary, so GPU tests share one device and one link step.

mod gpu_smoke;
mod bake_gpu;
