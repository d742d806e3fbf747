//! The plan of a GPU bake: every buffer the propagator allocates, with its label, its size
//! (from the `#[repr(C)]` element types and the scene's counts), its usage, and the chunks of
//! whole directions the per-direction buffers are split into ([`super::chunks`]).
//!
//! [`BakePlan`] is the one list: [`super::propagate_planned`] allocates exactly its buffers
//! (through one helper that takes a [`PlannedBuffer`]; the suite checks what was allocated
//! against the plan) and `vlf-bake`'s memory budget reads the same plan for the GPU side. The
//! plan bins every transport direction once, which is the sizing pass of the propagator too:
//! the per-direction byte counts it keeps place each direction in its chunk, and the upload
//! checks that it bins every direction to exactly those counts.

use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{
    self, ReflectCounts, SpecularSetup, TransportDir, bin_triangles, project,
};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, TileIndex};
use vlf_core::psf::PsfGrid;

use super::chunks::{Chunk, ChunkBytes, Chunker, chunk_cap};
use super::{DIR_STRIDE, GpuBakeError, MAX_CROSSINGS};
use crate::layout::{CellEntry, Crossing, ReflectItem, TexelAccum};

/// The buffers of a GPU bake, by role. Each is one buffer, except the three chunked ones
/// ([`BakeBuffer::chunked`]): one buffer per chunk of directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BakeBuffer {
    /// `BakeTriangle` per triangle (uploaded once).
    Triangles,
    /// `BakeFace` per face.
    Faces,
    /// The triangles' alpha masks (`AlphaMasks::words`).
    AlphaMasks,
    /// Texel centres, face id in `w`.
    TexelCenter,
    /// Indices of the texels the gather visits.
    ActiveTexels,
    /// Unshot radiance of the texels, then of the mirror tile values.
    Unshot,
    /// The mirror tile index, four arrays packed.
    TileIndex,
    /// The fixed directions' frames (u, v, w).
    Frames,
    /// Mirror tile values received in this iteration.
    NextTiles,
    /// Radiance escaping through mirrors, per ray.
    SpecEscape,
    /// Per face, its thin glass pane (`PaneFace`).
    Panes,
    /// What panes absorbed, let escape and passed of a sun, per ray.
    PaneEnergy,
    /// Crossings per ray.
    CellCount,
    /// Per-ray depth lists (`CellEntry`, k_max per ray).
    Cells,
    /// Arriving radiance per crossing (`Crossing`, k_max per ray).
    Crossings,
    /// `TexelAccum` per texel.
    Accumulators,
    /// The longest depth list seen above k_max (4 u32).
    Overflow,
    /// The per-direction uniforms (`BakeDirection` at a 256-byte stride).
    Directions,
    /// Tile starts of the directions of a chunk.
    BinStart,
    /// Binned triangle ids of the directions of a chunk.
    BinTris,
    /// Reflect items of the directions of a chunk.
    ReflectItems,
}

