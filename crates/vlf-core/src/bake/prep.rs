//! The scene as the propagators see it: VLF coordinates, flat `#[repr(C)]` arrays ready for
//! upload (the GPU propagator binds these very slices), and the diffuse atlas.
//!
//! Atlas: every face gets a chart of `width × height` square texels of edge `texel_size` laid on
//! its plane basis, for each of its two sides (side 0 = front/normal side, side 1 = back).
//! Texels are clipped exactly against the face's triangles: `texel_area` is the covered area
//! (0 for texels outside the polygon), so energy sums (Σ B·area) are exact for the polygon.
//! Albedo and emission are the material's factors; where the material has a base-colour or
//! emissive texture (read with the texture coordinate set its slot names) or the face has
//! vertex colours (which multiply the base colour), they are multiplied by the mean of the
//! texture (× vertex colour) over the texel's covered part ([`TEXTURE_SAMPLES`]), not by its
//! value at one point: a texel then absorbs and emits what its part of the surface does on
//! average, which is what energy conservation needs when the texture or the colours vary
//! faster than the atlas.

use glam::{Vec2, Vec3, Vec4};
use serde::Serialize;

use super::glossy::{self, SpecularModel};
use crate::directions::DirectionSet;
use crate::lightfield::{
    AlphaMasks, BakeFace, BakeParams, BakeTriangle, FACE_DIFFUSE, FACE_MIRROR, FACE_MIXED,
    ParamsError,
};
use crate::pathtrace::lights::DeltaLight;
use crate::scene::{MaterialKind, Scene, Texture, Translucency};

/// A face's thin glass pane as the propagation reads it (32 bytes; mirrors WGSL `PaneFace` of
/// `shaders/common/pane.wgsl`): crossing the face along a direction at |cos θ| to its normal,
/// light passes `tint × T(θ)` straight through (T = 1 − `scene::pane_reflectance`), and
/// `weight × (1 − T(θ))` of it is the pane's mirror reflection. All zero: no pane.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PaneFace {
    /// Pane weight × base colour × the base-colour texture's mean over the face.
    pub tint: [f32; 3],
    /// Pane weight ([`crate::scene::Material::pane_weight`]).
    pub weight: f32,
    /// Index of refraction.
    pub ior: f32,
    pub _pad: [f32; 3],
}

impl PaneFace {
    /// What a crossing at |cos θ| = `cos` passes straight through (rgb; 0 without a pane).
    pub fn transmittance(&self, cos: f32) -> Vec3 {
        if self.weight <= 0.0 {
            return Vec3::ZERO;
        }
        let t = 1.0 - crate::scene::pane_reflectance(cos, self.ior);
        Vec3::from(self.tint) * t
    }

    /// What a crossing at |cos θ| = `cos` passes straight through before the tint, `weight ×
    /// T(θ)` (the tint absorbs the difference).
    pub fn untinted(&self, cos: f32) -> f32 {
        if self.weight <= 0.0 {
            return 0.0;
        }
        self.weight * (1.0 - crate::scene::pane_reflectance(cos, self.ior))
    }
}

/// Summary of a prepared scene (for logs and `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct PrepSummary {
    pub triangles: usize,
    pub faces: usize,
    pub texels: usize,
    pub covered_texels: usize,
    pub texel_size_vlf: f32,
    pub non_diffuse_faces: usize,
}

