//! `vlf-bake info`: a summary of a `.vlf` file from its header alone.

use std::fmt;
use std::path::Path;

use serde::Serialize;

use super::disk::{self, FileHeader, Preamble};
use crate::lightfield::{BakeParams, BakeStats, Iterations, RadianceEncoding};
use crate::scene::{SceneSummary, Similarity};

/// What [`super::describe`] reports.
#[derive(Clone, Debug, Serialize)]
pub struct FileInfo {
    pub path: String,
    pub format_version: u32,
    pub file_bytes: u64,
    pub header_bytes: u64,
    pub params: BakeParams,
    /// Direction set: scheme id, frequency k, and l = 5k² + 1.
    pub direction_scheme: u32,
    pub direction_frequency: u32,
    pub directions: u32,
    pub transform: Similarity,
    pub scene: SceneSummary,
    /// Camera names (`"camera N"` for unnamed ones).
    pub cameras: Vec<String>,
    pub triangles: u64,
    pub faces: u64,
    /// Atlas texels (irradiance values).
    pub texels: u64,
    pub materials: u64,
    pub textures: u64,
    /// Texels of all textures.
    pub texture_texels: u64,
    /// Encoding of the irradiance and the mirror tiles' radiance.
    pub radiance_encoding: String,
    pub sections: Vec<SectionInfo>,
    pub memory: MemoryInfo,
    pub stats: BakeStats,
}

/// One section of the file.
#[derive(Clone, Debug, Serialize)]
pub struct SectionInfo {
    pub name: String,
    pub kind: u32,
    pub required: bool,
    pub offset: u64,
    pub count: u64,
    pub element_bytes: u32,
    /// Bytes in the file.
    pub file_bytes: u64,
    /// Bytes once loaded in memory (light values and texels stay in their stored encoding, so
    /// the same as in the file), `None` for sections unknown to this build.
    pub memory_bytes: Option<u64>,
    pub checksum: String,
}

/// Sizes of the light field on disk and in memory (cf. the paper's Table 1).
#[derive(Clone, Debug, Serialize)]
pub struct MemoryInfo {
    /// Light as stored (atlas irradiance and mirror tile radiance, in the file's encoding):
    /// also its size in the in-memory [`crate::lightfield::LightField`]
    /// ([`crate::lightfield::Radiance`]). The renderer keeps RGB9E5 as it is on the GPU
    /// (`Rgb9e5Ufloat`) and f16 RGB as `Rgba16Float` (8 bytes).
    pub light_file_bytes: u64,
    /// The same as f32 RGBA: what decoding it all would take (and one map of a propagation,
    /// which keeps several such maps per texel).
    pub light_f32_bytes: u64,
    /// Triangles, faces and the mirror tile index (identical on disk and in memory).
    pub geometry_bytes: u64,
    /// Materials, triangle uvs, texture records and texels (f16 RGB; `Rgba16Float` on the GPU).
    pub shading_bytes: u64,
    /// Sum of the sections in memory.
    pub loaded_bytes: u64,
}

impl FileInfo {
    pub(super) fn new(
        path: &Path,
        preamble: &Preamble,
        h: &FileHeader,
        enc: RadianceEncoding,
    ) -> Self {
        let memory_bytes = |s: &disk::SectionEntry| match s.name.as_str() {
            disk::SECTION_IRRADIANCE
            | disk::SECTION_TILE_RADIANCE
            | disk::SECTION_TRIANGLES
            | disk::SECTION_FACES
            | disk::SECTION_TILE_INDEX
            | disk::SECTION_MATERIALS
            | disk::SECTION_UVS
            | disk::SECTION_TEXTURES
            | disk::SECTION_TEXELS
            | disk::SECTION_SURFACES
            | disk::SECTION_TEXTURE_ALPHA => Some(s.byte_len),
            // Read into the bake parameters (`GatherParams`), not kept as data.
            disk::SECTION_GATHER_SAMPLING => Some(0),
            _ => None,
        };
        let sections: Vec<SectionInfo> = h
            .sections
            .iter()
            .map(|s| SectionInfo {
                name: s.name.clone(),
                kind: s.kind,
                required: s.required,
                offset: s.offset,
                count: s.count,
                element_bytes: s.elem_size,
                file_bytes: s.byte_len,
                memory_bytes: memory_bytes(s),
                checksum: format!("{:016x}", s.checksum),
            })
            .collect();
        let get = |name: &str| h.sections.iter().find(|s| s.name == name);
        let count = |name: &str| get(name).map_or(0, |s| s.count);
        let bytes = |name: &str| get(name).map_or(0, |s| s.byte_len);
        let geometry_bytes = bytes(disk::SECTION_TRIANGLES)
            .saturating_add(bytes(disk::SECTION_FACES))
            .saturating_add(bytes(disk::SECTION_TILE_INDEX));
        let light_f32_bytes =
            (h.texels.saturating_add(count(disk::SECTION_TILE_RADIANCE))).saturating_mul(16);
        let shading_bytes = [
            disk::SECTION_MATERIALS,
            disk::SECTION_UVS,
            disk::SECTION_TEXTURES,
            disk::SECTION_TEXELS,
            disk::SECTION_SURFACES,
            disk::SECTION_TEXTURE_ALPHA,
        ]
        .map(bytes)
        .iter()
        .fold(0u64, |a, b| a.saturating_add(*b));
        FileInfo {
            path: path.display().to_string(),
            format_version: preamble.version,
            file_bytes: preamble.file_len,
            header_bytes: u64::from(preamble.header_len),
            params: (&h.params).into(),
            direction_scheme: h.directions.scheme,
            direction_frequency: h.directions.frequency,
            directions: h.directions.count,
            transform: (&h.transform).into(),
            scene: h.scene.to_summary(),
            cameras: h
                .cameras
                .iter()
                .enumerate()
                .map(|(i, c)| c.name.clone().unwrap_or_else(|| format!("camera {i}")))
                .collect(),
            triangles: count(disk::SECTION_TRIANGLES),
            faces: count(disk::SECTION_FACES),
            texels: h.texels,
            materials: count(disk::SECTION_MATERIALS),
            textures: count(disk::SECTION_TEXTURES),
            texture_texels: count(disk::SECTION_TEXELS),
            radiance_encoding: enc.name().into(),
            memory: MemoryInfo {
                light_file_bytes: bytes(disk::SECTION_IRRADIANCE)
                    .saturating_add(bytes(disk::SECTION_TILE_RADIANCE)),
                light_f32_bytes,
                geometry_bytes,
                shading_bytes,
                loaded_bytes: sections
                    .iter()
                    .filter_map(|s| s.memory_bytes)
                    .fold(0, u64::saturating_add),
            },
            sections,
            stats: (&h.stats).into(),
        }
    }
}

