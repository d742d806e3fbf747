//! Materials as the importer reads them: the glTF metallic-roughness lobes under the shared
//! conventions (`shared/reference/README.md`), alpha masks and thin glass panes.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Reference to an entry of [`Scene::textures`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TexRef {
    /// Index into [`Scene::textures`] (not the glTF texture index).
    pub index: u32,
    /// The texture coordinate set the texture is read with: 0 ([`Triangle::uv`]) or 1
    /// ([`Triangle::uv1`]); the importer reads larger glTF `texCoord`s as 0 (with a warning).
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
    /// Where the surface lets light through: alpha cut-outs and thin glass panes.
    pub transparency: Transparency,
}

/// glTF `alphaMode`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum AlphaMode {
    /// Alpha is ignored.
    #[default]
    Opaque,
    /// Where the coverage α (baseColorFactor.a × the base-colour texture's alpha) is below
    /// [`Transparency::alpha_cutoff`] there is no surface.
    Mask,
    /// Coverage approximated by a threshold at α = ½: modelled as [`Mask`](AlphaMode::Mask) with a
    /// cutoff of 0.5 (see `docs/PROPAGATION.md`, *Alpha masks*).
    Blend,
}

/// How a material lets light through (`shared/reference/README.md`: *Alpha*, *Thin
/// transmission*).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transparency {
    /// glTF `alphaMode`.
    pub alpha_mode: AlphaMode,
    /// glTF `alphaCutoff` (0.5 unless the file says otherwise; 0.5 for [`AlphaMode::Blend`]).
    pub alpha_cutoff: f32,
    /// baseColorFactor.a, clamped to [0, 1].
    pub alpha: f32,
    /// `KHR_materials_transmission`'s transmissionFactor in [0, 1]: the share of the
    /// non-metal part that is a thin glass pane ([`Material::pane_weight`]).
    pub transmission: f32,
    /// `KHR_materials_ior` (1.5 when absent): the pane's index of refraction.
    pub ior: f32,
}

impl Default for Transparency {
    fn default() -> Self {
        Transparency {
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            alpha: 1.0,
            transmission: 0.0,
            ior: DEFAULT_IOR,
        }
    }
}

/// The index of refraction of a pane without `KHR_materials_ior` (the extension's default).
pub const DEFAULT_IOR: f32 = 1.5;

/// The reflectance of a thin pane of index `ior` in air at incidence cosine `cos` (either
/// side): both interfaces and their interreflections, Mitsuba's `thindielectric`,
/// R = r + (1 − r)² r / (1 − r²) = 2r / (1 + r) with r the unpolarised Fresnel reflectance of
/// one interface; the pane transmits T = 1 − R straight through (no refraction). The f32
/// operations are those of `pane_reflectance` in `shaders/common/pane.wgsl` (the propagation
/// stays bit-identical on the GPU).
pub fn pane_reflectance(cos: f32, ior: f32) -> f32 {
    let c = cos.abs().min(1.0);
    let s2 = (1.0 - c * c) / (ior * ior);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2).sqrt();
    let rs = (c - ior * ct) / (c + ior * ct);
    let rp = (ior * c - ct) / (ior * c + ct);
    let r = 0.5 * (rs * rs + rp * rp);
    2.0 * r / (1.0 + r)
}

impl Transparency {
    /// Whether alpha cuts holes into the surface (masks, and blends modelled as masks).
    pub fn masks(&self) -> bool {
        self.alpha_mode != AlphaMode::Opaque
    }

    /// The cutoff in effect: `alpha_cutoff` for masks, ½ for blends.
    pub fn cutoff(&self) -> f32 {
        match self.alpha_mode {
            AlphaMode::Blend => 0.5,
            _ => self.alpha_cutoff,
        }
    }
}

impl Material {
    /// Weight of the Lambertian lobe: 1, 0 or `1 − specular` ([`non_metal_weight`](Self::non_metal_weight)),
    /// less the pane's share of it ([`pane_weight`](Self::pane_weight)).
    pub fn diffuse_weight(&self) -> f32 {
        self.non_metal_weight() - self.pane_weight()
    }

    /// Weight of the non-metal part (Lambert and pane together): 1, 0 or `1 − specular`.
    pub fn non_metal_weight(&self) -> f32 {
        match self.kind {
            MaterialKind::Diffuse => 1.0,
            MaterialKind::Mirror => 0.0,
            MaterialKind::Mixed { specular } => 1.0 - specular,
        }
    }

    /// Weight of the thin glass pane (`KHR_materials_transmission`, shared conventions):
    /// transmissionFactor × the non-metal weight (1 − metallic with the metallic thresholds of
    /// [`MaterialKind`]). A pane reflects R(θ) as a mirror, untinted, and passes T(θ) = 1 − R(θ)
    /// straight through tinted by the base colour ([`pane_reflectance`]).
    pub fn pane_weight(&self) -> f32 {
        self.transparency.transmission * self.non_metal_weight()
    }

    /// Weight of the metal lobe: 0, 1 or `specular`.
    pub fn specular_weight(&self) -> f32 {
        1.0 - self.non_metal_weight()
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

    /// How vlf models the material, in words (`vlf-bake inspect`): its lobes, then what lets
    /// light through it, e.g. `diffuse, alpha mask (cutoff 0.5, baseColorFactor.a 1)`.
    pub fn model(&self) -> String {
        let metal = if self.specular_alpha() > 0.0 {
            format!("GGX metal (α {:.3})", self.specular_alpha())
        } else {
            "mirror".to_string()
        };
        let t = &self.transparency;
        let (d, p, m) = (
            self.diffuse_weight(),
            self.pane_weight(),
            self.specular_weight(),
        );
        let mut parts = Vec::new();
        if d > 0.0 {
            parts.push((d, "diffuse".to_string()));
        }
        if p > 0.0 {
            parts.push((
                p,
                format!(
                    "thin glass pane (IOR {}, transmission tinted by the base colour)",
                    t.ior
                ),
            ));
        }
        if m > 0.0 {
            parts.push((m, metal));
        }
        let mut s = match parts.as_slice() {
            [] => "black".to_string(),
            [(_, one)] => one.clone(),
            _ => parts
                .iter()
                .map(|(w, n)| format!("{w:.2} {n}"))
                .collect::<Vec<_>>()
                .join(" + "),
        };
        if self.is_emissive() {
            s += ", emissive";
        }
        match t.alpha_mode {
            AlphaMode::Opaque => {}
            AlphaMode::Mask => {
                s += &format!(
                    ", alpha mask (cutoff {}, baseColorFactor.a {})",
                    t.alpha_cutoff, t.alpha
                )
            }
            AlphaMode::Blend => {
                s += &format!(
                    ", alpha blend modelled as a mask at ½ (baseColorFactor.a {})",
                    t.alpha
                )
            }
        }
        s
    }
}
