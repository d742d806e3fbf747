//! On-disk types of the `.vlf` file, independent of the in-memory ones so that a change to
//! [`crate::lightfield::LightField`] or its parts can never change the file layout silently: every conversion
//! below names each field, and `tests/format.rs` pins the sizes and a golden byte prefix.
//!
//! Layout (see `docs/FORMAT.md`): a 32-byte [`Preamble`], the bincode-encoded [`FileHeader`]
//! (which holds the section table), then the sections, each starting at a multiple of
//! [`SECTION_ALIGN`]. These items are public for tools and tests (the fuzzer edits headers).

use bytemuck::{Pod, Zeroable};
use serde::{Deserialize, Serialize};

use crate::directions::{DirectionScheme, DirectionSet, DirectionSetDesc};
use crate::lightfield::{
    BakeFace, BakeParams, BakeStats, BakeTriangle, Denoiser, GatherParams, Iterations,
};
use crate::scene::{Camera, SceneSummary, Similarity};

/// The first 8 bytes of every `.vlf` file.
pub const MAGIC: [u8; 8] = *b"VLFIELD\0";
/// The version this build writes. Version 3: the atlas holds irradiance, the file holds the
/// materials, uvs and textures the renderer shades it with, and the header records the final
/// gather's settings (version 1 held outgoing radiance with the textures baked in at the
/// atlas's resolution; version 2, made only by development builds, added the final gather's
/// settings to version 1's layout).
pub const VERSION: u32 = 3;
/// The versions this build reads.
pub const SUPPORTED_VERSIONS: std::ops::RangeInclusive<u32> = 3..=3;
/// Alignment of every section's offset (bytes).
pub const SECTION_ALIGN: u64 = 16;
/// Upper bound of [`Preamble::header_len`]: a corrupt length cannot make a reader allocate
/// more than this for the header.
pub const MAX_HEADER_LEN: usize = 16 << 20;
/// Bytes of the preamble.
pub const PREAMBLE_LEN: usize = 32;
/// Bytes of the preamble covered by [`Preamble::header_checksum`] (all but the checksum).
pub const PREAMBLE_HASHED_LEN: usize = 24;

/// The fixed-size start of the file (32 bytes, little-endian).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Preamble {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// Bytes of the bincode header that follows the preamble.
    pub header_len: u32,
    /// Total length of the file in bytes.
    pub file_len: u64,
    /// XXH64 (seed 0) of preamble bytes 0..24 followed by the header bytes.
    pub header_checksum: u64,
}

impl Preamble {
    /// From the first [`PREAMBLE_LEN`] bytes of a file.
    pub fn from_bytes(b: &[u8; PREAMBLE_LEN]) -> Self {
        let mut p: Preamble = bytemuck::pod_read_unaligned(b);
        p.version = u32::from_le(p.version);
        p.header_len = u32::from_le(p.header_len);
        p.file_len = u64::from_le(p.file_len);
        p.header_checksum = u64::from_le(p.header_checksum);
        p
    }

    /// The on-disk bytes.
    pub fn to_bytes(&self) -> [u8; PREAMBLE_LEN] {
        let le = Preamble {
            magic: self.magic,
            version: self.version.to_le(),
            header_len: self.header_len.to_le(),
            file_len: self.file_len.to_le(),
            header_checksum: self.header_checksum.to_le(),
        };
        bytemuck::cast(le)
    }
}

/// The header checksum: XXH64 (seed 0) of the first 24 preamble bytes and the header.
pub fn header_checksum(preamble: &Preamble, header: &[u8]) -> u64 {
    let mut bytes = Vec::with_capacity(PREAMBLE_HASHED_LEN + header.len());
    bytes.extend_from_slice(&preamble.to_bytes()[..PREAMBLE_HASHED_LEN]);
    bytes.extend_from_slice(header);
    crate::hash::xxh64(&bytes, 0)
}

/// The bincode configuration of the header: bincode 2 "standard" (little-endian, variable-length
/// integers), with a decoding limit so that no length inside a corrupt header can cause a
/// large allocation.
pub fn bincode_config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<MAX_HEADER_LEN>()
}

/// Encodes a header.
pub fn encode_header(h: &FileHeader) -> Result<Vec<u8>, bincode::error::EncodeError> {
    bincode::serde::encode_to_vec(h, bincode_config())
}

