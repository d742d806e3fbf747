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
//!   world space.
//! - **Shading normals**: a primitive's `NORMAL`s are shading normals ([`Triangle::normals`]),
//!   transformed with the inverse transpose of the node's world matrix and renormalised. Faces
//!   stay planar (the light field is stored on them); only shading reads the interpolated
//!   normal. A triangle whose three normals agree with its geometric normal within 0.08°
//!   ([`FACE_COS_TOLERANCE`]) is stored flat (`None`), so flat meshes exported with normals
//!   shade exactly as without them. Normals that are not finite, zero, or on the back of their
//!   triangle (dot ≤ 0 with its geometric normal) are replaced by the geometric normal, with
//!   one warning per primitive instance giving their number. [`Scene::flatten_normals`] drops
//!   them all (`--flat-normals`).
//! - **Vertex colours**: `COLOR_0` (VEC3 or VEC4, float or normalised unsigned byte/short,
//!   linear) multiplies the base colour factor and texture ([`Triangle::colors`]; alpha is
//!   not read). Non-finite components read 1 and values are clamped to [0, 1], with a warning.
//! - **Texture coordinates**: `TEXCOORD_0` and `TEXCOORD_1` are imported; each texture slot
//!   reads the set its `textureInfo.texCoord` names ([`TexRef::texcoord`]; sets above 1 are
//!   read as set 0 with a warning).
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
mod lights;
mod material;
mod texture;
mod translucency;
mod uri;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec2, Vec3};
use serde::{Deserialize, Serialize};

pub use builder::SceneBuilder;
pub use error::SceneError;
pub use lights::{PunctualKind, PunctualLight, Sun};
pub use material::{
    AlphaMode, DEFAULT_IOR, DIFFUSE_MAX_METALLIC, METAL_MIN_METALLIC, MIRROR_MAX_ROUGHNESS,
    Material, MaterialKind, TexRef, Transparency, lobes, pane_reflectance,
};
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
    /// Unit shading normals at the corners (world space, each on the front side of the
    /// triangle: dot > 0 with [`Triangle::normal`]); `None` for a flat triangle.
    #[serde(default)]
    pub normals: Option<[Vec3; 3]>,
    /// `COLOR_0` at the corners (linear RGB in [0, 1]); `None` without vertex colours.
    #[serde(default)]
    pub colors: Option<[Vec3; 3]>,
    /// `TEXCOORD_1` at the corners; `None` when the primitive has none (reads 0).
    #[serde(default)]
    pub uv1: Option<[Vec2; 3]>,
}

/// A triangle's corners beyond their positions: what [`SceneBuilder::triangle_with`] takes
/// (the fields of [`Triangle`] of the same names).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Corners {
    pub uv: [Vec2; 3],
    pub uv1: Option<[Vec2; 3]>,
    pub normals: Option<[Vec3; 3]>,
    pub colors: Option<[Vec3; 3]>,
}

/// Barycentric blend `a·(1 − b1 − b2) + b·b1 + c·b2` of three corner values.
pub fn blend<T>(v: &[T; 3], b1: f32, b2: f32) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    v[0] * (1.0 - b1 - b2) + v[1] * b1 + v[2] * b2
}

impl Triangle {
    /// The corner texture coordinates of set `set` (0 or 1; a missing `TEXCOORD_1` reads 0).
    pub fn uv_set(&self, set: u32) -> [Vec2; 3] {
        if set == 1 {
            self.uv1.unwrap_or([Vec2::ZERO; 3])
        } else {
            self.uv
        }
    }

    /// Texture coordinates of set `set` at barycentrics `(b1, b2)` (weights of corners 1, 2).
    pub fn uv_at(&self, set: u32, b1: f32, b2: f32) -> Vec2 {
        blend(&self.uv_set(set), b1, b2)
    }

    /// The vertex colour at barycentrics `(b1, b2)`; 1 without vertex colours.
    pub fn color_at(&self, b1: f32, b2: f32) -> Vec3 {
        self.colors.map_or(Vec3::ONE, |c| blend(&c, b1, b2))
    }

    /// The unit shading normal of the front side at barycentrics `(b1, b2)`: the corner
    /// normals interpolated and renormalised; `None` for a flat triangle (its geometric
    /// normal shades it).
    pub fn shading_normal_at(&self, b1: f32, b2: f32) -> Option<Vec3> {
        let n = blend(&self.normals?, b1, b2).normalize_or_zero();
        (n != Vec3::ZERO).then_some(n)
    }

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
    /// Materials (indices) whose glTF `normalTexture` was ignored: normal maps would need
    /// irradiance per direction, which the atlas does not store.
    #[serde(default)]
    pub ignored_normal_maps: Vec<u32>,
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
    /// Drops every shading normal: all faces shade flat (`--flat-normals`; the shared
    /// references other than lamp-room are rendered so).
    pub fn flatten_normals(&mut self) {
        for t in &mut self.triangles {
            t.normals = None;
        }
    }

    /// Whether a material is (in part) a thin glass pane ([`Material::pane_weight`]).
    pub fn has_panes(&self) -> bool {
        self.materials.iter().any(|m| m.pane_weight() > 0.0)
    }

    /// Whether some triangle has shading normals.
    pub fn has_smooth_normals(&self) -> bool {
        self.triangles.iter().any(|t| t.normals.is_some())
    }

    /// Whether some triangle has vertex colours.
    pub fn has_vertex_colors(&self) -> bool {
        self.triangles.iter().any(|t| t.colors.is_some())
    }

    /// Whether some material reads a texture with `TEXCOORD_1`.
    pub fn uses_texcoord1(&self) -> bool {
        self.materials.iter().any(|m| {
            [m.base_color_texture, m.emissive_texture]
                .iter()
                .flatten()
                .any(|t| t.texcoord == 1)
        })
    }

    /// Per material: how its triangles shade (`vlf-bake inspect`).
    pub fn material_shading(&self) -> Vec<MaterialShading> {
        let mut out: Vec<MaterialShading> = self
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| MaterialShading {
                name: m.name.clone(),
                triangles: 0,
                smooth_triangles: 0,
                colored_triangles: 0,
                base_color_texcoord: m.base_color_texture.map(|t| t.texcoord),
                emissive_texcoord: m.emissive_texture.map(|t| t.texcoord),
                normal_map_ignored: self.ignored_normal_maps.contains(&(i as u32)),
            })
            .collect();
        for t in &self.triangles {
            let m = &mut out[t.material as usize];
            m.triangles += 1;
            m.smooth_triangles += usize::from(t.normals.is_some());
            m.colored_triangles += usize::from(t.colors.is_some());
        }
        out
    }

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

/// How one material's triangles shade: smooth or flat, vertex colours, texture coordinate sets
/// (for `vlf-bake inspect`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MaterialShading {
    pub name: String,
    /// Triangles using the material, those with shading normals (smooth) and those with
    /// vertex colours.
    pub triangles: usize,
    pub smooth_triangles: usize,
    pub colored_triangles: usize,
    /// The texture coordinate set of the base-colour and emissive textures, where there are.
    pub base_color_texcoord: Option<u32>,
    pub emissive_texcoord: Option<u32>,
    /// Whether the material's `normalTexture` was ignored.
    pub normal_map_ignored: bool,
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
