//! The one source of truth for data shared between Rust and WGSL.
//!
//! Each `#[repr(C)]` struct here (and the few `vlf_core` keeps next to their CPU users) mirrors a
//! WGSL struct of the same name, defined once: in `shaders/common/` when several shaders use it.
//! [`registry`] lists every such struct once with that file; the test `rust_structs_match_wgsl`
//! lays the file out with naga and compares every member's name, order, offset and size and the
//! struct's size and alignment, so a field added, resized or reordered on one side only fails
//! `cargo test`.

use bytemuck::{Pod, Zeroable};

/// Per-dispatch globals of the smoke pass (`shaders/smoke.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SmokeParams {
    pub a: f32,
    pub b: f32,
    pub count: u32,
    pub _pad: u32,
}

/// Per-frame (per-sample) globals of the five render passes and the display pass: bind group 0,
/// binding 0 of every `shaders/render_*.wgsl`. All positions are VLF coordinates.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderGlobals {
    /// VLF → clip space of the camera (jittered by the current sub-pixel sample; reverse-Z,
    /// infinite far plane).
    pub view_proj: [[f32; 4]; 4],
    /// The same camera placed at the sphere centre (rotation and projection only): direction
    /// space → clip space, for the direction-set passes.
    pub dir_view_proj: [[f32; 4]; 4],
    /// Eye position (xyz, VLF), w = 1.
    pub eye: [f32; 4],
    /// Background (sky) radiance, rgb; a unused.
    pub sky: [f32; 4],
    /// Render-target size in pixels.
    pub width: u32,
    pub height: u32,
    /// Index of the current sub-pixel sample (0 clears the accumulation).
    pub sample_index: u32,
    /// Number of samples accumulated into this image.
    pub sample_count: u32,
    /// Weight of this sample in the mean (1 / sample_count).
    pub sample_weight: f32,
    /// Number of faces (ids ≥ this are "no face").
    pub face_count: u32,
    /// Display: which pass output to show ([`crate::render::Pass`] as u32).
    pub view: u32,
    /// Display: 0 = none (raw linear values), 1 = clamp to [0, 1], 2 = ACES (fitted).
    pub tonemap: u32,
    /// Display: linear factor applied to radiance before tonemapping (2^stops).
    pub exposure: f32,
    /// Display: 1 when the target format is not sRGB and the shader must encode sRGB itself.
    pub encode_srgb: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// Per-direction globals of the bake passes (`shaders/bake_*.wgsl`), one per transport
/// direction, written at a 256-byte stride and bound with a dynamic offset.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BakeDirection {
    pub u: [f32; 4],
    pub v: [f32; 4],
    pub w: [f32; 4],
    /// Sun irradiance (rgb) for sun directions.
    pub sun: [f32; 4],
    /// Solid angle per sense (quadrature directions).
    pub weight: f32,
    pub n: u32,
    pub tile: u32,
    pub k_max: u32,
    /// Offset of this direction's tile starts in its chunk's bin buffers (`bake/chunks.rs`).
    pub bin_base: u32,
    pub tiles_per_side: u32,
    pub active_texels: u32,
    pub is_sun: u32,
    /// Sphere vertices (3 used) and weights of the specular lookup for light leaving along
    /// +w and along −w (non-diffuse senders).
    pub spec_plus_v: [u32; 4],
    pub spec_plus_w: [f32; 4],
    pub spec_minus_v: [u32; 4],
    pub spec_minus_w: [f32; 4],
    /// Sky radiance entering open ends in this iteration (rgb).
    pub sky: [f32; 4],
    /// Fixed directions l.
    pub tiles_l: u32,
    /// Cells per tile side m.
    pub tile_m: u32,
    pub words_per_slot: u32,
    /// Offsets (in u32) of the arrays packed in the tile index buffer.
    pub face_slot_off: u32,
    pub index_start_off: u32,
    pub tile_ids_off: u32,
    pub coverage_off: u32,
    /// Offset (in vec4) of the tile values in the unshot buffer.
    pub tile_values_off: u32,
    /// This direction's reflect items.
    pub items_base: u32,
    pub items_count: u32,
    /// 1 when the scene has non-diffuse faces.
    pub has_tiles: u32,
    /// 1 when the scene has thin glass panes (the interface pass carries light through them).
    pub has_panes: u32,
}

