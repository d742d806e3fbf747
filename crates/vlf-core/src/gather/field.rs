//! The converged light field as a gather ray reads it at its first hit: the propagation's
//! irradiance atlas (times the hit point's own albedo, texture included) for the diffuse part,
//! and the sparse mirror tiles in the ray's direction for the specular part — the same lookups
//! the renderer's pass 5 does ([`Tiles::radiance_towards`] is its CPU form).

use glam::{Vec2, Vec3, Vec4};

use crate::bake::BakeScene;
use crate::directions::DirectionSet;
use crate::lightfield::{BakeFace, TileIndex};
use crate::pathtrace::{Hit, PreparedScene};
use crate::psf::PsfFrame;
use crate::scene::Scene;

/// A converged light field as seen from a traced ray: an atlas of irradiance per texel side and,
/// for non-diffuse faces, their directional tiles. Radiance leaving a surface point towards a
/// ray's origin is the emission (front side) + the diffuse albedo (texture at the point's own
/// uv) / π × the atlas irradiance (bilinear) + the face's specular tiles in that direction.
pub struct Field<'a> {
    pub scene: &'a Scene,
    /// The atlas' charts.
    pub atlas: &'a BakeScene,
    /// Irradiance per texel of `atlas`, dilated so bilinear reads at polygon borders see
    /// covered texels.
    pub irradiance: Vec<[f32; 4]>,
    pub tiles: Option<Tiles<'a>>,
}

/// Where a ray landed: the hit point in VLF and world coordinates, its face, texture coordinates
/// and whether the ray arrived at the face's front.
pub struct SurfaceHit {
    pub face: u32,
    pub material: u32,
    pub world: Vec3,
    pub vlf: Vec3,
    pub uv: Vec2,
    /// The side the ray arrived at (0 = front).
    pub side: u32,
}

impl<'a> Field<'a> {
    /// A field over `atlas` with undilated `irradiance` (dilated here).
    pub fn new(
        scene: &'a Scene,
        atlas: &'a BakeScene,
        irradiance: &[[f32; 4]],
        tiles: Option<Tiles<'a>>,
    ) -> Self {
        let mut irradiance = irradiance.to_vec();
        crate::bake::dilate(atlas, &mut irradiance);
        Self {
            scene,
            atlas,
            irradiance,
            tiles,
        }
    }

    /// The surface `hit` of a ray travelling along `dir` (world) in the BVH of `ps`.
    pub fn surface(&self, ps: &PreparedScene, dir: Vec3, hit: &Hit) -> SurfaceHit {
        let tri = &ps.bvh.triangles[hit.tri as usize];
        let st = &self.scene.triangles[tri.prim as usize];
        let [p0, p1, p2] = tri.corners();
        let (b1, b2) = (hit.u, hit.v);
        let world = p0 * (1.0 - b1 - b2) + p1 * b1 + p2 * b2;
        let uv = {
            let uv = &ps.uvs[hit.tri as usize];
            uv[0] * (1.0 - b1 - b2) + uv[1] * b1 + uv[2] * b2
        };
        let f = &self.atlas.faces[st.face as usize];
        SurfaceHit {
            face: st.face,
            material: st.material,
            world,
            vlf: self.scene.to_vlf.apply(world),
            uv,
            side: if f.normal().dot(-dir) >= 0.0 { 0 } else { 1 },
        }
    }

    /// Diffuse (Lambertian) radiance leaving `s` on the side its ray arrived at: albedo at its
    /// uv / π × the atlas' irradiance there.
    pub fn diffuse(&self, s: &SurfaceHit) -> Vec3 {
        let m = &self.scene.materials[s.material as usize];
        // The diffuse albedo the bake used (a rough metal folded into it included).
        let mut rho = self.atlas.materials[s.material as usize].diffuse;
        if rho == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if let Some(t) = m.base_color_texture {
            rho *= self.scene.textures[t.index as usize]
                .bilinear(s.uv)
                .truncate();
        }
        let f = &self.atlas.faces[s.face as usize];
        rho * std::f32::consts::FRAC_1_PI * chart_bilinear(f, &self.irradiance, s.side, s.vlf)
    }

    /// Emitted radiance of `s` (the front side emits).
    pub fn emission(&self, s: &SurfaceHit) -> Vec3 {
        let m = &self.scene.materials[s.material as usize];
        if s.side != 0 || !m.is_emissive() {
            return Vec3::ZERO;
        }
        match m.emissive_texture {
            Some(t) => {
                m.emission
                    * self.scene.textures[t.index as usize]
                        .bilinear(s.uv)
                        .truncate()
            }
            None => m.emission,
        }
    }

    /// Specular radiance leaving `s` towards its ray's origin (travelling along −`dir`), from
    /// the face's tiles (zero for diffuse faces).
    pub fn specular(&self, s: &SurfaceHit, dir: Vec3) -> Vec3 {
        match &self.tiles {
            Some(tiles) => {
                let f = &self.atlas.faces[s.face as usize];
                tiles.radiance_towards(s.face, f.normal(), s.vlf, -dir)
            }
            None => Vec3::ZERO,
        }
    }
}

/// Continuous chart coordinates (texel units) of plane point `p` on face `f`.
pub fn chart_coords(f: &BakeFace, p: Vec3) -> Vec2 {
    let d = p - Vec3::from(f.origin);
    Vec2::new(d.dot(Vec3::from(f.u)), d.dot(Vec3::from(f.v))) / f.texel_size
}

