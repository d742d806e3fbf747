//! Rays, the packed triangle the BVH stores, the watertight ray–triangle test and
//! self-intersection-free ray origins.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// "No triangle" / "no light" marker in the packed arrays.
pub const NONE: u32 = u32::MAX;

/// A triangle in BVH leaf order (48 bytes; mirrors WGSL `RtTriangle`). Corners are world space
/// and counter-clockwise seen from the front.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtTriangle {
    pub p0: [f32; 3],
    /// Index into the scene's materials.
    pub material: u32,
    pub p1: [f32; 3],
    /// Index of the triangle in `Scene::triangles`.
    pub prim: u32,
    pub p2: [f32; 3],
    /// Index into the emitter list, or [`NONE`] when the triangle is not a sampled emitter.
    pub light: u32,
}

impl RtTriangle {
    /// Baked triangle `t`, the `prim`-th (VLF coordinates), with its face in `material`: what
    /// the BVHs over a light field's or a prepared scene's triangles hold.
    pub fn of_baked(prim: usize, t: &crate::lightfield::BakeTriangle) -> RtTriangle {
        RtTriangle {
            p0: t.p0,
            material: t.face,
            p1: t.p1,
            prim: prim as u32,
            p2: t.p2,
            light: NONE,
        }
    }

    /// Corners as vectors.
    pub fn corners(&self) -> [Vec3; 3] {
        [self.p0.into(), self.p1.into(), self.p2.into()]
    }
}

/// A ray `origin + t·dir`, `t ∈ (tmin, tmax)` (32 bytes; mirrors WGSL `Ray`). `dir` need not be
/// unit length (shadow rays to a point use the segment itself with `tmax = 1`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Ray {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}

impl Ray {
    /// A ray over `(0, tmax)`.
    pub fn new(origin: Vec3, dir: Vec3, tmax: f32) -> Self {
        Self {
            origin: origin.into(),
            tmin: 0.0,
            dir: dir.into(),
            tmax,
        }
    }
}

/// A ray hit (16 bytes; mirrors WGSL `Hit`): `tri` is the index in BVH leaf order, or [`NONE`]
/// for a miss; `u`, `v` are the barycentric weights of corners 1 and 2.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Hit {
    pub t: f32,
    pub tri: u32,
    pub u: f32,
    pub v: f32,
}

impl Hit {
    /// The miss value.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        tri: NONE,
        u: 0.0,
        v: 0.0,
    };

    /// Whether something was hit.
    pub fn is_hit(&self) -> bool {
        self.tri != NONE
    }
}

/// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013, "Watertight
/// ray/triangle intersection", JCGT 2(1)). The paper swaps `kx` and `ky` when `dir[kz] < 0` to
/// keep the sign of the edge functions tied to the winding; both faces count here, so the swap
/// is omitted (it changes the signs of U, V, W and det together, not t or the barycentrics).
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    pub origin: Vec3,
    /// Axis of the largest direction component; `kx = (kz + 1) % 3`, `ky = (kz + 2) % 3`.
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
}

impl RayPre {
    /// Precomputes the shear of `origin + t·dir`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        Self {
            origin,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
        }
    }
}

/// Watertight ray–triangle test: `Some((t, b1, b2))` for a hit with `tmin < t < tmax`. Both
/// faces are hit. Edges shared by two triangles are never missed by both; the rare case of an
/// edge test exactly zero in `f32` is redone in `f64`.
#[inline]
pub fn intersect(pre: &RayPre, p: [Vec3; 3], tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
    // Permute the axes so that z is the ray's dominant axis (static swizzles per case).
    let perm = |v: Vec3| match pre.kz {
        0 => Vec3::new(v.y, v.z, v.x),
        1 => Vec3::new(v.z, v.x, v.y),
        _ => v,
    };
    let a = perm(p[0] - pre.origin);
    let b = perm(p[1] - pre.origin);
    let c = perm(p[2] - pre.origin);
    let ax = a.x - pre.sx * a.z;
    let ay = a.y - pre.sy * a.z;
    let bx = b.x - pre.sx * b.z;
    let by = b.y - pre.sy * b.z;
    let cx = c.x - pre.sx * c.z;
    let cy = c.y - pre.sy * c.z;
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            f64::from(ax),
            f64::from(ay),
            f64::from(bx),
            f64::from(by),
            f64::from(cx),
            f64::from(cy),
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = pre.sz * (u * a.z + v * b.z + w * c.z);
    let rcp = 1.0 / det;
    let t = t_scaled * rcp;
    if !(t > tmin && t < tmax) {
        return None;
    }
    Some((t, v * rcp, w * rcp))
}

/// Moves a surface point off its surface along `n` (the side the new ray leaves towards) by
/// a few ulps of its coordinates (Wächter & Binder 2019, "A fast and robust method for avoiding
/// self-intersection", Ray Tracing Gems ch. 6), so a ray from it never re-hits the surface.
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65_536.0;
    const INT_SCALE: f32 = 256.0;
    let mut out = [0.0f32; 3];
    for i in 0..3 {
        let of_i = (INT_SCALE * n[i]) as i32;
        let bits = p[i].to_bits() as i32;
        let moved = f32::from_bits(bits.wrapping_add(if p[i] < 0.0 { -of_i } else { of_i }) as u32);
        out[i] = if p[i].abs() < ORIGIN {
            p[i] + FLOAT_SCALE * n[i]
        } else {
            moved
        };
    }
    Vec3::from(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_inside_misses_outside_both_faces() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let pre = RayPre::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
        let (t, b1, b2) = intersect(&pre, tri, 0.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (b1 - 0.2).abs() < 1e-6 && (b2 - 0.3).abs() < 1e-6);
        let back = RayPre::new(Vec3::new(0.2, 0.3, -1.0), Vec3::Z);
        assert!(intersect(&back, tri, 0.0, f32::INFINITY).is_some());
        let out = RayPre::new(Vec3::new(0.7, 0.7, 1.0), -Vec3::Z);
        assert!(intersect(&out, tri, 0.0, f32::INFINITY).is_none());
        assert!(intersect(&pre, tri, 0.0, 0.5).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a quad; rays aimed exactly at the diagonal
        // must hit at least one of them.
        let q = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.2),
        ];
        let t1 = [q[0], q[1], q[2]];
        let t2 = [q[0], q[2], q[3]];
        for i in 0..=1000 {
            let s = i as f32 / 1000.0;
            let target = q[0].lerp(q[2], s);
            let origin = Vec3::new(0.3, 0.6, 2.0);
            let pre = RayPre::new(origin, target - origin);
            let h1 = intersect(&pre, t1, 0.0, 2.0).is_some();
            let h2 = intersect(&pre, t2, 0.0, 2.0).is_some();
            assert!(h1 || h2, "ray {i} slipped through the shared edge");
        }
    }

    #[test]
    fn offset_origin_leaves_the_surface() {
        for p in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(100.0, -3.0, 0.5),
            Vec3::splat(-1e4),
        ] {
            let n = Vec3::new(0.0, 0.0, 1.0);
            let q = offset_ray_origin(p, n);
            assert!(q.z > p.z && (q.x - p.x).abs() < 1e-6 * p.x.abs().max(1.0));
            let q = offset_ray_origin(p, -n);
            assert!(q.z < p.z);
        }
    }
}
