//! The converged light field as a gather ray reads it at its first hit: the propagation's
//! irradiance atlas (times the hit point's own albedo, texture and vertex colour included) for
//! the diffuse part,
//! and the sparse mirror tiles in the ray's direction for the specular part — the same lookups
//! the renderer's pass 5 does ([`Tiles::radiance_towards`] is its CPU form) — except that the
//! atlas' bilinear filter never reaches across a contact ([`Contacts`]).

use glam::{Vec2, Vec3, Vec4};

use crate::bake::BakeScene;
use crate::directions::DirectionSet;
use crate::lightfield::{AlphaMasks, BakeFace, TileIndex};
use crate::pathtrace::geometry::offset_ray_origin;
use crate::pathtrace::{Bvh, Hit, PreparedScene, Ray};
use crate::psf::PsfFrame;
use crate::scene::{Scene, Similarity};

/// A converged light field as seen from a traced ray: an atlas of irradiance per texel side and,
/// for non-diffuse faces, their directional tiles. Radiance leaving a surface point towards a
/// ray's origin is the emission (front side) + the diffuse albedo (texture at the point's own
/// uv) / π × the atlas irradiance (bilinear within the point's side of any contact) + the
/// face's specular tiles in that direction.
pub struct Field<'a> {
    pub scene: &'a Scene,
    /// The atlas' charts.
    pub atlas: &'a BakeScene,
    /// Irradiance per texel of `atlas`, dilated so bilinear reads at polygon borders see
    /// covered texels.
    pub irradiance: Vec<[f32; 4]>,
    pub tiles: Option<Tiles<'a>>,
    /// Irradiance a read adds to the atlas': the final gather's direct light on its own atlas
    /// (dilated), when the atlas holds the light after the first bounce only.
    pub direct: Option<(&'a BakeScene, Vec<[f32; 4]>)>,
    /// Where the atlas' bilinear quads straddle a contact, and the BVH that tells which of their
    /// texels a point sees.
    pub contacts: Contacts<'a>,
}

/// Where a ray landed: the hit point in VLF and world coordinates, its face, texture coordinates
/// (sets 0 and 1), vertex colour and whether the ray arrived at the face's front.
pub struct SurfaceHit {
    pub face: u32,
    pub material: u32,
    pub world: Vec3,
    pub vlf: Vec3,
    /// `TEXCOORD_0` and `TEXCOORD_1` at the hit.
    pub uv: [Vec2; 2],
    /// The vertex colour at the hit (1 without).
    pub color: Vec3,
    /// The side the ray arrived at (0 = front).
    pub side: u32,
}

impl SurfaceHit {
    /// The texture coordinates a texture slot reading set `texcoord` uses.
    pub fn uv_of(&self, tex: crate::scene::TexRef) -> Vec2 {
        self.uv[tex.texcoord.min(1) as usize]
    }
}

impl<'a> Field<'a> {
    /// A field over `atlas` with undilated `irradiance` (dilated here) of the scene of `ps`,
    /// read bilinearly everywhere as the renderer reads it.
    pub fn new(
        ps: &'a PreparedScene<'a>,
        atlas: &'a BakeScene,
        irradiance: &[[f32; 4]],
        tiles: Option<Tiles<'a>>,
    ) -> Self {
        let mut irradiance = irradiance.to_vec();
        crate::bake::dilate(atlas, &mut irradiance);
        Self {
            scene: ps.scene,
            atlas,
            irradiance,
            tiles,
            direct: None,
            contacts: Contacts::none(&ps.bvh, ps.scene, atlas),
        }
    }

