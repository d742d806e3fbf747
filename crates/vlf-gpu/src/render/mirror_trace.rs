//! Pass 5's traced branch for mirror and glossy pixels (VLF 2004
//! §5: "only ES*D rays must be computed"): the scene's BVH for it and its CPU specification.
//!
//! Where the visible face is a mirror or a mixed face, pass 5 replaces the specular part read
//! from the face's tiles by tracing the reflected view ray (`shaders/render_final_radiance.wgsl`,
//! `traced_specular`, through the shared traversal of `shaders/common/bvh.wgsl`):
//!
//! * the chain follows further mirror faces, multiplying their reflectance (specular weight ×
//!   base colour × base-colour texture at the point, [`specular_reflectance`]), up to
//!   [`MAX_DEPTH`] mirrors including the visible one — the bound and the rules of
//!   `vlf_core::resample`, which computes the same chain once per tile cell;
//! * at the first diffuse face it reads the light field exactly as pass 5 reads a visible point
//!   (`Le(uv)` on the front, `ρ_d(uv)/π ·` atlas irradiance, at the hit's own point and uv:
//!   the same WGSL function);
//! * a ray that leaves the scene reads the sky;
//! * a chain cut off by the depth bound, or ending on a mixed face (whose specular part would
//!   need the tiles in the ray's direction, i.e. a direction lookup pass 5 does not have on the
//!   GPU), falls back to the visible face's own tiles for the whole specular part. After part 2
//!   those tiles hold the same chain, traced at tile resolution.
//!
//! Emission of mirrors passed along the chain is not added (as in the resampling).
//!
//! Shading normals: a smooth mirror (a face with [`super::upload::FLAG_SMOOTH`] and a non-zero
//! interpolated normal at the point) reflects about the interpolated normal, at the visible
//! point (pass 4b's normal) and along the chain (the hit's corner normals); its glossy lobe is
//! sampled about it. Rays still leave from the geometric surface, and a reflected direction
//! below it ends the chain black (it would enter the solid the mirror bounds; the path tracer
//! ends such a path too), not cut. Vertex colours multiply the reflectance C as they multiply
//! the base colour, and textures read the set their slot names ([`PixelSurface`]).
//!
//! A glossy visible face (GGX α > 0 in its material) traces [`LOBE_SAMPLES`]
//! directions of its lobe per pass-5 sample instead of the one mirror direction, each chain
//! following the rules above (further mirrors reflect as perfect mirrors); the share of them
//! that is cut off reads the tiles. The light field resolves directions only to its spacing
//! (0.16 rad at the default 246 directions), so a lobe narrower than that is baked as a
//! mirror: the traced lobe gives such faces their blur back at render time, and gives every
//! glossy face reflections as sharp as its lobe rather than as its tiles.
//!
//! The BVH is built here over the light field's own triangles in VLF coordinates (the
//! coordinates of every render pass), with [`RtTriangle::material`] holding the triangle's face
//! and [`RtTriangle::prim`] its index in `LightField::triangles`, and uploaded with the ray
//! engine's [`GpuBvh`]; the hit's uvs come from a leaf-order copy of the corner uvs.

use glam::{Vec2, Vec3};
use vlf_core::lightfield::{FACE_DIFFUSE, FACE_MIRROR, LightField};
use vlf_core::pathtrace::geometry::offset_ray_origin;
use vlf_core::pathtrace::sampling::{
    ggx_g1, ggx_sample_vndf, pcg_hash, reflect, to_local, to_world,
};
use vlf_core::pathtrace::{Bvh, Ray, RtTriangle};
use vlf_core::scene::pane_reflectance;
use wgpu::util::DeviceExt;

use super::RenderError;
use super::final_radiance::{
    PixelSurface, SurfaceLookup, shading_normal, surface_radiance, visible_side,
};
use super::upload::{FLAG_BASE_UV1, FLAG_COLORS};
use crate::raytrace::GpuBvh;