/// One unit of the reflect pass (`bake_reflect.wgsl`): one destination tile slot of one
/// reflect job; m² invocations each.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ReflectItem {
    /// The job's weight (rgb: `ReflectJob::weight`) and its loss (w: `ReflectJob::loss`).
    pub weight: [f32; 4],
    pub slot: u32,
    pub face: u32,
    /// Fixed direction of the destination.
    pub j: u32,
    /// bit 0: incoming sense (0 = +w), bit 1: destination sense.
    pub senses: u32,
}

/// One crossing of a ray's depth list (`bake_cells.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CellEntry {
    pub depth: f32,
    pub face: u32,
}

/// Arriving radiance at a crossing (`bake_interface.wgsl`); `w` components are open flags.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Crossing {
    pub below: [f32; 4],
    pub above: [f32; 4],
}

/// Per texel-side accumulators (`bake_gather.wgsl`); the GPU form of
/// `vlf_core::bake::reference::TexelAccum`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TexelAccum {
    pub irradiance: [f32; 4],
    pub open: [f32; 4],
}

/// Globals of the GPU path tracer (`shaders/raytrace_path.wgsl`, group 0 binding 0). Blob
/// offsets are in `vec4` units (see `crate::raytrace::scene`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtGlobals {
    /// Eye position; w = tan(yfov / 2).
    pub cam_pos: [f32; 4],
    /// Unit forward; w = aspect (width / height).
    pub cam_forward: [f32; 4],
    /// Unit right; w unused.
    pub cam_right: [f32; 4],
    /// Unit up; w unused.
    pub cam_up: [f32; 4],
    /// Sky radiance (rgb).
    pub sky: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    /// Sample index of the wave's first sample.
    pub sample_base: u32,
    /// Samples of each pixel traced by one wave.
    pub samples_per_wave: u32,
    /// Paths per wave (8×8 tiles × 64 × samples_per_wave).
    pub path_count: u32,
    pub tiles_x: u32,
    /// Largest workgroup count per dispatch dimension.
    pub max_groups: u32,
    /// Total samples per pixel (the divisor of `finish`).
    pub spp: u32,
    /// Russian roulette starts when a path has this many bounces.
    pub rr_depth: u32,
    /// First 8×8 tile of this chunk of the image (row-major tile index).
    pub tile_base: u32,
    /// Tiles in this chunk.
    pub tile_count: u32,
}

/// Where the sections of the ray-tracing scene's shading data start (`vec4` units, see
/// `crate::raytrace::scene`) and the light list's counts (`shaders/common/rt_scene.wgsl`,
/// group 1 binding 3 of the path tracer and the final gather).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtSceneInfo {
    pub mat_base: u32,
    pub emitter_base: u32,
    pub emitter_count: u32,
    /// Delta lights (suns, point and spot lights): four entries each.
    pub delta_base: u32,
    pub delta_count: u32,
    pub tex_base: u32,
    /// Probability of sampling an emitter rather than a delta light.
    pub p_emitters: f32,
    /// Where the per-triangle attributes (shading normals, vertex colours, `TEXCOORD_1`) start.
    pub attr_base: u32,
    /// 1 when a material is (in part) a thin glass pane: rays then go on through panes
    /// (`shaders/common/pane_trace.wgsl`); 0 keeps the plain traversals.
    pub has_panes: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// The icosahedron tables of the direction lookup (`shaders/common/directions.wgsl`, group 2
/// binding 0): [`vlf_core::directions::LookupTables`] as the shaders bind them (see
/// [`crate::directions`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DirTables {
    /// Unit outward normal of each icosahedron face (xyz; w = 0).
    pub face_normals: [[f32; 4]; 20],
    /// `edge_normals[f][0]`, `[1]`, `[2]` of each face (xyz; w = 0).
    pub edge0: [[f32; 4]; 20],
    pub edge1: [[f32; 4]; 20],
    pub edge2: [[f32; 4]; 20],
    /// The four candidate faces of each sign octant.
    pub octant_faces: [[u32; 4]; 8],
    /// Frequency of the direction set.
    pub k: u32,
    /// Number of directions (sphere vertices `0..2l`).
    pub l: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// Per-dispatch globals of the GPU final gather (`shaders/gather_texels.wgsl`, group 0
