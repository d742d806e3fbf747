//! The stability suite (issue 8): scenes on which light-transport methods of this family fail
//! (painter's sort, texture filtering, fixed directions, grazing sampling, equal depths,
//! degenerate geometry, extreme scales). Each is baked with the CPU reference and measured against
//! an exact answer; every bound states the value measured when it was written and its margin.
//! The bakes are deterministic (no float atomics, fixed seeds), so the margins only have to
//! absorb f32 differences between platforms and deliberate changes to the propagator.
//! `docs/STABILITY.md` quotes the numbers printed here
//! (`cargo test -p vlf-core --test core stability:: -- --nocapture`); the GPU runs the important cases
//! in `tests/suite/stability_gpu.rs`.

use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

use crate::bakes::params;
use crate::common::base64;
use crate::scenes::{self, hrect, rect};
use glam::{DVec3, Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::Quality;
use vlf_core::bake::reference::{self, Propagated};
use vlf_core::directions::DirectionSet;
use vlf_core::gather::{Converged, Gathered, final_gather};
use vlf_core::lightfield::{BakeParams, Denoiser, GatherParams, Iterations};
use vlf_core::psf::{PsfFrame, PsfGrid, fixed_frame};
use vlf_core::scene::{Scene, SceneBuilder};

/// `emitted + injected = absorbed + escaped + unshot` to this fraction: twice the Cornell-box
/// bound of `tests/propagation.rs` (0.5 % at 126 directions × 32²): these scenes use as few as 46
/// directions. Measured here: −0.16 % to +0.44 %.
const ENERGY_BOUND: f64 = 0.01;

// ----- helpers ------------------------------------------------------------------------------

/// A propagation and its texels' outgoing radiance (`BakeScene::outgoing_radiance` of its
/// irradiance: emission + ρE/π), which most checks here are about.
struct Baked {
    out: Propagated,
    radiance: Vec<[f32; 4]>,
}

impl std::ops::Deref for Baked {
    type Target = Propagated;
    fn deref(&self) -> &Propagated {
        &self.out
    }
}

fn bake(scene: &Scene, params: &BakeParams) -> (BakeScene, DirectionSet, Baked) {
    let prep = BakeScene::new(scene, params).unwrap();
    let set = DirectionSet::at_least(params.directions).unwrap();
    let out = reference::propagate(&prep, &set, params);
    let radiance = prep.outgoing_radiance(&out.irradiance);
    (prep, set, Baked { out, radiance })
}

/// Every irradiance value finite and non-negative, every energy term finite and non-negative.
fn assert_sane(out: &Baked, what: &str) {
    for (t, l) in out.irradiance.iter().enumerate() {
        assert!(
            l.iter().all(|x| x.is_finite() && *x >= 0.0),
            "{what}: texel {t} has irradiance {l:?}"
        );
    }
    let e = &out.energy;
    for (name, x) in [
        ("emitted", e.emitted),
        ("injected", e.injected),
        ("absorbed", e.absorbed),
        ("escaped", e.escaped),
        ("unshot", e.unshot),
    ] {
        assert!(x.is_finite() && x >= 0.0, "{what}: energy {name} = {x}");
    }
}

fn assert_balanced(out: &Propagated, what: &str) {
    let imbalance = out.energy.relative_imbalance();
    assert!(
        imbalance.abs() < ENERGY_BOUND,
        "{what}: energy imbalance {:.3}% ({:?})",
        100.0 * imbalance,
        out.energy
    );
}

/// Prints how long a test took (the suite's budget is ~10 s per test in the dev profile).
struct Timer(&'static str, Instant);

impl Timer {
    fn start(name: &'static str) -> Self {
        Timer(name, Instant::now())
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        eprintln!("[{}: {:.2} s]", self.0, self.1.elapsed().as_secs_f64());
    }
}

/// The texel range of `side` (0 = front) of prepared face `face`.
fn side_range(prep: &BakeScene, face: usize, side: usize) -> std::ops::Range<usize> {
    let f = prep.faces[face];
    let n = f.texels_per_side() as usize;
    let s = f.texel_base as usize + side * n;
    s..s + n
}

/// Fully covered texels of `side` of `face`, with their world-space sample points.
fn full_texels(prep: &BakeScene, scene: &Scene, face: usize, side: usize) -> Vec<(usize, DVec3)> {
    let full = 0.999 * prep.texel_size * prep.texel_size;
    side_range(prep, face, side)
        .filter(|&t| prep.texel_area[t] >= full)
        .map(|t| {
            let p = (scene.to_vlf).inverse(Vec4::from(prep.texel_center[t]).truncate());
            (t, p.as_dvec3())
        })
        .collect()
}

/// The face whose normal is within 8° of `n` and whose centroid is closest to `at`.
fn face_near(scene: &Scene, n: Vec3, at: Vec3) -> usize {
    let dist = |f: usize| {
        let tris = scene.face_triangles(f);
        let c = tris.iter().map(|t| t.centroid()).sum::<Vec3>() / tris.len() as f32;
        (c - at).length()
    };
    (0..scene.faces.len())
        .filter(|&f| scene.faces[f].normal.dot(n) > 0.99)
        .min_by(|&a, &b| dist(a).total_cmp(&dist(b)))
        .expect("a face with that normal")
}

/// The first face made of material `name`.
fn face_of(scene: &Scene, name: &str) -> usize {
    (scene.faces.iter())
        .position(|f| scene.materials[f.material as usize].name == name)
        .unwrap_or_else(|| panic!("no face of material {name}"))
}

/// Form factor from a differential area at `p` (unit normal `n`) to the planar polygon `poly`
/// (Lambert's contour integral; exact when the polygon lies entirely in front of `p`).
fn ff_polygon(p: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let a = (poly[i] - p).normalize();
        let b = (poly[(i + 1) % poly.len()] - p).normalize();
        let c = a.cross(b);
        let len = c.length();
        if len > 0.0 {
            sum += len.atan2(a.dot(b)) * n.dot(c / len);
        }
    }
    (sum / (2.0 * std::f64::consts::PI)).abs()
}

/// Per-texel relative errors of the red channel against `want(p)`: (mean, max, error of the
/// sum over the texels).
fn texel_errors(
    out: &Baked,
    texels: &[(usize, DVec3)],
    want: impl Fn(DVec3) -> f64,
) -> (f64, f64, f64) {
    let (mut sum, mut max, mut got_total, mut want_total) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(t, p) in texels {
        let (g, w) = (f64::from(out.radiance[t][0]), want(p));
        sum += (g - w).abs() / w;
        max = max.max((g - w).abs() / w);
        got_total += g;
        want_total += w;
    }
    let total = (got_total - want_total) / want_total;
    (sum / texels.len() as f64, max, total)
}

/// (area-weighted mean, max) relative difference of two radiance arrays over covered texels
/// whose radiance in `a` exceeds `floor`.
fn difference(prep: &BakeScene, a: &[[f32; 4]], b: &[[f32; 4]], floor: f32) -> (f64, f64) {
    let (mut sum, mut area, mut max) = (0f64, 0f64, 0f64);
    for t in 0..a.len() {
        let (x, y) = (Vec4::from(a[t]), Vec4::from(b[t]));
        if prep.texel_area[t] <= 0.0 || x.max_element() <= floor {
            continue;
        }
        let r = f64::from((x - y).abs().max_element() / x.max_element());
        sum += r * f64::from(prep.texel_area[t]);
        area += f64::from(prep.texel_area[t]);
        max = max.max(r);
    }
    (sum / area, max)
}

// ----- 1. cyclic overlaps and interpenetrating faces ------------------------------------------

/// Three long tilted sticks around a triangle: stick i lies above stick i+1 where they cross
/// (heights ±slope·r√3), so "above" is a 3-cycle and no painter's order of them exists.
fn add_cyclic_sticks(b: &mut SceneBuilder, m: u32) {
    let (r, half_len, width, slope) = (0.3f32, 0.8f32, 0.12f32, 0.15f32);
    for i in 0..3 {
        let th = i as f32 * 2.0 * std::f32::consts::PI / 3.0;
        let perp = Vec3::new(th.cos(), 0.0, th.sin());
        let dir = Vec3::new(-th.sin(), slope, th.cos());
        let o = perp * r - dir * half_len - perp * (0.5 * width);
        let (along, across) = (dir * (2.0 * half_len), perp * width);
        if along.cross(across).y > 0.0 {
            rect(b, o, along, across, m);
        } else {
            rect(b, o, across, along, m);
        }
    }
}

/// Two quads crossing each other along x = 0 (planes y = ±0.5·x), at z ∈ [0.55, 0.95].
fn add_crossed_quads(b: &mut SceneBuilder, m1: u32, m2: u32) {
    for (s, m) in [(0.5f32, m1), (-0.5, m2)] {
        let o = Vec3::new(-0.4, -0.4 * s, 0.55);
        let (along, across) = (Vec3::new(0.8, 0.8 * s, 0.0), Vec3::new(0.0, 0.0, 0.4));
        if along.cross(across).y > 0.0 {
            rect(b, o, along, across, m);
        } else {
            rect(b, o, across, along, m);
        }
    }
}

/// Faces 0–2: the sticks; 3–4: the crossed quads; lit: a floor and an emitter above.
fn tangle_scene(lit: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.7, 0.2, 0.2), Vec3::ZERO);
    let green = b.diffuse("green", Vec3::new(0.2, 0.7, 0.2), Vec3::ZERO);
    add_cyclic_sticks(&mut b, white);
    add_crossed_quads(&mut b, red, green);
    if lit {
        let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(5.0));
        hrect(&mut b, 0.6, (-0.3, 0.3), (-0.3, 0.3), false, light);
        hrect(&mut b, -0.5, (-1.0, 1.0), (-1.0, 1.2), true, white);
    }
    b.build("tangle")
}