    /// The field with reads that stop at contacts ([`Field::irradiance_at`]): for a propagated
    /// atlas, whose texels at a contact hold light from both sides. Contacts are found on
    /// `threads` workers (0 = all cores).
    pub fn with_contacts(mut self, ps: &'a PreparedScene<'a>, threads: usize) -> Self {
        self.contacts = Contacts::new(&ps.bvh, ps.scene, self.atlas, threads);
        self
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
            uv: [uv, st.uv_at(1, b1, b2)],
            color: st.color_at(b1, b2),
            side: if f.normal().dot(-dir) >= 0.0 { 0 } else { 1 },
        }
    }

    /// Diffuse (Lambertian) radiance leaving `s` on the side its ray arrived at: albedo at its
    /// uv (× its vertex colour) / π × the atlas' irradiance there.
    pub fn diffuse(&self, s: &SurfaceHit) -> Vec3 {
        let m = &self.scene.materials[s.material as usize];
        // The diffuse albedo the bake used (a rough metal folded into it included).
        let mut rho = self.atlas.materials[s.material as usize].diffuse;
        if rho == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if let Some(t) = m.base_color_texture {
            rho *= self.scene.textures[t.index as usize]
                .bilinear(s.uv_of(t))
                .truncate();
        }
        rho *= s.color;
        let mut e = self.irradiance_at(s);
        if let Some((atlas, direct)) = &self.direct {
            e += chart_bilinear(&atlas.faces[s.face as usize], direct, s.side, s.vlf);
        }
        rho * std::f32::consts::FRAC_1_PI * e
    }

    /// The atlas' irradiance at `s`: bilinear over the four texels around it as the renderer
    /// reads it, except near a contact (a wall standing on the face, a box's bottom lying on
    /// it: [`Contacts`]). There the quad's texels that are not cut and whose centres `s` sees
    /// count (weights renormalised); when there are none, such texels within two texels of `s`
    /// (tent weights); then the quad's texels that `s` sees, cut or not; the texel under `s`
    /// when it sees none.
    /// A floor point inside a box standing on the floor so reads neither the lit floor outside
    /// nor the texels at the box's foot (which hold light from both sides), and a floor point
    /// outside not the dark ones.
    pub fn irradiance_at(&self, s: &SurfaceHit) -> Vec3 {
        self.irradiance_on(s.face, s.side, s.vlf, s.world)
    }

    /// Whether a read of `face`'s `side` at VLF point `vlf` is plain bilinear (no contact
    /// near it).
    pub fn clear_at(&self, face: u32, side: u32, vlf: Vec3) -> bool {
        let q = Quad::at(&self.atlas.faces[face as usize], side, vlf);
        self.contacts.quad_is_clear(&q)
    }

    /// [`Field::irradiance_at`] at a point of `face`'s `side` given in VLF (`vlf`) and world
    /// (`world`) coordinates.
    pub fn irradiance_on(&self, face: u32, side: u32, vlf: Vec3, world: Vec3) -> Vec3 {
        let f = &self.atlas.faces[face as usize];
        let q = Quad::at(f, side, vlf);
        let at = |t: u32| Vec4::from(self.irradiance[t as usize]).truncate();
        if self.contacts.quad_is_clear(&q) {
            return q.bilinear(&self.irradiance);
        }
        let n = if side == 0 { f.normal() } else { -f.normal() };
        let from = self.contacts.lift(f, world, n);
        let sees = |t: u32| self.contacts.sees(from, self.contacts.centre(f, t, n));
        // The quad's texels that `s` sees: per class (uncut, cut), Σ w·E and Σ w.
        let mut quad = [(Vec3::ZERO, 0.0f32); 2];
        for (c, &t) in q.texel.iter().enumerate() {
            let w = q.weight(c);
            if w > 0.0 && sees(t) {
                let sum = &mut quad[usize::from(self.contacts.cut(t))];
                sum.0 += at(t) * w;
                sum.1 += w;
            }
        }
        if quad[0].1 > 0.0 {
            return quad[0].0 / quad[0].1;
        }
        // Uncut texels it sees within two texels (tent weights).
        let c = chart_coords(f, vlf);
        let base = f.texel_base + side * f.width * f.height;
        let (ci, cj) = (c.x.floor() as i64, c.y.floor() as i64);
        let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
        for j in (cj - 2).max(0)..=(cj + 2).min(i64::from(f.height) - 1) {
            for i in (ci - 2).max(0)..=(ci + 2).min(i64::from(f.width) - 1) {
                let d = (Vec2::new(i as f32 + 0.5, j as f32 + 0.5) - c).abs();
                let w = (1.0 - d.x * 0.5).max(0.0) * (1.0 - d.y * 0.5).max(0.0);
                let t = base + j as u32 * f.width + i as u32;
                if w > 0.0 && !self.contacts.cut(t) && sees(t) {
                    sum += at(t) * w;
                    wsum += w;
                }
            }
        }
        if wsum > 0.0 {
            sum / wsum
        } else if quad[1].1 > 0.0 {
            quad[1].0 / quad[1].1
        } else {
            at(q.texel[q.nearest()])
        }
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
                        .bilinear(s.uv_of(t))
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

/// The four texels a bilinear read of face `f`'s `side` at plane point `p` blends (indices
/// clamped to the chart, so never across faces or sides), in the order (i0, j0), (i1, j0),
/// (i0, j1), (i1, j1), and the weights' fractions.
pub struct Quad {
    pub texel: [u32; 4],
    pub fx: f32,
    pub fy: f32,
    /// Whether the quad spans two columns (i1 > i0) and two rows (j1 > j0).
    pub wide: bool,
    pub tall: bool,
}

impl Quad {
    pub fn at(f: &BakeFace, side: u32, p: Vec3) -> Self {
        let c = chart_coords(f, p) - Vec2::splat(0.5);
        let (x0, y0) = (c.x.floor(), c.y.floor());
        let ci = |i: f32| (i as i32).clamp(0, f.width as i32 - 1) as u32;
        let cj = |j: f32| (j as i32).clamp(0, f.height as i32 - 1) as u32;
        let base = f.texel_base + side * f.width * f.height;
        let (i0, i1, j0, j1) = (ci(x0), ci(x0 + 1.0), cj(y0), cj(y0 + 1.0));
        let t = |i: u32, j: u32| base + j * f.width + i;
        Self {
            texel: [t(i0, j0), t(i1, j0), t(i0, j1), t(i1, j1)],
            fx: c.x - x0,
            fy: c.y - y0,
            wide: i1 > i0,
            tall: j1 > j0,
        }
    }

    /// The bilinear blend of `values` (per texel of the atlas).
    pub fn bilinear(&self, values: &[[f32; 4]]) -> Vec3 {
        let at = |c: usize| Vec4::from(values[self.texel[c] as usize]).truncate();
        let top = at(0).lerp(at(1), self.fx);
        let bottom = at(2).lerp(at(3), self.fx);
        top.lerp(bottom, self.fy)
    }

    /// Bilinear weight of corner `c`.
    pub fn weight(&self, c: usize) -> f32 {
        let wx = if c & 1 == 1 { self.fx } else { 1.0 - self.fx };
        let wy = if c & 2 == 2 { self.fy } else { 1.0 - self.fy };
        wx * wy
    }

    /// The corner whose texel holds the read point.
    pub fn nearest(&self) -> usize {
        usize::from(self.fx >= 0.5) | (usize::from(self.fy >= 0.5) << 1)
    }
}

/// Where an atlas' texels meet a contact (a wall standing on their face, a solid lying on it).
/// Per texel side, four bits say whether its centre and the centres of its neighbours at
/// (+1, 0), (0, +1), (+1, +1) see each other, and whether (+1, 0) sees (0, +1); a fifth that
/// the texel is *cut*: its covered centroid does not see one of the four points inset a tenth
/// of a texel from its corners that lie on its face, or one of its 8 neighbours' centres (a
/// texel next to a contact holds light the contact's other side sent it through the
/// propagation's rays that cross it there). Every segment is lifted a thousandth of a
/// texel off the side. A bilinear quad whose six segments are clear and none of whose texels
/// is cut is read as it is, so a face with nothing standing on it reads exactly as before.
pub struct Contacts<'a> {
    bvh: &'a Bvh,
    xf: Similarity,
    /// Bits per texel: [`CONTACT_RIGHT`], [`CONTACT_UP`], [`CONTACT_DIAGONAL`],
    /// [`CONTACT_ANTI_DIAGONAL`], [`CONTACT_CUT`].
    bits: Vec<u8>,
}

