use super::*;
use proptest::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::OnceLock;

const TEST_K: [u32; 5] = [1, 2, 3, 10, 40];

/// Cached sets for the tested frequencies.
fn set(k: u32) -> &'static DirectionSet {
    static SETS: [OnceLock<DirectionSet>; 5] = [const { OnceLock::new() }; 5];
    let n = TEST_K.iter().position(|&x| x == k).expect("tested k");
    SETS[n].get_or_init(|| DirectionSet::with_frequency(k).expect("valid k"))
}

fn p64(s: &DirectionSet, v: u32) -> DVec3 {
    s.sphere_vertex(v).as_dvec3()
}

#[test]
fn parameters_and_errors() {
    assert_eq!(
        DirectionSet::with_frequency(0).unwrap_err(),
        DirectionError::FrequencyOutOfRange(0)
    );
    assert!(DirectionSet::with_frequency(65).is_err());
    for (k, l) in [(1, 6), (2, 21), (10, 501), (40, 8001)] {
        let s = set(k);
        assert_eq!(s.len(), l);
        assert_eq!(s.frequency(), k);
        assert!(!s.is_empty());
    }
    assert_eq!(DirectionSet::at_least(0).unwrap().frequency(), 1);
    assert_eq!(DirectionSet::at_least(6).unwrap().frequency(), 1);
    assert_eq!(DirectionSet::at_least(7).unwrap().frequency(), 2);
    assert_eq!(DirectionSet::at_least(512).unwrap().frequency(), 11);
    assert_eq!(DirectionSet::at_least(8000).unwrap().frequency(), 40);
    assert_eq!(DirectionSet::at_least(20481).unwrap().frequency(), 64);
    assert_eq!(
        DirectionSet::at_least(20482).unwrap_err(),
        DirectionError::TooManyDirections(20482)
    );
}

#[test]
fn serde_round_trip_via_desc() {
    let s = set(10);
    let cfg = bincode::config::standard();
    let bytes = bincode::serde::encode_to_vec(s, cfg).unwrap();
    assert!(bytes.len() < 8, "header stays tiny: {} bytes", bytes.len());
    let (back, _): (DirectionSet, usize) = bincode::serde::decode_from_slice(&bytes, cfg).unwrap();
    assert_eq!(&back, s);
    assert_eq!(back.sphere_vertices(), s.sphere_vertices());
    assert_eq!(back.sphere_triangles(), s.sphere_triangles());
    // An out-of-range frequency is rejected on load.
    let bad = DirectionSetDesc {
        scheme: DirectionScheme::IcosahedralGnomonicV1,
        frequency: 0,
    };
    let bytes = bincode::serde::encode_to_vec(bad, cfg).unwrap();
    let r: Result<(DirectionSet, usize), _> = bincode::serde::decode_from_slice(&bytes, cfg);
    assert!(r.is_err());
}

#[test]
fn icosahedron_tables() {
    let ico = Icosahedron::new();
    for (f, c) in ico.faces.iter().enumerate() {
        let [a, b, cc] = c.map(|i| ico.corners[i as usize]);
        assert!((b - a).cross(cc - a).dot(a + b + cc) > 0.0);
        assert_eq!(ico.anti_face[ico.anti_face[f] as usize] as usize, f);
    }
    for p in 0..12 {
        assert_eq!(ico.corners[ico.anti_corner[p] as usize], -ico.corners[p]);
        let deg = (0..12).filter(|&q| ico.edge_index[p][q] != u8::MAX).count();
        assert_eq!(deg, 5);
    }
}