/// Exact ray casting in f64 against every triangle (no binning, no f32): per cell, the faces
/// crossed sorted by depth, and whether the cell is ambiguous at f32 precision (its ray passes
/// within 1e-6 of a face's outline, or two of its crossings are within 1e-6 in depth).
fn brute_force_lists(prep: &BakeScene, grid: &PsfGrid, frame: &PsfFrame) -> Vec<(Vec<u32>, bool)> {
    const EPS: f64 = 1e-6;
    let (u, v, w) = (frame.u.as_dvec3(), frame.v.as_dvec3(), frame.w.as_dvec3());
    let tris: Vec<[DVec3; 3]> = (prep.triangles.iter())
        .map(|t| [t.p0, t.p1, t.p2].map(|p| Vec3::from(p).as_dvec3()))
        .collect();
    // Outline edges: edges not shared by two triangles of the same face.
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let edge = |face: u32, a: DVec3, b: DVec3| (face, key(a).min(key(b)), key(a).max(key(b)));
    let mut edge_count: HashMap<(u32, [u64; 3], [u64; 3]), u32> = HashMap::new();
    for (t, tri) in prep.triangles.iter().zip(&tris) {
        for k in 0..3 {
            *edge_count
                .entry(edge(t.face, tri[k], tri[(k + 1) % 3]))
                .or_default() += 1;
        }
    }
    // Per triangle, per corner k: whether the edge opposite k is on the face's outline.
    let outline: Vec<[bool; 3]> = (prep.triangles.iter().zip(&tris))
        .map(|(t, tri)| {
            [0, 1, 2].map(|k| edge_count[&edge(t.face, tri[(k + 1) % 3], tri[(k + 2) % 3])] == 1)
        })
        .collect();
    let proj: Vec<[(f64, f64, f64); 3]> = (tris.iter())
        .map(|tri| tri.map(|p| (p.dot(u), p.dot(v), p.dot(w))))
        .collect();
    let mut out = Vec::with_capacity((grid.n * grid.n) as usize);
    for j in 0..grid.n {
        for i in 0..grid.n {
            let (pa, pb) = grid.cell_center(i, j);
            let (pa, pb) = (f64::from(pa), f64::from(pb));
            let mut hits: Vec<(f64, u32)> = Vec::new();
            let mut ambiguous = false;
            for (ti, t) in prep.triangles.iter().enumerate() {
                let q = proj[ti];
                let cross = |a: (f64, f64, f64), b: (f64, f64, f64)| {
                    (a.0 - pa) * (b.1 - pb) - (b.0 - pa) * (a.1 - pb)
                };
                let area =
                    (q[1].0 - q[0].0) * (q[2].1 - q[0].1) - (q[2].0 - q[0].0) * (q[1].1 - q[0].1);
                if area == 0.0 {
                    continue;
                }
                let wgt = [0, 1, 2].map(|k| cross(q[(k + 1) % 3], q[(k + 2) % 3]) / area);
                for k in 0..3 {
                    let (a, b) = (q[(k + 1) % 3], q[(k + 2) % 3]);
                    let dist = (wgt[k] * area).abs() / (b.0 - a.0).hypot(b.1 - a.1);
                    let within = wgt[(k + 1) % 3] >= -EPS && wgt[(k + 2) % 3] >= -EPS;
                    ambiguous |= outline[ti][k] && within && dist < EPS;
                }
                if wgt.iter().all(|&x| x >= 0.0) && !hits.iter().any(|h| h.1 == t.face) {
                    hits.push((wgt[0] * q[0].2 + wgt[1] * q[1].2 + wgt[2] * q[2].2, t.face));
                }
            }
            hits.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            ambiguous |= hits.windows(2).any(|p| p[1].0 - p[0].0 < EPS);
            out.push((hits.iter().map(|h| h.1).collect(), ambiguous));
        }
    }
    out
}

/// The faces of cell `c`'s list, in depth order.
fn cell_faces(lists: &reference::CellLists, c: usize) -> Vec<u32> {
    let range = lists.start[c] as usize..lists.start[c + 1] as usize;
    lists.entries[range].iter().map(|e| e.1).collect()
}

/// Whether "in front of along +w" among `subset`'s faces, collected over all rays of one
/// direction, has a cycle: then no per-direction painter's order of those faces exists.
fn precedence_has_cycle(lists: &reference::CellLists, subset: &[u32]) -> bool {
    let k = subset.len();
    let mut edges = vec![vec![false; k]; k];
    for c in 0..lists.start.len() - 1 {
        let order: Vec<usize> = (cell_faces(lists, c).iter())
            .filter_map(|f| subset.iter().position(|s| s == f))
            .collect();
        for p in order.windows(2) {
            edges[p[0]][p[1]] = true;
        }
    }
    // Kahn's algorithm: nodes left over lie on (or behind) a cycle.
    let mut indeg: Vec<usize> = (0..k)
        .map(|t| (0..k).filter(|&s| edges[s][t]).count())
        .collect();
    let mut ready: Vec<usize> = (0..k).filter(|&f| indeg[f] == 0).collect();
    let mut done = 0;
    while let Some(f) = ready.pop() {
        done += 1;
        for t in 0..k {
            if edges[f][t] {
                indeg[t] -= 1;
                if indeg[t] == 0 {
                    ready.push(t);
                }
            }
        }
    }
    done < k
}

#[test]
fn cyclic_overlaps_and_interpenetration_give_exact_depth_lists() {
    let _t = Timer::start("cyclic overlaps: lists");
    let scene = tangle_scene(false);
    let p = params(46, 64, Iterations::Fixed(1));
    let prep = BakeScene::new(&scene, &p).unwrap();
    assert_eq!(prep.faces.len(), 5, "three sticks and two crossed quads");
    let set = DirectionSet::at_least(p.directions).unwrap();
    let grid = PsfGrid::new(p.resolution, p.tile).unwrap();
    // Every fixed direction and one perturbed copy of each (arbitrary frames).
    let mut frames: Vec<PsfFrame> = (0..set.len()).map(|i| fixed_frame(&set, i)).collect();
    let jittered = BakeParams {
        perturb: 1,
        ..p.clone()
    };
    frames.extend(
        reference::transport_directions(&set, &jittered)
            .iter()
            .map(|d| d.frame),
    );
    let (mut rays, mut crossings, mut ambiguous, mut mismatched) = (0, 0, 0, 0);
    let (mut cyclic_sticks, mut cyclic_crossed) = (0, 0);
    for frame in &frames {
        let lists = reference::build_cell_lists(&prep, &grid, frame);
        for (c, (want, amb)) in brute_force_lists(&prep, &grid, frame).iter().enumerate() {
            let got = cell_faces(&lists, c);
            rays += 1;
            crossings += got.len();
            if *amb {
                ambiguous += 1;
            } else if &got != want {
                mismatched += 1;
                eprintln!("cell {c}: lists {got:?}, exact ray casting {want:?}");
            }
        }
        cyclic_sticks += usize::from(precedence_has_cycle(&lists, &[0, 1, 2]));
        cyclic_crossed += usize::from(precedence_has_cycle(&lists, &[3, 4]));
    }
    eprintln!(
        "tangle: {rays} rays in {} directions, {crossings} crossings: {mismatched} differ from exact ray casting, {ambiguous} ambiguous at f32 precision (skipped); no painter's order exists for the sticks in {cyclic_sticks} directions, for the crossed quads in {cyclic_crossed}",
        frames.len()
    );
    // Exact agreement. Measured: 0 mismatches; 2 of 376 832 rays ambiguous (bound 100, so the
    // skip cannot hide a systematic error).
    assert_eq!(mismatched, 0);
    assert!(ambiguous < 100, "{ambiguous} ambiguous rays");
    // The scene really defeats a painter's sort. Measured: sticks cyclic in 43 of 92 directions
    // (those looking roughly down or up), crossed quads in 89 of 92.
    assert!(
        cyclic_sticks >= 20 && cyclic_crossed >= 80,
        "{cyclic_sticks}, {cyclic_crossed}"
    );
}

#[test]
fn cyclic_overlaps_bake_sanely() {
    let _t = Timer::start("cyclic overlaps: bake");
    let (_, _, out) = bake(&tangle_scene(true), &params(126, 64, Iterations::Fixed(3)));
    assert_sane(&out, "tangle");
    eprintln!(
        "tangle bake: imbalance {:+.3}%",
        100.0 * out.energy.relative_imbalance()
    );
    // Measured: −0.16 %.
    assert_balanced(&out, "tangle");
}

// ----- 2. light leaks ---------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq)]
enum Crate {
    /// A closed box whose bottom lies in the floor's plane (two faces back to back).
    Closed,
    /// The closed box lifted by this much (world units; the room is 2 wide).
    Lifted(f32),
    /// Side walls and a lid only, standing on the floor (the floor is its inside bottom).
    Bottomless,
}

