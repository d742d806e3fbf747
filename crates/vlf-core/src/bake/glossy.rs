//! How the bake models each material's metal lobe (`docs/PROPAGATION.md`): a perfect mirror, a glossy
//! GGX lobe carried in directional tiles, or — when the lobe is so wide that it reflects
//! almost like a Lambertian surface — folded into the diffuse part. The rules, and why:
//!
//! * **Narrower than the direction spacing → mirror.** The light field resolves directions to
//!   its spacing δ ≈ √(4π / 2l): a lobe whose core is narrower reflects into the three
//!   directions around the mirror direction as a perfect mirror does (barycentric weights),
//!   scaled by its directional albedo so that it loses what the GGX lobe loses. The lobe's
//!   width is measured as the cone around the mirror direction that holds half of its
//!   reflected light: GGX puts half of its microfacet normals within `tan θ_h = α`, so the
//!   cone's half-angle is `2 atan α`.
//! * **Wider than [`DIFFUSE_MIN_ALPHA`] → diffuse.** Its albedo is then the lobe's
//!   hemispherical albedo × C (what it reflects of uniform light), so the energy stays right.
//! * **Between them → directional tiles**: the face keeps per-direction tiles like a mirror,
//!   and the reflect step spreads the light of each incoming direction over the fixed
//!   directions of the lobe (`reference::lobe`).
//!
//! `vlf-bake bake --json` reports the choice per material ([`MaterialModel`]).

use glam::Vec3;
use serde::Serialize;

use crate::directions::DirectionSet;
use crate::pathtrace::material::GgxAlbedo;
use crate::scene::{Material, MaterialKind};

/// GGX α from which a metal lobe is folded into the diffuse part.
pub const DIFFUSE_MIN_ALPHA: f32 = 0.6;
/// A lobe whose half-light cone (half-angle `2 atan α`) is narrower than this many direction
/// spacings is modelled as a mirror.
pub const MIRROR_MAX_SPACINGS: f32 = 1.0;

/// How the bake models a face's metal lobe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum SpecularModel {
    /// No metal lobe (a diffuse material).
    None,
    /// Reflected into the three fixed directions around the mirror direction: a perfect
    /// mirror (α = 0) or a lobe narrower than the direction spacing (scaled by its
    /// directional albedo).
    Mirror { alpha: f32 },
    /// Directional tiles, the reflect step spreading each incoming direction over the lobe.
    Tiles { alpha: f32 },
    /// Folded into the diffuse part with its hemispherical albedo.
    Diffuse { alpha: f32 },
    /// A thin glass pane (`docs/TRANSMISSION.md`): reflected as a perfect mirror scaled by R(θ)
    /// (`scene::pane_reflectance`), the rest passed straight through by the interface step;
    /// a metal lobe of the same material is folded into the diffuse part.
    Pane { ior: f32 },
}

impl SpecularModel {
    /// The GGX α of the modelled lobe (0 for a perfect mirror or no lobe).
    pub fn alpha(&self) -> f32 {
        match *self {
            SpecularModel::None | SpecularModel::Pane { .. } => 0.0,
            SpecularModel::Mirror { alpha }
            | SpecularModel::Tiles { alpha }
            | SpecularModel::Diffuse { alpha } => alpha,
        }
    }

    /// Whether the face keeps directional tiles (mirror or glossy).
    pub fn has_tiles(&self) -> bool {
        matches!(
            self,
            SpecularModel::Mirror { .. } | SpecularModel::Tiles { .. } | SpecularModel::Pane { .. }
        )
    }
}

/// Half-angle (radians) of the cone around the mirror direction that holds half of the light
/// a GGX lobe of roughness α reflects.
pub fn lobe_width(alpha: f32) -> f32 {
    2.0 * alpha.atan()
}

/// Angular spacing δ ≈ √(4π / 2l) of a direction set (radians).
pub fn spacing(set: &DirectionSet) -> f32 {
    (4.0 * std::f32::consts::PI / set.sphere_vertex_count() as f32).sqrt()
}

