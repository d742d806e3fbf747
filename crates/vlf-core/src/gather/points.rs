//! Where a texel's gather samples start: stratified points over the texel's covered area, on
//! its own face, where the texel is *open*.
//!
//! A texel that straddles a nearby occluder (a lamp hung 1 mm under the ceiling, a box standing
//! on the floor) covers two regions: one that sees the room and one enclosed between the
//! surfaces. Averaging both makes the texel glow (or darken) around the occluder's outline, and
//! the renderer's bilinear filter spreads that over a texel beyond it. Lightmappers test their
//! sample points with short rays and drop the enclosed ones; so does [`Openness`]: a point is
//! closed when a probe along its normal hits anything within `r_close` (a gap thinner than
//! about half a texel, which the atlas cannot resolve anyway), or when it lies inside a closed
//! solid (of three probes, along the normal and two tilted directions, most reach back faces).
//!
//! Each point carries the shading normal its rays are drawn about ([`GatherPoint::n`]): the
//! interpolated vertex normal where its triangle is smooth, the face's normal elsewhere. The
//! openness probes and the rays' origins stay with the face's (geometric) normal: they are
//! about where the surface is, not how it shades.

use glam::{Vec2, Vec3};

use crate::bake::prep::BakeScene;
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::sampling::{self, Rng};
use crate::pathtrace::{Bvh, Ray};
use crate::scene::Similarity;

use super::field::Charts;

/// The open/closed test of surface points (world space).
pub struct Openness<'a> {
    pub bvh: &'a Bvh,
    /// Probes along the normal that hit anything closer than this close the point (world).
    pub r_close: f32,
    /// Per material (BVH triangles' `material`): whether it is a thin glass pane, which is
    /// never the wall of a closed solid (a probe that meets one is open).
    pub panes: Vec<bool>,
    /// By material index (empty: none): surfaces that light crosses (thin diffuse
    /// transmission, `docs/SUBSURFACE.md`), whose back faces do not close a solid: the inside of
    /// a paper lantern is lit through its walls.
    pub see_through: Vec<bool>,
}

impl Openness<'_> {
    /// Whether point `p` of a surface whose lit side has unit normal `n` is open.
    pub fn is_open(&self, p: Vec3, n: Vec3) -> bool {
        let origin = offset_ray_origin(p, n);
        if self.closes(origin, n) {
            return false;
        }
        // Inside a closed solid every direction reaches a back face; outside, most find a
        // front face or nothing. A majority of three decides: one back face (a single surface
        // with flipped winding) does not close a point, and one front face does not open it
        // (inside a wall built of touching boxes, a ray crossing the shared face meets the
        // neighbouring box's front face first).
        let (t, b) = sampling::basis(n);
        let tilt = |a: Vec3| (n * 0.5 + a * 0.866_025_4).normalize();
        let (mut open, mut closed) = (0, 0);
        for d in [n, tilt(t), tilt(-t * 0.5 + b * 0.866_025_4)] {
            let hit = self.bvh.closest_hit(&Ray::new(origin, d, f32::INFINITY));
            let front = !hit.is_hit() || {
                let tri = &self.bvh.triangles[hit.tri as usize];
                let [a, b, c] = tri.corners();
                // A pane or a see-through wall passes light: it counts as open.
                self.panes.get(tri.material as usize) == Some(&true)
                    || self.see_through.get(tri.material as usize) == Some(&true)
                    || (b - a).cross(c - a).dot(d) <= 0.0
            };
            if front {
                open += 1;
                if open == 2 {
                    return true;
                }
            } else {
                closed += 1;
                if closed == 2 {
                    return false;
                }
            }
        }
        unreachable!("three directions reach a majority")
    }
}

impl Openness<'_> {
    /// Whether anything but a pane lies within `r_close` of `origin` along `n` (a pane passes
    /// light, so a gap under one is lit).
    fn closes(&self, origin: Vec3, n: Vec3) -> bool {
        if !self.panes.contains(&true) {
            return self.bvh.occluded(&Ray::new(origin, n, self.r_close));
        }
        let (mut from, mut left) = (origin, self.r_close);
        for _ in 0..super::through::MAX_PANES {
            let hit = self.bvh.closest_hit(&Ray::new(from, n, left));
            if !hit.is_hit() {
                return false;
            }
            let tri = &self.bvh.triangles[hit.tri as usize];
            if self.panes.get(tri.material as usize) != Some(&true) {
                return true;
            }
            let [a, b, c] = tri.corners();
            let q = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
            let ng = (b - a).cross(c - a);
            from = offset_ray_origin(
                q,
                if ng.dot(n) > 0.0 {
                    ng.normalize()
                } else {
                    -ng.normalize()
                },
            );
            left -= hit.t;
        }
        true
    }
}

/// A sample point of a texel (world space) and the unit shading normal of the texel's lit side
/// there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherPoint {
    pub p: Vec3,
    pub n: Vec3,
}

/// Stratified open points of the texels of one atlas.
pub struct TexelPoints<'a> {
    pub atlas: &'a BakeScene,
    pub charts: &'a Charts,
    pub open: Openness<'a>,
    pub xf: Similarity,
    /// Face of every texel.
    pub tex_face: &'a [u32],
}

/// Draws per point: first inside the point's stratum, then anywhere in the texel.
pub const DRAWS_IN_STRATUM: u32 = 4;
pub const DRAWS_IN_TEXEL: u32 = 4;

