// Render pass 4 of 5 (paper §4): VLF position and TEXCOORD_0 of the visible surface.
//
// The scene drawn again with each vertex coloured by its VLF position and its uv; interpolation
// gives the point where the pixel's view ray meets the visible face and the texture coordinate
// there (perspective-correct, so it is exact for the planar triangle). Reuses pass 3's depth
// buffer (test "greater or equal", no depth writes), so only the visible surface is shaded.
// Outputs: xyz = position, w = 1 where a surface is seen (0 = background); the uv (only read
// by pass 5 for textured faces, so it is not cleared). Light fields with alpha masks draw with
// vs_masked + fs_masked, which discard what pass 3 discarded (render_face_id.wgsl).

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"
#import "common/alpha_mask.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;
// TEXCOORD_0 per triangle corner (three per triangle, in triangle order).
@group(1) @binding(1) var<storage, read> corner_uvs: array<vec2<f32>>;
// Binding 6: alpha_masks (common/alpha_mask.wgsl; vs_masked, fs_masked).

struct PositionOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) position: vec3<f32>,
    @location(1) uv: vec2<f32>,
}

struct PositionTargets {
    @location(0) position: vec4<f32>,
    @location(1) uv: vec2<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> PositionOut {
    let p = corner_position(triangles[vi / 3u], vi % 3u);
    var out: PositionOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.position = p;
    out.uv = corner_uvs[vi];
    return out;
}

@fragment
fn fs_main(in: PositionOut) -> PositionTargets {
    return PositionTargets(vec4<f32>(in.position, 1.0), in.uv);
}

struct MaskedPositionOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) position: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) @interpolate(flat) tri: u32,
}

@vertex
fn vs_masked(@builtin(vertex_index) vi: u32) -> MaskedPositionOut {
    let tri = triangles[vi / 3u];
    let p = corner_position(tri, vi % 3u);
    var out: MaskedPositionOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.position = p;
    out.uv = corner_uvs[vi];
    out.tri = tri._pad0;
    return out;
}

@fragment
fn fs_masked(in: MaskedPositionOut) -> PositionTargets {
    if alpha_cuts_uv(in.tri, in.uv) {
        discard;
    }
    return PositionTargets(vec4<f32>(in.position, 1.0), in.uv);
}
