//! The global direction set of the virtual light field.
//!
//! The VLF stores radiance for `l` *bi-directional* directions `ω_i`: parallel
//! subfield (PSF) `i` carries light travelling along both `+ω_i` and `−ω_i`
//! (paper §2.1). The `2l` unit vectors `±ω_i` are the vertices of a triangle
//! mesh on the unit sphere. That mesh is used for
//!
//! * **propagation quadrature**: each sphere vertex owns a solid angle
//!   ([`DirectionSet::solid_angle`]), one third of each adjacent spherical
//!   triangle, so the weights tile the sphere exactly;
//! * **interpolation** (paper §3.4, §4): any direction falls in exactly one
//!   spherical triangle whose three vertex PSFs are blended with barycentric
//!   weights ([`DirectionSet::lookup`]). The GPU renderer draws this very mesh
//!   from the sphere centre, so the weights are the *perspective-correct*
//!   barycentrics of the flat triangle through the three unit vertices (the
//!   gnomonic barycentrics) — CPU and GPU interpolation agree exactly.
//!
//! # Construction
//!
//! The mesh is the frequency-`k` geodesic subdivision of the regular
//! icosahedron: every icosahedron face carries a regular triangular grid whose
//! points are centrally projected (normalised) onto the sphere. This gives
//! `10k² + 2` sphere vertices, `20k²` triangles and `l = 5k² + 1` directions
//! (`k = 10`: 501, close to the paper's 512). The icosahedron is centrally
//! symmetric, so the vertex set is antipodal and splits into `l` pairs.
//!
//! Vertices shared between icosahedron faces (the 12 corners and the points on
//! the 30 edges) are identified *structurally* — by corner / edge / face and
//! integer grid coordinates — never by comparing floating-point positions.
//!
//! Sphere vertex ids are `0..2l`: vertex `v` is direction `v % l` with sense
//! `v / l` (0 = `+ω`, 1 = `−ω`); the stored position of `v + l` is exactly the
//! negation of that of `v`. The canonical `ω_i` lie on the hemisphere
//! `z > 0`, ties on the equator broken by `y > 0`, then `x > 0`
//! ([`is_canonical`]).
//!
//! The icosahedron is placed in the standard orientation with corners
//! `(0, ±1, ±φ)`, `(±1, ±φ, 0)`, `(±φ, 0, ±1)` (normalised), which is
//! symmetric under reflection in the three coordinate planes; the coordinate
//! axes are midpoints of icosahedron edges.

use glam::{DVec3, Vec3};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Largest supported subdivision frequency (`l = 20481` directions).
pub const MAX_FREQUENCY: u32 = 64;

/// Number of bi-directional directions `l = 5k² + 1` of the frequency-`k` set.
pub const fn directions_for_frequency(k: u32) -> u32 {
    5 * k * k + 1
}

/// Errors from building a [`DirectionSet`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DirectionError {
    /// The subdivision frequency is outside `1..=MAX_FREQUENCY`.
    #[error("direction-set frequency {0} is outside 1..={MAX_FREQUENCY}")]
    FrequencyOutOfRange(u32),
    /// More directions were requested than the largest supported set has.
    #[error("{0} directions requested, but at most {max} are supported", max = directions_for_frequency(MAX_FREQUENCY))]
    TooManyDirections(u32),
}

/// Which construction produced a direction set. Serialised in file headers so
/// that a change of algorithm can never silently reinterpret old data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DirectionScheme {
    /// Gnomonic (centrally projected) geodesic subdivision of the
    /// standard-orientation icosahedron, as described in the module docs.
    IcosahedralGnomonicV1,
}

/// Compact, serialisable description of a [`DirectionSet`]: the set is a
/// deterministic function of these fields and is rebuilt on deserialisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct DirectionSetDesc {
    /// Construction scheme.
    pub scheme: DirectionScheme,
    /// Subdivision frequency `k`.
    pub frequency: u32,
}

