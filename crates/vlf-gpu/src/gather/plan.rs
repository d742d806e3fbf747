//! The GPU gather's buffers before it runs ([`GatherPlan`]), for the memory plan of `vlf-bake`
//! (`memory.rs`), from the same formulas [`super::final_gather_with`] allocates with: the
//! estimators ([`Estimator::of`]), their scratch ([`Estimator::scratch_stride`]), the chunk
//! ([`chunk_texels`]) and the steps ([`steps`]).

use vlf_core::lightfield::GatherParams;
use vlf_core::pathtrace::{BvhNode, RtTriangle};

use super::{Estimator, GatherOptions, chunk_texels, steps};
use crate::layout::GatherGlobals;

/// What a gather's buffers depend on, known before propagating.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherCounts {
    /// Texels (both sides) of the indirect grid and of the stored (direct) grid.
    pub indirect_texels: u64,
    pub direct_texels: u64,
    /// Planar faces (charts) of the scene, and its triangles.
    pub faces: u64,
    pub triangles: u64,
    /// Triangles with shading normals, and those with any per-corner attribute beyond
    /// `TEXCOORD_0` (shading normals, vertex colours, `TEXCOORD_1`).
    pub smooth_triangles: u64,
    pub attributed_triangles: u64,
    /// Texels of the propagation's atlas and its mirror tile values.
    pub field_texels: u64,
    pub tile_values: u64,
    /// Texels of the scene's textures.
    pub texture_texels: u64,
    pub materials: u64,
    pub has_emitters: bool,
    /// Whether the scene has suns, point or spot lights.
    pub delta_lights: bool,
}

/// One buffer (or texture) of the gather.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherBuffer {
    pub name: &'static str,
    pub elements: u64,
    pub element_bytes: u64,
    pub bytes: u64,
}

/// Every buffer of a GPU gather: the scene and field, bound for the whole gather, then the
/// larger of the two grids' own buffers (the grids run one after the other).
#[derive(Clone, Debug, PartialEq)]
pub struct GatherPlan {
    pub buffers: Vec<GatherBuffer>,
    /// Texels per chunk of the indirect and the direct grid.
    pub chunks: [u32; 2],
}

fn buffer(name: &'static str, elements: u64, element_bytes: u64) -> GatherBuffer {
    GatherBuffer {
        name,
        elements,
        element_bytes,
        bytes: elements.max(1) * element_bytes,
    }
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
        let mut buffers = vec![
            buffer(
                "Gather scene: BVH nodes",
                2 * c.triangles,
                size_of::<BvhNode>() as u64,
            ),
            buffer(
                "Gather scene: triangles",
                c.triangles,
                size_of::<RtTriangle>() as u64,
            ),
            buffer(
                "Gather scene: shading data (uvs, materials, lights, textures)",
                2 * c.triangles
                    + 3 * c.materials
                    + 2 * c.triangles
                    + c.texture_texels
                    + u64::from(crate::raytrace::scene::ATTRIBUTE_ENTRIES) * c.attributed_triangles,
                16,
            ),
            buffer(
                "FinalGather::field (faces, dilated irradiance, contact bits)",
                5 * c.faces + c.field_texels + c.field_texels.div_ceil(16),
                16,
            ),
            buffer("FinalGather::tile_values", c.tile_values, 16),
        ];
        let ests = Estimator::of(gp, c.has_emitters, c.delta_lights);
        let texels = [c.indirect_texels, c.direct_texels];
        let mut chunks = [0; 2];
        let mut grids: Vec<Vec<GatherBuffer>> = Vec::new();
        for (i, est) in ests.iter().enumerate() {
            let count = texels[i].min(u64::from(u32::MAX)) as u32;
            let chunk = chunk_texels(est, options.chunk, count.max(1), binding_limit).unwrap_or(1);
            chunks[i] = chunk;
            let stride = u64::from(est.scratch_stride());
            grids.push(vec![
                buffer(
                    "FinalGather::grid (faces, texels, charts)",
                    5 * c.faces
                        + 2 * texels[i]
                        + c.faces
                        + 1
                        + 2 * c.triangles
                        + 3 * c.smooth_triangles,
                    16,
                ),
                buffer("FinalGather::out", texels[i], 16),
                buffer("FinalGather::scratch", u64::from(chunk) * stride, 16),
                buffer(
                    "FinalGather::globals (one per step)",
                    steps(est, options).len() as u64,
                    u64::from(uniform_align).max(size_of::<GatherGlobals>() as u64),
                ),
            ]);
        }
        let sum = |b: &[GatherBuffer]| b.iter().map(|b| b.bytes).sum::<u64>();
        let larger = if sum(&grids[0]) >= sum(&grids[1]) {
            grids.swap_remove(0)
        } else {
            grids.swap_remove(1)
        };
        buffers.extend(larger);
        GatherPlan { buffers, chunks }
    }

    /// Bytes of every buffer.
    pub fn bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.bytes).sum()
    }
}
