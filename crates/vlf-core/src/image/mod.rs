//! Linear images, EXR/PNG I/O and image comparison metrics (MSE, relMSE, FLIP).
//!
//! An [`Image`] holds linear Rec.709 RGB radiance, row 0 at the top, exactly the
//! convention of the path-traced references in `shared/reference/` (see its README).
//! Files are read with [`read_exr`] and written with [`write_exr`] (float32 R, G, B) or
//! [`write_png`] (8-bit sRGB preview). Every write goes to a temporary file in the target
//! directory first and is renamed into place, so a reader never sees half a file.
//!
//! Metrics: [`mse`], [`rel_mse`] and [`flip()`] (HDR-FLIP, see [`flip`](mod@flip) for the
//! LDR variant and the parameters). [`compare`] runs all three on two EXR files and
//! [`error_map_png`] writes a false-colour (magma) map of a per-pixel error.
//!
//! Errors are [`ImageError`]; every message ends with the path of the file concerned.

pub mod flip;

use std::fs::File;
use std::io::{BufWriter, Cursor};
use std::path::{Path, PathBuf};

use crate::atomic_file::{self, AtomicWriteError};
pub use flip::{FlipParams, FlipResult, flip, flip_hdr, flip_ldr, flip_ldr_srgb};

/// A linear Rec.709 RGB image: `pixels[y * width + x]`, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB radiance, row-major, top row first; `width * height` entries.
    pub pixels: Vec<[f32; 3]>,
}

/// A problem reading, writing or comparing images. Every message ends with a file path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The file cannot be read or written (missing, a directory, no permission, disk full…).
    #[error("cannot {action} image file ({cause}): {path}")]
    Io {
        /// "read" or "write".
        action: &'static str,
        /// Underlying I/O error (in the message, not chained: the message already names it).
        cause: std::io::Error,
        /// Image file.
        path: PathBuf,
    },

    /// The file is not a readable OpenEXR image (bad magic number, corrupt data,
    /// unsupported feature such as deep data).
    #[error("not a readable OpenEXR image ({reason}): {path}")]
    Exr {
        /// What the decoder reported.
        reason: String,
        /// Image file.
        path: PathBuf,
    },

    /// The first layer of the EXR file lacks some of the R, G, B channels.
    #[error(
        "EXR layer {layer} has no {missing} channel(s) (channels present: {present}); \
         expected R, G and B: {path}"
    )]
    MissingChannels {
        /// Layer name, or `0` for an unnamed first layer.
        layer: String,
        /// The missing channel names, comma separated.
        missing: String,
        /// The channel names the layer has, comma separated.
        present: String,
        /// Image file.
        path: PathBuf,
    },

    /// The EXR encoder failed.
    #[error("cannot encode OpenEXR image ({reason}): {path}")]
    ExrEncode {
        /// What the encoder reported.
        reason: String,
        /// Image file.
        path: PathBuf,
    },

    /// The file is not a readable 8-bit RGB or RGBA PNG image.
    #[error("not a readable 8-bit RGB(A) PNG image ({reason}): {path}")]
    Png {
        /// What the decoder reported.
        reason: String,
        /// Image file.
        path: PathBuf,
    },

    /// The PNG encoder failed.
    #[error("cannot encode PNG image ({reason}): {path}")]
    PngEncode {
        /// What the encoder reported.
        reason: String,
        /// Image file.
        path: PathBuf,
    },

    /// An image to be written is inconsistent (pixel count differs from width × height,
    /// empty or too large).
    #[error("invalid image: {reason}: {path}")]
    Invalid {
        /// What is wrong.
        reason: String,
        /// Image file.
        path: PathBuf,
    },

    /// Two images to be compared differ in size.
    #[error(
        "image sizes differ: test {test_width}×{test_height} ({test}) vs reference \
         {ref_width}×{ref_height}: {reference}"
    )]
    SizeMismatch {
        /// Test image width.
        test_width: u32,
        /// Test image height.
        test_height: u32,
        /// Test image file.
        test: PathBuf,
        /// Reference image width.
        ref_width: u32,
        /// Reference image height.
        ref_height: u32,
        /// Reference image file.
        reference: PathBuf,
    },

    /// An image to be compared contains NaN or infinite values.
    #[error(
        "image has {count} non-finite (NaN or infinite) channel value(s), the first at \
         pixel x={x}, y={y}: {path}"
    )]
    NonFinite {
        /// Number of non-finite channel values.
        count: usize,
        /// Column of the first one.
        x: u32,
        /// Row of the first one (0 = top).
        y: u32,
        /// Image file.
        path: PathBuf,
    },
}

