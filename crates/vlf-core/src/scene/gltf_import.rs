//! glTF 2.0 → [`Scene`].
//!
//! The gltf crate is used for its JSON schema types (`gltf::json::Root`) and its PNG/JPEG
//! decoding only. Container parsing (GLB), URI resolution, buffer loading, accessor
//! reading, node traversal and all index/byte-range validation are done here with
//! checked arithmetic, because the crate's own importer and accessor readers panic on
//! some malformed files (unchecked slicing, `unwrap` on percent-decoding, integer
//! underflow on a short GLB header, an out-of-range POSITION index in validation).

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat4, DQuat, DVec3, Vec2, Vec3};
use gltf::json::{self, Value, validation::Checked};

use super::faces::{RawTriangle, build_faces};
use super::texture::{self, FilterMode, Texture, WrapMode};
use super::uri::{self, UriTarget};
use super::{
    Aabb, Camera, DEGENERATE_AREA_FACTOR, MAX_TRIANGLES, Material, MaterialKind, Scene, SceneError,
    Similarity, Sun, TexRef,
};

/// Sparse accessors without a bufferView allocate `count` zeroed elements; cap the
/// number of components they may allocate.
const MAX_SPARSE_ONLY_VALUES: u64 = 1 << 24;
/// Decoded textures larger than this many texels are rejected (16 bytes each).
const MAX_TEXELS: u64 = 1 << 25;
/// Names quoted in messages are cut to this many characters.
const MAX_NAME_CHARS: usize = 60;

/// Extensions this importer implements (fully or by documented approximation).
const IMPLEMENTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Whether a file that lists `name` in `extensionsRequired` can be imported.
fn required_extension_supported(name: &str) -> bool {
    IMPLEMENTED_EXTENSIONS.contains(&name)
        || (name.starts_with("KHR_materials_") && name != "KHR_materials_pbrSpecularGlossiness")
}

fn short(name: &str) -> String {
    if name.chars().count() > MAX_NAME_CHARS {
        let cut: String = name.chars().take(MAX_NAME_CHARS).collect();
        format!("{cut}…")
    } else {
        name.to_string()
    }
}

/// `kind index` or `kind index ("name")`.
fn element(kind: &str, index: usize, name: Option<&String>) -> String {
    match name {
        Some(n) => format!("{kind} {index} ({:?})", short(n)),
        None => format!("{kind} {index}"),
    }
}

/// Splits a GLB file into its JSON chunk and optional BIN chunk.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let u32_at = |o: usize| -> Option<u32> {
        bytes
            .get(o..o.checked_add(4)?)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if bytes.len() < 12 {
        return Err(format!(
            "file has {} bytes, shorter than the 12-byte GLB header",
            bytes.len()
        ));
    }
    let version = u32_at(4).unwrap_or(0);
    if version != 2 {
        return Err(format!("unsupported GLB version {version} (expected 2)"));
    }
    let length = u32_at(8).unwrap_or(0) as usize;
    if length < 12 || length > bytes.len() {
        return Err(format!(
            "header length {length} does not fit the file size {}",
            bytes.len()
        ));
    }
    let mut json = None;
    let mut bin = None;
    let mut offset = 12usize;
    let mut chunk = 0usize;
    while offset < length {
        if length - offset < 8 {
            return Err(format!("truncated chunk header at byte {offset}"));
        }
        let chunk_len = u32_at(offset).unwrap_or(0) as usize;
        let kind = &bytes[offset + 4..offset + 8];
        let start = offset + 8;
        let end = start
            .checked_add(chunk_len)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!("chunk {chunk} ({chunk_len} bytes at byte {start}) runs past the end of the file")
            })?;
        let data = &bytes[start..end];
        match (chunk, kind) {
            (0, b"JSON") => json = Some(data),
            (0, _) => return Err("the first chunk is not a JSON chunk".to_string()),
            (1, b"BIN\0") => bin = Some(data),
            _ => {} // unknown chunk types are ignored (glTF spec)
        }
        offset = end;
        chunk += 1;
    }
    let json = json.ok_or("no JSON chunk")?;
    Ok((json, bin))
}

/// Decoded local data of one mesh primitive (shared by every instance).
struct DecodedPrimitive {
    positions: Vec<DVec3>,
    uvs: Option<Vec<Vec2>>,
    triangles: Vec<[u32; 3]>,
    material: u32,
}

/// An accessor read into `f64` components (exact for every glTF component type).
struct AccessorData {
    values: Vec<f64>,
    comps: usize,
    component: json::accessor::ComponentType,
    normalized: bool,
}

impl AccessorData {
    fn count(&self) -> usize {
        self.values.len() / self.comps.max(1)
    }

    /// Value `c` of element `e`, normalised to `[0, 1]` / `[−1, 1]` when the accessor says so.
    fn attribute(&self, e: usize, c: usize) -> f64 {
        use json::accessor::ComponentType as C;
        let v = self.values[e * self.comps + c];
        if !self.normalized {
            return v;
        }
        match self.component {
            C::I8 => (v / 127.0).max(-1.0),
            C::U8 => v / 255.0,
            C::I16 => (v / 32767.0).max(-1.0),
            C::U16 => v / 65535.0,
            C::U32 => v / 4_294_967_295.0,
            C::F32 => v,
        }
    }
}