/// Result of [`DirectionSet::lookup`]: the spherical triangle containing a
/// direction and the direction's barycentric weights in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// Sphere-vertex ids (`0..2l`, see [`DirectionSet::sphere_vertex`]) of
    /// the containing triangle, in the triangle's counter-clockwise order.
    pub vertices: [u32; 3],
    /// Gnomonic barycentric weights: `>= 0`, summing to 1, with
    /// `d ∝ Σ weights[n] · sphere_vertex(vertices[n])` — the perspective-correct
    /// barycentrics of the flat triangle through the three stored vertices
    /// seen from the sphere centre.
    pub weights: [f32; 3],
    /// Index of the containing triangle in [`DirectionSet::sphere_triangles`].
    pub triangle: u32,
}

/// The icosahedron tables of [`DirectionSet::lookup`] in f32 ([`DirectionSet::lookup_tables`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookupTables {
    /// Frequency `k`.
    pub k: u32,
    /// Unit outward normal of each icosahedron face.
    pub face_normals: [Vec3; 20],
    /// `c_j × c_k` for the cyclic corner triples of each face: `d · edge_normals[f][n]` is
    /// proportional to the flat-face barycentric of corner `n`.
    pub edge_normals: [[Vec3; 3]; 20],
    /// For each sign octant (bit 0: x < 0, bit 1: y < 0, bit 2: z < 0) the four faces that can
    /// contain a direction of that octant.
    pub octant_faces: [[u32; 4]; 8],
}

/// The set of `l` bi-directional VLF directions and the spherical triangle
/// mesh over their `2l` senses `±ω_i`. See the module docs for the layout.
///
/// Everything needed for O(1) lookup is precomputed at construction.
/// Serialises as its [`DirectionSetDesc`] only (a few bytes); deserialising
/// rebuilds the tables.
#[derive(Clone)]
pub struct DirectionSet {
    /// Frequency `k`.
    k: u32,
    /// Number of directions `l`.
    l: u32,
    /// Unit positions of the `2l` sphere vertices; `positions[v + l] == -positions[v]`.
    positions: Vec<Vec3>,
    /// `20k²` counter-clockwise (from outside) triangles; triangle
    /// `f·k² + 2kj − j² + 2i + down` is cell `(i, j)` of icosahedron face `f`.
    triangles: Vec<[u32; 3]>,
    /// Per-direction quadrature weight (identical for both senses).
    solid_angles: Vec<f32>,
    /// Icosahedron faces as used by the lookup.
    faces: [FaceData; 20],
    /// For each sign octant (bit 0: x < 0, bit 1: y < 0, bit 2: z < 0) the
    /// four faces that can contain a direction of that octant.
    octant_faces: [[u8; 4]; 8],
    /// Answer for zero-length or non-finite input.
    fallback: Lookup,
}

/// Per-icosahedron-face lookup data (f64 for robust cell selection).
#[derive(Clone, Copy, Debug)]
struct FaceData {
    /// Unit outward face normal (direction of the face centroid).
    normal: DVec3,
    /// `c_j × c_k` for the cyclic corner triples: `d · edge_normals[n]` is
    /// proportional to the flat-face barycentric of corner `n`.
    edge_normals: [DVec3; 3],
}

impl std::fmt::Debug for DirectionSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DirectionSet")
            .field("scheme", &DirectionScheme::IcosahedralGnomonicV1)
            .field("frequency", &self.k)
            .field("directions", &self.l)
            .finish_non_exhaustive()
    }
}

/// Two sets are equal when they were built with the same parameters (the set
/// is a deterministic function of them).
impl PartialEq for DirectionSet {
    fn eq(&self, other: &Self) -> bool {
        self.k == other.k
    }
}

impl Eq for DirectionSet {}

impl Serialize for DirectionSet {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.desc().serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for DirectionSet {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let desc = DirectionSetDesc::deserialize(deserializer)?;
        Self::from_desc(&desc).map_err(serde::de::Error::custom)
    }
}

/// The canonical-hemisphere rule: `z > 0`, or `z == 0 && y > 0`, or
/// `z == y == 0 && x > 0`. Exactly one of `p` and `-p` satisfies it for any
/// non-zero `p`.
pub fn is_canonical(p: Vec3) -> bool {
    if p.z != 0.0 {
        p.z > 0.0
    } else if p.y != 0.0 {
        p.y > 0.0
    } else {
        p.x > 0.0
    }
}