/// Mirrors a traced chain follows, the visible one included, before it falls back to the
/// tiles: the mirror-tile resampling's bound (it traces the same chains once per tile cell).
/// The WGSL constant `MIRROR_DEPTH` is checked against it.
pub use vlf_core::resample::MAX_DEPTH;

/// Whether `lf` has faces with a specular part (mirror or mixed): only then does pass 5 trace.
pub fn has_mirrors(lf: &LightField) -> bool {
    lf.faces.iter().any(|f| f.kind != FACE_DIFFUSE)
}

/// Mirror reflectance of face `face` at a point with attributes `s`: the face record's
/// ([`super::upload::specular_reflectance`]) × the base-colour texture × the vertex colour, as
/// pass 5 computes it (C of the glTF metal lobe).
pub fn specular_reflectance(
    lf: &LightField,
    lookup: &SurfaceLookup,
    face: u32,
    s: &PixelSurface,
) -> Vec3 {
    let f = &lf.faces[face as usize];
    let m = &lf.shading.materials[f.material as usize];
    let flags = lookup.flags[face as usize];
    let uv = s.tex_uv(flags & FLAG_BASE_UV1 != 0);
    let mut c = super::upload::specular_reflectance(f, m)
        * lf.shading.sample(m.base_color_texture, uv, &lookup.offsets);
    if flags & FLAG_COLORS != 0 {
        c *= s.color;
    }
    c
}

/// The BVH pass 5 traces: `lf`'s triangles (VLF coordinates), `material` = face,
/// `prim` = triangle index.
pub fn build_bvh(lf: &LightField) -> Bvh {
    let tris = lf
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| RtTriangle::of_baked(i, t))
        .collect();
    Bvh::build(tris).with_masks(std::sync::Arc::new(lf.alpha_masks()))
}

/// The traced branch's scene on the GPU: the BVH and the corner uvs in leaf order
/// (`array<vec2<f32>>`, three per triangle). Dummies (one empty leaf) for light fields without
/// mirrors, which never trace.
pub struct GpuMirrorScene {
    pub bvh: GpuBvh,
    pub uvs: wgpu::Buffer,
    pub bytes: u64,
}

impl GpuMirrorScene {
    pub fn new(device: &wgpu::Device, lf: &LightField) -> Result<Self, RenderError> {
        let bvh = if has_mirrors(lf) {
            build_bvh(lf)
        } else {
            Bvh::build(Vec::new())
        };
        let mut uvs: Vec<[f32; 2]> = (bvh.triangles.iter())
            .flat_map(|t| lf.shading.uvs[t.prim as usize])
            .collect();
        if uvs.is_empty() {
            uvs.push([0.0; 2]);
        }
        let gpu = GpuBvh::upload(device, "FinalRadiance", &bvh).map_err(|e| match e {
            crate::raytrace::RaytraceError::TooLarge { what, bytes, limit } => {
                RenderError::TooLarge {
                    what: what.to_owned(),
                    bytes,
                    limit,
                }
            }
            other => RenderError::InvalidLightField(other.to_string()),
        })?;
        let uvs = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("FinalRadiance::mirror_uvs"),
            contents: bytemuck::cast_slice(&uvs),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let bytes = gpu.nodes.size() + gpu.triangles.size() + uvs.size();
        Ok(Self {
            bvh: gpu,
            uvs,
            bytes,
        })
    }
}

/// Directions a glossy pixel traces per sample of pass 5 (see [`traced_specular`]). The WGSL
/// constant `LOBE_SAMPLES` is checked against it.
pub const LOBE_SAMPLES: u32 = 4;

/// What pass 5's traced branch brings back for a pixel ([`traced_specular`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracedSpecular {
    /// Specular radiance of the traced directions (their chains that were cut off count 0).
    pub radiance: Vec3,
    /// Share of the pixel's specular part that falls back to its tiles instead: the traced
    /// directions whose chain was cut off, over all traced (0 or 1 for a perfect mirror).
    pub tiles: f32,
}

