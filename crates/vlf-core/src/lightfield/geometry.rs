//! The baked geometry: triangles and planar faces with their atlas charts, in VLF coordinates.
//! `#[repr(C)]` records that the propagators bind as they are, the file stores (converted
//! field by field in `format::disk`) and the renderer uploads.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A triangle in VLF coordinates (48 bytes; mirrors WGSL `BakeTriangle`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BakeTriangle {
    pub p0: [f32; 3],
    /// Index of the triangle's face (`BakeScene::faces`, [`LightField::faces`](super::LightField::faces)).
    pub face: u32,
    pub p1: [f32; 3],
    pub _pad0: u32,
    pub p2: [f32; 3],
    pub _pad1: u32,
}

/// Face kinds stored in [`BakeFace::kind`].
pub const FACE_DIFFUSE: u32 = 0;
pub const FACE_MIRROR: u32 = 1;
pub const FACE_MIXED: u32 = 2;

/// A planar face with its atlas chart, in VLF coordinates (80 bytes; mirrors WGSL `BakeFace`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BakeFace {
    /// Unit front normal.
    pub normal: [f32; 3],
    /// Plane: `normal · p = offset`.
    pub offset: f32,
    /// Chart origin on the plane.
    pub origin: [f32; 3],
    /// Texel edge length (VLF units).
    pub texel_size: f32,
    /// Chart axis of texel columns.
    pub u: [f32; 3],
    /// Texel columns.
    pub width: u32,
    /// Chart axis of texel rows.
    pub v: [f32; 3],
    /// Texel rows.
    pub height: u32,
    /// Index of the first texel of side 0; side 1 starts at `texel_base + width × height`.
    pub texel_base: u32,
    /// [`FACE_DIFFUSE`], [`FACE_MIRROR`] or [`FACE_MIXED`].
    pub kind: u32,
    /// Mirror weight (0 for diffuse faces).
    pub specular: f32,
    /// Index of the face's material ([`Shading::materials`](super::Shading::materials)).
    pub material: u32,
}

impl BakeFace {
    pub fn normal(&self) -> Vec3 {
        Vec3::from(self.normal)
    }

    /// Texels per side.
    pub fn texels_per_side(&self) -> u32 {
        self.width * self.height
    }

    /// Index of the texel containing plane point `p` on `side` (clamped to the chart).
    pub fn texel_at(&self, p: Vec3, side: u32) -> u32 {
        let d = p - Vec3::from(self.origin);
        let x = (d.dot(Vec3::from(self.u)) / self.texel_size).floor();
        let y = (d.dot(Vec3::from(self.v)) / self.texel_size).floor();
        let x = (x.max(0.0) as u32).min(self.width - 1);
        let y = (y.max(0.0) as u32).min(self.height - 1);
        self.texel_base + side * self.texels_per_side() + y * self.width + x
    }
}