/// binding 0; see [`crate::gather`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GatherGlobals {
    /// Sky radiance (rgb; w unused).
    pub sky: [f32; 4],
    /// World → VLF: `(p − center) · scale`.
    pub xf_center: [f32; 3],
    pub xf_scale: f32,
    /// The chunk of texels of this dispatch.
    pub texel_base: u32,
    pub texel_count: u32,
    /// Random stream selector and seed (`vlf_core::gather::{STREAM_*, SEED}`).
    pub stream: u32,
    pub seed: u32,
    /// Sample points per texel and the side of their strata grid.
    pub points: u32,
    pub points_side: u32,
    /// Probes along the normal closer than this close a point (world units).
    pub r_close: f32,
    /// 1 when the light field has mirror tiles.
    pub has_tiles: u32,
    /// Light samples and cosine rays per texel and the sides of their strata grids.
    pub light_samples: u32,
    pub light_side: u32,
    pub cosine_rays: u32,
    pub cosine_side: u32,
    /// Section offsets (vec4 units) of the grid buffer (texels, chart starts, chart
    /// triangles) and of the field buffer's irradiance.
    pub grid_texels: u32,
    pub chart_start: u32,
    pub chart_tris: u32,
    pub field_irradiance: u32,
    /// Scratch entries (vec4) per invocation, and where its strata order starts.
    pub scratch_stride: u32,
    pub strata_at: u32,
    /// 2: the trip count of the shader's loop-budget check (a uniform, so not unrolled).
    pub sentinel: u32,
    /// The step of this entry: samples `k0 .. k1` of its loop and the side of the strata a
    /// shuffle makes (one entry per step, bound at a dynamic offset).
    pub k0: u32,
    pub k1: u32,
    pub side: u32,
    /// Where the field buffer's contact bits start (vec4 units; 16 texels per entry).
    pub field_contacts: u32,
    /// Where the grid buffer's chart normals start (three entries per smooth chart triangle).
    pub chart_normals: u32,
}

/// Which queue and ray-buffer slice a ray-engine or path-tracer dispatch works on
/// (`raytrace_*.wgsl`, bound with a dynamic offset at a 256-byte stride).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtBatch {
    pub queue: u32,
    pub base: u32,
    pub next_queue: u32,
    pub next_base: u32,
    pub shadow_base: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// A ray queue header (`raytrace_*.wgsl`): the number of rays in the queue.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtQueue {
    pub count: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// The state of one path in the wavefront path tracer (`raytrace_path.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RtPath {
    pub throughput: [f32; 3],
    /// Accumulation slot (`u32::MAX`: inactive).
    pub slot: u32,
    pub rng_state: u32,
    pub rng_inc: u32,
    pub depth: u32,
    /// Solid-angle pdf of the last BSDF sample; negative after a delta or camera sample.
    pub pdf: f32,
}

/// Globals of the GPU radiosity solver (`shaders/radiosity_jacobi.wgsl`, group 0 binding 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RadiosityGlobals {
    /// Rows of the form-factor matrix.
    pub patches: u32,
    /// Workgroups along x of the 2-D dispatch.
    pub groups_x: u32,
    /// Workgroups dispatched in all (entries of the partial-maxima buffer).
    pub partial_count: u32,
    pub max_iterations: u32,
    /// Residual below which the solver stops (0: never).
    pub threshold: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Per-patch terms of the radiosity system (`radiosity_jacobi.wgsl`): source S and albedo ρ.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PatchTerm {
    pub source: [f32; 4],
    pub albedo: [f32; 4],
}

/// A Rust field of a shared struct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: &'static str,
    /// `offset_of!` the field.
    pub offset: usize,
    pub size: usize,
}

/// A `#[repr(C)]` struct shared with WGSL and the one WGSL file that defines its mirror.
#[derive(Clone, Debug)]
pub struct SharedStruct {
    /// Name of the WGSL struct (equal to the Rust one).
    pub name: &'static str,
    /// The file under `shaders/` that defines it (`common/…` when several shaders use it).
    pub file: &'static str,
    pub size: usize,
    pub align: usize,
    /// Every field, in declaration order.
    pub fields: Vec<Field>,
}

/// Size of the field `get` projects to (no value needed).
fn field_size<T, F>(_get: fn(&T) -> &F) -> usize {
    std::mem::size_of::<F>()
}

/// `shared!(Type in "file.wgsl" { field, … })`: a [`SharedStruct`] entry listing every field.
macro_rules! shared {
    ($t:ident in $file:literal { $($f:ident),+ $(,)? }) => {
        SharedStruct {
            name: stringify!($t),
            file: $file,
            size: std::mem::size_of::<$t>(),
            align: std::mem::align_of::<$t>(),
            fields: vec![$(Field {
                name: stringify!($f),
                offset: std::mem::offset_of!($t, $f),
                size: field_size(|s: &$t| &s.$f),
            }),+],
        }
    };
}

