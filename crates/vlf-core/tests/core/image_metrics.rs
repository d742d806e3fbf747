//! Image I/O and comparison metrics: EXR/PNG round trips, MSE/relMSE on hand-computed
//! cases, FLIP against values from NVIDIA's reference implementation, `compare()`.
//!
//! Where FLIP expectations come from: "flip-evaluator 1.7" means NVIDIA's `flip-evaluator`
//! package (PyPI, version 1.7, the C++ reference implementation behind a Python binding), run
//! with default parameters on the very same synthetic images as built by `pattern()` below
//! (every value is k/256 or k/64, exact in f32, so both sides see identical inputs), e.g.
//! `flip_evaluator.evaluate(ref, test, "LDR", inputsRGB=False, applyMagma=False)`.
//! Our implementation follows the same f32 formulas, so the tolerance is a few float ulps
//! worth of drift through `exp`/`pow` (1e-5 on means, 1e-4 on single pixels).

use std::path::{Path, PathBuf};

use vlf_core::image::{
    self, CompareReport, FlipParams, Image, ImageError, Tonemap, compare, error_map_png, flip,
    flip::{exposure_range, pixels_per_degree},
    flip_hdr, flip_ldr, flip_ldr_srgb, mse, read_exr, rel_mse, write_exr, write_png,
};

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/reference")
}

fn tmp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("image_metrics")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn assert_close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, want {want} (tolerance {tol})"
    );
}

// ----- EXR --------------------------------------------------------------------------------

#[test]
fn exr_round_trip_is_bit_exact() {
    let specials = [
        0.0,
        -0.0,
        1.0,
        -2.5,
        1.0e-42,
        3.0e38,
        1.0 / 3.0,
        f32::INFINITY,
        f32::NAN,
    ];
    let img = Image::from_fn(37, 23, |x, y| {
        let i = (y * 37 + x) as usize;
        if i < specials.len() {
            [specials[i], specials[(i + 1) % specials.len()], 0.125]
        } else {
            let f = (i as f32 * 0.618_034).fract();
            [f * 100.0, f.sqrt(), (x as f32 - y as f32) * 1e-3]
        }
    });
    let dir = tmp_dir("exr_round_trip");
    let path = dir.join("round.exr");
    write_exr(&path, &img).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (37, 23));
    let bits = |im: &Image| {
        im.pixels
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&back), bits(&img));
    // Written atomically: nothing but the final file is left in the directory.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("round.exr")]);
    // Overwriting an existing file works too.
    write_exr(&path, &Image::new(2, 2, [0.5; 3])).unwrap();
    assert_eq!(read_exr(&path).unwrap().pixels, vec![[0.5; 3]; 4]);
}

/// The same image written twice gives the same bytes: scripts compare stills by hash, and the
/// parallel EXR writer used to store chunks in whatever order they finished.
#[test]
fn exr_bytes_are_the_same_run_to_run() {
    let dir = tmp_dir("exr_bytes_stable");
    // Tall enough for many chunks (ZIP compresses 16 rows per chunk).
    let img = Image::from_fn(64, 512, |x, y| {
        let f = ((y * 64 + x) as f32 * 0.618_034).fract();
        [f, 1.0 - f, f * f]
    });
    let bytes: Vec<Vec<u8>> = (0..4)
        .map(|i| {
            let p = dir.join(format!("{i}.exr"));
            write_exr(&p, &img).unwrap();
            std::fs::read(&p).unwrap()
        })
        .collect();
    for (i, b) in bytes.iter().enumerate().skip(1) {
        assert!(*b == bytes[0], "write {i} differs from write 0");
    }
}

#[test]
fn exr_reads_half_channels() {
    use exr::prelude::f16;
    let path = tmp_dir("exr_half").join("half.exr");
    // Values exact in half precision.
    let value = |x: usize, y: usize| [x as f32 * 0.5, y as f32 * 0.25, 1024.0 + x as f32];
    exr::prelude::write_rgb_file(&path, 5, 3, |x, y| {
        let v = value(x, y).map(f16::from_f32);
        (v[0], v[1], v[2])
    })
    .unwrap();
    let img = read_exr(&path).unwrap();
    assert_eq!((img.width, img.height), (5, 3));
    assert_eq!(img.get(4, 2), value(4, 2));
    assert_eq!(img.get(1, 0), value(1, 0));
}