/// Tone mapping applied by [`write_png`] after exposure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tonemap {
    /// Clamp to [0, 1].
    #[default]
    Clamp,
    /// Narkowicz's (2015) fit of the ACES filmic curve, with his 0.6 pre-exposure, the
    /// same curve HDR-FLIP uses (so a PNG at exposure `e` shows what FLIP sees at `e`).
    Aces,
}

impl Image {
    /// A `width × height` image filled with `value`.
    pub fn new(width: u32, height: u32, value: [f32; 3]) -> Self {
        Self {
            width,
            height,
            pixels: vec![value; width as usize * height as usize],
        }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [f32; 3]) -> Self {
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            pixels,
        }
    }

    /// Pixel `(x, y)` (row 0 at the top).
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the image"
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Mean RGB over all pixels (accumulated in f64); zero for an empty image.
    pub fn mean(&self) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                sum[c] += f64::from(p[c]);
            }
        }
        let n = self.pixels.len().max(1) as f64;
        sum.map(|s| s / n)
    }

    /// Box-filtered downscale by an integer `factor`: each output pixel is the mean of a
    /// `factor × factor` block. A remainder of fewer than `factor` rows or columns at the
    /// right/bottom edge is dropped.
    ///
    /// # Panics
    /// If `factor` is 0.
    pub fn resize_box(&self, factor: u32) -> Image {
        assert!(factor > 0, "resize_box factor must be at least 1");
        let (w, h) = (self.width / factor, self.height / factor);
        let inv = 1.0 / (f64::from(factor) * f64::from(factor));
        Image::from_fn(w, h, |x, y| {
            let mut sum = [0.0f64; 3];
            for dy in 0..factor {
                for dx in 0..factor {
                    let p = self.get(x * factor + dx, y * factor + dy);
                    for c in 0..3 {
                        sum[c] += f64::from(p[c]);
                    }
                }
            }
            sum.map(|s| (s * inv) as f32)
        })
    }

    /// Index and count of non-finite channel values: `(first pixel index, count)`.
    fn non_finite(&self) -> Option<(usize, usize)> {
        let mut first = None;
        let mut count = 0;
        for (i, p) in self.pixels.iter().enumerate() {
            let bad = p.iter().filter(|v| !v.is_finite()).count();
            if bad > 0 {
                first.get_or_insert(i);
                count += bad;
            }
        }
        first.map(|i| (i, count))
    }

    fn check_consistent(&self, path: &Path) -> Result<(), ImageError> {
        let expected = self.width as usize * self.height as usize;
        let reason = if self.width == 0 || self.height == 0 {
            format!("empty image ({}×{})", self.width, self.height)
        } else if self.pixels.len() != expected {
            format!(
                "{} pixels for a {}×{} image (expected {expected})",
                self.pixels.len(),
                self.width,
                self.height
            )
        } else {
            return Ok(());
        };
        Err(ImageError::Invalid {
            reason,
            path: path.to_path_buf(),
        })
    }
}

