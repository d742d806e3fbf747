//! A binned-SAH bounding volume hierarchy, flattened into 32-byte nodes in depth-first order
//! (the layout the GPU ray engine uploads unchanged), and its stack traversal.
//!
//! Node `i` is a leaf when `count > 0` (triangles `index .. index + count` of the reordered
//! triangle array); otherwise its children are `i + 1` (left) and `index` (right).

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A, Vec4};

use std::sync::Arc;

use super::geometry::{Hit, Ray, RayPre, RtTriangle, intersect};
use crate::lightfield::AlphaMasks;

/// A flattened BVH node (32 bytes; mirrors WGSL `BvhNode`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub min: [f32; 3],
    /// Leaf: first triangle; interior: index of the right child (the left one is next).
    pub index: u32,
    pub max: [f32; 3],
    /// Number of triangles (0 for interior nodes).
    pub count: u32,
}

/// Number of SAH bins per axis.
const BINS: usize = 16;
/// Leaves never hold more triangles than this (unless all centroids coincide).
const MAX_LEAF: usize = 8;
/// SAH cost of a traversal step relative to one triangle test.
const TRAVERSAL_COST: f32 = 1.0;
/// Bound on the tree depth: nodes at depth `MAX_DEPTH − 1` are always leaves, so the traversal
/// stacks (CPU, and `BVH_STACK` in the WGSL) never hold more than `MAX_DEPTH − 1` entries. 32
/// keeps the GPU's per-invocation stack small (faster on lavapipe) and is far deeper than a
/// binned-SAH tree of the scenes here (≤ 25 for 64K triangles); deeper trees only get larger
/// leaves.
pub const MAX_DEPTH: usize = 32;

/// The hierarchy and the triangles in leaf order.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// Nodes, root first (read them with [`Bvh::nodes`]).
    nodes: Vec<BvhNode>,
    /// The same nodes as SIMD vectors for the CPU traversal (`w` lanes hold the index and
    /// count bits).
    simd: Vec<[Vec4; 2]>,
    /// Triangles in leaf order (`RtTriangle::prim` gives the original index). Only the
    /// `material` and `light` fields may be changed after building.
    pub triangles: Vec<RtTriangle>,
    /// Alpha masks of the triangles by their original index (`prim`): a hit where a mask
    /// leaves no surface is skipped ([`Bvh::with_masks`]; none by default).
    masks: Arc<AlphaMasks>,
}