/// The prepared scene.
#[derive(Clone, Debug)]
pub struct BakeScene {
    pub triangles: Vec<BakeTriangle>,
    pub faces: Vec<BakeFace>,
    /// Covered area of each texel (VLF units²), both sides.
    pub texel_area: Vec<f32>,
    /// Centroid of each texel's covered part (VLF); the sample point of the gather.
    pub texel_center: Vec<[f32; 4]>,
    /// Diffuse albedo per texel (rgb, a unused).
    pub albedo: Vec<[f32; 4]>,
    /// Emitted radiance per texel (front side only; rgb, a unused).
    pub emission: Vec<[f32; 4]>,
    /// Metal-lobe reflectance per face (rgb; zero for faces without directional tiles): the
    /// material's, times the base-colour texture's mean over the face where it has one.
    pub specular: Vec<[f32; 4]>,
    /// Per face, its thin glass pane ([`PaneFace`]; zero for faces without one).
    pub panes: Vec<PaneFace>,
    /// How each face's metal lobe is modelled ([`glossy::model`]): the faces with
    /// directional tiles (`kind != FACE_DIFFUSE`) are mirrors, glossy or panes.
    pub lobes: Vec<SpecularModel>,
    /// Every material as baked (its lobe's model, the reflectance of its two parts), by
    /// material index: what a reader of the propagated field multiplies it by.
    pub materials: Vec<glossy::BakedMaterial>,
    /// Suns in VLF: (travel direction, irradiance).
    pub suns: Vec<(Vec3, Vec3)>,
    /// The alpha masks of `triangles` (empty when no material masks): the propagation's rays
    /// pass through a triangle where it [`cuts`](AlphaMasks::cuts).
    pub masks: AlphaMasks,
    /// Point and spot lights in VLF (positions and ranges mapped, intensities scaled by the
    /// VLF scale², so irradiance is unchanged): their direct light is injected into the
    /// propagation's first iteration ([`super::punctual`]).
    pub lights: Vec<DeltaLight>,
    /// Each material's subsurface model in VLF units (coefficients per VLF unit; a thin
    /// transmission's colour times the diffuse weight), by material index; empty when no
    /// material is translucent (`docs/SUBSURFACE.md`, `super::subsurface`, which replaces what
    /// translucent texels send on).
    pub translucency: Vec<Translucency>,
    pub texel_size: f32,
    pub warnings: Vec<String>,
}

impl BakeScene {
    /// Prepares `scene` for a bake with `params` (texel size from the ray spacing, metal lobes
    /// modelled for its direction set).
    pub fn new(scene: &Scene, params: &BakeParams) -> Result<Self, ParamsError> {
        params.validate()?;
        let cell = 2.0 / params.resolution as f32;
        let spacing = DirectionSet::at_least(params.directions)
            .ok()
            .map(|set| glossy::spacing(&set));
        Self::prepare(scene, cell * params.texel_scale, spacing)
    }

    /// Prepares `scene` with atlas texels of edge `texel_size` (VLF units), with no direction
    /// set in view: every metal lobe that is not folded into the diffuse part is modelled as a
    /// mirror (what the final gather's atlases need: albedo and emission).
    pub fn with_texel_size(scene: &Scene, texel_size: f32) -> Result<Self, ParamsError> {
        Self::prepare(scene, texel_size, None)
    }

    fn prepare(scene: &Scene, texel_size: f32, spacing: Option<f32>) -> Result<Self, ParamsError> {
        let xf = scene.to_vlf;
        let baked = glossy::baked_materials(&scene.materials, spacing);
        let masks = AlphaMasks::from_scene(scene);
        let warnings = Vec::new();

        let (faces, texel_count) = lay_out_faces(scene, &baked, texel_size)?;
        let mut texels = Texels::new(texel_count as usize);
        // The metal lobe's reflectance is C = base colour × base-colour texture, like the
        // Lambert part's: faces with tiles reflect with the texture's mean over their covered
        // area (the renderer applies the texture per pixel).
        let mut panes = vec![PaneFace::default(); scene.faces.len()];
        let mut specular: Vec<[f32; 4]> = scene
            .faces
            .iter()
            .map(|f| baked[f.material as usize].specular.extend(0.0).into())
            .collect();
        for (fi, f) in scene.faces.iter().enumerate() {
            let mat = &scene.materials[f.material as usize];
            let spec_tex = fill_face_texels(scene, fi, &faces[fi], &baked, &masks, &mut texels);
            let tex_mean = if spec_tex.1 > 0.0 {
                spec_tex.0 / spec_tex.1 as f32
            } else {
                Vec3::ONE
            };
            if matches!(baked[f.material as usize].model, SpecularModel::Pane { .. }) {
                // The pane passes t_w × T(θ) × C straight through; its reflection is untinted.
                let w = mat.pane_weight();
                panes[fi] = PaneFace {
                    tint: (mat.base_color * tex_mean * w).to_array(),
                    weight: w,
                    ior: mat.transparency.ior,
                    _pad: [0.0; 3],
                };
            } else if spec_tex.1 > 0.0 {
                let c = Vec4::from(specular[fi]).truncate() * tex_mean;
                specular[fi] = c.extend(0.0).into();
            }
        }
        let lobes = scene
            .faces
            .iter()
            .map(|f| baked[f.material as usize].model)
            .collect();
        let translucency = vlf_translucency(scene, xf.scale);
        let suns = scene
            .suns
            .iter()
            .map(|s| (s.direction.normalize(), s.irradiance))
            .collect();
        Ok(BakeScene {
            triangles: bake_triangles(scene),
            faces,
            texel_area: texels.area,
            texel_center: texels.center,
            albedo: texels.albedo,
            emission: texels.emission,
            specular,
            panes,
            lobes,
            materials: baked,
            suns,
            masks,
            lights: scene
                .lights
                .iter()
                .map(|l| DeltaLight::punctual(l, &xf))
                .filter(|l| l.intensity.max_element() > 0.0 && l.intensity.is_finite())
                .collect(),
            translucency,
            texel_size,
            warnings,
        })
    }

