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

/// Step 3: arriving radiance at every crossing. Also returns the specular power that leaves
/// through open ends of rays (escapes), for the energy bookkeeping.
pub fn interface(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    lists: &CellLists,
    unshot: &[[f32; 4]],
    spec: Option<&Specular>,
) -> (Vec<Interface>, f64) {
    let frame = &dir.frame;
    let n = grid.n as usize;
    let w = frame.w;
    let mut out = vec![Interface::default(); lists.entries.len()];
    let cell_power = f64::from(grid.cell_size() * grid.cell_size() * dir.weight);
    let mut escaped = 0f64;
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
    for c in 0..n * n {
        let cell = ((c % n) as u32, (c / n) as u32);
        let s = lists.start[c] as usize;
        let list = lists.cell(c);
        for k in 0..list.len() {
            let first = k == 0;
            let last = k + 1 == list.len();
            let sum = |(d, s): (Vec3, Vec3)| d + s;
            out[s + k] = Interface {
                from_below: if first {
                    Vec3::ZERO
                } else {
                    sum(outgoing(cell, list[k - 1], 1.0))
                },
                from_above: if last {
                    Vec3::ZERO
                } else {
                    sum(outgoing(cell, list[k + 1], -1.0))
                },
                first,
                last,
            };
            // Specular light leaving through an open end escapes (diffuse escapes are counted
            // per texel from the open fractions).
            if spec.is_some()
                && dir.sun.is_none()
                && scene.faces[list[k].1 as usize].kind != FACE_DIFFUSE
            {
                if last {
                    escaped += sum3(outgoing(cell, list[k], 1.0).1) * cell_power;
                }
                if first {
                    escaped += sum3(outgoing(cell, list[k], -1.0).1) * cell_power;
                }
            }
        }
    }
    (out, escaped)
}
