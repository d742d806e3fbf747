// Render pass 4 of 5 (paper §4): VLF position of the visible surface.
//
// The scene drawn again with each vertex coloured by its VLF position; interpolation gives the
// point where the pixel's view ray meets the visible face. Reuses pass 3's depth buffer
// (test "greater or equal", no depth writes), so only the visible surface is shaded.
// Output: xyz = position, w = 1 where a surface is seen (0 = background).

// Per-frame globals shared by every render pass (mirrors vlf_gpu::layout::RenderGlobals).
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

// A triangle in VLF coordinates (mirrors vlf_core::bake::BakeTriangle).
struct BakeTriangle {
    p0: vec3<f32>,
    face: u32,
    p1: vec3<f32>,
    _pad0: u32,
    p2: vec3<f32>,
    _pad1: u32,
}

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;

fn corner_position(tri: BakeTriangle, corner: u32) -> vec3<f32> {
    if corner == 1u {
        return tri.p1;
    }
    if corner == 2u {
        return tri.p2;
    }
    return tri.p0;
}

struct VsOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) position: vec3<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> VsOut {
    let p = corner_position(triangles[vi / 3u], vi % 3u);
    var out: VsOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.position = p;
    return out;
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.position, 1.0);
}
