use super::*;
use crate::gather::Grid;
use crate::gather::denoise::tests::{
    ACROSS, crate_on_floor, gather_filled, grid, plane, synthetic,
};
use crate::scene::Scene;

/// An atlas, noisy values on it (1 on faces other than the floor's front: see `level`) and
/// which texels the gather would give an estimate.
fn case(scene: &Scene, level: impl Fn(Vec3, usize) -> f32) -> (Grid, Vec<[f32; 4]>, Vec<bool>) {
    let g = grid(scene, ACROSS);
    let (e, _, _) = synthetic(scene, &g, level, 0.1, 0.05, 7);
    let filled = gather_filled(scene, &g);
    let est: Vec<bool> = (0..g.atlas.texel_count())
        .map(|t| filled[t] && g.atlas.texel_area[t] > 0.0)
        .collect();
    (g, e, est)
}

fn side_range(atlas: &BakeScene, face: usize, side: u32) -> std::ops::Range<usize> {
    let f = &atlas.faces[face];
    let base = (f.texel_base + side * f.texels_per_side()) as usize;
    base..base + f.texels_per_side() as usize
}

#[test]
fn the_fill_reaches_every_texel_keeps_the_estimates_and_stays_within_them() {
    // A 9 × 7 chart estimated only in a 2 × 2 block in one corner and on one texel of the far
    // edge: seven rings are needed, where the gather's dilation stops after two.
    let (w, h) = (9usize, 7usize);
    let mut values = vec![Vec3::ZERO; w * h];
    let mut est = vec![false; w * h];
    for (i, v) in [(0, 1.0), (1, 2.0), (w, 3.0), (w + 1, 4.0), (6 * w + 8, 0.5)] {
        values[i] = Vec3::new(v, 2.0 * v, 0.0);
        est[i] = true;
    }
    let out = fill_chart(&values, &est, w, h).expect("estimates");
    for i in 0..w * h {
        if est[i] {
            assert_eq!(out[i], values[i], "an estimate kept");
        } else {
            let v = out[i].x;
            assert!(
                (0.5..=4.0).contains(&v),
                "texel {i}: {v} outside the estimates' range"
            );
            assert_eq!(
                out[i].y,
                2.0 * v,
                "a mean of the estimates, channel by channel"
            );
        }
    }
    // The first ring: the mean of its filled neighbours (texel (2, 0) sees (1, 0) and (1, 1)).
    assert_eq!(out[2].x, (2.0 + 4.0) / 2.0);
    // Nothing estimated: nothing to show.
    assert!(fill_chart(&values, &[false; 63], w, h).is_none());
}

#[test]
fn the_packing_holds_each_chart_with_an_estimate_once_without_overlap() {
    let scene = crate_on_floor();
    let (g, _, mut est) = case(&scene, |_, _| 1.0);
    // Every side of this scene is open: take the estimates of the lid's outer side away.
    let lid = (0..g.atlas.faces.len())
        .find(|&f| g.atlas.faces[f].normal()[1].abs() > 0.9 && f != 0)
        .unwrap();
    for side in 0..2 {
        for t in side_range(&g.atlas, lid, side) {
            est[t] &= side == 0;
        }
    }
    let p = Packing::new(&g.atlas, &est, PADDING);
    let mut expected = Vec::new();
    for fi in 0..g.atlas.faces.len() {
        for side in 0..2 {
            if side_range(&g.atlas, fi, side).any(|t| est[t]) {
                expected.push((fi as u32, side));
            }
        }
    }
    let mut got: Vec<(u32, u32)> = p.charts.iter().map(|c| (c.face, c.side)).collect();
    got.sort_unstable();
    assert_eq!(got, expected);
    assert_eq!(expected.len(), 2 * g.atlas.faces.len() - 1);
    // Padded rectangles lie in the image and do not overlap.
    let rect = |c: &PackedChart| {
        let f = &g.atlas.faces[c.face as usize];
        (
            c.x - PADDING,
            c.y - PADDING,
            c.x + f.width + PADDING,
            c.y + f.height + PADDING,
        )
    };
    for (i, a) in p.charts.iter().enumerate() {
        let ra = rect(a);
        assert!(
            ra.2 <= p.width && ra.3 <= p.height,
            "chart {i} outside the image"
        );
        for b in &p.charts[i + 1..] {
            let rb = rect(b);
            let apart = ra.2 <= rb.0 || rb.2 <= ra.0 || ra.3 <= rb.1 || rb.3 <= ra.1;
            assert!(apart, "{a:?} overlaps {b:?}");
        }
    }
    assert_eq!(p, Packing::new(&g.atlas, &est, PADDING), "deterministic");
}

#[test]
fn pack_and_unpack_give_back_the_estimates_and_dilate_the_rest() {
    let scene = crate_on_floor();
    let (g, e, mut est) = case(&scene, |_, _| 1.0);
    // Texels without an estimate: a 5-texel-wide band across the floor.
    let w = g.atlas.faces[0].width as usize;
    for t in side_range(&g.atlas, 0, 0).skip(10 * w).take(5 * w) {
        est[t] = false;
    }
    let p = Packing::new(&g.atlas, &est, PADDING);
    let (image, filled) = pack(&g.atlas, &p, &e, &est);
    assert_eq!(image.len(), 3 * p.pixels());
    assert_eq!(filled, 5 * w);
    let back = unpack(&g.atlas, &p, &image, &e, &est);
    let mut dilated = e.clone();
    crate::bake::dilate_where(&g.atlas, &mut dilated, &est);
    let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(
        bits(&back) == bits(&dilated),
        "estimates as they were, the rest dilated"
    );
    // Each chart's padding repeats its border texels, and no pixel of a chart is black.
    let iw = p.width as usize;
    let px = |x: i64, y: i64| {
        let at = 3 * (y as usize * iw + x as usize);
        Vec3::from_slice(&image[at..at + 3])
    };
    for c in &p.charts {
        let f = &g.atlas.faces[c.face as usize];
        let (w, h) = (i64::from(f.width), i64::from(f.height));
        let (x0, y0) = (i64::from(c.x), i64::from(c.y));
        let pad = i64::from(PADDING);
        for y in -pad..h + pad {
            for x in -pad..w + pad {
                let v = px(x0 + x, y0 + y);
                assert!(
                    v.min_element() > 0.0,
                    "a black pixel in chart {c:?} at {x}, {y}"
                );
                let inner = px(x0 + x.clamp(0, w - 1), y0 + y.clamp(0, h - 1));
                assert_eq!(v, inner, "padding of {c:?} at {x}, {y}");
            }
        }
    }
}

