//! glTF 2.0 → [`Scene`].
//!
//! The gltf crate is used for its JSON schema types (`gltf::json::Root`) and its PNG/JPEG
//! decoding only. Container parsing (GLB), URI resolution, buffer loading, accessor
//! reading, node traversal and all index/byte-range validation are done here with
//! checked arithmetic, because the crate's own importer and accessor readers panic on
//! some malformed files (unchecked slicing, `unwrap` on percent-decoding, integer
//! underflow on a short GLB header, an out-of-range POSITION index in validation).
//!
//! The import is one [`Importer`] whose methods live with the part of the file they read:
//! `glb` (the binary container), `accessors` (buffers, buffer views, accessors), `materials`
//! (materials and textures), `meshes` (primitives and their instances), `nodes` (the node
//! hierarchy, cameras, suns, and the finished scene). Each uses only the parts before it.

mod accessors;
mod glb;
mod materials;
mod meshes;
mod nodes;
mod translucency;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use gltf::json::{self, Value};

use super::{Material, Scene, SceneError, Texture};
use meshes::DecodedPrimitive;

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

/// The import of one file: the parsed JSON, the loaded buffers and what has been converted so
/// far. Its methods are spread over the submodules, one per part of the file.
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
    /// Materials whose `normalTexture` is ignored.
    ignored_normal_maps: Vec<u32>,
}

/// Loads a glTF 2.0 file; see [`super::load`].
pub(crate) fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        cause: source,
    })?;
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        glb::split_glb(&bytes).map_err(|reason| SceneError::Glb {
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
        ignored_normal_maps: Vec::new(),
    };
    imp.check_asset_and_extensions()?;
    imp.load_buffers(bin)?;
    imp.convert_materials()?;
    imp.build()
}

impl Importer<'_> {
    pub(super) fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            log::warn!("{message} (in {})", self.path.display());
            self.warnings.push(message);
        }
    }

    pub(super) fn invalid(
        &self,
        element: impl Into<String>,
        reason: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            element: element.into(),
            reason: reason.into(),
            path: self.path.to_path_buf(),
        }
    }

    pub(super) fn resource(&self, element: String, file: String, reason: String) -> SceneError {
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
            if ext.starts_with("KHR_materials_") && !materials::is_modelled(ext) {
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
}