    pub fn texel_count(&self) -> usize {
        self.texel_area.len()
    }

    /// Emitted power Σ π·L_e·area over all texels (VLF units), per channel.
    pub fn emitted_power(&self) -> Vec3 {
        self.emission
            .iter()
            .zip(&self.texel_area)
            .map(|(e, a)| Vec4::from(*e).truncate() * (std::f32::consts::PI * a))
            .fold(Vec3::ZERO, |s, x| s + x)
    }

    /// Outgoing (diffuse) radiance per texel from its irradiance: `L = Le + ρ·E/π`, emission
    /// on the front side only: what a texel sends on in the propagation, and what the renderer
    /// shows of an untextured surface (rgb, a = 0).
    pub fn outgoing_radiance(&self, irradiance: &[[f32; 4]]) -> Vec<[f32; 4]> {
        irradiance
            .iter()
            .zip(&self.albedo)
            .zip(&self.emission)
            .map(|((e, rho), le)| {
                let l = Vec4::from(*le).truncate()
                    + Vec4::from(*rho).truncate()
                        * Vec4::from(*e).truncate()
                        * std::f32::consts::FRAC_1_PI;
                l.extend(0.0).into()
            })
            .collect()
    }

    pub fn summary(&self) -> PrepSummary {
        PrepSummary {
            triangles: self.triangles.len(),
            faces: self.faces.len(),
            texels: self.texel_count(),
            covered_texels: self.texel_area.iter().filter(|a| **a > 0.0).count(),
            texel_size_vlf: self.texel_size,
            non_diffuse_faces: self.faces.iter().filter(|f| f.kind != FACE_DIFFUSE).count(),
        }
    }
}

/// Sample points per texel side of the texture means: twice the texture's texels per atlas
/// texel side (from the triangle's uv gradient), between these bounds.
pub const TEXTURE_SAMPLES: std::ops::RangeInclusive<u32> = 4..=8;

/// The scene's triangles in VLF space.
fn bake_triangles(scene: &Scene) -> Vec<BakeTriangle> {
    let xf = scene.to_vlf;
    scene
        .triangles
        .iter()
        .map(|t| BakeTriangle {
            p0: xf.apply(t.p[0]).into(),
            face: t.face,
            p1: xf.apply(t.p[1]).into(),
            _pad0: 0,
            p2: xf.apply(t.p[2]).into(),
            _pad1: 0,
        })
        .collect()
}

/// Per-texel arrays of the atlas being built (both sides of every face).
struct Texels {
    area: Vec<f32>,
    center: Vec<[f32; 4]>,
    albedo: Vec<[f32; 4]>,
    emission: Vec<[f32; 4]>,
}

impl Texels {
    fn new(n: usize) -> Self {
        Texels {
            area: vec![0f32; n],
            center: vec![[0f32; 4]; n],
            albedo: vec![[0f32; 4]; n],
            emission: vec![[0f32; 4]; n],
        }
    }
}

