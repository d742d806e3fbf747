//! The GPU gather's buffers and textures ([`GatherPlan`]), each with its wgpu label and its
//! size from the scene's counts ([`GatherCounts`]): the one place their sizes are computed.
//!
//! The gather counts its scene exactly ([`GatherCounts::of`]), plans, and allocates its own
//! buffers from the plan: the field, grid, output, scratch and globals buffers take the
//! planned sizes, and one filled from host data must fill exactly that (its chunk of texels,
//! its globals stride too). The ray-tracing scene, the direction tables and the mirror-tile
//! textures are uploaded by the modules they belong to and must come out at the planned sizes.
//! [`GatherRecord`] keeps what wgpu made, and `tests/suite/gather_plan.rs` compares it with the
//! plan. `vlf-bake`'s memory plan reads the same plan from counts it estimates before
//! propagating (texel counts at the gather's texel sizes, the BVH's nodes bounded).

use vlf_core::gather::{Converged, Grids};
use vlf_core::lightfield::{BakeFace, GatherParams};
use vlf_core::pathtrace::{BvhNode, PreparedScene, RtTriangle};

use super::{Estimator, GatherOptions, GpuGatherError, chunk_texels, steps};
use crate::layout::{DirTables, GatherGlobals, RtSceneInfo};
use crate::raytrace::scene::{ATTRIBUTE_ENTRIES, MATERIAL_ENTRIES, attributed_triangles};
use crate::render::upload::{ATLAS_WIDTH, TILE_HEADER_WORDS, wrapped_extent};

/// What a gather's buffers depend on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherCounts {
    /// Texels (both sides) of the indirect grid and of the stored (direct) grid.
    pub indirect_texels: u64,
    pub direct_texels: u64,
    /// Planar faces (charts) of the scene.
    pub faces: u64,
    /// Triangles of the scene, and the nodes of their BVH (at most 2 per triangle).
    pub triangles: u64,
    pub bvh_nodes: u64,
    /// Triangles with shading normals, and those the ray-tracing scene stores per-corner
    /// attributes for (shading normals, vertex colours, a `TEXCOORD_1` a material reads).
    pub smooth_triangles: u64,
    pub attributed_triangles: u64,
    /// u32 words of the triangles' alpha masks (`AlphaMasks::word_count`).
    pub mask_words: u64,
    pub materials: u64,
    /// Emissive triangles in the light list, and delta lights (suns, point and spot lights).
    pub emitters: u64,
    pub delta_lights: u64,
    /// Textures, and their texels.
    pub textures: u64,
    pub texture_texels: u64,
    /// Entries (vec4) of the direction set's sphere mesh: its vertices and triangles.
    pub direction_mesh: u64,
    /// Texels of the propagation's atlas.
    pub field_texels: u64,
    /// Mirror tiles (all zero without): values, u32 words of the tile index (its four
    /// arrays), and the fixed directions whose frames the tiles read.
    pub tile_values: u64,
    pub tile_index_words: u64,
    pub tile_directions: u64,
}

impl GatherCounts {
    /// The exact counts of a gather over `field` with `grids`, `ps` being the scene prepared
    /// for ray tracing.
    pub fn of(ps: &PreparedScene, field: &Converged, grids: &Grids) -> GatherCounts {
        let scene = ps.scene;
        let (tile_values, tile_index_words, tile_directions) = match field.tiles {
            Some((ix, values)) => (
                values.len(),
                ix.face_slot.len() + ix.index_start.len() + ix.tile_ids.len() + ix.coverage.len(),
                field.directions.len(),
            ),
            None => (0, 0, 0),
        };
        let set = field.directions;
        GatherCounts {
            indirect_texels: grids.indirect.atlas.texel_count() as u64,
            direct_texels: grids.direct.atlas.texel_count() as u64,
            faces: field.prep.faces.len() as u64,
            triangles: ps.bvh.triangles.len() as u64,
            bvh_nodes: ps.bvh.nodes().len() as u64,
            smooth_triangles: scene
                .triangles
                .iter()
                .filter(|t| t.normals.is_some())
                .count() as u64,
            attributed_triangles: attributed_triangles(ps) as u64,
            mask_words: ps.bvh.masks().word_count() as u64,
            materials: ps.materials.len() as u64,
            emitters: ps.lights.emitters.len() as u64,
            delta_lights: ps.lights.delta.len() as u64,
            textures: scene.textures.len() as u64,
            texture_texels: scene.textures.iter().map(|t| t.pixels.len() as u64).sum(),
            direction_mesh: (set.sphere_vertices().len() + set.sphere_triangles().len()) as u64,
            field_texels: field.prep.texel_count() as u64,
            tile_values: tile_values as u64,
            tile_index_words: tile_index_words as u64,
            tile_directions: tile_directions as u64,
        }
    }
}