#[test]
fn exr_errors_name_the_file() {
    let dir = tmp_dir("exr_errors");

    let missing = dir.join("missing.exr");
    let err = read_exr(&missing).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err:?}");
    assert!(
        err.to_string().ends_with(&missing.display().to_string()),
        "{err}"
    );

    let garbage = dir.join("garbage.exr");
    std::fs::write(&garbage, b"this is not an EXR file at all").unwrap();
    let err = read_exr(&garbage).unwrap_err();
    assert!(matches!(err, ImageError::Exr { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.starts_with("not a readable OpenEXR image"), "{msg}");
    assert!(msg.ends_with(&garbage.display().to_string()), "{msg}");

    // A luminance-only EXR: R, G and B are missing.
    let gray = dir.join("gray.exr");
    let channels = exr::prelude::SpecificChannels::build()
        .with_channel("Y")
        .with_pixel_fn(|_pos| (0.5f32,));
    exr::prelude::WritableImage::write(&exr::prelude::Image::from_channels((4, 3), channels))
        .to_file(&gray)
        .unwrap();
    let err = read_exr(&gray).unwrap_err();
    assert!(matches!(err, ImageError::MissingChannels { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("no R, G, B channel"), "{msg}");
    assert!(msg.contains("channels present: Y"), "{msg}");
    assert!(msg.ends_with(&gray.display().to_string()), "{msg}");

    // Writing into a directory that does not exist.
    let nowhere = dir.join("no/such/dir/out.exr");
    let err = write_exr(&nowhere, &Image::new(1, 1, [0.0; 3])).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err:?}");
    assert!(
        err.to_string().ends_with(&nowhere.display().to_string()),
        "{err}"
    );
}

/// Parses `"mean_rgb": [r, g, b]` out of the reference's JSON sidecar (no JSON dependency).
fn json_mean_rgb(path: &Path) -> [f64; 3] {
    let text = std::fs::read_to_string(path).unwrap();
    let start = text.find("\"mean_rgb\"").expect("mean_rgb key");
    let open = start + text[start..].find('[').unwrap();
    let close = open + text[open..].find(']').unwrap();
    let v: Vec<f64> = text[open + 1..close]
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    [v[0], v[1], v[2]]
}

#[test]
fn cornell_reference_mean_matches_its_json() {
    let dir = reference_dir();
    let img = read_exr(dir.join("cornell-ref.exr")).unwrap();
    assert_eq!((img.width, img.height), (256, 256));
    let want = json_mean_rgb(&dir.join("cornell-ref.json"));
    let got = img.mean();
    for c in 0..3 {
        let rel = (got[c] - want[c]).abs() / want[c].abs();
        assert!(
            rel <= 1e-4,
            "channel {c}: mean {} vs json {} (rel {rel})",
            got[c],
            want[c]
        );
    }
}

// ----- PNG --------------------------------------------------------------------------------

fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn png_writes_srgb_bytes() {
    // Row 0 (top): 0, 1, 0.5 (sRGB 0.735357 → 187.52 → 188), 0.18 (sRGB 0.461356 → 117.6 → 118).
    // Row 1: NaN → 0, 1e9 → 255, 0.25 (exposure +1 → 0.5 → 188 in the second file),
    //        0.0031308 (the sRGB knee, 12.92·v = 0.04045 → 10.3 → 10).
    let img = Image {
        width: 4,
        height: 2,
        pixels: vec![
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 1.0],
            [0.5, 0.5, 0.5],
            [0.18, 0.18, 0.18],
            [f32::NAN, -1.0, 0.0],
            [1e9, 1e9, 1e9],
            [0.25, 0.25, 0.25],
            [0.003_130_8, 0.003_130_8, 0.003_130_8],
        ],
    };
    let dir = tmp_dir("png");
    let path = dir.join("clamp.png");
    write_png(&path, &img, 0.0, Tonemap::Clamp).unwrap();
    let (w, h, data) = decode_png(&path);
    assert_eq!((w, h), (4, 2));
    let px = |x: usize, y: usize| &data[(y * 4 + x) * 3..(y * 4 + x) * 3 + 3];
    assert_eq!(px(0, 0), [0, 0, 0]);
    assert_eq!(px(1, 0), [255, 255, 255]);
    assert_eq!(px(2, 0), [188, 188, 188]);
    assert_eq!(px(3, 0), [118, 118, 118]);
    assert_eq!(px(0, 1), [0, 0, 0]);
    assert_eq!(px(1, 1), [255, 255, 255]);
    assert_eq!(px(3, 1), [10, 10, 10]);

    // Exposure is in stops: +1 doubles 0.25 to 0.5.
    write_png(&path, &img, 1.0, Tonemap::Clamp).unwrap();
    let (_, _, data) = decode_png(&path);
    assert_eq!(&data[(4 + 2) * 3..(4 + 2) * 3 + 3], [188, 188, 188]);

    // ACES: 1.0 → Narkowicz(0.6) = 0.9216 / 1.3688 = 0.673290 → sRGB 0.83966 → 214.1 → 214;
    // huge values saturate to 255; 0 stays 0.
    let aces_path = dir.join("aces.png");
    write_png(&aces_path, &img, 0.0, Tonemap::Aces).unwrap();
    let (_, _, data) = decode_png(&aces_path);
    let px = |x: usize, y: usize| &data[(y * 4 + x) * 3..(y * 4 + x) * 3 + 3];
    assert_eq!(px(0, 0), [0, 0, 0]);
    assert_eq!(px(1, 0), [214, 214, 214]);
    assert_eq!(px(1, 1), [255, 255, 255]);
    assert_close(
        f64::from(image::aces(1.0)),
        0.9216 / 1.3688,
        1e-6,
        "aces(1)",
    );
}

/// `read_png` gives the linear values a display shows: the written sRGB codes decoded.
#[test]
fn png_reads_back_as_displayed_linear_values() {
    let img = Image {
        width: 3,
        height: 1,
        pixels: vec![[0.0, 0.25, 1.0], [2.0, 0.5, 0.0031308], [0.04, 0.6, 0.9]],
    };
    let path = tmp_dir("png_read").join("still.png");
    write_png(&path, &img, 0.0, Tonemap::Clamp).unwrap();
    let back = image::read_png(&path).unwrap();
    assert_eq!((back.width, back.height), (3, 1));
    for (p, q) in img.pixels.iter().zip(&back.pixels) {
        for c in 0..3 {
            let want = p[c].clamp(0.0, 1.0);
            // One 8-bit sRGB step at most (near black the steps are 1/3295 in linear).
            let step = (image::srgb_to_linear(image::linear_to_srgb(want) + 1.0 / 255.0) - want)
                .max(1.0 / 3295.0);
            assert!((q[c] - want).abs() <= step, "{p:?} → {q:?}");
        }
    }
    assert_eq!(back.pixels[0][2], 1.0);
    // read_any picks the decoder by extension; a PNG is not an EXR.
    assert_eq!(image::read_any(&path).unwrap(), back);
    assert!(matches!(read_exr(&path), Err(ImageError::Exr { .. })));
}

#[test]
fn error_map_png_uses_magma() {
    let dir = tmp_dir("error_map");
    let path = dir.join("diff.png");
    error_map_png(&path, &[0.0, 0.5, 1.0, 7.0, -1.0, f32::NAN], 3, 2).unwrap();
    let (w, h, data) = decode_png(&path);
    assert_eq!((w, h), (3, 2));
    // magma[0] = (0.001462, 0.000466, 0.013866), magma[128] = (0.716387, 0.214982, 0.475290)
    // (0.5 · 255 = 127.5 lies between entries 112 and 128), magma[255] = (0.987053, 0.991438,
    // 0.749504); out-of-range values clamp, NaN shows as the maximum.
    assert_eq!(&data[0..3], [0, 0, 4]);
    let mid = image::magma(0.5);
    assert!(
        (mid[0] - 0.7164).abs() < 0.01 && (mid[1] - 0.2150).abs() < 0.01,
        "{mid:?}"
    );
    assert_eq!(&data[6..9], [252, 253, 191]);
    assert_eq!(&data[9..12], [252, 253, 191]);
    assert_eq!(&data[12..15], [0, 0, 4]);
    assert_eq!(&data[15..18], [252, 253, 191]);

    let err = error_map_png(dir.join("bad.png"), &[0.0; 5], 3, 2).unwrap_err();
    assert!(err.to_string().ends_with("bad.png"), "{err}");
}

// ----- MSE / relMSE -----------------------------------------------------------------------

#[test]
fn mse_and_rel_mse_on_constant_images() {
    // Inputs are exact in f32 so the expectations are exact up to f64 rounding.
    // Grey: t = 0.625, r = 0.5 everywhere: MSE = 0.125² = 0.015625; relMSE = 0.015625 / 0.26.
    let r = Image::new(8, 4, [0.5; 3]);
    let t = Image::new(8, 4, [0.625; 3]);
    assert_close(mse(&t, &r), 0.015_625, 1e-12, "mse grey");
    assert_close(rel_mse(&t, &r), 0.015_625 / 0.26, 1e-12, "rel_mse grey");

    // Per channel r = (0.5, 0, 2), t = (0.625, 0.125, 1): squared errors 1/64, 1/64, 1,
    // MSE = (1 + 2/64) / 3 = 0.34375; relMSE = (0.015625/0.26 + 0.015625/0.01 + 1/4.01) / 3.
    let r = Image::new(5, 3, [0.5, 0.0, 2.0]);
    let t = Image::new(5, 3, [0.625, 0.125, 1.0]);
    assert_close(mse(&t, &r), 0.343_75, 1e-12, "mse rgb");
    let want = (0.015_625 / 0.26 + 0.015_625 / 0.01 + 1.0 / 4.01) / 3.0;
    assert_close(rel_mse(&t, &r), want, 1e-12, "rel_mse rgb");
    // relMSE divides by the reference: not symmetric.
    let want = (0.015_625 / 0.400_625 + 0.015_625 / 0.025_625 + 1.0 / 1.01) / 3.0;
    assert_close(rel_mse(&r, &t), want, 1e-12, "rel_mse swapped");

    // Half the pixels wrong by 1 on a black reference: MSE = 0.5, relMSE = 0.5 / 0.01 = 50.
    let r = Image::new(4, 4, [0.0; 3]);
    let t = Image::from_fn(4, 4, |x, _| if x < 2 { [1.0; 3] } else { [0.0; 3] });
    assert_close(mse(&t, &r), 0.5, 1e-12, "mse half");
    assert_close(rel_mse(&t, &r), 50.0, 1e-9, "rel_mse half");
    assert_eq!(mse(&r, &r), 0.0);
    assert_eq!(rel_mse(&r, &r), 0.0);
}

// ----- FLIP -------------------------------------------------------------------------------

const W: u32 = 40;
const H: u32 = 32;

/// Reference pattern: a ramp plus a bright box (integer numerator).
fn ref_num(x: u32, y: u32, c: u32) -> i32 {
    let box_ = (10..24).contains(&x) && (8..20).contains(&y);
    (x * 5 + y * 3 + c * 16) as i32 + if box_ { 64 } else { 0 }
}

/// Deterministic pseudo-noise in −15..=15.
fn noise(x: u32, y: u32, c: u32) -> i32 {
    ((x * 37 + y * 91 + c * 17) % 31) as i32 - 15
}

/// LDR pattern: `clamp(ref + k·noise, 0, 256) / 256`.
fn ldr_pattern(k: i32) -> Image {
    Image::from_fn(W, H, |x, y| {
        [0, 1, 2].map(|c| (ref_num(x, y, c) + k * noise(x, y, c)).clamp(0, 256) as f32 / 256.0)
    })
}

/// HDR pattern: `max(ref + 1 + k·noise, 0) / 64`, times 16 inside the box (up to ≈ 82).
fn hdr_pattern(k: i32) -> Image {
    Image::from_fn(W, H, |x, y| {
        let s = if (10..24).contains(&x) && (8..20).contains(&y) {
            16.0
        } else {
            1.0
        };
        [0, 1, 2].map(|c| (ref_num(x, y, c) + 1 + k * noise(x, y, c)).max(0) as f32 / 64.0 * s)
    })
}

fn ppd() -> f32 {
    FlipParams::default().ppd
}

fn map_at(result: &vlf_core::image::FlipResult, x: u32, y: u32) -> f64 {
    f64::from(result.map[(y * W + x) as usize])
}

#[test]
fn flip_default_viewing_conditions() {
    // 0.7 m · 3840 px / 0.7 m · π/180 = 67.0206 px/degree (flip-evaluator 1.7 reports
    // 67.02064514160156).
    assert_close(f64::from(ppd()), 67.020_645, 1e-5, "ppd");
    assert_eq!(pixels_per_degree(0.7, 3840.0, 0.7), ppd());
}

#[test]
fn flip_of_identical_images_is_zero() {
    let r = hdr_pattern(0);
    let result = flip(&r, &r);
    assert_eq!(result.mean, 0.0);
    assert!(result.map.iter().all(|&v| v == 0.0));
    let l = ldr_pattern(0);
    assert_eq!(flip_ldr(&l, &l, ppd()).mean, 0.0);
}

#[test]
fn flip_uniform_images() {
    // Uniform images have no features, so FLIP is the remapped colour difference alone.
    let black = Image::new(16, 16, [0.0; 3]);
    let white = Image::new(16, 16, [1.0; 3]);
    // Black vs white: HyAB = 100 (L only), 100^0.7 = 25.12, cmax = 41.27, pc·cmax = 16.51,
    // so 0.95 + (25.12 − 16.51)/(41.27 − 16.51)·0.05 = 0.9674 — not 1.0: only the green–blue
    // distance maps to 1. flip-evaluator 1.7 gives 0.9673909544944763.
    let bw = flip_ldr(&white, &black, ppd());
    assert_close(
        f64::from(bw.mean),
        0.967_390_954_494_476_3,
        1e-5,
        "black vs white",
    );
    assert!(bw.map.iter().all(|&v| (v - bw.mean).abs() < 1e-6));
    // Green vs blue is cmax by construction: 1.0 (flip-evaluator 1.7: 1.0).
    let green = Image::new(16, 16, [0.0, 1.0, 0.0]);
    let blue = Image::new(16, 16, [0.0, 0.0, 1.0]);
    assert_close(
        f64::from(flip_ldr(&green, &blue, ppd()).mean),
        1.0,
        1e-5,
        "green vs blue",
    );
    // A one-pixel black/white checkerboard against black: the CSF blurs it to grey, while the
    // feature term pushes the exponent towards 0 (flip-evaluator 1.7: 0.9655113220214844).
    let checker = Image::from_fn(
        16,
        16,
        |x, y| if (x + y) % 2 == 0 { [1.0; 3] } else { [0.0; 3] },
    );
    let cb = flip_ldr(&checker, &black, ppd());
    assert_close(
        f64::from(cb.mean),
        0.965_511_322_021_484_4,
        1e-5,
        "checker vs black",
    );
}

#[test]
fn flip_ldr_matches_reference_implementation() {
    let r = ldr_pattern(0);
    // (mean, pixel (7,5), pixel (20,16), pixel (39,31)) from flip-evaluator 1.7.
    let cases = [
        (
            1,
            0.082_810_349_762_439_73,
            [
                0.088_858_693_838_119_5,
                0.070_945_233_106_613_16,
                0.001_797_383_069_060_742_9,
            ],
        ),
        (
            4,
            0.229_472_234_845_161_44,
            [
                0.227_350_533_008_575_44,
                0.194_602_295_756_340_03,
                0.036_866_903_305_053_71,
            ],
        ),
    ];
    for (k, mean, px) in cases {
        let t = ldr_pattern(k);
        let result = flip_ldr(&t, &r, ppd());
        assert_close(
            f64::from(result.mean),
            mean,
            1e-5,
            &format!("LDR k={k} mean"),
        );
        for ((x, y), want) in [(7, 5), (20, 16), (39, 31)].into_iter().zip(px) {
            assert_close(
                map_at(&result, x, y),
                want,
                1e-4,
                &format!("LDR k={k} ({x},{y})"),
            );
        }
        // Every step of LDR-FLIP (HyAB, |edge_r − edge_t|, |point_r − point_t|) is symmetric in
        // its two inputs, so swapping them changes nothing (flip-evaluator 1.7 agrees: same
        // means). HDR-FLIP is not symmetric, see below.
        let swapped = flip_ldr(&r, &t, ppd());
        assert_close(
            f64::from(swapped.mean),
            f64::from(result.mean),
            1e-6,
            "LDR swapped",
        );
    }
    // sRGB-encoded inputs are decoded first (flip-evaluator 1.7 with inputsRGB=True).
    let result = flip_ldr_srgb(&ldr_pattern(4), &r, ppd());
    assert_close(
        f64::from(result.mean),
        0.307_366_907_596_588_13,
        1e-5,
        "LDR sRGB k=4",
    );
}

#[test]
fn flip_hdr_matches_reference_implementation() {
    let r = hdr_pattern(0);
    // Exposure range from the reference (flip-evaluator 1.7: start −4.886829376220703,
    // stop −0.4461614489555359, 5 exposures).
    let range = exposure_range(&r, &FlipParams::default());
    assert_close(
        f64::from(range.start),
        -4.886_829_376_220_703,
        1e-5,
        "start exposure",
    );
    assert_close(
        f64::from(range.stop),
        -0.446_161_448_955_535_9,
        1e-5,
        "stop exposure",
    );
    assert_eq!(range.count, 5);

    let cases = [
        (
            1,
            0.067_356_094_717_979_43,
            [
                0.089_116_640_388_965_6,
                0.025_335_373_356_938_362,
                0.066_175_974_905_490_88,
            ],
        ),
        (
            4,
            0.193_963_617_086_410_52,
            [
                0.305_066_108_703_613_3,
                0.074_289_985_001_087_19,
                0.172_378_852_963_447_57,
            ],
        ),
    ];
    for (k, mean, px) in cases {
        let t = hdr_pattern(k);
        let result = flip(&t, &r);
        assert_close(
            f64::from(result.mean),
            mean,
            1e-5,
            &format!("HDR k={k} mean"),
        );
        for ((x, y), want) in [(7, 5), (20, 16), (39, 31)].into_iter().zip(px) {
            assert_close(
                map_at(&result, x, y),
                want,
                1e-4,
                &format!("HDR k={k} ({x},{y})"),
            );
        }
    }

    // Not symmetric: with the noisy image as the reference the exposure range changes
    // (flip-evaluator 1.7: start −4.911783695220947, mean 0.06739148497581482 for k = 1).
    let t = hdr_pattern(1);
    let swapped_range = exposure_range(&t, &FlipParams::default());
    assert_close(
        f64::from(swapped_range.start),
        -4.911_783_695_220_947,
        1e-5,
        "swapped start",
    );
    let swapped = flip(&r, &t);
    assert_close(
        f64::from(swapped.mean),
        0.067_391_484_975_814_82,
        1e-5,
        "HDR swapped mean",
    );

    // Explicit exposures are honoured: one fixed exposure pair.
    let params = FlipParams {
        start_exposure: Some(-2.0),
        stop_exposure: Some(-2.0),
        num_exposures: Some(2),
        ..FlipParams::default()
    };
    let fixed = flip_hdr(&t, &r, &params);
    assert!(fixed.mean > 0.0 && fixed.mean < flip(&t, &r).mean + 1e-6);
}

#[test]
fn flip_grows_with_noise() {
    let (lr, hr) = (ldr_pattern(0), hdr_pattern(0));
    let mut last = (0.0f32, 0.0f32);
    for k in [1, 2, 4, 8] {
        let l = flip_ldr(&ldr_pattern(k), &lr, ppd()).mean;
        let h = flip(&hdr_pattern(k), &hr).mean;
        assert!(
            l > last.0 && h > last.1,
            "k={k}: LDR {l} HDR {h} after {last:?}"
        );
        assert!(l < 1.0 && h < 1.0);
        last = (l, h);
    }
}

#[test]
fn flip_all_black_reference_does_not_blow_up() {
    // The reference code divides by the max/median luminance; an all-black reference (or a
    // mostly black one) must still give finite exposures and a finite result.
    let black = Image::new(8, 8, [0.0; 3]);
    let grey = Image::new(8, 8, [0.5; 3]);
    let result = flip(&grey, &black);
    assert!(
        result.mean.is_finite() && result.mean > 0.0,
        "{}",
        result.mean
    );
    let mostly_black = Image::from_fn(8, 8, |x, _| if x == 0 { [1.0; 3] } else { [0.0; 3] });
    let range = exposure_range(&mostly_black, &FlipParams::default());
    assert!(
        range.start.is_finite() && range.stop.is_finite() && range.count >= 2,
        "{range:?}"
    );
}

// ----- compare ----------------------------------------------------------------------------

#[test]
fn compare_two_references() {
    let dir = reference_dir();
    let (test, reference) = (
        dir.join("cornell-mirror-ref.exr"),
        dir.join("cornell-ref.exr"),
    );
    let start = std::time::Instant::now();
    let report: CompareReport = compare(&test, &reference).unwrap();
    eprintln!(
        "compare (2 EXR reads + MSE + relMSE + HDR-FLIP 256×256): {:?}",
        start.elapsed()
    );
    eprintln!("{report:?}");
    assert_eq!((report.width, report.height), (256, 256));
    for v in [report.mse, report.rel_mse, report.flip_mean] {
        assert!(v.is_finite() && v > 0.0, "{report:?}");
    }
    // flip-evaluator 1.7 on the same pixels (passed as float arrays: its own EXR loader
    // misreads these PIZ-compressed float files) gives 0.2194022536277771 with exposures
    // −2.5723 … 5.3536 in 8 steps.
    assert_close(
        report.flip_mean,
        0.219_402_253_627_777_1,
        1e-4,
        "cornell FLIP",
    );
    let range = exposure_range(&read_exr(&reference).unwrap(), &FlipParams::default());
    assert_close(
        f64::from(range.start),
        -2.572_343_349_456_787,
        1e-4,
        "cornell start",
    );
    assert_close(
        f64::from(range.stop),
        5.353_585_720_062_256,
        1e-4,
        "cornell stop",
    );
    assert_eq!(range.count, 8);
    // Against itself everything is zero.
    let same = compare(&reference, &reference).unwrap();
    assert_eq!((same.mse, same.rel_mse, same.flip_mean), (0.0, 0.0, 0.0));
}

#[test]
fn compare_rejects_mismatched_sizes() {
    let dir = tmp_dir("compare_sizes");
    let small = dir.join("small.exr");
    write_exr(&small, &Image::new(8, 4, [0.25; 3])).unwrap();
    let reference = reference_dir().join("cornell-ref.exr");
    let err = compare(&small, &reference).unwrap_err();
    assert!(matches!(err, ImageError::SizeMismatch { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("8×4"), "{msg}");
    assert!(msg.contains("256×256"), "{msg}");
    assert!(msg.contains(&small.display().to_string()), "{msg}");
    assert!(msg.ends_with(&reference.display().to_string()), "{msg}");
}

#[test]
fn compare_rejects_non_finite_pixels() {
    let dir = tmp_dir("compare_nan");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let mut img = Image::new(4, 4, [0.25; 3]);
    write_exr(&b, &img).unwrap();
    img.pixels[6][1] = f32::NAN;
    write_exr(&a, &img).unwrap();
    let err = compare(&a, &b).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("x=2, y=1"), "{msg}");
    assert!(msg.ends_with(&a.display().to_string()), "{msg}");
}

#[test]
fn mean_and_resize_box() {
    let img = Image::from_fn(4, 2, |x, y| [x as f32, y as f32, 1.0]);
    assert_eq!(img.mean(), [1.5, 0.5, 1.0]);
    let half = img.resize_box(2);
    assert_eq!((half.width, half.height), (2, 1));
    assert_eq!(half.pixels, vec![[0.5, 0.5, 1.0], [2.5, 0.5, 1.0]]);
    assert_eq!(img.resize_box(1), img);
}
