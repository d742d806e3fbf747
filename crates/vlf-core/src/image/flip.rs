//! NVIDIA's FLIP image difference evaluator: LDR-FLIP (Andersson et al., "FLIP: A Difference
//! Evaluator for Alternating Images", HPG 2020) and HDR-FLIP (Andersson et al., "Visualizing
//! Errors in Rendered High Dynamic Range Images", Eurographics 2021), as in NVIDIA's
//! reference implementation (`flip-evaluator` 1.x, BSD-3), reimplemented here in f32 with the
//! same constants, filters and order of operations.
//!
//! Pipeline of LDR-FLIP for a reference `r` and a test `t`, both linear RGB in [0, 1]:
//! 1. Colour: linear RGB → XYZ → YCxCz (opponent space); each channel is convolved with the
//!    contrast sensitivity filters of the paper (sums of Gaussians, `a1`, `b1`, `a2`, `b2`
//!    below, in degrees of visual angle), clamped back to [0, 1] in linear RGB, converted to
//!    CIELAB with the Hunt adjustment (`a, b` scaled by `0.01 L`), compared with the HyAB
//!    distance, raised to `qc = 0.7` and remapped to [0, 1]: `[0, pc·cmax)` → `[0, pt)`,
//!    `[pc·cmax, cmax]` → `[pt, 1]` with `pc = 0.4`, `pt = 0.95`, and `cmax` the
//!    (Hunt-adjusted HyAB)^qc distance between pure green and pure blue.
//! 2. Features: the achromatic channel `(Y + 16)/116` is filtered with the first and second
//!    derivatives of a Gaussian of standard deviation `σ = 0.5 · 0.082 · ppd` pixels (edges and
//!    points); the feature difference is `(max(|‖∇r‖ − ‖∇t‖|, |‖∇²r‖ − ‖∇²t‖|)/√2)^qf`, `qf = 0.5`.
//! 3. FLIP per pixel: `ΔE_c^(1 − ΔE_f)`, in [0, 1].
//!
//! HDR-FLIP tone maps both images with ACES at a range of exposures `[c_start, c_stop]`
//! computed from the reference, runs LDR-FLIP on each pair and keeps the per-pixel maximum.
//! LDR-FLIP is symmetric in its two inputs; HDR-FLIP is not (the exposure range comes from
//! the reference only).
//!
//! Borders are handled by clamping coordinates to the image (edge replication), as in the
//! reference implementation.

use super::Image;
use std::f32::consts::PI;

/// Colour-difference exponent `qc`.
const QC: f32 = 0.7;
/// Fraction `pc` of `cmax` below which errors are compressed into `[0, pt)`.
const PC: f32 = 0.4;
/// Error value `pt` that `pc · cmax` maps to.
const PT: f32 = 0.95;
/// Feature-filter width `w` (degrees): the Gaussian's standard deviation is `0.5 · w · ppd`.
const GW: f32 = 0.082;
/// Feature-difference exponent `qf`.
const QF: f32 = 0.5;

/// Contrast sensitivity filters (paper, Table 1): channel c (Y, Cx, Cz) is the sum of
/// `a1[c]·√(π/b1[c])·exp(−π²x²/b1[c])` and the same with `a2`, `b2`; `x` in degrees.
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2: [f32; 3] = [0.0, 0.0, 13.5];
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];

/// ACES (Narkowicz 2015) as a rational function `(c0 x² + c1 x + c2)/(c3 x² + c4 x + c5)`
/// with his 0.6 pre-exposure folded into the coefficients (as in the FLIP code).
const ACES: [f32; 6] = [
    0.6 * 0.6 * 2.51,
    0.6 * 0.03,
    0.0,
    0.6 * 0.6 * 2.43,
    0.6 * 0.59,
    0.14,
];

/// D65 reference white (XYZ) and its inverse, as used by the FLIP code.
const ILLUMINANT: [f32; 3] = [0.950_428_55, 1.0, 1.088_900_3];
const INV_ILLUMINANT: [f32; 3] = [1.052_156_9, 1.0, 0.918_357_7];