#[test]
fn mesh_topology() {
    for k in TEST_K {
        let s = set(k);
        let l = s.len() as u32;
        let nv = s.sphere_vertex_count();
        assert_eq!(nv, 10 * (k * k) as usize + 2);
        assert_eq!(nv, 2 * s.len());
        let tris = s.sphere_triangles();
        assert_eq!(tris.len(), 20 * (k * k) as usize);

        // Each directed edge exactly once, its reverse exactly once:
        // a closed, consistently oriented 2-manifold.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        let mut used = vec![0u32; nv];
        for t in tris {
            assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
            for n in 0..3 {
                *directed.entry((t[n], t[(n + 1) % 3])).or_default() += 1;
                used[t[n] as usize] += 1;
            }
        }
        for (&(a, b), &c) in &directed {
            assert_eq!(c, 1, "directed edge {a}->{b} repeated");
            assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} not shared");
        }
        let edges = directed.len() / 2;
        assert_eq!(nv as i64 - edges as i64 + tris.len() as i64, 2);
        // Every vertex is used; valence 5 at the 12 corners, 6 elsewhere.
        let fives = used.iter().filter(|&&u| u == 5).count();
        assert_eq!(fives, 12);
        assert!(used.iter().all(|&u| u == 5 || u == 6));

        // Outward orientation; no degenerate (welded-wrongly) triangles.
        let min_edge = (0.5 * 1.1071487 / k as f64).min(1.0);
        for t in tris {
            let [a, b, c] = t.map(|v| p64(s, v));
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
            for (p, q) in [(a, b), (b, c), (c, a)] {
                assert!(p.angle_between(q) > 0.5 * min_edge);
            }
        }

        // Unit length, exact antipodes, canonical hemisphere.
        for v in 0..l {
            let p = s.sphere_vertex(v);
            assert!((p.length() - 1.0).abs() < 1e-6);
            assert_eq!(s.sphere_vertex(v + l), -p);
            assert!(is_canonical(p));
            assert!(!is_canonical(-p));
            assert_eq!(s.direction(v as usize), p);
        }
    }
}

#[test]
fn antipodal_mesh_symmetry() {
    // The triangle set is closed under the antipodal map (with reversed
    // winding), not just the vertex set.
    for k in TEST_K {
        let s = set(k);
        let l = s.len() as u32;
        let anti = |v: u32| (v + l) % (2 * l);
        let canon = |t: [u32; 3]| {
            let r = (0..3).min_by_key(|&n| t[n]).unwrap();
            [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
        };
        let all: std::collections::HashSet<[u32; 3]> =
            s.sphere_triangles().iter().map(|&t| canon(t)).collect();
        for &t in s.sphere_triangles() {
            assert!(all.contains(&canon([anti(t[0]), anti(t[2]), anti(t[1])])));
        }
    }
}

/// Measured max/min solid angle per direction: k = 1: 1.0000,
/// 2: 1.2813, 3: 1.5294, 10: 2.1042, 40: 2.3236 (also 5: 1.7977,
/// 16: 2.2163, 64: 2.3494). It tends to ≈ 2.39 = (6/5)/cos³θ_c: gnomonic
/// area shrinkage cos³θ_c ≈ 0.502 at the icosahedron corners
/// (θ_c = 37.38° from the face centre) times the valence-5 deficit there.
/// Asserted with a ~1% margin.
const SPREAD_BOUND: [(u32, f64); 5] = [
    (1, 1.0001),
    (2, 1.295),
    (3, 1.545),
    (10, 2.125),
    (40, 2.345),
];

#[test]
fn solid_angles() {
    for k in TEST_K {
        let s = set(k);
        let l = s.len() as u32;
        let total: f64 = (0..2 * l).map(|v| f64::from(s.solid_angle(v))).sum();
        assert!((total / (4.0 * PI) - 1.0).abs() < 1e-4, "k={k}: {total}");
        let mut min = f64::INFINITY;
        let mut max = 0.0f64;
        for v in 0..l {
            let w = f64::from(s.solid_angle(v));
            assert_eq!(s.solid_angle(v), s.solid_angle(v + l));
            min = min.min(w);
            max = max.max(w);
        }
        let spread = max / min;
        eprintln!("k={k}: solid-angle spread max/min = {spread:.4}");
        let bound = SPREAD_BOUND.iter().find(|b| b.0 == k).unwrap().1;
        assert!(spread <= bound, "k={k}: spread {spread}");
        // Mean is 4π / 2l.
        let mean = total / f64::from(2 * l);
        assert!(min <= mean && mean <= max);
    }
}

#[test]
fn triangle_solid_angles_sum_exactly() {
    // The f64 triangle solid angles tile the sphere (no gaps/overlaps).
    for k in TEST_K {
        let s = set(k);
        let total: f64 = s
            .sphere_triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| p64(s, v).normalize());
                spherical_triangle_solid_angle(a, b, c)
            })
            .sum();
        assert!((total / (4.0 * PI) - 1.0).abs() < 1e-12, "k={k}: {total}");
    }
}

