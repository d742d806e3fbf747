//! The per-pixel outputs of the five passes, sized to the view, and texture readback.

use super::RenderError;
use crate::wgpu_util::texture_2d;

/// Pass 1 output: three sphere-vertex ids + triangle index.
pub const DIRECTION_IDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
/// Pass 2 output: three barycentric weights (w unused).
pub const BARYCENTRICS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Pass 3 output: face index, `NO_FACE` for background.
pub const FACE_ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// Pass 4 output: VLF position (xyz), w = 1 where a face is seen.
pub const POSITION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Pass 4's second output: `TEXCOORD_0` of the visible point (undefined where no face is seen).
pub const UV_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// Pass 4b's attribute outputs (light fields with per-corner attributes only, see
/// [`super::position::attributes_pass`]): `[shading normal xyz, TEXCOORD_1 u]` of the visible
/// point, and its other attributes packed into words ([`ATTRIBUTE_WORDS_FORMAT`]: `TEXCOORD_1`
/// v, then vertex colour and irradiance correction as f16 pairs, `shaders/common/
/// surface_attributes.wgsl`).
pub const ATTRIBUTES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const ATTRIBUTE_WORDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
/// Pass 5 output: radiance of the current sample (rgb), a = 1 where a face is seen.
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Depth of passes 3–4 (reverse-Z: cleared to 0, greater is nearer).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// [`DEPTH_FORMAT`] with a stencil, used for light fields with textures or mirrors when the
/// device has `DEPTH32FLOAT_STENCIL8`: pass 3 writes [`TEXTURED_STENCIL`] where a textured face
/// is seen and [`MIRROR_STENCIL`] where a mirror or mixed face is, and pass 5 shades those
/// pixels, and only those, with its texture code and its mirror code (tiles or tracing) (see
/// [`super::final_radiance`]).
pub const DEPTH_STENCIL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32FloatStencil8;
/// Stencil bit of pixels showing a textured face (0 elsewhere).
pub const TEXTURED_STENCIL: u32 = 1;
/// Stencil bit of pixels showing a mirror or mixed face (0 elsewhere).
pub const MIRROR_STENCIL: u32 = 2;

/// Textures and buffers holding one frame's pass outputs.
pub struct Targets {
    pub width: u32,
    pub height: u32,
    pub direction_ids: wgpu::Texture,
    pub direction_ids_view: wgpu::TextureView,
    pub barycentrics: wgpu::Texture,
    pub barycentrics_view: wgpu::TextureView,
    pub face_id: wgpu::Texture,
    pub face_id_view: wgpu::TextureView,
    pub position: wgpu::Texture,
    pub position_view: wgpu::TextureView,
    pub uv: wgpu::Texture,
    pub uv_view: wgpu::TextureView,
    /// Pass 4b's attribute targets ([`ATTRIBUTES_FORMAT`], [`ATTRIBUTE_WORDS_FORMAT`]; one texel
    /// where the light field has
    /// no per-corner attributes).
    pub attributes: [wgpu::Texture; 2],
    pub attributes_view: [wgpu::TextureView; 2],
    pub depth_view: wgpu::TextureView,
    /// Pass 5 output: radiance of the current sample.
    pub radiance: wgpu::Texture,
    pub radiance_view: wgpu::TextureView,
    /// Mean radiance over a still's samples (vec4 per pixel: rgb, a = coverage), row 0 at the
    /// top; written only when a still has more than one sample.
    pub accum: wgpu::Buffer,
}

impl Targets {
    /// Targets of `width × height` with a depth buffer of `depth_format` ([`DEPTH_FORMAT`] or
    /// [`DEPTH_STENCIL_FORMAT`]), and attribute targets of that size when `attributes`.
    pub fn new(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        depth_format: wgpu::TextureFormat,
        attributes: bool,
    ) -> Result<Self, RenderError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size { width, height, max });
        }
        let radiance_bytes = u64::from(width) * u64::from(height) * 16;
        let max_binding = device.limits().max_storage_buffer_binding_size;
        if radiance_bytes > max_binding {
            return Err(RenderError::TooLarge {
                what: "FinalRadiance::accumulation".into(),
                bytes: radiance_bytes,
                limit: max_binding,
            });
        }
        let sized = |label: &str, format, size: (u32, u32)| {
            let written = wgpu::TextureUsages::RENDER_ATTACHMENT;
            let usage =
                written | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
            let t = texture_2d(device, label, size, format, usage);
            let v = t.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{label}_view")),
                ..Default::default()
            });
            (t, v)
        };
        let texture = |label: &str, format| sized(label, format, (width, height));
        let attr_size = if attributes { (width, height) } else { (1, 1) };
        let (a0, a0_view) = sized("Position::attributes_target", ATTRIBUTES_FORMAT, attr_size);
        let (a1, a1_view) = sized(
            "Position::attribute_words_target",
            ATTRIBUTE_WORDS_FORMAT,
            attr_size,
        );
        let (direction_ids, direction_ids_view) =
            texture("DirectionIds::target", DIRECTION_IDS_FORMAT);
        let (barycentrics, barycentrics_view) =
            texture("Barycentrics::target", BARYCENTRICS_FORMAT);
        let (face_id, face_id_view) = texture("FaceId::target", FACE_ID_FORMAT);
        let (position, position_view) = texture("Position::target", POSITION_FORMAT);
        let (uv, uv_view) = texture("Position::uv_target", UV_FORMAT);
        let (_, depth_view) = texture("FaceId::depth", depth_format);
        let (radiance, radiance_view) = texture("FinalRadiance::target", RADIANCE_FORMAT);
        let accum = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("FinalRadiance::accumulation"),
            size: radiance_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Ok(Self {
            width,
            height,
            direction_ids,
            direction_ids_view,
            barycentrics,
            barycentrics_view,
            face_id,
            face_id_view,
            position,
            position_view,
            uv,
            uv_view,
            attributes: [a0, a1],
            attributes_view: [a0_view, a1_view],
            depth_view,
            radiance,
            radiance_view,
            accum,
        })
    }
}

/// A `width × height` texture of `format` to render into and read back with [`read_texture`]
/// (render attachment, copy source).
pub fn readback_target(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    texture_2d(device, label, (width, height), format, usage)
}

/// Reads a whole 2D texture of `texel_bytes`-byte texels back as `T`s, row 0 first, blocking.
pub fn read_texture<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    texel_bytes: u32,
) -> Result<Vec<T>, RenderError> {
    let (w, h) = (texture.width(), texture.height());
    let row = w * texel_bytes;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("Readback::texture_copy"),
        size: u64::from(padded) * u64::from(h),
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("Readback::texture_encoder"),
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit(Some(encoder.finish()));
    // Texels are whole 32-bit words: read as u32 so the rows are aligned for any 4-byte T.
    let words: Vec<u32> = crate::readback::read_buffer(device, queue, &buffer)?;
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h as usize {
        let start = y * (padded / 4) as usize;
        let row_words = &words[start..start + (row / 4) as usize];
        out.extend_from_slice(bytemuck::cast_slice::<u32, T>(row_words));
    }
    Ok(out)
}