/// Decodes a header, requiring that it fills `bytes` exactly.
pub fn decode_header(bytes: &[u8]) -> Result<FileHeader, String> {
    let (h, used): (FileHeader, usize) =
        bincode::serde::decode_from_slice(bytes, bincode_config()).map_err(|e| e.to_string())?;
    if used != bytes.len() {
        return Err(format!(
            "{} unused bytes after the header's {used}",
            bytes.len() - used
        ));
    }
    Ok(h)
}

/// The header: everything but the bulk arrays, and the section table locating those.
///
/// Field order is the on-disk order; changing it (or any type below) requires a new
/// [`VERSION`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileHeader {
    pub params: FileParams,
    pub directions: FileDirections,
    pub transform: FileTransform,
    pub scene: FileSceneSummary,
    pub cameras: Vec<FileCamera>,
    pub stats: FileStats,
    /// [`RadianceEncoding::id`](crate::lightfield::RadianceEncoding::id) of the `irradiance`
    /// and `tile_radiance` sections.
    pub radiance_encoding: u32,
    /// Number of atlas texels (elements of the `irradiance` section).
    pub texels: u64,
    pub sections: Vec<SectionEntry>,
}

/// One entry of the section table.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SectionEntry {
    /// Role of the section (`"triangles"`, `"faces"`, `"irradiance"`, …; names are unique).
    pub name: String,
    /// Element type ([`KIND_TRIANGLE`], …); each kind has one element size.
    pub kind: u32,
    /// A reader that does not know this section must reject the file (rather than skip it).
    pub required: bool,
    /// Byte offset from the start of the file (a multiple of [`SECTION_ALIGN`]).
    pub offset: u64,
    /// Byte length (= `count × elem_size`).
    pub byte_len: u64,
    /// Number of elements.
    pub count: u64,
    /// Bytes per element.
    pub elem_size: u32,
    /// Section checksum (`hash::section_checksum` of its bytes).
    pub checksum: u64,
}

/// Section element kinds.
pub const KIND_TRIANGLE: u32 = 1;
pub const KIND_FACE: u32 = 2;
/// Light values (irradiance, tile radiance); the encoding is
/// [`FileHeader::radiance_encoding`].
pub const KIND_RADIANCE: u32 = 3;
/// Packed u32 words of the mirror tile index (see `format::tiles`).
pub const KIND_TILE_INDEX: u32 = 4;
/// Materials (`format::shading::FileMaterial`).
pub const KIND_MATERIAL: u32 = 5;
/// Triangle uvs (`format::shading::FileUvs`), one per triangle.
pub const KIND_UVS: u32 = 6;
/// Texture sizes and wrap modes (`format::shading::FileTexture`).
pub const KIND_TEXTURE: u32 = 7;
/// Texture texels: IEEE binary16 r, g, b (6 bytes), whatever the radiance encoding.
pub const KIND_TEXELS: u32 = 8;
/// How the final gather sampled and filtered the atlas ([`FileGatherSampling`], one element;
/// optional: written when the gather sampled adaptively, guided or denoised).
pub const KIND_GATHER_SAMPLING: u32 = 9;
/// Per triangle: `TEXCOORD_1` at its corners (`format::shading::FileUvs`); written when some
/// material reads a texture with set 1.
pub const KIND_UVS1: u32 = 10;
/// Per triangle: three vectors at its corners (`format::shading::FileCorners`): the shading
/// normals (section `normals`) or the vertex colours (section `colors`).
pub const KIND_CORNERS: u32 = 11;
/// Per material: which texture slots read `TEXCOORD_1` (`u32`: bit 0 base colour, bit 1
/// emissive).
pub const KIND_MATERIAL_TEXCOORDS: u32 = 12;

/// Section `gather_sampling`: the parts of [`GatherParams`] the header's [`FileGather`] has
/// no field for (added without a new version: an optional section, which older readers skip).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FileGatherSampling {
    /// 1: the rays were guided ([`crate::lightfield::Sampling::guided`]).
    pub guided: u32,
    pub target_error: f32,
    pub max_rounds: u32,
    /// The filter run over the atlas ([`GatherParams::denoise`]): [`DENOISE_OFF`],
    /// [`DENOISE_EDGE`] or [`DENOISE_OIDN`]. Files before OIDN wrote 0 or 1 (a bool), which
    /// read as before; a reader of that time reads 2 as 1 (some filter ran).
    pub denoise: u32,
}

