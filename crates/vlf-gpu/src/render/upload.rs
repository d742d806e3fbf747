//! The light field uploaded for rendering. Validated on upload so user data can never make a pass
//! read out of range.
//!
//! * Geometry, the triangles' corner uvs and the direction set's sphere mesh: storage buffers,
//!   read by vertex shaders only (a few invocations per triangle). The triangles are uploaded
//!   grouped by their face's stencil value ([`stencil_value`]: textured, mirror), in that
//!   order (`GpuLightField::stencil_starts`), so that pass 3 can draw each group with its own
//!   stencil value; each keeps its face index, so no output changes.
//! * Per-pixel data of pass 5 — the irradiance atlas, the face records and the textures — are
//!   2D textures read with `textureLoad`: on lavapipe a per-pixel, non-uniformly indexed
//!   storage-buffer read costs several times a texel fetch (measured: reading one `vec4` per
//!   pixel from a storage buffer took ~14 ms at 1024×768, a texture fetch a fraction of that).
//!
//! These textures are linear arrays wrapped into rows: element `i` is texel
//! `(i % width, i / width)`.
//!
//! * Atlas ([`ATLAS_WIDTH`] wide): texel `i` = `LightField::irradiance.get(i)`, uploaded in its
//!   stored encoding with no decoding on the CPU ([`radiance_format`]): RGB9E5 as it is, into
//!   an `Rgb9e5Ufloat` texture (4 bytes per texel, the file's bits); f16 RGB as an
//!   `Rgba16Float` texture (8 bytes per texel: the file's halves copied next to a zero alpha,
//!   as wgpu has no 3-channel half format). Texel fetches decode them exactly, so the shader
//!   reads the same f32 values as `Radiance::get` and is the same for both.
//! * Face records (`Rgba32Uint`, [`FACE_RECORD_TEXELS`] texels per face, [`FACES_PER_ROW`] faces
//!   per row; floats stored as their bits), the face's chart and its material joined
//!   ([`face_record`]):
//!   0: normal.xyz, kind | flags · 1: origin.xyz, texel_size · 2: u.xyz, width ·
//!   3: v.xyz, height · 4: ρ_d/π (rgb), texel_base · 5: Le (rgb), 0 ·
//!   6: base-colour texture, emissive texture, pane IOR, pane weight (`f32` bits; 1.5 and 0
//!   without a pane) · 7: mirror reflectance (rgb, [`specular_reflectance`]; a pane's
//!   transmission tint, pane weight × base colour), GGX α of the metal lobe (`f32` bits).
//!   Pass 5 reads texels 0–4 of every face, 5 only for emitters, 6 only for textured faces and
//!   panes ([`FLAG_DIFFUSE`] and the other flags) and 7 only for non-diffuse faces: the
//!   reflectance for the visible one and for mirrors along a traced chain, α for the visible
//!   one ([`super::mirror_trace`]).
//! * Per-corner attributes (light fields with shading normals, vertex colours or a texture read
//!   with `TEXCOORD_1`; [`super::attributes`]): a storage buffer of two `vec4` per triangle
//!   corner, `[n.xyz, t.x]`, `[c.rgb, t.y]` (shading normal, zero on flat triangles; vertex
//!   colour, white without; `TEXCOORD_1`), six per triangle in the light field's triangle order;
//!   the uploaded triangles name their index there in their first padding word. Read by
//!   vertex shaders and, along mirror chains, by pass 5. Face flags say which faces need them.
//! * Textures: records (`Rgba32Uint`, one texel per texture: first texel, width, height,
//!   wrap_s | wrap_t << 4, the wrap ids of the file) and texels ([`ATLAS_WIDTH`] wide,
//!   `Rgba16Float`: `Shading::texels`, all textures one after another, uploaded like the f16
//!   atlas); 1-texel dummies without textures.
//! * Mirror tiles (scenes with mirror/mixed faces; 1-texel dummies otherwise):
//!   - tile words (`Rgba32Uint`, [`ATLAS_WIDTH`] wide, one u32 per *channel*, i.e. word `k` is
//!     channel `k % 4` of texel `k / 4`): a header `[l, m, n, face_slot_off, index_start_off,
//!     tile_ids_off, coverage_off, words_per_slot]`, then the packed arrays of
//!     `vlf_core::lightfield::TileIndex` at those offsets;
//!   - tile values ([`ATLAS_WIDTH`] wide, in the atlas's texture format): `MirrorTiles::radiance`
//!     (1-texel dummy without tiles);
//!   - frames (`Rgba32Float`, 2 texels per fixed direction: u, v of its twisted PSF frame).