impl BakeBuffer {
    /// The wgpu label (`"Bake::thing"`; chunked buffers add `[k]`).
    pub fn name(self) -> &'static str {
        match self {
            BakeBuffer::Triangles => "Bake::triangles",
            BakeBuffer::Faces => "Bake::faces",
            BakeBuffer::AlphaMasks => "Bake::alpha_masks",
            BakeBuffer::TexelCenter => "Bake::texel_center",
            BakeBuffer::ActiveTexels => "Bake::active_texels",
            BakeBuffer::Unshot => "Bake::unshot",
            BakeBuffer::TileIndex => "Bake::tile_index",
            BakeBuffer::Frames => "Bake::frames",
            BakeBuffer::NextTiles => "Bake::next_tiles",
            BakeBuffer::SpecEscape => "Bake::spec_escape",
            BakeBuffer::Panes => "Bake::panes",
            BakeBuffer::PaneEnergy => "Bake::pane_energy",
            BakeBuffer::CellCount => "Bake::cell_count",
            BakeBuffer::Cells => "Bake::cells",
            BakeBuffer::Crossings => "Bake::crossings",
            BakeBuffer::Accumulators => "Bake::accumulators",
            BakeBuffer::Overflow => "Bake::overflow",
            BakeBuffer::Directions => "Bake::directions",
            BakeBuffer::BinStart => "Bake::bin_start",
            BakeBuffer::BinTris => "Bake::bin_tris",
            BakeBuffer::ReflectItems => "Bake::reflect_items",
        }
    }

    /// What it holds, for messages (`"… needs N bytes in one GPU buffer"`).
    pub fn what(self) -> &'static str {
        match self {
            BakeBuffer::Triangles => "the prepared triangles",
            BakeBuffer::Faces => "the prepared faces",
            BakeBuffer::AlphaMasks => "the alpha masks",
            BakeBuffer::TexelCenter => "the texel centres",
            BakeBuffer::ActiveTexels => "the active texel list",
            BakeBuffer::Unshot => "the unshot radiance (texels and mirror tiles)",
            BakeBuffer::TileIndex => "the mirror tile index",
            BakeBuffer::Frames => "the fixed directions' frames",
            BakeBuffer::NextTiles => "the mirror tile values of one iteration",
            BakeBuffer::SpecEscape => "the escaping radiance of every ray",
            BakeBuffer::Panes => "the faces' panes",
            BakeBuffer::PaneEnergy => "the panes' energy terms of every ray",
            BakeBuffer::CellCount => "the crossing counts of every ray",
            BakeBuffer::Cells => "the ray depth lists",
            BakeBuffer::Crossings => "the ray crossing lists",
            BakeBuffer::Accumulators => "the texel accumulators",
            BakeBuffer::Overflow => "the overflow counter",
            BakeBuffer::Directions => "the per-direction uniforms",
            BakeBuffer::BinStart => "the tile starts",
            BakeBuffer::BinTris => "the tile bins",
            BakeBuffer::ReflectItems => "the reflect items",
        }
    }

    /// One buffer per chunk of directions.
    pub fn chunked(self) -> bool {
        matches!(
            self,
            BakeBuffer::BinStart | BakeBuffer::BinTris | BakeBuffer::ReflectItems
        )
    }

    /// Filled from host data when created (the others are written or cleared later, or
    /// written by the shaders).
    fn initialised(self) -> bool {
        matches!(
            self,
            BakeBuffer::Triangles
                | BakeBuffer::Faces
                | BakeBuffer::AlphaMasks
                | BakeBuffer::Panes
                | BakeBuffer::TexelCenter
                | BakeBuffer::ActiveTexels
                | BakeBuffer::Unshot
                | BakeBuffer::TileIndex
                | BakeBuffer::Frames
                | BakeBuffer::Overflow
                | BakeBuffer::Directions
        )
    }

    fn usage(self) -> wgpu::BufferUsages {
        use wgpu::BufferUsages as U;
        match self {
            BakeBuffer::Directions => U::UNIFORM | U::COPY_DST,
            BakeBuffer::Unshot => U::STORAGE | U::COPY_DST,
            BakeBuffer::NextTiles
            | BakeBuffer::SpecEscape
            | BakeBuffer::PaneEnergy
            | BakeBuffer::Accumulators => U::STORAGE | U::COPY_SRC | U::COPY_DST,
            BakeBuffer::Overflow => U::STORAGE | U::COPY_SRC,
            BakeBuffer::BinStart | BakeBuffer::BinTris | BakeBuffer::ReflectItems => {
                U::STORAGE | U::COPY_DST
            }
            _ => U::STORAGE,
        }
    }
}

