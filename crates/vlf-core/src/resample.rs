//! Backward ray-traced resampling of the mirror tiles, once propagation has ended (the original
//! VLF paper, §5: "re-sample directional radiance maps on specular surfaces using backwards ray
//! tracing, following S*D paths only … by following true ray paths (not only paths dictated by
//! fixed PSF directions)").
//!
//! During propagation a mirror's tile value for fixed direction j is the radiance reflected from
//! the three fixed directions around the mirror image of j, so a reflection is interpolated
//! between directions (ghosts) and misses what falls between them (holes). Here every covered
//! tile cell and sense is computed again: from the point where the cell's ray crosses the mirror,
//! the true reflected ray is traced through further mirrors (up to a depth bound, then their
//! tiles are read) to the first other surface, whose radiance towards the ray comes from the
//! converged field ([`crate::gather::field::Field`]: emission, the diffuse part from the atlas —
//! the gathered one when the final gather ran — and a mixed face's own tiles), or the sky.
//! Light that mirrors sent to diffuse faces (caustics) was already propagated and is not touched:
//! only the stored tiles, which the renderer and the final gather read, change.
//!
//! Glossy faces (`bake::glossy`, [`SpecularModel::Tiles`]) keep their propagated tiles: their
//! light is spread over the lobe, which one true reflected ray does not sample; a path that
//! meets one reads its tiles there. A lobe the bake models as a mirror (narrower than the
//! direction spacing) reflects its directional albedo.

use glam::{Vec3, Vec4};
use serde::Serialize;

use crate::bake::BakeScene;
use crate::bake::glossy::SpecularModel;
use crate::bake::reference::tile_power;
use crate::directions::DirectionSet;
use crate::gather::field::{Field, Tiles};
use crate::lightfield::tiles::words_per_slot;
use crate::lightfield::{FACE_DIFFUSE, FACE_MIRROR, TileIndex};
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::material::GgxAlbedo;
use crate::pathtrace::{PreparedScene, Ray};
use crate::psf::{PsfGrid, fixed_frame};
use crate::scene::Scene;

/// Mirrors followed from a tile cell before the last one's own tiles are read.
pub const MAX_DEPTH: u32 = 8;
/// Slots handed to a worker at a time.
const CHUNK: usize = 16;

/// Bookkeeping of a resampling (`vlf-bake bake --json`, `resample`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ResampleStats {
    /// Tile values traced again (covered cells × 2 senses).
    pub values: u64,
    /// Paths cut at [`MAX_DEPTH`] mirrors (their last mirror's tiles were read).
    pub cut_off: u64,
    /// Paths that left the scene (sky).
    pub escaped: u64,
    /// Power of the tiles before and after (Σ L × cell area × ΔΩ, summed over channels).
    pub power_before: f64,
    pub power_after: f64,
}

/// How the bake modelled each face's metal lobe (`prep.lobes`), with the directional albedo of
/// the rough ones it keeps as mirrors.
struct Lobes<'a> {
    models: &'a [SpecularModel],
    albedos: Vec<GgxAlbedo>,
}

impl Lobes<'_> {
    fn new(models: &[SpecularModel]) -> Lobes<'_> {
        let mut albedos: Vec<GgxAlbedo> = Vec::new();
        for m in models {
            if let SpecularModel::Mirror { alpha } = *m
                && alpha > 0.0
                && !albedos.iter().any(|a| a.alpha == alpha)
            {
                albedos.push(GgxAlbedo::new(alpha));
            }
        }
        Lobes { models, albedos }
    }

    /// Whether `face` is a thin glass pane.
    fn pane(&self, face: u32) -> bool {
        matches!(self.models[face as usize], SpecularModel::Pane { .. })
    }

    /// Whether `face` keeps its propagated tiles (a glossy lobe).
    fn glossy(&self, face: u32) -> bool {
        matches!(self.models[face as usize], SpecularModel::Tiles { .. })
    }

    /// What `face`, modelled as a mirror, reflects at `|cos θ|` = `cos` per unit reflectance
    /// (1 for a perfect mirror, R(θ) for a pane).
    fn mirror_albedo(&self, face: u32, cos: f32) -> f32 {
        match self.models[face as usize] {
            SpecularModel::Pane { ior } => crate::scene::pane_reflectance(cos, ior),
            SpecularModel::Mirror { alpha } if alpha > 0.0 => self
                .albedos
                .iter()
                .find(|a| a.alpha == alpha)
                .map_or(1.0, |a| a.at(cos.abs())),
            _ => 1.0,
        }
    }
}

