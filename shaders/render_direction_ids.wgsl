// Render pass 1 of 5 (paper §4): direction ids.
//
// The direction set's spherical-triangle mesh (2l unit vertices, vertex v = direction v % l with
// sense v / l) is drawn from the centre of the unit sphere with the camera's orientation and
// projection. Every view ray leaves the centre through exactly one triangle, so each pixel
// receives the three sphere-vertex ids of the triangle containing its view direction (xyz, in
// the triangle's stored counter-clockwise order) and the triangle's index (w).
// No depth test: seen from the centre the triangles tile the view without overlap.

#import "common/render_globals.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

// Unit positions of the 2l sphere vertices (w unused).
@group(1) @binding(0) var<storage, read> sphere_vertices: array<vec4<f32>>;
// Sphere triangles: three sphere-vertex ids (xyz), w unused.
@group(1) @binding(1) var<storage, read> sphere_triangles: array<vec4<u32>>;

struct DirectionIdsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) ids: vec4<u32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> DirectionIdsOut {
    let t = vi / 3u;
    let tri = sphere_triangles[t];
    let v = tri[vi % 3u];
    var out: DirectionIdsOut;
    out.clip = g.dir_view_proj * vec4<f32>(sphere_vertices[v].xyz, 1.0);
    out.ids = vec4<u32>(tri.xyz, t);
    return out;
}

@fragment
fn fs_main(in: DirectionIdsOut) -> @location(0) vec4<u32> {
    return in.ids;
}
