// Bind group 0 of every bake pass (crates/vlf-gpu/src/bake): the per-direction globals, one
// record per transport direction at a 256-byte stride, bound with a dynamic offset.

// Per-direction globals (mirrors vlf_gpu::layout::BakeDirection).
struct BakeDirection {
    u: vec4<f32>,
    v: vec4<f32>,
    w: vec4<f32>,
    sun: vec4<f32>,
    weight: f32,
    n: u32,
    tile: u32,
    k_max: u32,
    bin_base: u32,
    tiles_per_side: u32,
    active_texels: u32,
    is_sun: u32,
    spec_plus_v: vec4<u32>,
    spec_plus_w: vec4<f32>,
    spec_minus_v: vec4<u32>,
    spec_minus_w: vec4<f32>,
    sky: vec4<f32>,
    tiles_l: u32,
    tile_m: u32,
    words_per_slot: u32,
    face_slot_off: u32,
    index_start_off: u32,
    tile_ids_off: u32,
    coverage_off: u32,
    tile_values_off: u32,
    items_base: u32,
    items_count: u32,
    has_tiles: u32,
    has_panes: u32,
}

@group(0) @binding(0) var<uniform> dir: BakeDirection;
