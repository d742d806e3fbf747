//! Parallel-subfield (PSF) geometry (paper §2.1).
//!
//! The scene has already been translated and uniformly scaled into the unit
//! sphere ("VLF coordinates"). For each direction `ω_i` a plane orthogonal to
//! `ω_i` covering the unit sphere's projection is discretised into an `N × N`
//! grid of cells; each cell is the origin of a ray parallel to `ω_i`, and the
//! cells are grouped into `m × m` tiles.
//!
//! [`PsfFrame`] is the rotation between VLF and PSF coordinates
//! (`M_{VLF→PSF}`), [`PsfGrid`] the cell / tile discretisation of the PSF
//! plane. In PSF coordinates a point is `(a, b, depth)`: `(a, b)` identify the
//! ray (both in `[-1, 1]` for points in the unit sphere) and `depth` is the
//! position along it. (The paper's canonical frame puts the ray along `Y`; we
//! put it along the third coordinate, which reads better as depth.)

use glam::{DVec3, Mat3, Mat4, Vec3};
use serde::{Deserialize, Serialize};

use crate::directions::DirectionSet;

/// Orthonormal, right-handed frame of a PSF: `w` is the PSF direction `ω_i`,
/// `u` and `v` span the PSF plane (`u × v = w`).
///
/// `u, v` are chosen with the branch-light construction of Duff et al. 2017,
/// "Building an Orthonormal Basis, Revisited" (JCGT 6(1)): deterministic,
/// accurate for every `w`, and continuous on each open hemisphere `w.z > 0`
/// and `w.z < 0`. All canonical directions of a [`DirectionSet`] have
/// `w.z >= 0`, so the frames vary continuously across the canonical hemisphere
/// except on the equator `w.z == 0` itself (where `+0.0` counts as positive).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PsfFrame {
    /// First in-plane axis (PSF coordinate `a`).
    pub u: Vec3,
    /// Second in-plane axis (PSF coordinate `b`).
    pub v: Vec3,
    /// The PSF direction (PSF coordinate `depth`).
    pub w: Vec3,
}

impl PsfFrame {
    /// Frame for direction `w` (any length; normalised here, in f64). A
    /// zero-length or non-finite `w` gives the frame of `+Z` (identity).
    pub fn new(w: Vec3) -> Self {
        let n = w.as_dvec3();
        let len2 = n.length_squared();
        let n = if len2 > 0.0 && len2.is_finite() {
            n / len2.sqrt()
        } else {
            DVec3::Z
        };
        // Duff et al. 2017, listing 3. `sign + n.z` has magnitude >= 1, so
        // there is no cancellation anywhere on the sphere.
        let sign = 1f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let u = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let v = DVec3::new(b, sign + n.y * n.y * a, -n.y);
        Self {
            u: u.as_vec3(),
            v: v.as_vec3(),
            w: n.as_vec3(),
        }
    }

    /// The frame rotated about `w` by `angle` radians. Bakes twist each direction's grid by a
    /// golden-angle sequence ([`twist_angle`]) so that the ray grids of neighbouring directions
    /// do not alias with the geometry in the same way (correlated aliasing biases projected
    /// areas of small faces by several percent; decorrelated it averages out).
    pub fn twisted(self, angle: f32) -> Self {
        let (s, c) = angle.sin_cos();
        let u = self.u * c + self.v * s;
        let v = self.w.cross(u);
        Self { u, v, w: self.w }
    }

    /// VLF → PSF: `(a, b, depth) = (p·u, p·v, p·w)`. A pure rotation, so it
    /// maps directions the same way as points.
    pub fn to_psf(&self, p: Vec3) -> Vec3 {
        Vec3::new(p.dot(self.u), p.dot(self.v), p.dot(self.w))
    }

    /// PSF → VLF: `a·u + b·v + depth·w`.
    pub fn from_psf(&self, q: Vec3) -> Vec3 {
        self.u * q.x + self.v * q.y + self.w * q.z
    }

