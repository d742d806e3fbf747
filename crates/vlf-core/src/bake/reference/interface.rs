//! Step 3 for one direction: the radiance arriving at every crossing of every ray, from the
//! neighbouring crossings (or the sky).

use glam::{Vec3, Vec4};

use super::cells::CellLists;
use super::energy::sum3;
use super::tiles::{Specular, specular_outgoing};
use super::transport::TransportDir;
use crate::bake::BakeScene;
use crate::lightfield::FACE_DIFFUSE;
use crate::psf::PsfGrid;

/// Per crossing: unshot radiance arriving from neighbouring surfaces travelling +w (from below)
/// and −w (from above); and whether it is the first/last crossing of its ray. A first (last)
/// crossing is *open* below (above): sky and sun light enter there, and light leaving it
/// downward (upward) escapes the scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct Interface {
    pub from_below: Vec3,
    pub from_above: Vec3,
    pub first: bool,
    pub last: bool,
}

/// The energy a direction's light spends in thin glass panes, for the bookkeeping: summed
/// over the direction's rays like the specular escape.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PaneEnergy {
    /// What the panes' tints absorbed of the light they passed (`weight × T − tint × T`).
    pub absorbed: f64,
    /// What left the scene through a pane at a ray's open end.
    pub escaped: f64,
    /// Sunlight that reached a crossing through panes: the texels there count it as injected
    /// ([`super::energy`]), but it was injected already where it entered the first pane.
    pub sun_through: f64,
}

impl PaneEnergy {
    /// Adds the panes' terms to an iteration's: their absorption, their escapes, and the
    /// sunlight counted twice as injected taken back (shared by the CPU and GPU propagators).
    pub fn apply(&self, e: &mut super::IterationEnergy) {
        e.absorbed += self.absorbed;
        e.escaped += self.escaped;
        e.injected -= self.sun_through;
    }
}

/// Step 3: arriving radiance at every crossing. Also returns the specular power that leaves
/// through open ends of rays (escapes), for the energy bookkeeping, and what panes did.
///
/// Panes (faces with a [`PaneFace`](crate::bake::prep::PaneFace)) pass light along the ray: the
/// radiance arriving at a crossing from below is what leaves the crossing below it upward
/// (its texel and tiles) plus that crossing's transmittance `tint × T(θ)` × what arrived
/// there from below — the sky (`sky`, the first iteration) or a sun entering at the ray's
/// open end included; the same from above. So a floor behind a window receives the sky and
/// the suns through the glass, and light travels through any number of panes in one
/// iteration. Along a sun's direction only the sun travels (surfaces' light is never read
/// there): `from_below` is then the sun's irradiance that reached the crossing through panes.
pub fn interface(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    lists: &CellLists,
    unshot: &[[f32; 4]],
    spec: Option<&Specular>,
    sky: Vec3,
) -> (Vec<Interface>, f64, PaneEnergy) {
    let frame = &dir.frame;
    let n = grid.n as usize;
    let w = frame.w;
    let mut out = vec![Interface::default(); lists.entries.len()];
    let cell_power = f64::from(grid.cell_size() * grid.cell_size() * dir.weight);
    let sun_power = f64::from(grid.cell_size() * grid.cell_size());
    let mut escaped = 0f64;
    let mut pane = PaneEnergy::default();
    let has_panes = scene.panes.iter().any(|p| p.weight > 0.0);
    let is_sun = dir.sun.is_some();
    // What enters at a ray's open end travelling +w and −w.
    let (src_up, src_down) = match dir.sun {
        Some(e) => (e, Vec3::ZERO),
        None => (sky, sky),
    };
    // Unshot radiance leaving crossing `e` of `cell` in direction `toward`·w.
    let outgoing = |cell: (u32, u32), e: (f32, u32), toward: f32| -> (Vec3, Vec3) {
        let f = &scene.faces[e.1 as usize];
        let (a, b) = grid.cell_center(cell.0, cell.1);
        let y = frame.from_psf(Vec3::new(a, b, e.0));
        let side = u32::from(f.normal().dot(w) * toward <= 0.0);
        let diffuse = Vec4::from(unshot[f.texel_at(y, side) as usize]).truncate();
        let specular = match spec {
            Some(sp) if f.kind != FACE_DIFFUSE => {
                specular_outgoing(sp.index, sp.unshot, sp.set, sp.frames, e.1, y, w * toward)
            }
            _ => Vec3::ZERO,
        };
        (diffuse, specular)
    };
    // Surfaces send nothing along a sun's direction (only the sun is followed there).
    let leaving = |cell: (u32, u32), e: (f32, u32), toward: f32| -> Vec3 {
        if is_sun {
            Vec3::ZERO
        } else {
            let (d, s) = outgoing(cell, e, toward);
            d + s
        }
    };
    // The pane of the crossing of face `f`: (tint × T, weight × T) along this direction.
    let pass = |f: u32| -> (Vec3, f32) {
        let p = &scene.panes[f as usize];
        let c = scene.faces[f as usize].normal().dot(w).abs();
        (p.transmittance(c), p.untinted(c))
    };
    for c in 0..n * n {
        let cell = ((c % n) as u32, (c / n) as u32);
        let s = lists.start[c] as usize;
        let list = lists.cell(c);
        let len = list.len();
        // Upward: what arrives at crossing k from below.
        let mut carry = Vec3::ZERO;
        for k in 0..len {
            let first = k == 0;
            let below = if first {
                Vec3::ZERO
            } else {
                leaving(cell, list[k - 1], 1.0) + carry
            };
            out[s + k].from_below = below;
            out[s + k].first = first;
            out[s + k].last = k + 1 == len;
            if has_panes {
                if is_sun && !first {
                    pane.sun_through += sum3(carry) * sun_power;
                }
                let arriving = below + if first { src_up } else { Vec3::ZERO };
                let (t, plain) = pass(list[k].1);
                carry = arriving * t;
                let power = if is_sun { sun_power } else { cell_power };
                pane.absorbed += (sum3(arriving) * f64::from(plain) - sum3(carry)) * power;
                if k + 1 == len {
                    pane.escaped += sum3(carry) * power;
                }
            }
        }
        // Downward: what arrives at crossing k from above.
        let mut carry = Vec3::ZERO;
        for k in (0..len).rev() {
            let last = k + 1 == len;
            let above = if last {
                Vec3::ZERO
            } else {
                leaving(cell, list[k + 1], -1.0) + carry
            };
            out[s + k].from_above = above;
            if has_panes && !is_sun {
                let arriving = above + if last { src_down } else { Vec3::ZERO };
                let (t, plain) = pass(list[k].1);
                carry = arriving * t;
                pane.absorbed += (sum3(arriving) * f64::from(plain) - sum3(carry)) * cell_power;
                if k == 0 {
                    pane.escaped += sum3(carry) * cell_power;
                }
            }
        }
        for k in 0..len {
            // Specular light leaving through an open end escapes (diffuse escapes are counted
            // per texel from the open fractions).
            let (first, last) = (k == 0, k + 1 == len);
            if spec.is_some() && !is_sun && scene.faces[list[k].1 as usize].kind != FACE_DIFFUSE {
                if last {
                    escaped += sum3(outgoing(cell, list[k], 1.0).1) * cell_power;
                }
                if first {
                    escaped += sum3(outgoing(cell, list[k], -1.0).1) * cell_power;
                }
            }
        }
    }
    (out, escaped, pane)
}
