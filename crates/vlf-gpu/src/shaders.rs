//! Registry of the WGSL shaders under the repository's `shaders/` folder.
//!
//! Every shader is embedded with `include_str!`, so release binaries are self-contained. The test
//! below checks that the registry and the folder agree and validates every file with naga.

/// One WGSL file of `shaders/`.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// File name under `shaders/`.
    pub file: &'static str,
    /// The WGSL source.
    pub source: &'static str,
}

macro_rules! shader {
    ($file:literal) => {
        Shader {
            file: $file,
            source: include_str!(concat!("../../../shaders/", $file)),
        }
    };
}

pub const SMOKE: Shader = shader!("smoke.wgsl");
pub const BAKE_CELLS: Shader = shader!("bake_cells.wgsl");
pub const BAKE_INTERFACE: Shader = shader!("bake_interface.wgsl");
pub const BAKE_GATHER: Shader = shader!("bake_gather.wgsl");
pub const BAKE_REFLECT: Shader = shader!("bake_reflect.wgsl");
pub const RENDER_DIRECTION_IDS: Shader = shader!("render_direction_ids.wgsl");
pub const RENDER_BARYCENTRICS: Shader = shader!("render_barycentrics.wgsl");
pub const RENDER_FACE_ID: Shader = shader!("render_face_id.wgsl");
pub const RENDER_POSITION: Shader = shader!("render_position.wgsl");
pub const RENDER_FINAL_RADIANCE: Shader = shader!("render_final_radiance.wgsl");
pub const RENDER_DISPLAY: Shader = shader!("render_display.wgsl");
pub const RAYTRACE_ENGINE: Shader = shader!("raytrace_engine.wgsl");
pub const RAYTRACE_PATH: Shader = shader!("raytrace_path.wgsl");
pub const RADIOSITY_JACOBI: Shader = shader!("radiosity_jacobi.wgsl");

/// Every shader of the project. The test `registry_matches_folder` keeps this list complete.
pub const ALL: &[Shader] = &[
    SMOKE,
    BAKE_CELLS,
    BAKE_INTERFACE,
    BAKE_GATHER,
    BAKE_REFLECT,
    RENDER_DIRECTION_IDS,
    RENDER_BARYCENTRICS,
    RENDER_FACE_ID,
    RENDER_POSITION,
    RENDER_FINAL_RADIANCE,
    RENDER_DISPLAY,
    RAYTRACE_ENGINE,
    RAYTRACE_PATH,
    RADIOSITY_JACOBI,
];

impl Shader {
    /// Compiles the shader into a module labelled `"Shader::<file>"`.
    pub fn module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&format!("Shader::{}", self.file)),
            source: wgpu::ShaderSource::Wgsl(self.source.into()),
        })
    }

    /// Parses and validates the shader with naga (no device needed).
    pub fn validate(&self) -> Result<wgpu::naga::Module, String> {
        use wgpu::naga;
        let module = naga::front::wgsl::parse_str(self.source)
            .map_err(|e| format!("{}: {}", self.file, e.emit_to_string(self.source)))?;
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .map_err(|e| format!("{}: {}", self.file, e.emit_to_string(self.source)))?;
        Ok(module)
    }
}

/// Path of the shader folder in the source tree (for tests and tooling).
pub fn source_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_wgsl_file_validates_with_naga() {
        let dir = source_dir();
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
            .collect();
        files.sort();
        assert!(
            !files.is_empty(),
            "no WGSL files found in {}",
            dir.display()
        );
        let mut errors = Vec::new();
        for path in &files {
            let source = std::fs::read_to_string(path).unwrap();
            let shader = Shader {
                file: "on-disk",
                source: Box::leak(source.into_boxed_str()),
            };
            if let Err(e) = shader.validate() {
                errors.push(format!("{}: {e}", path.display()));
            }
        }
        assert!(errors.is_empty(), "invalid shaders:\n{}", errors.join("\n"));
    }

    #[test]
    fn registry_matches_folder() {
        let mut on_disk: Vec<String> = std::fs::read_dir(source_dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".wgsl"))
            .collect();
        on_disk.sort();
        let mut registered: Vec<String> = ALL.iter().map(|s| s.file.to_owned()).collect();
        registered.sort();
        assert!(!registered.is_empty());
        assert_eq!(on_disk, registered, "shaders/ and shaders::ALL disagree");
        for s in ALL {
            s.validate().unwrap();
        }
    }
}
