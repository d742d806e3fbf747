// Render pass 2 of 5 (paper §4): barycentric weights of the view direction.
//
// The same spherical-triangle mesh as pass 1, drawn from the sphere centre, with the vertex
// colours (1,0,0), (0,1,0), (0,0,1). Perspective-correct interpolation over the flat triangle
// through the three unit vertices gives exactly the gnomonic barycentrics that
// `DirectionSet::lookup` computes on the CPU: weights[n] belongs to the id in component n of
// pass 1's output.

#import "common/render_globals.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var<storage, read> sphere_vertices: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> sphere_triangles: array<vec4<u32>>;

struct BarycentricsOut {
    @builtin(position) clip: vec4<f32>,
    // Perspective-correct (the WGSL default).
    @location(0) bary: vec3<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> BarycentricsOut {
    let corner = vi % 3u;
    let v = sphere_triangles[vi / 3u][corner];
    var out: BarycentricsOut;
    out.clip = g.dir_view_proj * vec4<f32>(sphere_vertices[v].xyz, 1.0);
    out.bary = vec3<f32>(f32(corner == 0u), f32(corner == 1u), f32(corner == 2u));
    return out;
}

@fragment
fn fs_main(in: BarycentricsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.bary, 0.0);
}