use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{
    BakeFace, BakeTriangle, LightField, NO_TEXTURE, Radiance, RadianceEncoding, SurfaceMaterial,
    TileIndex,
};
use wgpu::util::DeviceExt;

use super::RenderError;
use super::attributes::{ATTRIBUTE_ENTRIES, attribute_flags, corner_attributes, has_attributes};
use super::targets::{MIRROR_STENCIL, TEXTURED_STENCIL};
use super::texture_entry;

/// Width of the atlas texture (elements per row).
pub const ATLAS_WIDTH: u32 = 4096;
/// Texels per face record.
pub const FACE_RECORD_TEXELS: u32 = 8;
/// Face records per row of the face texture.
pub const FACES_PER_ROW: u32 = 1024;
/// Face flags, in the face record's texel 0 w above the kind (which takes the low 8 bits):
/// the face has a diffuse part (ρ_d ≠ 0), a base-colour texture, emission, an emissive
/// texture.
pub const FLAG_DIFFUSE: u32 = 0x100;
pub const FLAG_BASE_TEXTURE: u32 = 0x200;
pub const FLAG_EMISSIVE: u32 = 0x400;
pub const FLAG_EMISSIVE_TEXTURE: u32 = 0x800;
/// The per-corner attribute flags of a face, above these (`super::attributes`).
pub use super::attributes::{FLAG_BASE_UV1, FLAG_COLORS, FLAG_EMISSIVE_UV1, FLAG_SMOOTH};
/// The face is a thin glass pane (its material's pane weight and IOR in texel 6).
pub const FLAG_PANE: u32 = 0x10000;

/// GPU copies of a [`LightField`].
pub struct GpuLightField {
    /// The triangles, grouped by [`stencil_value`] (see the module docs).
    pub triangles: wgpu::Buffer,
    pub triangle_count: u32,
    /// Index in [`triangles`](Self::triangles) of the first triangle of stencil value `s`, for
    /// `s` in 0..4, then `triangle_count`.
    pub stencil_starts: [u32; 5],
    pub face_count: u32,
    /// `TEXCOORD_0` per triangle corner (vec2, three per triangle, in the order of
    /// [`triangles`](Self::triangles)).
    pub uvs: wgpu::Buffer,
    /// The alpha masks of the light field's triangles in its own order
    /// (`LightField::alpha_masks`, `AlphaMasks::words`): passes 3, 4 and 5 discard the
    /// fragments where they leave no surface, each uploaded triangle naming its index in the
    /// light field in `BakeTriangle::_pad0`; pass 5's mirror BVH looks them up by `prim`.
    pub alpha_masks: wgpu::Buffer,
    /// Whether a triangle has a mask (else the passes' mask code is not compiled in).
    pub has_masks: bool,
    /// Per-corner attributes ([`corner_attributes`]; a dummy without), and whether there are.
    pub attributes: wgpu::Buffer,
    pub has_attributes: bool,
    /// Face records (see the module docs).
    pub faces_view: wgpu::TextureView,
    /// The irradiance atlas (see the module docs).
    pub atlas_view: wgpu::TextureView,
    /// Texture records and texels (see the module docs).
    pub texture_records_view: wgpu::TextureView,
    pub texels_view: wgpu::TextureView,
    /// Mirror tile index words, values and direction frames (see the module docs).
    pub tile_words_view: wgpu::TextureView,
    pub tile_values_view: wgpu::TextureView,
    pub frames_view: wgpu::TextureView,
    /// Unit sphere-vertex positions (vec4, w unused), indexed by sphere-vertex id.
    pub sphere_vertices: wgpu::Buffer,
    /// Sphere triangles (vec4<u32>: three sphere-vertex ids, w unused).
    pub sphere_triangles: wgpu::Buffer,
    pub sphere_triangle_count: u32,
    /// Bytes of all buffers and textures above.
    pub bytes: u64,
    /// Bytes of the light textures (atlas irradiance and tile values).
    pub radiance_bytes: u64,
    /// Bytes of the surface textures (texels and records).
    pub texture_bytes: u64,
}

