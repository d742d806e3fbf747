// Bake pass 1 of 3 (per transport direction): exact per-ray depth lists.
//
// One invocation per ray (cell centre of the N×N PSF grid). The ray is intersected exactly with
// every triangle binned (on the CPU) into its tile; crossings are kept sorted by (depth, face),
// one per face (min depth), in a fixed-capacity list of k_max entries. This replaces the paper's
// painter's sort: the order along each ray is exact, so cyclic overlaps and interpenetrating
// faces cannot be mis-ordered. Mirrors vlf_core::bake::reference::build_cell_lists.

#import "common/bake_direction.wgsl"
#import "common/bake_scene.wgsl"
#import "common/bake_rays.wgsl"
#import "common/alpha_mask.wgsl"

// Group 0: `dir` (common/bake_direction.wgsl).

@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;
@group(1) @binding(1) var<storage, read> bin_start: array<u32>;
@group(1) @binding(2) var<storage, read> bin_tris: array<u32>;
@group(1) @binding(3) var<storage, read_write> cell_count: array<u32>;
@group(1) @binding(4) var<storage, read_write> cells: array<CellEntry>;
@group(1) @binding(5) var<storage, read_write> overflow: array<atomic<u32>>;
// Binding 6: `alpha_masks` (common/alpha_mask.wgsl), the triangles' alpha masks: a crossing
// where a mask leaves no surface is not listed.

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

fn to_psf(p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(p, dir.u.xyz), dot(p, dir.v.xyz), dot(p, dir.w.xyz));
}

// (a, b) after (c, d) in (depth, face) order?
fn after(da: f32, fa: u32, db: f32, fb: u32) -> bool {
    return da > db || (da == db && fa > fb);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = gid.x + gid.y * nwg.x * 64u;
    let n = dir.n;
    if (c >= n * n) {
        return;
    }
    let i = c % n;
    let j = c / n;
    let cell = 2.0 / f32(n);
    let p = vec2<f32>(-1.0 + (f32(i) + 0.5) * cell, -1.0 + (f32(j) + 0.5) * cell);
    let tile = (j / dir.tile) * dir.tiles_per_side + i / dir.tile;
    let first = bin_start[dir.bin_base + tile];
    let last = bin_start[dir.bin_base + tile + 1u];
    let base = c * dir.k_max;
    var count = 0u;
    for (var t = first; t < last; t++) {
        let tri = triangles[bin_tris[t]];
        let q0 = to_psf(tri.p0);
        let q1 = to_psf(tri.p1);
        let q2 = to_psf(tri.p2);
        let a = q0.xy;
        let b = q1.xy;
        let cc = q2.xy;
        let area = cross2(b - a, cc - a);
        if (area == 0.0) {
            continue;
        }
        let w0 = cross2(b - p, cc - p) / area;
        let w1 = cross2(cc - p, a - p) / area;
        let w2 = 1.0 - w0 - w1;
        if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) {
            continue;
        }
        let depth = w0 * q0.z + w1 * q1.z + w2 * q2.z;
        if (alpha_cuts(bin_tris[t], vec3<f32>(w0, w1, w2))) {
            continue;
        }
        let face = tri.face;
        // One crossing per face: keep the smallest (depth, face).
        var dup = count;
        for (var k = 0u; k < count; k++) {
            if (cells[base + k].face == face) {
                dup = k;
                break;
            }
        }
        if (dup < count) {
            if (!after(cells[base + dup].depth, face, depth, face)) {
                continue;
            }
            // Remove the old entry; the new, nearer one is inserted below.
            for (var k = dup; k + 1u < count; k++) {
                cells[base + k] = cells[base + k + 1u];
            }
            count -= 1u;
        }
        if (count == dir.k_max) {
            atomicMax(&overflow[0], count + 1u);
            continue;
        }
        // Insertion into (depth, face) order.
        var k = count;
        while (k > 0u && after(cells[base + k - 1u].depth, cells[base + k - 1u].face, depth, face)) {
            cells[base + k] = cells[base + k - 1u];
            k -= 1u;
        }
        cells[base + k] = CellEntry(depth, face);
        count += 1u;
    }
    cell_count[c] = count;
}