/// One buffer of a [`BakePlan`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlannedBuffer {
    pub buffer: BakeBuffer,
    /// The chunk of directions, for the chunked buffers.
    pub chunk: Option<usize>,
    /// Elements it holds (texels, crossings, …); 0 for an empty array (then padded).
    pub elements: u64,
    /// Bytes per element: `size_of` of the `#[repr(C)]` element type (the stride for the
    /// uniforms).
    pub element_bytes: u64,
    /// Bytes allocated: the elements, padded so that no binding is empty (one element for a
    /// buffer filled at creation, 16 bytes for the others).
    pub size: u64,
    pub usage: wgpu::BufferUsages,
}

impl PlannedBuffer {
    fn new(buffer: BakeBuffer, chunk: Option<usize>, elements: u64, element_bytes: u64) -> Self {
        let size = if buffer.initialised() {
            elements.max(1) * element_bytes
        } else {
            (elements * element_bytes).max(16)
        };
        PlannedBuffer {
            buffer,
            chunk,
            elements,
            element_bytes,
            size,
            usage: buffer.usage(),
        }
    }

    /// The wgpu label: `Bake::cells`, `Bake::bin_tris[3]`.
    pub fn label(&self) -> String {
        match self.chunk {
            Some(k) => format!("{}[{k}]", self.buffer.name()),
            None => self.buffer.name().to_string(),
        }
    }

    /// Bound as one storage binding (so within the adapter's binding limit).
    pub fn is_storage(&self) -> bool {
        self.usage.contains(wgpu::BufferUsages::STORAGE)
    }
}

/// What the plan and the propagator need from the scene's mirror tiles, counted from its
/// `SpecularSetup` (all zero without mirror or mixed faces).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MirrorCounts {
    /// Tile values in one copy (`TileIndex::value_len`).
    pub tile_values: u64,
    /// u32 words of the packed tile index.
    pub index_words: u64,
    /// Fixed-direction frames.
    pub frames: u64,
    /// Reflect jobs over every transport direction.
    pub reflect_jobs: u64,
    /// Reflect items per transport direction (one per destination tile slot of a job).
    pub items: Vec<u32>,
    /// Reflect jobs of the face with the most (`ReflectCounts::face_jobs_max`).
    pub face_jobs_max: u64,
}

impl MirrorCounts {
    pub fn new(spec: Option<&SpecularSetup>, transport_directions: usize) -> MirrorCounts {
        let Some(s) = spec else {
            return MirrorCounts {
                items: vec![0; transport_directions],
                ..MirrorCounts::default()
            };
        };
        let ix = &s.index;
        let index_words =
            ix.face_slot.len() + ix.index_start.len() + ix.tile_ids.len() + ix.coverage.len();
        let items = s
            .jobs
            .iter()
            .map(|jobs| {
                jobs.iter()
                    .map(|job| {
                        let mf = ix.face_slot[job.face as usize] as usize;
                        let k = mf * ix.directions as usize + job.j as usize;
                        ix.index_start[k + 1] - ix.index_start[k]
                    })
                    .sum()
            })
            .collect();
        let mut face_jobs = vec![0u64; ix.faces.len()];
        for job in s.jobs.iter().flatten() {
            face_jobs[ix.face_slot[job.face as usize] as usize] += 1;
        }
        MirrorCounts {
            tile_values: ix.value_len() as u64,
            index_words: index_words as u64,
            frames: s.frames.len() as u64,
            reflect_jobs: s.jobs.iter().map(|j| j.len() as u64).sum(),
            items,
            face_jobs_max: face_jobs.into_iter().max().unwrap_or(0),
        }
    }

    /// The counts [`MirrorCounts::new`] takes from the jobs of a `SpecularSetup`, from its
    /// tile index and the jobs counted without making them (`SpecularSetup::counted`): what a
    /// memory plan reads, before the jobs are allocated.
    pub fn counted(
        counted: Option<&(TileIndex, ReflectCounts)>,
        frames: usize,
        transport_directions: usize,
    ) -> MirrorCounts {
        let Some((ix, counts)) = counted else {
            return MirrorCounts {
                items: vec![0; transport_directions],
                ..MirrorCounts::default()
            };
        };
        let index_words =
            ix.face_slot.len() + ix.index_start.len() + ix.tile_ids.len() + ix.coverage.len();
        MirrorCounts {
            tile_values: ix.value_len() as u64,
            index_words: index_words as u64,
            frames: frames as u64,
            reflect_jobs: counts.total_jobs(),
            items: counts.slots.iter().map(|&s| s as u32).collect(),
            face_jobs_max: counts.face_jobs_max,
        }
    }