/// Each face's chart (size, kind, specular weight, first texel) and the atlas' texel count.
fn lay_out_faces(
    scene: &Scene,
    baked: &[glossy::BakedMaterial],
    texel_size: f32,
) -> Result<(Vec<BakeFace>, u64), ParamsError> {
    let xf = scene.to_vlf;
    let mut faces = Vec::with_capacity(scene.faces.len());
    let mut texel_count: u64 = 0;
    for (fi, f) in scene.faces.iter().enumerate() {
        let mat = &scene.materials[f.material as usize];
        let extent = f.extent * xf.scale;
        let width = ((extent.x / texel_size).ceil() as u32).max(1);
        let height = ((extent.y / texel_size).ceil() as u32).max(1);
        let origin = xf.apply(f.basis.origin);
        let bm = &baked[f.material as usize];
        let (kind, specular) = match mat.kind {
            _ if !bm.model.has_tiles() => (FACE_DIFFUSE, 0.0),
            // A pane: its mirror part is the pane's, any metal lobe folded.
            _ if matches!(bm.model, SpecularModel::Pane { .. }) => (
                if bm.diffuse_weight > 0.0 {
                    FACE_MIXED
                } else {
                    FACE_MIRROR
                },
                mat.pane_weight(),
            ),
            MaterialKind::Diffuse => (FACE_DIFFUSE, 0.0),
            MaterialKind::Mirror => (FACE_MIRROR, 1.0),
            MaterialKind::Mixed { specular } => (FACE_MIXED, specular),
        };
        faces.push(BakeFace {
            normal: f.normal.into(),
            offset: f.normal.dot(origin),
            origin: origin.into(),
            texel_size,
            u: f.basis.u.into(),
            width,
            v: f.basis.v.into(),
            height,
            texel_base: texel_count as u32,
            kind,
            specular,
            material: f.material,
        });
        texel_count += 2 * u64::from(width) * u64::from(height);
        if texel_count > u64::from(u32::MAX / 2) {
            return Err(ParamsError::OutOfRange {
                name: "texel count",
                value: format!("{texel_count} at face {fi}"),
                range: "< 2^31 (lower --resolution or raise --texel-scale)",
            });
        }
    }
    Ok((faces, texel_count))
}

/// Where a face's triangles cover the texels of its chart: per texel the covered area, its
/// area-weighted centroid (chart coordinates), and the triangle (index in the face) and chart
/// point of the centroid of its largest covered piece.
struct Coverage {
    area: Vec<f64>,
    centroid: Vec<Vec2>,
    best: Vec<(f64, usize, Vec2)>,
    basis: crate::scene::PlaneBasis,
}

fn coverage(scene: &Scene, fi: usize, bf: &BakeFace) -> Coverage {
    let xf = scene.to_vlf;
    let texel_size = bf.texel_size;
    let w = bf.width as usize;
    let h = bf.height as usize;
    // Per texel: covered area, area-weighted centroid (chart coords), and the triangle
    // (index in the face) and chart point of the centroid of its largest covered piece.
    let mut area = vec![0f64; w * h];
    let mut centroid = vec![Vec2::ZERO; w * h];
    let mut best = vec![(0f64, 0usize, Vec2::ZERO); w * h];
    let basis = crate::scene::PlaneBasis {
        origin: Vec3::from(bf.origin),
        u: Vec3::from(bf.u),
        v: Vec3::from(bf.v),
    };
    let face_tris = scene.face_triangles(fi);
    for (k, tri) in face_tris.iter().enumerate() {
        let q: [Vec2; 3] = tri.p.map(|p| basis.to_chart(xf.apply(p)) / texel_size);
        for (x, y) in texels_under(&q, w, h) {
            let poly = clip_to_square(&q, x as f32, y as f32);
            let (a, c) = polygon_area_centroid(&poly);
            if a <= 0.0 {
                continue;
            }
            let i = y * w + x;
            area[i] += a;
            centroid[i] += c * a as f32;
            if a > best[i].0 {
                best[i] = (a, k, c);
            }
        }
    }
    Coverage {
        area,
        centroid,
        best,
        basis,
    }
}

