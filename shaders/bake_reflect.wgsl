// Bake pass 4 (per transport direction, scenes with mirrors/mixed faces): the reflect step.
//
// One invocation per cell of every destination tile slot of this direction's reflect items
// (the three directions around the reflected one for a mirror, the lobe's for a glossy face).
// A destination cell (fixed direction j, sense s) of a non-diffuse face maps through the face's
// plane back into the current PSF, finds the nearest ray crossing the face there, and adds
// weight × the radiance arriving at that crossing (sky or sun entering through an open end
// included) to the next-iteration tile value. Every destination is written by at most one
// invocation per direction, so there are no atomics. Mirrors
// vlf_core::bake::reference::reflect.

#import "common/bake_direction.wgsl"
#import "common/bake_scene.wgsl"
#import "common/bake_rays.wgsl"

// Mirrors vlf_gpu::layout::ReflectItem.
struct ReflectItem {
    weight: vec4<f32>,
    slot: u32,
    face: u32,
    j: u32,
    senses: u32,
}

// Group 0: `dir` (common/bake_direction.wgsl).

@group(1) @binding(0) var<storage, read> faces: array<BakeFace>;
@group(1) @binding(1) var<storage, read> cell_count: array<u32>;
@group(1) @binding(2) var<storage, read> cells: array<CellEntry>;
@group(1) @binding(3) var<storage, read> crossings: array<Crossing>;
@group(1) @binding(4) var<storage, read> tile_index: array<u32>;
@group(1) @binding(5) var<storage, read> frames: array<vec4<f32>>;
@group(1) @binding(6) var<storage, read> items: array<ReflectItem>;
@group(1) @binding(7) var<storage, read_write> next_tiles: array<vec4<f32>>;

// Index into `crossings` of the crossing of `face` by the ray nearest to PSF point (a, b)
// among the 3×3 cells around it, or -1 (vlf_core::bake::reference::nearest_crossing).
fn nearest_crossing(a: f32, b: f32, face: u32) -> i32 {
    let n = i32(dir.n);
    let nf = f32(dir.n);
    let cx = (a + 1.0) * 0.5 * nf;
    let cy = (b + 1.0) * 0.5 * nf;
    let ci = i32(floor(cx));
    let cj = i32(floor(cy));
    var best = -1;
    var best_d2 = 0.0;
    for (var dj = -1; dj <= 1; dj++) {
        for (var di = -1; di <= 1; di++) {
            let i = ci + di;
            let j = cj + dj;
            if (i < 0 || j < 0 || i >= n || j >= n) {
                continue;
            }
            let c = u32(j * n + i);
            let base = c * dir.k_max;
            let count = cell_count[c];
            for (var k = 0u; k < count; k++) {
                if (cells[base + k].face == face) {
                    let dx = f32(i) + 0.5 - cx;
                    let dy = f32(j) + 0.5 - cy;
                    let d2 = dx * dx + dy * dy;
                    if (best < 0 || d2 < best_d2) {
                        best = i32(base + k);
                        best_d2 = d2;
                    }
                    break;
                }
            }
        }
    }
    return best;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let idx = gid.x + gid.y * nwg.x * 64u;
    let m = dir.tile_m;
    let m2 = m * m;
    let item_i = idx / m2;
    let local = idx % m2;
    if (item_i >= dir.items_count) {
        return;
    }
    let it = items[dir.items_base + item_i];
    let word = tile_index[dir.coverage_off + it.slot * dir.words_per_slot + local / 32u];
    if (((word >> (local % 32u)) & 1u) == 0u) {
        return;
    }
    let tile = tile_index[dir.tile_ids_off + it.slot];
    let tps = dir.n / m;
    let ci = (tile % tps) * m + local % m;
    let cj = (tile / tps) * m + local / m;
    let f = faces[it.face];
    let fu = frames[3u * it.j].xyz;
    let fv = frames[3u * it.j + 1u].xyz;
    let fw = frames[3u * it.j + 2u].xyz;
    let ndw = dot(f.normal, fw);
    if (abs(ndw) < MIN_COS) {
        return;
    }
    let cell = 2.0 / f32(dir.n);
    let a = -1.0 + (f32(ci) + 0.5) * cell;
    let b = -1.0 + (f32(cj) + 0.5) * cell;
    let o = fu * a + fv * b;
    let x = o + fw * ((f.offset - dot(f.normal, o)) / ndw);
    let k = nearest_crossing(dot(x, dir.u.xyz), dot(x, dir.v.xyz), it.face);
    if (k < 0) {
        return;
    }
    let cr = crossings[k];
    var arriving: vec3<f32>;
    if (dir.is_sun != 0u) {
        // Through its ray's open end or through panes.
        arriving = dir.sun.xyz * cr.below.w + cr.below.xyz;
    } else if ((it.senses & 1u) == 0u) {
        arriving = cr.below.xyz + dir.sky.xyz * cr.below.w;
    } else {
        arriving = cr.above.xyz + dir.sky.xyz * cr.above.w;
    }
    let sense = (it.senses >> 1u) & 1u;
    let vi = (it.slot * 2u + sense) * m2 + local;
    // w: what the lobe absorbed (`loss` × the reflected rgb), for the energy bookkeeping.
    let c = arriving * it.weight.xyz;
    next_tiles[vi] += vec4<f32>(c, (c.x + c.y + c.z) * it.weight.w);
}