/// The layout of the mirror tiles' bind group (`shaders/common/mirror_tiles.wgsl`: group 2,
/// bindings 3–5), visible to `visibility`.
pub fn tiles_layout(
    device: &wgpu::Device,
    label: &str,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayout {
    let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[
            texture_entry(3, visibility, wgpu::TextureSampleType::Uint),
            texture_entry(4, visibility, unfiltered),
            texture_entry(5, visibility, unfiltered),
        ],
    })
}

/// Words before the tile index's arrays in [`tile_words`].
pub const TILE_HEADER_WORDS: u32 = 8;

/// The tile index words of the mirror-tile textures (see the module docs): the header, then
/// the packed arrays of `ix`, padded to whole texels.
pub fn tile_words(ix: &TileIndex) -> Vec<u32> {
    let mut w = vec![0u32; TILE_HEADER_WORDS as usize];
    let push = |part: &[u32], w: &mut Vec<u32>| {
        let off = w.len() as u32;
        w.extend_from_slice(part);
        off
    };
    let o0 = push(&ix.face_slot, &mut w);
    let o1 = push(&ix.index_start, &mut w);
    let o2 = push(&ix.tile_ids, &mut w);
    let o3 = push(&ix.coverage, &mut w);
    w[..TILE_HEADER_WORDS as usize].copy_from_slice(&[
        ix.directions,
        ix.m,
        ix.n,
        o0,
        o1,
        o2,
        o3,
        vlf_core::lightfield::tiles::words_per_slot(ix.m) as u32,
    ]);
    w.resize(w.len().next_multiple_of(4), 0);
    w
}

/// The frame texels of the mirror-tile textures: u, v of each fixed direction's PSF frame.
pub fn tile_frames(set: &DirectionSet) -> Vec<[f32; 4]> {
    vlf_core::psf::fixed_frames(set)
        .iter()
        .flat_map(|f| [f.u.extend(0.0).to_array(), f.v.extend(0.0).to_array()])
        .collect()
}

/// Mirror tiles with f32 values (a converged light field before it is stored, as the GPU final
/// gather reads it) as the three textures of `shaders/common/mirror_tiles.wgsl`: index words,
/// values (`Rgba32Float`), frames; 1-texel dummies without tiles. Labels are
/// `"{prefix}::tile_words"` etc.; adds their bytes to `bytes`.
pub fn float_tile_textures(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    prefix: &str,
    tiles: Option<(&TileIndex, &[[f32; 4]])>,
    set: &DirectionSet,
    bytes: &mut u64,
) -> Result<[wgpu::TextureView; 3], RenderError> {
    let (words, values, frames) = match tiles {
        Some((ix, values)) => (tile_words(ix), values.to_vec(), tile_frames(set)),
        None => (vec![0u32; 4], Vec::new(), Vec::new()),
    };
    let mut tex = |what: &str, format, data: &[u8]| {
        wrapped_texture(
            device,
            queue,
            &format!("{prefix}::{what}"),
            format,
            ATLAS_WIDTH,
            data,
            bytes,
        )
    };
    Ok([
        tex(
            "tile_words",
            wgpu::TextureFormat::Rgba32Uint,
            bytemuck::cast_slice(&words),
        )?,
        tex(
            "tile_values",
            wgpu::TextureFormat::Rgba32Float,
            bytemuck::cast_slice(&values),
        )?,
        tex(
            "tile_frames",
            wgpu::TextureFormat::Rgba32Float,
            bytemuck::cast_slice(&frames),
        )?,
    ])
}