#[derive(Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };
    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn union(&mut self, o: &Bounds) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }
    fn area(&self) -> f32 {
        let d = self.max - self.min;
        if d.x < 0.0 {
            return 0.0;
        }
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

struct Prim {
    bounds: Bounds,
    centroid: Vec3,
}

impl Bvh {
    /// Builds the hierarchy over `triangles` (in any order); the result holds them reordered.
    pub fn build(triangles: Vec<RtTriangle>) -> Bvh {
        let prims: Vec<Prim> = triangles
            .iter()
            .map(|t| {
                let mut bounds = Bounds::EMPTY;
                for p in t.corners() {
                    bounds.grow(p);
                }
                Prim {
                    bounds,
                    centroid: (bounds.min + bounds.max) * 0.5,
                }
            })
            .collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len().max(1));
        if triangles.is_empty() {
            nodes.push(BvhNode {
                min: [1.0; 3],
                index: 0,
                max: [-1.0; 3],
                count: 0,
            });
            // An interior node whose box is empty: traversal never enters it.
            return Bvh::from_parts(nodes, triangles);
        }
        build_node(&prims, &mut order, 0, &mut nodes, 0);
        let triangles = order.iter().map(|&i| triangles[i as usize]).collect();
        Bvh::from_parts(nodes, triangles)
    }

    fn from_parts(nodes: Vec<BvhNode>, triangles: Vec<RtTriangle>) -> Bvh {
        let simd = nodes
            .iter()
            .map(|n| {
                [
                    Vec3::from(n.min).extend(f32::from_bits(n.index)),
                    Vec3::from(n.max).extend(f32::from_bits(n.count)),
                ]
            })
            .collect();
        Bvh {
            nodes,
            simd,
            triangles,
            masks: Arc::default(),
        }
    }

    /// The hierarchy with alpha masks: rays pass through a triangle wherever `masks` (indexed
    /// by `RtTriangle::prim`) [`cuts`](AlphaMasks::cuts) it.
    pub fn with_masks(mut self, masks: Arc<AlphaMasks>) -> Bvh {
        self.masks = masks;
        self
    }

    /// The alpha masks the traversal applies (empty: none).
    pub fn masks(&self) -> &AlphaMasks {
        &self.masks
    }

    /// The flattened nodes, root first.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Closest hit of `ray` over `(ray.tmin, ray.tmax)`.
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.traverse(ray, false)
    }

    /// Whether anything blocks `ray` over `(ray.tmin, ray.tmax)`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.traverse(ray, true).is_hit()
    }

    fn traverse(&self, ray: &Ray, any: bool) -> Hit {
        let mut best = Hit::MISS;
        if self.triangles.is_empty() {
            return best;
        }
        let origin = Vec3::from(ray.origin);
        let dir = Vec3::from(ray.dir);
        let pre = RayPre::new(origin, dir);
        let o = Vec3A::from(origin);
        let inv = Vec3A::from(safe_inverse(dir));
        let mut tmax = ray.tmax;
        let mut stack = [0u32; MAX_DEPTH];
        let mut sp = 0usize;
        let mut node = 0u32;
        if slab(&self.simd[0], o, inv, ray.tmin, tmax).is_none() {
            return best;
        }
        loop {
            let n = &self.simd[node as usize];
            let (index, count) = (n[0].w.to_bits(), n[1].w.to_bits());
            if count > 0 {
                for i in index..index + count {
                    let tri = &self.triangles[i as usize];
                    if let Some((t, u, v)) = intersect(&pre, tri.corners(), ray.tmin, tmax) {
                        if self.masks.cuts_at(tri.prim, u, v) {
                            continue;
                        }
                        best = Hit { t, tri: i, u, v };
                        tmax = t;
                        if any {
                            return best;
                        }
                    }
                }
            } else {
                let (l, r) = (node + 1, index);
                let tl = slab(&self.simd[l as usize], o, inv, ray.tmin, tmax);
                let tr = slab(&self.simd[r as usize], o, inv, ray.tmin, tmax);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a <= b { (l, r) } else { (r, l) };
                        stack[sp] = far;
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        best
    }
}

/// `1 / d` with zero components replaced by a tiny signed value (no infinities or NaNs in the
/// slab test).
pub fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-30 {
            1.0 / 1e-30f32.copysign(x)
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// Entry distance of the ray into the node's box, if it overlaps `(tmin, tmax)`. The exit
/// distance is widened by `1 + 2γ₃` (Ize 2013, "Robust BVH ray traversal") so rounding never
/// culls a box the ray touches.
#[inline(always)]
fn slab(n: &[Vec4; 2], origin: Vec3A, inv: Vec3A, tmin: f32, tmax: f32) -> Option<f32> {
    let t0 = (Vec3A::from_vec4(n[0]) - origin) * inv;
    let t1 = (Vec3A::from_vec4(n[1]) - origin) * inv;
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element() * (1.0 + 2.0 * GAMMA3);
    (near <= far.min(tmax)).then_some(near)
}

/// γ₃ = 3ε / (1 − 3ε) for f32 (ε = 2⁻²⁴).
const GAMMA3: f32 = 3.0 * 5.960_464_5e-8 / (1.0 - 3.0 * 5.960_464_5e-8);

fn build_node(
    prims: &[Prim],
    order: &mut [u32],
    first: u32,
    nodes: &mut Vec<BvhNode>,
    depth: usize,
) {
    let mut bounds = Bounds::EMPTY;
    let mut cbounds = Bounds::EMPTY;
    for &i in order.iter() {
        bounds.union(&prims[i as usize].bounds);
        cbounds.grow(prims[i as usize].centroid);
    }
    let me = nodes.len();
    nodes.push(BvhNode {
        min: bounds.min.into(),
        index: first,
        max: bounds.max.into(),
        count: order.len() as u32,
    });
    let n = order.len();
    if n <= 2 || depth + 1 >= MAX_DEPTH {
        return;
    }
    let extent = cbounds.max - cbounds.min;
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, split bin)
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let bin_of = |c: Vec3| (((c[axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1);
        let mut bin_bounds = [Bounds::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &i in order.iter() {
            let p = &prims[i as usize];
            let b = bin_of(p.centroid);
            bin_bounds[b].union(&p.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Bounds::EMPTY;
        let mut cnt = 0;
        for b in (1..BINS).rev() {
            acc.union(&bin_bounds[b]);
            cnt += bin_count[b];
            right_area[b] = acc.area();
            right_count[b] = cnt;
        }
        let mut acc = Bounds::EMPTY;
        let mut cnt = 0;
        for b in 0..BINS - 1 {
            acc.union(&bin_bounds[b]);
            cnt += bin_count[b];
            if cnt == 0 || right_count[b + 1] == 0 {
                continue;
            }
            let cost = acc.area() * cnt as f32 + right_area[b + 1] * right_count[b + 1] as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let parent_area = bounds.area().max(f32::MIN_POSITIVE);
    let leaf_cost = n as f32;
    let mid = match best {
        Some((cost, axis, split)) => {
            let split_cost = TRAVERSAL_COST + cost / parent_area;
            if split_cost >= leaf_cost && n <= MAX_LEAF {
                return;
            }
            let scale = BINS as f32 / extent[axis];
            let left = partition(order, |i| {
                let c = prims[i as usize].centroid;
                (((c[axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1) <= split
            });
            if left == 0 || left == n { n / 2 } else { left }
        }
        // All centroids coincide: split in the middle of the list if the leaf is too big.
        None if n > MAX_LEAF => n / 2,
        None => return,
    };
    let (lo, hi) = order.split_at_mut(mid);
    build_node(prims, lo, first, nodes, depth + 1);
    let right = nodes.len() as u32;
    build_node(prims, hi, first + mid as u32, nodes, depth + 1);
    nodes[me].count = 0;
    nodes[me].index = right;
}

/// In-place partition; returns the number of elements satisfying `pred` (now at the front).
fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut left = 0;
    for i in 0..v.len() {
        if pred(v[i]) {
            v.swap(i, left);
            left += 1;
        }
    }
    left
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pathtrace::geometry::NONE;
    use crate::pathtrace::sampling::Rng;

    fn random_soup(n: usize, seed: u32) -> Vec<RtTriangle> {
        let mut rng = Rng::for_path(seed, 0, 0);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0 - 5.0;
        (0..n)
            .map(|i| {
                let c = v();
                let (a, b, d) = (v() * 0.1, v() * 0.1, v() * 0.1);
                RtTriangle {
                    p0: (c + a).into(),
                    p1: (c + b).into(),
                    p2: (c + d).into(),
                    prim: i as u32,
                    material: 0,
                    light: NONE,
                }
            })
            .collect()
    }

    fn brute(tris: &[RtTriangle], ray: &Ray) -> Option<(f32, u32)> {
        let pre = RayPre::new(ray.origin.into(), ray.dir.into());
        let mut best: Option<(f32, u32)> = None;
        for t in tris {
            if let Some((d, _, _)) = intersect(&pre, t.corners(), ray.tmin, ray.tmax)
                && best.is_none_or(|(b, _)| d < b)
            {
                best = Some((d, t.prim));
            }
        }
        best
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let tris = random_soup(3000, 11);
        let bvh = Bvh::build(tris.clone());
        assert_eq!(bvh.triangles.len(), tris.len());
        let mut seen = vec![false; tris.len()];
        for t in &bvh.triangles {
            seen[t.prim as usize] = true;
        }
        assert!(
            seen.iter().all(|s| *s),
            "every triangle is in exactly one leaf"
        );
        let mut rng = Rng::for_path(3, 0, 0);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 12.0 - 6.0;
            let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            let ray = Ray::new(o, d, f32::INFINITY);
            let want = brute(&tris, &ray);
            let got = bvh.closest_hit(&ray);
            match want {
                Some((t, prim)) => {
                    hits += 1;
                    assert!(got.is_hit());
                    assert_eq!(bvh.triangles[got.tri as usize].prim, prim);
                    assert_eq!(got.t, t);
                    assert!(bvh.occluded(&ray));
                }
                None => {
                    assert!(!got.is_hit());
                    assert!(!bvh.occluded(&ray));
                }
            }
        }
        assert!(hits > 100);
    }

    #[test]
    fn nodes_are_32_bytes_and_bounded() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 32);
        let bvh = Bvh::build(random_soup(500, 2));
        for n in &bvh.nodes {
            if n.count > 0 {
                assert!(n.count as usize <= MAX_LEAF);
            }
        }
        fn depth(nodes: &[BvhNode], i: usize) -> usize {
            let n = &nodes[i];
            if n.count > 0 {
                0
            } else {
                1 + depth(nodes, i + 1).max(depth(nodes, n.index as usize))
            }
        }
        assert!(depth(&bvh.nodes, 0) < MAX_DEPTH);
        // Identical triangles: still a valid, shallow tree.
        let same = vec![random_soup(1, 5)[0]; 100];
        let bvh = Bvh::build(same);
        assert!(bvh.nodes.len() < 100);
    }
}
