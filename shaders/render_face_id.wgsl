// Render pass 3 of 5 (paper §4): face id of the visible surface.
//
// The scene's triangles (VLF coordinates, pulled from a storage buffer by vertex index) drawn
// with the camera, depth-tested (reverse-Z: greater is nearer), no culling (surfaces are
// two-sided). Output: the face index, u32::MAX where no surface is seen.

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;

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