/// The texture format the radiance of `encoding` is uploaded as (see the module docs).
pub fn radiance_format(encoding: RadianceEncoding) -> wgpu::TextureFormat {
    match encoding {
        RadianceEncoding::Rgb9e5 => wgpu::TextureFormat::Rgb9e5Ufloat,
        RadianceEncoding::RgbF16 => wgpu::TextureFormat::Rgba16Float,
    }
}

/// ρ_d / π of material `m` (the diffuse albedo factor over π), as the face record stores it.
pub fn rho_over_pi(m: &SurfaceMaterial) -> glam::Vec3 {
    m.diffuse_albedo() * std::f32::consts::FRAC_1_PI
}

/// The face flags of material `m` ([`FLAG_DIFFUSE`] and the others).
pub fn face_flags(m: &SurfaceMaterial) -> u32 {
    let rho = rho_over_pi(m);
    let emissive = m.emission.iter().any(|&e| e > 0.0);
    let mut flags = 0;
    if rho.max_element() > 0.0 {
        flags |= FLAG_DIFFUSE;
    }
    // The base-colour texture colours the diffuse part and the metal lobe alike.
    if m.base_color_texture != NO_TEXTURE {
        flags |= FLAG_BASE_TEXTURE;
    }
    if emissive {
        flags |= FLAG_EMISSIVE;
        if m.emissive_texture != NO_TEXTURE {
            flags |= FLAG_EMISSIVE_TEXTURE;
        }
    }
    if m.pane > 0.0 {
        flags |= FLAG_PANE;
    }
    flags
}

/// Mirror reflectance factor of face `f` with material `m`: specular weight × base colour (0
/// for diffuse faces); pass 5 multiplies it by the base-colour texture at the pixel
/// ([`super::mirror_trace::specular_reflectance`]).
pub fn specular_reflectance(f: &BakeFace, m: &SurfaceMaterial) -> glam::Vec3 {
    glam::Vec3::from(m.base_color) * f.specular
}

/// The stencil value pass 3 writes for face `f` of material `m`: [`TEXTURED_STENCIL`] if pass
/// 5 reads a texture for it, | [`MIRROR_STENCIL`] if it has a specular part.
pub fn stencil_value(f: &BakeFace, m: &SurfaceMaterial) -> u32 {
    let mut s = 0;
    if is_textured(m) {
        s |= TEXTURED_STENCIL;
    }
    if f.kind != vlf_core::lightfield::FACE_DIFFUSE {
        s |= MIRROR_STENCIL;
    }
    s
}

/// Whether pass 5 reads a texture for faces of material `m`.
pub fn is_textured(m: &SurfaceMaterial) -> bool {
    face_flags(m) & (FLAG_BASE_TEXTURE | FLAG_EMISSIVE_TEXTURE) != 0
}

/// The face record texels of `f` with its material `m` and attribute flags `attrs` (see the
/// module docs and [`super::attributes::attribute_flags`]).
pub fn face_record(
    f: &BakeFace,
    m: &SurfaceMaterial,
    attrs: u32,
) -> [[u32; 4]; FACE_RECORD_TEXELS as usize] {
    let b = |v: [f32; 3], w: u32| [v[0].to_bits(), v[1].to_bits(), v[2].to_bits(), w];
    let rho = rho_over_pi(m);
    [
        b(f.normal, f.kind | face_flags(m) | attrs),
        b(f.origin, f.texel_size.to_bits()),
        b(f.u, f.width),
        b(f.v, f.height),
        b(rho.into(), f.texel_base),
        b(m.emission, 0),
        [
            m.base_color_texture,
            m.emissive_texture,
            m.ior.to_bits(),
            m.pane.to_bits(),
        ],
        b(
            specular_reflectance(f, m).into(),
            m.specular_alpha.to_bits(),
        ),
    ]
}