impl DirectionSet {
    /// Builds the frequency-`k` set (`l = 5k² + 1` directions), `k` in
    /// `1..=MAX_FREQUENCY`.
    pub fn with_frequency(k: u32) -> Result<Self, DirectionError> {
        if !(1..=MAX_FREQUENCY).contains(&k) {
            return Err(DirectionError::FrequencyOutOfRange(k));
        }
        Ok(Self::build(k))
    }

    /// Builds the smallest set with at least `l` directions (smallest `k`
    /// with `5k² + 1 >= l`; `k >= 1`).
    pub fn at_least(l: u32) -> Result<Self, DirectionError> {
        let k = (1..=MAX_FREQUENCY)
            .find(|&k| directions_for_frequency(k) >= l)
            .ok_or(DirectionError::TooManyDirections(l))?;
        Self::with_frequency(k)
    }

    /// Rebuilds a set from its serialised description.
    pub fn from_desc(desc: &DirectionSetDesc) -> Result<Self, DirectionError> {
        match desc.scheme {
            DirectionScheme::IcosahedralGnomonicV1 => Self::with_frequency(desc.frequency),
        }
    }

    /// The description this set is serialised as.
    pub fn desc(&self) -> DirectionSetDesc {
        DirectionSetDesc {
            scheme: DirectionScheme::IcosahedralGnomonicV1,
            frequency: self.k,
        }
    }

    /// Number of bi-directional directions `l`.
    pub fn len(&self) -> usize {
        self.l as usize
    }

    /// Always false (a set has at least 6 directions); for API completeness.
    pub fn is_empty(&self) -> bool {
        self.l == 0
    }

    /// Subdivision frequency `k`.
    pub fn frequency(&self) -> u32 {
        self.k
    }

