//! vlf-core's integration tests: one binary (one link step), a module per subject, and the
//! scaffolding they share in `common` (scene pieces, bake/gather runners, small encoders) and
//! `bakes` and `scenes`
//! (fixtures the GPU suite in `tests/suite` uses too). Run one subject with
//! `cargo test -p vlf-core --test core SUBJECT::` (e.g. `format::encoding_error`).

#[path = "../../../../tests/src/bakes.rs"]
#[allow(dead_code)]
mod bakes;
#[path = "../../../../tests/src/scenes.rs"]
#[allow(dead_code)]
mod scenes;

mod auto_rules;
mod common;
mod format;
mod fuzz_format;
mod fuzz_loader;
mod gather;
mod glossy;
mod image_metrics;
mod mirrors;
mod pathtrace;
mod presets;
mod propagation;
mod punctual;
mod radiosity;
mod resample;
mod scene_import;
mod shading;
mod slivers;
mod stability;
mod subsurface;
mod subsurface_import;
mod subsurface_walk;
mod transmission;
