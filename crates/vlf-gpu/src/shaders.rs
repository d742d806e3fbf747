//! Registry of the WGSL shaders under the repository's `shaders/` folder, and the import step
//! WGSL lacks.
//!
//! Every shader is embedded with `include_str!`, so release binaries are self-contained.
//! Definitions used by more than one shader live once in `shaders/common/` and are pulled in by a
//! line `#import "common/NAME.wgsl"` (on its own line). [`resolve`] replaces each such line by
//! the imported file's resolved source: imports are transitive, each file is included at most
//! once per resolved module (the first import wins, later ones are dropped), and unknown names,
//! malformed lines and cycles are [`ShaderError`]s naming the files. Pipelines compile the
//! resolved source ([`Shader::module`]), resolved once per shader and cached.
//!
//! The tests (`shaders/tests.rs`) check that the registry and the folder agree, that every
//! shader resolves and validates with naga, and that no name is defined in two WGSL files.

use std::sync::OnceLock;

use wgpu::naga;

/// Folder (under `shaders/`) of the files that `#import` may name.
pub const IMPORT_DIR: &str = "common/";

/// One WGSL file of `shaders/`.
#[derive(Debug)]
pub struct Shader {
    /// File name under `shaders/` (`/`-separated).
    pub file: &'static str,
    /// The WGSL source as written, `#import` lines included.
    pub source: &'static str,
    resolved: OnceLock<Result<Resolved<'static>, ShaderError>>,
}

macro_rules! shader {
    ($file:literal) => {
        Shader::new($file, include_str!(concat!("../../../shaders/", $file)))
    };
}

pub static SMOKE: Shader = shader!("smoke.wgsl");
pub static BAKE_CELLS: Shader = shader!("bake_cells.wgsl");
pub static BAKE_INTERFACE: Shader = shader!("bake_interface.wgsl");
pub static BAKE_GATHER: Shader = shader!("bake_gather.wgsl");
pub static BAKE_REFLECT: Shader = shader!("bake_reflect.wgsl");
pub static RENDER_DIRECTION_IDS: Shader = shader!("render_direction_ids.wgsl");
pub static RENDER_BARYCENTRICS: Shader = shader!("render_barycentrics.wgsl");
pub static RENDER_FACE_ID: Shader = shader!("render_face_id.wgsl");
pub static RENDER_POSITION: Shader = shader!("render_position.wgsl");
pub static RENDER_ATTRIBUTES: Shader = shader!("render_attributes.wgsl");
pub static RENDER_FINAL_RADIANCE: Shader = shader!("render_final_radiance.wgsl");
pub static RENDER_DISPLAY: Shader = shader!("render_display.wgsl");
pub static RAYTRACE_ENGINE: Shader = shader!("raytrace_engine.wgsl");
pub static RAYTRACE_PATH: Shader = shader!("raytrace_path.wgsl");
pub static RADIOSITY_JACOBI: Shader = shader!("radiosity_jacobi.wgsl");
pub static DIRECTIONS_LOOKUP: Shader = shader!("directions_lookup.wgsl");
pub static GATHER_TEXELS: Shader = shader!("gather_texels.wgsl");