/// Reads the R, G, B channels (half, float or uint samples, converted to f32) of the first
/// layer of an OpenEXR file, at its largest resolution level.
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    use exr::prelude::{MetaData, ReadChannels, ReadLayers, read};

    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ImageError::Io {
        action: "read",
        cause: source,
        path: path.to_path_buf(),
    })?;
    let exr_err = |e: exr::error::Error| ImageError::Exr {
        reason: e.to_string(),
        path: path.to_path_buf(),
    };

    // Inspect the header first so that a missing channel gets a precise message.
    let meta = MetaData::read_from_buffered(Cursor::new(&bytes), false).map_err(exr_err)?;
    let Some(header) = meta.headers.first() else {
        return Err(ImageError::Exr {
            reason: "no layers".into(),
            path: path.to_path_buf(),
        });
    };
    let names: Vec<String> = header
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    let missing: Vec<&str> = ["R", "G", "B"]
        .into_iter()
        .filter(|n| !names.iter().any(|have| have == n))
        .collect();
    if !missing.is_empty() {
        let layer = header
            .own_attributes
            .layer_name
            .as_ref()
            .map_or_else(|| "0".to_string(), |n| format!("{:?}", n.to_string()));
        return Err(ImageError::MissingChannels {
            layer,
            missing: missing.join(", "),
            present: if names.is_empty() {
                "none".into()
            } else {
                names.join(", ")
            },
            path: path.to_path_buf(),
        });
    }
    if header.deep {
        return Err(ImageError::Exr {
            reason: "deep data is not supported".into(),
            path: path.to_path_buf(),
        });
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size, _| (size.width(), vec![[0.0f32; 3]; size.area()]),
            |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b): (f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(exr_err)?;

    let size = image.layer_data.size;
    let too_big = |reason: &str| ImageError::Exr {
        reason: reason.into(),
        path: path.to_path_buf(),
    };
    let width = u32::try_from(size.width()).map_err(|_| too_big("width too large"))?;
    let height = u32::try_from(size.height()).map_err(|_| too_big("height too large"))?;
    if width == 0 || height == 0 {
        return Err(too_big("empty data window"));
    }
    let (_, pixels) = image.layer_data.channel_data.pixels;
    log::debug!("read {width}×{height} EXR {}", path.display());
    Ok(Image {
        width,
        height,
        pixels,
    })
}

/// Writes `image` as an OpenEXR file with float32 R, G, B channels (lossless compression),
/// atomically (temporary file in the same directory, then rename). Chunks are stored in
/// increasing order, so the same image always gives the same bytes (with the crate's default,
/// "unspecified" order, they are stored as the compressing threads finish them, which changes
/// from run to run).
pub fn write_exr(path: impl AsRef<Path>, image: &Image) -> Result<(), ImageError> {
    use exr::prelude::{Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};

    let path = path.as_ref();
    image.check_consistent(path)?;
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * w + x];
        (p[0], p[1], p[2])
    });
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let exr_image =
        exr::image::Image::from_encoded_channels((w, image.height as usize), encoding, channels);
    write_atomically(path, |file| {
        exr_image.write().to_buffered(file).map_err(|e| match e {
            exr::error::Error::Io(source) => ImageError::Io {
                action: "write",
                cause: source,
                path: path.to_path_buf(),
            },
            other => ImageError::ExrEncode {
                reason: other.to_string(),
                path: path.to_path_buf(),
            },
        })
    })
}

/// Reads an 8-bit sRGB PNG (RGB or RGBA; alpha ignored) as linear values in [0, 1]: what a
/// display shows, for comparing displayed images (`vlf-bake compare` on PNG stills).
pub fn read_png(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let bad = |reason: String| ImageError::Png {
        reason,
        path: path.to_path_buf(),
    };
    let bytes = std::fs::read(path).map_err(|source| ImageError::Io {
        action: "read",
        cause: source,
        path: path.to_path_buf(),
    })?;
    let mut reader = png::Decoder::new(Cursor::new(bytes))
        .read_info()
        .map_err(|e| bad(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    let channels = match (info.color_type, info.bit_depth) {
        (png::ColorType::Rgb, png::BitDepth::Eight) => 3,
        (png::ColorType::Rgba, png::BitDepth::Eight) => 4,
        (c, d) => return Err(bad(format!("{c:?} at {d:?} bits"))),
    };
    let lut: Vec<f32> = (0..=255u8)
        .map(|v| srgb_to_linear(f32::from(v) / 255.0))
        .collect();
    let pixels = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]])
        .collect();
    Ok(Image {
        width: info.width,
        height: info.height,
        pixels,
    })
}

/// Reads an image for comparison: `.png` with [`read_png`], anything else with [`read_exr`].
pub fn read_any(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        read_png(path)
    } else {
        read_exr(path)
    }
}

/// Linear → sRGB transfer function (IEC 61966-2-1), input clamped to [0, 1]; NaN → 0.
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB → linear transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// ACES filmic tone curve as used by HDR-FLIP: Narkowicz's (2015) rational fit
/// `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)` applied to `0.6 · v`, clamped to [0, 1].
pub fn aces(v: f32) -> f32 {
    let t = flip::tone_map_aces(v);
    if t.is_nan() {
        if v > 0.0 { 1.0 } else { 0.0 }
    } else {
        t.clamp(0.0, 1.0)
    }
}

