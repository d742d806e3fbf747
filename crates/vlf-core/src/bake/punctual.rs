//! The direct light of point and spot lights on the propagation's atlas: what their first
//! bounce injects into the propagation, as a sun's first crossing does.
//!
//! A sun is a transport direction of its own: its parallel rays cross the scene like the
//! quadrature's and light what they reach first. A point light's rays diverge from one point, so
//! no ray grid of the propagation carries them; instead the irradiance each texel receives
//! straight from each point or spot light is computed here, once per bake, on the CPU, by
//! shadow rays (`I·cos θ/d²` times the spot's falloff and the range window,
//! [`crate::pathtrace::lights::DeltaLight::incident`]), and both propagators add it to the
//! first iteration's irradiance (`reference::finish_iteration`), so the propagation carries its
//! later bounces. The GPU propagator gets the very same array: it stays bit-identical to the
//! CPU's.
//!
//! Sample points: a [`POINTS_PER_SIDE`]² grid of sub-texel centres, those inside the face's
//! polygon (the same coverage the atlas clips texels by), one shadow ray per point and light;
//! a texel side receives the mean over its points. A shadow edge across a texel is then
//! resolved to 1/16 of its area, finer than the propagation resolves anything else, and the
//! result is deterministic (no random numbers) and thread-count independent (each texel on
//! its own, results in texel order).

use glam::{Vec2, Vec3};

use super::prep::{BakeScene, texels_under};
use crate::pathtrace::Bvh;
use crate::pathtrace::geometry::{NONE, RtTriangle, offset_ray_origin};

/// Sample points per texel edge: 4 × 4 points per texel.
pub const POINTS_PER_SIDE: u32 = 4;

/// Texels handed to a worker at a time.
const CHUNK: usize = 256;

/// The irradiance (rgb, a = 0) every texel side receives directly from the scene's point and
/// spot lights (`scene.lights`), with hard shadows; `None` when the scene has none. Computed
/// on `threads` workers (0 = all cores); the result does not depend on their number.
pub fn injected_irradiance(scene: &BakeScene, threads: usize) -> Option<Vec<[f32; 4]>> {
    if scene.lights.is_empty() {
        return None;
    }
    let bvh = Bvh::build(
        scene
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| RtTriangle {
                p0: t.p0,
                material: 0,
                p1: t.p1,
                prim: i as u32,
                p2: t.p2,
                light: NONE,
            })
            .collect(),
    );
    let masks = coverage_masks(scene);
    let n_tex = scene.texel_count();
    // Side 0 texel → (face, local index), for the texels that have points.
    let mut work: Vec<(u32, u32)> = Vec::new();
    for (fi, f) in scene.faces.iter().enumerate() {
        for i in 0..f.texels_per_side() {
            if masks[(f.texel_base + i) as usize] != 0 {
                work.push((fi as u32, i));
            }
        }
    }
    let values = crate::par::map(work.len(), threads, CHUNK, |k| {
        let (fi, i) = work[k];
        texel_irradiance(
            scene,
            &bvh,
            fi as usize,
            i,
            masks[(scene.faces[fi as usize].texel_base + i) as usize],
        )
    });
    let mut out = vec![[0f32; 4]; n_tex];
    for (&(fi, i), [front, back]) in work.iter().zip(values) {
        let f = &scene.faces[fi as usize];
        let t = (f.texel_base + i) as usize;
        out[t] = front.extend(0.0).into();
        out[t + f.texels_per_side() as usize] = back.extend(0.0).into();
    }
    Some(out)
}

/// The irradiance on both sides (front, back) of texel `i` of face `fi`, the mean over the
/// points of `mask`.
fn texel_irradiance(scene: &BakeScene, bvh: &Bvh, fi: usize, i: u32, mask: u16) -> [Vec3; 2] {
    let f = &scene.faces[fi];
    let (x, y) = ((i % f.width) as f32, (i / f.width) as f32);
    let (origin, u, v) = (Vec3::from(f.origin), Vec3::from(f.u), Vec3::from(f.v));
    let n = f.normal();
    let s = POINTS_PER_SIDE;
    let mut sum = [Vec3::ZERO; 2];
    let mut count = 0u32;
    for k in 0..s * s {
        if mask & (1 << k) == 0 {
            continue;
        }
        count += 1;
        let c = Vec2::new(
            x + ((k % s) as f32 + 0.5) / s as f32,
            y + ((k / s) as f32 + 0.5) / s as f32,
        ) * f.texel_size;
        let p = origin + u * c.x + v * c.y;
        for l in &scene.lights {
            let inc = l.incident(p);
            let cos = n.dot(inc.wi);
            let (side, nl, cos) = if cos > 0.0 {
                (0, n, cos)
            } else {
                (1, -n, -cos)
            };
            if cos.is_nan() || cos <= 0.0 || inc.irradiance == Vec3::ZERO {
                continue;
            }
            if !bvh.occluded(&l.shadow_ray(offset_ray_origin(p, nl), &inc)) {
                sum[side] += inc.irradiance * cos;
            }
        }
    }
    let k = 1.0 / count.max(1) as f32;
    [sum[0] * k, sum[1] * k]
}

/// Per side-0 texel (indexed by atlas texel; side-1 entries stay 0): bit `k` set when
/// sub-texel centre `k` (row-major in a [`POINTS_PER_SIDE`]² grid) lies inside one of the
/// face's triangles.
fn coverage_masks(scene: &BakeScene) -> Vec<u16> {
    const _: () = assert!(POINTS_PER_SIDE * POINTS_PER_SIDE <= 16);
    let mut masks = vec![0u16; scene.texel_count()];
    let s = POINTS_PER_SIDE;
    for t in &scene.triangles {
        let f = &scene.faces[t.face as usize];
        let (origin, u, v) = (Vec3::from(f.origin), Vec3::from(f.u), Vec3::from(f.v));
        let chart = |p: [f32; 3]| {
            let d = Vec3::from(p) - origin;
            Vec2::new(d.dot(u), d.dot(v)) / f.texel_size
        };
        let q = [chart(t.p0), chart(t.p1), chart(t.p2)];
        let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
        let det = e1.perp_dot(e2);
        if det.abs() < 1e-20 || !det.is_finite() {
            continue;
        }
        let (w, h) = (f.width as usize, f.height as usize);
        for (x, y) in texels_under(&q, w, h) {
            let texel = f.texel_base as usize + y * w + x;
            if scene.texel_area[texel] <= 0.0 {
                continue;
            }
            for k in 0..s * s {
                let c = Vec2::new(
                    x as f32 + ((k % s) as f32 + 0.5) / s as f32,
                    y as f32 + ((k / s) as f32 + 0.5) / s as f32,
                );
                let d = c - q[0];
                let b1 = d.perp_dot(e2) / det;
                let b2 = e1.perp_dot(d) / det;
                if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
                    masks[texel] |= 1 << k;
                }
            }
        }
    }
    masks
}