/// Pixels per degree of visual angle for an observer `distance_m` from a monitor
/// `monitor_width_m` wide showing `resolution_x` pixels across.
pub fn pixels_per_degree(distance_m: f32, resolution_x: f32, monitor_width_m: f32) -> f32 {
    distance_m * (resolution_x / monitor_width_m) * (PI / 180.0)
}

/// FLIP parameters. The default is the paper's viewing condition (0.7 m from a 0.7 m wide
/// 3840-pixel monitor, ≈ 67.02 pixels per degree) and, for HDR-FLIP, the exposure range
/// and count computed from the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipParams {
    /// Pixels per degree of visual angle.
    pub ppd: f32,
    /// HDR-FLIP start exposure `c_start` (stops); `None` = computed from the reference.
    pub start_exposure: Option<f32>,
    /// HDR-FLIP stop exposure `c_stop` (stops); `None` = computed from the reference.
    pub stop_exposure: Option<f32>,
    /// HDR-FLIP number of exposures (at least 2); `None` = `max(2, ⌈c_stop − c_start⌉)`.
    pub num_exposures: Option<u32>,
}

impl Default for FlipParams {
    fn default() -> Self {
        Self {
            ppd: pixels_per_degree(0.7, 3840.0, 0.7),
            start_exposure: None,
            stop_exposure: None,
            num_exposures: None,
        }
    }
}

/// A FLIP evaluation: the per-pixel error map (row 0 at the top, values in [0, 1]) and its mean.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipResult {
    /// Mean of `map`.
    pub mean: f32,
    /// Per-pixel FLIP error, `width × height` values, row-major, top row first.
    pub map: Vec<f32>,
}

/// The exposures HDR-FLIP evaluates: `count` values evenly spaced over `[start, stop]` (stops).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExposureRange {
    /// First exposure `c_start`.
    pub start: f32,
    /// Last exposure `c_stop`.
    pub stop: f32,
    /// Number of exposures (at least 2).
    pub count: u32,
}

/// HDR-FLIP (ACES tone mapper, exposure range from the reference, default viewing
/// conditions) of `test` against `reference`, both linear RGB radiance.
///
/// # Panics
/// If the images differ in size or their pixel count is not `width × height`.
pub fn flip(test: &Image, reference: &Image) -> FlipResult {
    flip_hdr(test, reference, &FlipParams::default())
}

/// HDR-FLIP of `test` against `reference` (linear RGB radiance) with explicit parameters.
///
/// # Panics
/// If the images differ in size, or if the given exposures have `start > stop` or a count
/// below 2.
pub fn flip_hdr(test: &Image, reference: &Image, params: &FlipParams) -> FlipResult {
    check_sizes(test, reference);
    let range = exposure_range(reference, params);
    assert!(
        range.start <= range.stop,
        "HDR-FLIP: start exposure must not exceed stop exposure"
    );
    assert!(
        range.count >= 2,
        "HDR-FLIP: at least two exposures are needed"
    );
    let (w, h) = (reference.width as usize, reference.height as usize);
    let n = w * h;
    if n == 0 {
        return FlipResult {
            mean: 0.0,
            map: Vec::new(),
        };
    }
    let filters = Filters::new(params.ppd);
    let step = (range.stop - range.start) / (range.count - 1) as f32;
    let count = range.count as usize;
    let threads = crate::par::threads(0).clamp(1, count);
    let worker = |first: usize| {
        let mut scratch = Scratch::new(n);
        let mut max_map = vec![0.0f32; n];
        let mut map = vec![0.0f32; n];
        let (mut r, mut t) = (vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n]);
        for i in (first..count).step_by(threads) {
            let exposure = range.start + i as f32 * step;
            let m = 2.0f32.powf(exposure);
            tone_map_into(&reference.pixels, m, &mut r);
            tone_map_into(&test.pixels, m, &mut t);
            ldr_flip_into(&r, &t, w, h, &filters, &mut scratch, &mut map);
            for (acc, &v) in max_map.iter_mut().zip(&map) {
                if v > *acc {
                    *acc = v;
                }
            }
        }
        max_map
    };
    // One job per worker, each with its own scratch over a stride of the exposures; the
    // maxima are exact and order-free.
    let mut maps: Vec<Vec<f32>> = crate::par::map(threads, threads, 1, worker);
    let mut map = maps.swap_remove(0);
    for other in &maps {
        for (acc, &v) in map.iter_mut().zip(other) {
            if v > *acc {
                *acc = v;
            }
        }
    }
    FlipResult {
        mean: mean(&map),
        map,
    }
}

