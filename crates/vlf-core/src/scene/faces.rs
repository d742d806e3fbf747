//! Merging triangles into planar polygons ([`Face`]s) and fitting their charts.
//!
//! 1. **Welding**: vertices are welded by *exact* world position (the `f32` bit
//!    pattern after the node transform, with −0 = +0). glTF exporters write shared
//!    corners with identical coordinates, so no tolerance is needed to reproduce the
//!    shared scenes' polygon counts, and no two distinct positions are ever merged.
//! 2. **Union-find** over triangles sharing a welded edge: two triangles are merged
//!    when they have the same material and their unit normals (computed in `f64`)
//!    satisfy `dot > cos 0.08°` ([`FACE_COS_TOLERANCE`]); equal-facing normals also
//!    mean the same winding side. For an edge shared by many triangles (non-manifold),
//!    every pair is compared up to [`PAIRWISE_LIMIT`] triangles; beyond that each
//!    triangle is compared with one representative per cluster (linear time on
//!    adversarial input).
//! 3. **Ordering**: faces are numbered by their first triangle in import order and
//!    triangles are stably regrouped so each face owns a contiguous range.
//! 4. **Chart**: the face's vertices are projected on its plane; the minimum-area
//!    bounding rectangle aligned with an edge of their convex hull gives (u, v)
//!    (u along the longer side) and the extent (hulls of more than
//!    [`MAX_CHART_DIRECTIONS`] edges try that many evenly spaced edge directions).

use std::collections::HashMap;

use glam::{DVec2, DVec3, Vec2, Vec3};

use super::{FACE_COS_TOLERANCE, Face, PlaneBasis, Triangle};

/// Above this many triangles on one edge, clustering replaces pairwise comparison.
pub(crate) const PAIRWISE_LIMIT: usize = 16;

/// At most this many hull edges are tried as chart directions per face.
const MAX_CHART_DIRECTIONS: usize = 1024;

/// A triangle before face assignment.
#[derive(Clone, Debug)]
pub(crate) struct RawTriangle {
    pub p: [Vec3; 3],
    pub uv: [Vec2; 3],
    pub material: u32,
    /// Shading normals, vertex colours and `TEXCOORD_1` ([`Triangle`]'s fields).
    pub normals: Option<[Vec3; 3]>,
    pub colors: Option<[Vec3; 3]>,
    pub uv1: Option<[Vec2; 3]>,
}

impl RawTriangle {
    /// A triangle with no attributes beyond its positions.
    pub fn plain(p: [Vec3; 3], material: u32) -> Self {
        RawTriangle {
            p,
            uv: [Vec2::ZERO; 3],
            material,
            normals: None,
            colors: None,
            uv1: None,
        }
    }
}

struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        let mut root = x;
        while self.parent[root as usize] != root {
            root = self.parent[root as usize];
        }
        while self.parent[x as usize] != root {
            let next = self.parent[x as usize];
            self.parent[x as usize] = root;
            x = next;
        }
        root
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        let (big, small) = if self.size[ra as usize] >= self.size[rb as usize] {
            (ra, rb)
        } else {
            (rb, ra)
        };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
    }
}

