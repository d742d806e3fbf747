//! Decoded textures.

use glam::{Vec2, Vec4};
use serde::{Deserialize, Serialize};

/// Texture coordinate wrapping (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum WrapMode {
    /// `REPEAT` (the glTF default).
    Repeat,
    /// `CLAMP_TO_EDGE`.
    ClampToEdge,
    /// `MIRRORED_REPEAT`.
    MirroredRepeat,
}

impl WrapMode {
    /// Every mode, in [`id`](Self::id) order.
    pub const ALL: [WrapMode; 3] = [
        WrapMode::Repeat,
        WrapMode::ClampToEdge,
        WrapMode::MirroredRepeat,
    ];

    /// The mode's id in `.vlf` files and on the GPU (`shaders/common/texture.wgsl`): 0 repeat,
    /// 1 clamp to edge, 2 mirrored repeat.
    pub fn id(self) -> u32 {
        match self {
            WrapMode::Repeat => 0,
            WrapMode::ClampToEdge => 1,
            WrapMode::MirroredRepeat => 2,
        }
    }

    /// The mode with [`id`](Self::id) `id`, if any.
    pub fn from_id(id: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.id() == id)
    }

    /// Maps an integer texel coordinate into `0..size`.
    pub fn wrap(self, i: i64, size: u32) -> u32 {
        let n = i64::from(size.max(1));
        let r = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::ClampToEdge => i.clamp(0, n - 1),
            WrapMode::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        r as u32
    }
}

/// Magnification filter (glTF sampler `magFilter`; linear when unspecified).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FilterMode {
    /// Bilinear.
    Linear,
    /// Nearest texel.
    Nearest,
}

/// A texture decoded to linear RGBA `f32` (base-colour and emissive textures are
/// sRGB-decoded; alpha stays linear; images without alpha get alpha 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    /// Texture or image name.
    pub name: Option<String>,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major texels, row 0 = top of the image (glTF UV (0,0) is the top-left corner).
    pub pixels: Vec<Vec4>,
    /// Whether the source image has an alpha channel.
    pub has_alpha: bool,
    /// Horizontal wrap mode.
    pub wrap_s: WrapMode,
    /// Vertical wrap mode.
    pub wrap_t: WrapMode,
    /// Magnification filter.
    pub filter: FilterMode,
    /// glTF texture index this was decoded from.
    pub gltf_texture: u32,
}

