//! What shades a pixel besides the atlas. The atlas stores each texel's irradiance E, which
//! varies slowly; the renderer applies the surface's own detail per pixel, as lightmappers do:
//!
//! ```text
//! L = Le(uv) [front side only] + ρ_d(uv) / π · E(bilinear atlas) + specular tiles
//! ρ_d = diffuse weight × baseColorFactor × baseColorTexture(uv)
//! Le  = emission factor × emissiveTexture(uv)
//! ```
//!
//! [`Shading`] holds what that needs: a [`SurfaceMaterial`] per material (faces name theirs in
//! [`BakeFace::material`](super::BakeFace::material)), each triangle's `TEXCOORD_0` at its
//! corners, and the textures ([`SurfaceTexture`] and their texels). Lookups are bilinear with
//! the sampler's wrap modes and no mipmaps (`shared/reference/README.md`).
//!
//! Where the scene has them, three more per-corner attributes (each `None` when no triangle
//! needs it, so light fields of scenes without them are unchanged):
//!
//! * [`Shading::colors`]: `COLOR_0`, which multiplies ρ_d (and the metal lobe's C) per pixel;
//! * [`Shading::uvs1`]: `TEXCOORD_1`, read by the texture slots whose material names set 1
//!   ([`SurfaceMaterial::base_color_texcoord`], [`SurfaceMaterial::emissive_texcoord`]);
//! * [`Shading::normals`]: the shading normals, zero vectors at the corners of flat
//!   triangles. The atlas already holds the irradiance about them (the final gather gathers
//!   about the interpolated normal); the renderer needs them only where the normal shapes
//!   the light per pixel: mirrors and glossy lobes reflect about the interpolated normal.
//!
//! **Texels are f16 RGB** (a [`Radiance`] in [`RadianceEncoding::RgbF16`]: 6 bytes per texel
//! in memory and in the file, `Rgba16Float` on the GPU like the atlas), not the importer's f32
//! RGBA (16 bytes):
//!
//! * alpha is kept apart, and only where a material masks ([`Shading::alpha`], f16, read by
//!   the alpha masks of [`super::mask`]); no blending is rendered (`Material::base_color`
//!   ignores alpha);
//! * f16 keeps every 8-bit sRGB source exactly enough: its rounding error (≤ 2⁻¹¹ relative,
//!   0.05 %) is under a twentieth of the gap between the linear values of two adjacent sRGB
//!   codes (≥ 0.9 % above code 10; absolute 3·10⁻⁴ below, where f16 is far finer), so every
//!   code keeps a distinct value; 16-bit and float sources lose at most those 0.05 %, values
//!   above 65504 are clamped;
//! * storing the sources' sRGB bytes instead (4 bytes) would not hold 16-bit or float images
//!   and would cost a decode (a `pow`) per texel fetch in the renderer's per-pixel pass.

use glam::{Vec2, Vec3};

use super::encoding::RadianceEncoding;
use super::radiance::Radiance;
use crate::scene::{FilterMode, Material, Scene, Texture, WrapMode};

/// Texture index meaning "no texture" (reads 1).
pub const NO_TEXTURE: u32 = u32::MAX;

/// Largest texture side the light field accepts (texels).
pub const MAX_TEXTURE_SIDE: u32 = 1 << 16;

