//! `vlf-bake export`: a light-field file as a glTF binary with lightmaps.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use vlf_core::export::{ExportOptions, LightmapEncoding, export_glb};

use crate::cli::TextureArg;

pub fn export_command(
    file: &Path,
    output: &Path,
    texture: TextureArg,
    max_size: u32,
    scene: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let encoding = match texture {
        TextureArg::Exr => LightmapEncoding::Exr,
        TextureArg::PngRgbm => LightmapEncoding::PngRgbm,
        TextureArg::Ktx2 => LightmapEncoding::Ktx2,
    };
    let lf = vlf_core::format::read(file)?;
    let scene_path = match scene {
        Some(p) => p.to_path_buf(),
        None => source_path(file, &lf.scene.source),
    };
    let scene = vlf_core::scene::load(&scene_path).with_context(|| {
        format!(
            "loading the scene the light field was baked from (pass --scene if it moved): {}",
            scene_path.display()
        )
    })?;
    let options = ExportOptions { encoding, max_size };
    let exported = export_glb(&lf, &scene, &options)
        .with_context(|| format!("exporting {}", file.display()))?;
    vlf_core::atomic_file::write_bytes(output, &exported.glb)
        .with_context(|| format!("writing {}", output.display()))?;
    let s = &exported.summary;
    if json {
        println!("{}", serde_json::to_string_pretty(s)?);
    } else {
        let pages: Vec<String> = s.pages.iter().map(|(w, h)| format!("{w}×{h}")).collect();
        println!(
            "{}: {} triangles, {} vertices, {} materials, {} cameras, lightmap {} ({}), {} bytes",
            output.display(),
            s.triangles,
            s.vertices,
            s.materials,
            s.cameras,
            s.encoding,
            pages.join(", "),
            s.bytes
        );
    }
    Ok(())
}

/// The recorded source path: as written when it exists, else relative to the file's folder.
fn source_path(file: &Path, source: &str) -> PathBuf {
    let p = PathBuf::from(source);
    if p.is_absolute() || p.exists() {
        return p;
    }
    file.parent().map_or(p.clone(), |d| d.join(&p))
}
