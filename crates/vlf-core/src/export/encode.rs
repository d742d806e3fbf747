//! Image encodings of the exported textures, in memory: OpenEXR (linear half float), PNG
//! (8-bit, for re-encoded base-colour and emissive textures) and RGBM in a PNG.

use std::io::Cursor;

/// OpenEXR bytes of an RGB image (row 0 = top): linear half-float R, G, B channels, ZIP
/// compression in blocks of 16 scan lines, increasing line order (what three.js's EXRLoader
/// and Godot read). Values above the half-float maximum (65504) are clamped to it.
pub fn exr_rgb_half(width: u32, height: u32, pixels: &[[f32; 3]]) -> Result<Vec<u8>, String> {
    use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage, f16};
    let w = width as usize;
    let half = |v: f32| f16::from_f32(v.clamp(0.0, 65504.0));
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * w + x];
        (half(p[0]), half(p[1]), half(p[2]))
    });
    let image = exr::image::Image::from_encoded_channels(
        (w, height as usize),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut bytes = Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes.into_inner())
}

/// PNG bytes of 8-bit RGBA data (row 0 = top).
pub fn png_rgba8(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(rgba).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(bytes)
}

/// The RGBM range for `pixels`: the smallest power of two ≥ the largest component (at least 1).
pub fn rgbm_range(pixels: &[[f32; 3]]) -> f32 {
    let max = pixels
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f32, |m, v| m.max(*v));
    if max <= 1.0 {
        1.0
    } else {
        max.log2().ceil().exp2()
    }
}

/// RGBM bytes (RGBA8, linear, no sRGB curve) of `pixels` with `range`: a texel decodes as
/// `rgb/255 · a/255 · range`. `m` is the smallest 8-bit multiplier ≥ max(rgb)/range, so the
/// brightest channel keeps 8 bits; the others lose precision in proportion to how weak they are.
pub fn rgbm(pixels: &[[f32; 3]], range: f32) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 * pixels.len());
    for p in pixels {
        let p = p.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
        let max = p[0].max(p[1]).max(p[2]).min(range);
        let m = ((max / range * 255.0).ceil()).clamp(1.0, 255.0);
        let scale = 255.0 / (m / 255.0 * range);
        for c in p {
            out.push((c * scale).round().clamp(0.0, 255.0) as u8);
        }
        out.push(m as u8);
    }
    out
}

/// Decodes one RGBM texel (the inverse of [`rgbm`] up to rounding).
pub fn rgbm_decode(texel: [u8; 4], range: f32) -> [f32; 3] {
    let m = f32::from(texel[3]) / 255.0 * range;
    [0, 1, 2].map(|c| f32::from(texel[c]) / 255.0 * m)
}
