//! Scene model and glTF 2.0 import.
//!
//! [`load`] reads a `.gltf` or `.glb` file into a [`Scene`]: world-space triangles
//! (node transforms applied), materials mapped to the propagator's material model,
//! decoded base-colour and emissive textures, cameras, directional lights (suns), point
//! and spot lights, the planar polygons ([`Face`]s) the light field is stored on, and the
//! [`Similarity`] that maps the scene into the unit sphere of VLF coordinates.
//!
//! # Conventions (see `shared/reference/README.md`)
//! - **Front face** = counter-clockwise in world space. A node whose world transform
//!   has a negative determinant reverses winding; the importer swaps two corners of
//!   such triangles so that every [`Triangle`] and [`Face`] here is CCW-front in
//!   world space. Vertex normals are ignored: faces are planar and flat shaded.
//! - **Materials**: see [`MaterialKind`] for the metallic/roughness mapping.
//!   `emission = emissiveFactor × KHR_materials_emissive_strength` (× the emissive
//!   texture) is radiance, emitted from the front face only.
//! - **Textures** are decoded to linear RGBA `f32`; base-colour and emissive
//!   textures are sRGB-decoded (the only kinds imported).
//! - **Cameras** look down their local −Z with +Y up; `yfov` is vertical.
//! - **Suns**: `irradiance = color × intensity`, read radiometrically.
//! - **Point and spot lights** ([`PunctualLight`]): radiant intensity `I = color × intensity`
//!   (W/sr, read radiometrically), irradiance `I·cos θ/d²` at distance d; spots fall off
//!   between their inner and outer cone angles by the extension's recommended smooth curve, and
//!   a `range` windows the inverse-square law by the extension's recommended
//!   `clamp(1 − (d/range)⁴, 0, 1)` ([`PunctualLight::attenuation`]). Bad values (negative or
//!   non-finite colour, intensity or range, cone angles outside `0 ≤ inner < outer ≤ π/2`) are
//!   errors naming the light.
//!
//! # Errors and warnings
//! Every fatal problem is a [`SceneError`] whose message names the element (buffer,
//! image, mesh/primitive, node, …) and ends with the file path. Non-fatal problems
//! are collected in [`Scene::warnings`] (and logged with `log::warn!`). Malformed
//! input never panics: the loader validates every index, byte range and count
//! itself and reads buffers through bounds-checked code. Specific choices:
//! - non-finite vertex positions (also after the node transform) are an **error**
//!   naming the mesh, primitive and vertex ([`SceneError::NonFinitePosition`]);
//! - non-finite texture coordinates are replaced by 0 with a warning;
//! - degenerate triangles (area below `1e-12 × bbox diagonal²`) are skipped with one
//!   warning per mesh primitive giving their number;
//! - out-of-range vertex indices are an error naming the primitive;
//! - points and lines primitives are skipped with a warning;
//! - a scene with no triangle left is an error ([`SceneError::Empty`]).

mod builder;
pub mod dipole;
mod error;
mod faces;
mod gltf_import;
mod texture;
mod translucency;
mod uri;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec2, Vec3};
use serde::{Deserialize, Serialize};

pub use builder::SceneBuilder;
pub use error::SceneError;
pub use texture::{FilterMode, Texture, WrapMode};
pub use translucency::{MaterialTranslucency, Translucency};

/// Largest number of triangles [`load`] accepts (after instancing); more is
/// reported as [`SceneError::TooLarge`] instead of exhausting memory.
pub const MAX_TRIANGLES: usize = 1 << 24;

/// Two triangles sharing an edge belong to the same [`Face`] when their unit normals
/// satisfy `dot > FACE_COS_TOLERANCE` (= cos 0.08°) and they have the same material.
pub const FACE_COS_TOLERANCE: f64 = 0.999_999_025_224_415_1;

/// Relative degenerate-triangle threshold: a triangle whose area is below
/// `DEGENERATE_AREA_FACTOR × (bbox diagonal)²` is skipped.
pub const DEGENERATE_AREA_FACTOR: f64 = 1e-12;

