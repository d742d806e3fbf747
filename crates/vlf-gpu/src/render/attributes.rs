//! Per-corner attributes beyond `TEXCOORD_0` in the renderer (`docs/SHADING.md`): shading normals,
//! vertex colours and `TEXCOORD_1`, and the irradiance continuity of smooth faces. Which light
//! fields and faces need them, the corner data uploaded for pass 4b, the window's fused pass and
//! traced hits (`super::upload`), and what the CPU specification of pass 5 reads at a pixel
//! ([`PixelSurface`], [`SurfaceLookup`], [`shading_normal`]).
//!
//! **Irradiance across smooth faces.** The atlas is stored per planar face, each with its own
//! chart, and pass 5's bilinear read stops at the chart's edge: a curved surface tessellated
//! into faces about a texel wide (lamp-room's sphere) reads one value per face, and its facets
//! show however smoothly the gather computed them. On faces with smooth triangles pass 5 adds,
//! per triangle, the linear function of the barycentrics that takes each corner from the
//! face's own atlas value there to the mean of the atlas values of every smooth face meeting at
//! that vertex (same position and shading normal, same side) ([`irradiance_corrections`]): the
//! irradiance is then continuous across the faces' edges wherever they are linear along them (a
//! face of one texel reads exactly the interpolation of its corners' means) and keeps the
//! atlas's detail inside larger faces. Vertices where the shading normals differ (a crease the
//! mesh keeps) are not merged, so creases stay sharp.

use std::collections::HashMap;

use glam::{Vec2, Vec3};
use vlf_core::lightfield::{LightField, NO_TEXTURE, SurfaceMaterial};

/// Per-corner attribute flags of a face ([`attribute_flags`]; bits of the face record's texel
/// 0 w, above the face flags of `super::upload`): some of its triangles have shading normals;
/// some have vertex colours; its material's base-colour texture reads `TEXCOORD_1`; its
/// emissive texture does.
pub const FLAG_SMOOTH: u32 = 0x1000;
pub const FLAG_COLORS: u32 = 0x2000;
pub const FLAG_BASE_UV1: u32 = 0x4000;
pub const FLAG_EMISSIVE_UV1: u32 = 0x8000;

/// `vec4` entries of [`corner_attributes`] per triangle (four per corner).
pub const ATTRIBUTE_ENTRIES: usize = 12;

/// Whether pass 5 needs per-corner attributes for `lf`.
pub fn has_attributes(lf: &LightField) -> bool {
    let sh = &lf.shading;
    sh.normals.is_some()
        || sh.colors.is_some()
        || sh.materials.iter().any(SurfaceMaterial::uses_texcoord1)
}

/// The per-corner attribute flags of every face of `lf` ([`FLAG_SMOOTH`], [`FLAG_COLORS`],
/// [`FLAG_BASE_UV1`], [`FLAG_EMISSIVE_UV1`]).
pub fn attribute_flags(lf: &LightField) -> Vec<u32> {
    let sh = &lf.shading;
    let mut flags: Vec<u32> = lf
        .faces
        .iter()
        .map(|f| {
            let m = &sh.materials[f.material as usize];
            let mut fl = 0;
            if m.base_color_texture != NO_TEXTURE && m.base_color_texcoord == 1 {
                fl |= FLAG_BASE_UV1;
            }
            if m.emissive_texture != NO_TEXTURE && m.emissive_texcoord == 1 {
                fl |= FLAG_EMISSIVE_UV1;
            }
            fl
        })
        .collect();
    for (i, t) in lf.triangles.iter().enumerate() {
        let fl = &mut flags[t.face as usize];
        if sh.normals.as_ref().is_some_and(|n| n[i] != [[0.0; 3]; 3]) {
            *fl |= FLAG_SMOOTH;
        }
        if sh.colors.as_ref().is_some_and(|c| c[i] != [[1.0; 3]; 3]) {
            *fl |= FLAG_COLORS;
        }
    }
    flags
}

/// The per-corner attributes of `lf`'s triangles (`super::upload`'s module docs): `[n.xyz, t.x]`,
/// `[c.rgb, t.y]`, `[e0.rgb, 0]`, `[e1.rgb, 0]` per corner (e: [`irradiance_corrections`] of
/// sides 0 and 1), in triangle order.
pub fn corner_attributes(lf: &LightField) -> Vec<[f32; 4]> {
    let sh = &lf.shading;
    let e = irradiance_corrections(lf, &attribute_flags(lf));
    let mut out = Vec::with_capacity(lf.triangles.len() * ATTRIBUTE_ENTRIES);
    for i in 0..lf.triangles.len() {
        let n = sh.normals.as_ref().map_or([[0.0; 3]; 3], |n| n[i]);
        let c = sh.colors.as_ref().map_or([[1.0; 3]; 3], |c| c[i]);
        let t = sh.uvs1.as_ref().map_or([[0.0; 2]; 3], |t| t[i]);
        for k in 0..3 {
            let [e0, e1] = e[3 * i + k];
            out.push([n[k][0], n[k][1], n[k][2], t[k][0]]);
            out.push([c[k][0], c[k][1], c[k][2], t[k][1]]);
            out.push([e0[0], e0[1], e0[2], 0.0]);
            out.push([e1[0], e1[1], e1[2], 0.0]);
        }
    }
    out
}