/// Writes an 8-bit sRGB PNG preview of `image`: each channel is multiplied by
/// `2^exposure` (exposure in stops; 0 leaves values unchanged), tone mapped, sRGB-encoded
/// and rounded. NaN maps to 0. Written atomically.
pub fn write_png(
    path: impl AsRef<Path>,
    image: &Image,
    exposure: f32,
    tonemap: Tonemap,
) -> Result<(), ImageError> {
    let path = path.as_ref();
    image.check_consistent(path)?;
    let scale = exposure.exp2();
    let to_byte = |v: f32| -> u8 {
        let v = v * scale;
        let t = match tonemap {
            Tonemap::Clamp => v,
            Tonemap::Aces => aces(v),
        };
        (linear_to_srgb(t) * 255.0 + 0.5) as u8
    };
    let data: Vec<u8> = image.pixels.iter().flat_map(|p| p.map(to_byte)).collect();
    write_png_rgb8(path, image.width, image.height, &data)
}

fn write_png_rgb8(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), ImageError> {
    write_atomically(path, |file| {
        let png_err = |e: png::EncodingError| match e {
            png::EncodingError::IoError(source) => ImageError::Io {
                action: "write",
                cause: source,
                path: path.to_path_buf(),
            },
            other => ImageError::PngEncode {
                reason: other.to_string(),
                path: path.to_path_buf(),
            },
        };
        let mut encoder = png::Encoder::new(file, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(data).map_err(png_err)?;
        writer.finish().map_err(png_err)
    })
}

/// Writes `f` into a temporary file next to `path` and renames it over `path`
/// ([`atomic_file::write`]); a failed step is an [`ImageError::Io`].
fn write_atomically(
    path: &Path,
    f: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    atomic_file::write(path, f).map_err(|e| match e {
        AtomicWriteError::Io { source, .. } => ImageError::Io {
            action: "write",
            cause: source,
            path: path.to_path_buf(),
        },
        AtomicWriteError::Content { error, .. } => error,
    })
}

fn assert_same_size(a: &Image, b: &Image, what: &str) {
    assert!(
        a.width == b.width && a.height == b.height && a.pixels.len() == b.pixels.len(),
        "{what}: image sizes differ ({}×{} vs {}×{})",
        a.width,
        a.height,
        b.width,
        b.height
    );
}

/// Mean squared error over all pixels and channels: mean of `(a − b)²` (f64 accumulation).
///
/// # Panics
/// If the images differ in size.
pub fn mse(a: &Image, b: &Image) -> f64 {
    assert_same_size(a, b, "mse");
    let mut sum = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let d = f64::from(p[c]) - f64::from(q[c]);
            sum += d * d;
        }
    }
    sum / (3 * a.pixels.len()).max(1) as f64
}

/// Relative MSE as defined in `shared/reference/README.md`: the mean over pixels and
/// channels of `(t − r)² / (r² + 0.01)` (f64 accumulation).
///
/// # Panics
/// If the images differ in size.
pub fn rel_mse(test: &Image, reference: &Image) -> f64 {
    assert_same_size(test, reference, "rel_mse");
    let mut sum = 0.0f64;
    for (t, r) in test.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (t, r) = (f64::from(t[c]), f64::from(r[c]));
            sum += (t - r) * (t - r) / (r * r + 0.01);
        }
    }
    sum / (3 * test.pixels.len()).max(1) as f64
}

/// Result of [`compare`]: MSE, relMSE and mean HDR-FLIP of a test image against a reference.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CompareReport {
    /// Mean squared error (see [`mse`]).
    pub mse: f64,
    /// Relative MSE (see [`rel_mse`]).
    pub rel_mse: f64,
    /// Mean HDR-FLIP error in [0, 1] (see [`flip()`]).
    pub flip_mean: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// Reads two EXR files and compares the test image against the reference.
/// Errors if either cannot be read, if their sizes differ or if either holds NaN/infinity.
pub fn compare(
    test_path: impl AsRef<Path>,
    ref_path: impl AsRef<Path>,
) -> Result<CompareReport, ImageError> {
    let (test_path, ref_path) = (test_path.as_ref(), ref_path.as_ref());
    let test = read_exr(test_path)?;
    let reference = read_exr(ref_path)?;
    compare_images(&test, &reference, test_path, ref_path).map(|(report, _)| report)
}

