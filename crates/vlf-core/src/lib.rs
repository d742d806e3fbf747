pub mod bake;
pub mod directions;
pub mod lightfield;
pub mod psf;
pub mod scene;