    /// `M_{VLF→PSF}` as a 4×4 matrix (glam, column-major; rows are `u, v, w`),
    /// ready to be composed with the world → VLF transform and uploaded.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_mat3(self.rotation().transpose())
    }

    /// `M_{PSF→VLF}` (columns `u, v, w`), the inverse (= transpose) of
    /// [`matrix`](Self::matrix).
    pub fn inverse_matrix(&self) -> Mat4 {
        Mat4::from_mat3(self.rotation())
    }

    /// The PSF → VLF rotation `[u v w]` as a 3×3 matrix.
    pub fn rotation(&self) -> Mat3 {
        Mat3::from_cols(self.u, self.v, self.w)
    }
}

/// Largest supported PSF resolution `n` (cells per side).
pub const MAX_PSF_RESOLUTION: u32 = 4096;

/// Errors from [`PsfGrid::new`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PsfGridError {
    /// `n` is outside `1..=MAX_PSF_RESOLUTION`.
    #[error("PSF resolution {0} is outside 1..={MAX_PSF_RESOLUTION}")]
    ResolutionOutOfRange(u32),
    /// The tile size is zero or does not divide `n`.
    #[error("tile size {tile} does not divide the PSF resolution {n}")]
    TileDoesNotDivide {
        /// Cells per side.
        n: u32,
        /// Cells per tile side.
        tile: u32,
    },
}

/// Discretisation of the PSF plane square `[-1, 1)²` into `n × n` cells
/// grouped into `tile × tile`-cell tiles (paper §2.1: `N`, `m`).
///
/// Cell `(i, j)` covers `a ∈ [-1 + i·s, -1 + (i+1)·s)`,
/// `b ∈ [-1 + j·s, -1 + (j+1)·s)` with `s = 2/n`: `i` follows the `u` axis,
/// `j` the `v` axis. The fields are public for convenience; build through
/// [`PsfGrid::new`] (deserialisation validates too), the methods assume a
/// valid grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "PsfGridRaw")]
pub struct PsfGrid {
    /// Cells per side `N`.
    pub n: u32,
    /// Cells per tile side `m` (divides `n`).
    pub tile: u32,
}

/// Unvalidated serde mirror of [`PsfGrid`].
#[derive(Deserialize)]
struct PsfGridRaw {
    n: u32,
    tile: u32,
}

impl TryFrom<PsfGridRaw> for PsfGrid {
    type Error = PsfGridError;
    fn try_from(raw: PsfGridRaw) -> Result<Self, Self::Error> {
        Self::new(raw.n, raw.tile)
    }
}

impl PsfGrid {
    /// A grid of `n × n` cells (`n in 1..=MAX_PSF_RESOLUTION`) in tiles of
    /// `tile × tile` cells (`tile >= 1` dividing `n`).
    pub fn new(n: u32, tile: u32) -> Result<Self, PsfGridError> {
        if !(1..=MAX_PSF_RESOLUTION).contains(&n) {
            return Err(PsfGridError::ResolutionOutOfRange(n));
        }
        if tile == 0 || !n.is_multiple_of(tile) {
            return Err(PsfGridError::TileDoesNotDivide { n, tile });
        }
        Ok(Self { n, tile })
    }

    /// Cell containing plane point `(a, b)`, or `None` unless both lie in
    /// `[-1, 1)` (NaN gives `None`). Exact for every f32 input (cell edges
    /// belong to the cell above them).
    pub fn cell_of(&self, a: f32, b: f32) -> Option<(u32, u32)> {
        Some((self.axis_cell(a)?, self.axis_cell(b)?))
    }

    fn axis_cell(&self, a: f32) -> Option<u32> {
        if !(-1.0..1.0).contains(&a) {
            return None;
        }
        // cell = floor((a + 1)·n/2), evaluated without rounding: `x` is an
        // f32 times an integer (exact in f64), and the integer / half-integer
        // offset is split off so that no addition can round across a cell
        // boundary (matters for tiny |a| next to the centre boundary).
        let half = 0.5 * f64::from(self.n);
        let frac = half.fract(); // 0 or 0.5
        let x = f64::from(a) * half;
        let c = (x + frac).floor() + (half - frac);
        Some((c as u32).min(self.n - 1))
    }