/// The part of a material the renderer shades with (per-pixel diffuse and emission).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// Linear baseColorFactor (rgb).
    pub base_color: [f32; 3],
    /// Weight of the Lambertian lobe ([`Material::diffuse_weight`]: 1 diffuse, 0 mirror,
    /// `1 − specular` mixed).
    pub diffuse_weight: f32,
    /// Emitted radiance factor (front side only).
    pub emission: [f32; 3],
    /// Index into [`Shading::textures`] of the base-colour texture, or [`NO_TEXTURE`].
    pub base_color_texture: u32,
    /// Index into [`Shading::textures`] of the emissive texture, or [`NO_TEXTURE`].
    pub emissive_texture: u32,
    /// GGX α of the metal lobe ([`Material::specular_alpha`]; 0: a perfect mirror, or no
    /// metal lobe): pass 5 samples the lobe when it traces a reflection.
    pub specular_alpha: f32,
    /// Alpha mask ([`super::mask`]): where baseColorFactor.a × the base-colour texture's alpha
    /// is below this there is no surface; 0 for opaque materials (coverage is never below 0).
    pub alpha_cutoff: f32,
    /// baseColorFactor.a (1 for opaque materials).
    pub alpha_factor: f32,
    /// Whether the mask reads its texture with NEAREST filtering (else LINEAR).
    pub alpha_nearest: bool,
    /// Weight of the thin glass pane ([`Material::pane_weight`]; 0: none): it reflects
    /// `pane × R(θ)` as a mirror, untinted, and passes `pane × T(θ) × base colour × texture`
    /// straight through ([`crate::scene::pane_reflectance`]).
    pub pane: f32,
    /// The pane's index of refraction.
    pub ior: f32,
    /// The texture coordinate set (0 or 1) the base-colour texture is read with.
    pub base_color_texcoord: u32,
    /// The texture coordinate set (0 or 1) the emissive texture is read with.
    pub emissive_texcoord: u32,
}

impl SurfaceMaterial {
    /// From an imported material.
    pub fn from_material(m: &Material) -> Self {
        SurfaceMaterial {
            base_color: m.base_color.into(),
            diffuse_weight: m.diffuse_weight(),
            emission: m.emission.into(),
            base_color_texture: m.base_color_texture.map_or(NO_TEXTURE, |t| t.index),
            emissive_texture: m.emissive_texture.map_or(NO_TEXTURE, |t| t.index),
            specular_alpha: m.specular_alpha(),
            alpha_cutoff: if m.transparency.masks() {
                m.transparency.cutoff()
            } else {
                0.0
            },
            alpha_factor: if m.transparency.masks() {
                m.transparency.alpha
            } else {
                1.0
            },
            alpha_nearest: false,
            pane: m.pane_weight(),
            ior: m.transparency.ior,
            base_color_texcoord: m.base_color_texture.map_or(0, |t| t.texcoord.min(1)),
            emissive_texcoord: m.emissive_texture.map_or(0, |t| t.texcoord.min(1)),
        }
    }

    /// A black opaque diffuse material: the fields a file's `materials` section does not hold
    /// at their opaque values (what files without a `surfaces` section mean).
    pub fn opaque_default() -> Self {
        SurfaceMaterial {
            base_color: [0.0; 3],
            diffuse_weight: 1.0,
            emission: [0.0; 3],
            base_color_texture: NO_TEXTURE,
            emissive_texture: NO_TEXTURE,
            specular_alpha: 0.0,
            alpha_cutoff: 0.0,
            alpha_factor: 1.0,
            alpha_nearest: false,
            pane: 0.0,
            ior: crate::scene::DEFAULT_IOR,
            base_color_texcoord: 0,
            emissive_texcoord: 0,
        }
    }

    /// Whether a texture of the material reads `TEXCOORD_1`.
    pub fn uses_texcoord1(&self) -> bool {
        (self.base_color_texture != NO_TEXTURE && self.base_color_texcoord == 1)
            || (self.emissive_texture != NO_TEXTURE && self.emissive_texcoord == 1)
    }

    /// Whether the material cuts holes where its coverage is below [`alpha_cutoff`](Self::alpha_cutoff).
    pub fn masks(&self) -> bool {
        self.alpha_cutoff > 0.0
    }

    /// The diffuse albedo factor `diffuse weight × baseColorFactor` (times the base-colour
    /// texture, where there is one).
    pub fn diffuse_albedo(&self) -> Vec3 {
        Vec3::from(self.base_color) * self.diffuse_weight
    }
}

/// A texture's size and sampler (its texels are in [`Shading::texels`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SurfaceTexture {
    pub width: u32,
    pub height: u32,
    pub wrap_s: WrapMode,
    pub wrap_t: WrapMode,
}