/// [`FileGatherSampling::denoise`]: no filter.
pub const DENOISE_OFF: u32 = 0;
/// vlf's edge-aware filter (`gather::denoise`).
pub const DENOISE_EDGE: u32 = 1;
/// Intel Open Image Denoise's `RTLightmap` filter (`gather::denoise::oidn`).
pub const DENOISE_OIDN: u32 = 2;

impl FileGatherSampling {
    /// The record of `g`, or `None` when it sampled as before the section existed.
    pub fn of(g: &GatherParams) -> Option<Self> {
        (!g.sampling.is_fixed() || g.denoise.is_on()).then_some(FileGatherSampling {
            guided: u32::from(g.sampling.guided),
            target_error: g.sampling.target_error,
            max_rounds: g.sampling.max_rounds,
            denoise: match g.denoise {
                Denoiser::Off => DENOISE_OFF,
                Denoiser::Edge => DENOISE_EDGE,
                Denoiser::Oidn => DENOISE_OIDN,
            },
        })
    }

    /// Writes the record into `g`; an unknown denoiser is an error naming its value.
    pub fn apply(&self, g: &mut GatherParams) -> Result<(), String> {
        g.sampling = crate::lightfield::Sampling {
            guided: self.guided != 0,
            target_error: self.target_error,
            max_rounds: self.max_rounds,
        };
        g.denoise = match self.denoise {
            DENOISE_OFF => Denoiser::Off,
            DENOISE_EDGE => Denoiser::Edge,
            DENOISE_OIDN => Denoiser::Oidn,
            v => return Err(format!("unknown denoiser {v} (0 off, 1 vlf's, 2 OIDN)")),
        };
        Ok(())
    }
}

/// What lets light through each material ([`crate::format::shading::FileSurface`], one per
/// material; written, required, when a material masks or is a pane).
pub const KIND_SURFACE: u32 = 13;
/// Texture alpha: IEEE binary16 (2 bytes) per texel, the `texels` section's texels; written,
/// required, when a material masks.
pub const KIND_TEXTURE_ALPHA: u32 = 14;

/// Section names.
pub const SECTION_TRIANGLES: &str = "triangles";
pub const SECTION_FACES: &str = "faces";
pub const SECTION_IRRADIANCE: &str = "irradiance";
pub const SECTION_MATERIALS: &str = "materials";
pub const SECTION_UVS: &str = "uvs";
pub const SECTION_TEXTURES: &str = "textures";
pub const SECTION_TEXELS: &str = "texels";
pub const SECTION_GATHER_SAMPLING: &str = "gather_sampling";
pub const SECTION_SURFACES: &str = "surfaces";
pub const SECTION_TEXTURE_ALPHA: &str = "texture_alpha";
/// Optional sections of the per-corner attributes (required when written: a reader that
/// cannot use them cannot render the file right); each is written only where the scene has
/// the attribute, so files of scenes without them are unchanged.
pub const SECTION_UVS1: &str = "uvs1";
pub const SECTION_NORMALS: &str = "normals";
pub const SECTION_COLORS: &str = "colors";
pub const SECTION_MATERIAL_TEXCOORDS: &str = "material_texcoords";
/// Optional pair: both present (scenes with mirror/mixed faces) or both absent.
pub const SECTION_TILE_INDEX: &str = "tile_index";
pub const SECTION_TILE_RADIANCE: &str = "tile_radiance";
/// Bytes per texture texel (f16 RGB).
pub const TEXEL_BYTES: usize = 6;

/// A triangle (48 bytes; every field a 4-byte little-endian word).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileTriangle {
    pub p0: [f32; 3],
    pub face: u32,
    pub p1: [f32; 3],
    pub reserved0: u32,
    pub p2: [f32; 3],
    pub reserved1: u32,
}

/// A face with its atlas chart (80 bytes; every field a 4-byte little-endian word).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FileFace {
    pub normal: [f32; 3],
    pub offset: f32,
    pub origin: [f32; 3],
    pub texel_size: f32,
    pub u: [f32; 3],
    pub width: u32,
    pub v: [f32; 3],
    pub height: u32,
    pub texel_base: u32,
    pub kind: u32,
    pub specular: f32,
    /// Index into the `materials` section.
    pub material: u32,
}