/// Fills face `fi`'s texels (both sides): area (less what its alpha mask cuts), centre,
/// albedo and emission with the textures' and vertex colours' means over the covered part.
/// Returns the base-colour means' area-weighted sum and weight (the mean the face's mirror
/// reflectance and pane tint take).
fn fill_face_texels(
    scene: &Scene,
    fi: usize,
    bf: &BakeFace,
    baked: &[glossy::BakedMaterial],
    masks: &AlphaMasks,
    out: &mut Texels,
) -> (Vec3, f64) {
    let xf = scene.to_vlf;
    let texel_size = bf.texel_size;
    let f = &scene.faces[fi];
    let mat = &scene.materials[f.material as usize];
    let (w, h) = (bf.width as usize, bf.height as usize);
    let face_tris = scene.face_triangles(fi);
    let Coverage {
        area,
        centroid,
        best,
        basis,
    } = coverage(scene, fi, bf);
    let base_tex = mat
        .base_color_texture
        .map(|t| (&scene.textures[t.index as usize], t.texcoord));
    let emit_tex = mat
        .emissive_texture
        .map(|t| (&scene.textures[t.index as usize], t.texcoord));
    let face_masks = (!masks.is_empty()).then_some(masks);
    let masked = face_masks.is_some_and(|m| m.is_masked(f.triangles.start));
    // Vertex colours multiply the base colour (never the emission).
    let colored = face_tris.iter().any(|t| t.colors.is_some());
    let means = (base_tex.is_some() || emit_tex.is_some() || colored || masked).then(|| {
        texture_means(
            scene,
            fi,
            &basis,
            texel_size,
            (w, h),
            [base_tex, emit_tex],
            colored,
            face_masks.filter(|_| masked),
        )
    });
    let mut spec_tex = (Vec3::ZERO, 0f64);
    for i in 0..w * h {
        if area[i] <= 0.0 {
            continue;
        }
        let c = centroid[i] / area[i] as f32 * texel_size;
        let p = basis.from_chart(c);
        // The means over the covered part the alpha mask leaves (at the centroid of the
        // largest covered piece for a sliver no sample point fell on).
        let (_, k, at) = best[i];
        let point = || {
            let tri = &face_tris[k];
            let q: [Vec2; 3] = tri.p.map(|p| basis.to_chart(xf.apply(p)) / texel_size);
            (tri, barycentrics(&q, at))
        };
        let mean = |k: usize, fallback: &dyn Fn() -> Vec3| match &means {
            Some(m) if m.open[i] > 0.0 => m.sum[k][i] / m.open[i],
            _ => fallback(),
        };
        // The share of the covered part the alpha mask leaves (1 without a mask): a
        // sliver no sample point fell on is kept or cut whole by its best piece.
        let coverage = match &means {
            _ if !masked => 1.0,
            Some(m) if m.weight[i] > 0.0 => m.open[i] / m.weight[i],
            _ => {
                let (b1, b2) = point().1;
                let tri = f.triangles.start + k as u32;
                if masks.cuts(tri, [1.0 - b1 - b2, b1, b2]) {
                    0.0
                } else {
                    1.0
                }
            }
        };
        if coverage <= 0.0 {
            continue;
        }
        let mut base = baked[f.material as usize].diffuse;
        if base_tex.is_some() || colored {
            let t = mean(0, &|| {
                let (tri, (b1, b2)) = point();
                surface_value(tri, base_tex, b1, b2) * tri.color_at(b1, b2)
            });
            base *= t;
            spec_tex.0 += t * (area[i] as f32 * coverage);
            spec_tex.1 += area[i] * f64::from(coverage);
        }
        let mut emit = mat.emission;
        if emit_tex.is_some() {
            emit *= mean(1, &|| {
                let (tri, (b1, b2)) = point();
                surface_value(tri, emit_tex, b1, b2)
            });
        }
        let a = (area[i] * f64::from(texel_size) * f64::from(texel_size)) as f32 * coverage;
        for side in 0..2 {
            let k = bf.texel_base as usize + side * w * h + i;
            out.area[k] = a;
            out.center[k] = [p.x, p.y, p.z, 0.0];
            out.albedo[k] = base.extend(0.0).into();
            if side == 0 {
                out.emission[k] = emit.extend(0.0).into();
            }
        }
    }
    spec_tex
}

/// Per texel of one chart side: the sums of the base-colour (times the vertex colour) and
/// emissive texture values over the sample points that fall on the face where its alpha mask
/// leaves a surface, each weighted by the area it stands for, the sum of those weights
/// (`open`), and the sum of the weights of all points on the face (`weight`).
struct TextureMeans {
    sum: [Vec<Vec3>; 2],
    open: Vec<f32>,
    weight: Vec<f32>,
}

/// A texture (and the texture coordinate set it is read with), or none.
type TexSlot<'a> = Option<(&'a Texture, u32)>;

/// The value of texture slot `tex` of `tri` at barycentrics `(b1, b2)`: 1 without a texture.
fn surface_value(tri: &crate::scene::Triangle, tex: TexSlot, b1: f32, b2: f32) -> Vec3 {
    tex.map_or(Vec3::ONE, |(t, set)| {
        t.bilinear(tri.uv_at(set, b1, b2)).truncate()
    })
}