    /// Number of sphere vertices, `2l`.
    pub fn sphere_vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Canonical direction `ω_i` (unit, on the canonical hemisphere, see
    /// [`is_canonical`]). Panics if `i >= len()`.
    pub fn direction(&self, i: usize) -> Vec3 {
        assert!(i < self.len(), "direction index {i} out of range");
        self.positions[i]
    }

    /// All canonical directions `ω_0 .. ω_{l-1}`.
    pub fn directions(&self) -> &[Vec3] {
        &self.positions[..self.len()]
    }

    /// Position of sphere vertex `v`: `+ω_v` for `v < l`, `−ω_{v−l}` otherwise.
    /// Panics if `v >= 2l`.
    pub fn sphere_vertex(&self, v: u32) -> Vec3 {
        self.positions[v as usize]
    }

    /// All `2l` sphere-vertex positions, indexed by sphere-vertex id.
    pub fn sphere_vertices(&self) -> &[Vec3] {
        &self.positions
    }

    /// The `20k²` spherical triangles (sphere-vertex ids), counter-clockwise
    /// seen from outside the sphere. Together they tile the sphere.
    pub fn sphere_triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Quadrature weight of sphere vertex `v`: one third of the solid angle
    /// of each adjacent spherical triangle (computed in f64 from the stored
    /// vertices), symmetrised so that `Ω(v) == Ω(v + l)` exactly. The weights
    /// of all `2l` vertices sum to 4π. Panics if `v >= 2l`.
    pub fn solid_angle(&self, v: u32) -> f32 {
        assert!(
            (v as usize) < self.positions.len(),
            "sphere vertex {v} out of range"
        );
        self.solid_angles[(v % self.l) as usize]
    }

    /// The icosahedron tables [`lookup`](Self::lookup) uses, in f32, for the same lookup on
    /// the GPU (`shaders/common/directions.wgsl`, with [`sphere_vertices`](Self::sphere_vertices)
    /// and [`sphere_triangles`](Self::sphere_triangles)).
    pub fn lookup_tables(&self) -> LookupTables {
        LookupTables {
            k: self.k,
            face_normals: self.faces.map(|f| f.normal.as_vec3()),
            edge_normals: self.faces.map(|f| f.edge_normals.map(|e| e.as_vec3())),
            octant_faces: self.octant_faces.map(|o| o.map(u32::from)),
        }
    }

    /// Finds the spherical triangle containing direction `d` (any length) and
    /// the gnomonic barycentric weights of `d` in it. O(1): one of four
    /// icosahedron faces is chosen by sign octant, `d` is projected into that
    /// face's plane and the triangular grid cell is computed directly.
    ///
    /// Points on shared edges or vertices get one of the adjacent triangles;
    /// weights are clamped at 0 and renormalised, so they are always `>= 0`
    /// and sum to 1. A zero-length or non-finite `d` returns weight 1 on
    /// sphere vertex 0 (`+ω_0`), never NaN.
    pub fn lookup(&self, d: Vec3) -> Lookup {
        match normalized_f64(d) {
            Some(d) => self.lookup_unit(d),
            None => self.fallback,
        }
    }

    /// The sphere vertex closest to direction `d` (maximal dot product).
    ///
    /// This is the best of [`lookup`](Self::lookup)'s three vertices, which is
    /// exact for these meshes: every spherical triangle of every supported
    /// frequency strictly contains its circumcentre and the mesh is the convex
    /// hull of its vertices (spherical Delaunay) — both verified for all
    /// `k in 1..=64` by the `acute_and_delaunay_all_frequencies` test. Then the
    /// Voronoi cell of each vertex lies inside the union of its adjacent
    /// triangles, so the vertex whose cell contains `d` is a corner of the
    /// triangle containing `d`. (Up to ties within float rounding.)
    /// Zero-length or non-finite `d` returns 0.
    pub fn nearest(&self, d: Vec3) -> u32 {
        let Some(du) = normalized_f64(d) else {
            return 0;
        };
        let lk = self.lookup_unit(du);
        let mut best = lk.vertices[0];
        let mut best_dot = f64::NEG_INFINITY;
        for &v in &lk.vertices {
            let dot = self.positions[v as usize].as_dvec3().dot(du);
            if dot > best_dot {
                best_dot = dot;
                best = v;
            }
        }
        best
    }

    /// Lookup for a unit (f64) direction.
    fn lookup_unit(&self, d: DVec3) -> Lookup {
        // 1. Icosahedron face: the ray leaves the (convex, origin-centred)
        //    icosahedron through the face maximising d·n. The normals are
        //    symmetric under coordinate reflections, so the maximiser is among
        //    the four normals whose non-zero components have d's signs.
        let octant =
            usize::from(d.x < 0.0) | usize::from(d.y < 0.0) << 1 | usize::from(d.z < 0.0) << 2;
        let mut f = self.octant_faces[octant][0] as usize;
        let mut best = self.faces[f].normal.dot(d);
        for &c in &self.octant_faces[octant][1..] {
            let dot = self.faces[c as usize].normal.dot(d);
            if dot > best {
                best = dot;
                f = c as usize;
            }
        }
        // 2. Flat-face barycentrics of the central projection of d.
        let face = &self.faces[f];
        let b1 = d.dot(face.edge_normals[1]);
        let b2 = d.dot(face.edge_normals[2]);
        let s = d.dot(face.edge_normals[0]) + b1 + b2;
        let kf = f64::from(self.k);
        let (x, y) = if s > 0.0 {
            (b1 / s * kf, b2 / s * kf)
        } else {
            (0.0, 0.0) // unreachable for a correctly chosen face
        };
        // 3. Grid cell (i, j) and up/down half: the spherical sub-triangles
        //    project centrally onto exactly the flat grid triangles.
        let km1 = self.k - 1;
        let i = floor_clamped(x, km1);
        let mut j = floor_clamped(y, km1);
        let down;
        if i + j > km1 {
            // At (or, by rounding, just past) the face edge opposite corner 0:
            // the up triangle of this column touches it.
            j = km1 - i;
            down = false;
        } else {
            let (fx, fy) = (x - f64::from(i), y - f64::from(j));
            down = fx + fy > 1.0 && i + j < km1;
        }
        let t = f as u32 * self.k * self.k + 2 * self.k * j - j * j + 2 * i + u32::from(down);
        let vertices = self.triangles[t as usize];
        // 4. Gnomonic barycentrics against the three stored (f32, unit to
        //    ~6e-8) vertices — the very triangle the GPU rasterises — not
        //    against the flat grid cell, which is not coplanar with them.
        let [p0, p1, p2] = vertices.map(|v| self.positions[v as usize].as_dvec3());
        let mut w = [
            d.dot(p1.cross(p2)).max(0.0),
            d.dot(p2.cross(p0)).max(0.0),
            d.dot(p0.cross(p1)).max(0.0),
        ];
        let sum = w[0] + w[1] + w[2];
        if sum > 0.0 && sum.is_finite() {
            w = w.map(|x| x / sum);
        } else {
            // Only reachable through pathological rounding: snap to the
            // closest corner.
            let dots = [d.dot(p0), d.dot(p1), d.dot(p2)];
            let m = (0..3).fold(0, |m, n| if dots[n] > dots[m] { n } else { m });
            w = [0.0; 3];
            w[m] = 1.0;
        }
        Lookup {
            vertices,
            weights: w.map(|x| x as f32),
            triangle: t,
        }
    }

    fn build(k: u32) -> Self {
        let ico = Icosahedron::new();
        let l = directions_for_frequency(k);
        let n_struct = 2 * l as usize;
        let ppf = points_per_face(k);

        // Structural vertex ids for every grid point of every face, the
        // structural id of each point's antipode, and one f64 position per
        // structural vertex.
        let mut face_grid = vec![0u32; 20 * ppf];
        let mut anti = vec![u32::MAX; n_struct];
        let mut pos = vec![DVec3::ZERO; n_struct];
        for f in 0..20 {
            let fc = ico.faces[f];
            let af = ico.anti_face[f] as usize;
            let afc = ico.faces[af];
            let perm = fc.map(|c| {
                let ac = ico.anti_corner[c as usize];
                afc.iter().position(|&x| x == ac).expect("antipodal face")
            });
            let corners = fc.map(|c| ico.corners[c as usize]);
            for j in 0..=k {
                for i in 0..=k - j {
                    let w = [k - i - j, i, j];
                    let s = struct_id(&ico, k, f, w);
                    face_grid[f * ppf + grid_index(k, i, j)] = s;
                    if anti[s as usize] == u32::MAX {
                        let mut wa = [0; 3];
                        for n in 0..3 {
                            wa[perm[n]] = w[n];
                        }
                        anti[s as usize] = struct_id(&ico, k, af, wa);
                        pos[s as usize] = (corners[0] * f64::from(w[0])
                            + corners[1] * f64::from(w[1])
                            + corners[2] * f64::from(w[2]))
                        .normalize();
                    }
                }
            }
        }

        // Final ids: antipodal pairs (s, anti s) get ids (i, i + l), with the
        // canonical-hemisphere member first; the antipode's position is set
        // to the exact negation.
        let lu = l as usize;
        let mut final_id = vec![u32::MAX; n_struct];
        let mut positions = vec![Vec3::ZERO; n_struct];
        let mut next = 0u32;
        for s in 0..n_struct {
            if final_id[s] != u32::MAX {
                continue;
            }
            let a = anti[s] as usize;
            debug_assert!(a != s && anti[a] as usize == s);
            let p = pos[s].as_vec3();
            let (plus, minus, canonical) = if is_canonical(p) {
                (s, a, p)
            } else {
                (a, s, -p)
            };
            final_id[plus] = next;
            final_id[minus] = next + l;
            positions[next as usize] = canonical;
            positions[next as usize + lu] = -canonical;
            next += 1;
        }
        debug_assert_eq!(next, l);
        for id in &mut face_grid {
            *id = final_id[*id as usize];
        }

        // Triangles, cell by cell in the layout documented on the field.
        let mut triangles = Vec::with_capacity(20 * (k * k) as usize);
        for f in 0..20 {
            let g = |i: u32, j: u32| face_grid[f * ppf + grid_index(k, i, j)];
            for j in 0..k {
                for i in 0..k - j {
                    triangles.push([g(i, j), g(i + 1, j), g(i, j + 1)]);
                    if i + j + 1 < k {
                        triangles.push([g(i + 1, j), g(i + 1, j + 1), g(i, j + 1)]);
                    }
                }
            }
        }

        // Quadrature weights: a third of each triangle's solid angle to each
        // corner, accumulated per direction over both senses and halved.
        let mut acc = vec![0.0f64; lu];
        for t in &triangles {
            // Normalise in f64: the f32 vertices are unit only to ~6e-8.
            let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3().normalize());
            let third = spherical_triangle_solid_angle(a, b, c) / 3.0;
            for &v in t {
                acc[(v % l) as usize] += third;
            }
        }
        let solid_angles = acc.iter().map(|&x| (0.5 * x) as f32).collect();

        let faces = std::array::from_fn(|f| {
            let c = ico.faces[f].map(|c| ico.corners[c as usize]);
            FaceData {
                normal: (c[0] + c[1] + c[2]).normalize(),
                edge_normals: [c[1].cross(c[2]), c[2].cross(c[0]), c[0].cross(c[1])],
            }
        });
        let octant_faces = std::array::from_fn(|o| {
            let sign = DVec3::new(
                if o & 1 != 0 { -1.0 } else { 1.0 },
                if o & 2 != 0 { -1.0 } else { 1.0 },
                if o & 4 != 0 { -1.0 } else { 1.0 },
            );
            let cands: Vec<u8> = (0..20u8)
                .filter(|&f| {
                    let n: DVec3 = faces[f as usize].normal;
                    (n * sign).to_array().iter().all(|&x| x > -1e-9)
                })
                .collect();
            cands.try_into().expect("four candidate faces per octant")
        });

        let mut set = Self {
            k,
            l,
            positions,
            triangles,
            solid_angles,
            faces,
            octant_faces,
            fallback: Lookup {
                vertices: [0; 3],
                weights: [1.0, 0.0, 0.0],
                triangle: 0,
            },
        };
        let mut fallback = set.lookup_unit(set.positions[0].as_dvec3());
        // Make the fallback exact: all weight on vertex 0.
        fallback.weights = fallback.vertices.map(|v| if v == 0 { 1.0 } else { 0.0 });
        set.fallback = fallback;
        set
    }
}