/// `1234567` → `"1.18 MiB"`.
fn human(bytes: u64) -> String {
    human_bytes(bytes, 2)
}

/// A byte count in binary units with `decimals` digits after the point (`human_bytes(1234567,
/// 2)` → `"1.18 MiB"`), under 1 KiB in bytes (`"12 B"`): how vlf's tools print sizes.
pub fn human_bytes(bytes: u64, decimals: usize) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.decimals$} {}", UNITS[u])
    }
}

impl fmt::Display for FileInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.params;
        writeln!(f, "{}", self.path)?;
        writeln!(
            f,
            "  format        .vlf version {}, {} ({} header)",
            self.format_version,
            human(self.file_bytes),
            human(self.header_bytes)
        )?;
        writeln!(f, "  scene         {}", self.scene.source)?;
        writeln!(
            f,
            "  geometry      {} triangles, {} faces, {} atlas texels ({} per side × 2 sides on average)",
            self.triangles,
            self.faces,
            self.texels,
            self.texels / 2 / self.faces.max(1)
        )?;
        writeln!(
            f,
            "  directions    {} (frequency {}, {} requested)",
            self.directions, self.direction_frequency, p.directions
        )?;
        writeln!(
            f,
            "  rays          {0} × {0} per direction, {1} × {1} tiles, texel scale {2}, {3} perturbed copies, seed {4:#x}",
            p.resolution, p.tile, p.texel_scale, p.perturb, p.seed
        )?;
        let iterations = match p.iterations {
            Iterations::Fixed(n) => format!("{n}"),
            Iterations::Converge { threshold, max } => {
                format!("until unshot < {threshold} × emitted, at most {max}")
            }
        };
        writeln!(
            f,
            "  iterations    {iterations}; sky {:?}",
            p.sky.to_array()
        )?;
        match &p.final_gather {
            Some(g) => writeln!(
                f,
                "  final gather  texel scale {}, indirect texel scale {}; {} light samples, {} direct rays, {} indirect rays; atlas denoiser {}",
                g.texel_scale,
                g.indirect_texel_scale,
                g.light_samples,
                g.direct_rays,
                g.indirect_rays,
                g.denoise.describe()
            )?,
            None => writeln!(f, "  final gather  none (the atlas is the propagation's)")?,
        }
        writeln!(
            f,
            "  transform     vlf = (world − {:?}) × {}",
            self.transform.center.to_array(),
            self.transform.scale
        )?;
        if !self.cameras.is_empty() {
            writeln!(f, "  cameras       {}", self.cameras.join(", "))?;
        }
        writeln!(
            f,
            "  atlas         irradiance in {}; {} materials, {} textures ({} texels, f16 RGB)",
            self.radiance_encoding, self.materials, self.textures, self.texture_texels
        )?;
        writeln!(
            f,
            "  sections      name                 count         file       memory"
        )?;
        for s in &self.sections {
            writeln!(
                f,
                "                {:<15} {:>10} {:>12} {:>12}{}",
                s.name,
                s.count,
                human(s.file_bytes),
                s.memory_bytes.map_or("?".into(), human),
                if s.memory_bytes.is_none() {
                    "  (unknown section)"
                } else {
                    ""
                }
            )?;
        }
        let m = &self.memory;
        writeln!(
            f,
            "  memory        light {} stored, {} as f32 RGBA; geometry {}; shading {}; {} loaded",
            human(m.light_file_bytes),
            human(m.light_f32_bytes),
            human(m.geometry_bytes),
            human(m.shading_bytes),
            human(m.loaded_bytes)
        )?;
        let s = &self.stats;
        write!(
            f,
            "  bake          {} iterations on {} ({})",
            s.iterations, s.device, s.adapter
        )?;
        if s.phases.is_empty() {
            // Timings are not stored (files are reproducible); `vlf-bake bake --json` reports them.
            writeln!(f)?;
        } else {
            writeln!(f, ", {:.2} s", s.total_seconds())?;
        }
        for (name, secs) in &s.phases {
            writeln!(f, "                {name:<12} {secs:>9.3} s")?;
        }
        write!(
            f,
            "  energy        emitted {:.6}, injected {:.6}, absorbed {:.6}, escaped {:.6}, unshot {:.6}",
            s.emitted, s.injected, s.absorbed, s.escaped, s.unshot
        )
    }
}
