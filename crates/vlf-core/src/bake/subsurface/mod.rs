//! Subsurface scattering in the bake (`docs/SUBSURFACE.md`): light that enters a translucent
//! surface leaves elsewhere, and re-enters the propagation as the next iteration's unshot
//! radiance.
//!
//! * **Dipole** objects (faces of one [`Translucency::Dipole`] material connected through shared
//!   vertices): the flux entering each outside (side-0) texel, (1 − F_dr,ext) E A, is scattered
//!   through the object's hierarchical links ([`links`], factors from [`kernel`]); the surface
//!   itself reflects F_dr,ext E.
//! * **Thin diffuse transmission**: each side of a texel reflects (1 − t) ρ of its own
//!   irradiance and sends on τ = t × colour × diffuse weight of the irradiance on its other side.
//!
//! [`Subsurface::exitance`] is the transport (what every translucent texel emits besides its
//! surface reflection, from the irradiance of every texel). The propagation replaces the
//! translucent texels' next unshot radiance, which `finish_iteration` made ρE/π, by their
//! exitance over π ([`Subsurface::apply`]); at its end their irradiance becomes the *effective*
//! irradiance E_eff = M/ρ ([`Subsurface::effective`]), the value whose product with the albedo
//! the renderer, the final gather's field and `BakeScene::outgoing_radiance` take, so they all
//! read the translucent surfaces' true exitance M. Nothing is built for scenes without
//! translucent materials ([`Subsurface::new`] returns `None`).

pub mod kernel;
pub mod links;

use std::collections::HashMap;

use glam::{Vec3, Vec4};
use serde::Serialize;

use crate::bake::BakeScene;
use crate::scene::Translucency;
use crate::scene::dipole::{Dipole, fresnel_diffuse_external};
pub use links::{Link, LinkParams, ObjectTree};

/// One dipole object: its tree and every receiver's links (CSR).
#[derive(Clone, Debug)]
pub struct DipoleObject {
    pub material: u32,
    /// F_dr,ext: the share of the irradiance the surface reflects; 1 − it enters.
    pub fresnel: f32,
    pub tree: ObjectTree,
    link_start: Vec<u32>,
    links: Vec<Link>,
    /// Largest bound, over receivers, of the dropped nodes' share of the total reflectance.
    pub dropped: f64,
}

/// What the links cost, for logs and `docs/PERFORMANCE.md`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SubsurfaceStats {
    pub dipole_objects: usize,
    pub dipole_texels: usize,
    pub links: usize,
    pub link_bytes: usize,
    pub thin_texels: usize,
    /// Largest bound of the dropped nodes' share of the total reflectance.
    pub dropped: f64,
}

/// The translucent texels of a prepared scene and their transport.
#[derive(Clone, Debug)]
pub struct Subsurface {
    pub objects: Vec<DipoleObject>,
    /// (side-0 texel, texels per side, τ) of every covered texel with thin transmission.
    thin: Vec<(u32, u32, Vec3)>,
    /// Every translucent texel (both sides, covered; sorted) and what its surface reflects.
    texels: Vec<u32>,
    reflect: Vec<Vec3>,
}