impl SurfaceTexture {
    /// Texels of the texture.
    pub fn texel_count(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// Materials, uvs and textures of a light field (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Shading {
    pub materials: Vec<SurfaceMaterial>,
    /// `TEXCOORD_0` at the three corners of each triangle, in the order of
    /// [`LightField::triangles`](super::LightField::triangles) (zeros where the mesh has none).
    pub uvs: Vec<[[f32; 2]; 3]>,
    /// `TEXCOORD_1` at the three corners of each triangle (zeros where the mesh has none);
    /// `None` unless some material reads a texture with it.
    pub uvs1: Option<Vec<[[f32; 2]; 3]>>,
    /// Unit shading normals at the three corners of each triangle (VLF directions equal world
    /// ones: the VLF transform is a similarity), zero vectors at the corners of flat
    /// triangles; `None` when every triangle is flat.
    pub normals: Option<Vec<[[f32; 3]; 3]>>,
    /// `COLOR_0` at the three corners of each triangle (linear RGB in [0, 1], white where the
    /// mesh has none); `None` when no triangle has vertex colours.
    pub colors: Option<Vec<[[f32; 3]; 3]>>,
    pub textures: Vec<SurfaceTexture>,
    /// Linear RGB of every texture's texels, f16: the textures one after another in
    /// `textures` order, each row-major with row 0 the top of the image (glTF uv (0, 0) is its
    /// top-left corner).
    pub texels: Radiance,
    /// The alpha of the same texels (f16 bits, in [0, 1]) where a material masks
    /// ([`SurfaceMaterial::masks`]); empty otherwise (alpha is then never read).
    pub alpha: Vec<u16>,
}

/// Materials, uvs or textures that do not fit together ([`Shading::check`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{element}: {reason}")]
pub struct InvalidShading {
    /// E.g. `material 3`, `uvs of triangle 7`, `texture 1`.
    pub element: String,
    pub reason: String,
}

impl Shading {
    /// No materials, textures or uvs.
    pub fn empty() -> Self {
        Shading {
            materials: Vec::new(),
            uvs: Vec::new(),
            uvs1: None,
            normals: None,
            colors: None,
            textures: Vec::new(),
            texels: Radiance::new(RadianceEncoding::RgbF16),
            alpha: Vec::new(),
        }
    }

    /// The scene's materials, triangle uvs (non-finite ones as 0) and textures (non-finite
    /// texels as 0, with a warning: no encoding stores them).
    pub fn from_scene(scene: &Scene) -> Self {
        let uvs = scene
            .triangles
            .iter()
            .map(|t| t.uv.map(finite_uv))
            .collect();
        let mut values = Vec::new();
        let mut non_finite = 0usize;
        for t in &scene.textures {
            let n = t.width as usize * t.height as usize;
            values.extend(t.pixels.iter().take(n).map(|p| {
                let v = p.truncate();
                if v.is_finite() {
                    v.extend(0.0).to_array()
                } else {
                    non_finite += 1;
                    let fix = |c: f32| if c.is_finite() { c } else { 0.0 };
                    [fix(v.x), fix(v.y), fix(v.z), 0.0]
                }
            }));
            // A decoded image shorter than its size (the importer rejects those) reads 1.
            values.resize(values.len() + n.saturating_sub(t.pixels.len()), [1.0; 4]);
        }
        if non_finite > 0 {
            log::warn!("{non_finite} texture texels are not finite; stored as 0");
        }
        let materials = surface_materials(scene);
        let alpha = if materials.iter().any(SurfaceMaterial::masks) {
            (scene.textures.iter())
                .flat_map(|t| (0..t.width as usize * t.height as usize).map(|i| texel_alpha(t, i)))
                .collect()
        } else {
            Vec::new()
        };
        let uvs1 = materials
            .iter()
            .any(SurfaceMaterial::uses_texcoord1)
            .then(|| {
                scene
                    .triangles
                    .iter()
                    .map(|t| t.uv_set(1).map(finite_uv))
                    .collect()
            });
        let normals = scene.has_smooth_normals().then(|| {
            (scene.triangles.iter())
                .map(|t| t.normals.map_or([[0.0; 3]; 3], |n| n.map(|v| v.to_array())))
                .collect()
        });
        let colors = scene.has_vertex_colors().then(|| {
            (scene.triangles.iter())
                .map(|t| t.colors.map_or([[1.0; 3]; 3], |c| c.map(|v| v.to_array())))
                .collect()
        });
        Shading {
            materials,
            uvs,
            uvs1,
            normals,
            colors,
            textures: surface_textures(scene),
            texels: Radiance::from_f32(&values, RadianceEncoding::RgbF16)
                .expect("non-finite texels were replaced"),
            alpha,
        }
    }