/// One buffer (or texture) of the gather.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherBuffer {
    /// The wgpu label.
    pub name: &'static str,
    /// Elements (texels for a texture); 0 for an empty array, then padded to one.
    pub elements: u64,
    pub element_bytes: u64,
    /// Bytes allocated.
    pub bytes: u64,
    /// Bound as one storage binding (so within the device's binding limit).
    pub storage: bool,
}

fn buffer(name: &'static str, elements: u64, element_bytes: u64) -> GatherBuffer {
    GatherBuffer {
        name,
        elements,
        element_bytes,
        bytes: elements.max(1) * element_bytes,
        storage: true,
    }
}

fn uniform(name: &'static str, elements: u64, stride: u64) -> GatherBuffer {
    GatherBuffer {
        storage: false,
        ..buffer(name, elements, stride)
    }
}

/// A texture of `texels` 16-byte texels wrapped into rows of [`ATLAS_WIDTH`], as the mirror
/// tiles are uploaded (`render::upload::float_tile_textures`).
fn texture(name: &'static str, texels: u64) -> GatherBuffer {
    let (width, rows) = wrapped_extent(texels, ATLAS_WIDTH);
    GatherBuffer {
        name,
        elements: texels,
        element_bytes: 16,
        bytes: u64::from(width) * rows * 16,
        storage: false,
    }
}

/// Every buffer and texture of a GPU gather.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherPlan {
    /// Bound for the whole gather: the ray-tracing scene, the direction tables, the mirror
    /// tiles and the converged field.
    pub shared: Vec<GatherBuffer>,
    /// Each grid's own (indirect, then direct), allocated while it runs and freed after; none
    /// for a grid without texels.
    pub grids: [Vec<GatherBuffer>; 2],
    /// Texels per chunk of the indirect and the direct grid.
    pub chunks: [u32; 2],
    /// Bytes from one step's globals to the next (a multiple of the uniform offset alignment).
    pub globals_stride: u32,
}

impl GatherPlan {
    /// The plan for `counts` gathered with `gp` and `options` on a device binding at most
    /// `binding_limit` bytes with uniform offsets aligned to `uniform_align`.
    pub fn new(
        counts: &GatherCounts,
        gp: &GatherParams,
        options: &GatherOptions,
        binding_limit: u64,
        uniform_align: u32,
    ) -> GatherPlan {
        let c = counts;
        // BakeFace records as vec4 entries, as the field and grid buffers hold them.
        let face_entries = (size_of::<BakeFace>() / 16) as u64 * c.faces;
        let blob = 2 * c.triangles
            + u64::from(MATERIAL_ENTRIES) * c.materials
            + c.emitters
            + 4 * c.delta_lights
            + c.textures
            + c.texture_texels
            + u64::from(ATTRIBUTE_ENTRIES) * c.attributed_triangles;
        let tiled = c.tile_values > 0;
        let shared = vec![
            buffer("RayScene::nodes", c.bvh_nodes, size_of::<BvhNode>() as u64),
            buffer(
                "RayScene::triangles",
                c.triangles,
                size_of::<RtTriangle>() as u64,
            ),
            buffer("RayScene::masks", c.mask_words, 4),
            buffer("RayScene::blob", blob, 16),
            uniform("RayScene::info", 1, size_of::<RtSceneInfo>() as u64),
            uniform("Directions::tables", 1, size_of::<DirTables>() as u64),
            buffer("Directions::mesh", c.direction_mesh, 16),
            texture(
                "Gather::tile_words",
                match tiled {
                    true => (u64::from(TILE_HEADER_WORDS) + c.tile_index_words).div_ceil(4),
                    false => 1,
                },
            ),
            texture("Gather::tile_values", c.tile_values),
            texture("Gather::tile_frames", 2 * c.tile_directions),
            buffer(
                "FinalGather::field",
                face_entries + c.field_texels + c.field_texels.div_ceil(16),
                16,
            ),
        ];
        let globals_stride = (size_of::<GatherGlobals>() as u32).next_multiple_of(uniform_align);
        let ests = Estimator::of(gp, c.emitters > 0, c.delta_lights > 0);
        let texels = [c.indirect_texels, c.direct_texels];
        let mut chunks = [0; 2];
        let grids = std::array::from_fn(|i| {
            let est = &ests[i];
            let count = texels[i].min(u64::from(u32::MAX)) as u32;
            // A scratch entry too large for one binding: one texel, which `check` refuses.
            chunks[i] = chunk_texels(est, options.chunk, count.max(1), binding_limit).unwrap_or(1);
            if texels[i] == 0 {
                return Vec::new();
            }
            let grid = face_entries
                + 2 * texels[i]
                + c.faces
                + 1
                + 2 * c.triangles
                + 3 * c.smooth_triangles;
            vec![
                buffer("FinalGather::grid", grid, 16),
                buffer("FinalGather::out", texels[i], 16),
                buffer(
                    "FinalGather::scratch",
                    u64::from(chunks[i]) * u64::from(est.scratch_stride()),
                    16,
                ),
                uniform(
                    "FinalGather::globals",
                    steps(est, options).len() as u64,
                    u64::from(globals_stride),
                ),
            ]
        });
        GatherPlan {
            shared,
            grids,
            chunks,
            globals_stride,
        }
    }