impl GpuLightField {
    /// The mirror tiles' bind group (index words, values, frames) for `layout` (made by
    /// [`tiles_layout`]).
    pub fn tiles_bind_group(
        &self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        label: &str,
    ) -> wgpu::BindGroup {
        let tex = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[
                tex(3, &self.tile_words_view),
                tex(4, &self.tile_values_view),
                tex(5, &self.frames_view),
            ],
        })
    }

    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        lf: &LightField,
    ) -> Result<Self, RenderError> {
        validate(lf)?;
        let max = device.limits().max_storage_buffer_binding_size;
        let mut bytes = 0u64;
        let mut buffer = |label: &str, data: &[u8]| -> Result<wgpu::Buffer, RenderError> {
            let size = data.len() as u64;
            if size > max {
                return Err(RenderError::TooLarge {
                    what: label.to_owned(),
                    bytes: size,
                    limit: max,
                });
            }
            bytes += size;
            // wgpu cannot bind empty buffers: keep one zeroed element's worth.
            let zeros = [0u8; 48];
            let contents = if data.is_empty() { &zeros[..] } else { data };
            Ok(
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage: wgpu::BufferUsages::STORAGE,
                }),
            )
        };
        // Triangles grouped by stencil value (stable order).
        let sh = &lf.shading;
        let stencil = |t: &BakeTriangle| {
            let f = &lf.faces[t.face as usize];
            stencil_value(f, &sh.materials[f.material as usize])
        };
        let mut order: Vec<usize> = (0..lf.triangles.len()).collect();
        order.sort_by_key(|&i| stencil(&lf.triangles[i]));
        let stencil_starts = [0, 1, 2, 3, 4].map(|s| {
            order
                .iter()
                .position(|&i| stencil(&lf.triangles[i]) >= s)
                .unwrap_or(order.len()) as u32
        });
        // Each uploaded triangle names its index in the light field in its first padding word
        // (`_pad0`, written 0 in files, unused by the bake): its per-corner attributes and the
        // alpha masks are in that order.
        let tris: Vec<BakeTriangle> = order
            .iter()
            .map(|&i| BakeTriangle {
                _pad0: i as u32,
                ..lf.triangles[i]
            })
            .collect();
        let masks = lf.alpha_masks();
        let has_masks = !masks.is_empty();
        let alpha_masks = buffer(
            "Renderer::alpha_masks",
            bytemuck::cast_slice(&masks.words()),
        )?;
        let corner_uvs: Vec<[[f32; 2]; 3]> = order.iter().map(|&i| sh.uvs[i]).collect();
        let triangles = buffer(
            "Renderer::triangles",
            bytemuck::cast_slice::<BakeTriangle, u8>(&tris),
        )?;
        let verts: Vec<[f32; 4]> = lf
            .directions
            .sphere_vertices()
            .iter()
            .map(|p| p.extend(0.0).into())
            .collect();
        let tris: Vec<[u32; 4]> = lf
            .directions
            .sphere_triangles()
            .iter()
            .map(|t| [t[0], t[1], t[2], 0])
            .collect();
        let sphere_vertices = buffer("Renderer::sphere_vertices", bytemuck::cast_slice(&verts))?;
        let sphere_triangles = buffer("Renderer::sphere_triangles", bytemuck::cast_slice(&tris))?;
        let uvs = buffer("Renderer::uvs", bytemuck::cast_slice(&corner_uvs))?;
        let has_attributes = has_attributes(lf);
        let attrs = if has_attributes {
            corner_attributes(lf)
        } else {
            Vec::new()
        };
        let attributes = buffer("Renderer::attributes", bytemuck::cast_slice(&attrs))?;

        let flags = attribute_flags(lf);
        let records: Vec<[u32; 4]> = lf
            .faces
            .iter()
            .zip(&flags)
            .flat_map(|(f, fl)| face_record(f, &sh.materials[f.material as usize], *fl))
            .collect();
        let faces_view = wrapped_texture(
            device,
            queue,
            "Renderer::face_records",
            wgpu::TextureFormat::Rgba32Uint,
            FACE_RECORD_TEXELS * FACES_PER_ROW,
            bytemuck::cast_slice(&records),
            &mut bytes,
        )?;
        let mut radiance_bytes = 0;
        let atlas_view = radiance_texture(
            device,
            queue,
            "Renderer::irradiance_atlas",
            &lf.irradiance,
            &mut radiance_bytes,
        )?;
        let mut texture_bytes = 0;
        let texture_records: Vec<[u32; 4]> = sh
            .textures
            .iter()
            .zip(sh.texture_offsets())
            .map(|(t, first)| {
                let wrap = t.wrap_s.id() | t.wrap_t.id() << 4;
                // validate: every texel index fits a u32.
                [first as u32, t.width, t.height, wrap]
            })
            .collect();
        let texture_records_view = wrapped_texture(
            device,
            queue,
            "Renderer::texture_records",
            wgpu::TextureFormat::Rgba32Uint,
            ATLAS_WIDTH,
            bytemuck::cast_slice(&texture_records),
            &mut texture_bytes,
        )?;
        let texels_view = radiance_texture(
            device,
            queue,
            "Renderer::texels",
            &sh.texels,
            &mut texture_bytes,
        )?;
        bytes += texture_bytes;
        let no_tiles = Radiance::new(lf.irradiance.encoding());
        let (words, values, frames) = match &lf.tiles {
            Some(t) => {
                let (w, frames) = (tile_words(&t.index), tile_frames(&lf.directions));
                (w, &t.radiance, frames)
            }
            None => (vec![0u32; 4], &no_tiles, Vec::new()),
        };
        let tile_words_view = wrapped_texture(
            device,
            queue,
            "Renderer::tile_words",
            wgpu::TextureFormat::Rgba32Uint,
            ATLAS_WIDTH,
            bytemuck::cast_slice(&words),
            &mut bytes,
        )?;
        let tile_values_view = radiance_texture(
            device,
            queue,
            "Renderer::tile_values",
            values,
            &mut radiance_bytes,
        )?;
        bytes += radiance_bytes;
        let frames_view = wrapped_texture(
            device,
            queue,
            "Renderer::frames",
            wgpu::TextureFormat::Rgba32Float,
            ATLAS_WIDTH,
            bytemuck::cast_slice(&frames),
            &mut bytes,
        )?;
        Ok(Self {
            tile_words_view,
            tile_values_view,
            frames_view,
            triangles,
            triangle_count: lf.triangles.len() as u32,
            stencil_starts,
            face_count: lf.faces.len() as u32,
            uvs,
            alpha_masks,
            has_masks,
            attributes,
            has_attributes,
            faces_view,
            atlas_view,
            texture_records_view,
            texels_view,
            sphere_vertices,
            sphere_triangles,
            sphere_triangle_count: tris.len() as u32,
            bytes,
            radiance_bytes,
            texture_bytes,
        })
    }
}