/// Per corner of every triangle (index 3 × triangle + corner), per side: what pass 5 adds to
/// the atlas's irradiance there, interpolated over the triangle, on faces with [`FLAG_SMOOTH`]
/// (see the module docs): the mean of the atlas reads at that vertex over the smooth faces that
/// share it (position and shading normal, bit for bit; a flat triangle's corners count with
/// their face's normal) minus the face's own read. Zero on other faces. Sums run in triangle
/// order, so the result is deterministic.
pub fn irradiance_corrections(lf: &LightField, flags: &[u32]) -> Vec<[[f32; 3]; 2]> {
    let sh = &lf.shading;
    let mut out = vec![[[0.0f32; 3]; 2]; 3 * lf.triangles.len()];
    let smooth = |face: u32| flags[face as usize] & FLAG_SMOOTH != 0;
    let key = |i: usize, k: usize| -> [u32; 6] {
        let t = &lf.triangles[i];
        let p = [t.p0, t.p1, t.p2][k];
        let n = sh.normals.as_ref().map_or([0.0; 3], |n| n[i][k]);
        let n = if n == [0.0; 3] {
            lf.faces[t.face as usize].normal
        } else {
            n
        };
        let b = |x: f32| (x + 0.0).to_bits();
        [b(p[0]), b(p[1]), b(p[2]), b(n[0]), b(n[1]), b(n[2])]
    };
    // The atlas read of every smooth corner, per side, and their sums per vertex.
    let mut reads = vec![[Vec3::ZERO; 2]; 3 * lf.triangles.len()];
    let mut sums: HashMap<[u32; 6], ([Vec3; 2], f32)> = HashMap::new();
    for (i, t) in lf.triangles.iter().enumerate() {
        if !smooth(t.face) {
            continue;
        }
        let f = &lf.faces[t.face as usize];
        for (k, p) in [t.p0, t.p1, t.p2].into_iter().enumerate() {
            let p = Vec3::from(p);
            let r = [0, 1]
                .map(|side| super::final_radiance::atlas_irradiance(f, &lf.irradiance, side, p));
            reads[3 * i + k] = r;
            let e = sums.entry(key(i, k)).or_insert(([Vec3::ZERO; 2], 0.0));
            e.0[0] += r[0];
            e.0[1] += r[1];
            e.1 += 1.0;
        }
    }
    for (i, t) in lf.triangles.iter().enumerate() {
        if !smooth(t.face) {
            continue;
        }
        for k in 0..3 {
            let (sum, n) = sums[&key(i, k)];
            let r = reads[3 * i + k];
            out[3 * i + k] = [0, 1].map(|side| (sum[side] / n - r[side]).to_array());
        }
    }
    out
}

/// What pass 5 interpolates at a pixel besides its position: `TEXCOORD_0` and `TEXCOORD_1`,
/// the vertex colour, the shading normal (zero on flat triangles) and the irradiance correction
/// of the visible side ([`irradiance_corrections`]). Read from pass 4's uv target and pass 4b's
/// attribute targets ([`PixelSurface::from_targets`]: the normal's direction as octahedral
/// coordinates, the colour rounded to 10 bits per channel there: 5e-4 at most), or interpolated
/// at a traced hit
/// ([`PixelSurface::of_triangle`]: the normal interpolated, not renormalised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSurface {
    pub uv: Vec2,
    pub uv1: Vec2,
    pub color: Vec3,
    pub normal: Vec3,
    pub irradiance: Vec3,
}

/// The octahedral coordinates of `n`'s direction, as `oct_encode` of
/// `shaders/common/surface_attributes.wgsl` (in [−1, 1]²; [`FLAT_NORMAL`] twice for zero).
pub fn oct_encode(n: Vec3) -> Vec2 {
    let s = n.x.abs() + n.y.abs() + n.z.abs();
    if s.is_nan() || s <= 0.0 {
        return Vec2::splat(FLAT_NORMAL);
    }
    let p = Vec2::new(n.x, n.y) / s;
    if n.z >= 0.0 {
        return p;
    }
    let sign = Vec2::new(
        if p.x >= 0.0 { 1.0 } else { -1.0 },
        if p.y >= 0.0 { 1.0 } else { -1.0 },
    );
    (Vec2::ONE - Vec2::new(p.y, p.x).abs()) * sign
}