/// Like [`compare`] on images already in memory (the paths only name them in errors);
/// also returns the FLIP result so the caller can write its map with [`error_map_png`].
pub fn compare_images(
    test: &Image,
    reference: &Image,
    test_path: &Path,
    ref_path: &Path,
) -> Result<(CompareReport, FlipResult), ImageError> {
    if test.width != reference.width || test.height != reference.height {
        return Err(ImageError::SizeMismatch {
            test_width: test.width,
            test_height: test.height,
            test: test_path.to_path_buf(),
            ref_width: reference.width,
            ref_height: reference.height,
            reference: ref_path.to_path_buf(),
        });
    }
    test.check_consistent(test_path)?;
    reference.check_consistent(ref_path)?;
    for (image, path) in [(test, test_path), (reference, ref_path)] {
        if let Some((i, count)) = image.non_finite() {
            let w = image.width as usize;
            return Err(ImageError::NonFinite {
                count,
                x: (i % w) as u32,
                y: (i / w) as u32,
                path: path.to_path_buf(),
            });
        }
    }
    let flip = flip(test, reference);
    let report = CompareReport {
        mse: mse(test, reference),
        rel_mse: rel_mse(test, reference),
        flip_mean: f64::from(flip.mean),
        width: test.width,
        height: test.height,
    };
    Ok((report, flip))
}

/// Magma colour map, sRGB-encoded: entries 0, 16, 32, …, 240 and 255 of the 256-entry
/// matplotlib table (CC0) that FLIP uses; [`magma`] interpolates linearly between them.
const MAGMA_KNOTS: [(f32, [f32; 3]); 17] = [
    (0.0, [0.001462, 0.000466, 0.013866]),
    (16.0, [0.039608, 0.031090, 0.133515]),
    (32.0, [0.113094, 0.065492, 0.276784]),
    (48.0, [0.211718, 0.061992, 0.418647]),
    (64.0, [0.316654, 0.071690, 0.485380]),
    (80.0, [0.414709, 0.110431, 0.504662]),
    (96.0, [0.512831, 0.148179, 0.507648]),
    (112.0, [0.613617, 0.181811, 0.498536]),
    (128.0, [0.716387, 0.214982, 0.475290]),
    (144.0, [0.816914, 0.255895, 0.436461]),
    (160.0, [0.904281, 0.319610, 0.388137]),
    (176.0, [0.960949, 0.418323, 0.359630]),
    (192.0, [0.986700, 0.535582, 0.382210]),
    (208.0, [0.996096, 0.653659, 0.446213]),
    (224.0, [0.996898, 0.769591, 0.534892]),
    (240.0, [0.992440, 0.884330, 0.640099]),
    (255.0, [0.987053, 0.991438, 0.749504]),
];

/// Magma colour (sRGB-encoded, each channel in [0, 1]) for `v` in [0, 1]; `v` is clamped
/// and NaN maps to the top of the scale (an error you cannot miss).
pub fn magma(v: f32) -> [f32; 3] {
    let v = if v.is_nan() { 1.0 } else { v.clamp(0.0, 1.0) };
    let s = v * 255.0;
    let i = MAGMA_KNOTS
        .iter()
        .rposition(|k| k.0 <= s)
        .unwrap_or(0)
        .min(MAGMA_KNOTS.len() - 2);
    let (s0, c0) = MAGMA_KNOTS[i];
    let (s1, c1) = MAGMA_KNOTS[i + 1];
    let t = ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
    [0, 1, 2].map(|c| c0[c] + (c1[c] - c0[c]) * t)
}

/// Writes a per-pixel error map (values in [0, 1], e.g. [`FlipResult::map`]; larger values
/// are clamped) as a magma false-colour 8-bit sRGB PNG, row 0 at the top. Written atomically.
pub fn error_map_png(
    path: impl AsRef<Path>,
    errors: &[f32],
    width: u32,
    height: u32,
) -> Result<(), ImageError> {
    let path = path.as_ref();
    if width == 0 || height == 0 || errors.len() != width as usize * height as usize {
        return Err(ImageError::Invalid {
            reason: format!("{} error values for a {width}×{height} map", errors.len()),
            path: path.to_path_buf(),
        });
    }
    let data: Vec<u8> = errors
        .iter()
        .flat_map(|&e| magma(e).map(|c| (c * 255.0 + 0.5) as u8))
        .collect();
    write_png_rgb8(path, width, height, &data)
}
