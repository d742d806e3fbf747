// Render pass 4b (after pass 4, for light fields with per-corner attributes only): the shading
// normal, vertex colour and TEXCOORD_1 of the visible surface, interpolated from the corners
// (perspective-correct) into two targets, as pass 4 interpolates position and TEXCOORD_0:
// [normal xyz, TEXCOORD_1 u] and [colour rgb, TEXCOORD_1 v]. The normal is not renormalised
// (zero on flat triangles: pass 5 then uses the face's normal). Reuses pass 3's depth buffer
// (test "greater or equal", no depth writes); the targets are read by pass 5 only where a face
// is seen whose flags ask for them, so they are not cleared.

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

// The scene's triangles; `_pad0` holds each one's index in the light field's triangle order.
@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;
// Two entries per corner, six per triangle in the light field's order:
// [normal xyz, TEXCOORD_1 u], [colour rgb, TEXCOORD_1 v] (vlf_gpu::render::upload).
@group(1) @binding(1) var<storage, read> corner_attributes: array<vec4<f32>>;

struct AttributesOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) a: vec4<f32>,
    @location(1) b: vec4<f32>,
}

struct AttributesTargets {
    @location(0) a: vec4<f32>,
    @location(1) b: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> AttributesOut {
    let tri = triangles[vi / 3u];
    let p = corner_position(tri, vi % 3u);
    let k = 6u * tri._pad0 + 2u * (vi % 3u);
    var out: AttributesOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.a = corner_attributes[k];
    out.b = corner_attributes[k + 1u];
    return out;
}

@fragment
fn fs_main(in: AttributesOut) -> AttributesTargets {
    return AttributesTargets(in.a, in.b);
}