/// [`Contacts`]' bits of a texel (mirrored in `shaders/common/gather_field.wgsl`): its
/// centre sees its right neighbour's, its upper neighbour's, its (+1, +1) neighbour's; its
/// (+1, 0) neighbour sees its (0, +1) neighbour; it is cut.
pub const CONTACT_RIGHT: u8 = 1;
pub const CONTACT_UP: u8 = 2;
pub const CONTACT_DIAGONAL: u8 = 4;
pub const CONTACT_ANTI_DIAGONAL: u8 = 8;
pub const CONTACT_CUT: u8 = 16;
/// How far segments between texel points are lifted off their side (texels; mirrored in
/// `shaders/common/gather_field.wgsl`).
pub const CONTACT_LIFT: f32 = 1e-3;

impl<'a> Contacts<'a> {
    /// No contacts: every quad reads bilinearly.
    fn none(bvh: &'a Bvh, scene: &Scene, atlas: &BakeScene) -> Self {
        let all = CONTACT_RIGHT | CONTACT_UP | CONTACT_DIAGONAL | CONTACT_ANTI_DIAGONAL;
        Self {
            bvh,
            xf: scene.to_vlf,
            bits: vec![all; atlas.texel_count()],
        }
    }

    /// The contacts of `atlas` (the charts of `scene`, whose BVH is `bvh`), found on `threads`
    /// workers (0 = all cores).
    pub fn new(bvh: &'a Bvh, scene: &Scene, atlas: &BakeScene, threads: usize) -> Self {
        let mut c = Self {
            bvh,
            xf: scene.to_vlf,
            bits: Vec::new(),
        };
        let faces = crate::bake::reference::texel_faces(atlas);
        let charts = Charts::new(scene, atlas);
        let c_ref = &c;
        let bits = crate::par::map(atlas.texel_count(), threads, 256, |t| {
            let c = c_ref;
            let fi = faces[t] as usize;
            let f = &atlas.faces[fi];
            let local = t as u32 - f.texel_base;
            let side = local / f.texels_per_side();
            let i = local % f.texels_per_side();
            let (x, y) = (i % f.width, i / f.width);
            let n = if side == 0 { f.normal() } else { -f.normal() };
            // Segments between centres off the face (beyond a room's edge, say) count as clear.
            let on_face = |dx: u32, dy: u32| {
                charts.inside(fi, Vec2::new((x + dx) as f32 + 0.5, (y + dy) as f32 + 0.5))
            };
            let p = |dx: u32, dy: u32| c.centre(f, t as u32 + dy * f.width + dx, n);
            let clear = |a: (u32, u32), b: (u32, u32)| {
                !on_face(a.0, a.1) || !on_face(b.0, b.1) || c.sees(p(a.0, a.1), p(b.0, b.1))
            };
            let (wide, tall) = (x + 1 < f.width, y + 1 < f.height);
            let mut bits = 0;
            if !wide || clear((0, 0), (1, 0)) {
                bits |= CONTACT_RIGHT;
            }
            if !tall || clear((0, 0), (0, 1)) {
                bits |= CONTACT_UP;
            }
            if !(wide && tall) || clear((0, 0), (1, 1)) {
                bits |= CONTACT_DIAGONAL;
            }
            if !(wide && tall) || clear((1, 0), (0, 1)) {
                bits |= CONTACT_ANTI_DIAGONAL;
            }
            if atlas.texel_area[t] > 0.0 {
                let centroid = c.xf.inverse(Vec4::from(atlas.texel_center[t]).truncate());
                let from = c.lift(f, centroid, n);
                let corner = Vec2::new(x as f32, y as f32);
                let corners = [(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)]
                    .into_iter()
                    .map(|(a, b)| corner + Vec2::new(a, b))
                    .filter(|&q| charts.inside(fi, q));
                let neighbours = (0..9)
                    .map(|k| corner + Vec2::new((k % 3) as f32 - 0.5, (k / 3) as f32 - 0.5))
                    .filter(|&q| q != corner + Vec2::splat(0.5) && charts.inside(fi, q));
                let cut = corners
                    .chain(neighbours)
                    .any(|q| !c.sees(from, c.lift(f, c.chart_world(f, q), n)));
                if cut {
                    bits |= CONTACT_CUT;
                }
            }
            bits
        });
        c.bits = bits;
        c
    }