/// The means of face `fi`'s texels ([`TEXTURE_SAMPLES`]): every texel a triangle's bounding box
/// touches gets an S × S grid of points (S from that triangle's uv gradients); those inside
/// the triangle sample the textures at their interpolated uvs (each slot its own set), the
/// base colour's times the interpolated vertex colour when `colored`, weighted by the area
/// 1/S² they stand for. A missing texture reads 1.
#[allow(clippy::too_many_arguments)]
fn texture_means(
    scene: &Scene,
    fi: usize,
    basis: &crate::scene::PlaneBasis,
    texel_size: f32,
    (w, h): (usize, usize),
    textures: [TexSlot; 2],
    colored: bool,
    masks: Option<&AlphaMasks>,
) -> TextureMeans {
    let mut m = TextureMeans {
        sum: [vec![Vec3::ZERO; w * h], vec![Vec3::ZERO; w * h]],
        open: vec![0.0; w * h],
        weight: vec![0.0; w * h],
    };
    let xf = scene.to_vlf;
    let first = scene.faces[fi].triangles.start;
    // The mask reads the base-colour texture: its density counts even when only the mask does.
    let mask_tex = masks.and_then(|_| {
        scene.materials[scene.faces[fi].material as usize]
            .base_color_texture
            .map(|t| (&scene.textures[t.index as usize], t.texcoord.min(1)))
    });
    for (k, tri) in scene.face_triangles(fi).iter().enumerate() {
        let ti = first + k as u32;
        let q: [Vec2; 3] = tri.p.map(|p| basis.to_chart(xf.apply(p)) / texel_size);
        let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
        let det = e1.perp_dot(e2);
        if det.abs() < 1e-20 || !det.is_finite() {
            continue;
        }
        // uv per unit of chart x and y (texel units), then texture texels per atlas texel.
        let density = textures
            .iter()
            .chain(std::iter::once(&mask_tex))
            .flatten()
            .map(|(t, set)| {
                let uv = tri.uv_set(*set);
                let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
                let du_dx = (d1 * e2.y - d2 * e1.y) / det;
                let du_dy = (d2 * e1.x - d1 * e2.x) / det;
                let size = Vec2::new(t.width as f32, t.height as f32);
                (du_dx * size).length().max((du_dy * size).length())
            })
            .fold(0.0f32, f32::max);
        let s = (2.0 * density).ceil().clamp(
            *TEXTURE_SAMPLES.start() as f32,
            *TEXTURE_SAMPLES.end() as f32,
        ) as u32;
        let wgt = 1.0 / (s * s) as f32;
        for (x, y) in texels_under(&q, w, h) {
            let i = y * w + x;
            for sy in 0..s {
                for sx in 0..s {
                    let c = Vec2::new(
                        x as f32 + (sx as f32 + 0.5) / s as f32,
                        y as f32 + (sy as f32 + 0.5) / s as f32,
                    );
                    let d = c - q[0];
                    let b1 = d.perp_dot(e2) / det;
                    let b2 = e1.perp_dot(d) / det;
                    if b1 < 0.0 || b2 < 0.0 || b1 + b2 > 1.0 {
                        continue;
                    }
                    m.weight[i] += wgt;
                    if masks.is_some_and(|mk| mk.cuts(ti, [1.0 - b1 - b2, b1, b2])) {
                        continue;
                    }
                    let mut base = surface_value(tri, textures[0], b1, b2);
                    if colored {
                        base *= tri.color_at(b1, b2);
                    }
                    m.sum[0][i] += base * wgt;
                    if textures[1].is_some() {
                        m.sum[1][i] += surface_value(tri, textures[1], b1, b2) * wgt;
                    }
                    m.open[i] += wgt;
                }
            }
        }
    }
    m
}

/// The texels (x, y) of a `w` × `h` chart that the bounding box of the triangle `q` (in texel
/// units) touches, clamped to the chart, row by row.
pub(super) fn texels_under(
    q: &[Vec2; 3],
    w: usize,
    h: usize,
) -> impl Iterator<Item = (usize, usize)> + use<> {
    let lo = q[0].min(q[1]).min(q[2]);
    let hi = q[0].max(q[1]).max(q[2]);
    let x0 = (lo.x.floor().max(0.0) as usize).min(w - 1);
    let y0 = (lo.y.floor().max(0.0) as usize).min(h - 1);
    let x1 = (hi.x.floor().max(0.0) as usize).min(w - 1);
    let y1 = (hi.y.floor().max(0.0) as usize).min(h - 1);
    (y0..=y1).flat_map(move |y| (x0..=x1).map(move |x| (x, y)))
}

