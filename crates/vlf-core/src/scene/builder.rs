//! Building scenes in code: analytic test scenes (furnaces, the stability suite) and tools.

use glam::{Vec2, Vec3};

use super::faces::{RawTriangle, build_faces};
use super::{Aabb, Material, MaterialKind, Scene, Translucency, fit_similarity};

/// Accumulates triangles and materials, then builds a [`Scene`] exactly as the glTF importer
/// does (faces merged, VLF transform fitted).
#[derive(Default)]
pub struct SceneBuilder {
    triangles: Vec<RawTriangle>,
    materials: Vec<Material>,
    translucency: Vec<(u32, Translucency)>,
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a Lambertian material (emission is radiance from the front side); returns its index.
    pub fn diffuse(&mut self, name: &str, albedo: Vec3, emission: Vec3) -> u32 {
        self.material(Material {
            name: name.into(),
            base_color: albedo,
            base_color_texture: None,
            emission,
            emissive_texture: None,
            double_sided: true,
            kind: MaterialKind::Diffuse,
            metallic: 0.0,
            roughness: 1.0,
        })
    }

    /// Adds a perfect mirror (metallic, roughness 0) of reflectance `reflectance`.
    pub fn mirror(&mut self, name: &str, reflectance: Vec3) -> u32 {
        self.material(Material {
            name: name.into(),
            base_color: reflectance,
            base_color_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            double_sided: true,
            kind: MaterialKind::Mirror,
            metallic: 1.0,
            roughness: 0.0,
        })
    }

    /// Gives material `material` the subsurface model `model` (`docs/SUBSURFACE.md`).
    pub fn translucent(&mut self, material: u32, model: Translucency) -> &mut Self {
        self.translucency.push((material, model));
        self
    }

    /// Adds any material; returns its index.
    pub fn material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    /// Adds a triangle, counter-clockwise seen from its front.
    pub fn triangle(&mut self, p: [Vec3; 3], material: u32) -> &mut Self {
        self.triangles.push(RawTriangle {
            p,
            uv: [Vec2::ZERO; 3],
            material,
        });
        self
    }

    /// Adds a planar quad `a b c d` (counter-clockwise from the front) as two triangles.
    pub fn quad(&mut self, [a, b, c, d]: [Vec3; 4], material: u32) -> &mut Self {
        self.triangle([a, b, c], material);
        self.triangle([a, c, d], material)
    }

    /// Adds an axis-aligned box `[lo, hi]`; `inward` makes the fronts face the inside (a room).
    pub fn aabox(&mut self, lo: Vec3, hi: Vec3, inward: bool, material: u32) -> &mut Self {
        let p = |x: usize, y: usize, z: usize| {
            Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z])
        };
        // Outward-facing CCW quads.
        let quads = [
            [p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)], // −x
            [p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1)], // +x
            [p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1)], // −y
            [p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0)], // +y
            [p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0)], // −z
            [p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)], // +z
        ];
        for mut q in quads {
            if inward {
                q.reverse();
            }
            self.quad(q, material);
        }
        self
    }

    /// Builds the scene (`source` names it in messages).
    pub fn build(self, source: &str) -> Scene {
        let (triangles, faces) = build_faces(self.triangles);
        let mut bounds = Aabb::EMPTY;
        for t in &triangles {
            for p in t.p {
                bounds.extend(p);
            }
        }
        let to_vlf = fit_similarity(&triangles, &bounds);
        let mut translucency = vec![Translucency::None; self.materials.len()];
        for (m, model) in self.translucency {
            translucency[m as usize] = model;
        }
        Scene {
            triangles,
            faces,
            materials: self.materials,
            textures: Vec::new(),
            cameras: Vec::new(),
            suns: Vec::new(),
            lights: Vec::new(),
            translucency,
            bounds,
            to_vlf,
            warnings: Vec::new(),
            source: source.into(),
        }
    }
}