/// Sample point `k` of pixel `pixel`'s lobe directions: the R2 sequence (Roberts 2018) shifted
/// by a per-pixel hash (a Cranley–Patterson rotation), so a pixel's points over all its
/// samples stay evenly spread and neighbouring pixels' errors do not line up. As pass 5's
/// `lobe_point`, in f32.
pub fn lobe_point(pixel: u32, k: u32) -> Vec2 {
    let h = pcg_hash(pixel);
    let shift = Vec2::new((h & 0xffff) as f32, (h >> 16) as f32) * (1.0 / 65536.0);
    let x = shift + k as f32 * Vec2::new(0.754_877_7, 0.569_840_3);
    x - x.floor()
}

/// CPU specification of pass 5's traced branch: the specular radiance reaching an eye at `eye`
/// from the visible point `p` (attributes `s`) of non-diffuse face `face`, in f32 in
/// the shader's order of operations. A perfect mirror (GGX α 0 in its material) traces the
/// reflected view ray along the chain of the module docs. A glossy lobe (α > 0) traces
/// [`LOBE_SAMPLES`] directions reflected about normals drawn from its distribution of visible
/// normals (Heitz 2018) at [`lobe_point`]`(pixel, first + k)`, each weighing C · G1(wi) (the
/// lobe's f cos / pdf without Fresnel; their mean's expectation is C × the directional albedo,
/// what the lobe reflects of the light around it): the lobe's blur of what it reflects, which
/// the tiles' direction spacing cannot resolve for lobes narrower than it. Only the visible
/// face's lobe is sampled: further mirrors along a chain reflect as perfect mirrors. Pass 5
/// calls it with `pixel` = row × width + column and `first` = sample index × [`LOBE_SAMPLES`].
/// A smooth point reflects about its shading normal (module docs). `bvh` is
/// [`build_bvh`]`(lf)`, `lookup` [`SurfaceLookup::new`]`(lf)`.
#[allow(clippy::too_many_arguments)]
pub fn traced_specular(
    lf: &LightField,
    bvh: &Bvh,
    lookup: &SurfaceLookup,
    eye: Vec3,
    face: u32,
    p: Vec3,
    s: &PixelSurface,
    pixel: u32,
    first: u32,
) -> TracedSpecular {
    let f = &lf.faces[face as usize];
    let n = f.normal();
    let d = (p - eye).normalize();
    let side = if visible_side(f, eye, p) == 0 { n } else { -n };
    let (ns, smooth) = shading_normal(lookup, face, s, side);
    let c = specular_reflectance(lf, lookup, face, s);
    let origin = offset_ray_origin(p, side);
    let m = &lf.shading.materials[f.material as usize];
    if m.pane > 0.0 {
        // A pane: its reflection, pane weight × R(θ) (untinted), and what lies behind it, `c`
        // (pane weight × C) × T(θ) straight through. The tiles stand in for the reflection
        // only.
        let r = pane_reflectance(d.dot(n), m.ior);
        let (reflected, cut) = trace_chain(
            lf,
            bvh,
            lookup,
            origin,
            (d - 2.0 * d.dot(n) * n).normalize(),
            Vec3::splat(m.pane * r),
        );
        let behind = offset_ray_origin(p, -side);
        let (passed, _) = trace_chain(lf, bvh, lookup, behind, d, c * (1.0 - r));
        return TracedSpecular {
            radiance: reflected + passed,
            tiles: if cut { 1.0 } else { 0.0 },
        };
    }
    let alpha = m.specular_alpha;
    let none = TracedSpecular {
        radiance: Vec3::ZERO,
        tiles: 0.0,
    };
    if alpha <= 0.0 {
        let r = (d - 2.0 * d.dot(ns) * ns).normalize();
        if smooth && r.dot(side) <= 0.0 {
            return none;
        }
        let (radiance, cut) = trace_chain(lf, bvh, lookup, origin, r, c);
        return TracedSpecular {
            radiance,
            tiles: if cut { 1.0 } else { 0.0 },
        };
    }
    let wo = to_local(-d, ns);
    if smooth && wo.z <= 0.0 {
        return none;
    }
    let (mut sum, mut cut) = (Vec3::ZERO, 0.0f32);
    for k in 0..LOBE_SAMPLES {
        let wi = reflect(wo, ggx_sample_vndf(wo, alpha, lobe_point(pixel, first + k)));
        if wi.z > 0.0 {
            let dir = to_world(wi, ns).normalize();
            if smooth && dir.dot(side) <= 0.0 {
                continue;
            }
            let (l, c_off) = trace_chain(lf, bvh, lookup, origin, dir, c * ggx_g1(wi.z, alpha));
            sum += l;
            cut += if c_off { 1.0 } else { 0.0 };
        }
    }
    let w = 1.0 / LOBE_SAMPLES as f32;
    TracedSpecular {
        radiance: sum * w,
        tiles: cut * w,
    }
}