/// LDR-FLIP of `test` against `reference`, both *linear* RGB display values in [0, 1]
/// (values outside are clamped, NaN counts as 0), at `ppd` pixels per degree.
///
/// # Panics
/// If the images differ in size.
pub fn flip_ldr(test: &Image, reference: &Image, ppd: f32) -> FlipResult {
    check_sizes(test, reference);
    let clamp =
        |img: &Image| -> Vec<[f32; 3]> { img.pixels.iter().map(|p| p.map(clamp01)).collect() };
    ldr(
        &clamp(test),
        &clamp(reference),
        reference.width,
        reference.height,
        ppd,
    )
}

/// LDR-FLIP of `test` against `reference` whose values are sRGB-*encoded* in [0, 1] (as
/// decoded from an 8-bit PNG divided by 255): the sRGB transfer function is undone first.
///
/// # Panics
/// If the images differ in size.
pub fn flip_ldr_srgb(test: &Image, reference: &Image, ppd: f32) -> FlipResult {
    check_sizes(test, reference);
    let decode = |img: &Image| -> Vec<[f32; 3]> {
        img.pixels
            .iter()
            .map(|p| p.map(|v| clamp01(super::srgb_to_linear(v))))
            .collect()
    };
    ldr(
        &decode(test),
        &decode(reference),
        reference.width,
        reference.height,
        ppd,
    )
}

fn ldr(test: &[[f32; 3]], reference: &[[f32; 3]], w: u32, h: u32, ppd: f32) -> FlipResult {
    let n = test.len();
    if n == 0 {
        return FlipResult {
            mean: 0.0,
            map: Vec::new(),
        };
    }
    let mut map = vec![0.0f32; n];
    let mut scratch = Scratch::new(n);
    ldr_flip_into(
        reference,
        test,
        w as usize,
        h as usize,
        &Filters::new(ppd),
        &mut scratch,
        &mut map,
    );
    FlipResult {
        mean: mean(&map),
        map,
    }
}

fn check_sizes(test: &Image, reference: &Image) {
    assert!(
        test.width == reference.width && test.height == reference.height,
        "FLIP: image sizes differ (test {}×{}, reference {}×{})",
        test.width,
        test.height,
        reference.width,
        reference.height
    );
    let n = reference.width as usize * reference.height as usize;
    assert!(
        test.pixels.len() == n && reference.pixels.len() == n,
        "FLIP: pixel count differs from width × height"
    );
}

fn mean(map: &[f32]) -> f32 {
    (map.iter().map(|&v| f64::from(v)).sum::<f64>() / map.len().max(1) as f64) as f32
}

/// The HDR-FLIP exposure range for `reference` under `params`: given values are kept, the
/// others computed as in the paper. With `t = 0.85` and `x_max` the input at which the
/// (pre-exposed) ACES curve reaches `t`: `c_start = log2(x_max / Y_max)`,
/// `c_stop = log2(x_max / Y_median)`, `count = max(2, ⌈c_stop − c_start⌉)`, where `Y` is the
/// Rec.709 luminance of the reference's pixels and the median is the element of rank `n/2`.
///
/// Deviations from the reference code, which has no answer for these cases: non-finite
/// luminances are ignored; a median of 0 (more than half the pixels black) is replaced by
/// the smallest positive luminance; an all-black reference gives `c_start = c_stop = 0`.
pub fn exposure_range(reference: &Image, params: &FlipParams) -> ExposureRange {
    let (auto_start, auto_stop) = auto_exposures(reference);
    let start = params.start_exposure.unwrap_or(auto_start);
    let stop = params.stop_exposure.unwrap_or(auto_stop);
    let count = params.num_exposures.unwrap_or_else(|| {
        let c = (stop - start).ceil();
        if c.is_finite() { (c as u32).max(2) } else { 2 }
    });
    ExposureRange { start, stop, count }
}

