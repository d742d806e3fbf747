//! The baked light field in memory: what the baker produces, the file stores and the viewer
//! renders, and the vocabulary the three share: the bake parameters ([`params`]), the
//! geometry records ([`geometry`]: triangles and faces with their atlas charts, in VLF
//! coordinates), the mirror tile index ([`tiles`]), the radiance encodings ([`encoding`]),
//! [`Radiance`], light values kept in their stored encoding (f16 RGB or RGB9E5, the bytes of
//! the file's sections), so loading a file is one read per section and a renderer uploads the
//! values as they are (decoding to f32 happens only where f32 is needed), and [`shading`]:
//! the materials, uvs and textures the renderer applies per pixel to the atlas irradiance.
//!
//! This is the layer `bake` and `format` stand on: it uses only `scene`, `directions` and the
//! checksum block size of `hash`, never the baker or the file code.

pub mod encoding;
pub mod geometry;
pub mod mask;
pub mod params;
mod radiance;
pub mod shading;
pub mod tiles;

use serde::{Deserialize, Serialize};

use crate::directions::DirectionSet;
use crate::scene::{Camera, SceneSummary, Similarity};
pub use encoding::{DEFAULT_ENCODING, RadianceEncoding};
pub use geometry::{BakeFace, BakeTriangle, FACE_DIFFUSE, FACE_MIRROR, FACE_MIXED};
pub use mask::AlphaMasks;
pub use params::{BakeParams, Denoiser, GatherParams, Iterations, ParamsError, Sampling};
pub use radiance::{InvalidStoredRadiance, NonFiniteRadiance, Radiance};
pub use shading::{InvalidShading, NO_TEXTURE, Shading, SurfaceMaterial, SurfaceTexture};
pub use tiles::TileIndex;

/// Timings and bookkeeping of a bake.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BakeStats {
    /// Iterations run.
    pub iterations: u32,
    /// `"gpu"` or `"cpu"`.
    pub device: String,
    /// Adapter description (GPU) or `"CPU reference"`.
    pub adapter: String,
    /// (phase name, seconds), in order.
    pub phases: Vec<(String, f64)>,
    pub emitted: f64,
    pub injected: f64,
    pub absorbed: f64,
    pub escaped: f64,
    pub unshot: f64,
    pub unshot_history: Vec<f64>,
}

impl BakeStats {
    pub fn total_seconds(&self) -> f64 {
        self.phases.iter().map(|p| p.1).sum()
    }
}

/// A baked virtual light field.
#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    pub params: BakeParams,
    pub directions: DirectionSet,
    /// World → VLF transform of the scene.
    pub to_vlf: Similarity,
    pub scene: SceneSummary,
    /// The scene's glTF cameras (world space), for the viewer.
    pub cameras: Vec<Camera>,
    /// Geometry in VLF coordinates.
    pub triangles: Vec<BakeTriangle>,
    /// Faces with their atlas charts and materials.
    pub faces: Vec<BakeFace>,
    /// Irradiance per atlas texel (rgb): all the light arriving at the texel's side, from
    /// surfaces, sky and suns; both sides of every face (see [`BakeFace::texel_base`]). The
    /// renderer turns it into outgoing radiance per pixel with [`Shading`] (`Le + ρ_d/π · E`),
    /// so textures keep their own resolution. Finite and non-negative like radiance, so it is
    /// kept in the same stored encodings.
    pub irradiance: Radiance,
    /// Materials, triangle uvs and textures.
    pub shading: Shading,
    /// Sparse per-direction tiles of the mirror and mixed faces (specular part of their
    /// outgoing radiance); `None` for diffuse-only scenes.
    pub tiles: Option<MirrorTiles>,
    pub stats: BakeStats,
}

/// Specular outgoing radiance of non-diffuse faces (see [`TileIndex`] for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct MirrorTiles {
    pub index: TileIndex,
    /// Total outgoing radiance per tile value (rgb): `index.value_len()` entries.
    pub radiance: Radiance,
}

impl LightField {
    /// The alpha masks of [`triangles`](Self::triangles) (each reads its face's material), in
    /// their order: what pass 3, pass 5 and its mirror tracing apply.
    pub fn alpha_masks(&self) -> AlphaMasks {
        AlphaMasks::from_shading(
            &self.shading,
            self.triangles
                .iter()
                .map(|t| self.faces.get(t.face as usize).map_or(0, |f| f.material)),
        )
    }

    /// Bytes of the stored light in memory (atlas irradiance and mirror tile radiance, as
    /// stored).
    pub fn light_bytes(&self) -> usize {
        self.irradiance.byte_len() + self.tiles.as_ref().map_or(0, |t| t.radiance.byte_len())
    }
}