/// The unit direction of octahedral coordinates `o` (zero for [`FLAT_NORMAL`]), as `oct_decode`
/// of the shader.
pub fn oct_decode(o: Vec2) -> Vec3 {
    if o.x > 2.0 {
        return Vec3::ZERO;
    }
    let mut n = Vec3::new(o.x, o.y, 1.0 - o.x.abs() - o.y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

/// The octahedral coordinates pass 4b stores for a flat triangle's zero normal.
pub const FLAT_NORMAL: f32 = 4.0;

/// A colour in [0, 1] as pass 4b stores it: three 10-bit unorm values, r in the low bits,
/// rounded half to even (`pack_colour` of the shader).
pub fn pack_colour(c: Vec3) -> u32 {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 1023.0).round_ties_even() as u32;
    q(c.x) | (q(c.y) << 10) | (q(c.z) << 20)
}

/// The colour of [`pack_colour`]'s word (`unpack_colour` of the shader).
pub fn unpack_colour(w: u32) -> Vec3 {
    Vec3::new(
        (w & 1023) as f32,
        ((w >> 10) & 1023) as f32,
        ((w >> 20) & 1023) as f32,
    ) / 1023.0
}

impl PixelSurface {
    /// A point with `TEXCOORD_0` `uv` and no other attribute (what a light field without them
    /// shades with).
    pub fn plain(uv: Vec2) -> Self {
        PixelSurface {
            uv,
            uv1: Vec2::ZERO,
            color: Vec3::ONE,
            normal: Vec3::ZERO,
            irradiance: Vec3::ZERO,
        }
    }

    /// From pass 4's uv and pass 4b's two attribute texels (`pack_surface` of
    /// `shaders/common/surface_attributes.wgsl`: `[octahedral normal, TEXCOORD_1]` as f32,
    /// `[colour as 10-bit unorm (`pack_colour`), the correction's bits]`); `None`: no attributes.
    pub fn from_targets(uv: [f32; 2], a: Option<[f32; 4]>, w: Option<[u32; 4]>) -> Self {
        let mut s = PixelSurface::plain(Vec2::from(uv));
        if let (Some(a), Some(w)) = (a, w) {
            s.normal = oct_decode(Vec2::new(a[0], a[1]));
            s.uv1 = Vec2::new(a[2], a[3]);
            s.color = unpack_colour(w[0]);
            s.irradiance = Vec3::new(
                f32::from_bits(w[1]),
                f32::from_bits(w[2]),
                f32::from_bits(w[3]),
            );
        }
        s
    }

    /// At barycentrics `(b1, b2)` of triangle `tri` of `lf`, seen from `side`, as pass 5
    /// interpolates a traced hit (`chain_surface`): `attrs` is [`corner_attributes`]`(lf)`
    /// (empty without).
    pub fn of_triangle(
        lf: &LightField,
        attrs: &[[f32; 4]],
        tri: usize,
        b1: f32,
        b2: f32,
        side: u32,
    ) -> Self {
        let b0 = 1.0 - b1 - b2;
        let uv = lf.shading.uvs[tri].map(Vec2::from);
        let mut s = PixelSurface::plain(uv[0] * b0 + uv[1] * b1 + uv[2] * b2);
        if !attrs.is_empty() {
            let k = ATTRIBUTE_ENTRIES * tri;
            let at = |j: usize| glam::Vec4::from(attrs[k + j]);
            let a = at(0) * b0 + at(4) * b1 + at(8) * b2;
            let b = at(1) * b0 + at(5) * b1 + at(9) * b2;
            let e = side as usize + 2;
            let e = at(e) * b0 + at(e + 4) * b1 + at(e + 8) * b2;
            s.normal = a.truncate();
            s.uv1 = Vec2::new(a.w, b.w);
            s.color = b.truncate();
            s.irradiance = e.truncate();
        }
        s
    }

    /// The texture coordinates of set 1 when `set1`, else set 0.
    pub fn tex_uv(&self, set1: bool) -> Vec2 {
        if set1 { self.uv1 } else { self.uv }
    }
}

/// What the CPU mirrors of pass 5 read besides the light field: its texture offsets
/// (`Shading::texture_offsets`), its faces' attribute flags
/// ([`attribute_flags`]) and its per-corner attributes
/// ([`corner_attributes`], empty without).
pub struct SurfaceLookup {
    pub offsets: Vec<u64>,
    pub flags: Vec<u32>,
    pub attributes: Vec<[f32; 4]>,
}

impl SurfaceLookup {
    pub fn new(lf: &LightField) -> Self {
        SurfaceLookup {
            offsets: lf.shading.texture_offsets(),
            flags: attribute_flags(lf),
            attributes: if has_attributes(lf) {
                corner_attributes(lf)
            } else {
                Vec::new()
            },
        }
    }
}

/// The unit shading normal pass 5 reflects about at a point of face `face` with attributes `s`,
/// turned to `side` (the unit geometric normal of the side the ray comes from), and whether it
/// is the point's own (`shading_normal` of the shader): the face's normal on faces without
/// [`FLAG_SMOOTH`] and on their flat triangles (zero interpolated normal).
pub fn shading_normal(
    lookup: &SurfaceLookup,
    face: u32,
    s: &PixelSurface,
    side: Vec3,
) -> (Vec3, bool) {
    if lookup.flags[face as usize] & FLAG_SMOOTH == 0 || s.normal.dot(s.normal) <= 0.0 {
        return (side, false);
    }
    let m = s.normal.normalize();
    (if m.dot(side) < 0.0 { -m } else { m }, true)
}