    /// The bits of every texel of the atlas, in texel order: [`CONTACT_RIGHT`], [`CONTACT_UP`],
    /// [`CONTACT_DIAGONAL`], [`CONTACT_ANTI_DIAGONAL`], [`CONTACT_CUT`] (what the GPU gather
    /// uploads).
    pub fn bits(&self) -> &[u8] {
        &self.bits
    }

    /// Whether the six segments between `q`'s texel centres are all clear and none of its
    /// texels is cut.
    fn quad_is_clear(&self, q: &Quad) -> bool {
        let b = |c: usize| self.bits[q.texel[c] as usize];
        if (b(0) | b(1) | b(2) | b(3)) & CONTACT_CUT != 0 {
            return false;
        }
        let mut ok = true;
        if q.wide {
            ok &= b(0) & b(2) & CONTACT_RIGHT != 0;
        }
        if q.tall {
            ok &= b(0) & b(1) & CONTACT_UP != 0;
        }
        if q.wide && q.tall {
            ok &= b(0) & (CONTACT_DIAGONAL | CONTACT_ANTI_DIAGONAL)
                == CONTACT_DIAGONAL | CONTACT_ANTI_DIAGONAL;
        }
        ok
    }

    /// Whether texel `t` is cut by a contact.
    fn cut(&self, t: u32) -> bool {
        self.bits[t as usize] & CONTACT_CUT != 0
    }