    /// Reflect items over every transport direction.
    pub fn reflect_items(&self) -> u64 {
        self.items.iter().map(|&i| u64::from(i)).sum()
    }
}

/// The transport directions and mirror setup of a bake: what both the plan and the
/// propagator derive from the scene and the parameters.
pub(super) struct Setup {
    pub grid: PsfGrid,
    pub dirs: Vec<TransportDir>,
    /// Directions `..quadrature` are propagated in every iteration, the suns after them in
    /// the first only.
    pub quadrature: usize,
    pub spec: Option<SpecularSetup>,
}

impl Setup {
    pub fn new(scene: &BakeScene, set: &DirectionSet, params: &BakeParams) -> Setup {
        let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
        let (dirs, quadrature) = reference::all_directions(scene, set, params);
        let spec = SpecularSetup::new(scene, set, &grid, &dirs);
        Setup {
            grid,
            dirs,
            quadrature,
            spec,
        }
    }
}

/// The texels the gather visits: covered ones of each face's first side (the gather writes
/// both sides).
pub(super) fn active_texels(scene: &BakeScene, tex_face: &[u32]) -> Vec<u32> {
    (0..scene.texel_count())
        .filter(|&t| {
            let f = &scene.faces[tex_face[t] as usize];
            scene.texel_area[t] > 0.0 && (t as u32 - f.texel_base) < f.texels_per_side()
        })
        .map(|t| t as u32)
        .collect()
}

/// The bytes one direction adds to the chunked buffers.
pub(super) fn direction_bytes(bins: &reference::Bins, items: u32) -> ChunkBytes {
    ChunkBytes {
        bin_start: bins.start.len() as u64 * 4,
        bin_tris: bins.tris.len() as u64 * 4,
        reflect_items: u64::from(items) * size_of::<ReflectItem>() as u64,
    }
}

/// Where a direction's data lies in its chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirSlot {
    pub chunk: usize,
    /// Offset of its tile starts in the chunk's `bin_start` (u32 words).
    pub bin_base: u32,
    /// Offset of its first reflect item in the chunk's `reflect_items`.
    pub items_base: u32,
}

/// Every buffer of the GPU bake of one scene with one set of parameters, and the counts they
/// are sized from.
#[derive(Clone, Debug, PartialEq)]
pub struct BakePlan {
    pub resolution: u32,
    pub tile: u32,
    /// Transport directions (perturbed copies and suns included).
    pub transport_directions: usize,
    pub triangles: u64,
    pub faces: u64,
    /// Texels, both sides of every chart.
    pub texels: u64,
    pub active_texels: u64,
    pub mirror: MirrorCounts,
    /// Longest tile bin over every direction (≥ 1): an upper bound on the faces one ray
    /// crosses.
    pub k_max: u32,
    /// Bytes each transport direction adds to the chunked buffers (its tile starts, tile
    /// bins and reflect items), in direction order.
    pub direction_bytes: Vec<ChunkBytes>,
    /// Cap on one chunk buffer.
    pub chunk_cap: u64,
    pub chunks: Vec<Chunk>,
    /// Every buffer, in allocation order.
    pub buffers: Vec<PlannedBuffer>,
}

