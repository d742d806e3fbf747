//! Alpha masks (`alphaMode: MASK`, and `BLEND` modelled as a mask at α = ½): where the coverage
//! α = baseColorFactor.a × the base-colour texture's alpha at a point is below the material's
//! cutoff, the surface has no surface at all, and every ray passes (`docs/PROPAGATION.md`,
//! *Alpha masks*).
//!
//! [`AlphaMasks`] is the one lookup every stage uses: the propagation's per-ray depth lists
//! (`bake::reference::build_cell_lists` and the GPU's `bake_cells.wgsl`), the BVH traversal of
//! the path tracer, the final gather and the mirror resampling (`pathtrace::Bvh`, the GPU's
//! `common/bvh.wgsl`), the gather's sample points, and pass 3 and pass 5 of the renderer. Its
//! CPU form here is the specification; [`AlphaMasks::words`] is the same data as the GPU binds
//! it (`shaders/common/alpha_mask.wgsl`, which mirrors [`AlphaMasks::cuts`] operation for
//! operation, so the propagation stays bit-identical).
//!
//! The texture's alpha is read as the light field stores it (IEEE binary16, exact for 8-bit
//! sources' k/255 up to 2⁻¹¹ relative), with the texture's own filter: NEAREST reads the texel
//! under the point, LINEAR interpolates the four around it (the renderer's bilinear footprint,
//! `shaders/common/texture.wgsl`), then compares with the cutoff.

use glam::Vec2;

use super::encoding::{f16_decode, f16_encode};
use super::shading::{
    NO_TEXTURE, Shading, SurfaceMaterial, SurfaceTexture, finite_uv, surface_textures, texel_alpha,
    texel_axis,
};
use crate::scene::{Scene, WrapMode};

/// "No mask" in the per-triangle table and "no texture" in a mask material.
pub const NO_MASK: u32 = u32::MAX;

/// Words of a triangle's mask record in [`AlphaMasks::words`].
pub const RECORD_WORDS: u32 = 8;
/// Words of a mask material in [`AlphaMasks::words`].
pub const MATERIAL_WORDS: u32 = 8;

/// How one masking material reads its coverage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskMaterial {
    /// Below this coverage there is no surface.
    pub cutoff: f32,
    /// baseColorFactor.a.
    pub factor: f32,
    /// The base-colour texture's size and wrap modes (unused without a texture).
    pub texture: SurfaceTexture,
    /// NEAREST magnification (else LINEAR).
    pub nearest: bool,
    /// Index of the texture's first alpha in [`AlphaMasks::alpha`], or [`NO_MASK`] for a
    /// material without a base-colour texture (coverage = `factor` everywhere).
    pub first: u32,
}

impl MaskMaterial {
    /// The coverage α at glTF uv `uv`: `factor` × the texture's alpha there.
    pub fn coverage(&self, alpha: &[f32], uv: Vec2) -> f32 {
        if self.first == NO_MASK {
            return self.factor;
        }
        let t = &self.texture;
        let a = if self.nearest {
            let i = nearest_axis(uv.x, t.width, t.wrap_s);
            let j = nearest_axis(uv.y, t.height, t.wrap_t);
            alpha[(self.first + j * t.width + i) as usize]
        } else {
            let (i0, i1, fx) = texel_axis(uv.x, t.width, t.wrap_s);
            let (j0, j1, fy) = texel_axis(uv.y, t.height, t.wrap_t);
            let at = |i: u32, j: u32| alpha[(self.first + j * t.width + i) as usize];
            let top = at(i0, j0) * (1.0 - fx) + at(i1, j0) * fx;
            let bottom = at(i0, j1) * (1.0 - fx) + at(i1, j1) * fx;
            top * (1.0 - fy) + bottom * fy
        };
        self.factor * a
    }
}

/// A masked triangle: its corners' uvs and its material's entry.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MaskRecord {
    uv: [[f32; 2]; 3],
    material: u32,
}

/// The alpha masks of a set of triangles (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlphaMasks {
    /// Per triangle: its record in `records`, or [`NO_MASK`].
    tri: Vec<u32>,
    records: Vec<MaskRecord>,
    /// The masking materials.
    pub materials: Vec<MaskMaterial>,
    /// The alpha of the textures the masks read, one after another (f16 values as f32).
    pub alpha: Vec<f32>,
}