impl TexelPoints<'_> {
    /// Face, side and chart texel of atlas texel `t`.
    fn locate(&self, t: usize) -> (usize, u32, Vec2) {
        let fi = self.tex_face[t] as usize;
        let f = &self.atlas.faces[fi];
        let local = t as u32 - f.texel_base;
        let side = local / f.texels_per_side();
        let i = local % f.texels_per_side();
        (
            fi,
            side,
            Vec2::new((i % f.width) as f32, (i / f.width) as f32),
        )
    }

    /// Unit normal of the lit side of texel `t`.
    pub fn normal(&self, t: usize) -> Vec3 {
        let (fi, side, _) = self.locate(t);
        let n = self.atlas.faces[fi].normal();
        if side == 0 { n } else { -n }
    }

    fn world(&self, fi: usize, c: Vec2) -> Vec3 {
        let f = &self.atlas.faces[fi];
        let p = Vec3::from(f.origin)
            + Vec3::from(f.u) * (c.x * f.texel_size)
            + Vec3::from(f.v) * (c.y * f.texel_size);
        self.xf.inverse(p)
    }

    /// Probes the centre and four inset corners of a texel that lie on the face: `Some(true)`
    /// when all are open (its points need no test of their own), `Some(false)` when all are
    /// closed (the texel is enclosed: no points), `None` when they disagree (test each point).
    fn classify(&self, fi: usize, corner: Vec2, n: Vec3) -> Option<bool> {
        let (mut open, mut closed) = (0, 0);
        for (x, y) in [(0.5, 0.5), (0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)] {
            let c = corner + Vec2::new(x, y);
            if self.charts.inside(fi, c) {
                if self.open.is_open(self.world(fi, c), n) {
                    open += 1;
                } else {
                    closed += 1;
                }
            }
        }
        match (open, closed) {
            (_, 0) => Some(true),
            (0, _) => Some(false),
            _ => None,
        }
    }

    /// Where texel `t` is read from as a whole (world): the centroid of its covered part when
    /// that is all open, the mean of the open ones among the centres of a 4 × 4 grid over the
    /// texel square (on the face) when part of it is closed, `None` when it is enclosed (or no
    /// grid point is open). Deterministic: no random draws. A texel straddling a wall's foot
    /// so reads the light of its open side, not of a centroid under the wall.
    pub fn open_centroid(&self, t: usize) -> Option<Vec3> {
        let (fi, _, corner) = self.locate(t);
        let n = self.normal(t);
        let centroid = self
            .xf
            .inverse(glam::Vec4::from(self.atlas.texel_center[t]).truncate());
        if self.atlas.texel_area[t] <= 0.0 {
            return None;
        }
        match self.classify(fi, corner, n) {
            Some(true) => return Some(centroid),
            Some(false) => return None,
            None => {}
        }
        const G: u32 = 4;
        let (mut sum, mut count) = (Vec3::ZERO, 0u32);
        for k in 0..G * G {
            let c = corner + (Vec2::new((k % G) as f32, (k / G) as f32) + 0.5) / G as f32;
            if !self.charts.inside(fi, c) {
                continue;
            }
            let p = self.world(fi, c);
            if self.open.is_open(p, n) {
                sum += p;
                count += 1;
            }
        }
        (count > 0).then(|| sum / count as f32)
    }

    /// Up to `count` stratified world points on texel `t` (its face, its lit side) where the
    /// texel is open, appended to `out` with their shading normals: stratum `k` of a g × g
    /// grid over the texel square (g = ⌈√count⌉) holds point `k`, redrawn within the stratum
    /// when off the face or closed, then anywhere in the texel; points that find no open spot
    /// are dropped. Returns the lit side's unit (geometric) normal.
    pub fn sample(&self, t: usize, count: u32, rng: &mut Rng, out: &mut Vec<GatherPoint>) -> Vec3 {
        let (fi, side, corner) = self.locate(t);
        let n = {
            let n = self.atlas.faces[fi].normal();
            if side == 0 { n } else { -n }
        };
        if self.atlas.texel_area[t] <= 0.0 || count == 0 {
            return n;
        }
        let test_each = match self.classify(fi, corner, n) {
            Some(true) => false,
            Some(false) => return n,
            None => true,
        };
        let g = (count as f32).sqrt().ceil() as u32;
        let inv = 1.0 / g as f32;
        let first = out.len();
        for k in 0..count {
            let s = Vec2::new((k % g) as f32, (k / g % g) as f32);
            for draw in 0..DRAWS_IN_STRATUM + DRAWS_IN_TEXEL {
                let j = rng.next_2d();
                let c = if draw < DRAWS_IN_STRATUM {
                    corner + (s + j) * inv
                } else {
                    corner + j
                };
                let Some(tri) = self.charts.locate(fi, c) else {
                    continue;
                };
                let p = self.world(fi, c);
                if test_each && !self.open.is_open(p, n) {
                    continue;
                }
                out.push(GatherPoint {
                    p,
                    n: self.charts.shading_normal(fi, tri, c, n),
                });
                break;
            }
        }
        if out.len() == first {
            // A sliver of the face that no draw found: its covered part's centroid.
            let q = glam::Vec4::from(self.atlas.texel_center[t]).truncate();
            let p = self.xf.inverse(q);
            if !test_each || self.open.is_open(p, n) {
                let c = super::field::chart_coords(&self.atlas.faces[fi], q);
                let ns = match self.charts.locate(fi, c) {
                    Some(tri) => self.charts.shading_normal(fi, tri, c, n),
                    None => n,
                };
                out.push(GatherPoint { p, n: ns });
            }
        }
        n
    }
}