    /// World point `p` of face `f` lifted off the side with unit normal `n`.
    fn lift(&self, f: &BakeFace, p: Vec3, n: Vec3) -> Vec3 {
        offset_ray_origin(p + n * (CONTACT_LIFT * f.texel_size / self.xf.scale), n)
    }

    /// World point of face `f`'s plane at chart coordinates `c` (texel units).
    fn chart_world(&self, f: &BakeFace, c: Vec2) -> Vec3 {
        let c = c * f.texel_size;
        self.xf
            .inverse(Vec3::from(f.origin) + Vec3::from(f.u) * c.x + Vec3::from(f.v) * c.y)
    }

    /// The lifted world centre of the square of texel `t` (index into the atlas) of face `f`.
    fn centre(&self, f: &BakeFace, t: u32, n: Vec3) -> Vec3 {
        let i = (t - f.texel_base) % f.texels_per_side();
        let c = Vec2::new((i % f.width) as f32 + 0.5, (i / f.width) as f32 + 0.5);
        self.lift(f, self.chart_world(f, c), n)
    }

    /// Whether nothing lies between world points `a` and `b`.
    fn sees(&self, a: Vec3, b: Vec3) -> bool {
        a == b || !self.bvh.occluded(&Ray::new(a, b - a, 1.0))
    }
}

/// Chart-space triangles (texel units) of every face of an atlas, to tell whether a chart
/// point lies on its face, and their shading normals, to tell the shading normal there.
pub struct Charts {
    tris: Vec<Vec<[Vec2; 3]>>,
    /// Index of each face's first triangle in the scene (its triangles follow it).
    first: Vec<u32>,
    /// The triangles' alpha masks (by scene index): a point where they leave no surface is
    /// not on the face.
    masks: AlphaMasks,
    /// The shading normals of each face's triangles (`None`: flat).
    normals: Vec<Vec<Option<[Vec3; 3]>>>,
}

