//! The shading sections of a file: materials, triangle uvs, textures and their texels (see
//! `lightfield::shading`), their on-disk types (converted field by field, like `disk`'s) and
//! their conversion to and from a [`Shading`].

use bytemuck::{Pod, Zeroable};

use crate::lightfield::{Radiance, Shading, SurfaceMaterial, SurfaceTexture};
use crate::scene::WrapMode;

/// A material's shading factors (40 bytes; every field a 4-byte little-endian word).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileMaterial {
    pub base_color: [f32; 3],
    pub diffuse_weight: f32,
    pub emission: [f32; 3],
    /// Index into the `textures` section, or `u32::MAX` for none.
    pub base_color_texture: u32,
    /// Index into the `textures` section, or `u32::MAX` for none.
    pub emissive_texture: u32,
    /// GGX α of the metal lobe (0: a perfect mirror or none). Files written before it existed
    /// hold 0 here (the word was reserved and written 0), which renders their metals as the
    /// perfect mirrors they were rendered as then.
    pub specular_alpha: f32,
}

/// A triangle's `TEXCOORD_0` at its three corners (24 bytes: u0, v0, u1, v1, u2, v2).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileUvs {
    pub uv: [f32; 6],
}

/// Three vectors at a triangle's corners (36 bytes: x0 y0 z0 x1 y1 z1 x2 y2 z2): its shading
/// normals or its vertex colours.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileCorners {
    pub v: [f32; 9],
}

impl From<&[[f32; 3]; 3]> for FileCorners {
    fn from(t: &[[f32; 3]; 3]) -> Self {
        let mut v = [0.0; 9];
        for (k, c) in t.iter().enumerate() {
            v[3 * k..3 * k + 3].copy_from_slice(c);
        }
        FileCorners { v }
    }
}

impl From<&FileCorners> for [[f32; 3]; 3] {
    fn from(t: &FileCorners) -> Self {
        let v = t.v;
        [[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]]
    }
}

/// Bit of a `material_texcoords` word: the base-colour texture reads `TEXCOORD_1`.
pub const TEXCOORD1_BASE: u32 = 1;
/// Bit of a `material_texcoords` word: the emissive texture reads `TEXCOORD_1`.
pub const TEXCOORD1_EMISSIVE: u32 = 2;

/// The optional per-corner sections of a [`Shading`] (each `None` when not written).
#[derive(Default)]
pub(super) struct Attributes {
    pub uvs1: Option<Vec<FileUvs>>,
    pub normals: Option<Vec<FileCorners>>,
    pub colors: Option<Vec<FileCorners>>,
    pub texcoords: Option<Vec<u32>>,
}

/// The optional sections of `s` (see [`Attributes`]): the material words only where some
/// material reads `TEXCOORD_1`.
pub(super) fn pack_attributes(s: &Shading) -> Attributes {
    let words: Vec<u32> = s
        .materials
        .iter()
        .map(|m| {
            (if m.base_color_texcoord == 1 {
                TEXCOORD1_BASE
            } else {
                0
            }) | (if m.emissive_texcoord == 1 {
                TEXCOORD1_EMISSIVE
            } else {
                0
            })
        })
        .collect();
    Attributes {
        uvs1: s
            .uvs1
            .as_ref()
            .map(|u| u.iter().map(FileUvs::from).collect()),
        normals: (s.normals.as_ref()).map(|n| n.iter().map(FileCorners::from).collect()),
        colors: (s.colors.as_ref()).map(|c| c.iter().map(FileCorners::from).collect()),
        texcoords: words.iter().any(|w| *w != 0).then_some(words),
    }
}

/// Adds the optional sections `a` to `s`; `Err` names a material word with unknown bits.
pub(super) fn unpack_attributes(s: &mut Shading, a: Attributes) -> Result<(), (String, String)> {
    s.uvs1 = a
        .uvs1
        .map(|u| u.iter().map(<[[f32; 2]; 3]>::from).collect());
    s.normals = a
        .normals
        .map(|n| n.iter().map(<[[f32; 3]; 3]>::from).collect());
    s.colors = a
        .colors
        .map(|c| c.iter().map(<[[f32; 3]; 3]>::from).collect());
    if let Some(words) = a.texcoords {
        if words.len() != s.materials.len() {
            return Err((
                "material_texcoords".into(),
                format!("{} words for {} materials", words.len(), s.materials.len()),
            ));
        }
        for (i, (m, w)) in s.materials.iter_mut().zip(words).enumerate() {
            if w & !(TEXCOORD1_BASE | TEXCOORD1_EMISSIVE) != 0 {
                return Err((
                    format!("material {i}"),
                    format!("unknown texcoord bits {w:#x}"),
                ));
            }
            m.base_color_texcoord = u32::from(w & TEXCOORD1_BASE != 0);
            m.emissive_texcoord = u32::from(w & TEXCOORD1_EMISSIVE != 0);
        }
    }
    Ok(())
}

/// A texture's size and wrap modes (16 bytes); its texels follow the previous textures' in
/// the `texels` section.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileTexture {
    pub width: u32,
    pub height: u32,
    /// [`WrapMode::id`]: 0 repeat, 1 clamp to edge, 2 mirrored repeat.
    pub wrap_s: u32,
    pub wrap_t: u32,
}