    /// Index of the first texel of each texture in [`texels`](Self::texels).
    pub fn texture_offsets(&self) -> Vec<u64> {
        let mut first = 0u64;
        self.textures
            .iter()
            .map(|t| {
                let f = first;
                first = first.saturating_add(t.texel_count());
                f
            })
            .collect()
    }

    /// Bytes of materials, uvs, per-corner attributes and textures in memory.
    pub fn byte_len(&self) -> usize {
        size_of_val(self.materials.as_slice())
            + size_of_val(self.uvs.as_slice())
            + self.uvs1.as_ref().map_or(0, |v| size_of_val(v.as_slice()))
            + self
                .normals
                .as_ref()
                .map_or(0, |v| size_of_val(v.as_slice()))
            + self
                .colors
                .as_ref()
                .map_or(0, |v| size_of_val(v.as_slice()))
            + size_of_val(self.textures.as_slice())
            + self.texels.byte_len()
            + size_of_val(self.alpha.as_slice())
    }

    /// Whether a material masks ([`SurfaceMaterial::masks`]).
    pub fn has_masks(&self) -> bool {
        self.materials.iter().any(SurfaceMaterial::masks)
    }

    /// The corner texture coordinates of set `set` of triangle `tri` (a missing set 1 reads
    /// 0).
    pub fn corner_uvs(&self, tri: usize, set: u32) -> [Vec2; 3] {
        let uv = match (set, &self.uvs1) {
            (1, Some(u1)) => u1[tri],
            (1, None) => [[0.0; 2]; 3],
            _ => self.uvs[tri],
        };
        uv.map(Vec2::from)
    }

    /// Texture coordinates of set `set` of triangle `tri` at barycentric weights `b` (of
    /// corners 0, 1, 2), in f32 as the renderer interpolates them.
    pub fn uv_at(&self, tri: usize, set: u32, b: [f32; 3]) -> Vec2 {
        let uv = self.corner_uvs(tri, set);
        uv[0] * b[0] + uv[1] * b[1] + uv[2] * b[2]
    }

    /// The vertex colour of triangle `tri` at barycentric weights `b`: 1 without colours.
    pub fn color_at(&self, tri: usize, b: [f32; 3]) -> Vec3 {
        match &self.colors {
            Some(c) => {
                let c = c[tri].map(Vec3::from);
                c[0] * b[0] + c[1] * b[1] + c[2] * b[2]
            }
            None => Vec3::ONE,
        }
    }

    /// The interpolated shading normal of triangle `tri` at barycentric weights `b`, not
    /// normalised; zero for a flat triangle (the face's normal shades it).
    pub fn normal_at(&self, tri: usize, b: [f32; 3]) -> Vec3 {
        match &self.normals {
            Some(n) => {
                let n = n[tri].map(Vec3::from);
                n[0] * b[0] + n[1] * b[1] + n[2] * b[2]
            }
            None => Vec3::ZERO,
        }
    }