/// Per-direction globals of the bake passes (bind group 0).
pub static COMMON_BAKE_DIRECTION: Shader = shader!("common/bake_direction.wgsl");
/// Records of the prepared bake scene (triangles, faces).
pub static COMMON_BAKE_SCENE: Shader = shader!("common/bake_scene.wgsl");
/// Per-ray records of the bake passes (crossings, arriving radiance).
pub static COMMON_BAKE_RAYS: Shader = shader!("common/bake_rays.wgsl");
/// Per-frame globals of the render passes (bind group 0) and the no-face id.
pub static COMMON_RENDER_GLOBALS: Shader = shader!("common/render_globals.wgsl");
/// The viewport-covering triangle.
pub static COMMON_FULLSCREEN: Shader = shader!("common/fullscreen.wgsl");
/// Exposure, tonemapping and sRGB encoding.
pub static COMMON_DISPLAY_MAPPING: Shader = shader!("common/display_mapping.wgsl");
/// The PCG hash.
pub static COMMON_HASH: Shader = shader!("common/hash.wgsl");
/// Rays, hits and ray queues of the ray engine and the path tracer.
pub static COMMON_RAYS: Shader = shader!("common/rays.wgsl");
/// The BVH, its bindings and its traversal.
pub static COMMON_BVH: Shader = shader!("common/bvh.wgsl");
/// Texture wrap modes and the bilinear footprint (path tracer, pass 5).
pub static COMMON_TEXTURE: Shader = shader!("common/texture.wgsl");
/// Alpha masks: where a triangle has no surface (group 1, binding 6).
pub static COMMON_ALPHA_MASK: Shader = shader!("common/alpha_mask.wgsl");
/// Thin glass panes: the thin dielectric's reflectance and a face's transmittance.
pub static COMMON_PANE: Shader = shader!("common/pane.wgsl");
/// Rays of the final gather and the path tracer that go on through thin glass panes.
pub static COMMON_PANE_TRACE: Shader = shader!("common/pane_trace.wgsl");
/// Per-path random streams (`Rng`).
pub static COMMON_RANDOM: Shader = shader!("common/random.wgsl");
/// Sampling routines (cosine hemisphere, bases, barycentrics, MIS weights).
pub static COMMON_SAMPLING: Shader = shader!("common/sampling.wgsl");
/// The ray-tracing scene's shading data: materials, texture coordinates, textures, lights.
pub static COMMON_RT_SCENE: Shader = shader!("common/rt_scene.wgsl");
/// The direction set's lookup (DirectionSet::lookup) and its tables.
pub static COMMON_DIRECTIONS: Shader = shader!("common/directions.wgsl");
/// The light field's mirror tiles: specular radiance leaving a face in a direction.
pub static COMMON_MIRROR_TILES: Shader = shader!("common/mirror_tiles.wgsl");
/// What a final-gather ray reads at its hit: the field's irradiance, stopping at contacts.
pub static COMMON_GATHER_FIELD: Shader = shader!("common/gather_field.wgsl");
pub static COMMON_SURFACE_ATTRIBUTES: Shader = shader!("common/surface_attributes.wgsl");

/// Every shader of the project, the importable `common/` files included. The test
/// `registry_matches_folder` keeps this list complete.
pub static ALL: &[&Shader] = &[
    &SMOKE,
    &BAKE_CELLS,
    &BAKE_INTERFACE,
    &BAKE_GATHER,
    &BAKE_REFLECT,
    &RENDER_DIRECTION_IDS,
    &RENDER_BARYCENTRICS,
    &RENDER_FACE_ID,
    &RENDER_POSITION,
    &RENDER_ATTRIBUTES,
    &RENDER_FINAL_RADIANCE,
    &RENDER_DISPLAY,
    &RAYTRACE_ENGINE,
    &RAYTRACE_PATH,
    &RADIOSITY_JACOBI,
    &DIRECTIONS_LOOKUP,
    &GATHER_TEXELS,
    &COMMON_BAKE_DIRECTION,
    &COMMON_BAKE_SCENE,
    &COMMON_BAKE_RAYS,
    &COMMON_RENDER_GLOBALS,
    &COMMON_FULLSCREEN,
    &COMMON_DISPLAY_MAPPING,
    &COMMON_HASH,
    &COMMON_RAYS,
    &COMMON_BVH,
    &COMMON_TEXTURE,
    &COMMON_ALPHA_MASK,
    &COMMON_PANE,
    &COMMON_PANE_TRACE,
    &COMMON_RANDOM,
    &COMMON_SAMPLING,
    &COMMON_RT_SCENE,
    &COMMON_DIRECTIONS,
    &COMMON_MIRROR_TILES,
    &COMMON_GATHER_FIELD,
    &COMMON_SURFACE_ATTRIBUTES,
];

