// Bake pass 2 of 3 (per transport direction): the radiance interface along every ray.
//
// For each crossing of a ray's depth list: the unshot radiance arriving travelling +w (from the
// previous crossing, "below") and −w (from the next one, "above"), read from the neighbouring
// face's atlas texel on the side facing this crossing; plus open flags: the first (last)
// crossing is open below (above), where sky and sun enter and outgoing light escapes. Panes
// (common/pane.wgsl) pass what arrives at them on along the ray, tinted by T(θ): the sky and a
// sun through the glass included; along a sun's direction only the sun is followed.
// Mirrors vlf_core::bake::reference::interface.

#import "common/bake_direction.wgsl"
#import "common/bake_scene.wgsl"
#import "common/bake_rays.wgsl"
#import "common/pane.wgsl"

// Group 0: `dir` (common/bake_direction.wgsl).

@group(1) @binding(0) var<storage, read> faces: array<BakeFace>;
// Unshot radiance: atlas texels, then the non-diffuse tile values from dir.tile_values_off.
@group(1) @binding(1) var<storage, read> unshot: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> cell_count: array<u32>;
@group(1) @binding(3) var<storage, read> cells: array<CellEntry>;
@group(1) @binding(4) var<storage, read_write> crossings: array<Crossing>;
// Packed tile index (vlf_core::bake::tiles::TileIndex): face_slot, index_start, tile_ids,
// coverage at the offsets in `dir`.
@group(1) @binding(5) var<storage, read> tile_index: array<u32>;
// Frames of the fixed directions: u, v, w (xyz) for direction j at 3j, 3j+1, 3j+2.
@group(1) @binding(6) var<storage, read> frames: array<vec4<f32>>;
// Per ray: specular power escaping through the ray's open ends (rgb), summed over directions.
@group(1) @binding(7) var<storage, read_write> spec_escape: array<vec4<f32>>;
// Per face: its pane (zero without one).
@group(1) @binding(8) var<storage, read> panes: array<PaneFace>;
// Per ray, summed over directions: what panes absorbed (x), let escape (y) and the sunlight
// that reached a crossing through panes (z) (vlf_core::bake::reference::PaneEnergy).
@group(1) @binding(9) var<storage, read_write> pane_energy: array<vec4<f32>>;

fn cell_at(x: f32) -> u32 {
    let nf = f32(dir.n);
    return u32(clamp(floor((x + 1.0) * 0.5 * nf), 0.0, nf - 1.0));
}

// Index of the tile value of `face` at cell (ci, cj) of fixed direction j, sense `sense`, or -1.
fn value_index(face: u32, j: u32, sense: u32, ci: u32, cj: u32) -> i32 {
    let mf = tile_index[dir.face_slot_off + face];
    if (mf == 0xffffffffu) {
        return -1;
    }
    let k = mf * dir.tiles_l + j;
    var lo = tile_index[dir.index_start_off + k];
    var hi = tile_index[dir.index_start_off + k + 1u];
    let m = dir.tile_m;
    let tile = (cj / m) * (dir.n / m) + ci / m;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        let t = tile_index[dir.tile_ids_off + mid];
        if (t == tile) {
            return i32((mid * 2u + sense) * m * m + (cj % m) * m + ci % m);
        }
        if (t < tile) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return -1;
}

// Specular unshot radiance leaving `face` at y along +w (plus) or −w: the three fixed
// directions around it with their barycentric weights (vlf_core::bake::tiles::specular_outgoing).
fn specular(face: u32, y: vec3<f32>, plus: bool) -> vec3<f32> {
    var verts = dir.spec_minus_v;
    var weights = dir.spec_minus_w;
    if (plus) {
        verts = dir.spec_plus_v;
        weights = dir.spec_plus_w;
    }
    var out = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        if (weights[k] <= 0.0) {
            continue;
        }
        let j = verts[k] % dir.tiles_l;
        let sense = verts[k] / dir.tiles_l;
        let a = dot(y, frames[3u * j].xyz);
        let b = dot(y, frames[3u * j + 1u].xyz);
        let i = value_index(face, j, sense, cell_at(a), cell_at(b));
        if (i >= 0) {
            out += unshot[dir.tile_values_off + u32(i)].xyz * weights[k];
        }
    }
    return out;
}

fn texel_at(f: BakeFace, p: vec3<f32>, side: u32) -> u32 {
    let d = p - f.origin;
    let x = floor(dot(d, f.u) / f.texel_size);
    let y = floor(dot(d, f.v) / f.texel_size);
    let xi = min(u32(max(x, 0.0)), f.width - 1u);
    let yi = min(u32(max(y, 0.0)), f.height - 1u);
    return f.texel_base + side * f.width * f.height + yi * f.width + xi;
}