    /// Checks that the parts fit together for a light field of `triangles` triangles: one uv
    /// triple per triangle, all finite; materials finite and non-negative, diffuse weights in
    /// [0, 1], texture indices in range; textures of 1..=[`MAX_TEXTURE_SIDE`] texels per side
    /// whose texels add up to `texels`, stored in f16.
    pub fn check(&self, triangles: usize) -> Result<(), InvalidShading> {
        let bad = |element: String, reason: String| Err(InvalidShading { element, reason });
        if self.uvs.len() != triangles {
            return bad(
                "uvs".into(),
                format!("{} uv triples for {triangles} triangles", self.uvs.len()),
            );
        }
        if let Some(i) = self
            .uvs
            .iter()
            .position(|t| !t.iter().flatten().all(|x| x.is_finite()))
        {
            return bad(format!("uvs of triangle {i}"), "non-finite value".into());
        }
        let per_triangle = |name: &str, len: Option<usize>| match len {
            Some(n) if n != triangles => Err(InvalidShading {
                element: name.into(),
                reason: format!("{n} corner triples for {triangles} triangles"),
            }),
            _ => Ok(()),
        };
        per_triangle("uvs1", self.uvs1.as_ref().map(Vec::len))?;
        per_triangle("normals", self.normals.as_ref().map(Vec::len))?;
        per_triangle("colors", self.colors.as_ref().map(Vec::len))?;
        if let Some(i) =
            (self.uvs1.iter().flatten()).position(|t| !t.iter().flatten().all(|x| x.is_finite()))
        {
            return bad(format!("uvs1 of triangle {i}"), "non-finite value".into());
        }
        if let Some(i) = self.normals.iter().flatten().position(|t| {
            !t.iter().all(|n| {
                let n = Vec3::from(*n);
                n.is_finite() && (n == Vec3::ZERO || (n.length() - 1.0).abs() < 1e-3)
            })
        }) {
            return bad(
                format!("normals of triangle {i}"),
                "not unit length, zero or finite".into(),
            );
        }
        if let Some(i) = self
            .colors
            .iter()
            .flatten()
            .position(|t| !t.iter().flatten().all(|x| (0.0..=1.0).contains(x)))
        {
            return bad(
                format!("colors of triangle {i}"),
                "a component outside [0, 1]".into(),
            );
        }
        let n_tex = self.textures.len();
        for (i, m) in self.materials.iter().enumerate() {
            let el = || format!("material {i}");
            let colours = m.base_color.iter().chain(&m.emission);
            if !colours.clone().all(|x| x.is_finite() && *x >= 0.0) {
                return bad(
                    el(),
                    "colour factors must be finite and non-negative".into(),
                );
            }
            if !(0.0..=1.0).contains(&m.diffuse_weight) {
                return bad(
                    el(),
                    format!("diffuse weight {} is not in [0, 1]", m.diffuse_weight),
                );
            }
            if !(0.0..=1.0).contains(&m.specular_alpha) {
                return bad(el(), format!("GGX α {} is not in [0, 1]", m.specular_alpha));
            }
            if !(m.alpha_cutoff.is_finite() && m.alpha_cutoff >= 0.0) {
                return bad(
                    el(),
                    format!(
                        "alpha cutoff {} is not finite and non-negative",
                        m.alpha_cutoff
                    ),
                );
            }
            if !(0.0..=1.0).contains(&m.alpha_factor) {
                return bad(
                    el(),
                    format!("alpha factor {} is not in [0, 1]", m.alpha_factor),
                );
            }
            if !(0.0..=1.0).contains(&m.pane) || m.diffuse_weight + m.pane > 1.0 + 1e-6 {
                return bad(
                    el(),
                    format!(
                        "pane weight {} is not in [0, 1 − diffuse weight {}]",
                        m.pane, m.diffuse_weight
                    ),
                );
            }
            if !(m.ior.is_finite() && m.ior >= 1.0) {
                return bad(el(), format!("index of refraction {} is below 1", m.ior));
            }
            if m.base_color_texcoord > 1 || m.emissive_texcoord > 1 {
                return bad(el(), "texture coordinate sets must be 0 or 1".into());
            }
            for (slot, t) in [
                ("base-colour", m.base_color_texture),
                ("emissive", m.emissive_texture),
            ] {
                if t != NO_TEXTURE && t as usize >= n_tex {
                    return bad(
                        el(),
                        format!("{slot} texture {t} is out of range ({n_tex} textures)"),
                    );
                }
            }
        }
        let mut total = 0u64;
        for (i, t) in self.textures.iter().enumerate() {
            let ok = |s: u32| (1..=MAX_TEXTURE_SIDE).contains(&s);
            if !ok(t.width) || !ok(t.height) {
                return bad(
                    format!("texture {i}"),
                    format!(
                        "size {} × {} is outside 1..={MAX_TEXTURE_SIDE} per side",
                        t.width, t.height
                    ),
                );
            }
            total += t.texel_count();
        }
        if total != self.texels.len() as u64 {
            return bad(
                "textures".into(),
                format!(
                    "{} textures need {total} texels, but there are {}",
                    n_tex,
                    self.texels.len()
                ),
            );
        }
        if !self.alpha.is_empty() && self.alpha.len() != self.texels.len() {
            return bad(
                "texture alpha".into(),
                format!(
                    "{} alpha values for {} texels",
                    self.alpha.len(),
                    self.texels.len()
                ),
            );
        }
        // f16 values in [0, 1]: at most 0x3C00 (1.0), no sign bit.
        if let Some(i) = self.alpha.iter().position(|&a| a > 0x3C00) {
            return bad(
                format!("texture alpha {i}"),
                "not a stored alpha (outside [0, 1] or not a number)".into(),
            );
        }
        if self.texels.encoding() != RadianceEncoding::RgbF16 {
            return bad(
                "texels".into(),
                format!("stored as {}, not rgb16f", self.texels.encoding().name()),
            );
        }
        Ok(())
    }