/// `radiance` as an [`ATLAS_WIDTH`]-wide texture in [`radiance_format`] (see the module docs):
/// value `i` at texel `(i % ATLAS_WIDTH, i / ATLAS_WIDTH)`, at least one texel. Adds its bytes
/// to `bytes`.
pub fn radiance_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    radiance: &Radiance,
    bytes: &mut u64,
) -> Result<wgpu::TextureView, RenderError> {
    let format = radiance_format(radiance.encoding());
    match radiance.encoding() {
        // The stored words are the texture's texels.
        RadianceEncoding::Rgb9e5 => wrapped_texture(
            device,
            queue,
            label,
            format,
            ATLAS_WIDTH,
            radiance.as_bytes(),
            bytes,
        ),
        // The halves next to a zero alpha, copied band by band into the upload buffer.
        RadianceEncoding::RgbF16 => banded_texture(
            device,
            queue,
            label,
            format,
            ATLAS_WIDTH,
            radiance.len(),
            bytes,
            |first, out| radiance.rgba16f_into(first, bytemuck::cast_slice_mut(out)),
        ),
    }
}

/// A 2D texture of `format` holding `data` (whole texels in the texture's byte layout)
/// wrapped into rows of `width` texels (narrower when there are fewer; at least one texel,
/// the rest of the last row zero); adds its bytes to `bytes`.
fn wrapped_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    format: wgpu::TextureFormat,
    width: u32,
    data: &[u8],
    bytes: &mut u64,
) -> Result<wgpu::TextureView, RenderError> {
    let texel = texel_bytes(format);
    debug_assert_eq!(data.len() % texel, 0);
    banded_texture(
        device,
        queue,
        label,
        format,
        width,
        data.len() / texel,
        bytes,
        |first, out| out.copy_from_slice(&data[first * texel..first * texel + out.len()]),
    )
}

