// The direction set's lookup on the GPU: the spherical triangle of the sphere mesh that holds a
// direction and the gnomonic barycentric weights of its three vertices. Mirrors
// vlf_core::directions::DirectionSet::lookup (which works in f64; this works in f32, so a
// direction within rounding of a triangle edge may land in the neighbouring triangle, where the
// vertex it does not share carries a weight of about zero). Tables: vlf_gpu::directions.
//
// Group 2 (bindings 0 and 1) of the shaders that import it.

// The icosahedron tables of the lookup (mirrors vlf_gpu::layout::DirTables, built from
// vlf_core::directions::LookupTables).
struct DirTables {
    // Unit outward normal of each icosahedron face (xyz).
    face_normals: array<vec4<f32>, 20>,
    // edge_n[f] = c_j × c_k for corner n of face f: d · edge_n[f] is proportional to the
    // flat-face barycentric of corner n.
    edge0: array<vec4<f32>, 20>,
    edge1: array<vec4<f32>, 20>,
    edge2: array<vec4<f32>, 20>,
    // Per sign octant (bit 0: x < 0, bit 1: y < 0, bit 2: z < 0), the four candidate faces.
    octant_faces: array<vec4<u32>, 8>,
    // Frequency k and the number of directions l (sphere vertices 0..2l).
    k: u32,
    l: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(2) @binding(0) var<uniform> dir_tables: DirTables;
// The sphere mesh: the 2l unit sphere-vertex positions (xyz; w unused) by sphere-vertex id,
// then the sphere triangles in the order of DirectionSet::sphere_triangles (three sphere-vertex
// ids as bits; w unused). One buffer, to keep within 8 storage buffers per stage.
@group(2) @binding(1) var<storage, read> dir_mesh: array<vec4<f32>>;

fn sphere_vertex(v: u32) -> vec3<f32> {
    return dir_mesh[v].xyz;
}

fn sphere_triangle(t: u32) -> vec3<u32> {
    return bitcast<vec3<u32>>(dir_mesh[2u * dir_tables.l + t].xyz);
}

// Result of direction_lookup (mirrors vlf_core::directions::Lookup).
struct DirLookup {
    vertices: vec3<u32>,
    weights: vec3<f32>,
    triangle: u32,
}

// floor(x) clamped to 0..=max (NaN gives 0), as the CPU's floor_clamped.
fn dir_floor_clamped(x: f32, max: u32) -> u32 {
    let f = floor(x);
    if f >= f32(max) {
        return max;
    }
    if f > 0.0 {
        return u32(f);
    }
    return 0u;
}

// The spherical triangle holding direction `d` (any length) and the barycentric weights of its
// vertices. A zero-length or non-finite `d` gives the CPU's fallback: the triangle of vertex 0
// with all weight on vertex 0.
fn direction_lookup(d_in: vec3<f32>) -> DirLookup {
    // Scale before normalising so that huge components do not overflow.
    let m = max(abs(d_in.x), max(abs(d_in.y), abs(d_in.z)));
    let fallback = !(m > 0.0 && m <= 3.4028235e38);
    var d = sphere_vertex(0u);
    if !fallback {
        d = normalize(d_in / m);
    }
    // 1. Icosahedron face: the one of the octant's four maximising d · n.
    let octant = select(0u, 1u, d.x < 0.0) | select(0u, 2u, d.y < 0.0) | select(0u, 4u, d.z < 0.0);
    let cands = dir_tables.octant_faces[octant];
    var f = cands[0];
    var best = dot(dir_tables.face_normals[f].xyz, d);
    for (var c = 1u; c < 4u; c++) {
        let dt = dot(dir_tables.face_normals[cands[c]].xyz, d);
        if dt > best {
            best = dt;
            f = cands[c];
        }
    }
    // 2. Flat-face barycentrics of the central projection of d.
    let b1 = dot(d, dir_tables.edge1[f].xyz);
    let b2 = dot(d, dir_tables.edge2[f].xyz);
    let s = dot(d, dir_tables.edge0[f].xyz) + b1 + b2;
    let k = dir_tables.k;
    let kf = f32(k);
    var x = 0.0;
    var y = 0.0;
    if s > 0.0 {
        x = b1 / s * kf;
        y = b2 / s * kf;
    }
    // 3. Grid cell (i, j) and up/down half.
    let km1 = k - 1u;
    let i = dir_floor_clamped(x, km1);
    var j = dir_floor_clamped(y, km1);
    var down = false;
    if i + j > km1 {
        j = km1 - i;
    } else {
        let fx = x - f32(i);
        let fy = y - f32(j);
        down = fx + fy > 1.0 && i + j < km1;
    }
    let t = f * k * k + 2u * k * j - j * j + 2u * i + select(0u, 1u, down);
    let vs = sphere_triangle(t);
    // 4. Gnomonic barycentrics against the three stored vertices.
    let p0 = sphere_vertex(vs.x);
    let p1 = sphere_vertex(vs.y);
    let p2 = sphere_vertex(vs.z);
    var w = max(vec3<f32>(dot(d, cross(p1, p2)), dot(d, cross(p2, p0)), dot(d, cross(p0, p1))), vec3<f32>(0.0));
    let sum = w.x + w.y + w.z;
    if sum > 0.0 {
        w = w / sum;
    } else {
        // Only through pathological rounding: snap to the closest corner.
        let dots = vec3<f32>(dot(d, p0), dot(d, p1), dot(d, p2));
        var mi = 0u;
        if dots.y > dots[mi] {
            mi = 1u;
        }
        if dots.z > dots[mi] {
            mi = 2u;
        }
        w = vec3<f32>(0.0);
        w[mi] = 1.0;
    }
    if fallback {
        w = select(vec3<f32>(0.0), vec3<f32>(1.0), vs == vec3<u32>(0u));
    }
    return DirLookup(vs, w, t);
}