    /// Plane coordinates `(a, b)` of the centre of cell `(i, j)`: where that
    /// cell's ray pierces the PSF plane.
    pub fn cell_center(&self, i: u32, j: u32) -> (f32, f32) {
        let n = f64::from(self.n);
        let c = |i: u32| (-1.0 + (2.0 * f64::from(i) + 1.0) / n) as f32;
        (c(i), c(j))
    }

    /// Side length of a cell in plane units, `2/n`.
    pub fn cell_size(&self) -> f32 {
        2.0 / self.n as f32
    }

    /// Tile `(s, t)` containing cell `(i, j)`.
    pub fn tile_of_cell(&self, i: u32, j: u32) -> (u32, u32) {
        (i / self.tile, j / self.tile)
    }

    /// Position `(u, v)` of cell `(i, j)` within its tile (`0..tile`), so
    /// that `(i, j) = (s·tile + u, t·tile + v)`.
    pub fn cell_in_tile(&self, i: u32, j: u32) -> (u32, u32) {
        (i % self.tile, j % self.tile)
    }

    /// Tiles per side, `n / tile`.
    pub fn tiles_per_side(&self) -> u32 {
        self.n / self.tile
    }

    /// Continuous cell coordinates of plane point `(a, b)`: cell `i` spans
    /// `[i, i+1)`, so cell centres are at integer + 0.5 (texel convention,
    /// for bilinear filtering). Not clamped.
    pub fn continuous(&self, a: f32, b: f32) -> (f32, f32) {
        let h = 0.5 * f64::from(self.n);
        let c = |a: f32| ((f64::from(a) + 1.0) * h) as f32;
        (c(a), c(b))
    }
}

/// Twist of the grid of transport direction `i` (golden angle × i, wrapped).
pub fn twist_angle(i: usize) -> f32 {
    const GOLDEN: f64 = 2.399_963_229_728_653; // π (3 − √5)
    ((i as f64 * GOLDEN) % std::f64::consts::TAU) as f32
}

/// The PSF frame of fixed direction `i`: the canonical frame twisted by [`twist_angle`]`(i)`.
/// Everything that addresses a fixed direction's ray grid (propagation, mirror tiles, the
/// renderer's lookup) uses this frame. Panics if `i >= set.len()`.
pub fn fixed_frame(set: &DirectionSet, i: usize) -> PsfFrame {
    PsfFrame::new(set.direction(i)).twisted(twist_angle(i))
}

/// [`fixed_frame`] of every direction of the set, indexed by direction.
pub fn fixed_frames(set: &DirectionSet) -> Vec<PsfFrame> {
    (0..set.len()).map(|j| fixed_frame(set, j)).collect()
}