/// A lit room `[-1, 1] × [0, 2] × [-1, 1]` with a 0.6 × 0.6 × 0.6 box standing on its floor.
/// Faces: the box's outward faces carry material 1.
fn box_on_floor_scene(kind: Crate) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let crate_m = b.diffuse("box", Vec3::splat(0.7), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(10.0));
    b.aabox(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, 1.0),
        true,
        white,
    );
    hrect(&mut b, 1.98, (-0.3, 0.3), (-0.3, 0.3), false, light);
    let lift = if let Crate::Lifted(h) = kind { h } else { 0.0 };
    let (lo, hi) = (Vec3::new(-0.3, lift, -0.3), Vec3::new(0.3, 0.6, 0.3));
    if kind == Crate::Bottomless {
        let (dx, dy, dz) = (Vec3::X * 0.6, Vec3::Y * (0.6 - lift), Vec3::Z * 0.6);
        rect(&mut b, lo, dz, dy, crate_m); // −x
        rect(&mut b, lo + dx, dy, dz, crate_m); // +x
        rect(&mut b, lo, dy, dx, crate_m); // −z
        rect(&mut b, lo + dz, dx, dy, crate_m); // +z
        rect(&mut b, lo + dy, dz, dx, crate_m); // lid, +y
    } else {
        b.aabox(lo, hi, false, crate_m);
    }
    b.build("box on floor")
}

/// (max inside radiance / mean outside radiance, inside power / outside power) of the box's
/// faces (material 1) in `radiance` over `atlas` (side 1 faces into the box; the bottom's outer
/// side faces the floor and is skipped).
fn box_leak_ratios(scene: &Scene, atlas: &BakeScene, radiance: &[[f32; 4]]) -> (f64, f64) {
    let (mut in_max, mut in_pow, mut out_pow, mut out_area) = (0f64, 0f64, 0f64, 0f64);
    for (fi, f) in scene.faces.iter().enumerate() {
        if f.material != 1 {
            continue;
        }
        for side in 0..2 {
            for t in side_range(atlas, fi, side) {
                let a = f64::from(atlas.texel_area[t]);
                let l = f64::from(Vec4::from(radiance[t]).max_element());
                if side == 1 {
                    in_max = in_max.max(l);
                    in_pow += l * a;
                } else if f.normal.y > -0.5 {
                    out_pow += l * a;
                    out_area += a;
                }
            }
        }
    }
    (in_max / (out_pow / out_area), in_pow / out_pow)
}

/// (max inside radiance / mean outside radiance, inside power / outside power) of the box's
/// faces (side 1 faces into the box; the bottom's outer side faces the floor and is skipped).
fn box_leak(kind: Crate, resolution: u32, texel_scale: f32) -> (f64, f64) {
    let scene = box_on_floor_scene(kind);
    let p = BakeParams {
        texel_scale,
        ..params(46, resolution, Iterations::Fixed(3))
    };
    let (prep, _, out) = bake(&scene, &p);
    assert_sane(&out, "box on floor");
    // Closed room: measured +1.5 % at N = 32 (with or without the contact; ray aliasing of
    // the room itself), within ±0.34 % at N ≥ 64. Bound 2 %.
    let imbalance = out.energy.relative_imbalance();
    assert!(imbalance.abs() < 0.02, "imbalance {imbalance}");
    let r = box_leak_ratios(&scene, &prep, &out.radiance);
    eprintln!(
        "box on floor, {kind:?}, N = {resolution}, texel scale {texel_scale}: inside max / outside mean {:.2e}, inside / outside power {:.2e}",
        r.0, r.1
    );
    r
}

#[test]
fn box_standing_on_a_floor_stays_dark_inside_up_to_texel_scale_bleeding() {
    let _t = Timer::start("box on floor");
    // Not touching (even by 1e-5 of a 2-unit room, 1/5000 of a cell at N = 64): exactly dark.
    let (max, _) = box_leak(Crate::Lifted(1e-5), 64, 1.0);
    assert_eq!(max, 0.0, "lifted box");
    // Touching: texel-scale leaks. Measured (inside max / outside mean, power ratio):
    //   closed box (bottom back to back with the floor):
    //     N = 32: 1.41e-2, 1.54e-3   N = 64: 8.62e-3, 5.44e-4   N = 128: 7.32e-3, 2.33e-4
    //   bottomless box (its walls stand on the floor face):
    //     N = 32: 2.00e-2, 2.92e-3   N = 64: 1.25e-2, 1.07e-3   N = 128: 1.15e-2, 5.03e-4
    // The leaked power falls 2.1–2.8× with every halving of the texel; the peak falls more
    // slowly (it sits in the texel row at the contact). Bounds: peak < 3 %, power ratio
    // < 4e-3 and falling by ≥ 1.6× per halving.
    for kind in [Crate::Closed, Crate::Bottomless] {
        let mut last = f64::INFINITY;
        for n in [32, 64, 128] {
            let (max, power) = box_leak(kind, n, 1.0);
            assert!(
                max < 0.03 && power < 4e-3,
                "{kind:?} N = {n}: {max:.2e}, {power:.2e}"
            );
            assert!(
                power * 1.6 < last,
                "{kind:?} N = {n}: leak {power:.2e} after {last:.2e}"
            );
            last = power;
        }
    }
    // Texels smaller or larger than the ray spacing (N = 64). Measured (closed box): texel
    // scale 0.5 → 8.87e-3, 6.22e-4; 2 → 1.11e-2, 1.11e-3: finer texels alone do not help, the
    // ray spacing matters as much.
    for ts in [0.5, 2.0] {
        let (max, power) = box_leak(Crate::Closed, 64, ts);
        assert!(
            max < 0.03 && power < 4e-3,
            "texel scale {ts}: {max:.2e}, {power:.2e}"
        );
    }
}

/// A closed room `[-1, 1] × [-0.5, 0.5]²` cut in two by a wall at x = 0 that stops `gap` below
/// the ceiling, lit in the left half. The halves use distinct materials, so no face spans both
/// halves. `needles` triangulates the wall with two needle triangles (aspect ratio > 1e4).
fn split_room_scene(gap: f32, needles: bool) -> Scene {
    split_room_scene_with(gap, needles, false)
}

/// [`split_room_scene`], with `shared_floor` one floor face of material `floor` running on
/// under the wall (the wall stands on it: a contact across which the halves meet in one chart).
fn split_room_scene_with(gap: f32, needles: bool, shared_floor: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let left = b.diffuse("left", Vec3::splat(0.7), Vec3::ZERO);
    let right = b.diffuse("right", Vec3::splat(0.7), Vec3::ZERO);
    let wall = b.diffuse("wall", Vec3::splat(0.7), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(10.0));
    let (h, d) = (0.5f32, 0.5f32);
    let (up, deep) = (Vec3::Y * (2.0 * h), Vec3::Z * (2.0 * d));
    if shared_floor {
        let floor = b.diffuse("floor", Vec3::splat(0.7), Vec3::ZERO);
        hrect(&mut b, -h, (-1.0, 1.0), (-d, d), true, floor);
    }
    for (m, x0) in [(left, -1.0f32), (right, 0.0f32)] {
        let along = Vec3::X;
        if !shared_floor {
            hrect(&mut b, -h, (x0, x0 + 1.0), (-d, d), true, m);
        }
        hrect(&mut b, h, (x0, x0 + 1.0), (-d, d), false, m);
        rect(&mut b, Vec3::new(x0, -h, -d), along, up, m); // facing +z
        rect(&mut b, Vec3::new(x0, -h, d), up, along, m); // facing −z
        if m == left {
            rect(&mut b, Vec3::new(-1.0, -h, -d), up, deep, m); // facing +x
        } else {
            rect(&mut b, Vec3::new(1.0, -h, -d), deep, up, m); // facing −x
        }
    }
    // The wall at x = 0, facing −x (towards the light), spanning y ∈ [−h, h − gap].
    let at = |z: f32, y: f32| Vec3::new(0.0, y, z);
    let mut tri = |p: [Vec3; 3]| {
        let facing_light = (p[1] - p[0]).cross(p[2] - p[0]).x < 0.0;
        b.triangle(if facing_light { p } else { [p[0], p[2], p[1]] }, wall);
    };
    let (a, bb, c, dd) = (at(-d, -h), at(d, -h), at(d, h - gap), at(-d, h - gap));
    if needles {
        // P lies 1e-4 above the bottom edge: A B P is a needle along the edge. Q lies 1e-4 off
        // the segment P C, inside P C D: P Q C is a needle across the wall.
        let p = at(0.0, -h + 1e-4);
        let (pc, pd) = (c - p, dd - p);
        let off = (pd - pc * (pd.dot(pc) / pc.length_squared())).normalize();
        let q = p + pc * 0.5 + off * 1e-4;
        for t in [
            [a, bb, p],
            [p, bb, c],
            [p, q, c],
            [p, dd, q],
            [q, dd, c],
            [p, a, dd],
        ] {
            tri(t);
        }
    } else {
        tri([a, bb, c]);
        tri([a, c, dd]);
    }
    hrect(&mut b, h - 0.02, (-0.7, -0.3), (-0.2, 0.2), false, light);
    b.build("split room")
}

