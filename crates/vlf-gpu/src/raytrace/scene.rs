//! The scene as the GPU ray engine and path tracer see it: the CPU tracer's BVH nodes and
//! leaf-order triangles uploaded unchanged, plus one `array<vec4<f32>>` "blob" holding everything
//! shading needs (so a shading kernel binds few storage buffers):
//!
//! | section | entries (vec4 each) |
//! |---|---|
//! | shading, at 0 | per triangle: `[uv0, uv1]`, `[uv2, face, attributes]` (corner `TEXCOORD_0`s; `attributes`: the triangle's entry in the attribute section, [`NONE`] without one) |
//! | materials, at `mat_base` | per material: `[base rgb, base texture]`, `[emission rgb, emissive texture]`, `[w_diffuse, α, bake diffuse weight, texcoords]`, `[w_pane, ior, openness, 0]` (`texcoords`: bit 0 the base-colour texture reads `TEXCOORD_1`, bit 1 the emissive one; `openness`: [`MAT_PANE`], [`MAT_SEE_THROUGH`], what the final gather's openness probes pass) |
//! | attributes, at `attr_base` | per triangle with shading normals, vertex colours or `TEXCOORD_1` ([`ATTRIBUTE_ENTRIES`] each): `[n0, flags]`, `[n1, 0]`, `[n2, 0]`, `[c0, 0]`, `[c1, 0]`, `[c2, 0]`, `[t0, t1]`, `[t2, 0, 0]` (flags: [`ATTR_SMOOTH`], [`ATTR_COLORS`]; the normals are unit, the colours white without vertex colours, the t the corner `TEXCOORD_1`s, 0 without) |
//! | emitters, at `emitter_base` | per emitter: `[triangle, area, pdf, cdf]` |
//! | delta lights, at `delta_base` | per light (suns, then point and spot lights, `vlf_core::pathtrace::lights::DeltaLight`): `[position (sun: direction towards it) xyz, kind]`, `[intensity (sun: irradiance) rgb, pdf]`, `[spot axis xyz, cdf]`, `[cone scale, cone offset, 1/range, 0]` |
//! | textures, at `tex_base` | per texture: `[texel offset, width, height, wrap_s | wrap_t << 4]`, then all texels (linear RGBA) |
//!
//! Integers (indices, sizes, [`NONE`]) are stored as their bit patterns. The path tracer reads
//! the path tracer's lobes (`w_diffuse`, α); the final gather reads what the light field holds at
//! a ray's hit: the triangle's planar face and the baker's diffuse weight
//! (`vlf_core::bake::glossy::BakedMaterial::diffuse_weight`: a rough metal folded into the
//! diffuse part included, as the CPU gather reads it; it does not depend on the direction set). The section offsets reach the shaders as an
//! [`RtSceneInfo`] uniform ([`PackedScene::info`]).

use crate::layout::RtSceneInfo;
use vlf_core::pathtrace::{NONE, PreparedScene};

/// Entries (vec4) per triangle of the attribute section.
pub const ATTRIBUTE_ENTRIES: u32 = 8;
/// Entries (vec4) per material.
pub const MATERIAL_ENTRIES: u32 = 4;
/// Material openness flags (`vlf_core::gather::Openness`): a thin glass pane
/// (`Material::pane_weight` > 0), and a surface light crosses (thin diffuse transmission), neither
/// of which closes a solid for the final gather's openness probes.
pub const MAT_PANE: u32 = 1;
pub const MAT_SEE_THROUGH: u32 = 2;
/// Attribute flags: the triangle has shading normals; it has vertex colours.
pub const ATTR_SMOOTH: u32 = 1;
pub const ATTR_COLORS: u32 = 2;

/// The packed shading data and where each section starts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedScene {
    pub blob: Vec<[f32; 4]>,
    pub mat_base: u32,
    pub emitter_base: u32,
    pub emitter_count: u32,
    pub delta_base: u32,
    pub delta_count: u32,
    pub tex_base: u32,
    /// Probability of sampling an emitter rather than a delta light.
    pub p_emitters: f32,
    /// Where the attribute section starts.
    pub attr_base: u32,
    /// Whether a material is (in part) a thin glass pane.
    pub has_panes: bool,
}

fn bits(x: u32) -> f32 {
    f32::from_bits(x)
}

impl PackedScene {
    /// The section offsets and light counts as the shaders bind them.
    pub fn info(&self) -> RtSceneInfo {
        RtSceneInfo {
            mat_base: self.mat_base,
            emitter_base: self.emitter_base,
            emitter_count: self.emitter_count,
            delta_base: self.delta_base,
            delta_count: self.delta_count,
            tex_base: self.tex_base,
            p_emitters: self.p_emitters,
            attr_base: self.attr_base,
            has_panes: u32::from(self.has_panes),
            ..Default::default()
        }
    }
}