/// The cell of PSF point `(a, b)` in an `n`-grid, clamped (same f32 arithmetic as the shaders).
pub fn cell_at(a: f32, b: f32, n: u32) -> (u32, u32) {
    let nf = n as f32;
    let c = |x: f32| ((x + 1.0) * 0.5 * nf).floor().clamp(0.0, nf - 1.0) as u32;
    (c(a), c(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check_frame(f: &PsfFrame) {
        for (a, b) in [(f.u, f.v), (f.v, f.w), (f.w, f.u)] {
            assert!(a.dot(b).abs() < 1e-6, "{f:?}");
        }
        for a in [f.u, f.v, f.w] {
            assert!((a.length() - 1.0).abs() < 1e-6, "{f:?}");
        }
        assert!(f.u.cross(f.v).abs_diff_eq(f.w, 1e-6), "{f:?}");
    }

    fn next(rng: &mut u64) -> f32 {
        *rng ^= *rng << 13;
        *rng ^= *rng >> 7;
        *rng ^= *rng << 17;
        (*rng >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }

    fn random_in_ball(rng: &mut u64) -> Vec3 {
        loop {
            let p = Vec3::new(next(rng), next(rng), next(rng));
            if p.length_squared() <= 1.0 {
                return p;
            }
        }
    }

    #[test]
    fn frames_of_direction_set() {
        let set = DirectionSet::with_frequency(10).unwrap();
        let frames = fixed_frames(&set);
        assert_eq!(frames.len(), set.len());
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(*f, fixed_frame(&set, i));
            assert_eq!(f.w, set.direction(i));
            check_frame(f);
            let m = f.matrix();
            let mi = f.inverse_matrix();
            assert!((m * mi).abs_diff_eq(Mat4::IDENTITY, 1e-5));
            assert!((mi * m).abs_diff_eq(Mat4::IDENTITY, 1e-5));
            for _ in 0..64 {
                let p = random_in_ball(&mut rng);
                let q = f.to_psf(p);
                assert!(q.x.abs() <= 1.0 + 1e-6 && q.y.abs() <= 1.0 + 1e-6);
                assert!(q.abs_diff_eq(m.transform_point3(p), 1e-5));
                assert!(f.from_psf(q).abs_diff_eq(p, 1e-5));
                assert!(mi.transform_point3(q).abs_diff_eq(p, 1e-5));
                assert!((q.z - p.dot(f.w)).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn frame_special_cases() {
        assert_eq!(
            PsfFrame::new(Vec3::Z),
            PsfFrame {
                u: Vec3::X,
                v: Vec3::Y,
                w: Vec3::Z
            }
        );
        assert_eq!(PsfFrame::new(Vec3::ZERO), PsfFrame::new(Vec3::Z));
        assert_eq!(PsfFrame::new(Vec3::NAN), PsfFrame::new(Vec3::Z));
        assert_eq!(PsfFrame::new(Vec3::Z * 3.0).matrix(), Mat4::IDENTITY);
        for w in [
            Vec3::X,
            Vec3::Y,
            -Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            Vec3::new(1e-30, 0.0, -1.0),
            Vec3::new(0.0, 1.0, -0.0),
        ] {
            let f = PsfFrame::new(w);
            check_frame(&f);
            assert!(f.w.abs_diff_eq(w.normalize(), 1e-7));
        }
    }

    #[test]
    fn frame_continuity_on_upper_hemisphere() {
        // Neighbouring directions with z > 0 get neighbouring frames.
        let mut rng = 7u64;
        for _ in 0..10000 {
            let w = Vec3::new(next(&mut rng), next(&mut rng), next(&mut rng).abs() + 1e-3);
            let d = Vec3::new(next(&mut rng), next(&mut rng), next(&mut rng)) * 1e-4;
            if (w + d).z <= 0.0 {
                continue;
            }
            let (f, g) = (PsfFrame::new(w), PsfFrame::new(w + d));
            let tol = 100.0 * d.length() / w.length();
            assert!(
                f.u.abs_diff_eq(g.u, tol) && f.v.abs_diff_eq(g.v, tol),
                "{w} {d}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn frame_random(w in prop::array::uniform3(-1.0f32..1.0)) {
            let w = Vec3::from_array(w);
            prop_assume!(w.length() > 1e-3);
            let f = PsfFrame::new(w);
            check_frame(&f);
            let p = w.cross(Vec3::ONE) * 0.3 + w * 0.2;
            prop_assert!(f.from_psf(f.to_psf(p)).abs_diff_eq(p, 1e-5));
        }

        #[test]
        fn cell_round_trip(
            n_log in 0u32..13,
            ti in any::<u32>(),
            i in any::<u32>(),
            j in any::<u32>(),
        ) {
            let n = 1u32 << n_log;
            let tile = 1u32 << (ti % (n_log + 1));
            let g = PsfGrid::new(n, tile).unwrap();
            let (i, j) = (i % n, j % n);
            let (a, b) = g.cell_center(i, j);
            prop_assert_eq!(g.cell_of(a, b), Some((i, j)));
            let (x, y) = g.continuous(a, b);
            prop_assert!((x - (i as f32 + 0.5)).abs() < 1e-3);
            prop_assert!((y - (j as f32 + 0.5)).abs() < 1e-3);
            let (s, t) = g.tile_of_cell(i, j);
            let (u, v) = g.cell_in_tile(i, j);
            prop_assert!(s < g.tiles_per_side() && t < g.tiles_per_side());
            prop_assert_eq!((s * tile + u, t * tile + v), (i, j));
        }
    }

    #[test]
    fn cell_round_trip_non_power_of_two() {
        for (n, tile) in [
            (1, 1),
            (3, 1),
            (3, 3),
            (48, 6),
            (64, 8),
            (1000, 125),
            (4095, 7),
        ] {
            let g = PsfGrid::new(n, tile).unwrap();
            for i in (0..n).step_by((n as usize / 97).max(1)) {
                for j in [0, n / 2, n - 1, i] {
                    let (a, b) = g.cell_center(i, j);
                    assert_eq!(g.cell_of(a, b), Some((i, j)));
                }
            }
        }
    }

    #[test]
    fn cell_boundaries() {
        let g = PsfGrid::new(64, 8).unwrap();
        assert_eq!(g.cell_size(), 2.0 / 64.0);
        assert_eq!(g.tiles_per_side(), 8);
        assert_eq!(g.cell_of(-1.0, -1.0), Some((0, 0)));
        assert_eq!(g.cell_of(1.0, 0.0), None);
        assert_eq!(g.cell_of(0.0, 1.0), None);
        assert_eq!(g.cell_of(-1.0 - 1e-7, 0.0), None);
        let below_one = 1.0f32.next_down();
        assert_eq!(g.cell_of(below_one, below_one), Some((63, 63)));
        assert_eq!(g.cell_of(0.0, -0.0), Some((32, 32)));
        assert_eq!(g.cell_of(f32::NAN, 0.0), None);
        assert_eq!(g.cell_of(0.0, f32::INFINITY), None);
        // Tiny values either side of the central boundary.
        assert_eq!(g.cell_of(-1e-30, 1e-30), Some((31, 32)));
        assert_eq!(
            g.cell_of(-f32::MIN_POSITIVE, f32::MIN_POSITIVE),
            Some((31, 32))
        );
        let odd = PsfGrid::new(3, 1).unwrap();
        assert_eq!(odd.cell_of(-1e-30, 1e-30), Some((1, 1)));
        assert_eq!(
            odd.cell_of(-1.0 / 3.0 - 1e-7, 1.0 / 3.0 + 1e-7),
            Some((0, 2))
        );
        // Cell edges belong to the upper cell.
        assert_eq!(g.cell_of(-1.0 + 2.0 / 64.0, -0.5), Some((1, 16)));
        assert_eq!(g.continuous(-1.0, 1.0), (0.0, 64.0));
        assert_eq!(g.continuous(0.0, 0.0), (32.0, 32.0));
        assert_eq!(g.tile_of_cell(63, 0), (7, 0));
        assert_eq!(g.tile_of_cell(8, 15), (1, 1));
        assert_eq!(g.cell_in_tile(63, 9), (7, 1));
        let one = PsfGrid::new(1, 1).unwrap();
        assert_eq!(one.cell_of(0.99, -1.0), Some((0, 0)));
        assert_eq!(one.cell_center(0, 0), (0.0, 0.0));
    }

    #[test]
    fn grid_validation() {
        assert_eq!(
            PsfGrid::new(0, 1),
            Err(PsfGridError::ResolutionOutOfRange(0))
        );
        assert_eq!(
            PsfGrid::new(4097, 1),
            Err(PsfGridError::ResolutionOutOfRange(4097))
        );
        assert!(PsfGrid::new(4096, 4096).is_ok());
        assert_eq!(
            PsfGrid::new(64, 0),
            Err(PsfGridError::TileDoesNotDivide { n: 64, tile: 0 })
        );
        assert!(PsfGrid::new(64, 7).is_err());
        assert!(PsfGrid::new(64, 128).is_err());
        let cfg = bincode::config::standard();
        let ok = PsfGrid::new(64, 8).unwrap();
        let bytes = bincode::serde::encode_to_vec(ok, cfg).unwrap();
        let (back, _): (PsfGrid, usize) = bincode::serde::decode_from_slice(&bytes, cfg).unwrap();
        assert_eq!(back, ok);
        let bad = PsfGrid { n: 64, tile: 7 };
        let bytes = bincode::serde::encode_to_vec(bad, cfg).unwrap();
        let r: Result<(PsfGrid, usize), _> = bincode::serde::decode_from_slice(&bytes, cfg);
        assert!(r.is_err());
    }
}
