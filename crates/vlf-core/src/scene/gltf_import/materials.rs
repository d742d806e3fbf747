//! Materials and textures: metallic-roughness materials mapped to their lobes (diffuse, metal,
//! mixed), emission, and PNG/JPEG textures with their samplers.

use std::path::Path;

use glam::Vec3;
use gltf::json::{self, Value, validation::Checked};

use super::{Importer, element, short};
use crate::scene::texture::{self, FilterMode, Texture, WrapMode};
use crate::scene::uri;
use crate::scene::{
    AlphaMode, DEFAULT_IOR, Material, MaterialKind, SceneError, TexRef, Transparency,
};

/// Decoded textures larger than this many texels are rejected (16 bytes each).
const MAX_TEXELS: u64 = 1 << 25;
impl Importer<'_> {
    pub(super) fn convert_materials(&mut self) -> Result<(), SceneError> {
        for i in 0..self.root.materials.len() {
            let m = self.convert_material(i)?;
            self.materials.push(m);
        }
        Ok(())
    }

    fn clamp_factor(&mut self, el: &str, what: &str, v: f32, lo: f32, hi: f32) -> f32 {
        if v.is_finite() && (lo..=hi).contains(&v) {
            return v;
        }
        let fixed = if v.is_finite() { v.clamp(lo, hi) } else { lo };
        self.warn(format!(
            "{el}: {what} {v} is outside [{lo}, {hi}]; using {fixed}"
        ));
        fixed
    }

    fn convert_material(&mut self, i: usize) -> Result<Material, SceneError> {
        let m = self.root.materials[i].clone();
        let el = element("material", i, m.name.as_ref());
        let pbr = &m.pbr_metallic_roughness;
        let f = pbr.base_color_factor.0;
        let mut base = [0.0f32; 3];
        for c in 0..3 {
            base[c] = self.clamp_factor(&el, "baseColorFactor component", f[c], 0.0, 1.0);
        }
        let metallic = self.clamp_factor(&el, "metallicFactor", pbr.metallic_factor.0, 0.0, 1.0);
        let roughness = self.clamp_factor(&el, "roughnessFactor", pbr.roughness_factor.0, 0.0, 1.0);
        let e = m.emissive_factor.0;
        let mut emissive = [0.0f32; 3];
        for c in 0..3 {
            emissive[c] = self.clamp_factor(&el, "emissiveFactor component", e[c], 0.0, 1.0);
        }
        let strength = m
            .extensions
            .as_ref()
            .and_then(|x| x.emissive_strength.as_ref())
            .map_or(1.0, |s| s.emissive_strength.0);
        let strength = self.clamp_factor(&el, "emissiveStrength", strength, 0.0, f32::MAX);

        // The metal lobe's roughness is kept as read: how the baker models a rough metal
        // (mirror, directional tiles, or diffuse) depends on its direction set (`bake::glossy`).
        let kind = MaterialKind::from_metallic(metallic);

        let mut transparency = self.transparency(&m, &el);
        self.read_transmission(i, &el, roughness, &mut transparency);
        self.warn_material_extensions(i, &el);

        let base_color_texture = match &pbr.base_color_texture {
            Some(info) => Some(self.texture_ref(info, &format!("{el} baseColorTexture"))?),
            None => None,
        };
        let emissive_texture = match &m.emissive_texture {
            Some(info) => Some(self.texture_ref(info, &format!("{el} emissiveTexture"))?),
            None => None,
        };
        // Not a warning (every normal-mapped scene would warn): `vlf-bake inspect` lists them.
        if m.normal_texture.is_some() {
            log::info!(
                "{el}: normalTexture is ignored (a normal map needs irradiance per direction, which the atlas does not store)"
            );
            self.ignored_normal_maps.push(i as u32);
        }
        Ok(Material {
            name: m.name.clone().unwrap_or_else(|| format!("material {i}")),
            base_color: Vec3::from_array(base),
            base_color_texture,
            emission: Vec3::from_array(emissive) * strength,
            emissive_texture,
            double_sided: m.double_sided,
            kind,
            metallic,
            roughness,
            transparency,
        })
    }

    /// `alphaMode`, `alphaCutoff` and baseColorFactor.a (`Transparency`).
    fn transparency(&mut self, m: &json::Material, el: &str) -> Transparency {
        let mode = match m.alpha_mode {
            Checked::Valid(json::material::AlphaMode::Mask) => AlphaMode::Mask,
            Checked::Valid(json::material::AlphaMode::Blend) => AlphaMode::Blend,
            Checked::Valid(json::material::AlphaMode::Opaque) => AlphaMode::Opaque,
            Checked::Invalid => {
                self.warn(format!("{el}: unknown alphaMode; treated as OPAQUE"));
                AlphaMode::Opaque
            }
        };
        let mut t = Transparency {
            alpha_mode: mode,
            ..Transparency::default()
        };
        if mode == AlphaMode::Opaque {
            return t;
        }
        let a = m.pbr_metallic_roughness.base_color_factor.0[3];
        t.alpha = self.clamp_factor(el, "baseColorFactor alpha", a, 0.0, 1.0);
        if let Some(c) = m.alpha_cutoff {
            t.alpha_cutoff = self.clamp_factor(el, "alphaCutoff", c.0, 0.0, f32::MAX);
        }
        t
    }

    /// `KHR_materials_transmission` (a thin pane, shared conventions) and `KHR_materials_ior`,
    /// from the raw JSON; what of them is not modelled is a warning.
    fn read_transmission(&mut self, i: usize, el: &str, roughness: f32, t: &mut Transparency) {
        let Some(exts) = self
            .raw
            .get("materials")
            .and_then(|m| m.get(i))
            .and_then(|m| m.get("extensions"))
            .cloned()
        else {
            return;
        };
        if let Some(tr) = exts.get("KHR_materials_transmission") {
            let f = tr
                .get("transmissionFactor")
                .and_then(Value::as_f64)
                .unwrap_or(0.0) as f32;
            t.transmission = self.clamp_factor(el, "transmissionFactor", f, 0.0, 1.0);
            if tr.get("transmissionTexture").is_some() {
                self.warn(format!(
                    "{el}: transmissionTexture is ignored (transmissionFactor {} everywhere)",
                    t.transmission
                ));
            }
            if t.transmission > 0.0 && roughness > crate::scene::MIRROR_MAX_ROUGHNESS {
                self.warn(format!(
                    "{el}: rough transmission (roughness {roughness}) is modelled as a smooth thin pane"
                ));
            }
            if t.transmission > 0.0 && exts.get("KHR_materials_volume").is_some() {
                self.warn(format!(
                    "{el}: KHR_materials_volume is not modelled: a thin pane (no refraction, no absorption in the volume)"
                ));
            }
        }
        if let Some(ior) = exts.get("KHR_materials_ior") {
            let v = ior
                .get("ior")
                .and_then(Value::as_f64)
                .unwrap_or(f64::from(DEFAULT_IOR)) as f32;
            // The extension allows 0 (meaning an infinite index) and values ≥ 1.
            t.ior = if v.is_finite() && v >= 1.0 {
                v
            } else {
                self.warn(format!(
                    "{el}: ior {v} is not modelled (below 1 or infinite); using {DEFAULT_IOR}"
                ));
                DEFAULT_IOR
            };
        }
    }

    /// Warnings for material extensions that change nothing here, and for
    /// `KHR_texture_transform` (not applied).
    fn warn_material_extensions(&mut self, i: usize, el: &str) {
        let Some(raw) = self.raw.get("materials").and_then(|m| m.get(i)).cloned() else {
            return;
        };
        if let Some(exts) = raw.get("extensions").and_then(Value::as_object) {
            // Transmission and its IOR are read (and a pane's volume warned about) in
            // `read_transmission`; IOR, diffuse transmission, volume and volume scatter in
            // `translucency` (docs/SUBSURFACE.md).
            for name in exts.keys() {
                if !is_modelled(name) {
                    self.warn(format!("{el}: extension {} is ignored", short(name)));
                }
            }
        }
        let slots = [
            (
                "baseColorTexture",
                raw.get("pbrMetallicRoughness")
                    .and_then(|p| p.get("baseColorTexture")),
            ),
            ("emissiveTexture", raw.get("emissiveTexture")),
        ];
        for (slot, info) in slots {
            let Some(tt) = info
                .and_then(|x| x.get("extensions"))
                .and_then(|x| x.get("KHR_texture_transform"))
            else {
                continue;
            };
            let num = |key: &str, idx: Option<usize>, default: f64| -> f64 {
                let v = tt.get(key);
                let v = match idx {
                    Some(k) => v.and_then(|a| a.get(k)),
                    None => v,
                };
                v.and_then(Value::as_f64).unwrap_or(default)
            };
            let identity = num("offset", Some(0), 0.0) == 0.0
                && num("offset", Some(1), 0.0) == 0.0
                && num("rotation", None, 0.0) == 0.0
                && num("scale", Some(0), 1.0) == 1.0
                && num("scale", Some(1), 1.0) == 1.0;
            if !identity {
                self.warn(format!(
                    "{el} {slot}: KHR_texture_transform is not applied (texture coordinates used as is)"
                ));
            }
        }
    }

    fn texture_ref(&mut self, info: &json::texture::Info, el: &str) -> Result<TexRef, SceneError> {
        let ti = info.index.value();
        let texcoord = if info.tex_coord > 1 {
            self.warn(format!(
                "{el}: uses TEXCOORD_{} but only TEXCOORD_0 and TEXCOORD_1 are imported; sampled with TEXCOORD_0",
                info.tex_coord
            ));
            0
        } else {
            info.tex_coord
        };
        if let Some(&index) = self.texture_of_gltf.get(&ti) {
            return Ok(TexRef { index, texcoord });
        }
        let tex = self.root.textures.get(ti).cloned().ok_or_else(|| {
            self.invalid(
                el,
                format!(
                    "texture index {ti} is out of range ({} textures)",
                    self.root.textures.len()
                ),
            )
        })?;
        let tex_el = element("texture", ti, tex.name.as_ref());
        let ii = tex.source.value();
        let image = self.root.images.get(ii).cloned().ok_or_else(|| {
            self.invalid(
                &tex_el,
                format!(
                    "image source {} is missing or out of range ({} images); only PNG and JPEG sources are supported",
                    if ii == u32::MAX as usize { "(none)".to_string() } else { ii.to_string() },
                    self.root.images.len()
                ),
            )
        })?;
        let img_el = element("image", ii, image.name.as_ref());
        let (bytes, file) = if let Some(view) = image.buffer_view {
            let vi = view.value();
            let len = self
                .root
                .buffer_views
                .get(vi)
                .map_or(0, |v| v.byte_length.0);
            let (bytes, _) = self.view_slice(&img_el, vi, 0, 1, len, true)?;
            (bytes.to_vec(), format!("bufferView {vi}"))
        } else if let Some(u) = &image.uri {
            match self.read_uri(u) {
                Ok((bytes, file)) => (bytes, file),
                Err((file, reason)) => return Err(self.resource(img_el, file, reason)),
            }
        } else {
            return Err(self.invalid(img_el, "has neither a uri nor a bufferView"));
        };
        let mime = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            "image/png"
        } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
            "image/jpeg"
        } else {
            return Err(self.resource(
                img_el,
                file,
                format!(
                    "unsupported image format{}: only PNG and JPEG are supported",
                    image
                        .mime_type
                        .as_ref()
                        .map(|m| format!(" (mimeType {:?})", short(&m.0)))
                        .unwrap_or_default()
                ),
            ));
        };
        let data = decode_image(&bytes, mime).map_err(|reason| {
            self.resource(
                img_el.clone(),
                file.clone(),
                format!("cannot decode image: {reason}"),
            )
        })?;
        if u64::from(data.width) * u64::from(data.height) > MAX_TEXELS {
            return Err(self.resource(
                img_el,
                file,
                format!(
                    "image of {}×{} texels exceeds the limit of {MAX_TEXELS} texels",
                    data.width, data.height
                ),
            ));
        }
        let (pixels, has_alpha) = texture::to_linear_rgba(&data)
            .map_err(|reason| self.resource(img_el.clone(), file.clone(), reason))?;
        let (mut wrap_s, mut wrap_t, mut filter) =
            (WrapMode::Repeat, WrapMode::Repeat, FilterMode::Linear);
        if let Some(si) = tex.sampler {
            let s = self.root.samplers.get(si.value()).cloned().ok_or_else(|| {
                self.invalid(
                    &tex_el,
                    format!("sampler index {} is out of range", si.value()),
                )
            })?;
            let wrap = |w: Checked<json::texture::WrappingMode>| match w {
                Checked::Valid(json::texture::WrappingMode::ClampToEdge) => {
                    Some(WrapMode::ClampToEdge)
                }
                Checked::Valid(json::texture::WrappingMode::MirroredRepeat) => {
                    Some(WrapMode::MirroredRepeat)
                }
                Checked::Valid(json::texture::WrappingMode::Repeat) => Some(WrapMode::Repeat),
                Checked::Invalid => None,
            };
            match (wrap(s.wrap_s), wrap(s.wrap_t)) {
                (Some(a), Some(b)) => (wrap_s, wrap_t) = (a, b),
                _ => self.warn(format!(
                    "sampler {}: invalid wrap mode; using REPEAT",
                    si.value()
                )),
            }
            if let Some(Checked::Valid(json::texture::MagFilter::Nearest)) = s.mag_filter {
                filter = FilterMode::Nearest;
            }
        }
        let index = self.textures.len() as u32;
        self.textures.push(Texture {
            name: tex.name.clone().or(image.name.clone()),
            width: data.width,
            height: data.height,
            pixels,
            has_alpha,
            wrap_s,
            wrap_t,
            filter,
            gltf_texture: ti as u32,
        });
        self.texture_of_gltf.insert(ti, index);
        Ok(TexRef { index, texcoord })
    }

    pub(super) fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        // glTF default material: base colour 1, metallic 1, roughness 1.
        self.warn(
            "some primitives have no material: using the glTF default material (white, metallic 1, roughness 1: a rough white metal)"
                .to_string(),
        );
        let i = self.materials.len() as u32;
        self.materials.push(Material {
            name: "default".to_string(),
            base_color: Vec3::ONE,
            base_color_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            double_sided: false,
            kind: MaterialKind::Mirror,
            metallic: 1.0,
            roughness: 1.0,
            transparency: Transparency::default(),
        });
        self.default_material = Some(i);
        i
    }
}