/// What lets light through a material (32 bytes; every field a 4-byte little-endian word):
/// section `surfaces`, one per material, written only when a material masks or has a pane
/// (files without it hold opaque materials).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileSurface {
    /// [`SurfaceMaterial::alpha_cutoff`] (0: no mask).
    pub alpha_cutoff: f32,
    /// [`SurfaceMaterial::alpha_factor`].
    pub alpha_factor: f32,
    /// Bit 0: the mask reads its texture with NEAREST filtering; other bits 0.
    pub flags: u32,
    /// [`SurfaceMaterial::pane`] (0: no pane).
    pub pane: f32,
    /// [`SurfaceMaterial::ior`].
    pub ior: f32,
    /// Reserved, written 0.
    pub reserved: [u32; 3],
}

/// [`FileSurface::flags`] bit: NEAREST mask filtering.
pub const SURFACE_NEAREST: u32 = 1;

impl From<&SurfaceMaterial> for FileSurface {
    fn from(m: &SurfaceMaterial) -> Self {
        FileSurface {
            alpha_cutoff: m.alpha_cutoff,
            alpha_factor: m.alpha_factor,
            flags: if m.alpha_nearest { SURFACE_NEAREST } else { 0 },
            pane: m.pane,
            ior: m.ior,
            reserved: [0; 3],
        }
    }
}

impl FileSurface {
    /// Writes the record into `m`; `Err` names what is not a record a writer produces.
    pub fn apply(&self, m: &mut SurfaceMaterial) -> Result<(), String> {
        if self.flags & !SURFACE_NEAREST != 0 || self.reserved != [0; 3] {
            return Err(format!(
                "unknown flags {:#x} or reserved words {:?} set",
                self.flags, self.reserved
            ));
        }
        m.alpha_cutoff = self.alpha_cutoff;
        m.alpha_factor = self.alpha_factor;
        m.alpha_nearest = self.flags & SURFACE_NEAREST != 0;
        m.pane = self.pane;
        m.ior = self.ior;
        Ok(())
    }
}

/// Whether `s` needs the `surfaces` section (a material that is not plainly opaque).
pub(super) fn has_surfaces(s: &Shading) -> bool {
    s.materials
        .iter()
        .any(|m| FileSurface::from(m) != FileSurface::from(&SurfaceMaterial::opaque_default()))
}

impl From<&SurfaceMaterial> for FileMaterial {
    fn from(m: &SurfaceMaterial) -> Self {
        FileMaterial {
            base_color: m.base_color,
            diffuse_weight: m.diffuse_weight,
            emission: m.emission,
            base_color_texture: m.base_color_texture,
            emissive_texture: m.emissive_texture,
            specular_alpha: m.specular_alpha,
        }
    }
}

impl From<&FileMaterial> for SurfaceMaterial {
    fn from(m: &FileMaterial) -> Self {
        SurfaceMaterial {
            base_color: m.base_color,
            diffuse_weight: m.diffuse_weight,
            emission: m.emission,
            base_color_texture: m.base_color_texture,
            emissive_texture: m.emissive_texture,
            specular_alpha: m.specular_alpha,
            ..SurfaceMaterial::opaque_default()
        }
    }
}

impl From<&[[f32; 2]; 3]> for FileUvs {
    fn from(t: &[[f32; 2]; 3]) -> Self {
        FileUvs {
            uv: [t[0][0], t[0][1], t[1][0], t[1][1], t[2][0], t[2][1]],
        }
    }
}

impl From<&FileUvs> for [[f32; 2]; 3] {
    fn from(t: &FileUvs) -> Self {
        let u = t.uv;
        [[u[0], u[1]], [u[2], u[3]], [u[4], u[5]]]
    }
}

impl From<&SurfaceTexture> for FileTexture {
    fn from(t: &SurfaceTexture) -> Self {
        FileTexture {
            width: t.width,
            height: t.height,
            wrap_s: t.wrap_s.id(),
            wrap_t: t.wrap_t.id(),
        }
    }
}

/// The on-disk records of `s`: materials, uvs, textures (the texels are written as stored).
pub(super) fn pack(s: &Shading) -> (Vec<FileMaterial>, Vec<FileUvs>, Vec<FileTexture>) {
    (
        s.materials.iter().map(FileMaterial::from).collect(),
        s.uvs.iter().map(FileUvs::from).collect(),
        s.textures.iter().map(FileTexture::from).collect(),
    )
}

/// The shading of a file's sections; `Err` names a texture with an unknown wrap mode.
pub(super) fn unpack(
    materials: &[FileMaterial],
    uvs: &[FileUvs],
    textures: &[FileTexture],
    texels: Radiance,
) -> Result<Shading, (String, String)> {
    let textures = textures
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mode = |id| {
                WrapMode::from_id(id).ok_or_else(|| {
                    (
                        format!("texture {i}"),
                        format!(
                            "unknown wrap mode {id} (0 repeat, 1 clamp to edge, 2 mirrored repeat)"
                        ),
                    )
                })
            };
            Ok::<_, (String, String)>(SurfaceTexture {
                width: t.width,
                height: t.height,
                wrap_s: mode(t.wrap_s)?,
                wrap_t: mode(t.wrap_t)?,
            })
        })
        .collect::<Result<_, _>>()?;
    Ok(Shading {
        materials: materials.iter().map(SurfaceMaterial::from).collect(),
        uvs: uvs.iter().map(<[[f32; 2]; 3]>::from).collect(),
        uvs1: None,
        normals: None,
        colors: None,
        textures,
        texels,
        alpha: Vec::new(),
    })
}