/// Max radiance over the dark half (both sides of its faces) and the wall's dark side.
fn split_room_dark(scene: &Scene, prep: &BakeScene, out: &Baked) -> f32 {
    split_room_dark_values(scene, prep, &out.radiance)
}

/// [`split_room_dark`] of outgoing radiance `values` over `prep`'s texels.
fn split_room_dark_values(scene: &Scene, prep: &BakeScene, values: &[[f32; 4]]) -> f32 {
    let mut dark = 0.0f32;
    for (fi, f) in scene.faces.iter().enumerate() {
        let sides: &[usize] = match scene.materials[f.material as usize].name.as_str() {
            "right" => &[0, 1],
            "wall" => &[1], // the wall faces −x: its back faces the dark half
            _ => &[],
        };
        for &s in sides {
            for t in side_range(prep, fi, s) {
                dark = dark.max(Vec4::from(values[t]).max_element());
            }
        }
    }
    dark
}

#[test]
fn thin_wall_across_a_closed_room_passes_no_light() {
    let _t = Timer::start("thin wall");
    let p = params(126, 64, Iterations::Fixed(4));
    let scene = split_room_scene(0.0, false);
    let (prep, set, out) = bake(&scene, &p);
    assert_sane(&out, "split room");
    let dark = split_room_dark(&scene, &prep, &out);
    // With a gap under the ceiling light gets round the wall: the measurement can see it.
    let gap_scene = split_room_scene(0.1, false);
    let (gap_prep, gap_set, gap_out) = bake(&gap_scene, &p);
    let dark_gap = split_room_dark(&gap_scene, &gap_prep, &gap_out);
    // The same with the final gather.
    let gathered_dark = |scene: &Scene, baked: (&BakeScene, &DirectionSet, &Propagated)| {
        let g = gather(scene, baked, &p, &gather_params(16, 64));
        split_room_dark_values(scene, &g.atlas, &gathered_radiance(&g))
    };
    let g_dark = gathered_dark(&scene, (&prep, &set, &out));
    let g_dark_gap = gathered_dark(&gap_scene, (&gap_prep, &gap_set, &gap_out));
    eprintln!(
        "thin wall with the gather: dark half max radiance {g_dark:e} (with a 0.1 gap: {g_dark_gap:.4})"
    );
    // Exactly zero: gather rays and shadow rays start on their own side of the wall. Measured:
    // 0 (with the gap: 0.179).
    assert_eq!(g_dark, 0.0);
    assert!(g_dark_gap > 0.01, "light must get round a wall with a gap");
    eprintln!(
        "thin wall: dark half max radiance {dark:e} (with a 0.1 gap: {dark_gap:.4}), imbalance {:+.3}%",
        100.0 * out.energy.relative_imbalance()
    );
    // Exactly zero: every ray lists the wall, so nothing crosses it. Measured: 0 (with the gap:
    // 0.136). Energy measured: +0.44 %.
    assert_eq!(dark, 0.0);
    assert!(dark_gap > 0.01, "light must get round a wall with a gap");
    assert_balanced(&out, "split room");
}

// ----- 2a / 2b with the final gather -----------------------------------------------------------

/// The final gather of a propagation, texel sizes relative to the ray spacing as in a bake.
fn gather(
    scene: &Scene,
    (prep, set, out): (&BakeScene, &DirectionSet, &Propagated),
    p: &BakeParams,
    gp: &GatherParams,
) -> Gathered {
    let field = Converged {
        prep,
        irradiance: &out.irradiance,
        first_bounce: out.first_bounce.as_deref(),
        tiles: out.tiles.as_ref().map(|(i, v)| (i, v.as_slice())),
        directions: set,
        sky: p.sky,
        ray_spacing: 2.0 / p.resolution as f32,
    };
    final_gather(scene, &field, gp, 0).unwrap()
}

/// Gather settings of these cases: stored texels half the ray spacing, indirect grid one ray
/// spacing (the defaults), fewer samples than a bake's.
fn gather_params(light_samples: u32, indirect_rays: u32) -> GatherParams {
    crate::bakes::fixed_gather(
        0.5,
        1.0,
        [light_samples, light_samples.div_ceil(4), indirect_rays],
    )
}

/// Outgoing radiance of a gathered atlas (L_e + ρ·E/π, what the renderer shows).
fn gathered_radiance(g: &Gathered) -> Vec<[f32; 4]> {
    g.atlas.outgoing_radiance(&g.irradiance)
}

/// Case 2a with the final gather: (max inside radiance / mean outside, inside / outside power)
/// of the box's faces in the gathered atlas, as [`box_leak`] measures the light field.
fn box_leak_gathered(kind: Crate, resolution: u32) -> (f64, f64) {
    let scene = box_on_floor_scene(kind);
    let p = params(46, resolution, Iterations::Fixed(3));
    let (prep, set, out) = bake(&scene, &p);
    let g = gather(&scene, (&prep, &set, &out), &p, &gather_params(16, 64));
    let radiance = gathered_radiance(&g);
    let r = box_leak_ratios(&scene, &g.atlas, &radiance);
    eprintln!(
        "box on floor with the gather, {kind:?}, N = {resolution}: inside max / outside mean {:.2e}, inside / outside power {:.2e}; gather {:+.3}% against the propagation",
        r.0,
        r.1,
        100.0 * g.stats.relative_difference()
    );
    r
}

#[test]
fn box_on_a_floor_with_the_gather_stays_dark_inside() {
    let _t = Timer::start("box on floor, gathered");
    // Bounds: the light field's own leak (`box_leak`, the figures docs/STABILITY.md gave for
    // case 2a before the gather), as issue 14 asks: "no worse than today". Measured (inside
    // max / outside mean, power ratio):
    //   closed:     N = 32: 2.42e-3, 7.62e-4   N = 64: 1.15e-3, 1.77e-4   N = 128: 2.37e-3, 9.00e-5
    //   bottomless: N = 32: 4.94e-3, 1.46e-3   N = 64: 1.75e-3, 3.36e-4   N = 128: 3.51e-3, 1.77e-4
    // With plain bilinear reads of the field (before `Contacts`) the gather leaked two to four
    // times the light field: closed N = 32 2.96e-2, 4.60e-3; bottomless N = 32 5.28e-2, 7.98e-3.
    for (kind, today) in [
        (
            Crate::Closed,
            [(1.41e-2, 1.54e-3), (8.62e-3, 5.44e-4), (7.32e-3, 2.33e-4)],
        ),
        (
            Crate::Bottomless,
            [(2.00e-2, 2.92e-3), (1.25e-2, 1.07e-3), (1.15e-2, 5.03e-4)],
        ),
    ] {
        for (n, (b_max, b_power)) in [32, 64, 128].into_iter().zip(today) {
            let (max, power) = box_leak_gathered(kind, n);
            assert!(
                max < b_max && power < b_power,
                "{kind:?}, N = {n}: {max:.2e}, {power:.2e} against today's {b_max:.2e}, {b_power:.2e}"
            );
        }
    }
}

// ----- 2a / 2b with the atlas denoisers (issue 24) ---------------------------------------------

/// A leak after the gather and a denoiser: the dark region's largest outgoing radiance over the
/// lit region's mean, and the ratio of their powers (Σ L·area).
#[derive(Clone, Copy, Debug)]
struct Leak {
    max: f64,
    power: f64,
}

impl std::fmt::Display for Leak {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "max {:.3e}, power {:.3e}", self.max, self.power)
    }
}

/// Texels of a dark and a lit region: (largest value, power) and (area, power).
#[derive(Default)]
struct Regions {
    dark: (f64, f64),
    lit: (f64, f64),
}

impl Regions {
    fn add(&mut self, l: [f32; 4], area: f32, dark: bool) {
        let (v, a) = (f64::from(Vec4::from(l).max_element()), f64::from(area));
        if dark {
            self.dark = (self.dark.0.max(v), self.dark.1 + v * a);
        } else {
            self.lit = (self.lit.0 + a, self.lit.1 + v * a);
        }
    }

    fn leak(&self) -> Leak {
        Leak {
            max: self.dark.0 / (self.lit.1 / self.lit.0),
            power: self.dark.1 / self.lit.1,
        }
    }
}

/// The gather of these cases sampled as a default bake samples (guided, adaptive), so that
/// every denoiser filters the same estimates.
fn denoised_params(denoise: Denoiser) -> GatherParams {
    GatherParams {
        sampling: Quality::Auto.preset().gather.sampling,
        denoise,
        ..gather_params(16, 64)
    }
}

/// Case 2a (N = 32) after the gather and each of `denoisers`: the leak into a box standing on
/// the floor, as [`box_leak_gathered`] measures it (dark: the box's inner faces; lit: its outer
/// faces). The floor under the box is enclosed (the box is a solid: its faces face out), holds
/// no estimate and is not measured.
fn box_leaks_denoised(kind: Crate, denoisers: &[Denoiser]) -> Vec<Leak> {
    let scene = box_on_floor_scene(kind);
    let p = params(46, 32, Iterations::Fixed(3));
    let (prep, set, out) = bake(&scene, &p);
    let mut leaks = Vec::new();
    for &d in denoisers {
        let g = gather(&scene, (&prep, &set, &out), &p, &denoised_params(d));
        let l = gathered_radiance(&g);
        let mut r = Regions::default();
        for (fi, f) in scene.faces.iter().enumerate() {
            for side in 0..2 {
                for t in side_range(&g.atlas, fi, side) {
                    if f.material == 1 && (side == 1 || f.normal.y > -0.5) {
                        r.add(l[t], g.atlas.texel_area[t], side == 1);
                    }
                }
            }
        }
        leaks.push(r.leak());
    }
    leaks
}