impl Charts {
    pub fn new(scene: &Scene, atlas: &BakeScene) -> Self {
        let xf = scene.to_vlf;
        let first = scene.faces.iter().map(|f| f.triangles.start).collect();
        let tris = atlas
            .faces
            .iter()
            .enumerate()
            .map(|(fi, f)| {
                scene
                    .face_triangles(fi)
                    .iter()
                    .map(|t| t.p.map(|p| chart_coords(f, xf.apply(p))))
                    .collect()
            })
            .collect();
        let normals = (0..atlas.faces.len())
            .map(|fi| scene.face_triangles(fi).iter().map(|t| t.normals).collect())
            .collect();
        Self {
            tris,
            first,
            masks: atlas.masks.clone(),
            normals,
        }
    }

    /// The scene index of the first triangle of `face` (the GPU gather tags each chart
    /// triangle with its own).
    pub fn first_triangle(&self, face: usize) -> u32 {
        self.first[face]
    }

    /// The chart-space triangles of `face` (what the GPU gather uploads).
    pub fn triangles(&self, face: usize) -> &[[Vec2; 3]] {
        &self.tris[face]
    }

    /// The shading normals of `face`'s triangles, in the order of [`Charts::triangles`].
    pub fn normals(&self, face: usize) -> &[Option<[Vec3; 3]>] {
        &self.normals[face]
    }

    /// The first of `face`'s triangles holding chart point `c` (texel units), `None` when none
    /// does or when its alpha mask (if any) leaves no surface there (the first triangle that
    /// holds it decides).
    pub fn locate(&self, face: usize, c: Vec2) -> Option<usize> {
        for (k, q) in self.tris[face].iter().enumerate() {
            let e = |a: Vec2, b: Vec2| (b - a).perp_dot(c - a);
            let (d0, d1, d2) = (e(q[0], q[1]), e(q[1], q[2]), e(q[2], q[0]));
            if (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0) {
                let sum = d0 + d1 + d2;
                if self.masks.is_empty() || sum == 0.0 {
                    return Some(k);
                }
                // d1, d2, d0 are twice the areas opposite corners 0, 1, 2.
                let tri = self.first[face] + k as u32;
                return (!self.masks.cuts(tri, [d1 / sum, d2 / sum, d0 / sum])).then_some(k);
            }
        }
        None
    }

    /// Whether chart point `c` (texel units) of `face` lies on one of its triangles.
    pub fn inside(&self, face: usize, c: Vec2) -> bool {
        self.locate(face, c).is_some()
    }

    /// The unit shading normal at chart point `c` of triangle `tri` of `face`, on the side
    /// whose unit geometric normal is `n`: its corner normals interpolated with the chart
    /// barycentrics of `c` and renormalised (turned to `n`'s side). `n` itself where the
    /// triangle is flat. As `point_normal` of `shaders/gather_texels.wgsl`.
    pub fn shading_normal(&self, face: usize, tri: usize, c: Vec2, n: Vec3) -> Vec3 {
        let Some(ns) = self.normals[face][tri] else {
            return n;
        };
        let q = &self.tris[face][tri];
        let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
        let det = e1.perp_dot(e2);
        let d = c - q[0];
        let (b1, b2) = if det != 0.0 {
            (d.perp_dot(e2) / det, e1.perp_dot(d) / det)
        } else {
            (0.0, 0.0)
        };
        let m = (ns[0] * (1.0 - b1 - b2) + ns[1] * b1 + ns[2] * b2).normalize_or_zero();
        if m == Vec3::ZERO {
            n
        } else if m.dot(n) < 0.0 {
            -m
        } else {
            m
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
    Quad::at(f, side, p).bilinear(values)
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