fn position_key(p: Vec3) -> [u32; 3] {
    // Adding +0.0 turns −0.0 into +0.0 so both weld together.
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

fn normal_f64(t: &RawTriangle) -> DVec3 {
    let [a, b, c] = t.p.map(|p| p.as_dvec3());
    (b - a).cross(c - a)
}

/// Groups triangles into faces. Returns the regrouped triangles and the faces.
pub(crate) fn build_faces(raw: Vec<RawTriangle>) -> (Vec<Triangle>, Vec<Face>) {
    let n = raw.len();
    // 1. Weld.
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(n * 3 / 2 + 1);
    let mut positions: Vec<Vec3> = Vec::new();
    let corners: Vec<[u32; 3]> = raw
        .iter()
        .map(|t| {
            t.p.map(|p| {
                *ids.entry(position_key(p)).or_insert_with(|| {
                    positions.push(p);
                    (positions.len() - 1) as u32
                })
            })
        })
        .collect();
    drop(ids);
    let normals: Vec<DVec3> = raw
        .iter()
        .map(|t| normal_f64(t).normalize_or_zero())
        .collect();

    // 2. Edges → union-find.
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(n * 3);
    for (t, c) in corners.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            if a != b {
                edges.push((a.min(b), a.max(b), t as u32));
            }
        }
    }
    edges.sort_unstable();
    let mut uf = UnionFind::new(n);
    let compatible = |a: u32, b: u32| {
        raw[a as usize].material == raw[b as usize].material
            && normals[a as usize].dot(normals[b as usize]) > FACE_COS_TOLERANCE
    };
    let mut start = 0;
    while start < edges.len() {
        let key = (edges[start].0, edges[start].1);
        let mut end = start + 1;
        while end < edges.len() && (edges[end].0, edges[end].1) == key {
            end += 1;
        }
        let group: Vec<u32> = edges[start..end].iter().map(|e| e.2).collect();
        if group.len() <= PAIRWISE_LIMIT {
            for i in 0..group.len() {
                for j in i + 1..group.len() {
                    if group[i] != group[j] && compatible(group[i], group[j]) {
                        uf.union(group[i], group[j]);
                    }
                }
            }
        } else {
            let mut reps: Vec<u32> = Vec::new();
            for &t in &group {
                let mut matched = false;
                for &r in &reps {
                    if compatible(t, r) {
                        uf.union(t, r);
                        matched = true;
                    }
                }
                if !matched {
                    reps.push(t);
                }
            }
        }
        start = end;
    }

    // 3. Number faces by first triangle; regroup triangles.
    let mut face_of_root: HashMap<u32, u32> = HashMap::new();
    let mut face_of_tri: Vec<u32> = Vec::with_capacity(n);
    for t in 0..n as u32 {
        let root = uf.find(t);
        let next = face_of_root.len() as u32;
        face_of_tri.push(*face_of_root.entry(root).or_insert(next));
    }
    let face_count = face_of_root.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by_key(|&t| face_of_tri[t as usize]); // stable: keeps import order

    let mut triangles: Vec<Triangle> = Vec::with_capacity(n);
    let mut faces: Vec<Face> = Vec::with_capacity(face_count);
    let mut i = 0;
    while i < order.len() {
        let f = face_of_tri[order[i] as usize];
        let mut j = i;
        while j < order.len() && face_of_tri[order[j] as usize] == f {
            j += 1;
        }
        let members = &order[i..j];
        let first = triangles.len() as u32;
        for &t in members {
            let r = &raw[t as usize];
            triangles.push(Triangle {
                p: r.p,
                uv: r.uv,
                material: r.material,
                face: f,
                normals: r.normals,
                colors: r.colors,
                uv1: r.uv1,
            });
        }
        let mut verts: Vec<u32> = members.iter().flat_map(|&t| corners[t as usize]).collect();
        verts.sort_unstable();
        verts.dedup();
        let pts: Vec<DVec3> = verts
            .iter()
            .map(|&v| positions[v as usize].as_dvec3())
            .collect();
        faces.push(fit_face(
            members.iter().map(|&t| &raw[t as usize]),
            &pts,
            raw[members[0] as usize].material,
            first..first + members.len() as u32,
        ));
        i = j;
    }
    (triangles, faces)
}

/// Plane, area and chart of one face.
fn fit_face<'a>(
    tris: impl Iterator<Item = &'a RawTriangle>,
    pts: &[DVec3],
    material: u32,
    range: std::ops::Range<u32>,
) -> Face {
    let mut cross_sum = DVec3::ZERO;
    let mut area = 0.0f64;
    let mut weighted_centroid = DVec3::ZERO;
    for t in tris {
        let c = normal_f64(t);
        let a = 0.5 * c.length();
        cross_sum += c;
        area += a;
        let [p0, p1, p2] = t.p.map(|p| p.as_dvec3());
        weighted_centroid += a * (p0 + p1 + p2) / 3.0;
    }
    let mut n = cross_sum.normalize_or_zero();
    if n == DVec3::ZERO {
        n = DVec3::Z; // unreachable for non-degenerate, consistently oriented triangles
    }
    let centroid = if area > 0.0 {
        weighted_centroid / area
    } else {
        pts.first().copied().unwrap_or(DVec3::ZERO)
    };
    let offset = n.dot(centroid);

    // Arbitrary in-plane frame, then the minimum-area rectangle over hull edges.
    let (t1, t2) = n.any_orthonormal_pair();
    let projected: Vec<DVec2> = pts
        .iter()
        .map(|p| DVec2::new(p.dot(t1), p.dot(t2)))
        .collect();
    let hull = convex_hull(projected);
    // Every hull edge is a candidate direction; very large hulls (a finely tessellated
    // disk) test at most MAX_CHART_DIRECTIONS evenly spaced edges to stay O(h). The
    // extent is always measured over every point, so containment stays exact.
    let step = hull.len().div_ceil(MAX_CHART_DIRECTIONS).max(1);
    let mut candidates: Vec<(f64, DVec2)> = Vec::new();
    for k in (0..hull.len()).step_by(step) {
        let e = hull[(k + 1) % hull.len()] - hull[k];
        let len = e.length();
        if len <= 0.0 {
            continue;
        }
        let d = e / len;
        let (lo, hi) = extent_along(&hull, d);
        candidates.push(((hi.x - lo.x) * (hi.y - lo.y), d));
    }
    // Near-ties (a square fits several minimal rectangles; rounding picks among them) are
    // broken by a fixed world-space rule, so the chart does not turn when the scene is scaled:
    // prefer the rectangle with an axis most aligned with CHART_REFERENCE.
    let best_area = candidates.iter().map(|c| c.0).fold(f64::INFINITY, f64::min);
    let axis_score = |a: DVec3| a.dot(CHART_REFERENCE).abs();
    let to_3d = |d: DVec2| (t1 * d.x + t2 * d.y).normalize();
    let best_dir = candidates
        .iter()
        .filter(|c| c.0 <= best_area * (1.0 + TIE))
        .map(|c| c.1)
        .max_by(|a, b| {
            let s = |d: DVec2| {
                let u = to_3d(d);
                axis_score(u).max(axis_score(n.cross(u)))
            };
            s(*a).total_cmp(&s(*b))
        })
        .unwrap_or(DVec2::X);
    let mut u = to_3d(best_dir);
    let mut v = n.cross(u);
    let (mut lo, mut hi) = range_3d(pts, u, v);
    let (wu, wv) = (hi.x - lo.x, hi.y - lo.y);
    // u along the longer side; for (near-)squares the axis most aligned with the reference.
    let swap = if (wu - wv).abs() > TIE * wu.max(wv) {
        wv > wu
    } else {
        axis_score(v) > axis_score(u)
    };
    if swap {
        // (v, −u) keeps u × v = n.
        (u, v) = (v, -u);
    }
    if u.dot(CHART_REFERENCE) < 0.0 {
        // Rotate by 180° in the plane: (−u, −v) keeps u × v = n.
        (u, v) = (-u, -v);
    }
    (lo, hi) = range_3d(pts, u, v);
    let origin = n * offset + u * lo.x + v * lo.y;
    Face {
        normal: n.as_vec3(),
        offset: offset as f32,
        material,
        triangles: range,
        area: area as f32,
        basis: PlaneBasis {
            origin: origin.as_vec3(),
            u: u.as_vec3(),
            v: v.as_vec3(),
        },
        extent: (hi - lo).as_vec2(),
    }
}