/// Case 2b (126 directions, N = 32, 4 iterations) after the gather and each of `denoisers`:
/// with the halves' own faces, the dark half's largest radiance ([`split_room_dark_values`])
/// over the mean of the lit half's floor;
/// with one floor running on under the wall, the leak into the floor's dark half (x > 0; lit
/// region its other half), and the same beyond two texels of the wall.
fn split_room_leaks_denoised(denoisers: &[Denoiser]) -> Vec<(f32, Leak, Leak)> {
    let p = params(126, 32, Iterations::Fixed(4));
    let apart = split_room_scene(0.0, false);
    let (prep, set, out) = bake(&apart, &p);
    let one = split_room_scene_with(0.0, false, true);
    let (one_prep, one_set, one_out) = bake(&one, &p);
    let floor = face_of(&one, "floor");
    let lit_floor = face_near(&apart, Vec3::Y, Vec3::new(-0.5, -0.5, 0.0));
    let mut leaks = Vec::new();
    for &d in denoisers {
        let g = gather(&apart, (&prep, &set, &out), &p, &denoised_params(d));
        let l = gathered_radiance(&g);
        let mut r = Regions::default();
        for t in side_range(&g.atlas, lit_floor, 0) {
            r.add(l[t], g.atlas.texel_area[t], false);
        }
        let dark_apart = split_room_dark_values(&apart, &g.atlas, &l) / (r.lit.1 / r.lit.0) as f32;
        let g = gather(
            &one,
            (&one_prep, &one_set, &one_out),
            &p,
            &denoised_params(d),
        );
        let l = gathered_radiance(&g);
        let texel = g.atlas.texel_size / one.to_vlf.scale;
        let (mut all, mut far) = (Regions::default(), Regions::default());
        for side in 0..2 {
            for t in side_range(&g.atlas, floor, side) {
                let c = Vec4::from(g.atlas.texel_center[t]).truncate();
                let x = one.to_vlf.inverse(c).x;
                all.add(l[t], g.atlas.texel_area[t], x > 0.0);
                if x < 0.0 || x > 2.0 * texel {
                    far.add(l[t], g.atlas.texel_area[t], x > 0.0);
                }
            }
        }
        leaks.push((dark_apart, all.leak(), far.leak()));
    }
    leaks
}

#[test]
fn the_atlas_denoiser_leaks_nothing_across_a_contact_or_a_thin_wall() {
    let _t = Timer::start("2a / 2b denoised");
    let ds = [Denoiser::Off, Denoiser::Edge];
    let boxes = [Crate::Closed, Crate::Bottomless].map(|k| (k, box_leaks_denoised(k, &ds)));
    let split = split_room_leaks_denoised(&ds);
    for (k, l) in &boxes {
        eprintln!(
            "box on a floor, {k:?}, N = 32, gathered: denoiser off {}, on {}",
            l[0], l[1]
        );
    }
    for (name, (apart, one, far)) in ["off", "on"].iter().zip(&split) {
        eprintln!(
            "split room, N = 32, denoiser {name}: dark half max {apart:e}; one floor under the \
             wall: dark half {one}, beyond 2 texels {far}"
        );
    }
    // A filtered texel is a convex combination of texels whose centroids it sees on its own
    // plane (texels without an estimate: of their chart's neighbours, as without the filter),
    // so a dark region's largest value cannot grow: the box's inner faces, the floor's dark
    // half (its texels see no texel of the lit half), and the dark half of the split room,
    // exactly 0 without the filter, stays exactly 0. Measured (off / on): both boxes 0 / 0,
    // the split room 0 / 0, the dark half of the floor under the wall 0.1169 / 0.1167.
    for (k, l) in &boxes {
        assert!(l[1].max <= l[0].max, "{k:?}: {:?} after {:?}", l[1], l[0]);
    }
    assert!(
        split[1].1.max <= split[0].1.max,
        "{:?} after {:?}",
        split[1].1,
        split[0].1
    );
    assert_eq!((split[0].0, split[1].0), (0.0, 0.0));
}

/// The same with Intel Open Image Denoise's lightmap filter (`--denoise oidn`): builds with the
/// feature only (`cargo test -p vlf-core --features oidn --test core stability::oidn -- --nocapture`,
/// with OIDN_DIR and the library's path set, docs/GATHER.md); CI does not build it. OIDN sees
/// each chart's neighbours in its image (beyond the padding), so charts that are black without
/// it (the closed box's inside, the split room's dark half) receive light, and on a floor that
/// runs on under a thin wall it carries light across the wall's foot.
#[cfg(feature = "oidn")]
#[test]
fn oidn_leaks_across_contacts_and_thin_walls() {
    let _t = Timer::start("2a / 2b with OIDN");
    let ds = [Denoiser::Off, Denoiser::Edge, Denoiser::Oidn];
    let names = ["off", "on", "oidn"];
    let closed = box_leaks_denoised(Crate::Closed, &ds);
    for k in [Crate::Closed, Crate::Bottomless] {
        let l = if k == Crate::Closed {
            closed.clone()
        } else {
            box_leaks_denoised(k, &ds)
        };
        for (name, l) in names.iter().zip(&l) {
            eprintln!("box on a floor, {k:?}, N = 32, denoiser {name}: {l}");
        }
    }
    let split = split_room_leaks_denoised(&ds);
    for (name, (apart, one, far)) in names.iter().zip(&split) {
        eprintln!(
            "split room, N = 32, denoiser {name}: dark half max {apart:e}; one floor under the \
             wall: dark half {one}, beyond 2 texels {far}"
        );
    }
    assert_eq!((closed[0].max, closed[1].max), (0.0, 0.0));
    assert!(
        closed[2].max > 0.0,
        "OIDN lit the closed box's inside: {:?}",
        closed[2]
    );
    assert!(split[2].0 > 0.0, "OIDN lit the dark half: {:e}", split[2].0);
    assert!(
        split[2].1.power > split[0].1.power,
        "{:?} / {:?}",
        split[2].1,
        split[0].1
    );
}

// ----- 3. direction holes -----------------------------------------------------------------------

/// A 0.05-wide emitter (radiance 1) 3 above a 1 × 1 floor of albedo 0.5, facing it.
fn distant_emitter_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
    let floor = b.diffuse("floor", Vec3::splat(0.5), Vec3::ZERO);
    hrect(&mut b, 3.0, (-0.025, 0.025), (-0.025, 0.025), false, light);
    hrect(&mut b, 0.0, (-0.5, 0.5), (-0.5, 0.5), true, floor);
    b.build("distant emitter")
}

#[derive(Debug)]
struct Holes {
    /// Per-texel relative error: max.
    max: f64,
    /// Fraction of the floor's texels that receive no direct light.
    holes: f64,
    /// Mean relative error of 8 × 8-texel block sums.
    blocks: f64,
    /// Relative error of the floor's total received power.
    power: f64,
}

fn direction_holes(directions: u32, perturb: u32) -> Holes {
    let scene = distant_emitter_scene();
    let p = BakeParams {
        perturb,
        ..params(directions, 64, Iterations::Fixed(1))
    };
    let (prep, _, out) = bake(&scene, &p);
    assert_sane(&out, "distant emitter");
    let fi = face_near(&scene, Vec3::Y, Vec3::ZERO);
    let texels = full_texels(&prep, &scene, fi, 0);
    let emitter = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(x, z)| DVec3::new(0.025 * x, 3.0, 0.025 * z));
    let want = |p: DVec3| 0.5 * ff_polygon(p, DVec3::Y, &emitter);
    let (mean, max, power) = texel_errors(&out, &texels, want);
    let dark = texels
        .iter()
        .filter(|(t, _)| out.radiance[*t][0] == 0.0)
        .count();
    let f = prep.faces[fi];
    let mut blocks: HashMap<(u32, u32), (f64, f64)> = HashMap::new();
    for &(t, p) in &texels {
        let local = t as u32 - f.texel_base;
        let e = blocks
            .entry((local % f.width / 8, local / f.width / 8))
            .or_default();
        e.0 += f64::from(out.radiance[t][0]);
        e.1 += want(p);
    }
    let blocks = blocks.values().map(|(g, w)| (g - w).abs() / w).sum::<f64>() / blocks.len() as f64;
    let h = Holes {
        max,
        holes: dark as f64 / texels.len() as f64,
        blocks,
        power,
    };
    eprintln!(
        "distant emitter, {directions} directions × {perturb} perturbed: texel error mean {mean:.2} max {:.1}; {:.1} % of {} texels dark; 8×8 blocks {:.3}; floor power {:+.3}",
        h.max,
        100.0 * h.holes,
        texels.len(),
        h.blocks,
        h.power
    );
    h
}

