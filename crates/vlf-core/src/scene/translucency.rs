//! The subsurface model of a material (`docs/SUBSURFACE.md`): none, thin diffuse transmission,
//! or a dipole medium. Kept apart from [`super::Material`], by material index in
//! [`super::Scene::translucency`], so that scenes without translucent materials carry nothing.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// How light crosses a material's surface (`docs/SUBSURFACE.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum Translucency {
    /// Opaque: the material's reflection model alone.
    #[default]
    None,
    /// `KHR_materials_diffuse_transmission` on a thin surface: of the irradiance on one side,
    /// `(1 − factor)` × the Lambertian albedo is reflected and `factor × color` × the diffuse
    /// weight leaves from the other side.
    ThinDiffuseTransmission {
        /// `diffuseTransmissionFactor`, in [0, 1].
        factor: f32,
        /// `diffuseTransmissionColorFactor`, in [0, 1]³.
        color: Vec3,
    },
    /// A dense scattering volume bounded by the mesh (front side outside), Jensen's dipole.
    Dipole {
        /// Reduced scattering coefficient σ_s′ per scene unit (rgb).
        sigma_s_prime: Vec3,
        /// Absorption coefficient σ_a per scene unit (rgb).
        sigma_a: Vec3,
        /// Relative index of refraction η ≥ 1.
        eta: f32,
    },
}

impl Translucency {
    /// Whether light crosses the surface (any model but [`Translucency::None`]).
    pub fn is_translucent(&self) -> bool {
        !matches!(self, Translucency::None)
    }

    /// What a texel side of this material reflects of its irradiance, given the material's
    /// Lambertian albedo `albedo` (`side` 0 = front): all of it for opaque materials,
    /// `(1 − factor) × albedo` with thin transmission (the rest of the diffuse part is
    /// transmitted), and the boundary's diffuse Fresnel reflectance F_dr,ext(η) on either side
    /// of a dipole surface (the front's remainder enters the medium; the back, inside a closed
    /// object, is absorbed: `docs/SUBSURFACE.md`).
    pub fn reflected_albedo(&self, albedo: Vec3, _side: usize) -> Vec3 {
        match *self {
            Translucency::None => albedo,
            Translucency::ThinDiffuseTransmission { factor, .. } => albedo * (1.0 - factor),
            Translucency::Dipole { eta, .. } => {
                Vec3::splat(super::dipole::fresnel_diffuse_external(f64::from(eta)) as f32)
            }
        }
    }

    /// A short name for reports: `none`, `thin-diffuse-transmission` or `dipole`.
    pub fn name(&self) -> &'static str {
        match self {
            Translucency::None => "none",
            Translucency::ThinDiffuseTransmission { .. } => "thin-diffuse-transmission",
            Translucency::Dipole { .. } => "dipole",
        }
    }
}

/// A material's name and subsurface model, as `vlf-bake inspect` lists them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialTranslucency {
    pub material: String,
    #[serde(flatten)]
    pub translucency: Translucency,
}

impl std::fmt::Display for MaterialTranslucency {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "material {:?}: {}",
            self.material,
            self.translucency.name()
        )?;
        match self.translucency {
            Translucency::None => Ok(()),
            Translucency::ThinDiffuseTransmission { factor, color } => write!(
                f,
                ", transmits {factor} × ({:.4}, {:.4}, {:.4})",
                color.x, color.y, color.z
            ),
            Translucency::Dipole {
                sigma_s_prime: s,
                sigma_a: a,
                eta,
            } => write!(
                f,
                ", σ_s′ ({:.5}, {:.5}, {:.5}) σ_a ({:.5}, {:.5}, {:.5}) per scene unit, η {eta}",
                s.x, s.y, s.z, a.x, a.y, a.z
            ),
        }
    }
}
