// Render pass 4 of 5 (paper §4): VLF position of the visible surface.
//
// The scene drawn again with each vertex coloured by its VLF position; interpolation gives the
// point where the pixel's view ray meets the visible face. Reuses pass 3's depth buffer
// (test "greater or equal", no depth writes), so only the visible surface is shaded.
// Output: xyz = position, w = 1 where a surface is seen (0 = background).

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;

struct PositionOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) position: vec3<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> PositionOut {
    let p = corner_position(triangles[vi / 3u], vi % 3u);
    var out: PositionOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.position = p;
    return out;
}

@fragment
fn fs_main(in: PositionOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.position, 1.0);
}