/// Minimum over triangles of the (normalised) distance of the
/// circumcentre inside each edge plane, and minimum over edges of the
/// distance of the opposite vertex below the triangle's plane.
fn acute_delaunay_margins(s: &DirectionSet) -> (f64, f64) {
    let mut opposite: HashMap<(u32, u32), u32> = HashMap::new();
    for t in s.sphere_triangles() {
        for n in 0..3 {
            opposite.insert((t[n], t[(n + 1) % 3]), t[(n + 2) % 3]);
        }
    }
    let mut acute = f64::INFINITY;
    let mut convex = f64::INFINITY;
    for t in s.sphere_triangles() {
        let [a, b, c] = t.map(|v| p64(s, v));
        let normal = (b - a).cross(c - a).normalize();
        let scale = a.angle_between(b);
        for (p, q) in [(a, b), (b, c), (c, a)] {
            let en = p.cross(q).normalize();
            acute = acute.min(normal.dot(en) / scale);
        }
        for n in 0..3 {
            let o = opposite[&(t[(n + 1) % 3], t[n])];
            let dist = (p64(s, o) - a).dot(normal);
            convex = convex.min(-dist / (scale * scale));
        }
    }
    (acute, convex)
}

/// Guarantees `nearest` (see its docs): every triangle strictly contains
/// its circumcentre and every edge is locally convex, for every
/// supported frequency. Margins are relative to the edge length; the
/// measured minimum relative acute margin is ≈ 0.16 (equilateral: 0.29).
#[test]
fn acute_and_delaunay_all_frequencies() {
    let mut worst = (f64::INFINITY, f64::INFINITY);
    for k in 1..=MAX_FREQUENCY {
        let s = if TEST_K.contains(&k) {
            set(k).clone()
        } else {
            DirectionSet::with_frequency(k).unwrap()
        };
        let (a, c) = acute_delaunay_margins(&s);
        worst = (worst.0.min(a), worst.1.min(c));
    }
    eprintln!(
        "acute margin {:.4}, convexity margin {:.4}",
        worst.0, worst.1
    );
    assert!(worst.0 > 0.1, "{worst:?}");
    assert!(worst.1 > 0.05, "{worst:?}");
}

#[test]
fn octant_face_table_matches_full_search() {
    let s = set(3);
    let mut rng = 0x1234_5678_9abc_def0u64;
    for _ in 0..20000 {
        let d = random_unit(&mut rng);
        let full = (0..20)
            .map(|f| s.faces[f].normal.dot(d))
            .fold(f64::NEG_INFINITY, f64::max);
        let octant =
            usize::from(d.x < 0.0) | usize::from(d.y < 0.0) << 1 | usize::from(d.z < 0.0) << 2;
        let fast = s.octant_faces[octant]
            .iter()
            .map(|&f| s.faces[f as usize].normal.dot(d))
            .fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(full, fast);
    }
}

#[test]
fn vertices_map_to_themselves() {
    for k in TEST_K {
        let s = set(k);
        for v in 0..s.sphere_vertex_count() as u32 {
            let p = s.sphere_vertex(v);
            let lk = s.lookup(p);
            let n = lk
                .vertices
                .iter()
                .position(|&x| x == v)
                .expect("vertex in triangle");
            assert!(lk.weights[n] > 1.0 - 1e-6, "k={k} v={v} {lk:?}");
            assert_eq!(s.nearest(p), v);
            // Scaled input (rounded differently, so possibly another
            // triangle around the vertex).
            let lk = s.lookup(p * 7.5);
            let n = lk
                .vertices
                .iter()
                .position(|&x| x == v)
                .expect("vertex in triangle");
            assert!(lk.weights[n] > 1.0 - 1e-5, "k={k} v={v} {lk:?}");
        }
    }
}

