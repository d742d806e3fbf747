//! The dipole's link factors between atlas texels (`docs/SUBSURFACE.md`): what a receiver texel
//! gets per unit flux entering a source texel, k_ij = (1/(A_i A_j)) ∫_{A_i}∫_{A_j} R_d(‖x − y‖),
//! per colour channel.
//!
//! * Texels of one face at grid offset (a, b) ([`OffsetTable`]): exact for full squares, by the
//!   overlap of the two squares, T(s) = (h − |s_x|)₊(h − |s_y|)₊, integrated against R_d in
//!   polar coordinates about the origin (so the profile's sharp peak at r = 0, of width
//!   z_r = 1/σ_t′, costs nothing however large the texel): k = (1/h⁴) ∫ r R_d(r) Θ(r) dr with
//!   Θ(r) = ∫ T(r e_θ − Δ) dθ, radially by Gauss–Legendre on intervals split at every radius
//!   where Θ has a kink and refined geometrically towards r = 0 on the scale of z_r.
//! * Near texels of different faces: 4 × 4 Gauss points on each square within 3 texel sizes,
//!   2 × 2 farther ([`pair_gauss`]).
//! * Far texels and clusters: R_d at the distance (the receiver's point to the source's
//!   centroid).

use glam::Vec3;

use crate::scene::dipole::Dipole;

/// The dipole of each colour channel.
pub type Dipole3 = [Dipole; 3];

/// R_d(r) of the three channels.
pub fn profile3(d: &Dipole3, r: f64) -> [f64; 3] {
    [d[0].profile(r), d[1].profile(r), d[2].profile(r)]
}

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_2, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_2, 0.101_228_536_290_376_26),
];

/// Gauss–Legendre nodes and weights on [−1, 1], 2 points.
const GL2: [(f64, f64); 2] = [
    (-0.577_350_269_189_625_8, 1.0),
    (0.577_350_269_189_625_8, 1.0),
];

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points.
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_85),
    (-0.339_981_043_584_856_26, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_26, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_85),
];

/// Angular samples of Θ(r) (midpoint rule over the full circle; Θ is continuous in θ with
/// kinks, error O(1/n²)).
const THETA_SAMPLES: usize = 720;

/// Overlap area of two axis-aligned squares of side `h` whose centres differ by (x, y).
fn overlap(h: f64, x: f64, y: f64) -> f64 {
    (h - x.abs()).max(0.0) * (h - y.abs()).max(0.0)
}

/// Θ(r) = ∫₀^{2π} T(r e_θ − Δ) dθ.
fn theta_integral(h: f64, dx: f64, dy: f64, r: f64, trig: &[(f64, f64)]) -> f64 {
    let w = std::f64::consts::TAU / trig.len() as f64;
    trig.iter()
        .map(|&(c, s)| overlap(h, r * c - dx, r * s - dy))
        .sum::<f64>()
        * w
}

/// k for two full texels of side `h` of one face whose centres differ by `delta` (in the
/// face's plane): (1/h⁴) ∫∫ R_d over the two squares.
pub fn coplanar(d: &Dipole3, h: f64, delta: (f64, f64)) -> [f64; 3] {
    let (dx, dy) = (delta.0.abs(), delta.1.abs());
    let trig: Vec<(f64, f64)> = (0..THETA_SAMPLES)
        .map(|k| {
            let t = (k as f64 + 0.5) * std::f64::consts::TAU / THETA_SAMPLES as f64;
            (t.cos(), t.sin())
        })
        .collect();
    // Θ has kinks where the circle passes the corners of T's pieces (the 3 × 3 grid of lines
    // x ∈ {dx − h, dx, dx + h}, y ∈ {dy − h, dy, dy + h}) or touches one of its lines.
    let xs = [dx - h, dx, dx + h];
    let ys = [dy - h, dy, dy + h];
    let r_max = (dx + h).hypot(dy + h);
    let mut cuts = vec![0.0, r_max];
    for x in xs {
        cuts.push(x.abs());
        for y in ys {
            cuts.push(x.hypot(y));
        }
    }
    for y in ys {
        cuts.push(y.abs());
    }
    // Geometric refinement towards 0 on the profile's scale (its peak has width z_r).
    let z = d.iter().map(|c| c.z_r).fold(f64::INFINITY, f64::min).min(h);
    let mut s = z / 64.0;
    while s < r_max {
        cuts.push(s);
        s *= 2.0;
    }
    cuts.retain(|c| (0.0..=r_max).contains(c));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * r_max);
    let mut k = [0f64; 3];
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let (m, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, wt) in GL8 {
            let r = m + half * x;
            let t = theta_integral(h, dx, dy, r, &trig);
            if t <= 0.0 {
                continue;
            }
            let p = profile3(d, r);
            for c in 0..3 {
                k[c] += wt * half * r * p[c] * t;
            }
        }
    }
    let h4 = h.powi(4);
    k.map(|v| v / h4)
}

/// The coplanar factors of one face grid by offset (a, b), 0 ≤ b ≤ a ≤ `reach` (the rest by
/// symmetry), for texels of side `h`.
#[derive(Clone, Debug)]
pub struct OffsetTable {
    pub reach: u32,
    values: Vec<[f32; 3]>,
}

impl OffsetTable {
    pub fn new(d: &Dipole3, h: f64, reach: u32) -> OffsetTable {
        let n = reach as usize + 1;
        let pairs: Vec<(u32, u32)> = (0..=reach)
            .flat_map(|a| (0..=a).map(move |b| (a, b)))
            .collect();
        let computed = crate::par::map(pairs.len(), 0, 8, |i| {
            let (a, b) = pairs[i];
            coplanar(d, h, (f64::from(a) * h, f64::from(b) * h)).map(|v| v as f32)
        });
        let mut values = vec![[0f32; 3]; n * n];
        for (&(a, b), v) in pairs.iter().zip(computed) {
            values[a as usize * n + b as usize] = v;
            values[b as usize * n + a as usize] = v;
        }
        OffsetTable { reach, values }
    }

    /// k at grid offset (a, b), if within reach.
    pub fn get(&self, a: i64, b: i64) -> Option<[f32; 3]> {
        let (a, b) = (a.unsigned_abs(), b.unsigned_abs());
        let n = u64::from(self.reach) + 1;
        (a < n && b < n).then(|| self.values[(a * n + b) as usize])
    }
}

/// A square texel in space: centre and the half-edge vectors along its face's chart axes.
#[derive(Clone, Copy, Debug)]
pub struct Square {
    pub center: Vec3,
    pub u: Vec3,
    pub v: Vec3,
}

/// k between two squares by Gauss points on each (near texels of different faces): 4 × 4
/// when `fine`, else 2 × 2.
pub fn pair_gauss(d: &Dipole3, a: &Square, b: &Square, fine: bool) -> [f64; 3] {
    let rule: &[(f64, f64)] = if fine { &GL4 } else { &GL2 };
    let pts = |s: &Square| {
        let mut out = Vec::with_capacity(rule.len() * rule.len());
        for &(x, wx) in rule {
            for &(y, wy) in rule {
                out.push((s.center + s.u * x as f32 + s.v * y as f32, 0.25 * wx * wy));
            }
        }
        out
    };
    let (pa, pb) = (pts(a), pts(b));
    let mut k = [0f64; 3];
    for (x, wa) in &pa {
        for (y, wb) in &pb {
            let p = profile3(d, f64::from(x.distance(*y)));
            for c in 0..3 {
                k[c] += wa * wb * p[c];
            }
        }
    }
    k
}
