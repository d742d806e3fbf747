//! The reflect step for one direction: light arriving on non-diffuse faces, gathered into the
//! tiles of the reflected directions.

use glam::{Vec3, Vec4};

use super::MIN_COS;
use super::cells::CellLists;
use super::interface::Interface;
use super::tiles::ReflectJob;
use super::transport::TransportDir;
use crate::bake::BakeScene;
use crate::lightfield::TileIndex;
use crate::psf::{PsfFrame, PsfGrid};

/// The reflect step (receiving on non-diffuse faces) for one transport direction: every
/// destination cell of every job maps through the face plane into this direction's PSF and
/// gathers the radiance arriving there (`sky` enters through open ends). The radiance for
/// tile value `i` is pushed as `(i, radiance)` onto `next`, in order, for the propagation to
/// add in direction order (directions are gathered in parallel).
#[allow(clippy::too_many_arguments)]
pub fn reflect(
    scene: &BakeScene,
    grid: &PsfGrid,
    dir: &TransportDir,
    lists: &CellLists,
    iface: &[Interface],
    index: &TileIndex,
    frames: &[PsfFrame],
    jobs: &[ReflectJob],
    sky: Vec3,
    next: &mut Vec<(u32, Vec4)>,
) {
    let n = grid.n;
    let m = index.m;
    let tps = n / m;
    for job in jobs {
        let f = &scene.faces[job.face as usize];
        let normal = f.normal();
        let fr = &frames[job.j as usize];
        let ndw = normal.dot(fr.w);
        if ndw.abs() < MIN_COS {
            continue;
        }
        let mf = index.face_slot[job.face as usize] as usize;
        let k = mf * index.directions as usize + job.j as usize;
        for slot in index.index_start[k] as usize..index.index_start[k + 1] as usize {
            let tile = index.tile_ids[slot];
            let (tx, ty) = (tile % tps, tile / tps);
            for local in 0..m * m {
                if !index.covered(slot, local) {
                    continue;
                }
                let (ci, cj) = (tx * m + local % m, ty * m + local / m);
                let (a, b) = grid.cell_center(ci, cj);
                let o = fr.u * a + fr.v * b;
                let x = o + fr.w * ((f.offset - normal.dot(o)) / ndw);
                let q = dir.frame.to_psf(x);
                // The nearest ray of this direction that crosses the face (the destination
                // point may lie just outside the face as this grid samples it).
                let Some(k) = nearest_crossing(grid, lists, q.x, q.y, job.face) else {
                    continue;
                };
                let cr = &iface[k];
                let arriving = match (dir.sun, job.incoming_sense) {
                    // A sun through its ray's open end or through panes (`from_below`).
                    (Some(irr), _) => irr * f32::from(u8::from(cr.first)) + cr.from_below,
                    (None, 0) => cr.from_below + sky * f32::from(u8::from(cr.first)),
                    (None, _) => cr.from_above + sky * f32::from(u8::from(cr.last)),
                };
                let i = (slot * 2 + job.sense as usize) * (m * m) as usize + local as usize;
                let c = arriving * job.rgb_weight(&scene.specular);
                // The fourth component counts what the lobe absorbed (energy bookkeeping).
                next.push((i as u32, c.extend((c.x + c.y + c.z) * job.loss)));
            }
        }
    }
}

/// Index into the crossing arrays of the crossing of `face` by the ray nearest to PSF point
/// `(a, b)` among the 3×3 cells around it, if any.
pub fn nearest_crossing(
    grid: &PsfGrid,
    lists: &CellLists,
    a: f32,
    b: f32,
    face: u32,
) -> Option<usize> {
    let n = grid.n as i64;
    let nf = grid.n as f32;
    let (cx, cy) = ((a + 1.0) * 0.5 * nf, (b + 1.0) * 0.5 * nf);
    let (ci, cj) = (cx.floor() as i64, cy.floor() as i64);
    let mut best: Option<(f32, usize)> = None;
    for dj in -1..=1i64 {
        for di in -1..=1i64 {
            let (i, j) = (ci + di, cj + dj);
            if i < 0 || j < 0 || i >= n || j >= n {
                continue;
            }
            let c = (j * n + i) as usize;
            if let Some(e) = lists.cell(c).iter().position(|e| e.1 == face) {
                let d2 = (i as f32 + 0.5 - cx).powi(2) + (j as f32 + 0.5 - cy).powi(2);
                if best.is_none_or(|b| d2 < b.0) {
                    best = Some((d2, lists.start[c] as usize + e));
                }
            }
        }
    }
    best.map(|b| b.1)
}