impl Texture {
    /// Texel at integer coordinates, wrapped with the sampler's modes.
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        if self.pixels.is_empty() {
            return Vec4::ONE;
        }
        let xi = self.wrap_s.wrap(x, self.width) as usize;
        let yi = self.wrap_t.wrap(y, self.height) as usize;
        self.pixels
            .get(yi * self.width as usize + xi)
            .copied()
            .unwrap_or(Vec4::ONE)
    }

    /// Samples at glTF UV coordinates with the texture's filter and wrap modes.
    /// Non-finite coordinates read texel (0, 0).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let x = f64::from(uv.x) * f64::from(self.width);
        let y = f64::from(uv.y) * f64::from(self.height);
        match self.filter {
            FilterMode::Nearest => self.texel(x.floor() as i64, y.floor() as i64),
            FilterMode::Linear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let top = self
                    .texel(x0, y0)
                    .lerp(self.texel(x0.saturating_add(1), y0), fx);
                let bottom = self
                    .texel(x0, y0.saturating_add(1))
                    .lerp(self.texel(x0.saturating_add(1), y0.saturating_add(1)), fx);
                top.lerp(bottom, fy)
            }
        }
    }

    /// Bilinear sample with the texture's wrap modes, whatever its filter mode, in f32 (glTF
    /// uv: v down the image): what the bake and the path tracer read. An empty texture or a
    /// non-finite uv reads 1.
    pub fn bilinear(&self, uv: Vec2) -> Vec4 {
        if self.width == 0 || self.height == 0 || self.pixels.is_empty() || !uv.is_finite() {
            return Vec4::ONE;
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |i: i64, j: i64| {
            let i = self.wrap_s.wrap(i, self.width);
            let j = self.wrap_t.wrap(j, self.height);
            self.pixels[(j as usize) * self.width as usize + i as usize]
        };
        let (i, j) = (x0 as i64, y0 as i64);
        let top = texel(i, j).lerp(texel(i + 1, j), fx);
        let bottom = texel(i, j + 1).lerp(texel(i + 1, j + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Mean texel value (e.g. for an average albedo or emission).
    pub fn mean(&self) -> Vec4 {
        if self.pixels.is_empty() {
            return Vec4::ONE;
        }
        let sum: glam::DVec4 = self.pixels.iter().map(|p| p.as_dvec4()).sum();
        (sum / self.pixels.len() as f64).as_vec4()
    }
}

/// sRGB transfer function → linear.
pub(crate) fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Converts decoded image data to linear RGBA, sRGB-decoding the colour channels.
/// Returns the texels and whether the image has alpha.
pub(crate) fn to_linear_rgba(data: &gltf::image::Data) -> Result<(Vec<Vec4>, bool), String> {
    use gltf::image::Format;
    let lut8: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
    let (channels, bytes_per_channel) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let texel_bytes = channels * bytes_per_channel;
    let n = (data.width as usize)
        .checked_mul(data.height as usize)
        .ok_or("image too large")?;
    if data.pixels.len() < n.saturating_mul(texel_bytes) {
        return Err("decoded image is shorter than its size".to_string());
    }
    let read = |texel: &[u8], c: usize| -> (f32, bool) {
        // Returns the value and whether it is already linear (floats).
        let o = c * bytes_per_channel;
        match bytes_per_channel {
            1 => (texel[o] as f32, false),
            2 => (u16::from_le_bytes([texel[o], texel[o + 1]]) as f32, false),
            _ => (
                f32::from_le_bytes([texel[o], texel[o + 1], texel[o + 2], texel[o + 3]]),
                true,
            ),
        }
    };
    let colour = |texel: &[u8], c: usize| -> f32 {
        let (v, linear) = read(texel, c);
        if linear {
            v
        } else if bytes_per_channel == 1 {
            lut8[v as usize]
        } else {
            srgb_to_linear(v / 65535.0)
        }
    };
    let alpha = |texel: &[u8], c: usize| -> f32 {
        let (v, linear) = read(texel, c);
        if linear {
            v
        } else if bytes_per_channel == 1 {
            v / 255.0
        } else {
            v / 65535.0
        }
    };
    let pixels = data
        .pixels
        .chunks_exact(texel_bytes)
        .take(n)
        .map(|t| match channels {
            1 => {
                let l = colour(t, 0);
                Vec4::new(l, l, l, 1.0)
            }
            2 => {
                let l = colour(t, 0);
                Vec4::new(l, l, l, alpha(t, 1))
            }
            3 => Vec4::new(colour(t, 0), colour(t, 1), colour(t, 2), 1.0),
            _ => Vec4::new(colour(t, 0), colour(t, 1), colour(t, 2), alpha(t, 3)),
        })
        .collect();
    Ok((pixels, channels == 2 || channels == 4))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes() {
        assert_eq!(WrapMode::Repeat.wrap(-1, 4), 3);
        assert_eq!(WrapMode::Repeat.wrap(9, 4), 1);
        assert_eq!(WrapMode::ClampToEdge.wrap(-5, 4), 0);
        assert_eq!(WrapMode::ClampToEdge.wrap(9, 4), 3);
        assert_eq!(WrapMode::MirroredRepeat.wrap(4, 4), 3);
        assert_eq!(WrapMode::MirroredRepeat.wrap(-1, 4), 0);
        assert_eq!(WrapMode::MirroredRepeat.wrap(i64::MIN, 4), 0);
    }

    #[test]
    fn srgb() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn sampling() {
        let t = Texture {
            name: None,
            width: 2,
            height: 1,
            pixels: vec![Vec4::ZERO, Vec4::ONE],
            has_alpha: false,
            wrap_s: WrapMode::ClampToEdge,
            wrap_t: WrapMode::ClampToEdge,
            filter: FilterMode::Linear,
            gltf_texture: 0,
        };
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)), Vec4::ZERO);
        assert_eq!(t.sample(Vec2::new(0.5, 0.5)), Vec4::splat(0.5));
        assert_eq!(t.sample(Vec2::new(f32::NAN, 0.5)), Vec4::ZERO);
        assert_eq!(t.mean(), Vec4::splat(0.5));
    }
}