/// Every struct shared between Rust and WGSL, each once, with the file that defines its WGSL
/// mirror. The test `rust_structs_match_wgsl` compares each field's name, order, offset and
/// size, and the struct's size and alignment, with naga's layout of that file.
pub fn registry() -> Vec<SharedStruct> {
    use vlf_core::bake::prep::PaneFace;
    use vlf_core::lightfield::{BakeFace, BakeTriangle};
    use vlf_core::pathtrace::{BvhNode, Hit, Ray, RtTriangle};
    vec![
        shared!(SmokeParams in "smoke.wgsl" { a, b, count, _pad }),
        shared!(RenderGlobals in "common/render_globals.wgsl" {
            view_proj, dir_view_proj, eye, sky, width, height, sample_index, sample_count,
            sample_weight, face_count, view, tonemap, exposure, encode_srgb, _pad0, _pad1,
        }),
        shared!(BakeDirection in "common/bake_direction.wgsl" {
            u, v, w, sun, weight, n, tile, k_max, bin_base, tiles_per_side, active_texels,
            is_sun, spec_plus_v, spec_plus_w, spec_minus_v, spec_minus_w, sky, tiles_l, tile_m,
            words_per_slot, face_slot_off, index_start_off, tile_ids_off, coverage_off,
            tile_values_off, items_base, items_count, has_tiles, has_panes,
        }),
        shared!(BakeTriangle in "common/bake_scene.wgsl" { p0, face, p1, _pad0, p2, _pad1 }),
        shared!(BakeFace in "common/bake_scene.wgsl" {
            normal, offset, origin, texel_size, u, width, v, height, texel_base, kind, specular,
            material,
        }),
        shared!(CellEntry in "common/bake_rays.wgsl" { depth, face }),
        shared!(PaneFace in "common/pane.wgsl" { tint, weight, ior, _pad }),
        shared!(Crossing in "common/bake_rays.wgsl" { below, above }),
        shared!(TexelAccum in "bake_gather.wgsl" { irradiance, open }),
        shared!(ReflectItem in "bake_reflect.wgsl" { weight, slot, face, j, senses }),
        shared!(Ray in "common/rays.wgsl" { origin, tmin, dir, tmax }),
        shared!(Hit in "common/rays.wgsl" { t, tri, u, v }),
        shared!(RtBatch in "common/rays.wgsl" {
            queue, base, next_queue, next_base, shadow_base, _pad0, _pad1, _pad2,
        }),
        shared!(RtQueue in "common/rays.wgsl" { count, _pad0, _pad1, _pad2 }),
        shared!(BvhNode in "common/bvh.wgsl" { min, index, max, count }),
        shared!(RtTriangle in "common/bvh.wgsl" { p0, material, p1, prim, p2, light }),
        shared!(RtGlobals in "raytrace_path.wgsl" {
            cam_pos, cam_forward, cam_right, cam_up, sky, width, height, seed, sample_base,
            samples_per_wave, path_count, tiles_x, max_groups, spp, rr_depth, tile_base,
            tile_count,
        }),
        shared!(RtSceneInfo in "common/rt_scene.wgsl" {
            mat_base, emitter_base, emitter_count, delta_base, delta_count, tex_base, p_emitters,
            attr_base, has_panes, _pad0, _pad1, _pad2,
        }),
        shared!(DirTables in "common/directions.wgsl" {
            face_normals, edge0, edge1, edge2, octant_faces, k, l, _pad0, _pad1,
        }),
        shared!(GatherGlobals in "gather_texels.wgsl" {
            sky, xf_center, xf_scale, texel_base, texel_count, stream, seed, points, points_side,
            r_close, has_tiles, light_samples, light_side, cosine_rays, cosine_side, grid_texels,
            chart_start, chart_tris, field_irradiance, scratch_stride, strata_at, sentinel, k0, k1,
            side, field_contacts, chart_normals,
        }),
        shared!(RtPath in "raytrace_path.wgsl" {
            throughput, slot, rng_state, rng_inc, depth, pdf,
        }),
        shared!(RadiosityGlobals in "radiosity_jacobi.wgsl" {
            patches, groups_x, partial_count, max_iterations, threshold, _pad0, _pad1, _pad2,
        }),
        shared!(PatchTerm in "radiosity_jacobi.wgsl" { source, albedo }),
    ]
}

#[cfg(test)]
mod tests;
