//! The baked light field in memory: what the baker produces, the file stores and the viewer
//! renders. Full-precision (f32) radiance here; the file stores a compact encoding.

use serde::{Deserialize, Serialize};

use crate::bake::reference::EnergyStats;
use crate::bake::tiles::TileIndex;
use crate::bake::{BakeFace, BakeParams, BakeTriangle};
use crate::directions::DirectionSet;
use crate::scene::{Camera, SceneSummary, Similarity};

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
    pub fn set_energy(&mut self, e: &EnergyStats) {
        self.emitted = e.emitted;
        self.injected = e.injected;
        self.absorbed = e.absorbed;
        self.escaped = e.escaped;
        self.unshot = e.unshot;
        self.unshot_history = e.unshot_history.clone();
    }

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
    /// Faces with their atlas charts.
    pub faces: Vec<BakeFace>,
    /// Total outgoing radiance per atlas texel (rgb, a unused), emission included; both sides
    /// of every face (see [`BakeFace::texel_base`]).
    pub radiance: Vec<[f32; 4]>,
    /// Sparse per-direction tiles of the mirror and mixed faces (specular part of their
    /// outgoing radiance); `None` for diffuse-only scenes.
    pub tiles: Option<MirrorTiles>,
    pub stats: BakeStats,
}

/// Specular outgoing radiance of non-diffuse faces (see `bake::tiles` for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct MirrorTiles {
    pub index: TileIndex,
    /// Total outgoing radiance per tile value (rgb, a unused): `index.value_len()` entries.
    pub radiance: Vec<[f32; 4]>,
}

impl LightField {
    /// Bytes of the radiance data in memory (atlas and mirror tiles).
    pub fn radiance_bytes(&self) -> usize {
        std::mem::size_of_val(self.radiance.as_slice())
            + self
                .tiles
                .as_ref()
                .map_or(0, |t| std::mem::size_of_val(t.radiance.as_slice()))
    }
}
