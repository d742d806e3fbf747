//! GPU side of vlf, shared by the baker and the viewer.
//!
//! * [`device`]: adapter/device creation with explicit features and limits, working on real GPUs
//!   and on Mesa's lavapipe; errors name exactly what the adapter lacks.
//! * [`shaders`]: the registry of every WGSL file under `shaders/`, embedded at compile time, and
//!   the `#import "common/NAME.wgsl"` resolver that keeps each shared definition in one file.
//! * [`layout`]: the one source of truth for structs shared between Rust and WGSL.
//! * [`wgpu_util`]: the one home of the wgpu boilerplate every pass shares.
//! * [`bake`]: the GPU propagator (`vlf_core::bake::reference` is its specification).
//! * [`raytrace`]: the GPU ray engine and path tracer.
//! * [`render`]: the viewer's five render passes (paper §4) and headless stills.
//! * [`directions`]: the direction set's lookup in WGSL, its tables and a batch lookup pass.
//! * [`gather`]: the final gather on the GPU (`vlf_core::gather` is its specification).
//! * [`radiosity`]: Jacobi sweeps of the matrix radiosity baseline (`vlf_core::radiosity`).
//! * [`readback`]: small helpers to copy buffers back to the CPU (tests, stills, bakes).

pub mod bake;
pub mod device;
pub mod directions;
pub mod gather;
pub mod layout;
pub mod radiosity;
pub mod raytrace;
pub mod readback;
pub mod render;
pub mod shaders;
pub mod smoke;
pub mod wgpu_util;

pub use device::{DeviceError, DeviceOptions, GpuContext};