/// A world-space triangle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Triangle {
    /// Corners in world space, counter-clockwise seen from the front.
    pub p: [Vec3; 3],
    /// `TEXCOORD_0` at the corners (zeros when the primitive has none).
    pub uv: [Vec2; 3],
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::faces`] of the planar polygon holding this triangle.
    pub face: u32,
}

impl Triangle {
    /// Unnormalised geometric normal `(p1 − p0) × (p2 − p0)`; its length is twice the area.
    pub fn cross(&self) -> Vec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    /// Unit front-face normal (CCW side).
    pub fn normal(&self) -> Vec3 {
        self.cross().normalize_or_zero()
    }

    /// Area in world units².
    pub fn area(&self) -> f32 {
        0.5 * self.cross().length()
    }

    /// Centroid.
    pub fn centroid(&self) -> Vec3 {
        (self.p[0] + self.p[1] + self.p[2]) / 3.0
    }
}

/// An orthonormal frame in a face's plane: a point `p` of the plane has chart
/// coordinates `((p − origin)·u, (p − origin)·v)`. `u × v` equals the face normal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaneBasis {
    /// Chart origin (a corner of the face's bounding rectangle, on the plane).
    pub origin: Vec3,
    /// First in-plane axis (unit).
    pub u: Vec3,
    /// Second in-plane axis (unit), `normal × u`.
    pub v: Vec3,
}

impl PlaneBasis {
    /// Chart coordinates of a world point (its projection onto the plane).
    pub fn to_chart(&self, p: Vec3) -> Vec2 {
        let d = p - self.origin;
        Vec2::new(d.dot(self.u), d.dot(self.v))
    }

    /// World point of chart coordinates.
    pub fn from_chart(&self, c: Vec2) -> Vec3 {
        self.origin + self.u * c.x + self.v * c.y
    }
}

/// A planar polygon: a maximal edge-connected set of triangles with one material
/// whose normals agree within 0.08° (see [`FACE_COS_TOLERANCE`]). Its triangles are
/// contiguous in [`Scene::triangles`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Face {
    /// Unit normal of the front (CCW) side: area-weighted mean of its triangles' normals.
    pub normal: Vec3,
    /// Plane offset: points of the plane satisfy `normal · p = offset`.
    pub offset: f32,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Range of [`Scene::triangles`] forming this face.
    pub triangles: Range<u32>,
    /// Total area of the face's triangles (world units²).
    pub area: f32,
    /// In-plane chart frame; every vertex of the face projects into
    /// `[0, extent.x] × [0, extent.y]` (up to `f32` rounding).
    pub basis: PlaneBasis,
    /// Size of the face's bounding rectangle in the chart, `extent.x >= extent.y` (up to a
    /// relative 1e-6 for near-squares, whose orientation follows a fixed world-space tie rule).
    /// The rectangle is the minimum-area one aligned with an edge of the face's
    /// convex hull, so charts are tight for rectangles and rotated polygons alike.
    pub extent: Vec2,
}

/// Reference to an entry of [`Scene::textures`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TexRef {
    /// Index into [`Scene::textures`] (not the glTF texture index).
    pub index: u32,
    /// The glTF `texCoord` set. Only `TEXCOORD_0` is imported
    /// ([`Triangle::uv`]); other sets produce a warning and are sampled with set 0.
    pub texcoord: u32,
}

/// Metallic factor at or below which a material is purely Lambertian
/// (`shared/reference/README.md`).
pub const DIFFUSE_MAX_METALLIC: f32 = 0.01;
/// Metallic factor at or above which a material is purely metal.
pub const METAL_MIN_METALLIC: f32 = 0.99;
/// Roughness at or below which the metal lobe is a perfect mirror.
pub const MIRROR_MAX_ROUGHNESS: f32 = 0.05;

/// Lobes of a glTF (metallic, roughness) pair under the conventions of
/// `shared/reference/README.md`: `(diffuse weight, GGX α)`; the metal lobe has weight
/// `1 − diffuse weight`, and α = 0 means it is a perfect mirror (α = r² otherwise).
pub fn lobes(metallic: f32, roughness: f32) -> (f32, f32) {
    let w_diffuse = if metallic <= DIFFUSE_MAX_METALLIC {
        1.0
    } else if metallic >= METAL_MIN_METALLIC {
        0.0
    } else {
        1.0 - metallic
    };
    let alpha = if roughness <= MIRROR_MAX_ROUGHNESS {
        0.0
    } else {
        roughness * roughness
    };
    (w_diffuse, alpha)
}

/// Which lobes a surface has; derived from the glTF metallic factor m (missing factors
/// default to 1 as in the glTF spec). The metal lobe is a perfect mirror of reflectance C
/// when the roughness r ≤ 0.05 and a GGX lobe with α = r² and reflectance C otherwise (no
/// Fresnel; [`Material::specular_alpha`]); how the baker models it (mirror, directional
/// tiles, or folded into the diffuse part) is its own choice (`bake::glossy`).
///
/// | m | kind |
/// |---|---|
/// | m ≤ 0.01 | [`Diffuse`](MaterialKind::Diffuse), albedo C |
/// | m ≥ 0.99 | [`Mirror`](MaterialKind::Mirror): the metal lobe alone |
/// | 0.01 < m < 0.99 | [`Mixed`](MaterialKind::Mixed) `{ specular: m }` |
///
/// (C = base colour factor × base-colour texture.)
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum MaterialKind {
    /// Lambertian reflection with albedo C.
    Diffuse,
    /// The metal lobe alone, reflectance C at every angle (no Fresnel): a perfect mirror, or a
    /// GGX lobe when rough.
    Mirror,
    /// `(1 − specular)·Lambert(C) + specular·metal(C)`.
    Mixed {
        /// Weight of the metal lobe (the metallic factor), in (0.01, 0.99).
        specular: f32,
    },
}

impl MaterialKind {
    /// The kind of a metallic factor (the thresholds of [`lobes`]).
    pub fn from_metallic(metallic: f32) -> MaterialKind {
        if metallic <= DIFFUSE_MAX_METALLIC {
            MaterialKind::Diffuse
        } else if metallic >= METAL_MIN_METALLIC {
            MaterialKind::Mirror
        } else {
            MaterialKind::Mixed { specular: metallic }
        }
    }
}

/// A surface material (see [`MaterialKind`] for the reflection model).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// glTF name, or `"material N"` when unnamed (`"default"` for the glTF default material).
    pub name: String,
    /// Linear RGB base colour factor (alpha ignored), clamped to [0, 1].
    pub base_color: Vec3,
    /// Base-colour texture (multiplies `base_color`).
    pub base_color_texture: Option<TexRef>,
    /// Emitted radiance factor: `emissiveFactor × KHR_materials_emissive_strength`.
    /// Emission is one-sided (front face only).
    pub emission: Vec3,
    /// Emissive texture (multiplies `emission`).
    pub emissive_texture: Option<TexRef>,
    /// glTF `doubleSided` (informative: surfaces reflect alike from both sides).
    pub double_sided: bool,
    /// Reflection model.
    pub kind: MaterialKind,
    /// glTF metallic factor as read (clamped to [0, 1]).
    pub metallic: f32,
    /// glTF roughness factor as read (clamped to [0, 1]).
    pub roughness: f32,
}

impl Material {
    /// Weight of the Lambertian lobe: 1, 0 or `1 − specular`.
    pub fn diffuse_weight(&self) -> f32 {
        match self.kind {
            MaterialKind::Diffuse => 1.0,
            MaterialKind::Mirror => 0.0,
            MaterialKind::Mixed { specular } => 1.0 - specular,
        }
    }

    /// Weight of the metal lobe: 0, 1 or `specular`.
    pub fn specular_weight(&self) -> f32 {
        1.0 - self.diffuse_weight()
    }

    /// Lambertian albedo `diffuse_weight × base_color` (multiply by the base-colour
    /// texture where there is one).
    pub fn diffuse_albedo(&self) -> Vec3 {
        self.base_color * self.diffuse_weight()
    }

    /// GGX α of the metal lobe (`roughness²`), 0 when it is a perfect mirror
    /// (roughness ≤ [`MIRROR_MAX_ROUGHNESS`]).
    pub fn specular_alpha(&self) -> f32 {
        lobes(1.0, self.roughness).1
    }

    /// Metal-lobe reflectance `specular_weight × base_color` (multiply by the
    /// base-colour texture where there is one).
    pub fn specular_reflectance(&self) -> Vec3 {
        self.base_color * self.specular_weight()
    }

    /// Whether the material emits light (non-zero emission factor).
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// A perspective camera of the default scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Node name (or the glTF camera's name when the node has none).
    pub name: Option<String>,
    /// World position of the eye.
    pub position: Vec3,
    /// World rotation; the camera looks down its local −Z with +Y up.
    pub rotation: Quat,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Width / height, when the file fixes it.
    pub aspect_ratio: Option<f32>,
    /// Near plane distance.
    pub znear: f32,
    /// Far plane distance (`None` = infinite).
    pub zfar: Option<f32>,
}

impl Camera {
    /// World-space viewing direction (local −Z).
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::NEG_Z
    }

    /// World-space up direction (local +Y).
    pub fn up(&self) -> Vec3 {
        self.rotation * Vec3::Y
    }
}

/// A directional light (`KHR_lights_punctual` "directional").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sun {
    /// Light name (or node name).
    pub name: Option<String>,
    /// Unit direction in which the light travels (the node's local −Z in world space).
    pub direction: Vec3,
    /// Irradiance at normal incidence, `color × intensity` (radiometric reading).
    pub irradiance: Vec3,
}

/// The kind of a [`PunctualLight`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum PunctualKind {
    /// Light in every direction.
    Point,
    /// A cone about the light's direction: full intensity within `inner` radians of the axis,
    /// none beyond `outer`, the extension's smooth falloff between ([`PunctualLight::cone`]).
    Spot {
        /// `innerConeAngle` (radians), `0 ≤ inner < outer`.
        inner: f32,
        /// `outerConeAngle` (radians), `≤ π/2`.
        outer: f32,
    },
}

/// A point or spot light (`KHR_lights_punctual` "point" / "spot"), world space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PunctualLight {
    /// Light name (or node name).
    pub name: Option<String>,
    pub kind: PunctualKind,
    /// Position (the node's world translation).
    pub position: Vec3,
    /// Unit direction the light points in (the node's local −Z in world space); a spot's axis.
    pub direction: Vec3,
    /// Radiant intensity `color × intensity` (W/sr, radiometric reading): irradiance
    /// `I·cos θ/d²` at distance d.
    pub intensity: Vec3,
    /// `range` (world units), when the file sets one.
    pub range: Option<f32>,
}

impl PunctualLight {
    /// `(scale, offset)` of the spot's angular falloff, the extension's recommended
    /// `t = clamp(cos α · scale + offset, 0, 1)`, attenuation `t²`, with
    /// `scale = 1 / max(0.001, cos inner − cos outer)` and `offset = −cos outer · scale`;
    /// `(0, 1)` for a point light (attenuation 1 everywhere).
    pub fn cone(&self) -> (f32, f32) {
        match self.kind {
            PunctualKind::Point => (0.0, 1.0),
            PunctualKind::Spot { inner, outer } => {
                let scale = 1.0 / (inner.cos() - outer.cos()).max(0.001);
                (scale, -outer.cos() * scale)
            }
        }
    }

    /// The share of the intensity that reaches distance `d` along a ray at cosine `cos_axis`
    /// from the axis: the spot's cone falloff times the range window
    /// `clamp(1 − (d/range)⁴, 0, 1)` (1 without a range).
    pub fn attenuation(&self, cos_axis: f32, d: f32) -> f32 {
        let (scale, offset) = self.cone();
        let t = (cos_axis * scale + offset).clamp(0.0, 1.0);
        let window = self
            .range
            .map_or(1.0, |r| (1.0 - (d / r).powi(4)).clamp(0.0, 1.0));
        t * t * window
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// Grows the box to contain `p`.
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Centre of the box (computed without overflow for huge coordinates).
    pub fn center(&self) -> Vec3 {
        0.5 * self.min + 0.5 * self.max
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f32 {
        (self.max - self.min).length()
    }
}

/// World → VLF coordinates: `vlf = (world − center) × scale`, a translation and a
/// uniform scale that put every vertex of the scene inside the sphere of radius
/// `1 − MARGIN` (so the unit sphere's boundary never touches geometry).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Similarity {
    /// World point mapped to the origin (the bounding-box centre).
    pub center: Vec3,
    /// World length → VLF length factor.
    pub scale: f32,
}

impl Similarity {
    /// Gap left between the farthest vertex and the unit sphere (VLF units).
    pub const MARGIN: f32 = 1e-3;

    /// Identity transform.
    pub const IDENTITY: Similarity = Similarity {
        center: Vec3::ZERO,
        scale: 1.0,
    };

    /// World point → VLF point.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        (p - self.center) * self.scale
    }

    /// VLF point → world point.
    pub fn inverse(&self, q: Vec3) -> Vec3 {
        q / self.scale + self.center
    }

    /// World vector (direction × length) → VLF vector.
    pub fn apply_vector(&self, v: Vec3) -> Vec3 {
        v * self.scale
    }

    /// World length → VLF length.
    pub fn apply_length(&self, l: f32) -> f32 {
        l * self.scale
    }

    /// World area → VLF area.
    pub fn apply_area(&self, a: f32) -> f32 {
        a * self.scale * self.scale
    }
}

/// Bounding-box centre and the largest scale keeping every vertex within
/// `1 − MARGIN` of it, checked in `f32` exactly as [`Similarity::apply`] computes.
fn fit_similarity(triangles: &[Triangle], bounds: &Aabb) -> Similarity {
    let center = bounds.center();
    let c64 = center.as_dvec3();
    let radius = triangles
        .iter()
        .flat_map(|t| t.p)
        .map(|p| (p.as_dvec3() - c64).length())
        .fold(0.0f64, f64::max);
    let target = f64::from(1.0 - Similarity::MARGIN);
    let mut sim = Similarity {
        center,
        scale: if radius > 0.0 {
            (target / radius) as f32
        } else {
            1.0
        },
    };
    if !sim.scale.is_finite() {
        sim.scale = f32::MAX; // sub-normal scenes
    }
    for _ in 0..8 {
        let max = triangles
            .iter()
            .flat_map(|t| t.p)
            .map(|p| sim.apply(p).length())
            .fold(0.0f32, f32::max);
        if max <= 1.0 - Similarity::MARGIN || !max.is_finite() {
            break;
        }
        sim.scale *= (1.0 - Similarity::MARGIN) / max * (1.0 - 1e-6);
    }
    sim
}

/// An imported scene, in world coordinates (see the module docs for conventions).
///
/// Triangles are ordered by face: face `f` owns `triangles[faces[f].triangles]`.
/// Faces are numbered in the order of their first triangle in glTF traversal order
/// (default scene, depth-first, children in file order, primitives in file order),
/// and a face's triangles keep that relative order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// World-space triangles, grouped by face.
    pub triangles: Vec<Triangle>,
    /// Planar polygons.
    pub faces: Vec<Face>,
    /// Materials: the file's materials in file order, then a `"default"` material
    /// if some primitive has none.
    pub materials: Vec<Material>,
    /// Decoded textures referenced by base-colour or emissive slots (only those).
    pub textures: Vec<Texture>,
    /// Perspective cameras in scene traversal order.
    pub cameras: Vec<Camera>,
    /// Directional lights.
    pub suns: Vec<Sun>,
    /// Point and spot lights.
    #[serde(default)]
    pub lights: Vec<PunctualLight>,
    /// The subsurface model of each material, by material index (`docs/SUBSURFACE.md`); a
    /// material past its end is opaque ([`Scene::translucency_of`]).
    #[serde(default)]
    pub translucency: Vec<Translucency>,
    /// Bounds of all triangle vertices.
    pub bounds: Aabb,
    /// World → VLF coordinates.
    pub to_vlf: Similarity,
    /// Every non-fatal problem met while importing, each naming the element.
    pub warnings: Vec<String>,
    /// The file this scene was read from.
    pub source: PathBuf,
}

/// Counts describing a [`Scene`] (for `vlf-bake info`, `--json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneSummary {
    /// Source file.
    pub source: String,
    /// Number of triangles.
    pub triangles: usize,
    /// Number of planar polygons.
    pub faces: usize,
    /// Number of materials.
    pub materials: usize,
    /// Materials of kind Diffuse.
    pub diffuse_materials: usize,
    /// Materials of kind Mirror.
    pub mirror_materials: usize,
    /// Materials of kind Mixed.
    pub mixed_materials: usize,
    /// Emissive materials used by at least one triangle.
    pub emissive_materials: usize,
    /// Faces with an emissive material.
    pub emissive_faces: usize,
    /// Triangles with an emissive material.
    pub emissive_triangles: usize,
    /// Cameras.
    pub cameras: usize,
    /// Directional lights.
    pub suns: usize,
    /// Decoded textures.
    pub textures: usize,
    /// Bounding box minimum.
    pub bounds_min: [f32; 3],
    /// Bounding box maximum.
    pub bounds_max: [f32; 3],
    /// Number of import warnings.
    pub warnings: usize,
}