impl Subsurface {
    /// The transport of `prep`'s translucent materials, links built on `threads` workers
    /// (0 = all cores); `None` when no face is translucent.
    pub fn new(prep: &BakeScene, params: &LinkParams, threads: usize) -> Option<Subsurface> {
        let model = |m: u32| {
            prep.translucency
                .get(m as usize)
                .copied()
                .unwrap_or_default()
        };
        if !prep
            .faces
            .iter()
            .any(|f| model(f.material).is_translucent())
        {
            return None;
        }
        let mut thin = Vec::new();
        for f in &prep.faces {
            if let Translucency::ThinDiffuseTransmission { color, .. } = model(f.material) {
                let n = f.texels_per_side();
                for t in f.texel_base..f.texel_base + n {
                    if prep.texel_area[t as usize] > 0.0 {
                        thin.push((t, n, color));
                    }
                }
            }
        }
        let mut objects = Vec::new();
        for (material, faces) in dipole_objects(prep) {
            let Translucency::Dipole {
                sigma_s_prime,
                sigma_a,
                eta,
            } = model(material)
            else {
                continue;
            };
            let dipole: [Dipole; 3] = std::array::from_fn(|c| {
                Dipole::new(
                    f64::from(sigma_s_prime[c]),
                    f64::from(sigma_a[c]),
                    f64::from(eta),
                )
            });
            let (mut tex, mut tex_face) = (Vec::new(), Vec::new());
            for fi in faces {
                let f = &prep.faces[fi as usize];
                for t in f.texel_base..f.texel_base + f.texels_per_side() {
                    if prep.texel_area[t as usize] > 0.0 {
                        tex.push(t);
                        tex_face.push(fi);
                    }
                }
            }
            let tree = ObjectTree::new(prep, &tex, &tex_face, dipole, *params);
            let built = crate::par::map(tree.len(), threads, 64, |i| tree.links_for(prep, i));
            let mut link_start = Vec::with_capacity(tree.len() + 1);
            let mut links = Vec::new();
            let mut dropped = 0f64;
            link_start.push(0);
            for (l, d) in built {
                links.extend(l);
                link_start.push(links.len() as u32);
                dropped = dropped.max(d);
            }
            objects.push(DipoleObject {
                material,
                fresnel: fresnel_diffuse_external(f64::from(eta)) as f32,
                tree,
                link_start,
                links,
                dropped,
            });
        }
        // Both sides of every translucent face, with what their surfaces reflect.
        let mut texels = Vec::new();
        for f in &prep.faces {
            let model = model(f.material);
            if !model.is_translucent() {
                continue;
            }
            let n = f.texels_per_side();
            for side in 0..2u32 {
                for t in f.texel_base + side * n..f.texel_base + (side + 1) * n {
                    if prep.texel_area[t as usize] > 0.0 {
                        texels.push(t);
                    }
                }
            }
        }
        texels.sort_unstable();
        let reflect = texels
            .iter()
            .map(|&t| {
                let f = &prep.faces[face_of(prep, t)];
                let side = ((t - f.texel_base) / f.texels_per_side()) as usize;
                let rho = Vec4::from(prep.albedo[t as usize]).truncate();
                model(f.material).reflected_albedo(rho, side)
            })
            .collect();
        let s = Subsurface {
            objects,
            thin,
            texels,
            reflect,
        };
        let st = s.stats();
        log::info!(
            "subsurface: {} dipole objects, {} texels, {} links ({:.1} MiB), {} thin texels, dropped ≤ {:.2e}",
            st.dipole_objects,
            st.dipole_texels,
            st.links,
            st.link_bytes as f64 / 1048576.0,
            st.thin_texels,
            st.dropped
        );
        Some(s)
    }

    pub fn stats(&self) -> SubsurfaceStats {
        let links: usize = self.objects.iter().map(|o| o.links.len()).sum();
        SubsurfaceStats {
            dipole_objects: self.objects.len(),
            dipole_texels: self.objects.iter().map(|o| o.tree.len()).sum(),
            links,
            link_bytes: links * std::mem::size_of::<Link>()
                + self
                    .objects
                    .iter()
                    .map(|o| o.link_start.len() * 4)
                    .sum::<usize>(),
            thin_texels: self.thin.len(),
            dropped: self.objects.iter().map(|o| o.dropped).fold(0.0, f64::max),
        }
    }

    /// The links of receiver `i` of object `o`.
    pub fn links(&self, o: usize, i: usize) -> &[Link] {
        let ob = &self.objects[o];
        &ob.links[ob.link_start[i] as usize..ob.link_start[i + 1] as usize]
    }

    /// What every translucent texel emits besides its surface reflection, from the irradiance
    /// `irr(t)` of every texel: (atlas texel, exitance rgb), the thin texels' transmitted light
    /// and the dipole texels' scattered light, in a fixed order.
    pub fn exitance(&self, prep: &BakeScene, irr: impl Fn(u32) -> Vec3) -> Vec<(u32, Vec3)> {
        let mut out = Vec::new();
        for &(t, n, tau) in &self.thin {
            out.push((t, tau * irr(t + n)));
            out.push((t + n, tau * irr(t)));
        }
        for (o, ob) in self.objects.iter().enumerate() {
            let enter = 1.0 - ob.fresnel;
            let flux: Vec<Vec3> = (0..ob.tree.len())
                .map(|i| {
                    let t = ob.tree.atlas_texel(i);
                    irr(t) * (enter * prep.texel_area[t as usize])
                })
                .collect();
            let nf = ob.tree.node_flux(&flux);
            for i in 0..ob.tree.len() {
                out.push((ob.tree.atlas_texel(i), links::gather(self.links(o, i), &nf)));
            }
        }
        out
    }

    /// Every translucent texel (both sides of their faces, covered), sorted.
    pub fn texels(&self) -> &[u32] {
        &self.texels
    }

    /// The irradiance of [`Subsurface::texels`] (to take this iteration's share of a running
    /// sum: [`Subsurface::apply`]).
    pub fn snapshot(&self, irradiance: &[[f32; 4]]) -> Vec<[f32; 4]> {
        self.texels
            .iter()
            .map(|&t| irradiance[t as usize])
            .collect()
    }

