// Bake pass 2 of 3 (per transport direction): the radiance interface along every ray.
//
// For each crossing of a ray's depth list: the unshot radiance arriving travelling +w (from the
// previous crossing, "below") and −w (from the next one, "above"), read from the neighbouring
// face's atlas texel on the side facing this crossing; plus open flags: the first (last)
// crossing is open below (above), where sky and sun enter and outgoing light escapes.
// Mirrors vlf_core::bake::reference::interface.

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
}

struct BakeFace {
    normal: vec3<f32>,
    offset: f32,
    origin: vec3<f32>,
    texel_size: f32,
    u: vec3<f32>,
    width: u32,
    v: vec3<f32>,
    height: u32,
    texel_base: u32,
    kind: u32,
    specular: f32,
    _pad: u32,
}

struct CellEntry {
    depth: f32,
    face: u32,
}

// Arriving radiance at one crossing (mirrors vlf_gpu::layout::Crossing):
// below.rgb travelling +w, below.w = 1 if first; above.rgb travelling −w, above.w = 1 if last.
struct Crossing {
    below: vec4<f32>,
    above: vec4<f32>,
}

@group(0) @binding(0) var<uniform> dir: BakeDirection;

@group(1) @binding(0) var<storage, read> faces: array<BakeFace>;
@group(1) @binding(1) var<storage, read> unshot: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> cell_count: array<u32>;
@group(1) @binding(3) var<storage, read> cells: array<CellEntry>;
@group(1) @binding(4) var<storage, read_write> crossings: array<Crossing>;

fn texel_at(f: BakeFace, p: vec3<f32>, side: u32) -> u32 {
    let d = p - f.origin;
    let x = floor(dot(d, f.u) / f.texel_size);
    let y = floor(dot(d, f.v) / f.texel_size);
    let xi = min(u32(max(x, 0.0)), f.width - 1u);
    let yi = min(u32(max(y, 0.0)), f.height - 1u);
    return f.texel_base + side * f.width * f.height + yi * f.width + xi;
}

// Unshot radiance leaving crossing e of the ray at (a, b) in direction toward·w.
fn outgoing(e: CellEntry, a: f32, b: f32, toward: f32) -> vec3<f32> {
    let f = faces[e.face];
    let y = dir.u.xyz * a + dir.v.xyz * b + dir.w.xyz * e.depth;
    let side = select(0u, 1u, dot(f.normal, dir.w.xyz) * toward <= 0.0);
    return unshot[texel_at(f, y, side)].xyz;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = gid.x + gid.y * nwg.x * 64u;
    let n = dir.n;
    if (c >= n * n) {
        return;
    }
    let cell = 2.0 / f32(n);
    let a = -1.0 + (f32(c % n) + 0.5) * cell;
    let b = -1.0 + (f32(c / n) + 0.5) * cell;
    let count = cell_count[c];
    let base = c * dir.k_max;
    for (var k = 0u; k < count; k++) {
        var below = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        var above = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        if (k > 0u) {
            below = vec4<f32>(outgoing(cells[base + k - 1u], a, b, 1.0), 0.0);
        }
        if (k + 1u < count) {
            above = vec4<f32>(outgoing(cells[base + k + 1u], a, b, -1.0), 0.0);
        }
        crossings[base + k] = Crossing(below, above);
    }
}