impl Scene {
    /// Triangles of face `face`.
    pub fn face_triangles(&self, face: usize) -> &[Triangle] {
        let r = &self.faces[face].triangles;
        &self.triangles[r.start as usize..r.end as usize]
    }

    /// The subsurface model of material `material` ([`Translucency::None`] when it has none).
    pub fn translucency_of(&self, material: u32) -> Translucency {
        self.translucency
            .get(material as usize)
            .copied()
            .unwrap_or_default()
    }

    /// Whether any face has a translucent material (light crossing surfaces).
    pub fn has_translucency(&self) -> bool {
        self.translucency.iter().any(Translucency::is_translucent)
            && self
                .faces
                .iter()
                .any(|f| self.translucency_of(f.material).is_translucent())
    }

    /// Every material's subsurface model, for reports (`vlf-bake inspect`).
    pub fn material_translucency(&self) -> Vec<MaterialTranslucency> {
        self.materials
            .iter()
            .enumerate()
            .map(|(i, m)| MaterialTranslucency {
                material: m.name.clone(),
                translucency: self.translucency_of(i as u32),
            })
            .collect()
    }

    /// Whether any triangle uses an emissive material.
    pub fn has_emitters(&self) -> bool {
        self.faces
            .iter()
            .any(|f| self.materials[f.material as usize].is_emissive())
    }