fn auto_exposures(reference: &Image) -> (f32, f32) {
    // Solve (c0 − t c3) x² + (c1 − t c4) x + (c2 − t c5) = 0 for the larger root.
    let t = 0.85f32;
    let a = ACES[0] - t * ACES[3];
    let b = ACES[1] - t * ACES[4];
    let c = ACES[2] - t * ACES[5];
    let x_max = if a == 0.0 {
        -c / b
    } else {
        let d1 = -0.5 * (b / a);
        let d2 = ((d1 * d1) - (c / a)).sqrt();
        d1 + d2
    };

    let mut lum: Vec<f32> = reference
        .pixels
        .iter()
        .map(|&p| luminance(p))
        .filter(|y| y.is_finite())
        .collect();
    if lum.is_empty() {
        return (0.0, 0.0);
    }
    let y_max = lum.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let y_min_positive = lum
        .iter()
        .copied()
        .filter(|&y| y > 0.0)
        .fold(f32::INFINITY, f32::min);
    if y_max <= 0.0 {
        return (0.0, 0.0);
    }
    let mid = lum.len() / 2;
    let (_, &mut median, _) = lum.select_nth_unstable_by(mid, f32::total_cmp);
    let median = if median > 0.0 { median } else { y_min_positive };
    ((x_max / y_max).log2(), (x_max / median).log2())
}

fn luminance(p: [f32; 3]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The ACES curve HDR-FLIP uses, unclamped.
pub(super) fn tone_map_aces(x: f32) -> f32 {
    let c = &ACES;
    ((x * x) * c[0] + x * c[1] + c[2]) / (x * x * c[3] + x * c[4] + c[5])
}

/// `clamp(aces(v · m), 0, 1)` for every channel.
fn tone_map_into(src: &[[f32; 3]], m: f32, dst: &mut [[f32; 3]]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = s.map(|v| clamp01(tone_map_aces(v * m)));
    }
}

/// `min(max(v, 0), 1)` with the reference code's NaN behaviour (NaN → 0).
fn clamp01(v: f32) -> f32 {
    let v = if v > 0.0 { v } else { 0.0 };
    if v > 1.0 { 1.0 } else { v }
}

// ----- colour spaces ---------------------------------------------------------------------