/// The model of `material`'s metal lobe on a direction set of spacing `spacing` (radians);
/// `None` for the spacing models every lobe that is not folded into the diffuse part as a
/// mirror (used where no direction set is known, e.g. the final gather's atlas, which only
/// needs the diffuse albedo).
pub fn model(material: &Material, spacing: Option<f32>) -> SpecularModel {
    if material.pane_weight() > 0.0 {
        return SpecularModel::Pane {
            ior: material.transparency.ior,
        };
    }
    if matches!(material.kind, MaterialKind::Diffuse) {
        return SpecularModel::None;
    }
    let alpha = material.specular_alpha();
    if alpha >= DIFFUSE_MIN_ALPHA {
        return SpecularModel::Diffuse { alpha };
    }
    match spacing {
        Some(d) if alpha > 0.0 && lobe_width(alpha) >= MIRROR_MAX_SPACINGS * d => {
            SpecularModel::Tiles { alpha }
        }
        _ => SpecularModel::Mirror { alpha },
    }
}

/// A material as the bake sees it: its metal lobe's model and the reflectance factors of its
/// two parts (multiply by the base-colour texture where there is one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakedMaterial {
    pub model: SpecularModel,
    /// Lambertian albedo: the Lambert lobe's, plus the metal lobe's × its hemispherical
    /// albedo when it is folded into the diffuse part.
    pub diffuse: Vec3,
    /// The same as a weight of `baseColorFactor` (`diffuse` = base colour × this): what the
    /// renderer multiplies the base-colour texture with per pixel.
    pub diffuse_weight: f32,
    /// Reflectance of the metal lobe where it keeps directional tiles (zero otherwise).
    pub specular: Vec3,
}

/// Every material of `materials` as baked on a direction set of spacing `spacing` (see
/// [`model`]).
pub fn baked_materials(materials: &[Material], spacing: Option<f32>) -> Vec<BakedMaterial> {
    materials
        .iter()
        .map(|m| {
            let model = model(m, spacing);
            let (diffuse_weight, specular) = match model {
                SpecularModel::Diffuse { alpha } => {
                    let fold = m.specular_weight() * GgxAlbedo::new(alpha).hemispherical();
                    (m.diffuse_weight() + fold, Vec3::ZERO)
                }
                SpecularModel::None => (m.diffuse_weight(), Vec3::ZERO),
                SpecularModel::Mirror { .. } | SpecularModel::Tiles { .. } => {
                    (m.diffuse_weight(), m.specular_reflectance())
                }
                SpecularModel::Pane { .. } => {
                    // The pane's reflection is untinted; a metal lobe beside it is folded.
                    let alpha = m.specular_alpha();
                    let albedo = if alpha > 0.0 {
                        GgxAlbedo::new(alpha).hemispherical()
                    } else {
                        1.0
                    };
                    (
                        m.diffuse_weight() + m.specular_weight() * albedo,
                        Vec3::splat(m.pane_weight()),
                    )
                }
            };
            BakedMaterial {
                model,
                diffuse: m.base_color * diffuse_weight,
                diffuse_weight,
                specular,
            }
        })
        .collect()
}

/// What `--json` reports per material.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialModel {
    pub material: String,
    pub metallic: f32,
    pub roughness: f32,
    #[serde(flatten)]
    pub model: SpecularModel,
    /// Half-angle of the lobe's half-light cone against the direction spacing (radians).
    pub lobe_width: f32,
    pub spacing: f32,
}

/// The model of every material of `materials` on `set`.
pub fn report(materials: &[Material], set: &DirectionSet) -> Vec<MaterialModel> {
    let d = spacing(set);
    materials
        .iter()
        .map(|m| {
            let model = model(m, Some(d));
            MaterialModel {
                material: m.name.clone(),
                metallic: m.metallic,
                roughness: m.roughness,
                model,
                lobe_width: lobe_width(model.alpha()),
                spacing: d,
            }
        })
        .collect()
}