/// Converts every 4-byte word of `items` between little-endian and native order (a no-op on
/// little-endian machines). Only for types made of 4-byte words.
pub fn swap_words_le<T: Pod>(items: &mut [T]) {
    if cfg!(target_endian = "big") {
        for w in bytemuck::cast_slice_mut::<T, u32>(items) {
            *w = u32::from_le(*w);
        }
    }
}

impl From<&BakeTriangle> for FileTriangle {
    fn from(t: &BakeTriangle) -> Self {
        FileTriangle {
            p0: t.p0,
            face: t.face,
            p1: t.p1,
            reserved0: 0,
            p2: t.p2,
            reserved1: 0,
        }
    }
}

impl From<&FileTriangle> for BakeTriangle {
    fn from(t: &FileTriangle) -> Self {
        BakeTriangle {
            p0: t.p0,
            face: t.face,
            p1: t.p1,
            _pad0: 0,
            p2: t.p2,
            _pad1: 0,
        }
    }
}

impl From<&BakeFace> for FileFace {
    fn from(f: &BakeFace) -> Self {
        FileFace {
            normal: f.normal,
            offset: f.offset,
            origin: f.origin,
            texel_size: f.texel_size,
            u: f.u,
            width: f.width,
            v: f.v,
            height: f.height,
            texel_base: f.texel_base,
            kind: f.kind,
            specular: f.specular,
            material: f.material,
        }
    }
}

impl From<&FileFace> for BakeFace {
    fn from(f: &FileFace) -> Self {
        BakeFace {
            normal: f.normal,
            offset: f.offset,
            origin: f.origin,
            texel_size: f.texel_size,
            u: f.u,
            width: f.width,
            v: f.v,
            height: f.height,
            texel_base: f.texel_base,
            kind: f.kind,
            specular: f.specular,
            material: f.material,
        }
    }
}

/// [`BakeParams`] on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileParams {
    pub directions: u32,
    pub resolution: u32,
    pub tile: u32,
    pub texel_scale: f32,
    pub iterations: FileIterations,
    pub sky: [f32; 3],
    pub perturb: u32,
    pub seed: u64,
    /// The final gather's settings (`None`: the light field alone).
    pub final_gather: Option<FileGather>,
}

/// [`GatherParams`] on disk.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileGather {
    pub texel_scale: f32,
    pub indirect_texel_scale: f32,
    pub light_samples: u32,
    pub direct_rays: u32,
    pub indirect_rays: u32,
}

/// [`Iterations`] on disk (variant index 0 = fixed, 1 = converge).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum FileIterations {
    Fixed(u32),
    Converge { threshold: f32, max: u32 },
}

impl From<&BakeParams> for FileParams {
    fn from(p: &BakeParams) -> Self {
        FileParams {
            directions: p.directions,
            resolution: p.resolution,
            tile: p.tile,
            texel_scale: p.texel_scale,
            iterations: match p.iterations {
                Iterations::Fixed(n) => FileIterations::Fixed(n),
                Iterations::Converge { threshold, max } => {
                    FileIterations::Converge { threshold, max }
                }
            },
            sky: p.sky.into(),
            perturb: p.perturb,
            seed: p.seed,
            final_gather: p.final_gather.map(|g| FileGather {
                texel_scale: g.texel_scale,
                indirect_texel_scale: g.indirect_texel_scale,
                light_samples: g.light_samples,
                direct_rays: g.direct_rays,
                indirect_rays: g.indirect_rays,
            }),
        }
    }
}

impl From<&FileParams> for BakeParams {
    fn from(p: &FileParams) -> Self {
        BakeParams {
            directions: p.directions,
            resolution: p.resolution,
            tile: p.tile,
            texel_scale: p.texel_scale,
            iterations: match p.iterations {
                FileIterations::Fixed(n) => Iterations::Fixed(n),
                FileIterations::Converge { threshold, max } => {
                    Iterations::Converge { threshold, max }
                }
            },
            sky: p.sky.into(),
            perturb: p.perturb,
            seed: p.seed,
            final_gather: p.final_gather.map(|g| GatherParams {
                texel_scale: g.texel_scale,
                indirect_texel_scale: g.indirect_texel_scale,
                light_samples: g.light_samples,
                direct_rays: g.direct_rays,
                indirect_rays: g.indirect_rays,
                // The section `gather_sampling` holds these (`FileGatherSampling`).
                sampling: crate::lightfield::Sampling::FIXED,
                denoise: crate::lightfield::Denoiser::Off,
            }),
        }
    }
}