impl BakePlan {
    /// The plan for `scene` on an adapter whose binding limit is `binding_limit`, with chunks
    /// of at most `max_chunk_bytes` (`None`: the default, see [`chunk_cap`]). Bins every
    /// transport direction once and builds the mirror tile index.
    pub fn new(
        scene: &BakeScene,
        set: &DirectionSet,
        params: &BakeParams,
        binding_limit: u64,
        max_chunk_bytes: Option<u64>,
    ) -> BakePlan {
        // Counted, not made: the reflect jobs (glossy lobes especially) may be what does not
        // fit the budget this plan is checked against.
        let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
        let (dirs, _) = reference::all_directions(scene, set, params);
        let counted = SpecularSetup::counted(scene, set, &grid, &dirs);
        let mirror = MirrorCounts::counted(counted.as_ref(), set.len(), dirs.len());
        let cap = chunk_cap(binding_limit, max_chunk_bytes);
        BakePlan::from_counts(scene, params, &grid, &dirs, mirror, cap)
    }

    pub(super) fn from_setup(
        scene: &BakeScene,
        params: &BakeParams,
        setup: &Setup,
        cap: u64,
    ) -> BakePlan {
        let mirror = MirrorCounts::new(setup.spec.as_ref(), setup.dirs.len());
        BakePlan::from_counts(scene, params, &setup.grid, &setup.dirs, mirror, cap)
    }

    fn from_counts(
        scene: &BakeScene,
        params: &BakeParams,
        grid: &PsfGrid,
        dirs: &[TransportDir],
        mirror: MirrorCounts,
        cap: u64,
    ) -> BakePlan {
        let mut chunker = Chunker::new(cap);
        let mut k_max = 1;
        let mut direction_bytes_all = Vec::with_capacity(dirs.len());
        for (d, &items) in dirs.iter().zip(&mirror.items) {
            let bins = bin_triangles(&project(scene, &d.frame), grid);
            k_max = k_max.max(bins.max_len());
            let bytes = direction_bytes(&bins, items);
            chunker.push(bytes);
            direction_bytes_all.push(bytes);
        }
        let tex_face = reference::texel_faces(scene);
        let mut plan = BakePlan {
            resolution: params.resolution,
            tile: params.tile,
            transport_directions: dirs.len(),
            triangles: scene.triangles.len() as u64,
            faces: scene.faces.len() as u64,
            texels: scene.texel_count() as u64,
            active_texels: active_texels(scene, &tex_face).len() as u64,
            mirror,
            k_max,
            direction_bytes: direction_bytes_all,
            chunk_cap: chunker.cap(),
            chunks: chunker.chunks().to_vec(),
            buffers: Vec::new(),
        };
        plan.buffers = plan.list_buffers(scene);
        plan
    }

    /// Crossings kept per ray: [`BakePlan::k_max`] capped at [`MAX_CROSSINGS`].
    pub fn crossings_per_ray(&self) -> u32 {
        self.k_max.min(MAX_CROSSINGS)
    }

    fn list_buffers(&self, scene: &BakeScene) -> Vec<PlannedBuffer> {
        use BakeBuffer as B;
        fn each<T>(_: &[T]) -> u64 {
            size_of::<T>() as u64
        }
        let one =
            |b: BakeBuffer, elements: u64, bytes: u64| PlannedBuffer::new(b, None, elements, bytes);
        let cells = u64::from(self.resolution).pow(2);
        let crossings = cells * u64::from(self.crossings_per_ray());
        let v4 = size_of::<[f32; 4]>() as u64;
        let mut out = Vec::with_capacity(18 + 3 * self.chunks.len());
        for (k, c) in self.chunks.iter().enumerate() {
            let item = size_of::<ReflectItem>() as u64;
            out.extend([
                PlannedBuffer::new(B::BinStart, Some(k), c.bytes.bin_start / 4, 4),
                PlannedBuffer::new(B::BinTris, Some(k), c.bytes.bin_tris / 4, 4),
                PlannedBuffer::new(B::ReflectItems, Some(k), c.bytes.reflect_items / item, item),
            ]);
        }
        out.extend([
            one(B::Triangles, self.triangles, each(&scene.triangles)),
            one(B::Faces, self.faces, each(&scene.faces)),
            one(B::AlphaMasks, scene.masks.word_count() as u64, 4),
            one(B::TexelCenter, self.texels, v4),
            one(B::ActiveTexels, self.active_texels, 4),
            one(B::Unshot, self.texels + self.mirror.tile_values, v4),
            one(B::TileIndex, self.mirror.index_words, 4),
            one(B::Frames, self.mirror.frames * 3, v4),
            one(B::NextTiles, self.mirror.tile_values, v4),
            one(B::SpecEscape, cells, v4),
            one(B::Panes, self.faces, each(&scene.panes)),
            one(B::PaneEnergy, cells, v4),
            one(B::CellCount, cells, 4),
            one(B::Cells, crossings, size_of::<CellEntry>() as u64),
            one(B::Crossings, crossings, size_of::<Crossing>() as u64),
            one(B::Accumulators, self.texels, size_of::<TexelAccum>() as u64),
            one(B::Overflow, 4, 4),
            one(B::Directions, self.transport_directions as u64, DIR_STRIDE),
        ]);
        out
    }