/// `d` as a unit f64 vector, or `None` if it has zero length or is not finite.
fn normalized_f64(d: Vec3) -> Option<DVec3> {
    let d = d.as_dvec3();
    let len2 = d.length_squared();
    (len2 > 0.0 && len2.is_finite()).then(|| d / len2.sqrt())
}

/// `floor(x)` clamped to `0..=max` (NaN gives 0).
fn floor_clamped(x: f64, max: u32) -> u32 {
    let f = x.floor();
    if f >= f64::from(max) {
        max
    } else if f > 0.0 {
        f as u32
    } else {
        0
    }
}

/// Grid points per icosahedron face: `(k+1)(k+2)/2`.
fn points_per_face(k: u32) -> usize {
    ((k + 1) * (k + 2) / 2) as usize
}

/// Index of grid point `(i, j)` (`i + j <= k`) within its face's table.
fn grid_index(k: u32, i: u32, j: u32) -> usize {
    (j * (k + 1) - j * (j.saturating_sub(1)) / 2 + i) as usize
}

/// Structural id of the grid point with integer barycentric weights `w`
/// (summing to `k`) on icosahedron face `f`: corners `0..12`, then `k − 1`
/// points per edge (ordered from the lower corner id), then the
/// `(k−1)(k−2)/2` interior points of each face.
fn struct_id(ico: &Icosahedron, k: u32, f: usize, w: [u32; 3]) -> u32 {
    let fc = ico.faces[f];
    let nonzero = w.iter().filter(|&&x| x > 0).count();
    match nonzero {
        1 => {
            let n = w.iter().position(|&x| x > 0).unwrap_or(0);
            u32::from(fc[n])
        }
        2 => {
            let mut slots = (0..3).filter(|&n| w[n] > 0);
            let (s, t) = (slots.next().unwrap_or(0), slots.next().unwrap_or(0));
            let (p, q, wq) = if fc[s] < fc[t] {
                (fc[s], fc[t], w[t])
            } else {
                (fc[t], fc[s], w[s])
            };
            let e = u32::from(ico.edge_index[p as usize][q as usize]);
            12 + e * (k - 1) + (wq - 1)
        }
        _ => {
            let (i, j) = (w[1], w[2]);
            let local = (j - 1) * (k - 1) - (j - 1) * j / 2 + (i - 1);
            12 + 30 * (k - 1) + f as u32 * ((k - 1) * (k - 2) / 2) + local
        }
    }
}