    /// Texture `t` at glTF `uv`, bilinear with its wrap modes, in f32: the renderer's lookup
    /// (`shaders/common/texture.wgsl`), of which this is the CPU mirror. Per axis: the
    /// coordinate, clamped to ±10⁹, is reduced to one period unless the mode clamps
    /// (`u − p·floor(u/p)`, p = 1 for repeat, 2 for mirrored repeat); texel coordinate
    /// `x = u × size − ½` (clamped to ±10⁹); texels `floor(x)` and `floor(x) + 1`, wrapped;
    /// weight `x − floor(x)`. The same texels and weights as `scene::Texture::bilinear` up to
    /// the rounding of the reduction. [`NO_TEXTURE`] reads 1. Panics if `t` is out of range
    /// (see [`check`](Self::check)).
    pub fn sample(&self, t: u32, uv: Vec2, offsets: &[u64]) -> Vec3 {
        if t == NO_TEXTURE {
            return Vec3::ONE;
        }
        let tex = &self.textures[t as usize];
        let first = offsets[t as usize];
        let (i0, i1, fx) = texel_axis(uv.x, tex.width, tex.wrap_s);
        let (j0, j1, fy) = texel_axis(uv.y, tex.height, tex.wrap_t);
        let texel = |i: u32, j: u32| {
            let k = first + u64::from(j) * u64::from(tex.width) + u64::from(i);
            Vec3::from(self.texels.get(k as usize))
        };
        let top = texel(i0, j0).lerp(texel(i1, j0), fx);
        let bottom = texel(i0, j1).lerp(texel(i1, j1), fx);
        top.lerp(bottom, fy)
    }
}

/// The file's materials of `scene`'s: [`SurfaceMaterial::from_material`] each, a mask reading
/// its texture NEAREST where the base-colour texture's sampler says so (what both the light
/// field and the bake's [`super::mask::AlphaMasks::from_scene`] store).
pub fn surface_materials(scene: &Scene) -> Vec<SurfaceMaterial> {
    scene
        .materials
        .iter()
        .map(|m| {
            let mut s = SurfaceMaterial::from_material(m);
            s.alpha_nearest = s.masks()
                && m.base_color_texture
                    .and_then(|t| scene.textures.get(t.index as usize))
                    .is_some_and(|t| t.filter == FilterMode::Nearest);
            s
        })
        .collect()
}

/// The file's textures of `scene`'s: their sizes and wrap modes.
pub fn surface_textures(scene: &Scene) -> Vec<SurfaceTexture> {
    (scene.textures.iter())
        .map(|t| SurfaceTexture {
            width: t.width,
            height: t.height,
            wrap_s: t.wrap_s,
            wrap_t: t.wrap_t,
        })
        .collect()
}

/// A corner's texture coordinates as the light field stores them: a non-finite one as 0.
pub fn finite_uv(uv: Vec2) -> [f32; 2] {
    if uv.is_finite() { uv } else { Vec2::ZERO }.to_array()
}

/// A texture alpha as the light field stores it ([`Shading::alpha`]): clamped to [0, 1] (NaN as
/// 1), in f16.
pub fn texture_alpha(a: f32) -> u16 {
    super::encoding::f16_encode(if a.is_nan() { 1.0 } else { a.clamp(0.0, 1.0) })
}

/// The stored alpha ([`texture_alpha`]) of texel `i` of `texture`, 1 past its decoded pixels
/// (an image shorter than its size, which the importer rejects): the one read of a scene's
/// texture alpha, for the light field's [`Shading::alpha`] and the bake's
/// [`super::mask::AlphaMasks::from_scene`].
pub fn texel_alpha(texture: &Texture, i: usize) -> u16 {
    texture
        .pixels
        .get(i)
        .map_or(texture_alpha(1.0), |p| texture_alpha(p.w))
}

/// One axis of [`Shading::sample`]: the wrapped indices of the two texels around the sample
/// point and the weight of the second (`texel_axis` of `shaders/common/texture.wgsl`).
pub(crate) fn texel_axis(u: f32, size: u32, mode: WrapMode) -> (u32, u32, f32) {
    let mut r = u.clamp(-1e9, 1e9);
    if mode != WrapMode::ClampToEdge {
        let p = if mode == WrapMode::MirroredRepeat {
            2.0
        } else {
            1.0
        };
        r -= p * (r / p).floor();
    }
    let x = (r * size as f32 - 0.5).clamp(-1e9, 1e9);
    let x0 = x.floor();
    let i = x0 as i32;
    let n = size as i32;
    (
        wrap_reduced(i, n, mode),
        wrap_reduced(i + 1, n, mode),
        x - x0,
    )
}

/// Index `i` of a coordinate reduced to one period ([`texel_axis`]) wrapped into `0..n`
/// (`wrap_reduced` of `shaders/common/texture.wgsl`).
pub(crate) fn wrap_reduced(i: i32, n: i32, mode: WrapMode) -> u32 {
    if mode == WrapMode::ClampToEdge {
        return i.clamp(0, n - 1) as u32;
    }
    let period = if mode == WrapMode::MirroredRepeat {
        2 * n
    } else {
        n
    };
    let mut m = if i < 0 { i + period } else { i };
    if m >= period {
        m -= period;
    }
    (if m >= n { 2 * n - 1 - m } else { m }) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Texture;
    use glam::Vec4;

    /// `sample` reads the same texels with the same weights as `Texture::bilinear` (the spec of
    /// the bake and the path tracer), up to the rounding of its reduction to one period, for
    /// every wrap mode, far outside [0, 1] too.
    #[test]
    fn sample_agrees_with_the_importers_bilinear_lookup() {
        let (w, h) = (5u32, 3u32);
        let pixels: Vec<Vec4> = (0..w * h)
            .map(|i| Vec4::new(i as f32, (i * 7 % 11) as f32, (i % 2) as f32, 1.0))
            .collect();
        let mut s = 0x1234_5678u32;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s as f32 / u32::MAX as f32
        };
        for wrap_s in WrapMode::ALL {
            for wrap_t in WrapMode::ALL {
                let tex = Texture {
                    name: None,
                    width: w,
                    height: h,
                    pixels: pixels.clone(),
                    has_alpha: false,
                    wrap_s,
                    wrap_t,
                    filter: FilterMode::Nearest,
                    gltf_texture: 0,
                };
                let values: Vec<[f32; 4]> = pixels.iter().map(|p| p.to_array()).collect();
                let shading = Shading {
                    textures: vec![SurfaceTexture {
                        width: w,
                        height: h,
                        wrap_s,
                        wrap_t,
                    }],
                    // Small integers: exact in f16.
                    texels: Radiance::from_f32(&values, RadianceEncoding::RgbF16).unwrap(),
                    ..Shading::empty()
                };
                let offsets = shading.texture_offsets();
                for k in 0..2000 {
                    let span = [1.0, 4.0, 300.0][k % 3];
                    let uv = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 2.0 * span;
                    let got = shading.sample(0, uv, &offsets);
                    let want = tex.bilinear(uv).truncate();
                    // Values up to 14; the reduction moves a weight by a few ulps of `span`.
                    let tol = 14.0 * span * w as f32 * 4e-7;
                    assert!(
                        (got - want).abs().max_element() <= tol,
                        "{wrap_s:?}/{wrap_t:?} at {uv}: {got} vs {want}"
                    );
                }
                // Texel centres read their texel exactly.
                for (i, p) in pixels.iter().enumerate() {
                    let (x, y) = (i as u32 % w, i as u32 / w);
                    let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                    assert_eq!(shading.sample(0, uv, &offsets), p.truncate());
                }
            }
        }
        assert_eq!(
            Shading::empty().sample(NO_TEXTURE, Vec2::ZERO, &[]),
            Vec3::ONE
        );
    }
}
