// Render pass 3 of 5 (paper §4): face id of the visible surface.
//
// The scene's triangles (VLF coordinates, pulled from a storage buffer by vertex index) drawn
// with the camera, depth-tested (reverse-Z: greater is nearer), no culling (surfaces are
// two-sided). Output: the face index, u32::MAX where no surface is seen.
//
// Light fields with alpha masks draw with vs_masked + fs_masked: each fragment interpolates its
// uv and discards itself where its triangle's mask leaves no surface (common/alpha_mask.wgsl),
// so the depth buffer holds what lies behind the holes; the others with vs_main + fs_main,
// which keep early depth testing.

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"
#import "common/alpha_mask.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;
// TEXCOORD_0 per triangle corner (three per triangle, in triangle order; vs_masked only).
@group(1) @binding(1) var<storage, read> corner_uvs: array<vec2<f32>>;
// Binding 6: alpha_masks (common/alpha_mask.wgsl), by the triangle's index in the light field,
// which the upload writes into BakeTriangle::_pad0.

struct FaceIdOut {
    // Invariant so that pass 4 (same vertex transform) reproduces these depths exactly.
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) @interpolate(flat) face: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> FaceIdOut {
    let tri = triangles[vi / 3u];
    var out: FaceIdOut;
    out.clip = g.view_proj * vec4<f32>(corner_position(tri, vi % 3u), 1.0);
    out.face = tri.face;
    return out;
}

@fragment
fn fs_main(in: FaceIdOut) -> @location(0) u32 {
    return in.face;
}

struct MaskedFaceIdOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) @interpolate(flat) face: u32,
    @location(1) @interpolate(flat) tri: u32,
    @location(2) uv: vec2<f32>,
}

@vertex
fn vs_masked(@builtin(vertex_index) vi: u32) -> MaskedFaceIdOut {
    let tri = triangles[vi / 3u];
    var out: MaskedFaceIdOut;
    out.clip = g.view_proj * vec4<f32>(corner_position(tri, vi % 3u), 1.0);
    out.face = tri.face;
    out.tri = tri._pad0;
    out.uv = corner_uvs[vi];
    return out;
}

@fragment
fn fs_masked(in: MaskedFaceIdOut) -> @location(0) u32 {
    if alpha_cuts_uv(in.tri, in.uv) {
        discard;
    }
    return in.face;
}