/// Solid angle of the spherical triangle with unit vertices `a, b, c`
/// (Van Oosterom & Strackee 1983).
fn spherical_triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// The standard-orientation icosahedron with combinatorial tables.
struct Icosahedron {
    /// Unit corners.
    corners: [DVec3; 12],
    /// Index of the antipodal corner.
    anti_corner: [u8; 12],
    /// Faces, counter-clockwise from outside.
    faces: [[u8; 3]; 20],
    /// Index of the antipodal face.
    anti_face: [u8; 20],
    /// `edge_index[p][q]` (`p < q`) = edge number `0..30`, 255 if no edge.
    edge_index: [[u8; 12]; 12],
}

impl Icosahedron {
    fn new() -> Self {
        let phi = 0.5 * (1.0 + 5f64.sqrt());
        let mut raw = Vec::with_capacity(12);
        for s1 in [1.0, -1.0] {
            for s2 in [1.0, -1.0] {
                raw.push(DVec3::new(0.0, s1, s2 * phi));
                raw.push(DVec3::new(s1, s2 * phi, 0.0));
                raw.push(DVec3::new(s2 * phi, 0.0, s1));
            }
        }
        // Unnormalised edge length is 2; the next distance is 2φ.
        let adjacent = |p: usize, q: usize| (raw[p] - raw[q]).length_squared() < 5.0;
        let anti_corner: [u8; 12] = std::array::from_fn(|p| {
            (0..12)
                .find(|&q| raw[q] == -raw[p])
                .expect("antipodal corner") as u8
        });
        let mut edge_index = [[u8::MAX; 12]; 12];
        let mut n_edges = 0u8;
        let pairs = (0..12).flat_map(|p| (p + 1..12).map(move |q| (p, q)));
        for (p, q) in pairs.filter(|&(p, q)| adjacent(p, q)) {
            edge_index[p][q] = n_edges;
            edge_index[q][p] = n_edges;
            n_edges += 1;
        }
        assert_eq!(n_edges, 30);
        let mut faces = Vec::with_capacity(20);
        for p in 0..12 {
            for q in p + 1..12 {
                for r in q + 1..12 {
                    if adjacent(p, q) && adjacent(q, r) && adjacent(p, r) {
                        let outward = (raw[q] - raw[p]).cross(raw[r] - raw[p]).dot(raw[p]) > 0.0;
                        faces.push(if outward {
                            [p as u8, q as u8, r as u8]
                        } else {
                            [p as u8, r as u8, q as u8]
                        });
                    }
                }
            }
        }
        let faces: [[u8; 3]; 20] = faces.try_into().expect("20 icosahedron faces");
        let sorted = |mut c: [u8; 3]| {
            c.sort_unstable();
            c
        };
        let anti_face = std::array::from_fn(|f| {
            let target = sorted(faces[f].map(|c| anti_corner[c as usize]));
            (0..20)
                .find(|&g| sorted(faces[g]) == target)
                .expect("antipodal face") as u8
        });
        Self {
            corners: raw
                .iter()
                .map(|c| c.normalize())
                .collect::<Vec<_>>()
                .try_into()
                .expect("12 corners"),
            anti_corner,
            faces,
            anti_face,
            edge_index,
        }
    }
}

#[cfg(test)]
mod tests;