#[test]
fn distant_small_emitter_shows_direction_holes_that_perturbation_fills() {
    let _t = Timer::start("direction holes");
    // The emitter subtends Ω_e = 2.8e-4 sr from the floor; one direction of a 126 (501) set
    // carries ΔΩ ≈ 0.050 (0.0125) sr. A direction either sees the emitter or not, so the floor
    // is a few spots ΔΩ/Ω_e ≈ 180 (45) times too bright in a field of holes. Measured:
    //   126 × 0:  max 190, 99.4 % dark, blocks 1.78, power +6.5 %
    //   126 × 16: max 12.4, 91.7 % dark, blocks 0.56, power −1.2 %
    //   501 × 0:  max 48.8, 98.1 % dark, blocks 0.77, power −5.0 %
    //   501 × 16: max 8.1, 70.1 % dark, blocks 0.16, power +0.1 %
    for l in [126, 501] {
        let fixed = direction_holes(l, 0);
        let jittered = direction_holes(l, 16);
        // Holes: the error is huge without perturbation (bound: max > 20, > 90 % dark) …
        assert!(fixed.max > 20.0 && fixed.holes > 0.9, "{l}: {fixed:?}");
        // … and perturbation spreads it: max down ≥ 4× (measured 15× and 6×), block error
        // down ≥ 2× (3.2× and 4.8×), fewer holes.
        assert!(
            jittered.max * 4.0 < fixed.max,
            "{l}: {jittered:?} vs {fixed:?}"
        );
        assert!(
            jittered.blocks * 2.0 < fixed.blocks,
            "{l}: {jittered:?} vs {fixed:?}"
        );
        assert!(
            jittered.holes < fixed.holes,
            "{l}: {jittered:?} vs {fixed:?}"
        );
        // With perturbation the floor's total stays within 10 % (measured ≤ 1.2 %). Without it
        // the total is at the mercy of which few rays happen to meet the emitter: measured
        // +6.5 % and, after the texel grid of the floor moved (scale-invariant charts), +60 %;
        // it is reported, not bounded — that failure is what this case documents.
        assert!(jittered.power.abs() < 0.1, "{l}: {jittered:?}");
    }
}

// ----- 4. mirrors: ghosting and convergence ------------------------------------------------------

/// Emitter `[-0.6, -0.2] × [-0.2, 0.2]` and receiver `[0.2, 0.6] × [-0.2, 0.2]` (albedo 0.5)
/// side by side at height 0.5, both facing down (so the receiver cannot see the emitter), over a
/// floor mirror of reflectance 0.9: the receiver sees only the emitter's image.
fn mirror_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
    let recv = b.diffuse("receiver", Vec3::splat(0.5), Vec3::ZERO);
    let m = b.mirror("mirror", Vec3::splat(0.9));
    hrect(&mut b, 0.5, (-0.6, -0.2), (-0.2, 0.2), false, light);
    hrect(&mut b, 0.5, (0.2, 0.6), (-0.2, 0.2), false, recv);
    hrect(&mut b, 0.0, (-1.0, 1.0), (-0.6, 0.6), true, m);
    b.build("mirror image")
}

/// (mean, max, total) relative error of the receiver against ρ_r ρ_m L F(image of the emitter).
fn mirror_error(directions: u32) -> (f64, f64, f64) {
    let scene = mirror_scene();
    let (prep, _, out) = bake(&scene, &params(directions, 64, Iterations::Fixed(2)));
    assert_sane(&out, "mirror image");
    let fi = face_near(&scene, -Vec3::Y, Vec3::new(0.4, 0.5, 0.0));
    let texels = full_texels(&prep, &scene, fi, 0); // side 0 faces down, at the mirror
    let image =
        [(-0.6, -0.2), (-0.2, -0.2), (-0.2, 0.2), (-0.6, 0.2)].map(|(x, z)| DVec3::new(x, -0.5, z));
    let e = texel_errors(&out, &texels, |p| {
        0.5 * 0.9 * ff_polygon(p, -DVec3::Y, &image)
    });
    eprintln!(
        "mirror image, {directions} directions: receiver error mean {:.3}, max {:.3}, total {:+.3} ({} texels)",
        e.0,
        e.1,
        e.2,
        texels.len()
    );
    e
}

#[test]
fn mirror_image_converges_as_directions_grow() {
    let _t = Timer::start("mirror convergence");
    // Reflected light is stored per fixed direction and read back through the 3 directions
    // around the reflected one, so with few directions the receiver sees shifted, blended copies
    // of the image (ghosts). Measured (mean, max, total):
    //   21: 1.68, 3.03, +108 %   46: 0.562, 1.55, −9.3 %   126: 0.304, 0.92, +3.3 %
    //   501: 0.107, 0.43, +1.2 %
    // Mean error ∝ l^−0.87 from 21 to 501 (l^−0.69 from 46 to 501).
    let ls = [21u32, 46, 126, 501];
    let errs: Vec<(f64, f64, f64)> = ls.iter().map(|&l| mirror_error(l)).collect();
    for k in 1..ls.len() {
        assert!(
            errs[k].0 < errs[k - 1].0 && errs[k].1 < errs[k - 1].1,
            "error must fall from {} to {} directions: {errs:?}",
            ls[k - 1],
            ls[k]
        );
    }
    let rate = (errs[3].0 / errs[0].0).ln() / (501f64 / 21.0).ln();
    eprintln!("mirror image: mean error ∝ l^{rate:.2}");
    // Bounds: rate below −0.5 (measured −0.86 / −0.87); at 501 directions mean < 0.15 (0.107)
    // and the receiver's total within 4 % (measured +1.2 % and +2.7 % for two placements of
    // the receiver's texel grid).
    assert!(rate < -0.5, "rate {rate}");
    assert!(errs[3].0 < 0.15 && errs[3].2.abs() < 0.04, "{:?}", errs[3]);
}

// ----- 5. grazing angles -------------------------------------------------------------------------

/// A floor receiver `[0, 1] × [−0.5, 0.5]` (albedo 0.5) and a 1 × 0.1 emitter hinged 0.05
/// before it at floor level, tilted so that the normals make `alpha` degrees: light leaves the
/// emitter and reaches the floor at grazing angles (within 6° of the floor at its far end).
fn grazing_scene(alpha_deg: f32) -> (Scene, [DVec3; 4]) {
    let a = alpha_deg.to_radians();
    let mut b = SceneBuilder::new();
    let light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
    let floor = b.diffuse("floor", Vec3::splat(0.5), Vec3::ZERO);
    hrect(&mut b, 0.0, (0.0, 1.0), (-0.5, 0.5), true, floor);
    let hinge = Vec3::new(-0.05, 0.0, -0.5);
    let (up, across) = (Vec3::new(-a.cos(), a.sin(), 0.0) * 0.1, Vec3::Z);
    rect(&mut b, hinge, up, across, light); // normal up × across = (sin α, cos α, 0)
    let poly = [hinge, hinge + across, hinge + across + up, hinge + up].map(|p| p.as_dvec3());
    (b.build("grazing"), poly)
}

fn grazing_error(alpha: f32, directions: u32, perturb: u32) -> (f64, f64, f64) {
    let (scene, emitter) = grazing_scene(alpha);
    let p = BakeParams {
        perturb,
        ..params(directions, 64, Iterations::Fixed(1))
    };
    let (prep, _, out) = bake(&scene, &p);
    assert_sane(&out, "grazing");
    let fi = face_near(&scene, Vec3::Y, Vec3::new(0.5, 0.0, 0.0));
    let texels = full_texels(&prep, &scene, fi, 0);
    let want = |p: DVec3| 0.5 * ff_polygon(p, DVec3::Y, &emitter);
    let e = texel_errors(&out, &texels, want);
    let far: Vec<_> = texels.iter().copied().filter(|(_, p)| p.x > 0.6).collect();
    let (far_mean, _, _) = texel_errors(&out, &far, want);
    eprintln!(
        "grazing, normals at {alpha}°, {directions} × {perturb}: receiver error mean {:.4} (x > 0.6: {far_mean:.4}), max {:.4}, total {:+.4}",
        e.0, e.1, e.2
    );
    e
}

#[test]
fn grazing_emitter_and_receiver_match_form_factors() {
    let _t = Timer::start("grazing");
    // Measured with 501 directions × 4 perturbed (mean, max, total):
    //   85°: 0.058, 0.36, −0.87 %   88°: 0.057, 0.33, −0.96 %   89°: 0.056, 0.36, −0.96 %
    // The error grows towards the far end (mean 0.09 beyond x = 0.6), where the emitter is a
    // thin sliver above the horizon; rays cross the floor's texels at a few degrees, so most
    // texels take the fallback (nearest crossing within two cells). Bounds: mean < 0.1, max
    // < 0.6, total within 2 %.
    for alpha in [85.0, 88.0, 89.0] {
        let (mean, max, total) = grazing_error(alpha, 501, 4);
        assert!(
            mean < 0.1 && max < 0.6 && total.abs() < 0.02,
            "{alpha}°: {mean} {max} {total}"
        );
    }
    // 126 directions leave the far half in a direction hole (there the emitter fills only the
    // 5–9° band above the horizon): measured mean 0.58, far mean 0.97, total −6.6 %.
    // Still no NaN and the total within 15 %.
    let (_, _, total) = grazing_error(89.0, 126, 0);
    assert!(total.abs() < 0.15, "{total}");
}