fn texel_bytes(format: wgpu::TextureFormat) -> usize {
    format
        .block_copy_size(None)
        .expect("an uncompressed colour format") as usize
}

/// Bytes of texels uploaded per band (and submitted before the next band is filled, so that
/// an upload never holds more than this in extra host memory, however large the texture).
const UPLOAD_BAND_BYTES: usize = 8 << 20;

/// Width and rows of a texture of `count` texels wrapped into rows of `width` (narrower when
/// there are fewer; at least one texel).
pub fn wrapped_extent(count: u64, width: u32) -> (u32, u64) {
    let n = count.max(1);
    let width = n.min(u64::from(width)) as u32;
    (width, n.div_ceil(u64::from(width)))
}

/// A 2D texture of `format` holding `count` texels wrapped into rows of `width` (narrower
/// when there are fewer; at least one texel, the rest of the last row zero), filled in bands
/// of rows: `fill(first, out)` writes texels `first..` into `out` (whole texels, 8-byte
/// aligned so that it casts to any texel type). Adds the texture's bytes to `bytes`.
#[allow(clippy::too_many_arguments)]
fn banded_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    format: wgpu::TextureFormat,
    width: u32,
    count: usize,
    bytes: &mut u64,
    fill: impl Fn(usize, &mut [u8]),
) -> Result<wgpu::TextureView, RenderError> {
    let texel = texel_bytes(format);
    let n = count.max(1) as u64;
    let (width, rows) = wrapped_extent(count as u64, width);
    let max = device.limits().max_texture_dimension_2d;
    if rows > u64::from(max) {
        return Err(RenderError::TooLarge {
            what: label.to_owned(),
            bytes: n * texel as u64,
            limit: u64::from(width) * u64::from(max) * texel as u64,
        });
    }
    let rows = rows as usize;
    let row_bytes = width as usize * texel;
    *bytes += (rows * row_bytes) as u64;
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let texture = crate::wgpu_util::texture_2d(device, label, (width, rows as u32), format, usage);
    let band_rows = (UPLOAD_BAND_BYTES / row_bytes).clamp(1, rows);
    // u64s: an 8-byte aligned buffer, reused for every band.
    let mut band = vec![0u64; (band_rows * row_bytes).div_ceil(8)];
    let band = &mut bytemuck::cast_slice_mut::<u64, u8>(&mut band)[..band_rows * row_bytes];
    for first_row in (0..rows).step_by(band_rows) {
        let band_rows = band_rows.min(rows - first_row);
        let first = first_row * width as usize;
        let filled = count.saturating_sub(first).min(band_rows * width as usize) * texel;
        let b = &mut band[..band_rows * row_bytes];
        fill(first, &mut b[..filled]);
        // The rest of the last row.
        b[filled..].fill(0);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: first_row as u32,
                    z: 0,
                },
                aspect: wgpu::TextureAspect::All,
            },
            b,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row_bytes as u32),
                rows_per_image: Some(band_rows as u32),
            },
            wgpu::Extent3d {
                width,
                height: band_rows as u32,
                depth_or_array_layers: 1,
            },
        );
        if band_rows < rows {
            // Hand this band's staging copy to the GPU before filling the next one.
            queue.submit(None);
        }
    }
    Ok(texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some(&format!("{label}_view")),
        ..Default::default()
    }))
}