/// The radiance a traced chain brings back along `dir` from `origin` (a point of the visible
/// non-diffuse face, already offset) times `throughput`, and whether it was cut off (by the
/// depth bound or on a mixed face: zero radiance, the tiles stand in). A smooth mirror along the
/// chain reflects about its interpolated normal; a reflection below its geometric surface ends
/// the chain black. As pass 5's `trace_chain`.
fn trace_chain(
    lf: &LightField,
    bvh: &Bvh,
    lookup: &SurfaceLookup,
    origin: Vec3,
    dir: Vec3,
    throughput: Vec3,
) -> (Vec3, bool) {
    let (mut origin, mut dir, mut throughput) = (origin, dir, throughput);
    let mut depth = 1;
    // The diffuse part of panes passed on the way.
    let mut seen = Vec3::ZERO;
    loop {
        let hit = bvh.closest_hit(&Ray::new(origin, dir, f32::MAX));
        if !hit.is_hit() {
            return (seen + throughput * lf.params.sky, false);
        }
        let t = &bvh.triangles[hit.tri as usize];
        let face = t.material;
        let [p0, p1, p2] = t.corners();
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let q = p0 * b0 + p1 * b1 + p2 * b2;
        let f = &lf.faces[face as usize];
        let n = f.normal();
        let hside = if n.dot(-dir) >= 0.0 { 0 } else { 1 };
        let s = PixelSurface::of_triangle(lf, &lookup.attributes, t.prim as usize, b1, b2, hside);
        let m = &lf.shading.materials[f.material as usize];
        if m.pane > 0.0 && depth < MAX_DEPTH {
            // A pane along the chain: its diffuse part, then on straight through it (its own
            // reflection, which only its tiles hold in the ray's direction, is left out).
            seen += throughput * surface_radiance(lf, lookup, face, hside, q, &s);
            throughput *= specular_reflectance(lf, lookup, face, &s)
                * (1.0 - pane_reflectance(dir.dot(n), m.ior));
            origin = offset_ray_origin(q, if n.dot(dir) > 0.0 { n } else { -n });
            depth += 1;
            continue;
        }
        match f.kind {
            FACE_DIFFUSE => {
                let side = hside;
                let l = surface_radiance(lf, lookup, face, side, q, &s);
                return (seen + throughput * l, false);
            }
            FACE_MIRROR if depth < MAX_DEPTH => {
                throughput *= specular_reflectance(lf, lookup, face, &s);
                let side = if n.dot(-dir) > 0.0 { n } else { -n };
                let (ns, smooth) = shading_normal(lookup, face, &s, side);
                dir = (dir - 2.0 * dir.dot(ns) * ns).normalize();
                if smooth && dir.dot(side) <= 0.0 {
                    return (Vec3::ZERO, false);
                }
                origin = offset_ray_origin(q, side);
                depth += 1;
            }
            // Cut off by the bound, or a mixed face: the pixel's own tiles.
            _ => return (seen, true),
        }
    }
}
