//! The subsurface model of every material, read from the raw JSON of its extensions
//! (`KHR_materials_ior`, `KHR_materials_diffuse_transmission`, `KHR_materials_volume` and the
//! draft `KHR_materials_volume_scatter`, which the gltf crate does not type): the mapping of
//! `docs/SUBSURFACE.md`. Malformed values are errors naming the material and the file.

use glam::Vec3;
use gltf::json::Value;

use super::{Importer, element};
use crate::scene::dipole;
use crate::scene::{SceneError, Translucency};

const IOR: &str = "KHR_materials_ior";
const DIFFUSE_TRANSMISSION: &str = "KHR_materials_diffuse_transmission";
const VOLUME: &str = "KHR_materials_volume";
const VOLUME_SCATTER: &str = "KHR_materials_volume_scatter";

/// Whether the material extension `name` is read here (so `materials` does not call it ignored).
pub(super) fn handles(name: &str) -> bool {
    [IOR, DIFFUSE_TRANSMISSION, VOLUME, VOLUME_SCATTER].contains(&name)
}

/// Smallest attenuation colour channel used for σ_t = −ln(c)/d (c = 0 would be infinite).
const MIN_ATTENUATION_COLOR: f64 = 1e-4;

/// One extension object of a material, with the names its messages need.
struct Ext<'v> {
    obj: Option<&'v serde_json::Map<String, Value>>,
    name: &'static str,
}

