//! Lights that are not surfaces: the sun (`KHR_lights_punctual` "directional") and point and
//! spot lights, as the importer reads them (`docs/LIGHTS.md`).

use glam::Vec3;
use serde::{Deserialize, Serialize};

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