// ----- 6. coplanar overlapping faces ------------------------------------------------------------

#[test]
fn coplanar_decal_is_deterministic_and_balanced() {
    let _t = Timer::start("coplanar decal");
    let scene = scenes::decal_room();
    let p = params(126, 64, Iterations::Fixed(4));
    let (prep, set, a) = bake(&scene, &p);
    let (_, _, b) = bake(&scene, &p);
    assert_sane(&a, "decal");
    let bits = |o: &Baked| -> Vec<u32> {
        o.irradiance
            .iter()
            .flat_map(|l| l.map(f32::to_bits))
            .collect()
    };
    assert!(
        bits(&a) == bits(&b) && a.energy == b.energy,
        "two bakes differ"
    );
    let decal = face_of(&scene, "decal");
    let floor = (0..scene.faces.len())
        .find(|&f| f != decal && scene.faces[f].normal.y > 0.99)
        .unwrap();
    assert!(floor < decal, "the room is built first");
    // Irradiance (L / ρ) of the decal, of the floor under it and of the floor around it.
    let mean_e = |face: usize, rho: f32, under: bool| {
        let (mut s, mut n) = (0.0f64, 0);
        for (t, p) in full_texels(&prep, &scene, face, 0) {
            let (x, z) = (p.x.abs(), p.z.abs());
            if (x < 0.25 && z < 0.25) == under && x < 0.55 && z < 0.55 {
                s += f64::from(a.radiance[t][0] / rho);
                n += 1;
            }
        }
        s / f64::from(n)
    };
    let e_decal = mean_e(decal, 0.8, true);
    let (e_under, e_beside) = (mean_e(floor, 0.7, true), mean_e(floor, 0.7, false));
    // Which face is on top (seen from the room) on the rays that cross both: the one first
    // along +w when w points down, the one last when w points up.
    let grid = PsfGrid::new(p.resolution, p.tile).unwrap();
    let (mut decal_on_top, mut floor_on_top, mut tied) = (0, 0, 0);
    for i in 0..set.len() {
        let frame = fixed_frame(&set, i);
        let down = scene.to_vlf.apply_vector(Vec3::Y).dot(frame.w) < 0.0;
        let lists = reference::build_cell_lists(&prep, &grid, &frame);
        for c in 0..lists.start.len() - 1 {
            let e = &lists.entries[lists.start[c] as usize..lists.start[c + 1] as usize];
            let at = |f: usize| e.iter().position(|x| x.1 as usize == f);
            if let (Some(d), Some(f)) = (at(decal), at(floor)) {
                if e[d].0 == e[f].0 {
                    tied += 1;
                    assert!(f < d, "equal depths sort by face index");
                }
                if (d < f) == down {
                    decal_on_top += 1;
                } else {
                    floor_on_top += 1;
                }
            }
        }
    }
    let top = f64::from(decal_on_top) / f64::from(decal_on_top + floor_on_top);
    eprintln!(
        "coplanar decal: irradiance decal {e_decal:.3}, floor under it {e_under:.3}, floor around it {e_beside:.3}; the decal is on top in {decal_on_top} rays, the floor in {floor_on_top} ({tied} with bit-equal depths); imbalance {:+.3}%",
        100.0 * a.energy.relative_imbalance()
    );
    // Neither face wins. Bit-equal depths (2248 rays) put the lower face index (the floor) first
    // along +w, so the floor is on top for directions pointing down and the decal for those
    // pointing up; elsewhere f32 rounding of the two planes' depths decides. Measured: decal on
    // top in 5276 rays, floor in 3739 (59 %); the decal reads 0.77 of the irradiance around it
    // (0.467 / 0.604), the floor under it 0.58 (0.353); they also light each other across zero
    // distance. Bounds: on-top share 30–70 %, decal 0.5–0.95 of its surroundings.
    assert!(
        tied > 0 && (0.3..0.7).contains(&top),
        "decal on top in {top:.3} of the rays"
    );
    let share = e_decal / e_beside;
    assert!((0.5..0.95).contains(&share), "decal share {share}");
    // Measured +0.33 %.
    assert_balanced(&a, "decal");
}

// ----- 7. degenerate and needle triangles --------------------------------------------------------

#[test]
fn needle_triangles_bake_without_cracks() {
    let _t = Timer::start("needles");
    let p = params(126, 64, Iterations::Fixed(4));
    let scene = split_room_scene(0.0, true);
    let (prep, set, out) = bake(&scene, &p);
    assert_sane(&out, "needles");
    let dark = split_room_dark(&scene, &prep, &out);
    // Crack test: every ray whose exact path crosses the wall (away from its outline) lists it.
    let wall = face_of(&scene, "wall") as u32;
    let grid = PsfGrid::new(p.resolution, p.tile).unwrap();
    let (mut crossing, mut missed) = (0, 0);
    for i in 0..set.len() {
        let frame = fixed_frame(&set, i);
        let lists = reference::build_cell_lists(&prep, &grid, &frame);
        for (c, (want, amb)) in brute_force_lists(&prep, &grid, &frame).iter().enumerate() {
            if !*amb && want.contains(&wall) {
                crossing += 1;
                missed += usize::from(!cell_faces(&lists, c).contains(&wall));
            }
        }
    }
    let aspect = |t: &vlf_core::scene::Triangle| {
        let longest = [t.p[1] - t.p[0], t.p[2] - t.p[1], t.p[0] - t.p[2]]
            .map(|e| e.length())
            .into_iter()
            .fold(0.0, f32::max);
        longest * longest / (2.0 * t.area()) // longest edge / height on it
    };
    let worst = (scene.face_triangles(wall as usize).iter())
        .map(aspect)
        .fold(0.0, f32::max);
    eprintln!(
        "needles (worst aspect ratio {worst:.0}): dark half max {dark:e}, {missed} of {crossing} wall rays missed, imbalance {:+.3}%",
        100.0 * out.energy.relative_imbalance()
    );
    assert!(worst > 1e4, "the wall must contain needles ({worst})");
    // Measured: 0 of 42 636 rays missed, dark half exactly 0, imbalance +0.44 %.
    assert_eq!(missed, 0);
    assert_eq!(dark, 0.0);
    assert_balanced(&out, "needles");
}