/// The direction set's description on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileDirections {
    /// Construction scheme: 1 = icosahedral gnomonic geodesic v1.
    pub scheme: u32,
    /// Subdivision frequency k.
    pub frequency: u32,
    /// Number of directions l (= 5k² + 1; redundant, for tools).
    pub count: u32,
}

/// On-disk id of [`DirectionScheme::IcosahedralGnomonicV1`].
pub const SCHEME_ICOSAHEDRAL_GNOMONIC_V1: u32 = 1;

impl From<&DirectionSet> for FileDirections {
    fn from(d: &DirectionSet) -> Self {
        let desc = d.desc();
        FileDirections {
            scheme: match desc.scheme {
                DirectionScheme::IcosahedralGnomonicV1 => SCHEME_ICOSAHEDRAL_GNOMONIC_V1,
            },
            frequency: desc.frequency,
            count: d.len() as u32,
        }
    }
}

impl FileDirections {
    /// The in-memory description, or `None` for an unknown scheme.
    pub fn desc(&self) -> Option<DirectionSetDesc> {
        let scheme = match self.scheme {
            SCHEME_ICOSAHEDRAL_GNOMONIC_V1 => DirectionScheme::IcosahedralGnomonicV1,
            _ => return None,
        };
        Some(DirectionSetDesc {
            scheme,
            frequency: self.frequency,
        })
    }
}

/// [`Similarity`] on disk.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileTransform {
    pub center: [f32; 3],
    pub scale: f32,
}

impl From<&Similarity> for FileTransform {
    fn from(s: &Similarity) -> Self {
        FileTransform {
            center: s.center.into(),
            scale: s.scale,
        }
    }
}

impl From<&FileTransform> for Similarity {
    fn from(s: &FileTransform) -> Self {
        Similarity {
            center: s.center.into(),
            scale: s.scale,
        }
    }
}

/// [`SceneSummary`] on disk (counts as u64).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileSceneSummary {
    pub source: String,
    pub triangles: u64,
    pub faces: u64,
    pub materials: u64,
    pub diffuse_materials: u64,
    pub mirror_materials: u64,
    pub mixed_materials: u64,
    pub emissive_materials: u64,
    pub emissive_faces: u64,
    pub emissive_triangles: u64,
    pub cameras: u64,
    pub suns: u64,
    pub textures: u64,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub warnings: u64,
}

impl From<&SceneSummary> for FileSceneSummary {
    fn from(s: &SceneSummary) -> Self {
        let n = |v: usize| v as u64;
        FileSceneSummary {
            source: s.source.clone(),
            triangles: n(s.triangles),
            faces: n(s.faces),
            materials: n(s.materials),
            diffuse_materials: n(s.diffuse_materials),
            mirror_materials: n(s.mirror_materials),
            mixed_materials: n(s.mixed_materials),
            emissive_materials: n(s.emissive_materials),
            emissive_faces: n(s.emissive_faces),
            emissive_triangles: n(s.emissive_triangles),
            cameras: n(s.cameras),
            suns: n(s.suns),
            textures: n(s.textures),
            bounds_min: s.bounds_min,
            bounds_max: s.bounds_max,
            warnings: n(s.warnings),
        }
    }
}

impl FileSceneSummary {
    /// The in-memory summary (counts saturate at `usize::MAX` on 32-bit targets).
    pub fn to_summary(&self) -> SceneSummary {
        let n = |v: u64| usize::try_from(v).unwrap_or(usize::MAX);
        SceneSummary {
            source: self.source.clone(),
            triangles: n(self.triangles),
            faces: n(self.faces),
            materials: n(self.materials),
            diffuse_materials: n(self.diffuse_materials),
            mirror_materials: n(self.mirror_materials),
            mixed_materials: n(self.mixed_materials),
            emissive_materials: n(self.emissive_materials),
            emissive_faces: n(self.emissive_faces),
            emissive_triangles: n(self.emissive_triangles),
            cameras: n(self.cameras),
            suns: n(self.suns),
            textures: n(self.textures),
            bounds_min: self.bounds_min,
            bounds_max: self.bounds_max,
            warnings: n(self.warnings),
        }
    }
}

