//! The hierarchical links of one translucent object (`docs/SUBSURFACE.md`): a binary tree over
//! its texels, and per receiver texel the list of (node, factor) whose sum of factor × the
//! flux entering the node is the scattered exitance of the receiver.
//!
//! Near the receiver (within [`LinkParams::near_texels`] texel sizes, or farther where the
//! profile is still above [`NEAR_PROFILE_SHARE`] of its peak) every texel is a link of its own
//! with an accurately integrated factor ([`super::kernel`]); beyond, a whole node is one link,
//! R_d at the distance to its centroid, when the error of replacing the node by its centroid
//! (estimated from the profile's second difference over the node's radius, for a flux smooth
//! over the node) is within [`LinkParams::tolerance`] of the value or, times the node's area,
//! within [`LinkParams::absolute`] of the total reflectance, and the node is smaller than half
//! its distance; nodes whose whole contribution is below [`LinkParams::drop`] of the total diffuse
//! reflectance are left out (their sum is reported).

use glam::Vec3;
use serde::Serialize;

use super::kernel::{self, Dipole3, OffsetTable, Square};
use crate::bake::BakeScene;

/// The near field reaches at least as far as the profile stays above this share of its peak:
/// the profile's main lobe is resolved texel by texel.
pub const NEAR_PROFILE_SHARE: f64 = 0.01;

/// Accuracy and memory of the links.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LinkParams {
    /// Texels within this many texel sizes are linked one by one.
    pub near_texels: u32,
    /// Largest estimated relative error of a cluster linked as a whole: the mean of R_d over a
    /// disc of the node's radius ρ differs from its value at the centre by about
    /// ρ²R_d″/8, estimated as (R_d(d − ρ) + R_d(d + ρ) − 2R_d(d))/8.
    pub tolerance: f64,
    /// A cluster is also linked as a whole when that error times its area is at most this
    /// share of the total diffuse reflectance (far clusters, whose whole contribution is small).
    pub absolute: f64,
    /// A node whose whole contribution is at most this share of the total diffuse reflectance
    /// (and whose profile is below 1e-3 of the peak) is left out.
    pub drop: f64,
    /// Largest number of links of a bake (16 bytes each): the near field is narrowed (to no
    /// less than `near_texels`) to fit it.
    pub max_links: u64,
}

impl Default for LinkParams {
    fn default() -> Self {
        LinkParams {
            near_texels: 8,
            tolerance: 0.02,
            absolute: 1e-4,
            drop: 1e-6,
            max_links: 1 << 24,
        }
    }
}

/// One link: a node of the tree and the exitance per unit flux entering it (rgb).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    pub node: u32,
    pub k: [f32; 3],
}

const LEAF: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
struct Node {
    centroid: Vec3,
    radius: f32,
    area: f32,
    first: u32,
    count: u32,
    children: [u32; 2],
}

/// A texel of the object as the links see it.
#[derive(Clone, Copy, Debug)]
struct Texel {
    /// Atlas index (side 0).
    atlas: u32,
    pos: Vec3,
    face: u32,
    grid: (i64, i64),
}

/// The tree of one object and what its links are computed from.
#[derive(Clone, Debug)]
pub struct ObjectTree {
    pub dipole: Dipole3,
    /// Total diffuse reflectance per channel (∫ R_d).
    pub total: [f64; 3],
    texels: Vec<Texel>,
    /// Tree order of the texels (indices into `texels`).
    order: Vec<u32>,
    nodes: Vec<Node>,
    table: OffsetTable,
    near: f64,
    texel_size: f64,
    params: LinkParams,
}