/// Writes a glTF with one mesh: primitive k uses `indices[k]` and material k, where material k
/// is diffuse with albedo `materials[k].0` and emission `materials[k].1`.
fn write_gltf(path: &Path, positions: &[Vec3], indices: &[Vec<u16>], materials: &[(f32, f32)]) {
    let mut bin: Vec<u8> = positions
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let mut views = vec![format!(
        r#"{{"buffer":0,"byteOffset":0,"byteLength":{}}}"#,
        bin.len()
    )];
    let (lo, hi) = positions
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(l, h), p| (l.min(*p), h.max(*p)));
    let mut accessors = vec![format!(
        r#"{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":{:?},"max":{:?}}}"#,
        positions.len(),
        lo.to_array(),
        hi.to_array()
    )];
    let mut prims = Vec::new();
    for (k, idx) in indices.iter().enumerate() {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let offset = bin.len();
        bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{}}}"#,
            idx.len() * 2
        ));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5123,"count":{},"type":"SCALAR"}}"#,
            views.len() - 1,
            idx.len()
        ));
        prims.push(format!(
            r#"{{"attributes":{{"POSITION":0}},"indices":{},"material":{k}}}"#,
            accessors.len() - 1
        ));
    }
    let mats: Vec<String> = (materials.iter())
        .map(|(a, e)| {
            format!(
                r#"{{"pbrMetallicRoughness":{{"baseColorFactor":[{a},{a},{a},1],"metallicFactor":0}},"emissiveFactor":[{e},{e},{e}]}}"#
            )
        })
        .collect();
    let doc = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],"bufferViews":[{}],"accessors":[{}],"materials":[{}],"meshes":[{{"primitives":[{}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len(),
        base64(&bin),
        views.join(","),
        accessors.join(","),
        mats.join(","),
        prims.join(",")
    );
    std::fs::write(path, doc).unwrap();
}

#[test]
fn degenerate_triangles_are_skipped_or_harmless() {
    let _t = Timer::start("degenerate");
    // A lit floor: floor quad (0–3), emitter quad (4–7) and points for degenerate triangles
    // inside the same bounds (8–10 exactly collinear, slanted through the light's path).
    let pts = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-0.3, 1.0, -0.3),
        Vec3::new(0.3, 1.0, -0.3),
        Vec3::new(0.3, 1.0, 0.3),
        Vec3::new(-0.3, 1.0, 0.3),
        Vec3::new(-0.5, 0.25, 0.125),
        Vec3::new(0.0, 0.375, 0.125),
        Vec3::new(0.5, 0.5, 0.125),
    ];
    let floor = vec![0u16, 1, 2, 0, 2, 3];
    let light = vec![4u16, 5, 6, 4, 6, 7];
    // Repeated vertex, collinear, and a zero-area triangle inside the floor.
    let degenerate = [4u16, 4, 6, 8, 9, 10, 0, 2, 0];
    let mut floor_deg = floor.clone();
    floor_deg.extend(degenerate);
    let dir = std::env::temp_dir().join(format!("vlf-stability-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("degenerate.gltf");
    write_gltf(
        &path,
        &pts,
        &[floor_deg, light.clone()],
        &[(0.5, 0.0), (0.0, 1.0)],
    );
    let loaded = vlf_core::scene::load(&path).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("degenerate: importer warnings {:?}", loaded.warnings);
    assert_eq!(
        loaded.triangles.len(),
        4,
        "the importer skips the three degenerate triangles"
    );
    // The same scene built in code, without and with the degenerate triangles (the builder
    // keeps them: they become zero-area faces that no ray can cross).
    let build = |with_degenerate: bool| {
        let mut b = SceneBuilder::new();
        let m_floor = b.diffuse("floor", Vec3::splat(0.5), Vec3::ZERO);
        let m_light = b.diffuse("light", Vec3::ZERO, Vec3::ONE);
        for (idx, m) in [(&floor, m_floor), (&light, m_light)] {
            for t in idx.chunks(3) {
                b.triangle([0, 1, 2].map(|k| pts[t[k] as usize]), m);
            }
        }
        if with_degenerate {
            for t in degenerate.chunks(3) {
                b.triangle([0, 1, 2].map(|k| pts[t[k] as usize]), m_floor);
            }
        }
        b.build("degenerate")
    };
    let p = params(46, 64, Iterations::Fixed(2));
    let (prep, _, clean) = bake(&build(false), &p);
    let (_, _, imported) = bake(&loaded, &p);
    let (prep_deg, _, with_deg) = bake(&build(true), &p);
    for (o, what) in [
        (&clean, "clean"),
        (&imported, "imported"),
        (&with_deg, "builder"),
    ] {
        assert_sane(o, what);
        assert_balanced(o, what);
    }
    eprintln!(
        "degenerate: {} faces with the builder's degenerate triangles, imbalance {:+.3}%",
        prep_deg.faces.len(),
        100.0 * with_deg.energy.relative_imbalance()
    );
    // Measured: bit-identical in both cases (the real faces keep their indices and texels).
    let n = prep.texel_count();
    assert_eq!(clean.radiance, imported.radiance, "imported scene");
    assert_eq!(
        clean.radiance[..],
        with_deg.radiance[..n],
        "builder's degenerate faces"
    );
}

// ----- 8. huge scale ranges ----------------------------------------------------------------------

/// A Cornell-like box (1 × 0.9 × 1.1, open front, red and green side walls, ceiling light, two
/// turned boxes without bottoms) with every coordinate multiplied by `scale`, and optionally a
/// cube of edge `tiny` (relative to the room) floating at its centre. No face is square, so every
/// face's chart is unique (see `square_face_chart_is_scale_invariant`).
fn cornell_like(scale: f32, tiny: Option<f32>) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.73), Vec3::ZERO);
    let red = b.diffuse("red", Vec3::new(0.65, 0.05, 0.05), Vec3::ZERO);
    let green = b.diffuse("green", Vec3::new(0.12, 0.45, 0.15), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(15.0));
    let mut q = |p: [Vec3; 4], m: u32| {
        b.quad(p.map(|v| v * scale), m);
    };
    let hi = Vec3::new(1.0, 0.9, 1.1);
    let c =
        |x: usize, y: usize, z: usize| Vec3::new([0.0, hi.x][x], [0.0, hi.y][y], [0.0, hi.z][z]);
    q([c(0, 0, 0), c(0, 0, 1), c(1, 0, 1), c(1, 0, 0)], white); // floor
    q([c(0, 1, 0), c(1, 1, 0), c(1, 1, 1), c(0, 1, 1)], white); // ceiling
    q([c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0)], white); // back
    q([c(0, 0, 0), c(0, 1, 0), c(0, 1, 1), c(0, 0, 1)], red);
    q([c(1, 0, 0), c(1, 0, 1), c(1, 1, 1), c(1, 1, 0)], green);
    let (y, x0, x1, z0, z1) = (0.898, 0.37, 0.63, 0.4, 0.7);
    q(
        [
            Vec3::new(x0, y, z0),
            Vec3::new(x1, y, z0),
            Vec3::new(x1, y, z1),
            Vec3::new(x0, y, z1),
        ],
        light,
    );
    for (centre, height, turn) in [
        (Vec3::new(0.65, 0.0, 0.35), 0.25f32, -0.29f32),
        (Vec3::new(0.33, 0.0, 0.6), 0.55, 0.29),
    ] {
        let (s, co) = turn.sin_cos();
        let at = |x: f32, y: f32, z: f32| centre + Vec3::new(co * x + s * z, y, -s * x + co * z);
        let corners = [
            (-0.15, -0.135),
            (0.15, -0.135),
            (0.15, 0.135),
            (-0.15, 0.135),
        ];
        for k in 0..4 {
            let ((ax, az), (bx, bz)) = (corners[k], corners[(k + 1) % 4]);
            q(
                [
                    at(ax, 0.0, az),
                    at(ax, height, az),
                    at(bx, height, bz),
                    at(bx, 0.0, bz),
                ],
                white,
            );
        }
        q(corners.map(|(x, z)| at(x, height, z)), white);
    }
    if let Some(size) = tiny {
        let centre = Vec3::new(0.5, 0.45, 0.55);
        let h = Vec3::splat(0.5 * size);
        b.aabox((centre - h) * scale, (centre + h) * scale, false, white);
    }
    b.build("cornell-like")
}

#[test]
fn scaled_scenes_match_the_unscaled_bake() {
    let _t = Timer::start("scales");
    let p = params(46, 64, Iterations::Fixed(3));
    let (prep, _, unscaled) = bake(&cornell_like(1.0, None), &p);
    assert_sane(&unscaled, "cornell-like");
    assert_balanced(&unscaled, "cornell-like");
    for scale in [1e-3f32, 1e4] {
        let (prep_s, _, out) = bake(&cornell_like(scale, None), &p);
        assert_sane(&out, "scaled");
        assert_eq!(prep_s.texel_count(), prep.texel_count());
        let (mean, max) = difference(&prep, &unscaled.radiance, &out.radiance, 1e-6);
        eprintln!(
            "scaled by {scale:e}: relative difference to the unscaled bake: mean {mean:.1e}, max {max:.1e}"
        );
        // The VLF transform maps both into the unit sphere; what is left is f32 rounding of the
        // vertices (~1e-7). Measured: 1e-3 → mean 5.0e-8, max 4.1e-6; 1e4 → 4.1e-8, 6.8e-6.
        assert!(
            mean < 1e-6 && max < 1e-4,
            "scale {scale}: mean {mean:e} max {max:e}"
        );
    }
}

/// Regression (was a defect of the scene import): a square face's chart used to be picked among tied
/// minimum-area rectangles by f32 rounding, so scaling the scene can turn the chart by 90° and
/// move its texel grid; texel-by-texel comparisons of scaled bakes then fail (a cube-shaped
/// Cornell box at 1e-3: mean per-texel difference 8e-2) although the physics is unchanged.
#[test]
fn square_face_chart_is_scale_invariant() {
    let square = |scale: f32| {
        let mut b = SceneBuilder::new();
        let m = b.diffuse("white", Vec3::splat(0.5), Vec3::ZERO);
        let (s, c) = 0.29f32.sin_cos();
        let at = |x: f32, y: f32| Vec3::new(c * x, y, -s * x) * scale;
        b.quad([at(0.0, 0.0), at(0.3, 0.0), at(0.3, 0.3), at(0.0, 0.3)], m);
        b.build("square")
    };
    let reference = square(1.0).faces[0].basis.u;
    for scale in [1e-3f32, 0.1, 3.0, 1e4] {
        let u = square(scale).faces[0].basis.u;
        // Measured: 0.1 and 1e4 give u = (0.958, 0, −0.286) instead of (0, 1, 0).
        assert!(
            (u - reference).length() < 1e-5,
            "scale {scale}: u {u} vs {reference}"
        );
    }
}

#[test]
fn tiny_object_in_a_room_bakes_sanely() {
    let _t = Timer::start("tiny object");
    let p = params(46, 64, Iterations::Fixed(3));
    let (prep, _, out) = bake(&cornell_like(1.0, Some(1e-4)), &p);
    let (_, _, room) = bake(&cornell_like(1.0, None), &p);
    assert_sane(&out, "tiny object");
    assert_balanced(&out, "tiny object");
    let n = room.radiance.len();
    let (mean, max) = difference(&prep, &room.radiance, &out.radiance[..n], 1e-6);
    let tiny_max = out.radiance[n..]
        .iter()
        .map(|l| Vec4::from(*l).max_element())
        .fold(0.0, f32::max);
    eprintln!(
        "tiny object (1e-4 of the room, 1/270 of a cell): room vs room alone mean {mean:.1e} max {max:.1e}; tiny cube max radiance {tiny_max}; imbalance {:+.3}%",
        100.0 * out.energy.relative_imbalance()
    );
    // Measured: the room is bit-identical to the bake without the cube and the cube stays black:
    // no ray of any direction crosses it, so it neither shadows nor receives (a known limitation
    // of every object smaller than the ray spacing; see docs/STABILITY.md).
    assert!(mean == 0.0 && max == 0.0, "{mean} {max}");
    assert_eq!(
        tiny_max, 0.0,
        "if sub-cell objects now receive light, update STABILITY.md"
    );
}