/// [`Camera`] on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileCamera {
    pub name: Option<String>,
    pub position: [f32; 3],
    /// Quaternion x, y, z, w.
    pub rotation: [f32; 4],
    pub yfov: f32,
    pub aspect_ratio: Option<f32>,
    pub znear: f32,
    pub zfar: Option<f32>,
}

impl From<&Camera> for FileCamera {
    fn from(c: &Camera) -> Self {
        FileCamera {
            name: c.name.clone(),
            position: c.position.into(),
            rotation: c.rotation.to_array(),
            yfov: c.yfov,
            aspect_ratio: c.aspect_ratio,
            znear: c.znear,
            zfar: c.zfar,
        }
    }
}

impl From<&FileCamera> for Camera {
    fn from(c: &FileCamera) -> Self {
        Camera {
            name: c.name.clone(),
            position: c.position.into(),
            rotation: glam::Quat::from_array(c.rotation),
            yfov: c.yfov,
            aspect_ratio: c.aspect_ratio,
            znear: c.znear,
            zfar: c.zfar,
        }
    }
}

/// [`BakeStats`] on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileStats {
    pub iterations: u32,
    pub device: String,
    pub adapter: String,
    pub phases: Vec<(String, f64)>,
    pub emitted: f64,
    pub injected: f64,
    pub absorbed: f64,
    pub escaped: f64,
    pub unshot: f64,
    pub unshot_history: Vec<f64>,
}

impl From<&BakeStats> for FileStats {
    fn from(s: &BakeStats) -> Self {
        FileStats {
            iterations: s.iterations,
            device: s.device.clone(),
            adapter: s.adapter.clone(),
            phases: s.phases.clone(),
            emitted: s.emitted,
            injected: s.injected,
            absorbed: s.absorbed,
            escaped: s.escaped,
            unshot: s.unshot,
            unshot_history: s.unshot_history.clone(),
        }
    }
}

impl From<&FileStats> for BakeStats {
    fn from(s: &FileStats) -> Self {
        BakeStats {
            iterations: s.iterations,
            device: s.device.clone(),
            adapter: s.adapter.clone(),
            phases: s.phases.clone(),
            emitted: s.emitted,
            injected: s.injected,
            absorbed: s.absorbed,
            escaped: s.escaped,
            unshot: s.unshot,
            unshot_history: s.unshot_history.clone(),
        }
    }
}

fn align16(x: u64) -> u64 {
    x.div_ceil(SECTION_ALIGN) * SECTION_ALIGN
}

/// For tools and tests: re-encodes the header of `file` after `edit` and recomputes the header
/// checksum, keeping the section data where the (edited) section table says relative to the
/// data's start. `edit` sees the offsets as they are in `file`; if the new header is longer
/// than the old one, the data and every offset move by the same multiple of 16. Only the
/// preamble has to be intact; errors say what prevents the rewrite.
pub fn rewrite_header(file: &[u8], edit: impl FnOnce(&mut FileHeader)) -> Result<Vec<u8>, String> {
    let pre: &[u8; PREAMBLE_LEN] = file
        .get(..PREAMBLE_LEN)
        .and_then(|b| b.try_into().ok())
        .ok_or("no preamble")?;
    let mut preamble = Preamble::from_bytes(pre);
    let header_end = PREAMBLE_LEN + preamble.header_len as usize;
    let header_bytes = file
        .get(PREAMBLE_LEN..header_end)
        .ok_or("truncated header")?;
    let mut header = decode_header(header_bytes)?;
    let data_start = align16(header_end as u64);
    let data = file.get(data_start as usize..).unwrap_or(&[]);
    edit(&mut header);
    let mut start = data_start;
    for _ in 0..8 {
        let bytes = encode_header(&header).map_err(|e| e.to_string())?;
        let need = align16((PREAMBLE_LEN + bytes.len()) as u64);
        if need <= start {
            preamble.header_len = bytes.len() as u32;
            preamble.file_len = start + data.len() as u64;
            preamble.header_checksum = header_checksum(&preamble, &bytes);
            let mut out = preamble.to_bytes().to_vec();
            out.extend_from_slice(&bytes);
            out.resize(start as usize, 0);
            out.extend_from_slice(data);
            return Ok(out);
        }
        let delta = need - start;
        for s in &mut header.sections {
            s.offset = s.offset.wrapping_add(delta);
        }
        start = need;
    }
    Err("the header length does not settle".into())
}