/// The openness flags of material `m` of `scene`, as `vlf_core::gather::Grid::points` builds
/// its `Openness`.
fn openness(scene: &vlf_core::scene::Scene, m: u32) -> u32 {
    let pane = scene
        .materials
        .get(m as usize)
        .is_some_and(|m| m.pane_weight() > 0.0);
    let see_through = matches!(
        scene.translucency_of(m),
        vlf_core::scene::Translucency::ThinDiffuseTransmission { .. }
    );
    let pane = if pane { MAT_PANE } else { 0 };
    pane | if see_through { MAT_SEE_THROUGH } else { 0 }
}

/// Which triangles of `prep` (in leaf order) get an entry in the attribute section: those
/// with shading normals, vertex colours, or a `TEXCOORD_1` where a material reads that set.
fn has_attributes(prep: &PreparedScene) -> impl Iterator<Item = bool> {
    let uv1 = prep.materials.iter().any(|m| {
        (m.base_texture.is_some() && m.base_texcoord == 1)
            || (m.emissive_texture.is_some() && m.emissive_texcoord == 1)
    });
    prep.bvh.triangles.iter().map(move |t| {
        let st = &prep.scene.triangles[t.prim as usize];
        st.normals.is_some() || st.colors.is_some() || (uv1 && st.uv1.is_some())
    })
}

/// Triangles of `prep` with an entry in the attribute section ([`ATTRIBUTE_ENTRIES`] each).
pub fn attributed_triangles(prep: &PreparedScene) -> usize {
    has_attributes(prep).filter(|&a| a).count()
}