impl AlphaMasks {
    /// Masks of the light field's (or a bake's) triangles: `materials` and `textures` as
    /// [`Shading`] holds them, `alpha(texture, texel)` the stored f16 alpha of a texel, and per
    /// triangle its material and corner uvs.
    fn build(
        materials: &[SurfaceMaterial],
        textures: &[SurfaceTexture],
        alpha: &dyn Fn(usize, usize) -> u16,
        triangles: impl Iterator<Item = (u32, [[f32; 2]; 3])>,
    ) -> Self {
        let mut out = AlphaMasks::default();
        let mut entry = vec![NO_MASK; materials.len()];
        let mut first_of = vec![NO_MASK; textures.len()];
        for (mi, m) in materials.iter().enumerate() {
            if !m.masks() {
                continue;
            }
            let tex = m.base_color_texture;
            let texture = textures
                .get(tex as usize)
                .copied()
                .filter(|_| tex != NO_TEXTURE);
            let first = match texture {
                Some(t) => {
                    let k = tex as usize;
                    if first_of[k] == NO_MASK {
                        first_of[k] = out.alpha.len() as u32;
                        let n = t.texel_count() as usize;
                        out.alpha.extend((0..n).map(|i| f16_decode(alpha(k, i))));
                    }
                    first_of[k]
                }
                None => NO_MASK,
            };
            entry[mi] = out.materials.len() as u32;
            out.materials.push(MaskMaterial {
                cutoff: m.alpha_cutoff,
                factor: m.alpha_factor,
                texture: texture.unwrap_or(SurfaceTexture {
                    width: 1,
                    height: 1,
                    wrap_s: WrapMode::Repeat,
                    wrap_t: WrapMode::Repeat,
                }),
                nearest: m.alpha_nearest,
                first,
            });
        }
        if out.materials.is_empty() {
            return out;
        }
        for (material, uv) in triangles {
            let e = entry.get(material as usize).copied().unwrap_or(NO_MASK);
            if e == NO_MASK {
                out.tri.push(NO_MASK);
            } else {
                out.tri.push(out.records.len() as u32);
                out.records.push(MaskRecord { uv, material: e });
            }
        }
        out
    }

    /// The masks of an imported scene's triangles (scene order), with the alphas the light
    /// field will store ([`AlphaMasks::from_shading`] of the baked light field gives the same).
    pub fn from_scene(scene: &Scene) -> Self {
        let materials = super::shading::surface_materials(scene);
        if !materials.iter().any(SurfaceMaterial::masks) {
            return AlphaMasks::default();
        }
        let alpha = |t: usize, i: usize| texel_alpha(&scene.textures[t], i);
        Self::build(
            &materials,
            &surface_textures(scene),
            &alpha,
            (scene.triangles.iter()).map(|t| (t.material, t.uv.map(finite_uv))),
        )
    }

    /// The masks of a light field's triangles: `materials` the material of each triangle
    /// (its face's), uvs and textures from `shading`.
    pub fn from_shading(shading: &Shading, materials: impl Iterator<Item = u32>) -> Self {
        if !shading.materials.iter().any(SurfaceMaterial::masks) {
            return AlphaMasks::default();
        }
        // Without stored alpha (never written so) a texture reads a coverage of 1.
        let offsets = shading.texture_offsets();
        let alpha = |t: usize, i: usize| {
            shading
                .alpha
                .get(offsets[t] as usize + i)
                .copied()
                .unwrap_or(f16_encode(1.0))
        };
        Self::build(
            &shading.materials,
            &shading.textures,
            &alpha,
            materials.zip(shading.uvs.iter().copied()),
        )
    }

    /// Whether no triangle is masked (every lookup passes through [`cuts`](Self::cuts) at once).
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Whether triangle `tri` has a mask.
    pub fn is_masked(&self, tri: u32) -> bool {
        self.tri.get(tri as usize).is_some_and(|&r| r != NO_MASK)
    }

    /// Whether triangle `tri` has no surface at the point of barycentric weights `w` (of corners
    /// 0, 1, 2): its coverage there is below its material's cutoff. The uv is
    /// `uv0·w0 + uv1·w1 + uv2·w2`, in that order (`alpha_mask.wgsl` computes the same).
    pub fn cuts(&self, tri: u32, w: [f32; 3]) -> bool {
        let Some(&r) = self.tri.get(tri as usize) else {
            return false;
        };
        if r == NO_MASK {
            return false;
        }
        let rec = &self.records[r as usize];
        let m = &self.materials[rec.material as usize];
        let [a, b, c] = rec.uv;
        let uv = Vec2::new(
            a[0] * w[0] + b[0] * w[1] + c[0] * w[2],
            a[1] * w[0] + b[1] * w[1] + c[1] * w[2],
        );
        m.coverage(&self.alpha, uv) < m.cutoff
    }