#[test]
fn an_enclosed_patch_shows_the_filter_its_surroundings_not_black() {
    // The floor under a closed box (no estimate, 0 in the atlas) is as wide as 16 texels: the
    // gather's two rings of dilation leave its middle black, the packing's fill does not.
    let scene = plane();
    let (g, _, _) = case(&scene, |_, _| 1.0);
    let n = g.atlas.texel_count();
    let f = &g.atlas.faces[0];
    let under = |t: usize| {
        let i = t - f.texel_base as usize;
        let (x, y) = (i % f.width as usize, i / f.width as usize);
        (24..40).contains(&x) && (24..40).contains(&y)
    };
    let est: Vec<bool> = (0..n)
        .map(|t| t < f.texels_per_side() as usize && !under(t))
        .collect();
    let e: Vec<[f32; 4]> = (0..n)
        .map(|t| {
            if est[t] {
                [1.0, 0.5, 0.25, 0.0]
            } else {
                [0.0; 4]
            }
        })
        .collect();
    let mut dilated = e.clone();
    crate::bake::dilate_where(&g.atlas, &mut dilated, &est);
    assert!(
        (0..n).any(|t| under(t) && dilated[t][0] == 0.0),
        "the gather's dilation leaves black inside"
    );
    let p = Packing::new(&g.atlas, &est, PADDING);
    assert_eq!(p.charts.len(), 1);
    let (image, filled) = pack(&g.atlas, &p, &e, &est);
    assert_eq!(filled, 16 * 16);
    assert!(image.chunks(3).all(|px| px == [1.0, 0.5, 0.25]));
}

#[cfg(not(feature = "oidn"))]
#[test]
fn without_the_feature_oidn_is_refused_naming_the_feature() {
    use crate::lightfield::{Denoiser, ParamsError};
    let scene = plane();
    let (g, e, est) = case(&scene, |_, _| 1.0);
    let err = denoise(&g.atlas, &e, &est, 0).unwrap_err();
    assert_eq!(err, OidnError::NotBuilt);
    let msg = err.to_string();
    assert!(
        msg.contains("--denoise oidn") && msg.contains("--features oidn"),
        "{msg}"
    );
    // The parameters are refused before any bake starts, but they are valid: a file baked with
    // OIDN reads in this build.
    let mut p = crate::bake::Quality::Auto.preset().params(true);
    assert!(p.check_available().is_ok());
    p.final_gather.as_mut().unwrap().denoise = Denoiser::Oidn;
    assert!(p.validate().is_ok());
    let err = p.check_available().unwrap_err();
    assert!(matches!(
        err,
        ParamsError::Unavailable {
            name: "denoise",
            ..
        }
    ));
    assert!(
        err.to_string()
            .starts_with("denoise = oidn: this build has no"),
        "{err}"
    );
    assert!(!Denoiser::Oidn.available() && Denoiser::Edge.available());
}

/// OIDN itself (builds with the feature only, which CI does not make): white noise on a flat
/// floor drops (measured 64×: MSE 9.82e-3 → 1.54e-4), blotches on the indirect grid's 2-texel
/// lattice hardly (1.6× with white noise 0.05, 1.0× alone: printed, the comparison in
/// docs/GATHER.md), and the result does not depend on the thread count.
#[cfg(feature = "oidn")]
#[test]
fn oidn_smooths_white_noise_on_a_floor_whatever_the_thread_count() {
    let scene = plane();
    let g = grid(&scene, ACROSS);
    let est: Vec<bool> = g.atlas.texel_area.iter().map(|a| *a > 0.0).collect();
    let mse = |v: &[[f32; 4]], m: &[f32]| {
        side_range(&g.atlas, 0, 0)
            .map(|t| f64::from(v[t][0] - m[t]).powi(2))
            .sum::<f64>()
            / f64::from(g.atlas.faces[0].texels_per_side())
    };
    let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (coarse, white) in [(0.0, 0.1), (0.1, 0.05), (0.1, 0.0)] {
        let (e, m, _) = synthetic(&scene, &g, |_, _| 1.0, coarse, white, 7);
        let (one, stats) = denoise(&g.atlas, &e, &est, 1).unwrap();
        let (two, _) = denoise(&g.atlas, &e, &est, 2).unwrap();
        let (before, after) = (mse(&e, &m), mse(&one, &m));
        eprintln!(
            "OIDN, floor with blotches {coarse} and white noise {white}: MSE {before:.3e} -> \
             {after:.3e} ({:.1}x), power {:+.2e}",
            before / after,
            stats.relative_power_change()
        );
        assert!(bits(&one) == bits(&two), "1 and 2 threads differ");
        if coarse == 0.0 {
            assert!(
                before / after > 10.0,
                "white noise: MSE {before:.3e} -> {after:.3e}"
            );
        }
    }
}