/// Packs the shading data of `prep` (see the module docs for the layout).
pub fn pack(prep: &PreparedScene) -> PackedScene {
    let mut blob: Vec<[f32; 4]> = Vec::new();
    let mut attributes: Vec<[f32; 4]> = Vec::new();
    for ((uv, t), extra) in prep
        .uvs
        .iter()
        .zip(&prep.bvh.triangles)
        .zip(has_attributes(prep))
    {
        let st = &prep.scene.triangles[t.prim as usize];
        let attr = if extra {
            let k = attributes.len() as u32 / ATTRIBUTE_ENTRIES;
            let flags = if st.normals.is_some() { ATTR_SMOOTH } else { 0 }
                | if st.colors.is_some() { ATTR_COLORS } else { 0 };
            let n = st.normals.unwrap_or([glam::Vec3::ZERO; 3]);
            let c = st.colors.unwrap_or([glam::Vec3::ONE; 3]);
            let t1 = st.uv_set(1);
            attributes.push([n[0].x, n[0].y, n[0].z, bits(flags)]);
            attributes.push([n[1].x, n[1].y, n[1].z, 0.0]);
            attributes.push([n[2].x, n[2].y, n[2].z, 0.0]);
            for c in c {
                attributes.push([c.x, c.y, c.z, 0.0]);
            }
            attributes.push([t1[0].x, t1[0].y, t1[1].x, t1[1].y]);
            attributes.push([t1[2].x, t1[2].y, 0.0, 0.0]);
            k
        } else {
            NONE
        };
        blob.push([uv[0].x, uv[0].y, uv[1].x, uv[1].y]);
        blob.push([uv[2].x, uv[2].y, bits(st.face), bits(attr)]);
    }
    let mat_base = blob.len() as u32;
    let baked = vlf_core::bake::glossy::baked_materials(&prep.scene.materials, None);
    for (i, (m, bm)) in prep.materials.iter().zip(&baked).enumerate() {
        let b = m.base_color;
        let e = m.emission;
        let sets = m.base_texcoord.min(1) | (m.emissive_texcoord.min(1) << 1);
        blob.push([b.x, b.y, b.z, bits(m.base_texture.unwrap_or(NONE))]);
        blob.push([e.x, e.y, e.z, bits(m.emissive_texture.unwrap_or(NONE))]);
        blob.push([m.w_diffuse, m.alpha, bm.diffuse_weight, bits(sets)]);
        blob.push([m.w_pane, m.ior, bits(openness(prep.scene, i as u32)), 0.0]);
    }
    let emitter_base = blob.len() as u32;
    for e in &prep.lights.emitters {
        blob.push([bits(e.tri), e.area, e.pdf, e.cdf]);
    }
    let delta_base = blob.len() as u32;
    for l in &prep.lights.delta {
        blob.push(l.position.extend(bits(l.kind)).into());
        blob.push(l.intensity.extend(l.pdf).into());
        blob.push(l.axis.extend(l.cdf).into());
        blob.push([l.cone_scale, l.cone_offset, l.inv_range, 0.0]);
    }
    let tex_base = blob.len() as u32;
    let textures = &prep.scene.textures;
    let mut offset = tex_base as usize + textures.len();
    let mut headers = Vec::with_capacity(textures.len());
    for t in textures {
        let usable = t.width > 0 && t.height > 0 && t.pixels.len() == (t.width * t.height) as usize;
        let (w, h) = if usable { (t.width, t.height) } else { (0, 0) };
        headers.push([
            bits(offset as u32),
            bits(w),
            bits(h),
            bits(t.wrap_s.id() | (t.wrap_t.id() << 4)),
        ]);
        if usable {
            offset += t.pixels.len();
        }
    }
    blob.extend(headers);
    for t in textures {
        if t.width > 0 && t.height > 0 && t.pixels.len() == (t.width * t.height) as usize {
            blob.extend(t.pixels.iter().map(|p| p.to_array()));
        }
    }
    let attr_base = blob.len() as u32;
    blob.extend(attributes);
    if blob.is_empty() {
        blob.push([0.0; 4]);
    }
    PackedScene {
        blob,
        mat_base,
        emitter_base,
        emitter_count: prep.lights.emitters.len() as u32,
        delta_base,
        delta_count: prep.lights.delta.len() as u32,
        tex_base,
        p_emitters: prep.lights.p_emitters,
        attr_base,
        // Either side's notion of a pane: the shaders' shortcuts without panes give the same
        // answers as their loops, so a wider flag only costs time.
        has_panes: prep.has_panes() || prep.scene.has_panes(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec4};
    use vlf_core::scene::{FilterMode, SceneBuilder, Texture, WrapMode};

    #[test]
    fn sections_follow_each_other() {
        let mut b = SceneBuilder::new();
        let lamp = b.diffuse("lamp", Vec3::ONE, Vec3::splat(2.0));
        let wall = b.diffuse("wall", Vec3::splat(0.5), Vec3::ZERO);
        b.aabox(Vec3::splat(-1.0), Vec3::ONE, true, wall);
        b.quad(
            [
                Vec3::new(-0.2, 0.9, -0.2),
                Vec3::new(0.2, 0.9, -0.2),
                Vec3::new(0.2, 0.9, 0.2),
                Vec3::new(-0.2, 0.9, 0.2),
            ],
            lamp,
        );
        let mut scene = b.build("test");
        scene.textures.push(Texture {
            name: None,
            width: 2,
            height: 1,
            pixels: vec![Vec4::ONE, Vec4::ZERO],
            has_alpha: false,
            wrap_s: WrapMode::MirroredRepeat,
            wrap_t: WrapMode::ClampToEdge,
            filter: FilterMode::Linear,
            gltf_texture: 0,
        });
        let prep = PreparedScene::new(&scene);
        let p = pack(&prep);
        assert_eq!(p.mat_base as usize, 2 * prep.bvh.triangles.len());
        assert_eq!(p.emitter_base, p.mat_base + MATERIAL_ENTRIES * 2);
        assert_eq!(p.emitter_count, 2);
        assert_eq!(p.delta_base, p.emitter_base + 2);
        assert_eq!(p.tex_base, p.delta_base);
        let header = p.blob[p.tex_base as usize];
        assert_eq!(header[0].to_bits(), p.tex_base + 1);
        assert_eq!((header[1].to_bits(), header[2].to_bits()), (2, 1));
        assert_eq!(header[3].to_bits(), 2 | (1 << 4));
        assert_eq!(p.blob.len() as u32, p.tex_base + 1 + 2);
        assert_eq!(p.p_emitters, 1.0);
        // The lamp's emitter entry points at a triangle of the lamp's material.
        let e = p.blob[p.emitter_base as usize];
        assert_eq!(prep.bvh.triangles[e[0].to_bits() as usize].material, lamp);
        // Every triangle names its face; materials carry the baker's diffuse weight.
        for (i, t) in prep.bvh.triangles.iter().enumerate() {
            let face = scene.triangles[t.prim as usize].face;
            assert_eq!(p.blob[2 * i + 1][2].to_bits(), face);
        }
        assert_eq!(
            p.blob[(p.mat_base + MATERIAL_ENTRIES * wall) as usize + 2][2],
            1.0
        );
        assert!(!p.has_panes && p.info().has_panes == 0);
        assert_eq!(p.info().emitter_count, 2);
    }
}