/// What goes wrong when resolving or validating a shader. `file` is the shader being resolved
/// (for import errors: the file holding the offending line).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShaderError {
    #[error(
        "line {line}: #import of \"{name}\", which is not a file of shaders/{IMPORT_DIR}: {file}"
    )]
    UnknownImport {
        name: String,
        line: u32,
        file: String,
    },
    #[error(
        "line {line}: malformed #import (expected `#import \"{IMPORT_DIR}NAME.wgsl\"` on a line of its own): {file}"
    )]
    MalformedImport { line: u32, file: String },
    #[error("#import cycle {}: {file}", chain.join(" -> "))]
    ImportCycle { chain: Vec<String>, file: String },
    /// naga rejected the resolved source; `at` is the place in the original files
    /// (`common/bvh.wgsl:42:5`), `report` naga's diagnostic on the resolved source.
    #[error("invalid WGSL at {at}: {message}: {file}\n{report}")]
    Wgsl {
        at: String,
        message: String,
        report: String,
        file: String,
    },
}

/// A shader with its imports resolved.
#[derive(Clone, Debug)]
pub struct Resolved<'a> {
    /// The WGSL that naga and wgpu compile.
    pub source: String,
    /// The files `source` is made of, in inclusion order (the shader itself first).
    pub files: Vec<&'a str>,
    /// Per line of `source`: the file and 1-based line it comes from.
    origins: Vec<(&'a str, u32)>,
}

impl<'a> Resolved<'a> {
    /// File and line (1-based) that line `line` (1-based) of [`Resolved::source`] comes from.
    pub fn origin(&self, line: u32) -> Option<(&'a str, u32)> {
        let index = usize::try_from(line.checked_sub(1)?).ok()?;
        self.origins.get(index).copied()
    }

    /// `file:line:column` in the original files of a place in the resolved source.
    fn place(&self, location: Option<naga::SourceLocation>) -> String {
        match location.and_then(|l| Some((self.origin(l.line_number)?, l.line_position))) {
            Some(((file, line), column)) => format!("{file}:{line}:{column}"),
            None => "an unknown place".to_owned(),
        }
    }
}

/// The `#import` target of `line`: `None` for an ordinary line, `Some(Err(()))` for a malformed
/// import.
fn parse_import(line: &str) -> Option<Result<&str, ()>> {
    let rest = line.trim().strip_prefix("#import")?;
    let name = rest
        .trim()
        .strip_prefix('"')
        .and_then(|r| r.strip_suffix('"'))
        .filter(|n| !n.is_empty() && !n.contains('"'));
    Some(name.ok_or(()))
}

struct Resolver<'a, 'l> {
    lookup: &'l dyn Fn(&str) -> Option<(&'a str, &'a str)>,
    root: &'a str,
    out: Resolved<'a>,
    /// Files being resolved, outermost first (for cycle detection).
    stack: Vec<&'a str>,
}

impl<'a> Resolver<'a, '_> {
    fn visit(&mut self, file: &'a str, source: &'a str) -> Result<(), ShaderError> {
        self.stack.push(file);
        self.out.files.push(file);
        for (i, text) in source.lines().enumerate() {
            let line = u32::try_from(i + 1).unwrap_or(u32::MAX);
            let name = match parse_import(text) {
                None => {
                    self.out.source.push_str(text);
                    self.out.source.push('\n');
                    self.out.origins.push((file, line));
                    continue;
                }
                Some(Err(())) => {
                    return Err(ShaderError::MalformedImport {
                        line,
                        file: file.to_owned(),
                    });
                }
                Some(Ok(name)) => name,
            };
            if let Some(at) = self.stack.iter().position(|f| *f == name) {
                let mut chain: Vec<String> =
                    self.stack[at..].iter().map(|f| (*f).to_owned()).collect();
                chain.push(name.to_owned());
                return Err(ShaderError::ImportCycle {
                    chain,
                    file: self.root.to_owned(),
                });
            }
            if self.out.files.contains(&name) {
                continue;
            }
            let (imported, imported_source) =
                (self.lookup)(name).ok_or_else(|| ShaderError::UnknownImport {
                    name: name.to_owned(),
                    line,
                    file: file.to_owned(),
                })?;
            self.visit(imported, imported_source)?;
        }
        self.stack.pop();
        Ok(())
    }
}

