//! The WGSL direction lookup (`shaders/common/directions.wgsl`) against the CPU's
//! `DirectionSet::lookup`, which it mirrors in f32.

use std::collections::BTreeMap;

use glam::Vec3;
use vlf_core::directions::{DirectionSet, Lookup};
use vlf_gpu::directions::{DirectionLookup, GpuDirections};
use vlf_tests::gpu;

/// Directions that probe the lookup: a quasi-random cover of the sphere, every sphere vertex,
/// the midpoints of every triangle's edges (on the edge: a tie between two triangles), the
/// axes with signed zeros, and lengths far from 1.
fn probes(set: &DirectionSet) -> Vec<Vec3> {
    let mut d = Vec::new();
    let n = GENERIC;
    for i in 0..n {
        // Fibonacci sphere.
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = i as f32 * 2.399_963;
        d.push(Vec3::new(r * phi.cos(), r * phi.sin(), z));
    }
    d.extend_from_slice(set.sphere_vertices());
    for t in set.sphere_triangles() {
        let p = t.map(|v| set.sphere_vertex(v));
        d.push(p[0] + p[1]);
        d.push(p[1] + p[2]);
        d.push(p[2] + p[0]);
    }
    for a in [Vec3::X, Vec3::Y, Vec3::Z] {
        d.push(a);
        d.push(-a);
    }
    d.push(Vec3::new(-0.0, 0.0, 1.0));
    d.push(Vec3::new(0.0, -0.0, -1.0));
    d.push(Vec3::new(3.0e-30, -2.0e-30, 1.0e-30));
    d.push(Vec3::new(1.0e30, 2.0e30, -3.0e29));
    // No direction: the fallback (all weight on vertex 0).
    d.push(Vec3::ZERO);
    d.push(Vec3::NAN);
    d
}

/// Vertex → weight of a lookup.
fn weights(lk: &Lookup) -> BTreeMap<u32, f32> {
    let mut m = BTreeMap::new();
    for (v, w) in lk.vertices.iter().zip(lk.weights) {
        *m.entry(*v).or_insert(0.0) += w;
    }
    m
}

#[test]
fn gpu_direction_lookup_matches_cpu() {
    let Some(ctx) = gpu() else { return };
    let pass = DirectionLookup::new(&ctx.device);
    for k in [1, 2, 5, 8, 13] {
        let set = DirectionSet::with_frequency(k).unwrap();
        let dirs = probes(&set);
        let gpu = pass
            .run(ctx, &GpuDirections::new(&ctx.device, &set), &dirs)
            .expect("readback");
        assert_eq!(gpu.len(), dirs.len());
        let (mut same_triangle, mut worst) = (0usize, 0.0f32);
        for (i, (d, g)) in dirs.iter().zip(&gpu).enumerate() {
            let c = set.lookup(*d);
            // The GPU's triangle is a real triangle of the mesh with its own vertices.
            assert_eq!(
                set.sphere_triangles()[g.triangle as usize],
                g.vertices,
                "k {k} direction {i} {d}"
            );
            let sum: f32 = g.weights.iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-5 && g.weights.iter().all(|w| *w >= 0.0),
                "k {k} direction {i} {d}: weights {:?}",
                g.weights
            );
            if i < GENERIC {
                same_triangle += usize::from(c.triangle == g.triangle);
            }
            // Where the triangles differ (ties at edges) the weights must still agree per
            // vertex: a vertex of one lookup only is weighted about zero.
            let (wc, wg) = (weights(&c), weights(g));
            for v in wc.keys().chain(wg.keys()) {
                let diff =
                    (wc.get(v).copied().unwrap_or(0.0) - wg.get(v).copied().unwrap_or(0.0)).abs();
                worst = worst.max(diff);
                assert!(
                    diff < WEIGHT_TOLERANCE,
                    "k {k} direction {i} {d}: cpu {c:?} gpu {g:?}"
                );
            }
        }
        let frac = same_triangle as f64 / GENERIC as f64;
        eprintln!(
            "k {k}: same triangle for {frac:.5} of {GENERIC} generic directions, worst weight \
             difference {worst:.2e} over {}",
            dirs.len()
        );
        // Generic directions land in another triangle only within rounding of an edge.
        assert!(frac > 0.999, "k {k}: the same triangle for only {frac:.5}");
    }
}

/// The quasi-random (generic) directions at the start of [`probes`].
const GENERIC: usize = 20_000;

/// Largest per-vertex weight difference between the f32 GPU lookup and the f64 CPU lookup.
const WEIGHT_TOLERANCE: f32 = 1e-4;