#[test]
fn centroids_map_to_their_triangle() {
    for k in TEST_K {
        let s = set(k);
        for (t, tri) in s.sphere_triangles().iter().enumerate() {
            let c = tri.iter().map(|&v| s.sphere_vertex(v)).sum::<Vec3>();
            let lk = s.lookup(c);
            assert_eq!(lk.triangle as usize, t);
            assert_eq!(lk.vertices, *tri);
            for w in lk.weights {
                assert!((w - 1.0 / 3.0).abs() < 1e-3);
            }
        }
    }
}

#[test]
fn degenerate_input() {
    let s = set(10);
    for d in [
        Vec3::ZERO,
        -Vec3::ZERO,
        Vec3::NAN,
        Vec3::new(f32::INFINITY, 0.0, 0.0),
        Vec3::new(1.0, f32::NAN, 0.0),
    ] {
        let lk = s.lookup(d);
        assert_eq!(lk.weights.iter().sum::<f32>(), 1.0);
        assert!(lk.vertices.contains(&0));
        assert_eq!(
            lk.weights[lk.vertices.iter().position(|&v| v == 0).unwrap()],
            1.0
        );
        assert_eq!(s.nearest(d), 0);
    }
    // Tiny and huge (finite) inputs are fine.
    // Subnormal input: no NaN.
    let sub = s.lookup(Vec3::new(1e-44, 2e-44, 3e-44));
    assert!(sub.weights.iter().all(|w| w.is_finite() && *w >= 0.0));
    assert!((sub.weights.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    let tiny = s.lookup(Vec3::new(1e-30, 2e-30, 3e-30));
    let unit = s.lookup(Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(tiny.vertices, unit.vertices);
    let huge = s.lookup(Vec3::new(1e38, 2e38, 3e38));
    assert_eq!(huge.vertices, unit.vertices);
    for (a, b) in tiny.weights.iter().zip(unit.weights) {
        assert!((a - b).abs() < 1e-6);
    }
}

#[test]
fn axes_and_equator() {
    // Coordinate axes are icosahedron edge midpoints: on triangle edges
    // for odd k, vertices for even k.
    for k in TEST_K {
        let s = set(k);
        for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            check_lookup(s, d.as_dvec3());
            if k % 2 == 0 {
                let v = s.nearest(d);
                assert!(s.sphere_vertex(v).abs_diff_eq(d, 1e-6), "k={k} {d}");
            }
        }
    }
}

fn random_unit(rng: &mut u64) -> DVec3 {
    loop {
        let mut c = [0.0; 3];
        for x in &mut c {
            *rng ^= *rng << 13;
            *rng ^= *rng >> 7;
            *rng ^= *rng << 17;
            *x = (*rng >> 11) as f64 / (1u64 << 52) as f64 - 1.0;
        }
        let v = DVec3::from_array(c);
        let l2 = v.length_squared();
        if l2 > 1e-6 && l2 <= 1.0 {
            return v / l2.sqrt();
        }
    }
}

/// All lookup properties for direction `d` (f64, rounded to f32 input).
fn check_lookup(s: &DirectionSet, d: DVec3) {
    let df = d.as_vec3();
    let d = df.as_dvec3().normalize();
    let lk = s.lookup(df);
    let sum: f32 = lk.weights.iter().sum();
    assert!((sum - 1.0).abs() < 1e-5, "{lk:?}");
    assert!(lk.weights.iter().all(|&w| w >= 0.0), "{lk:?}");
    assert_eq!(s.sphere_triangles()[lk.triangle as usize], lk.vertices);
    let p = lk.vertices.map(|v| p64(s, v));
    // Reconstruction.
    let r = (0..3)
        .map(|n| p[n] * f64::from(lk.weights[n]))
        .sum::<DVec3>();
    let err = r.normalize().angle_between(d);
    assert!(err < 1e-5, "reconstruction error {err} rad for {d}: {lk:?}");
    // Containment: d is inside (or within rounding of) all edge planes.
    for n in 0..3 {
        let en = p[n].cross(p[(n + 1) % 3]).normalize();
        assert!(
            d.dot(en) >= -1e-6,
            "outside edge {n} by {}: {d} {lk:?}",
            d.dot(en)
        );
    }
    // Nearest vertex: brute force over all 2l.
    let best = (0..s.sphere_vertex_count() as u32)
        .map(|v| p64(s, v).dot(d))
        .fold(f64::NEG_INFINITY, f64::max);
    let tri_best = p.iter().map(|q| q.dot(d)).fold(f64::NEG_INFINITY, f64::max);
    assert!(
        tri_best >= best - 1e-9,
        "nearest not in triangle: {d} {lk:?}"
    );
    let nv = s.nearest(df);
    assert!(p64(s, nv).dot(d) >= best - 1e-9);
}

/// Builds a test direction of one of several kinds from raw parameters.
fn test_direction(s: &DirectionSet, kind: u8, r: [f64; 3], idx: u32, t: f64, eps: f64) -> DVec3 {
    let tris = s.sphere_triangles();
    let jitter = DVec3::from_array(r) * eps;
    match kind {
        // Uniform-ish random direction.
        0 => {
            let v = DVec3::from_array(r);
            if v.length_squared() < 1e-6 {
                DVec3::Z
            } else {
                v
            }
        }
        // Near a sphere vertex.
        1 => p64(s, idx % s.sphere_vertex_count() as u32) + jitter,
        // Near a triangle edge.
        2 => {
            let tri = tris[idx as usize % tris.len()];
            let e = (idx / 7 % 3) as usize;
            let (a, b) = (p64(s, tri[e]), p64(s, tri[(e + 1) % 3]));
            a.lerp(b, t).normalize() + jitter
        }
        // Near a pole / coordinate axis (exact when eps underflows in f32).
        3 => {
            let axis = [DVec3::X, DVec3::Y, DVec3::Z][idx as usize % 3];
            let sign = if idx & 8 != 0 { -1.0 } else { 1.0 };
            axis * sign + jitter
        }
        // Exactly on the coordinate planes.
        _ => {
            let mut v = DVec3::from_array(r);
            let zero = idx as usize % 3;
            v[zero] = 0.0;
            if v.length_squared() < 1e-6 {
                DVec3::X
            } else {
                v
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn lookup_properties(
        kn in 0usize..TEST_K.len(),
        kind in 0u8..5,
        r in prop::array::uniform3(-1.0f64..1.0),
        idx in any::<u32>(),
        t in 0.0f64..=1.0,
        exp in -12i32..-2,
    ) {
        let s = set(TEST_K[kn]);
        let d = test_direction(s, kind, r, idx, t, 10f64.powi(exp));
        check_lookup(s, d);
    }

    #[test]
    fn lookup_exact_edge_points(
        kn in 0usize..TEST_K.len(),
        idx in any::<u32>(),
        t in 0.0f64..=1.0,
    ) {
        // Points exactly on a great-circle edge (up to f32 rounding).
        let s = set(TEST_K[kn]);
        let d = test_direction(s, 2, [0.0; 3], idx, t, 0.0);
        check_lookup(s, d);
    }
}

#[test]
fn many_random_directions_all_k() {
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    for k in TEST_K {
        let s = set(k);
        let n = if k >= 40 { 300 } else { 2000 };
        for _ in 0..n {
            check_lookup(s, random_unit(&mut rng));
        }
    }
}

#[test]
fn construction_time() {
    for k in [40, 64] {
        let start = std::time::Instant::now();
        let s = DirectionSet::with_frequency(k).unwrap();
        let dt = start.elapsed();
        eprintln!("construction k={k} (l={}): {dt:?}", s.len());
        assert!(dt.as_secs_f64() < 5.0);
    }
}