fn component_size(c: json::accessor::ComponentType) -> usize {
    use json::accessor::ComponentType as C;
    match c {
        C::I8 | C::U8 => 1,
        C::I16 | C::U16 => 2,
        C::U32 | C::F32 => 4,
    }
}

/// Reads one component; `None` when `bytes` is too short (never after validation).
fn read_component(bytes: &[u8], offset: usize, c: json::accessor::ComponentType) -> Option<f64> {
    use json::accessor::ComponentType as C;
    let b = bytes.get(offset..offset.checked_add(component_size(c))?)?;
    Some(match c {
        C::I8 => f64::from(b[0] as i8),
        C::U8 => f64::from(b[0]),
        C::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        C::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        C::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        C::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    })
}

struct Importer<'a> {
    path: &'a Path,
    base_dir: PathBuf,
    root: json::Root,
    raw: Value,
    buffers: Vec<Vec<u8>>,
    warnings: Vec<String>,
    warned: HashSet<String>,
    materials: Vec<Material>,
    default_material: Option<u32>,
    textures: Vec<Texture>,
    texture_of_gltf: HashMap<usize, u32>,
    primitives: HashMap<(usize, usize), Option<Rc<DecodedPrimitive>>>,
    /// (mesh, primitive) of each source id used by raw triangles.
    sources: Vec<(usize, usize)>,
    source_of: HashMap<(usize, usize), u32>,
    skipped_primitives: usize,
}

/// Loads a glTF 2.0 file; see [`super::load`].
pub(crate) fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        cause: source,
    })?;
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        split_glb(&bytes).map_err(|reason| SceneError::Glb {
            reason,
            path: path.to_path_buf(),
        })?
    } else {
        (bytes.as_slice(), None)
    };
    let json_bytes = json_bytes
        .strip_prefix(b"\xEF\xBB\xBF".as_slice())
        .unwrap_or(json_bytes);
    let json_error = |e: json::Error| SceneError::Json {
        message: e.to_string(),
        path: path.to_path_buf(),
    };
    let raw: Value = json::deserialize::from_slice(json_bytes).map_err(json_error)?;
    if let Some(required) = raw.get("extensionsRequired").and_then(Value::as_array) {
        for ext in required.iter().filter_map(Value::as_str) {
            if !required_extension_supported(ext) {
                return Err(SceneError::UnsupportedExtension {
                    extension: short(ext),
                    path: path.to_path_buf(),
                });
            }
        }
    }
    let root: json::Root = json::deserialize::from_slice(json_bytes).map_err(json_error)?;
    let base_dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let mut imp = Importer {
        path,
        base_dir,
        root,
        raw,
        buffers: Vec::new(),
        warnings: Vec::new(),
        warned: HashSet::new(),
        materials: Vec::new(),
        default_material: None,
        textures: Vec::new(),
        texture_of_gltf: HashMap::new(),
        primitives: HashMap::new(),
        sources: Vec::new(),
        source_of: HashMap::new(),
        skipped_primitives: 0,
    };
    imp.check_asset_and_extensions()?;
    imp.load_buffers(bin)?;
    imp.convert_materials()?;
    imp.build()
}