/// Clips triangle `q` (texel units) against the unit square at `(x, y)` (Sutherland–Hodgman).
fn clip_to_square(q: &[Vec2; 3], x: f32, y: f32) -> Vec<Vec2> {
    let mut poly: Vec<Vec2> = q.to_vec();
    // (axis, bound, keep >= bound?)
    for (axis, bound, keep_ge) in [
        (0, x, true),
        (0, x + 1.0, false),
        (1, y, true),
        (1, y + 1.0, false),
    ] {
        if poly.is_empty() {
            break;
        }
        let inside = |p: Vec2| {
            let c = if axis == 0 { p.x } else { p.y };
            if keep_ge { c >= bound } else { c <= bound }
        };
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let a = poly[i];
            let b = poly[(i + 1) % poly.len()];
            let (ia, ib) = (inside(a), inside(b));
            if ia {
                out.push(a);
            }
            if ia != ib {
                let (ca, cb) = if axis == 0 { (a.x, b.x) } else { (a.y, b.y) };
                let t = (bound - ca) / (cb - ca);
                out.push(a + (b - a) * t);
            }
        }
        poly = out;
    }
    poly
}

/// Area (absolute) and centroid of a simple polygon.
fn polygon_area_centroid(poly: &[Vec2]) -> (f64, Vec2) {
    if poly.len() < 3 {
        return (0.0, Vec2::ZERO);
    }
    let mut a2 = 0f64;
    let (mut cx, mut cy) = (0f64, 0f64);
    for i in 0..poly.len() {
        let p = poly[i].as_dvec2();
        let q = poly[(i + 1) % poly.len()].as_dvec2();
        let cr = p.x * q.y - q.x * p.y;
        a2 += cr;
        cx += (p.x + q.x) * cr;
        cy += (p.y + q.y) * cr;
    }
    if a2.abs() < 1e-18 {
        return (0.0, Vec2::ZERO);
    }
    let c = Vec2::new((cx / (3.0 * a2)) as f32, (cy / (3.0 * a2)) as f32);
    (a2.abs() * 0.5, c)
}

/// Barycentric weights `(b1, b2)` of corners 1 and 2 at chart point `c` of triangle `q` (0
/// for a degenerate triangle).
fn barycentrics(q: &[Vec2; 3], c: Vec2) -> (f32, f32) {
    let e1 = q[1] - q[0];
    let e2 = q[2] - q[0];
    let d = c - q[0];
    let det = e1.perp_dot(e2);
    if det.abs() < 1e-20 {
        return (0.0, 0.0);
    }
    (d.perp_dot(e2) / det, e1.perp_dot(d) / det)
}

/// Every material's subsurface model in VLF units (`scale` VLF units per scene unit), a thin
/// transmission's colour times the material's diffuse weight; empty when none is translucent.
fn vlf_translucency(scene: &Scene, scale: f32) -> Vec<Translucency> {
    if !scene.has_translucency() {
        return Vec::new();
    }
    (0..scene.materials.len() as u32)
        .map(|m| match scene.translucency_of(m) {
            Translucency::ThinDiffuseTransmission { factor, color } => {
                Translucency::ThinDiffuseTransmission {
                    factor,
                    color: color * factor * scene.materials[m as usize].diffuse_weight(),
                }
            }
            Translucency::Dipole {
                sigma_s_prime,
                sigma_a,
                eta,
            } => Translucency::Dipole {
                sigma_s_prime: sigma_s_prime / scale,
                sigma_a: sigma_a / scale,
                eta,
            },
            Translucency::None => Translucency::None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_partitions_a_triangle_exactly() {
        let q = [
            Vec2::new(0.3, 0.2),
            Vec2::new(4.7, 1.1),
            Vec2::new(1.9, 3.6),
        ];
        let (whole, _) = polygon_area_centroid(&q);
        let mut sum = 0.0;
        for y in 0..4 {
            for x in 0..5 {
                sum += polygon_area_centroid(&clip_to_square(&q, x as f32, y as f32)).0;
            }
        }
        assert!((sum - whole).abs() < 1e-5 * whole, "{sum} vs {whole}");
    }
}