    /// Every translucent texel's whole exitance M (surface reflection + transmitted or
    /// scattered light) from the irradiance `irr(t)` of every texel, in texel order.
    pub fn total_exitance(&self, prep: &BakeScene, irr: impl Fn(u32) -> Vec3) -> Vec<Vec3> {
        let mut m: Vec<Vec3> = self
            .texels
            .iter()
            .zip(&self.reflect)
            .map(|(&t, r)| *r * irr(t))
            .collect();
        for (t, x) in self.exitance(prep, &irr) {
            let k = self.texels.binary_search(&t).expect("translucent texel");
            m[k] += x;
        }
        m
    }

    /// Replaces the translucent texels' next unshot radiance, which `finish_iteration` made
    /// ρE/π from this iteration's irradiance (`irradiance` now minus `before`, a
    /// [`Subsurface::snapshot`] taken before the iteration added to it), by their exitance
    /// M/π; returns the power this adds to what is sent on (Σ (M − ρE) × area over texels and
    /// channels, signed), which the caller moves from the absorbed power to the unshot.
    pub fn apply(
        &self,
        prep: &BakeScene,
        before: &[[f32; 4]],
        irradiance: &[[f32; 4]],
        next: &mut [[f32; 4]],
    ) -> f64 {
        let this = |t: u32| -> Vec3 {
            let k = self.texels.binary_search(&t).expect("translucent texel");
            (Vec4::from(irradiance[t as usize]) - Vec4::from(before[k])).truncate()
        };
        let m = self.total_exitance(prep, this);
        let mut power = 0f64;
        for (&t, m) in self.texels.iter().zip(m) {
            let t = t as usize;
            let old = Vec4::from(next[t]).truncate() * std::f32::consts::PI;
            next[t] = (m / std::f32::consts::PI).extend(0.0).into();
            let d = m - old;
            power +=
                (f64::from(d.x) + f64::from(d.y) + f64::from(d.z)) * f64::from(prep.texel_area[t]);
        }
        power
    }

    /// Turns the translucent texels' irradiance E into the effective irradiance E_eff = M/ρ
    /// (per channel; 0 where the albedo ρ is 0, which cannot show the light), M their whole
    /// exitance from E ([`Subsurface::total_exitance`]): what the renderer, the final gather's
    /// field and [`BakeScene::outgoing_radiance`] multiply by ρ/π. The transport is linear, so
    /// this holds for a sum of iterations as for each.
    pub fn effective(&self, prep: &BakeScene, irradiance: &mut [[f32; 4]]) {
        let m = self.total_exitance(prep, |t| Vec4::from(irradiance[t as usize]).truncate());
        for (&t, m) in self.texels.iter().zip(m) {
            let rho = Vec4::from(prep.albedo[t as usize]).truncate();
            let e = Vec3::select(
                rho.cmpgt(Vec3::ZERO),
                m / rho.max(Vec3::splat(1e-30)),
                Vec3::ZERO,
            );
            irradiance[t as usize] = e.extend(0.0).into();
        }
    }
}

/// The face of atlas texel `t`.
fn face_of(prep: &BakeScene, t: u32) -> usize {
    prep.faces
        .partition_point(|f| f.texel_base <= t)
        .saturating_sub(1)
}

/// The dipole objects of `prep`: (material, faces) for every set of faces with one
/// [`Translucency::Dipole`] material connected through shared vertices (bit-equal positions),
/// in order of their first face.
pub fn dipole_objects(prep: &BakeScene) -> Vec<(u32, Vec<u32>)> {
    let is_dipole = |f: u32| {
        matches!(
            prep.translucency
                .get(prep.faces[f as usize].material as usize),
            Some(Translucency::Dipole { .. })
        )
    };
    let n = prep.faces.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(p: &mut [u32], mut i: u32) -> u32 {
        while p[i as usize] != i {
            p[i as usize] = p[p[i as usize] as usize];
            i = p[i as usize];
        }
        i
    }
    let mut first_at: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
    for t in &prep.triangles {
        if !is_dipole(t.face) {
            continue;
        }
        let m = prep.faces[t.face as usize].material;
        for p in [t.p0, t.p1, t.p2] {
            let key = (m, p.map(f32::to_bits));
            let other = *first_at.entry(key).or_insert(t.face);
            let (a, b) = (root(&mut parent, t.face), root(&mut parent, other));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut groups: Vec<(u32, Vec<u32>)> = Vec::new();
    let mut group_of: HashMap<u32, usize> = HashMap::new();
    for f in 0..n as u32 {
        if !is_dipole(f) {
            continue;
        }
        let r = root(&mut parent, f);
        let g = *group_of.entry(r).or_insert_with(|| {
            groups.push((prep.faces[f as usize].material, Vec::new()));
            groups.len() - 1
        });
        groups[g].1.push(f);
    }
    groups
}