impl Importer<'_> {
    fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            log::warn!("{message} (in {})", self.path.display());
            self.warnings.push(message);
        }
    }

    fn invalid(&self, element: impl Into<String>, reason: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            element: element.into(),
            reason: reason.into(),
            path: self.path.to_path_buf(),
        }
    }

    fn resource(&self, element: String, file: String, reason: String) -> SceneError {
        SceneError::Resource {
            element,
            file,
            reason,
            path: self.path.to_path_buf(),
        }
    }

    fn check_asset_and_extensions(&mut self) -> Result<(), SceneError> {
        let version = self.root.asset.version.clone();
        if !version.starts_with("2.") {
            return Err(self.invalid(
                "asset",
                format!("unsupported glTF version {:?} (only 2.x)", short(&version)),
            ));
        }
        let required = self.root.extensions_required.clone();
        for ext in &required {
            if ext.starts_with("KHR_materials_") && ext != "KHR_materials_emissive_strength" {
                self.warn(format!(
                    "required extension {} is not implemented: its material properties are ignored",
                    short(ext)
                ));
            }
        }
        let used = self.root.extensions_used.clone();
        for ext in &used {
            let known =
                IMPLEMENTED_EXTENSIONS.contains(&ext.as_str()) || ext.starts_with("KHR_materials_");
            if !known && !required.contains(ext) {
                self.warn(format!(
                    "extension {} (in extensionsUsed) is not supported and is ignored",
                    short(ext)
                ));
            }
        }
        Ok(())
    }

    /// Reads a whole external file, with a reason string on failure.
    fn read_file(file: &Path) -> Result<Vec<u8>, String> {
        match std::fs::metadata(file) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err("file not found".to_string());
            }
            Err(e) => return Err(e.to_string()),
            Ok(m) if !m.is_file() => return Err("not a regular file".to_string()),
            Ok(_) => {}
        }
        std::fs::read(file).map_err(|e| e.to_string())
    }

    /// Bytes of a `uri` (data URI or file) and the file name for messages; on failure
    /// the file name and the reason.
    fn read_uri(&self, uri: &str) -> Result<(Vec<u8>, String), (String, String)> {
        match uri::resolve(uri, &self.base_dir) {
            Ok(UriTarget::Data(_media, bytes)) => Ok((bytes, "embedded data URI".to_string())),
            Ok(UriTarget::File(file)) => {
                let name = file.display().to_string();
                match Self::read_file(&file) {
                    Ok(bytes) => Ok((bytes, name)),
                    Err(reason) => Err((name, reason)),
                }
            }
            Err(reason) => {
                let shown = if uri.starts_with("data:") {
                    "embedded data URI".to_string()
                } else {
                    short(uri)
                };
                Err((shown, reason))
            }
        }
    }

    fn load_buffers(&mut self, bin: Option<&[u8]>) -> Result<(), SceneError> {
        let mut bin = bin;
        let mut buffers = Vec::with_capacity(self.root.buffers.len().min(1024));
        for (i, b) in self.root.buffers.iter().enumerate() {
            let el = element("buffer", i, b.name.as_ref());
            let (mut data, file) = match &b.uri {
                None => match bin.take() {
                    Some(chunk) if i == 0 => (chunk.to_vec(), "the GLB binary chunk".to_string()),
                    _ => {
                        return Err(self.resource(
                            el,
                            "the GLB binary chunk".to_string(),
                            "the buffer has no uri and there is no GLB binary chunk for it"
                                .to_string(),
                        ));
                    }
                },
                Some(uri) => match self.read_uri(uri) {
                    Ok((bytes, file)) => (bytes, file),
                    Err((file, reason)) => return Err(self.resource(el, file, reason)),
                },
            };
            let need = b.byte_length.0;
            if (data.len() as u64) < need {
                return Err(self.invalid(
                    el,
                    format!(
                        "byteLength is {need} but {file} holds only {} bytes",
                        data.len()
                    ),
                ));
            }
            data.truncate(need as usize);
            buffers.push(data);
        }
        self.buffers = buffers;
        Ok(())
    }

    /// The bytes of `count` elements of `elem` bytes at `offset` in buffer view `view`.
    /// Returns the slice (starting at the first element) and the stride.
    fn view_slice(
        &self,
        el: &str,
        view: usize,
        offset: u64,
        elem: usize,
        count: u64,
        packed: bool,
    ) -> Result<(&[u8], usize), SceneError> {
        let v = self.root.buffer_views.get(view).ok_or_else(|| {
            self.invalid(
                el,
                format!(
                    "bufferView {view} is out of range ({} buffer views)",
                    self.root.buffer_views.len()
                ),
            )
        })?;
        let b = v.buffer.value();
        let data = self.buffers.get(b).ok_or_else(|| {
            self.invalid(
                format!("bufferView {view}"),
                format!(
                    "buffer {b} is out of range ({} buffers)",
                    self.buffers.len()
                ),
            )
        })?;
        let start = v.byte_offset.map_or(0, |o| o.0);
        let len = v.byte_length.0;
        start
            .checked_add(len)
            .filter(|&e| e <= data.len() as u64)
            .ok_or_else(|| {
                self.invalid(
                    format!("bufferView {view}"),
                    format!(
                        "bytes {start}..{} exceed buffer {b} ({} bytes)",
                        start.saturating_add(len),
                        data.len()
                    ),
                )
            })?;
        let stride = match v.byte_stride {
            Some(s) if !packed => {
                if s.0 < elem {
                    return Err(self.invalid(
                        format!("bufferView {view}"),
                        format!("byteStride {} is smaller than the element size {elem}", s.0),
                    ));
                }
                s.0
            }
            _ => elem,
        };
        if count == 0 {
            return Ok((&[], stride));
        }
        let need = (stride as u64)
            .checked_mul(count - 1)
            .and_then(|x| x.checked_add(elem as u64))
            .and_then(|x| x.checked_add(offset));
        match need {
            Some(need) if need <= len => {
                let first = (start + offset) as usize;
                Ok((&data[first..(start + need) as usize], stride))
            }
            _ => Err(self.invalid(
                el,
                format!(
                    "{count} elements of {elem} bytes (stride {stride}) at offset {offset} do not fit bufferView {view} ({len} bytes)",
                ),
            )),
        }
    }

    /// Reads accessor `index` for `user` (e.g. "mesh 0 primitive 1 POSITION").
    fn read_accessor(&self, user: &str, index: usize) -> Result<AccessorData, SceneError> {
        use json::accessor::{ComponentType, Type};
        let acc = self.root.accessors.get(index).ok_or_else(|| {
            self.invalid(
                user,
                format!(
                    "accessor index {index} is out of range ({} accessors)",
                    self.root.accessors.len()
                ),
            )
        })?;
        let el = format!("{user}: accessor {index}");
        let component = match acc.component_type {
            Checked::Valid(json::accessor::GenericComponentType(c)) => c,
            Checked::Invalid => return Err(self.invalid(el, "invalid componentType")),
        };
        let comps = match acc.type_ {
            Checked::Valid(Type::Scalar) => 1,
            Checked::Valid(Type::Vec2) => 2,
            Checked::Valid(Type::Vec3) => 3,
            Checked::Valid(Type::Vec4 | Type::Mat2) => 4,
            Checked::Valid(Type::Mat3) => 9,
            Checked::Valid(Type::Mat4) => 16,
            Checked::Invalid => return Err(self.invalid(el, "invalid type")),
        };
        let csize = component_size(component);
        let elem = csize * comps;
        let count = acc.count.0;
        let mut values: Vec<f64> = match acc.buffer_view {
            Some(view) => {
                let offset = acc.byte_offset.map_or(0, |o| o.0);
                let (bytes, stride) =
                    self.view_slice(&el, view.value(), offset, elem, count, false)?;
                let mut values = Vec::with_capacity(count as usize * comps);
                for e in 0..count as usize {
                    for c in 0..comps {
                        let v = read_component(bytes, e * stride + c * csize, component)
                            .ok_or_else(|| self.invalid(&el, "read past the end of its data"))?;
                        values.push(v);
                    }
                }
                values
            }
            None => {
                if acc.sparse.is_none() {
                    return Err(self.invalid(el, "has neither a bufferView nor sparse data"));
                }
                if count.saturating_mul(comps as u64) > MAX_SPARSE_ONLY_VALUES {
                    return Err(self.invalid(
                        el,
                        format!(
                            "sparse accessor without bufferView: count {count} exceeds the limit {}",
                            MAX_SPARSE_ONLY_VALUES / comps as u64
                        ),
                    ));
                }
                vec![0.0; count as usize * comps]
            }
        };
        if let Some(sparse) = &acc.sparse {
            let n = sparse.count.0;
            if n > count {
                return Err(self.invalid(
                    el,
                    format!("sparse count {n} exceeds the accessor count {count}"),
                ));
            }
            let index_type = match sparse.indices.component_type {
                Checked::Valid(json::accessor::IndexComponentType(
                    c @ (ComponentType::U8 | ComponentType::U16 | ComponentType::U32),
                )) => c,
                _ => return Err(self.invalid(el, "invalid sparse indices componentType")),
            };
            let isize_ = component_size(index_type);
            let (ibytes, _) = self.view_slice(
                &format!("{el} sparse indices"),
                sparse.indices.buffer_view.value(),
                sparse.indices.byte_offset.0,
                isize_,
                n,
                true,
            )?;
            let (vbytes, _) = self.view_slice(
                &format!("{el} sparse values"),
                sparse.values.buffer_view.value(),
                sparse.values.byte_offset.0,
                elem,
                n,
                true,
            )?;
            for k in 0..n as usize {
                let target = read_component(ibytes, k * isize_, index_type)
                    .ok_or_else(|| self.invalid(&el, "sparse indices out of range"))?;
                if target >= count as f64 {
                    return Err(self.invalid(
                        el,
                        format!("sparse index {target} is out of range (count {count})"),
                    ));
                }
                let t = target as usize;
                for c in 0..comps {
                    values[t * comps + c] = read_component(vbytes, k * elem + c * csize, component)
                        .ok_or_else(|| self.invalid(&el, "sparse values out of range"))?;
                }
            }
        }
        Ok(AccessorData {
            values,
            comps,
            component,
            normalized: acc.normalized,
        })
    }

    // ----- materials and textures ---------------------------------------------------

    fn convert_materials(&mut self) -> Result<(), SceneError> {
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

        let kind = if metallic <= 0.01 {
            MaterialKind::Diffuse
        } else {
            let sharp = if metallic >= 0.99 {
                MaterialKind::Mirror
            } else {
                MaterialKind::Mixed { specular: metallic }
            };
            if roughness <= 0.05 {
                sharp
            } else if roughness <= 0.3 {
                self.warn(format!(
                    "{el}: glossy metal (metallic {metallic}, roughness {roughness}) is not supported yet; treated as {} (roughness 0)",
                    if metallic >= 0.99 { "a mirror" } else { "mixed diffuse + mirror" }
                ));
                sharp
            } else {
                self.warn(format!(
                    "{el}: rough metal (metallic {metallic}, roughness {roughness}) is not supported yet; treated as diffuse with albedo = base colour"
                ));
                MaterialKind::Diffuse
            }
        };

        if let Checked::Valid(mode) = m.alpha_mode
            && mode != json::material::AlphaMode::Opaque
        {
            self.warn(format!(
                "{el}: alphaMode {mode:?} is ignored (treated as opaque)"
            ));
        }
        self.warn_material_extensions(i, &el);

        let base_color_texture = match &pbr.base_color_texture {
            Some(info) => Some(self.texture_ref(info, &format!("{el} baseColorTexture"))?),
            None => None,
        };
        let emissive_texture = match &m.emissive_texture {
            Some(info) => Some(self.texture_ref(info, &format!("{el} emissiveTexture"))?),
            None => None,
        };
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
        })
    }

    /// Warnings for material extensions that change nothing here, and for
    /// `KHR_texture_transform` (not applied).
    fn warn_material_extensions(&mut self, i: usize, el: &str) {
        let Some(raw) = self.raw.get("materials").and_then(|m| m.get(i)).cloned() else {
            return;
        };
        if let Some(exts) = raw.get("extensions").and_then(Value::as_object) {
            for name in exts.keys() {
                if name != "KHR_materials_emissive_strength" {
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
        if info.tex_coord != 0 {
            self.warn(format!(
                "{el}: uses TEXCOORD_{} but only TEXCOORD_0 is imported; sampled with TEXCOORD_0",
                info.tex_coord
            ));
        }
        if let Some(&index) = self.texture_of_gltf.get(&ti) {
            return Ok(TexRef {
                index,
                texcoord: info.tex_coord,
            });
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
        Ok(TexRef {
            index,
            texcoord: info.tex_coord,
        })
    }

    fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        // glTF default material: base colour 1, metallic 1, roughness 1.
        self.warn(
            "some primitives have no material: using the glTF default material (white, metallic 1, roughness 1 → diffuse albedo 1)"
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
            kind: MaterialKind::Diffuse,
            metallic: 1.0,
            roughness: 1.0,
        });
        self.default_material = Some(i);
        i
    }

    // ----- geometry --------------------------------------------------------------------

    /// Decodes mesh `mi` primitive `pi` once; `None` when it is skipped (points/lines).
    fn primitive(
        &mut self,
        mi: usize,
        pi: usize,
    ) -> Result<Option<Rc<DecodedPrimitive>>, SceneError> {
        if let Some(p) = self.primitives.get(&(mi, pi)) {
            return Ok(p.clone());
        }
        let decoded = self.decode_primitive(mi, pi)?.map(Rc::new);
        if decoded.is_none() {
            self.skipped_primitives += 1;
        }
        self.primitives.insert((mi, pi), decoded.clone());
        Ok(decoded)
    }

    fn decode_primitive(
        &mut self,
        mi: usize,
        pi: usize,
    ) -> Result<Option<DecodedPrimitive>, SceneError> {
        use json::mesh::{Mode, Semantic};
        let mesh = &self.root.meshes[mi];
        let el = format!("{} primitive {pi}", element("mesh", mi, mesh.name.as_ref()));
        let prim = mesh.primitives[pi].clone();
        let mode = match prim.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => return Err(self.invalid(el, "invalid primitive mode")),
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warn(format!(
                "{el}: mode {mode:?} is not a triangle mode; primitive skipped"
            ));
            return Ok(None);
        }
        if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            self.warn(format!("{el}: morph targets are ignored (base shape used)"));
        }
        let material = match prim.material {
            Some(m) if m.value() < self.root.materials.len() => m.value() as u32,
            Some(m) => {
                return Err(self.invalid(
                    el,
                    format!(
                        "material index {} is out of range ({} materials)",
                        m.value(),
                        self.root.materials.len()
                    ),
                ));
            }
            None => self.default_material(),
        };
        let pos_index = prim
            .attributes
            .get(&Checked::Valid(Semantic::Positions))
            .ok_or_else(|| self.invalid(&el, "has no POSITION attribute"))?
            .value();
        let pos = self.read_accessor(&format!("{el} POSITION"), pos_index)?;
        if pos.comps != 3 {
            return Err(self.invalid(
                format!("{el} POSITION: accessor {pos_index}"),
                "must be of type VEC3",
            ));
        }
        let vertex_count = pos.count();
        let mut positions = Vec::with_capacity(vertex_count);
        for v in 0..vertex_count {
            let p = DVec3::new(
                pos.attribute(v, 0),
                pos.attribute(v, 1),
                pos.attribute(v, 2),
            );
            positions.push(p);
        }
        drop(pos);
        let uvs = match prim.attributes.get(&Checked::Valid(Semantic::TexCoords(0))) {
            None => None,
            Some(ti) => {
                let uv = self.read_accessor(&format!("{el} TEXCOORD_0"), ti.value())?;
                if uv.comps != 2 {
                    return Err(self.invalid(
                        format!("{el} TEXCOORD_0: accessor {}", ti.value()),
                        "must be of type VEC2",
                    ));
                }
                if uv.count() < vertex_count {
                    self.warn(format!(
                        "{el}: TEXCOORD_0 has {} elements for {vertex_count} vertices; texture coordinates ignored",
                        uv.count()
                    ));
                    None
                } else {
                    let mut bad = 0usize;
                    let list: Vec<Vec2> = (0..vertex_count)
                        .map(|v| {
                            let t = Vec2::new(uv.attribute(v, 0) as f32, uv.attribute(v, 1) as f32);
                            if t.is_finite() {
                                t
                            } else {
                                bad += 1;
                                Vec2::ZERO
                            }
                        })
                        .collect();
                    if bad > 0 {
                        self.warn(format!(
                            "{el}: {bad} non-finite texture coordinates replaced by (0, 0)"
                        ));
                    }
                    Some(list)
                }
            }
        };
        let indices: Vec<u32> = match prim.indices {
            Some(ii) => {
                let idx = self.read_accessor(&format!("{el} indices"), ii.value())?;
                use json::accessor::ComponentType as C;
                if idx.comps != 1 || !matches!(idx.component, C::U8 | C::U16 | C::U32) {
                    return Err(self.invalid(
                        format!("{el} indices: accessor {}", ii.value()),
                        "must be SCALAR of unsigned byte, short or int",
                    ));
                }
                let mut out = Vec::with_capacity(idx.values.len());
                for &v in &idx.values {
                    if v >= vertex_count as f64 {
                        return Err(SceneError::IndexOutOfRange {
                            element: el,
                            index: v as u64,
                            vertex_count,
                            path: self.path.to_path_buf(),
                        });
                    }
                    out.push(v as u32);
                }
                out
            }
            None => {
                if vertex_count > u32::MAX as usize {
                    return Err(self.invalid(el, "too many vertices"));
                }
                (0..vertex_count as u32).collect()
            }
        };
        let n = indices.len();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        match mode {
            Mode::Triangles => {
                if !n.is_multiple_of(3) {
                    self.warn(format!(
                        "{el}: {n} indices is not a multiple of 3; the last {} ignored",
                        n % 3
                    ));
                }
                triangles.extend(indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            }
            Mode::TriangleStrip => {
                for i in 0..n.saturating_sub(2) {
                    // glTF: p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2−i%2)}}
                    let (a, b) = if i % 2 == 0 {
                        (i + 1, i + 2)
                    } else {
                        (i + 2, i + 1)
                    };
                    triangles.push([indices[i], indices[a], indices[b]]);
                }
            }
            Mode::TriangleFan => {
                for i in 0..n.saturating_sub(2) {
                    // glTF: p_i = {v_{i+1}, v_{i+2}, v_0}
                    triangles.push([indices[i + 1], indices[i + 2], indices[0]]);
                }
            }
            _ => unreachable!("non-triangle modes returned above"),
        }
        if triangles.is_empty() {
            self.warn(format!("{el}: no triangles ({n} indices)"));
        }
        Ok(Some(DecodedPrimitive {
            positions,
            uvs,
            triangles,
            material,
        }))
    }

    fn node_local(&self, ni: usize) -> Result<DMat4, SceneError> {
        let node = &self.root.nodes[ni];
        let el = element("node", ni, node.name.as_ref());
        let m = if let Some(m) = node.matrix {
            if m.iter().any(|x| !x.is_finite()) {
                return Err(self.invalid(el, "matrix has non-finite entries"));
            }
            DMat4::from_cols_array(&m.map(f64::from))
        } else {
            let t = node.translation.unwrap_or([0.0; 3]);
            let r = node.rotation.unwrap_or_default().0;
            let s = node.scale.unwrap_or([1.0; 3]);
            if t.iter().chain(&r).chain(&s).any(|x| !x.is_finite()) {
                return Err(self.invalid(el, "translation/rotation/scale has non-finite values"));
            }
            let q = DQuat::from_array(r.map(f64::from));
            if q.length() < 1e-6 {
                return Err(self.invalid(el, "rotation quaternion has zero length"));
            }
            DMat4::from_scale_rotation_translation(
                DVec3::from_array(s.map(f64::from)),
                q.normalize(),
                DVec3::from_array(t.map(f64::from)),
            )
        };
        Ok(m)
    }

    fn build(mut self) -> Result<Scene, SceneError> {
        // Default scene, or scene 0, or (no scenes at all) every root node.
        let (scene_label, roots): (String, Vec<usize>) = match self.root.scene {
            Some(s) => {
                let s = s.value();
                let scene = self.root.scenes.get(s).ok_or_else(|| {
                    self.invalid(
                        "scene",
                        format!(
                            "default scene index {s} is out of range ({} scenes)",
                            self.root.scenes.len()
                        ),
                    )
                })?;
                (
                    format!("scene {s}"),
                    scene.nodes.iter().map(|n| n.value()).collect(),
                )
            }
            None if !self.root.scenes.is_empty() => (
                "scene 0".to_string(),
                self.root.scenes[0]
                    .nodes
                    .iter()
                    .map(|n| n.value())
                    .collect(),
            ),
            None => {
                let mut has_parent = vec![false; self.root.nodes.len()];
                for node in &self.root.nodes {
                    for c in node.children.iter().flatten() {
                        if let Some(h) = has_parent.get_mut(c.value()) {
                            *h = true;
                        }
                    }
                }
                self.warn("the file defines no scene: every root node is imported".to_string());
                (
                    "root nodes".to_string(),
                    (0..self.root.nodes.len())
                        .filter(|&n| !has_parent[n])
                        .collect(),
                )
            }
        };

        let mut raw: Vec<RawTriangle> = Vec::new();
        let mut raw_source: Vec<u32> = Vec::new();
        let mut cameras = Vec::new();
        let mut suns = Vec::new();
        let mut visited = vec![false; self.root.nodes.len()];
        let mut stack: Vec<(usize, DMat4, String)> = roots
            .iter()
            .rev()
            .map(|&n| (n, DMat4::IDENTITY, scene_label.clone()))
            .collect();
        while let Some((ni, parent, referrer)) = stack.pop() {
            if ni >= self.root.nodes.len() {
                return Err(self.invalid(
                    referrer,
                    format!(
                        "node index {ni} is out of range ({} nodes)",
                        self.root.nodes.len()
                    ),
                ));
            }
            let node = self.root.nodes[ni].clone();
            let el = element("node", ni, node.name.as_ref());
            if visited[ni] {
                return Err(self.invalid(
                    el,
                    format!(
                        "is reached twice from {scene_label} (the node hierarchy must be a tree)"
                    ),
                ));
            }
            visited[ni] = true;
            let world = parent * self.node_local(ni)?;
            if !world.is_finite() {
                return Err(self.invalid(el, "world transform is not finite"));
            }
            if node.skin.is_some() {
                self.warn(format!(
                    "{el}: skin ignored (mesh drawn with the node transform)"
                ));
            }
            if let Some(mesh) = node.mesh {
                self.emit_mesh(mesh.value(), &el, &world, &mut raw, &mut raw_source)?;
            }
            if let Some(ci) = node.camera {
                self.add_camera(ci.value(), &el, node.name.as_ref(), &world, &mut cameras)?;
            }
            if let Some(light) = node
                .extensions
                .as_ref()
                .and_then(|e| e.khr_lights_punctual.as_ref())
            {
                self.add_light(
                    light.light.value(),
                    &el,
                    node.name.as_ref(),
                    &world,
                    &mut suns,
                )?;
            }
            for c in node.children.iter().flatten().rev() {
                stack.push((c.value(), world, el.clone()));
            }
        }

        // Degenerate triangles, relative to the scene size.
        let mut bbox = Aabb::EMPTY;
        for t in &raw {
            for p in t.p {
                bbox.extend(p);
            }
        }
        let diag = (bbox.max.as_dvec3() - bbox.min.as_dvec3()).length();
        let threshold = DEGENERATE_AREA_FACTOR * diag * diag;
        let mut degenerate = vec![0usize; self.sources.len()];
        let mut kept = Vec::with_capacity(raw.len());
        for (t, src) in raw.into_iter().zip(raw_source) {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            let area = 0.5 * (b - a).cross(c - a).length();
            if area == 0.0 || area < threshold {
                degenerate[src as usize] += 1;
            } else {
                kept.push(t);
            }
        }
        let total_degenerate: usize = degenerate.iter().sum();
        for (src, &count) in degenerate.iter().enumerate() {
            if count > 0 {
                let (mi, pi) = self.sources[src];
                let mesh_el = element("mesh", mi, self.root.meshes[mi].name.as_ref());
                self.warn(format!(
                    "{mesh_el} primitive {pi}: {count} degenerate triangle{} skipped",
                    if count == 1 { "" } else { "s" }
                ));
            }
        }
        if kept.is_empty() {
            let detail = if total_degenerate > 0 {
                format!("all {total_degenerate} triangles are degenerate")
            } else if self.skipped_primitives > 0 {
                format!(
                    "{} non-triangle primitives skipped and no triangles",
                    self.skipped_primitives
                )
            } else {
                format!("{scene_label} contains no triangle meshes")
            };
            return Err(SceneError::Empty {
                detail,
                path: self.path.to_path_buf(),
            });
        }

        let (triangles, faces) = build_faces(kept);
        let mut bounds = Aabb::EMPTY;
        for t in &triangles {
            for p in t.p {
                bounds.extend(p);
            }
        }
        let to_vlf = fit_similarity(&triangles, &bounds);
        Ok(Scene {
            triangles,
            faces,
            materials: self.materials,
            textures: self.textures,
            cameras,
            suns,
            bounds,
            to_vlf,
            warnings: self.warnings,
            source: self.path.to_path_buf(),
        })
    }

    /// Appends the world-space triangles of mesh `mi` instanced by node `el`.
    fn emit_mesh(
        &mut self,
        mi: usize,
        el: &str,
        world: &DMat4,
        raw: &mut Vec<RawTriangle>,
        raw_source: &mut Vec<u32>,
    ) -> Result<(), SceneError> {
        if mi >= self.root.meshes.len() {
            return Err(self.invalid(
                el,
                format!(
                    "mesh index {mi} is out of range ({} meshes)",
                    self.root.meshes.len()
                ),
            ));
        }
        let flip = world.determinant() < 0.0;
        for pi in 0..self.root.meshes[mi].primitives.len() {
            let Some(prim) = self.primitive(mi, pi)? else {
                continue;
            };
            if raw.len() + prim.triangles.len() > MAX_TRIANGLES {
                return Err(SceneError::TooLarge {
                    limit: MAX_TRIANGLES,
                    path: self.path.to_path_buf(),
                });
            }
            let src = *self.source_of.entry((mi, pi)).or_insert_with(|| {
                self.sources.push((mi, pi));
                (self.sources.len() - 1) as u32
            });
            let prim_el = || {
                format!(
                    "{} primitive {pi} ({el})",
                    element("mesh", mi, self.root.meshes[mi].name.as_ref())
                )
            };
            let mut world_pos: Vec<Option<Vec3>> = vec![None; prim.positions.len()];
            for tri in &prim.triangles {
                let mut p = [Vec3::ZERO; 3];
                for k in 0..3 {
                    let v = tri[k] as usize;
                    p[k] = match world_pos[v] {
                        Some(w) => w,
                        None => {
                            let local = prim.positions[v];
                            let w = world.transform_point3(local).as_vec3();
                            if !local.is_finite() || !w.is_finite() {
                                return Err(SceneError::NonFinitePosition {
                                    element: prim_el(),
                                    vertex: v,
                                    value: format!(
                                        "{:?} (world {:?})",
                                        local.to_array(),
                                        w.to_array()
                                    ),
                                    path: self.path.to_path_buf(),
                                });
                            }
                            world_pos[v] = Some(w);
                            w
                        }
                    };
                }
                let mut uv = match &prim.uvs {
                    Some(uvs) => tri.map(|v| uvs[v as usize]),
                    None => [Vec2::ZERO; 3],
                };
                if flip {
                    p.swap(1, 2);
                    uv.swap(1, 2);
                }
                raw.push(RawTriangle {
                    p,
                    uv,
                    material: prim.material,
                });
                raw_source.push(src);
            }
        }
        Ok(())
    }

    fn add_camera(
        &mut self,
        ci: usize,
        node_el: &str,
        node_name: Option<&String>,
        world: &DMat4,
        cameras: &mut Vec<Camera>,
    ) -> Result<(), SceneError> {
        use json::camera::Type;
        let cam = self.root.cameras.get(ci).cloned().ok_or_else(|| {
            self.invalid(
                node_el,
                format!(
                    "camera index {ci} is out of range ({} cameras)",
                    self.root.cameras.len()
                ),
            )
        })?;
        let cam_el = element("camera", ci, cam.name.as_ref());
        let persp = match (cam.type_, &cam.perspective) {
            (Checked::Valid(Type::Perspective), Some(p)) => p.clone(),
            (Checked::Valid(Type::Orthographic), _) => {
                self.warn(format!(
                    "{cam_el}: orthographic cameras are not supported; ignored"
                ));
                return Ok(());
            }
            _ => {
                self.warn(format!(
                    "{cam_el}: invalid camera (no perspective data); ignored"
                ));
                return Ok(());
            }
        };
        let valid = persp.yfov.is_finite()
            && persp.yfov > 0.0
            && persp.yfov < std::f32::consts::PI
            && persp.znear.is_finite()
            && persp.znear > 0.0
            && persp.zfar.is_none_or(|f| f.is_finite() && f > persp.znear)
            && persp.aspect_ratio.is_none_or(|a| a.is_finite() && a > 0.0);
        if !valid {
            self.warn(format!(
                "{cam_el}: invalid perspective parameters (yfov {}, znear {}, zfar {:?}, aspectRatio {:?}); ignored",
                persp.yfov, persp.znear, persp.zfar, persp.aspect_ratio
            ));
            return Ok(());
        }
        let (_, rotation, translation) = world.to_scale_rotation_translation();
        let rotation = rotation.normalize();
        if !rotation.is_finite() || !translation.is_finite() {
            self.warn(format!(
                "{cam_el} at {node_el}: degenerate node transform; camera ignored"
            ));
            return Ok(());
        }
        cameras.push(Camera {
            name: node_name.cloned().or(cam.name.clone()),
            position: translation.as_vec3(),
            rotation: rotation.as_quat(),
            yfov: persp.yfov,
            aspect_ratio: persp.aspect_ratio,
            znear: persp.znear,
            zfar: persp.zfar,
        });
        Ok(())
    }

    fn add_light(
        &mut self,
        li: usize,
        node_el: &str,
        node_name: Option<&String>,
        world: &DMat4,
        suns: &mut Vec<Sun>,
    ) -> Result<(), SceneError> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |l| &l.lights[..]);
        let light = lights.get(li).cloned().ok_or_else(|| {
            self.invalid(
                node_el,
                format!(
                    "KHR_lights_punctual light index {li} is out of range ({} lights)",
                    lights.len()
                ),
            )
        })?;
        let light_el = element("light", li, light.name.as_ref());
        match light.type_ {
            Checked::Valid(Type::Directional) => {}
            Checked::Valid(Type::Point) => {
                self.warn(format!(
                    "light {li} (point) is not supported and is ignored"
                ));
                return Ok(());
            }
            Checked::Valid(Type::Spot) => {
                self.warn(format!("light {li} (spot) is not supported and is ignored"));
                return Ok(());
            }
            Checked::Invalid => {
                self.warn(format!("{light_el}: invalid light type; ignored"));
                return Ok(());
            }
        }
        let direction = world.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
        let irradiance = Vec3::from_array(light.color) * light.intensity;
        if direction == DVec3::ZERO || !direction.is_finite() {
            self.warn(format!(
                "{light_el} at {node_el}: degenerate node transform; sun ignored"
            ));
            return Ok(());
        }
        if !irradiance.is_finite() || irradiance.min_element() < 0.0 {
            self.warn(format!(
                "{light_el}: invalid color × intensity {:?}; sun ignored",
                irradiance.to_array()
            ));
            return Ok(());
        }
        suns.push(Sun {
            name: light.name.clone().or(node_name.cloned()),
            direction: direction.as_vec3(),
            irradiance,
        });
        Ok(())
    }
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

/// Bounding-box centre and the largest scale keeping every vertex within
/// `1 − MARGIN` of it, checked in `f32` exactly as [`Similarity::apply`] computes.
pub(super) fn fit_similarity(triangles: &[super::Triangle], bounds: &Aabb) -> Similarity {
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