    /// The one buffer planned for `buffer` (panics for a chunked buffer).
    pub fn buffer(&self, buffer: BakeBuffer) -> &PlannedBuffer {
        assert!(!buffer.chunked(), "{buffer:?} has one buffer per chunk");
        self.buffers
            .iter()
            .find(|b| b.buffer == buffer)
            .expect("every unchunked buffer is planned")
    }

    /// The buffer planned for `buffer` in chunk `k`.
    pub fn chunk_buffer(&self, buffer: BakeBuffer, k: usize) -> &PlannedBuffer {
        self.buffers
            .iter()
            .find(|b| b.buffer == buffer && b.chunk == Some(k))
            .expect("every chunk's buffers are planned")
    }

    /// Bytes of every buffer together.
    pub fn total_bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.size).sum()
    }

    /// The largest storage buffer: what the binding limit is checked against.
    pub fn largest_binding(&self) -> Option<&PlannedBuffer> {
        self.buffers
            .iter()
            .filter(|b| b.is_storage())
            .max_by_key(|b| b.size)
    }

    /// Where each direction lies in its chunk (from the per-direction byte counts).
    pub fn slots(&self) -> Vec<DirSlot> {
        let mut slots = Vec::with_capacity(self.transport_directions);
        for (k, chunk) in self.chunks.iter().enumerate() {
            let (mut bin_base, mut items_base) = (0u64, 0u64);
            for b in &self.direction_bytes[chunk.directions.clone()] {
                slots.push(DirSlot {
                    chunk: k,
                    bin_base: (bin_base / 4) as u32,
                    items_base: (items_base / size_of::<ReflectItem>() as u64) as u32,
                });
                bin_base += b.bin_start;
                items_base += b.reflect_items;
            }
        }
        slots
    }

    /// Checks every storage buffer against the adapter's binding limit `limit`, the chunked
    /// ones first.
    pub fn check(&self, limit: u64) -> Result<(), GpuBakeError> {
        let chunked = self.buffers.iter().filter(|b| b.buffer.chunked());
        let whole = self.buffers.iter().filter(|b| !b.buffer.chunked());
        for b in chunked.chain(whole).filter(|b| b.is_storage()) {
            if b.size > limit {
                return Err(GpuBakeError::TooLarge {
                    what: self.describe(b),
                    need: b.size,
                    limit,
                });
            }
        }
        Ok(())
    }

    /// `the tile bins of one direction`, `the ray crossing lists`.
    fn describe(&self, b: &PlannedBuffer) -> String {
        match b.chunk {
            Some(k) if self.chunks[k].directions.len() == 1 => {
                format!("{} of one direction", b.buffer.what())
            }
            Some(_) => format!("{} of a chunk of directions", b.buffer.what()),
            None => b.buffer.what().to_string(),
        }
    }
}