impl Importer<'_> {
    /// The subsurface model of every material of the file, by material index.
    pub(super) fn convert_translucency(&mut self) -> Result<Vec<Translucency>, SceneError> {
        let n = self.root.materials.len();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let raw = self
                .raw
                .get("materials")
                .and_then(|m| m.get(i))
                .cloned()
                .unwrap_or(Value::Null);
            let el = element("material", i, self.root.materials[i].name.as_ref());
            out.push(self.translucency_of(&raw, &el)?);
        }
        Ok(out)
    }

    fn translucency_of(&mut self, raw: &Value, el: &str) -> Result<Translucency, SceneError> {
        let exts = raw.get("extensions");
        let ext = |name: &'static str| -> Result<Ext<'_>, SceneError> {
            match exts.and_then(|e| e.get(name)) {
                None => Ok(Ext { obj: None, name }),
                Some(Value::Object(o)) => Ok(Ext { obj: Some(o), name }),
                Some(_) => Err(self.invalid(el, format!("{name} is not a JSON object"))),
            }
        };
        let (ior, dt, vol, sc) = (
            ext(IOR)?,
            ext(DIFFUSE_TRANSMISSION)?,
            ext(VOLUME)?,
            ext(VOLUME_SCATTER)?,
        );
        if ior.obj.is_none() && dt.obj.is_none() && vol.obj.is_none() && sc.obj.is_none() {
            return Ok(Translucency::None);
        }
        let mut eta = self.number(&ior, "ior", 1.5, el)?;
        if eta == 0.0 {
            eta = 1.0; // the spec's "no refraction" (infinitely thin)
        } else if eta.is_nan() || eta < 1.0 {
            // Below 1 (or not finite): the material importer warns and takes the extension's
            // default, as here (`materials::read_transmission`).
            eta = f64::from(crate::scene::DEFAULT_IOR);
        }
        let factor = self.number(&dt, "diffuseTransmissionFactor", 0.0, el)?;
        let color = self.color(&dt, "diffuseTransmissionColorFactor", Vec3::ONE, el)?;
        if factor > 1.0 {
            return Err(self.invalid(
                el,
                format!("{DIFFUSE_TRANSMISSION} diffuseTransmissionFactor {factor} is above 1"),
            ));
        }
        let thickness = self.number(&vol, "thicknessFactor", 0.0, el)?;
        let distance = self.number(&vol, "attenuationDistance", f64::INFINITY, el)?;
        if distance == 0.0 {
            return Err(self.invalid(el, format!("{VOLUME} attenuationDistance must be > 0")));
        }
        let att = self.color(&vol, "attenuationColor", Vec3::ONE, el)?;
        let ms = self.color(&sc, "multiscatterColor", Vec3::ZERO, el)?;
        let g = match sc.obj.and_then(|o| o.get("scatterAnisotropy")) {
            None => 0.0,
            Some(v) => match v.as_f64() {
                Some(g) if g.is_finite() && g > -1.0 && g < 1.0 => g,
                _ => {
                    return Err(self.invalid(
                        el,
                        format!("{VOLUME_SCATTER} scatterAnisotropy {v} is not in (−1, 1)"),
                    ));
                }
            },
        };
        for (ext, keys) in [
            (
                &dt,
                &[
                    "diffuseTransmissionTexture",
                    "diffuseTransmissionColorTexture",
                ][..],
            ),
            (&vol, &["thicknessTexture"][..]),
            (&sc, &["multiscatterColorTexture"][..]),
        ] {
            for k in keys {
                if ext.obj.is_some_and(|o| o.contains_key(*k)) {
                    self.warn(format!("{el}: {} {k} is not read", ext.name));
                }
            }
        }
        let volume = thickness > 0.0;
        if volume && sc.obj.is_some() && ms.max_element() > 0.0 {
            if distance.is_finite() {
                let mut s_prime = [0f32; 3];
                let mut s_a = [0f32; 3];
                for c in 0..3 {
                    let ac = f64::from(att[c]);
                    let sigma_t = if ac < 1.0 {
                        -ac.max(MIN_ATTENUATION_COLOR).ln() / distance
                    } else {
                        1.0 / distance
                    };
                    let alpha = dipole::albedo_for_reflectance(f64::from(ms[c]), eta);
                    let s = alpha * sigma_t / (1.0 - g + alpha * g);
                    s_prime[c] = ((1.0 - g) * s) as f32;
                    s_a[c] = (sigma_t - s).max(0.0) as f32;
                }
                return Ok(Translucency::Dipole {
                    sigma_s_prime: Vec3::from_array(s_prime),
                    sigma_a: Vec3::from_array(s_a),
                    eta: eta as f32,
                });
            }
            self.warn(format!(
                "{el}: {VOLUME_SCATTER} without a finite {VOLUME} attenuationDistance has no length scale; not scattered"
            ));
        } else if sc.obj.is_some() {
            self.warn(format!(
                "{el}: {VOLUME_SCATTER} needs {VOLUME} with thicknessFactor > 0 and a non-zero multiscatterColor; ignored"
            ));
        }
        if dt.obj.is_some() && factor > 0.0 {
            return Ok(Translucency::ThinDiffuseTransmission {
                factor: factor as f32,
                color,
            });
        }
        if vol.obj.is_some() && sc.obj.is_none() {
            self.warn(format!(
                "{el}: {VOLUME} without scattering or diffuse transmission is ignored"
            ));
        }
        Ok(Translucency::None)
    }

    /// A finite, non-negative number of `ext` (`default` when absent; +∞ only as a default).
    fn number(&self, ext: &Ext, key: &str, default: f64, el: &str) -> Result<f64, SceneError> {
        let Some(v) = ext.obj.and_then(|o| o.get(key)) else {
            return Ok(default);
        };
        match v.as_f64() {
            Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
            _ => Err(self.invalid(
                el,
                format!("{} {key} {v} is not a finite number ≥ 0", ext.name),
            )),
        }
    }

    /// An RGB factor of `ext` with components in [0, 1] (`default` when absent).
    fn color(&self, ext: &Ext, key: &str, default: Vec3, el: &str) -> Result<Vec3, SceneError> {
        let Some(v) = ext.obj.and_then(|o| o.get(key)) else {
            return Ok(default);
        };
        let bad = || {
            self.invalid(
                el,
                format!("{} {key} {v} is not three numbers in [0, 1]", ext.name),
            )
        };
        let arr = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
        let mut c = [0f32; 3];
        for k in 0..3 {
            match arr[k].as_f64() {
                Some(x) if (0.0..=1.0).contains(&x) => c[k] = x as f32,
                _ => return Err(bad()),
            }
        }
        Ok(Vec3::from_array(c))
    }
}
