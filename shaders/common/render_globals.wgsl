// What every render pass shares (crates/vlf-gpu/src/render): the per-frame globals in bind
// group 0 (one layout, `Renderer::globals_layout`, for all six pipelines) and the no-face id.

// Per-frame globals (mirrors vlf_gpu::layout::RenderGlobals). All positions are VLF coordinates.
struct RenderGlobals {
    view_proj: mat4x4<f32>,
    dir_view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    sky: vec4<f32>,
    width: u32,
    height: u32,
    sample_index: u32,
    sample_count: u32,
    sample_weight: f32,
    face_count: u32,
    view: u32,
    tonemap: u32,
    exposure: f32,
    encode_srgb: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> g: RenderGlobals;

// Face id of pass 3 where no surface is seen (vlf_gpu::render::NO_FACE).
const NO_FACE: u32 = 0xffffffffu;