/// Per-value outcome of a traced path.
#[derive(Clone, Copy, Default)]
struct Traced {
    value: [f32; 4],
    cut: bool,
    escaped: bool,
}

/// Resamples every covered value of `tiles` (total outgoing radiance, as propagated) by tracing
/// true reflected rays into the converged field `atlas` / `irradiance` (undilated), on `threads`
/// workers (0 = all cores). Returns the new values and the bookkeeping.
#[allow(clippy::too_many_arguments)]
pub fn resample_tiles(
    scene: &Scene,
    prep: &BakeScene,
    atlas: &BakeScene,
    irradiance: &[[f32; 4]],
    index: &TileIndex,
    values: &[[f32; 4]],
    directions: &DirectionSet,
    sky: Vec3,
    threads: usize,
) -> (Vec<[f32; 4]>, ResampleStats) {
    let ps = PreparedScene::new(scene);
    let lobes = Lobes::new(&prep.lobes);
    let field = Field::new(
        &ps,
        atlas,
        irradiance,
        Some(Tiles::new(index, values, directions)),
    );
    let grid = PsfGrid::new(index.n, index.m).expect("a tile index has a valid grid");
    let (m, l) = (index.m, index.directions as usize);
    let m2 = (m * m) as usize;
    let words = words_per_slot(m);
    let tiles_per_side = grid.tiles_per_side();
    let cell = grid.cell_size();
    let slots = index.tile_ids.len();
    // Slot → (face, direction) without a search per slot.
    let mut owner = vec![(0u32, 0usize); slots];
    for (k, w) in index.index_start.windows(2).enumerate() {
        let face = index.faces[k / l];
        for o in &mut owner[w[0] as usize..w[1] as usize] {
            *o = (face, k % l);
        }
    }
    let traced: Vec<Vec<Traced>> = crate::par::map(slots, threads, CHUNK, |slot| {
        let (face, j) = owner[slot];
        let f = &prep.faces[face as usize];
        let normal = f.normal();
        let frame = fixed_frame(directions, j);
        let ndw = normal.dot(frame.w);
        let reflectance = Vec4::from(prep.specular[face as usize]).truncate();
        let tile = index.tile_ids[slot];
        let (tx, ty) = (tile % tiles_per_side, tile / tiles_per_side);
        let mut out = vec![Traced::default(); 2 * m2];
        for local in 0..m2 {
            let covered = (index.coverage[slot * words + local / 32] >> (local % 32)) & 1 == 1;
            if !covered || ndw.abs() < crate::bake::reference::MIN_COS || lobes.glossy(face) {
                for sense in 0..2 {
                    out[sense * m2 + local].value = values[(slot * 2 + sense) * m2 + local];
                }
                continue;
            }
            let (ci, cj) = (tx * m + local as u32 % m, ty * m + local as u32 / m);
            let a = -1.0 + (ci as f32 + 0.5) * cell;
            let b = -1.0 + (cj as f32 + 0.5) * cell;
            let o = frame.u * a + frame.v * b;
            let p = o + frame.w * ((f.offset - normal.dot(o)) / ndw);
            for sense in 0..2 {
                let leaving = if sense == 0 { frame.w } else { -frame.w };
                let t = trace(
                    &ps,
                    &field,
                    &lobes,
                    scene.to_vlf.inverse(p),
                    normal,
                    leaving,
                    sky,
                );
                let albedo = lobes.mirror_albedo(face, ndw);
                out[sense * m2 + local] = Traced {
                    value: (reflectance * albedo * t.0).extend(0.0).into(),
                    cut: t.1 == Ending::Cut,
                    escaped: t.1 == Ending::Sky,
                };
            }
        }
        out
    });
    let mut new = vec![[0f32; 4]; values.len()];
    let mut stats = ResampleStats::default();
    for (slot, vs) in traced.iter().enumerate() {
        for (k, t) in vs.iter().enumerate() {
            let (sense, local) = (k / m2, k % m2);
            new[(slot * 2 + sense) * m2 + local] = t.value;
        }
        for local in 0..m2 {
            if (index.coverage[slot * words + local / 32] >> (local % 32)) & 1 == 1 {
                stats.values += 2;
                for sense in 0..2 {
                    let t = &vs[sense * m2 + local];
                    stats.cut_off += u64::from(t.cut);
                    stats.escaped += u64::from(t.escaped);
                }
            }
        }
    }
    stats.power_before = tile_power(index, values, directions, &grid);
    stats.power_after = tile_power(index, &new, directions, &grid);
    (new, stats)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Ending {
    Surface,
    Sky,
    Cut,
}

/// Radiance arriving at mirror point `p` (world) of unit `normal` from the direction whose
/// reflection leaves along `leaving` (unit): the true reflected ray, through further mirrors.
fn trace(
    ps: &PreparedScene,
    field: &Field,
    lobes: &Lobes,
    p: Vec3,
    normal: Vec3,
    leaving: Vec3,
    sky: Vec3,
) -> (Vec3, Ending) {
    // Light leaving along `leaving` arrived travelling along reflect(leaving); trace against it.
    let mut dir = (2.0 * leaving.dot(normal) * normal - leaving).normalize();
    let mut side = if normal.dot(leaving) > 0.0 {
        normal
    } else {
        -normal
    };
    let mut origin = offset_ray_origin(p, side);
    let mut throughput = Vec3::ONE;
    let mut depth = 0;
    // What panes crossed on the way sent back (their reflection, from their tiles).
    let mut seen = Vec3::ZERO;
    loop {
        let hit = ps.bvh.closest_hit(&Ray::new(origin, dir, f32::INFINITY));
        if !hit.is_hit() {
            return (seen + throughput * sky, Ending::Sky);
        }
        let s = field.surface(ps, dir, &hit);
        let f = &field.atlas.faces[s.face as usize];
        // A pane passes the ray on straight through (attenuated) and sends back what its tiles
        // and diffuse part hold: the chain follows the transmission (`gather::through`).
        if lobes.pane(s.face) && depth + 1 < MAX_DEPTH {
            seen += throughput * (field.emission(&s) + field.diffuse(&s) + field.specular(&s, dir));
            throughput *= crate::gather::through::pane_pass(ps, &hit, dir).unwrap_or(Vec3::ZERO);
            let n = f.normal();
            origin = offset_ray_origin(s.world, if n.dot(dir) > 0.0 { n } else { -n });
            depth += 1;
            continue;
        }
        match f.kind {
            FACE_MIRROR if depth + 1 < MAX_DEPTH && !lobes.glossy(s.face) => {
                let n = f.normal();
                throughput *= Vec4::from(field.atlas.specular[s.face as usize]).truncate()
                    * lobes.mirror_albedo(s.face, n.dot(dir));
                side = if n.dot(-dir) > 0.0 { n } else { -n };
                dir = (dir - 2.0 * dir.dot(n) * n).normalize();
                origin = offset_ray_origin(s.world, side);
                depth += 1;
            }
            FACE_MIRROR if !lobes.glossy(s.face) => {
                return (seen + throughput * field.specular(&s, dir), Ending::Cut);
            }
            FACE_DIFFUSE => {
                return (
                    seen + throughput * (field.emission(&s) + field.diffuse(&s)),
                    Ending::Surface,
                );
            }
            _ => {
                return (
                    seen + throughput
                        * (field.emission(&s) + field.diffuse(&s) + field.specular(&s, dir)),
                    Ending::Surface,
                );
            }
        }
    }
}