/// Resolves the `#import` lines of `source` (the file `file`); `lookup` maps an import name to
/// the importable file of that name and its source.
pub fn resolve<'a>(
    file: &'a str,
    source: &'a str,
    lookup: &dyn Fn(&str) -> Option<(&'a str, &'a str)>,
) -> Result<Resolved<'a>, ShaderError> {
    let mut resolver = Resolver {
        lookup,
        root: file,
        out: Resolved {
            source: String::with_capacity(source.len()),
            files: Vec::new(),
            origins: Vec::new(),
        },
        stack: Vec::new(),
    };
    resolver.visit(file, source)?;
    Ok(resolver.out)
}

/// The registered file `name` when it may be imported (it lies in [`IMPORT_DIR`]).
fn importable(name: &str) -> Option<(&'static str, &'static str)> {
    ALL.iter()
        .find(|s| s.file == name && s.file.starts_with(IMPORT_DIR))
        .map(|s| (s.file, s.source))
}

/// Parses and validates resolved WGSL with naga; errors point into the original files.
pub fn validate_resolved(file: &str, r: &Resolved<'_>) -> Result<naga::Module, ShaderError> {
    let label = format!("{file} (resolved)");
    let error = |location, message: String, report| ShaderError::Wgsl {
        at: r.place(location),
        message,
        report,
        file: file.to_owned(),
    };
    let module = naga::front::wgsl::parse_str(&r.source).map_err(|e| {
        error(
            e.location(&r.source),
            e.message().to_owned(),
            e.emit_to_string_with_path(&r.source, &label),
        )
    })?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .map_err(|e| {
        error(
            e.location(&r.source),
            e.as_inner().to_string(),
            e.emit_to_string_with_path(&r.source, &label),
        )
    })?;
    Ok(module)
}

impl Shader {
    const fn new(file: &'static str, source: &'static str) -> Self {
        Self {
            file,
            source,
            resolved: OnceLock::new(),
        }
    }

    /// The shader with its imports resolved (computed once, then cached).
    pub fn resolved(&self) -> Result<&Resolved<'static>, ShaderError> {
        self.resolved
            .get_or_init(|| resolve(self.file, self.source, &importable))
            .as_ref()
            .map_err(Clone::clone)
    }

    /// Compiles the resolved shader into a module labelled `"Shader::<file>"`.
    ///
    /// # Panics
    /// When the embedded sources do not resolve (an unknown or cyclic `#import`): a defect of
    /// the build itself, which the test `every_registered_shader_resolves_and_validates` rules
    /// out.
    pub fn module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        let resolved = self
            .resolved()
            .unwrap_or_else(|e| panic!("embedded shader does not resolve: {e}"));
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&format!("Shader::{}", self.file)),
            source: wgpu::ShaderSource::Wgsl(resolved.source.as_str().into()),
        })
    }

    /// Resolves, parses and validates the shader with naga (no device needed).
    pub fn validate(&self) -> Result<naga::Module, ShaderError> {
        validate_resolved(self.file, self.resolved()?)
    }
}

/// Path of the shader folder in the source tree (for tests and tooling).
pub fn source_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders")
}

/// The value of the module-scope constant `name` (a literal) of a validated module: for tests
/// that keep WGSL constants equal to their Rust counterparts.
#[cfg(test)]
pub(crate) fn constant(module: &naga::Module, name: &str) -> Option<naga::Literal> {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))?;
    match module.global_expressions[c.init] {
        naga::Expression::Literal(literal) => Some(literal),
        _ => None,
    }
}

#[cfg(test)]
mod tests;