impl ObjectTree {
    /// The tree over `texels` (atlas indices of side 0, covered; `faces[i]` the face of
    /// `texels[i]`) of a medium `dipole` in VLF units; the near field is sized to the memory
    /// budget as if every texel were a receiver.
    pub fn new(
        prep: &BakeScene,
        texels: &[u32],
        faces: &[u32],
        dipole: Dipole3,
        params: LinkParams,
    ) -> ObjectTree {
        let h = f64::from(prep.texel_size);
        let total = dipole.map(|d| d.total_reflectance());
        // Near field: `near_texels` texel sizes, or as far as the profile keeps 1 % of its peak.
        let mut near = f64::from(params.near_texels) * h;
        for d in &dipole {
            let peak = d.profile(0.0);
            let (mut lo, mut hi) = (0.0f64, 1.0 / d.sigma_tr.max(1e-9) * 50.0 + d.z_v * 50.0);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if d.profile(mid) > NEAR_PROFILE_SHARE * peak {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            near = near.max(hi);
        }
        // Memory: about π (near/h)² near links per receiver.
        let per = std::f64::consts::PI * (near / h).powi(2);
        let budget = params.max_links as f64 / texels.len().max(1) as f64;
        if per > budget {
            let fit = (budget / std::f64::consts::PI).sqrt() * h;
            let floor = f64::from(params.near_texels) * h;
            log::warn!(
                "subsurface: near field narrowed from {:.3e} to {:.3e} (VLF units) to fit {} links",
                near,
                fit.max(floor),
                params.max_links
            );
            near = fit.max(floor);
        }
        let reach = (near / h).ceil() as u32 + 1;
        let table = OffsetTable::new(&dipole, h, reach);
        let tex: Vec<Texel> = texels
            .iter()
            .zip(faces)
            .map(|(&t, &f)| {
                let face = &prep.faces[f as usize];
                let local = t - face.texel_base;
                Texel {
                    atlas: t,
                    pos: glam::Vec4::from(prep.texel_center[t as usize]).truncate(),
                    face: f,
                    grid: (i64::from(local % face.width), i64::from(local / face.width)),
                }
            })
            .collect();
        let mut tree = ObjectTree {
            dipole,
            total,
            order: (0..tex.len() as u32).collect(),
            texels: tex,
            nodes: Vec::new(),
            table,
            near,
            texel_size: h,
            params,
        };
        if !tree.texels.is_empty() {
            let n = tree.texels.len();
            tree.build(prep, 0, n);
        }
        tree
    }

    fn build(&mut self, prep: &BakeScene, first: usize, end: usize) -> u32 {
        let id = self.nodes.len() as u32;
        let ids = &self.order[first..end];
        let mut area = 0f64;
        let mut c = glam::DVec3::ZERO;
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for &i in ids {
            let t = &self.texels[i as usize];
            let a = f64::from(prep.texel_area[t.atlas as usize]);
            area += a;
            c += t.pos.as_dvec3() * a;
            lo = lo.min(t.pos);
            hi = hi.max(t.pos);
        }
        let centroid = if area > 0.0 {
            (c / area).as_vec3()
        } else {
            0.5 * (lo + hi)
        };
        let half_diag = self.texel_size as f32 * std::f32::consts::FRAC_1_SQRT_2;
        let radius = ids
            .iter()
            .map(|&i| self.texels[i as usize].pos.distance(centroid))
            .fold(0f32, f32::max)
            + half_diag;
        self.nodes.push(Node {
            centroid,
            radius,
            area: area as f32,
            first: first as u32,
            count: (end - first) as u32,
            children: [LEAF; 2],
        });
        if end - first > 1 {
            let axis = (hi - lo).max_position();
            let texels = &self.texels;
            self.order[first..end].sort_by(|a, b| {
                let (pa, pb) = (texels[*a as usize].pos, texels[*b as usize].pos);
                pa[axis].total_cmp(&pb[axis]).then(a.cmp(b))
            });
            let mid = first + (end - first) / 2;
            let l = self.build(prep, first, mid);
            let r = self.build(prep, mid, end);
            self.nodes[id as usize].children = [l, r];
        }
        id
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        self.texels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.texels.is_empty()
    }

    /// Atlas index of texel `i` (in the order given to [`ObjectTree::new`]).
    pub fn atlas_texel(&self, i: usize) -> u32 {
        self.texels[i].atlas
    }

    /// (texel count, bounding radius, centroid) of node `n`.
    pub fn node(&self, n: u32) -> (u32, f32, Vec3) {
        let node = &self.nodes[n as usize];
        (node.count, node.radius, node.centroid)
    }

    /// Near-field radius (VLF units).
    pub fn near_radius(&self) -> f64 {
        self.near
    }

    fn square(&self, prep: &BakeScene, t: &Texel) -> Square {
        let f = &prep.faces[t.face as usize];
        let h = 0.5 * f.texel_size;
        Square {
            center: t.pos,
            u: Vec3::from(f.u) * h,
            v: Vec3::from(f.v) * h,
        }
    }

    /// The links of receiver texel `i`, and an upper bound of what the dropped nodes would
    /// have added (per unit entering flux density, relative to the total reflectance).
    pub fn links_for(&self, prep: &BakeScene, i: usize) -> (Vec<Link>, f64) {
        let r = self.texels[i];
        let h = self.texel_size;
        let d3 = &self.dipole;
        let peak = d3.map(|d| d.profile(0.0));
        let mut links = Vec::new();
        let mut dropped = 0f64;
        let mut stack = vec![0u32];
        let to32 = |k: [f64; 3]| k.map(|v| v as f32);
        while let Some(n) = stack.pop() {
            let node = self.nodes[n as usize];
            let d = f64::from(r.pos.distance(node.centroid));
            let rho = f64::from(node.radius);
            // Negligible: the whole node's largest possible contribution.
            let upper = kernel::profile3(d3, (d - rho).max(0.0));
            if (0..3).all(|c| {
                upper[c] * f64::from(node.area) <= self.params.drop * self.total[c]
                    && upper[c] <= 1e-3 * peak[c]
            }) {
                dropped += (0..3)
                    .map(|c| upper[c] * f64::from(node.area) / self.total[c].max(1e-30))
                    .fold(0.0, f64::max);
                continue;
            }
            if node.count == 1 {
                let s = self.texels[self.order[node.first as usize] as usize];
                let k = if s.face == r.face
                    && let Some(k) = self.table.get(s.grid.0 - r.grid.0, s.grid.1 - r.grid.1)
                {
                    k
                } else {
                    let dist = f64::from(r.pos.distance(s.pos));
                    if dist < f64::from(self.params.near_texels) * h && s.face != r.face {
                        to32(kernel::pair_gauss(
                            d3,
                            &self.square(prep, &r),
                            &self.square(prep, &s),
                            dist < 3.0 * h,
                        ))
                    } else {
                        to32(kernel::profile3(d3, dist))
                    }
                };
                links.push(Link { node: n, k });
                continue;
            }
            let accept = d - rho > self.near && rho <= 0.5 * d && {
                let (a, b, m) = (
                    kernel::profile3(d3, d - rho),
                    kernel::profile3(d3, d + rho),
                    kernel::profile3(d3, d),
                );
                (0..3).all(|c| {
                    let err = (a[c] + b[c] - 2.0 * m[c]).abs() / 8.0;
                    err <= self.params.tolerance * m[c]
                        || err * f64::from(node.area) <= self.params.absolute * self.total[c]
                })
            };
            if accept {
                links.push(Link {
                    node: n,
                    k: to32(kernel::profile3(d3, d)),
                });
            } else {
                stack.extend(node.children);
            }
        }
        (links, dropped)
    }

    /// The flux entering every node from the flux entering each texel (`flux[i]`, in the order
    /// given to [`ObjectTree::new`]): children before parents, in a fixed order.
    pub fn node_flux(&self, flux: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; self.nodes.len()];
        for n in (0..self.nodes.len()).rev() {
            let node = self.nodes[n];
            out[n] = if node.count == 1 {
                flux[self.order[node.first as usize] as usize]
            } else {
                out[node.children[0] as usize] + out[node.children[1] as usize]
            };
        }
        out
    }
}

/// Σ k × node flux over `links`.
pub fn gather(links: &[Link], node_flux: &[Vec3]) -> Vec3 {
    links.iter().fold(Vec3::ZERO, |s, l| {
        s + Vec3::from_array(l.k) * node_flux[l.node as usize]
    })
}
