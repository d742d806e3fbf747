//! The cross-crate test suite: one binary, so GPU tests share one device and one link step.

mod accuracy;
mod bake_gpu;
mod bake_plan;
mod directions_gpu;
mod gather_gpu;
mod gather_plan;
mod glossy_gpu;
mod gpu_smoke;
mod pathtrace_gpu;
mod radiosity_gpu;
mod render;
mod render_encoding;
mod render_mirrors;
mod render_textures;
mod shading_gpu;
mod stability_gpu;
mod transmission_gpu;