    /// Whether anything lights the scene by itself (the sky aside): an emissive triangle, a
    /// sun or a point or spot light.
    pub fn has_lights(&self) -> bool {
        self.has_emitters() || !self.suns.is_empty() || !self.lights.is_empty()
    }

    /// Counts for reports.
    pub fn summary(&self) -> SceneSummary {
        let mut used = vec![false; self.materials.len()];
        for f in &self.faces {
            used[f.material as usize] = true;
        }
        let emissive = |m: u32| self.materials[m as usize].is_emissive();
        let count_kind = |pred: fn(&MaterialKind) -> bool| {
            self.materials.iter().filter(|m| pred(&m.kind)).count()
        };
        SceneSummary {
            source: self.source.display().to_string(),
            triangles: self.triangles.len(),
            faces: self.faces.len(),
            materials: self.materials.len(),
            diffuse_materials: count_kind(|k| matches!(k, MaterialKind::Diffuse)),
            mirror_materials: count_kind(|k| matches!(k, MaterialKind::Mirror)),
            mixed_materials: count_kind(|k| matches!(k, MaterialKind::Mixed { .. })),
            emissive_materials: self
                .materials
                .iter()
                .zip(&used)
                .filter(|(m, u)| **u && m.is_emissive())
                .count(),
            emissive_faces: self.faces.iter().filter(|f| emissive(f.material)).count(),
            emissive_triangles: self
                .triangles
                .iter()
                .filter(|t| emissive(t.material))
                .count(),
            cameras: self.cameras.len(),
            suns: self.suns.len(),
            textures: self.textures.len(),
            bounds_min: self.bounds.min.to_array(),
            bounds_max: self.bounds.max.to_array(),
            warnings: self.warnings.len(),
        }
    }
}

/// Loads a glTF 2.0 file (`.gltf` with external or embedded buffers, or `.glb`).
///
/// The default scene (scene 0 when the file names none) is traversed with node
/// transforms applied. See the module documentation for the conventions and for
/// which problems are errors and which are warnings.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    gltf_import::load(path)
}

/// Checks that something lights the scene: an emissive material used by a
/// triangle, a sun, a point or spot light, or a non-zero sky radiance.
pub fn check_lighting(scene: &Scene, sky: Option<Vec3>) -> Result<(), SceneError> {
    let sky_lit = sky.is_some_and(|s| s.is_finite() && s.max_element() > 0.0);
    if scene.has_lights() || sky_lit {
        Ok(())
    } else {
        Err(SceneError::NothingLit {
            path: scene.source.clone(),
        })
    }
}
