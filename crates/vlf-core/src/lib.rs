//! Everything of vlf that needs no GPU: scene import, the direction set and PSF geometry, the
//! light field and its file, the CPU reference propagator, images, the path tracer and the
//! radiosity baseline. The modules form layers, each using only those below it (checked by
//! `cargo xtask check-modules`; see `docs/ARCHITECTURE.md`).

pub mod atomic_file;
pub mod bake;
pub mod directions;
pub mod export;
pub mod format;
pub mod gather;
pub mod hash;
pub mod image;
pub mod lightfield;
pub mod par;
pub(crate) mod parallel;
pub mod pathtrace;
pub mod pipeline;
pub mod psf;
pub mod radiosity;
pub mod resample;
pub mod scene;