/// A per-texel quantity of face `f` on `side`, read bilinearly at plane point `p` with texel
/// indices clamped to the chart (never across faces or sides): the filter the renderer applies
/// to the atlas (`render_final_radiance.wgsl`, `atlas_irradiance`).
pub fn chart_bilinear(f: &BakeFace, values: &[[f32; 4]], side: u32, p: Vec3) -> Vec3 {
    let c = chart_coords(f, p) - Vec2::splat(0.5);
    let (x0, y0) = (c.x.floor(), c.y.floor());
    let (fx, fy) = (c.x - x0, c.y - y0);
    let ci = |i: f32| (i as i32).clamp(0, f.width as i32 - 1) as u32;
    let cj = |j: f32| (j as i32).clamp(0, f.height as i32 - 1) as u32;
    let base = f.texel_base + side * f.width * f.height;
    let at = |i: u32, j: u32| Vec4::from(values[(base + j * f.width + i) as usize]).truncate();
    let (i0, i1, j0, j1) = (ci(x0), ci(x0 + 1.0), cj(y0), cj(y0 + 1.0));
    let top = at(i0, j0).lerp(at(i1, j0), fx);
    let bottom = at(i0, j1).lerp(at(i1, j1), fx);
    top.lerp(bottom, fy)
}

/// The sparse per-direction tiles of the non-diffuse faces, with the fixed directions' frames.
pub struct Tiles<'a> {
    pub index: &'a TileIndex,
    /// Total outgoing radiance per tile value (rgb).
    pub values: &'a [[f32; 4]],
    pub set: &'a DirectionSet,
    frames: Vec<PsfFrame>,
}

impl<'a> Tiles<'a> {
    pub fn new(index: &'a TileIndex, values: &'a [[f32; 4]], set: &'a DirectionSet) -> Self {
        let frames = crate::psf::fixed_frames(set);
        Self {
            index,
            values,
            set,
            frames,
        }
    }

    /// Value index of face slot `mf`, fixed direction `j`, cell `(ci, cj)` and `sense`, or
    /// `None` when the face stores no tile there or the cell is not covered.
    fn value_index(&self, mf: u32, j: usize, ci: i64, cj: i64, sense: u32) -> Option<usize> {
        let ix = self.index;
        let n = i64::from(ix.n);
        if ci < 0 || cj < 0 || ci >= n || cj >= n {
            return None;
        }
        let (ci, cj) = (ci as u32, cj as u32);
        let k = mf as usize * ix.directions as usize + j;
        let range = ix.index_start[k] as usize..ix.index_start[k + 1] as usize;
        let m = ix.m;
        let tile = (cj / m) * (ix.n / m) + ci / m;
        let slot = range.start + ix.tile_ids[range].binary_search(&tile).ok()?;
        let local = (cj % m) * m + ci % m;
        let words = crate::lightfield::tiles::words_per_slot(m);
        let cov = ix.coverage[slot * words + (local / 32) as usize];
        if (cov >> (local % 32)) & 1 == 0 {
            return None;
        }
        Some(((slot as u32 * 2 + sense) * m * m + local) as usize)
    }

    /// Specular radiance leaving non-diffuse face `face` (unit `normal`) at `p` along the unit
    /// direction `out`, interpolated as the renderer does: the three sphere vertices around
    /// the direction of travel towards `p` (taken in the opposite sense) with their
    /// barycentric weights; per vertex, bilinear over the covered cells around `p` in that
    /// direction's ray grid. Zero for diffuse faces.
    pub fn radiance_towards(&self, face: u32, normal: Vec3, p: Vec3, out: Vec3) -> Vec3 {
        let mf = self.index.face_slot[face as usize];
        if mf == u32::MAX {
            return Vec3::ZERO;
        }
        let l = self.set.len() as u32;
        let n = self.index.n as f32;
        let lk = self.set.lookup(-out);
        let mut sum = Vec3::ZERO;
        for (&v, &w) in lk.vertices.iter().zip(&lk.weights) {
            let j = (v % l) as usize;
            let sense = 1 - v / l;
            let frame = &self.frames[j];
            let dir = if sense == 1 { -frame.w } else { frame.w };
            if dir.dot(normal) * out.dot(normal) <= 0.0 {
                continue;
            }
            let cx = (p.dot(frame.u) + 1.0) * 0.5 * n - 0.5;
            let cy = (p.dot(frame.v) + 1.0) * 0.5 * n - 0.5;
            let (x0, y0) = (cx.floor(), cy.floor());
            let (fx, fy) = (cx - x0, cy - y0);
            let (mut acc, mut wsum) = (Vec3::ZERO, 0.0f32);
            for c in 0..4u32 {
                let (dx, dy) = ((c & 1) as i64, (c >> 1) as i64);
                let wc = if dx == 1 { fx } else { 1.0 - fx } * if dy == 1 { fy } else { 1.0 - fy };
                if wc <= 0.0 {
                    continue;
                }
                if let Some(i) = self.value_index(mf, j, x0 as i64 + dx, y0 as i64 + dy, sense) {
                    acc += Vec4::from(self.values[i]).truncate() * wc;
                    wsum += wc;
                }
            }
            if wsum > 0.0 {
                sum += acc / wsum * w;
            }
        }
        sum
    }
}