/// Fixed world direction that breaks ties between equally good chart orientations.
const CHART_REFERENCE: DVec3 = DVec3::new(
    0.267_261_241_912_424_4,
    0.534_522_483_824_848_8,
    0.801_783_725_737_273_2,
);
/// Relative tolerance under which two chart rectangles (or side lengths) count as equal.
const TIE: f64 = 1e-6;

/// Min/max of the points' coordinates along `d` and its perpendicular.
fn extent_along(pts: &[DVec2], d: DVec2) -> (DVec2, DVec2) {
    let perp = d.perp();
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in pts {
        let q = DVec2::new(p.dot(d), p.dot(perp));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo, hi)
}

fn range_3d(pts: &[DVec3], u: DVec3, v: DVec3) -> (DVec2, DVec2) {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in pts {
        let q = DVec2::new(p.dot(u), p.dot(v));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo, hi)
}

/// Andrew's monotone chain; returns the hull counter-clockwise without repeats.
fn convex_hull(mut pts: Vec<DVec2>) -> Vec<DVec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(pts.len() * 2);
    // Lower hull on the forward pass…
    for &p in &pts {
        while hull.len() >= 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    // …upper hull on the backward pass, never popping into the lower hull.
    let lower = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(corners: [Vec3; 4], material: u32) -> [RawTriangle; 2] {
        let [a, b, c, d] = corners;
        [
            RawTriangle::plain([a, b, c], material),
            RawTriangle::plain([a, c, d], material),
        ]
    }

    #[test]
    fn hull_of_square_with_interior_point() {
        let h = convex_hull(vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.5, 0.5),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.5, 0.0),
        ]);
        assert_eq!(h.len(), 4);
    }

    #[test]
    fn quad_becomes_one_face_with_tight_chart() {
        // A 2 × 1 rectangle rotated 30° in the z = 1 plane.
        let (s, c) = 30f32.to_radians().sin_cos();
        let rot = |x: f32, y: f32| Vec3::new(c * x - s * y, s * x + c * y, 1.0);
        let tris = quad(
            [rot(0.0, 0.0), rot(2.0, 0.0), rot(2.0, 1.0), rot(0.0, 1.0)],
            0,
        );
        let (t, f) = build_faces(tris.to_vec());
        assert_eq!(t.len(), 2);
        assert_eq!(f.len(), 1);
        let face = &f[0];
        assert!((face.normal - Vec3::Z).length() < 1e-6);
        assert!((face.offset - 1.0).abs() < 1e-6);
        assert!((face.area - 2.0).abs() < 1e-5);
        assert!(
            (face.extent - Vec2::new(2.0, 1.0)).length() < 1e-5,
            "{:?}",
            face.extent
        );
        assert!((face.basis.u.cross(face.basis.v) - face.normal).length() < 1e-5);
        for tri in &t {
            for p in tri.p {
                let q = face.basis.to_chart(p);
                assert!(q.x > -1e-5 && q.y > -1e-5 && q.x < 2.0 + 1e-5 && q.y < 1.0 + 1e-5);
            }
        }
    }

    /// A convex polygon (fan-triangulated around its centre) rotated into an arbitrary plane.
    fn polygon(n: usize, radius: f32, rot: glam::Quat, offset: Vec3) -> Vec<RawTriangle> {
        let pts: Vec<Vec3> = (0..n)
            .map(|k| {
                let a = std::f32::consts::TAU * k as f32 / n as f32;
                rot * Vec3::new(radius * a.cos(), 0.5 * radius * a.sin(), 0.0) + offset
            })
            .collect();
        let centre = rot * Vec3::ZERO + offset;
        (0..n)
            .map(|k| RawTriangle::plain([centre, pts[k], pts[(k + 1) % n]], 0))
            .collect()
    }

    fn check_chart(t: &[Triangle], f: &Face) {
        let tol = 1e-4 * (1.0 + f.extent.x);
        for tri in t {
            for p in tri.p {
                let q = f.basis.to_chart(p);
                assert!(q.x > -tol && q.y > -tol, "{q} below 0");
                assert!(
                    q.x < f.extent.x + tol && q.y < f.extent.y + tol,
                    "{q} beyond {}",
                    f.extent
                );
            }
        }
    }

    #[test]
    fn huge_polygon_is_one_face() {
        // In a z = const plane so that f32 rounding cannot tilt the 20,000 thin
        // triangles apart by more than the 0.08° tolerance.
        let rot = glam::Quat::from_rotation_z(0.7);
        let tris = polygon(20_000, 3.0, rot, Vec3::new(1.0, 2.0, 3.0));
        let t0 = std::time::Instant::now();
        let (t, f) = build_faces(tris);
        assert!(
            t0.elapsed().as_secs_f64() < 5.0,
            "chart fit is not quadratic"
        );
        assert_eq!(f.len(), 1);
        assert!((f[0].normal - rot * Vec3::Z).length() < 1e-4);
        assert!((f[0].extent.x - 6.0).abs() < 1e-2 && (f[0].extent.y - 3.0).abs() < 1e-2);
        check_chart(&t, &f[0]);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        #[test]
        fn random_planar_polygons(
            n in 3usize..40,
            radius in 1.0f32..100.0,
            (a, b, c) in (-3.2f32..3.2, -3.2f32..3.2, -3.2f32..3.2),
            (x, y, z) in (-50f32..50.0, -50f32..50.0, -50f32..50.0),
        ) {
            let rot = glam::Quat::from_euler(glam::EulerRot::XYZ, a, b, c);
            let tris = polygon(n, radius, rot, Vec3::new(x, y, z));
            let area: f32 = tris.iter().map(|t| 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length()).sum();
            let (t, f) = build_faces(tris);
            proptest::prop_assert_eq!(f.len(), 1);
            proptest::prop_assert!((f[0].normal - rot * Vec3::Z).length() < 1e-3);
            proptest::prop_assert!((f[0].area - area).abs() <= 1e-3 * area);
            proptest::prop_assert!(f[0].extent.x >= f[0].extent.y);
            // A tight chart: its rectangle is at most the polygon's axis box (2r × r).
            proptest::prop_assert!(f[0].extent.x * f[0].extent.y <= 2.0 * radius * radius * 1.001);
            check_chart(&t, &f[0]);
        }
    }

    #[test]
    fn materials_and_bends_split_faces() {
        let mut tris = quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y], 0).to_vec();
        // Same plane, adjacent along x = 1, other material.
        tris.extend(quad(
            [
                Vec3::X,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ],
            1,
        ));
        // Bent by 0.1° along y = 1 (more than 0.08°): separate face.
        let h = 0.1f32.to_radians().tan();
        tris.extend(quad(
            [
                Vec3::Y,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(1.0, 2.0, h),
                Vec3::new(0.0, 2.0, h),
            ],
            0,
        ));
        // Bent by 0.05°: same face as the first quad... but it is adjacent to the
        // second quad's material only along x = 2, so attach it at y = 0 instead.
        let h2 = 0.05f32.to_radians().tan();
        tris.extend(quad(
            [
                Vec3::new(0.0, -1.0, h2),
                Vec3::new(1.0, -1.0, h2),
                Vec3::X,
                Vec3::ZERO,
            ],
            0,
        ));
        let (t, f) = build_faces(tris);
        assert_eq!(f.len(), 3);
        assert_eq!(f[0].triangles, 0..4);
        assert_eq!(t[0].face, 0);
        assert_eq!(f[1].material, 1);
    }
}