fn linear_rgb_to_xyz(c: [f32; 3]) -> [f32; 3] {
    const M: [[f32; 3]; 3] = [
        [
            10135552.0 / 24577794.0,
            8788810.0 / 24577794.0,
            4435075.0 / 24577794.0,
        ],
        [
            2613072.0 / 12288897.0,
            8788810.0 / 12288897.0,
            887015.0 / 12288897.0,
        ],
        [
            1425312.0 / 73733382.0,
            8788810.0 / 73733382.0,
            70074185.0 / 73733382.0,
        ],
    ];
    M.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

fn xyz_to_linear_rgb(c: [f32; 3]) -> [f32; 3] {
    const M: [[f32; 3]; 3] = [
        [3.241_003_3, -1.537_398_9, -0.498_615_86],
        [-0.969_224_33, 1.875_930_1, 0.041_554_224],
        [0.055_639_423, -0.204_011_2, 1.057_148_9],
    ];
    M.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

fn xyz_to_ycxcz(c: [f32; 3]) -> [f32; 3] {
    let x = c[0] * INV_ILLUMINANT[0];
    let y = c[1] * INV_ILLUMINANT[1];
    let z = c[2] * INV_ILLUMINANT[2];
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let y = (c[0] + 16.0) / 116.0;
    let cx = c[1] / 500.0;
    let cz = c[2] / 200.0;
    [
        (y + cx) * ILLUMINANT[0],
        y * ILLUMINANT[1],
        (y - cz) * ILLUMINANT[2],
    ]
}

fn xyz_to_lab(c: [f32; 3]) -> [f32; 3] {
    const DELTA: f32 = 6.0 / 29.0;
    const DELTA_SQUARE: f32 = DELTA * DELTA;
    const DELTA_CUBE: f32 = DELTA * DELTA_SQUARE;
    const FACTOR: f32 = 1.0 / (3.0 * DELTA_SQUARE);
    const TERM: f32 = 4.0 / 29.0;
    let f = |v: f32| {
        if v > DELTA_CUBE {
            v.powf(1.0 / 3.0)
        } else {
            FACTOR * v + TERM
        }
    };
    let x = f(c[0] * INV_ILLUMINANT[0]);
    let y = f(c[1] * INV_ILLUMINANT[1]);
    let z = f(c[2] * INV_ILLUMINANT[2]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// CIELAB with the Hunt adjustment: chroma scaled by `0.01 · L`.
fn hunt_lab(linear_rgb: [f32; 3]) -> [f32; 3] {
    let lab = xyz_to_lab(linear_rgb_to_xyz(linear_rgb));
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

/// HyAB distance: city-block in L, Euclidean in (a, b).
fn hyab(p: [f32; 3], q: [f32; 3]) -> f32 {
    let (da, db) = (p[1] - q[1], p[2] - q[2]);
    (p[0] - q[0]).abs() + (da * da + db * db).sqrt()
}

// ----- filters ---------------------------------------------------------------------------

/// Per-ppd filter kernels and colour-remapping constants.
struct Filters {
    /// Spatial (CSF) filter taps for the Y and Cx channels, normalised to sum 1.
    yc: Vec<[f32; 2]>,
    /// Separable parts of the two-Gaussian Cz filter (the 2-D filter is
    /// `cz0 ⊗ cz0 + cz1 ⊗ cz1`), normalised so that it sums to 1.
    cz: Vec<[f32; 2]>,
    /// Feature filter taps: Gaussian, first and second derivative.
    feature: Vec<[f32; 3]>,
    /// `cmax` and `pc · cmax`.
    cmax: f32,
    pccmax: f32,
}

impl Filters {
    fn new(ppd: f32) -> Self {
        let pi_sq = PI * PI;
        // Spatial filters (the 2-D Gaussian a·(π/b)·exp(−π²r²/b) factors into
        // √(a·√(π/b))·exp(−π²x²/b) per axis; for Y and Cx the scale cancels in the
        // normalisation).
        let gauss = |x2: f32, a: f32, b: f32| a * (PI / b).sqrt() * (-pi_sq * x2 / b).exp();
        let gauss_sqrt =
            |x2: f32, a: f32, b: f32| (a * (PI / b).sqrt()).sqrt() * (-pi_sq * x2 / b).exp();
        let max_b = B1.iter().chain(&B2).copied().fold(0.0f32, f32::max);
        let radius = (3.0 * (max_b / (2.0 * pi_sq)).sqrt() * ppd).ceil() as i32;
        let delta_x = 1.0 / ppd;
        let mut yc = Vec::new();
        let mut cz = Vec::new();
        let (mut sum_yc, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
        for i in -radius..=radius {
            let x = i as f32 * delta_x;
            let x2 = x * x;
            let v_yc = [gauss(x2, A1[0], B1[0]), gauss(x2, A1[1], B1[1])];
            let v_cz = [gauss_sqrt(x2, A1[2], B1[2]), gauss_sqrt(x2, A2[2], B2[2])];
            for k in 0..2 {
                sum_yc[k] += v_yc[k];
                sum_cz[k] += v_cz[k];
            }
            yc.push(v_yc);
            cz.push(v_cz);
        }
        let norm_yc = [1.0 / sum_yc[0], 1.0 / sum_yc[1]];
        let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
        for v in &mut yc {
            *v = [v[0] * norm_yc[0], v[1] * norm_yc[1]];
        }
        for v in &mut cz {
            *v = [v[0] * norm_cz, v[1] * norm_cz];
        }

        // Feature filters: Gaussian (sums to 1), first and second derivative (positive taps
        // sum to 1, negative taps to −1).
        let sigma = 0.5 * GW * ppd;
        let fradius = (3.0 * sigma).ceil() as i32;
        let mut feature = Vec::new();
        let (mut g_sum, mut dg_pos, mut dg_neg, mut ddg_pos, mut ddg_neg) =
            (0.0f32, 0.0, 0.0, 0.0, 0.0);
        for i in -fradius..=fradius {
            let x = i as f32;
            let g = (-(x * x) / (2.0 * sigma * sigma)).exp();
            g_sum += g;
            let dg = -x * g;
            if dg > 0.0 {
                dg_pos += dg;
            } else {
                dg_neg -= dg;
            }
            let ddg = (x * x / (sigma * sigma) - 1.0) * g;
            if ddg > 0.0 {
                ddg_pos += ddg;
            } else {
                ddg_neg -= ddg;
            }
            feature.push([g, dg, ddg]);
        }
        for v in &mut feature {
            *v = [
                v[0] / g_sum,
                v[1] / if v[1] > 0.0 { dg_pos } else { dg_neg },
                v[2] / if v[2] > 0.0 { ddg_pos } else { ddg_neg },
            ];
        }

        let cmax = hyab(hunt_lab([0.0, 1.0, 0.0]), hunt_lab([0.0, 0.0, 1.0])).powf(QC);
        Self {
            yc,
            cz,
            feature,
            cmax,
            pccmax: PC * cmax,
        }
    }
}

/// Reusable buffers for one LDR-FLIP evaluation.
struct Scratch {
    ycxcz: [Vec<[f32; 3]>; 2],
    /// Horizontal pass of the spatial filter: Y, Cx, Cz part 0, Cz part 1.
    spatial: [Vec<[f32; 4]>; 2],
    /// Horizontal pass of the feature filter: d/dx, d²/dx², Gaussian.
    feature: [Vec<[f32; 3]>; 2],
    color_diff: Vec<f32>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Self {
            ycxcz: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            spatial: [vec![[0.0; 4]; n], vec![[0.0; 4]; n]],
            feature: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            color_diff: vec![0.0; n],
        }
    }
}

/// LDR-FLIP map of `test` against `reference` (linear RGB in [0, 1]) into `out`.
fn ldr_flip_into(
    reference: &[[f32; 3]],
    test: &[[f32; 3]],
    w: usize,
    h: usize,
    filters: &Filters,
    scratch: &mut Scratch,
    out: &mut [f32],
) {
    let n = w * h;
    debug_assert!(reference.len() == n && test.len() == n && out.len() == n);
    let Scratch {
        ycxcz,
        spatial,
        feature,
        color_diff,
    } = scratch;

    for (dst, src) in ycxcz.iter_mut().zip([reference, test]) {
        for (d, &s) in dst.iter_mut().zip(src) {
            *d = xyz_to_ycxcz(linear_rgb_to_xyz(s));
        }
    }

    // Spatial filtering, horizontal pass.
    let r = (filters.yc.len() / 2) as isize;
    for (dst, src) in spatial.iter_mut().zip(ycxcz.iter()) {
        for y in 0..h {
            let row = &src[y * w..(y + 1) * w];
            for x in 0..w {
                let mut acc = [0.0f32; 4];
                for (k, (wyc, wcz)) in filters.yc.iter().zip(&filters.cz).enumerate() {
                    let xx = (x as isize + k as isize - r).clamp(0, w as isize - 1) as usize;
                    let p = row[xx];
                    acc[0] += wyc[0] * p[0];
                    acc[1] += wyc[1] * p[1];
                    acc[2] += wcz[0] * p[2];
                    acc[3] += wcz[1] * p[2];
                }
                dst[y * w + x] = acc;
            }
        }
    }

    // Spatial filtering, vertical pass, then the colour difference.
    let [sr, st] = &*spatial;
    for y in 0..h {
        for x in 0..w {
            let mut fr = [0.0f32; 4];
            let mut ft = [0.0f32; 4];
            for (k, (wyc, wcz)) in filters.yc.iter().zip(&filters.cz).enumerate() {
                let yy = (y as isize + k as isize - r).clamp(0, h as isize - 1) as usize;
                let (pr, pt) = (sr[yy * w + x], st[yy * w + x]);
                fr[0] += wyc[0] * pr[0];
                fr[1] += wyc[1] * pr[1];
                fr[2] += wcz[0] * pr[2];
                fr[3] += wcz[1] * pr[3];
                ft[0] += wyc[0] * pt[0];
                ft[1] += wyc[1] * pt[1];
                ft[2] += wcz[0] * pt[2];
                ft[3] += wcz[1] * pt[3];
            }
            let to_lab = |f: [f32; 4]| {
                let rgb = xyz_to_linear_rgb(ycxcz_to_xyz([f[0], f[1], f[2] + f[3]]));
                hunt_lab(rgb.map(clamp01))
            };
            let mut d = hyab(to_lab(fr), to_lab(ft)).powf(QC);
            d = if d < filters.pccmax {
                d * (PT / filters.pccmax)
            } else {
                PT + ((d - filters.pccmax) / (filters.cmax - filters.pccmax)) * (1.0 - PT)
            };
            color_diff[y * w + x] = d;
        }
    }

    // Feature filtering, horizontal pass on the normalised achromatic channel.
    let fr = (filters.feature.len() / 2) as isize;
    const ONE_OVER_116: f32 = 1.0 / 116.0;
    const SIXTEEN_OVER_116: f32 = 16.0 / 116.0;
    for (dst, src) in feature.iter_mut().zip(ycxcz.iter()) {
        for y in 0..h {
            let row = &src[y * w..(y + 1) * w];
            for x in 0..w {
                let mut acc = [0.0f32; 3];
                for (k, f) in filters.feature.iter().enumerate() {
                    let xx = (x as isize + k as isize - fr).clamp(0, w as isize - 1) as usize;
                    let v = row[xx][0] * ONE_OVER_116 + SIXTEEN_OVER_116;
                    acc[0] += f[1] * v;
                    acc[1] += f[2] * v;
                    acc[2] += f[0] * v;
                }
                dst[y * w + x] = acc;
            }
        }
    }

    // Feature filtering, vertical pass, feature difference and the final error.
    let [fr_img, ft_img] = &*feature;
    let norm = 1.0 / 2.0f32.sqrt();
    for y in 0..h {
        for x in 0..w {
            let (mut a, mut b) = ([0.0f32; 4], [0.0f32; 4]); // dx, ddx, dy, ddy
            for (k, f) in filters.feature.iter().enumerate() {
                let yy = (y as isize + k as isize - fr).clamp(0, h as isize - 1) as usize;
                let (pr, pt) = (fr_img[yy * w + x], ft_img[yy * w + x]);
                a[0] += f[0] * pr[0];
                b[0] += f[0] * pt[0];
                a[1] += f[0] * pr[1];
                b[1] += f[0] * pt[1];
                a[2] += f[1] * pr[2];
                b[2] += f[1] * pt[2];
                a[3] += f[2] * pr[2];
                b[3] += f[2] * pt[2];
            }
            let edge_r = (a[0] * a[0] + a[2] * a[2]).sqrt();
            let edge_t = (b[0] * b[0] + b[2] * b[2]).sqrt();
            let point_r = (a[1] * a[1] + a[3] * a[3]).sqrt();
            let point_t = (b[1] * b[1] + b[3] * b[3]).sqrt();
            let edge_diff = (edge_r - edge_t).abs();
            let point_diff = (point_r - point_t).abs();
            let feature_diff = (norm * edge_diff.max(point_diff)).powf(QF);
            let i = y * w + x;
            out[i] = color_diff[i].powf(1.0 - feature_diff);
        }
    }
}