/// Whether material extension `name` is read by the importer (here: emissive strength,
/// transmission and its IOR; `translucency`: IOR, diffuse transmission, volume, volume
/// scatter), so that neither a material's nor `extensionsRequired`'s warning calls it ignored.
pub(super) fn is_modelled(name: &str) -> bool {
    [
        "KHR_materials_emissive_strength",
        "KHR_materials_transmission",
        "KHR_materials_ior",
    ]
    .contains(&name)
        || super::translucency::handles(name)
}

/// Decodes PNG/JPEG bytes with the gltf crate's image decoder.
///
/// The bytes are handed over as a data URI, the only way to reach the decoder without
/// the crate's unchecked buffer slicing. The call is wrapped in `catch_unwind` as a
/// last resort against panics inside the third-party decoders on corrupt data.
fn decode_image(bytes: &[u8], mime: &str) -> Result<gltf::image::Data, String> {
    let data_uri = format!("data:{mime};base64,{}", uri::base64_encode(bytes));
    let source = gltf::image::Source::Uri {
        uri: &data_uri,
        mime_type: None,
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        gltf::image::Data::from_source(source, Some(Path::new(".")), &[])
    }));
    match result {
        Ok(Ok(data)) => Ok(data),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => Err("the image decoder panicked on this data".to_string()),
    }
}
