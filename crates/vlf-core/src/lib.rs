pub mod bake;
pub mod directions;
pub mod format;
pub mod image;
pub mod lightfield;
pub mod pathtrace;
pub mod psf;
pub mod scene;