/// Checks the index relations the shaders rely on.
fn validate(lf: &LightField) -> Result<(), RenderError> {
    let invalid = |msg: String| Err(RenderError::InvalidLightField(msg));
    if lf.faces.len() >= u32::MAX as usize / FACE_RECORD_TEXELS as usize
        || lf.triangles.len() > (u32::MAX / ATTRIBUTE_ENTRIES as u32) as usize
        || lf.irradiance.len() > u32::MAX as usize
        || lf.shading.texels.len() > u32::MAX as usize
    {
        return invalid(format!(
            "{} faces / {} triangles / {} atlas texels / {} texture texels is more than the \
             renderer can index",
            lf.faces.len(),
            lf.triangles.len(),
            lf.irradiance.len(),
            lf.shading.texels.len()
        ));
    }
    // Materials, uvs and textures fit together (a LightField built in memory may not).
    if let Err(e) = lf.shading.check(lf.triangles.len()) {
        return invalid(e.to_string());
    }
    for (i, t) in lf.triangles.iter().enumerate() {
        if t.face as usize >= lf.faces.len() {
            return invalid(format!(
                "triangle {i} names face {} but there are {} faces",
                t.face,
                lf.faces.len()
            ));
        }
        if ![t.p0, t.p1, t.p2].iter().flatten().all(|x| x.is_finite()) {
            return invalid(format!("triangle {i} has a non-finite vertex"));
        }
    }
    for (i, f) in lf.faces.iter().enumerate() {
        let end = u64::from(f.texel_base) + 2 * u64::from(f.width) * u64::from(f.height);
        if f.width == 0 || f.height == 0 {
            return invalid(format!(
                "face {i} has an empty chart ({}×{})",
                f.width, f.height
            ));
        }
        if end > lf.irradiance.len() as u64 {
            return invalid(format!(
                "face {i} needs atlas texels up to {end} but the atlas has {}",
                lf.irradiance.len()
            ));
        }
        if f.material as usize >= lf.shading.materials.len() {
            return invalid(format!(
                "face {i} names material {} but there are {}",
                f.material,
                lf.shading.materials.len()
            ));
        }
        if !(f.texel_size.is_finite() && f.texel_size > 0.0) {
            return invalid(format!("face {i} has texel size {}", f.texel_size));
        }
    }
    if let Some(t) = &lf.tiles {
        // The format validates the index on read; a LightField built in memory may not be.
        let ix = &t.index;
        if ix.face_slot.len() != lf.faces.len()
            || t.radiance.len() != ix.value_len()
            || ix.directions as usize != lf.directions.len()
            || ix.index_start.len() != ix.faces.len() * ix.directions as usize + 1
            || ix.index_start.last().map(|&x| x as usize) != Some(ix.tile_ids.len())
            || ix.m == 0
            || !ix.n.is_multiple_of(ix.m)
        {
            return invalid("the mirror tile index does not match the light field".into());
        }
    }
    Ok(())
}
