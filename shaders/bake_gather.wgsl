// Bake pass 3 of 3 (per transport direction): every texel gathers the light arriving at it.
//
// One invocation per covered front-side texel (both sides are handled together). The texel
// reads the mean arriving radiance of the rays that cross its own square on its own face (a box
// filter that never reaches past the texel: no leaks across contact edges), falling back to the
// nearest crossing of its face within two cells when no ray crosses it (small texel, grazing
// direction), and adds |cos|·ΔΩ·L to its accumulators. Each texel owns its accumulators, so
// there are no atomics and the result is deterministic. Mirrors
// vlf_core::bake::reference::{sample_texel, gather_direction}.

#import "common/bake_direction.wgsl"
#import "common/bake_scene.wgsl"
#import "common/bake_rays.wgsl"

// Per texel side (mirrors vlf_core::bake::reference::TexelAccum): irradiance.rgb = Σ|cos|ΔΩL,
// irradiance.w = Σ|cos|ΔΩ of valid directions; open.rgb = Σ E_sun|cos|·open (suns),
// open.w = Σ|cos|ΔΩ·open.
struct TexelAccum {
    irradiance: vec4<f32>,
    open: vec4<f32>,
}

const FALLBACK_RADIUS: i32 = 2;

// Group 0: `dir` (common/bake_direction.wgsl).

@group(1) @binding(0) var<storage, read> faces: array<BakeFace>;
@group(1) @binding(1) var<storage, read> active_texels: array<u32>;
// xyz: sample point (VLF), w: face index (bit pattern).
@group(1) @binding(2) var<storage, read> texel_center: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> cell_count: array<u32>;
@group(1) @binding(4) var<storage, read> cells: array<CellEntry>;
@group(1) @binding(5) var<storage, read> crossings: array<Crossing>;
@group(1) @binding(6) var<storage, read_write> acc: array<TexelAccum>;

// Index into `crossings` of `face` in cell (i, j), or -1.
fn find(i: i32, j: i32, face: u32) -> i32 {
    let n = i32(dir.n);
    if (i < 0 || j < 0 || i >= n || j >= n) {
        return -1;
    }
    let c = u32(j * n + i);
    let base = c * dir.k_max;
    let count = cell_count[c];
    for (var k = 0u; k < count; k++) {
        if (cells[base + k].face == face) {
            return i32(base + k);
        }
    }
    return -1;
}

fn continuous(p: vec3<f32>) -> vec2<f32> {
    let q = vec2<f32>(dot(p, dir.u.xyz), dot(p, dir.v.xyz));
    return (q + 1.0) * (0.5 * f32(dir.n));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let idx = gid.x + gid.y * nwg.x * 64u;
    if (idx >= dir.active_texels) {
        return;
    }
    let t = active_texels[idx];
    let tc = texel_center[t];
    let face = bitcast<u32>(tc.w);
    let f = faces[face];
    let w = dir.w.xyz;
    let ndw = dot(f.normal, w);
    if (abs(ndw) < MIN_COS) {
        return;
    }
    let local = t - f.texel_base;
    let tx = local % f.width;
    let ty = local / f.width;
    let ts = f.texel_size;
    let c00 = continuous(f.origin + f.u * (f32(tx) * ts) + f.v * (f32(ty) * ts));
    let c10 = continuous(f.origin + f.u * (f32(tx + 1u) * ts) + f.v * (f32(ty) * ts));
    let c01 = continuous(f.origin + f.u * (f32(tx) * ts) + f.v * (f32(ty + 1u) * ts));
    let c11 = continuous(f.origin + f.u * (f32(tx + 1u) * ts) + f.v * (f32(ty + 1u) * ts));
    let lo = min(min(c00, c10), min(c01, c11));
    let hi = max(max(c00, c10), max(c01, c11));
    let n = i32(dir.n);
    let i0 = max(i32(ceil(lo.x - 0.5)), 0);
    let j0 = max(i32(ceil(lo.y - 0.5)), 0);
    let i1 = min(i32(floor(hi.x - 0.5)), n - 1);
    let j1 = min(i32(floor(hi.y - 0.5)), n - 1);
    let cell = 2.0 / f32(dir.n);
    var below = vec3<f32>(0.0);
    var above = vec3<f32>(0.0);
    var first = 0.0;
    var last = 0.0;
    var weight = 0.0;
    for (var j = j0; j <= j1; j++) {
        for (var i = i0; i <= i1; i++) {
            let a = -1.0 + (f32(i) + 0.5) * cell;
            let b = -1.0 + (f32(j) + 0.5) * cell;
            let o = dir.u.xyz * a + dir.v.xyz * b;
            let depth = (f.offset - dot(f.normal, o)) / ndw;
            let d = o + w * depth - f.origin;
            let x = floor(dot(d, f.u) / ts);
            let y = floor(dot(d, f.v) / ts);
            if (x != f32(tx) || y != f32(ty)) {
                continue;
            }
            let k = find(i, j, face);
            if (k >= 0) {
                let e = crossings[k];
                below += e.below.xyz;
                above += e.above.xyz;
                first += e.below.w;
                last += e.above.w;
                weight += 1.0;
            }
        }
    }
    if (weight == 0.0) {
        let cp = continuous(tc.xyz);
        let ci = i32(floor(cp.x));
        let cj = i32(floor(cp.y));
        var best = -1;
        var best_d2 = 0.0;
        for (var dj = -FALLBACK_RADIUS; dj <= FALLBACK_RADIUS; dj++) {
            for (var di = -FALLBACK_RADIUS; di <= FALLBACK_RADIUS; di++) {
                let k = find(ci + di, cj + dj, face);
                if (k >= 0) {
                    let dx = f32(ci + di) + 0.5 - cp.x;
                    let dy = f32(cj + dj) + 0.5 - cp.y;
                    let d2 = dx * dx + dy * dy;
                    if (best < 0 || d2 < best_d2) {
                        best = k;
                        best_d2 = d2;
                    }
                }
            }
        }
        if (best < 0) {
            return;
        }
        let e = crossings[best];
        below = e.below.xyz;
        above = e.above.xyz;
        first = e.below.w;
        last = e.above.w;
        weight = 1.0;
    }
    let inv = 1.0 / weight;
    below *= inv;
    above *= inv;
    first *= inv;
    last *= inv;
    // The front side faces −w when n·w < 0: rays travelling +w (from below) reach it.
    var arriving0 = above;
    var arriving1 = below;
    var open0 = last;
    var open1 = first;
    if (ndw < 0.0) {
        arriving0 = below;
        arriving1 = above;
        open0 = first;
        open1 = last;
    }
    let cos_t = abs(ndw);
    let back = t + f.width * f.height;
    if (dir.is_sun != 0u) {
        // A sun's light travels +w only: it reaches the side facing −w (side 0 when n·w < 0),
        // through the first crossing of its ray (open0 / open1 is then the "first" fraction).
        // Through panes too: `arriving` along a sun's direction is the sun that passed them.
        if (ndw < 0.0) {
            acc[t].open += vec4<f32>(dir.sun.xyz * (cos_t * open0) + arriving0 * cos_t, 0.0);
        } else {
            acc[back].open += vec4<f32>(dir.sun.xyz * (cos_t * open1) + arriving1 * cos_t, 0.0);
        }
        return;
    }
    let wgt = dir.weight * cos_t;
    acc[t].irradiance += vec4<f32>(arriving0 * wgt, wgt);
    acc[t].open.w += open0 * wgt;
    acc[back].irradiance += vec4<f32>(arriving1 * wgt, wgt);
    acc[back].open.w += open1 * wgt;
}