    /// Whether triangle `tri` has no surface at glTF uv `uv` (the renderer's rasterising
    /// passes interpolate uv themselves: `alpha_cuts_uv` of `alpha_mask.wgsl`).
    pub fn cuts_uv(&self, tri: u32, uv: Vec2) -> bool {
        match self.tri.get(tri as usize) {
            Some(&r) if r != NO_MASK => {
                let m = &self.materials[self.records[r as usize].material as usize];
                m.coverage(&self.alpha, uv) < m.cutoff
            }
            _ => false,
        }
    }

    /// [`cuts`](Self::cuts) with the BVH's barycentrics (`b1`, `b2` the weights of corners 1
    /// and 2).
    pub fn cuts_at(&self, tri: u32, b1: f32, b2: f32) -> bool {
        self.cuts(tri, [1.0 - b1 - b2, b1, b2])
    }

    /// The length of [`words`](Self::words), without making them.
    pub fn word_count(&self) -> usize {
        if self.is_empty() {
            return 4;
        }
        4 + self.tri.len()
            + RECORD_WORDS as usize * self.records.len()
            + MATERIAL_WORDS as usize * self.materials.len()
            + self.alpha.len()
    }

    /// The masks as the GPU binds them (`array<u32>`, `shaders/common/alpha_mask.wgsl`):
    ///
    /// | words | content |
    /// |---|---|
    /// | 0..4 | triangle count T, first record, first material, first alpha |
    /// | 4..4 + T | per triangle: its record's word offset, or [`NO_MASK`] |
    /// | records | per masked triangle, [`RECORD_WORDS`]: uv0, uv1, uv2 (f32 bits), its material's word offset, 0 |
    /// | materials | [`MATERIAL_WORDS`]: cutoff, factor (f32 bits), width, height, wrap_s \| wrap_t << 4 \| nearest << 8, first alpha's word offset or [`NO_MASK`], 0, 0 |
    /// | alpha | one f32 per texel |
    ///
    /// Without masks: the header alone, T = 0.
    pub fn words(&self) -> Vec<u32> {
        let t = if self.is_empty() { 0 } else { self.tri.len() };
        let rec_base = 4 + t as u32;
        let mat_base = rec_base + RECORD_WORDS * if t == 0 { 0 } else { self.records.len() as u32 };
        let alpha_base = mat_base
            + MATERIAL_WORDS
                * if t == 0 {
                    0
                } else {
                    self.materials.len() as u32
                };
        let mut w = vec![t as u32, rec_base, mat_base, alpha_base];
        if t == 0 {
            return w;
        }
        w.extend(self.tri.iter().map(|&r| {
            if r == NO_MASK {
                NO_MASK
            } else {
                rec_base + RECORD_WORDS * r
            }
        }));
        for r in &self.records {
            w.extend(r.uv.iter().flatten().map(|x| x.to_bits()));
            w.push(mat_base + MATERIAL_WORDS * r.material);
            w.push(0);
        }
        for m in &self.materials {
            let modes =
                m.texture.wrap_s.id() | (m.texture.wrap_t.id() << 4) | (u32::from(m.nearest) << 8);
            w.extend([
                m.cutoff.to_bits(),
                m.factor.to_bits(),
                m.texture.width,
                m.texture.height,
                modes,
                if m.first == NO_MASK {
                    NO_MASK
                } else {
                    alpha_base + m.first
                },
                0,
                0,
            ]);
        }
        w.extend(self.alpha.iter().map(|a| a.to_bits()));
        w
    }
}

/// The texel index along one axis under coordinate `u` with NEAREST filtering: the coordinate
/// reduced to one period as in [`texel_axis`], `floor(u × size)`, wrapped
/// (`nearest_axis` of `shaders/common/alpha_mask.wgsl`).
pub fn nearest_axis(u: f32, size: u32, mode: WrapMode) -> u32 {
    let mut r = u.clamp(-1e9, 1e9);
    if mode != WrapMode::ClampToEdge {
        let p = if mode == WrapMode::MirroredRepeat {
            2.0
        } else {
            1.0
        };
        r -= p * (r / p).floor();
    }
    let x = (r * size as f32).clamp(-1e9, 1e9);
    super::shading::wrap_reduced(x.floor() as i32, size as i32, mode)
}

#[cfg(test)]
mod tests;