    /// What is allocated at the peak: the shared buffers and the larger grid's.
    pub fn peak(&self) -> Vec<&GatherBuffer> {
        let sum = |b: &[GatherBuffer]| b.iter().map(|b| b.bytes).sum::<u64>();
        let larger = if sum(&self.grids[0]) >= sum(&self.grids[1]) {
            &self.grids[0]
        } else {
            &self.grids[1]
        };
        self.shared.iter().chain(larger).collect()
    }

    /// Bytes at the peak.
    pub fn bytes(&self) -> u64 {
        self.peak().iter().map(|b| b.bytes).sum()
    }

    /// The gather's own storage buffers each fit one binding of `limit` bytes (the uploads of
    /// the ray-tracing scene check theirs).
    pub fn check(&self, limit: u64) -> Result<(), GpuGatherError> {
        let mut own = self.shared.iter().chain(self.grids.iter().flatten());
        match own.find(|b| b.storage && b.name.starts_with("FinalGather::") && b.bytes > limit) {
            Some(b) => Err(GpuGatherError::TooLarge {
                what: b.name,
                bytes: b.bytes,
                limit,
            }),
            None => Ok(()),
        }
    }

    /// The shared buffer labelled `name`.
    pub(super) fn shared(&self, name: &str) -> &GatherBuffer {
        find(&self.shared, name)
    }

    /// Grid `i`'s buffer labelled `name`.
    pub(super) fn grid(&self, i: usize, name: &str) -> &GatherBuffer {
        find(&self.grids[i], name)
    }
}

fn find<'a>(buffers: &'a [GatherBuffer], name: &str) -> &'a GatherBuffer {
    buffers
        .iter()
        .find(|b| b.name == name)
        .unwrap_or_else(|| panic!("{name} is not in the gather's plan"))
}

/// What a gather allocated, as wgpu reports it: the label and bytes of every buffer and
/// texture, those bound for the whole gather and each grid's own, and the plan each grid was
/// gathered with (a grid gathered again with smaller batches has more steps).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GatherRecord {
    pub shared: Vec<(String, u64)>,
    pub grids: [Vec<(String, u64)>; 2],
    pub plans: [Option<GatherPlan>; 2],
}

/// The plan a grid allocates from, and where its allocations are recorded.
pub(super) struct Planned<'a> {
    pub plan: &'a GatherPlan,
    pub grid: usize,
    pub record: &'a mut Vec<(String, u64)>,
}

/// Creates the planned buffer `p` with `usage` (a storage buffer's `STORAGE` added), filled
/// with `data` when given, whose bytes must be the plan's (an empty array padded to one zero
/// element), and records it.
pub(super) fn create(
    device: &wgpu::Device,
    p: &GatherBuffer,
    usage: wgpu::BufferUsages,
    data: Option<&[u8]>,
    record: &mut Vec<(String, u64)>,
) -> wgpu::Buffer {
    let usage = usage
        | match p.storage {
            true => wgpu::BufferUsages::STORAGE,
            false => wgpu::BufferUsages::empty(),
        };
    let buffer = match data {
        Some(data) => {
            let zero = vec![0u8; p.element_bytes as usize];
            let data = if data.is_empty() { &zero[..] } else { data };
            assert_eq!(
                data.len() as u64,
                p.bytes,
                "{}: contents off the plan",
                p.name
            );
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some(p.name),
                    contents: data,
                    usage,
                },
            )
        }
        None => device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(p.name),
            size: p.bytes,
            usage,
            mapped_at_creation: false,
        }),
    };
    record.push((p.name.to_string(), buffer.size()));
    buffer
}

/// Bytes of the texture `view` shows.
pub(super) fn texture_bytes(view: &wgpu::TextureView) -> u64 {
    let t = view.texture();
    let texel = t.format().block_copy_size(None).unwrap_or(0);
    u64::from(t.width()) * u64::from(t.height()) * u64::from(texel)
}