// Unshot radiance leaving crossing e of the ray at (a, b) in direction toward·w: the diffuse
// texel plus, for non-diffuse faces, the specular tiles.
fn outgoing(e: CellEntry, a: f32, b: f32, toward: f32) -> vec3<f32> {
    let f = faces[e.face];
    let y = dir.u.xyz * a + dir.v.xyz * b + dir.w.xyz * e.depth;
    let side = select(0u, 1u, dot(f.normal, dir.w.xyz) * toward <= 0.0);
    var l = unshot[texel_at(f, y, side)].xyz;
    if (dir.has_tiles != 0u && f.kind != 0u) {
        l += specular(e.face, y, toward > 0.0);
    }
    return l;
}

fn specular_at(e: CellEntry, a: f32, b: f32, plus: bool) -> vec3<f32> {
    let y = dir.u.xyz * a + dir.v.xyz * b + dir.w.xyz * e.depth;
    return specular(e.face, y, plus);
}

// Unshot radiance leaving crossing e toward·w; nothing along a sun's direction.
fn leaving(e: CellEntry, a: f32, b: f32, toward: f32) -> vec3<f32> {
    if (dir.is_sun != 0u) {
        return vec3<f32>(0.0);
    }
    return outgoing(e, a, b, toward);
}

fn sum3(v: vec3<f32>) -> f32 {
    return v.x + v.y + v.z;
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
    let sun = dir.is_sun != 0u;
    let panes_on = dir.has_panes != 0u;
    var src_up = dir.sky.xyz;
    var src_down = dir.sky.xyz;
    if (sun) {
        src_up = dir.sun.xyz;
        src_down = vec3<f32>(0.0);
    }
    let cell_power = cell * cell * dir.weight;
    let sun_power = cell * cell;
    var power = cell_power;
    if (sun) {
        power = sun_power;
    }
    var energy = vec3<f32>(0.0);
    // Upward: what arrives at each crossing from below.
    var carry = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        var below = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        if (k > 0u) {
            below = vec4<f32>(leaving(cells[base + k - 1u], a, b, 1.0) + carry, 0.0);
        }
        crossings[base + k].below = below;
        if (panes_on) {
            if (sun && k > 0u) {
                energy.z += sum3(carry) * sun_power;
            }
            var arriving = below.xyz;
            if (k == 0u) {
                arriving += src_up;
            }
            let e = cells[base + k];
            let p = panes[e.face];
            let ct = abs(dot(faces[e.face].normal, dir.w.xyz));
            carry = arriving * pane_transmittance(p, ct);
            energy.x += (sum3(arriving) * pane_untinted(p, ct) - sum3(carry)) * power;
            if (k + 1u == count) {
                energy.y += sum3(carry) * power;
            }
        }
    }
    // Downward: what arrives at each crossing from above.
    carry = vec3<f32>(0.0);
    for (var i = 0u; i < count; i++) {
        let k = count - 1u - i;
        var above = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        if (k + 1u < count) {
            above = vec4<f32>(leaving(cells[base + k + 1u], a, b, -1.0) + carry, 0.0);
        }
        crossings[base + k].above = above;
        if (panes_on && !sun) {
            var arriving = above.xyz;
            if (k + 1u == count) {
                arriving += src_down;
            }
            let e = cells[base + k];
            let p = panes[e.face];
            let ct = abs(dot(faces[e.face].normal, dir.w.xyz));
            carry = arriving * pane_transmittance(p, ct);
            energy.x += (sum3(arriving) * pane_untinted(p, ct) - sum3(carry)) * cell_power;
            if (k == 0u) {
                energy.y += sum3(carry) * cell_power;
            }
        }
    }
    if (panes_on) {
        pane_energy[c] += vec4<f32>(energy, 0.0);
    }
    // Specular light leaving through an open end escapes (diffuse escapes are counted per
    // texel from the open fractions).
    if (dir.has_tiles != 0u && dir.is_sun == 0u && count > 0u) {
        var esc = vec3<f32>(0.0);
        let top = cells[base + count - 1u];
        if (faces[top.face].kind != 0u) {
            esc += specular_at(top, a, b, true);
        }
        let bottom = cells[base];
        if (faces[bottom.face].kind != 0u) {
            esc += specular_at(bottom, a, b, false);
        }
        spec_escape[c] += vec4<f32>(esc * (cell * cell * dir.weight), 0.0);
    }
}
