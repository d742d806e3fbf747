//! Building scenes in code: analytic test scenes (furnaces, the stability suite) and tools.

use glam::{Vec2, Vec3};

use super::faces::{RawTriangle, build_faces};
use super::{
    Aabb, Corners, Material, MaterialKind, Scene, Texture, Translucency, Transparency,
    fit_similarity,
};

/// Accumulates triangles and materials, then builds a [`Scene`] exactly as the glTF importer
/// does (faces merged, VLF transform fitted).
#[derive(Default)]
pub struct SceneBuilder {
    triangles: Vec<RawTriangle>,
    materials: Vec<Material>,
    textures: Vec<Texture>,
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
            transparency: Transparency::default(),
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
            transparency: Transparency::default(),
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

    /// Adds a texture; returns its index in [`Scene::textures`] (for a [`super::TexRef`]).
    pub fn texture(&mut self, t: Texture) -> u32 {
        self.textures.push(t);
        (self.textures.len() - 1) as u32
    }

    /// Adds a triangle, counter-clockwise seen from its front.
    pub fn triangle(&mut self, p: [Vec3; 3], material: u32) -> &mut Self {
        self.triangles.push(RawTriangle::plain(p, material));
        self
    }

    /// Adds a triangle with texture coordinates, shading normals or vertex colours at its
    /// corners. Normals are taken as given (unit, on the front side: the importer's
    /// guarantees), except that a triangle whose normals all equal its geometric normal is
    /// stored flat as the importer stores it.
    pub fn triangle_with(&mut self, p: [Vec3; 3], material: u32, corners: Corners) -> &mut Self {
        let g = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let normals = corners.normals.filter(|n| {
            n.iter()
                .any(|n| f64::from(n.dot(g)) <= super::FACE_COS_TOLERANCE)
        });
        self.triangles.push(RawTriangle {
            p,
            uv: corners.uv,
            material,
            normals,
            colors: corners.colors,
            uv1: corners.uv1,
        });
        self
    }

    /// Adds a UV sphere (`segments` around the axis +Y, `rings` from pole to pole), fronts
    /// outwards; `smooth` gives every corner the sphere's normal there as its shading normal.
    pub fn sphere(
        &mut self,
        center: Vec3,
        radius: f32,
        (segments, rings): (u32, u32),
        material: u32,
        smooth: bool,
    ) -> &mut Self {
        let dir = |i: u32, j: u32| {
            let phi = std::f32::consts::TAU * i as f32 / segments as f32;
            let theta = std::f32::consts::PI * j as f32 / rings as f32;
            Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            )
        };
        for j in 0..rings {
            for i in 0..segments {
                let (a, b) = (dir(i, j), dir(i + 1, j));
                let (c, d) = (dir(i + 1, j + 1), dir(i, j + 1));
                // Counter-clockwise from outside; the poles' degenerate halves left out.
                let mut tris = Vec::new();
                if j + 1 < rings {
                    tris.push([a, d, c]);
                }
                if j > 0 {
                    tris.push([a, c, b]);
                }
                for n in tris {
                    let p = n.map(|n| center + n * radius);
                    let corners = Corners {
                        normals: smooth.then_some(n),
                        ..Corners::default()
                    };
                    self.triangle_with(p, material, corners);
                }
            }
        }
        self
    }

    /// Adds a planar quad `a b c d` (counter-clockwise from the front) as two triangles.
    pub fn quad(&mut self, [a, b, c, d]: [Vec3; 4], material: u32) -> &mut Self {
        self.triangle([a, b, c], material);
        self.triangle([a, c, d], material)
    }

    /// Adds a planar quad `a b c d` like [`quad`](Self::quad), with `TEXCOORD_0` `uv` at its
    /// corners.
    pub fn uv_quad(&mut self, [a, b, c, d]: [Vec3; 4], uv: [Vec2; 4], material: u32) -> &mut Self {
        for (p, uv) in [
            ([a, b, c], [uv[0], uv[1], uv[2]]),
            ([a, c, d], [uv[0], uv[2], uv[3]]),
        ] {
            self.triangle_with(
                p,
                material,
                Corners {
                    uv,
                    ..Corners::default()
                },
            );
        }
        self
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
            textures: self.textures,
            cameras: Vec::new(),
            suns: Vec::new(),
            lights: Vec::new(),
            translucency,
            bounds,
            to_vlf,
            warnings: Vec::new(),
            source: source.into(),
            ignored_normal_maps: Vec::new(),
        }
    }
}
