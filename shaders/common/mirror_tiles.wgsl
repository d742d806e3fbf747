// The mirror tiles of a light field as the renderer's pass 5 (render_final_radiance.wgsl) and
// the GPU final gather read them: the specular radiance leaving a non-diffuse face at a point
// in a direction, from the sparse per-direction tiles. CPU form:
// vlf_core::gather::field::Tiles::radiance_towards. Texture layout (linear arrays wrapped into
// rows of ATLAS_WIDTH texels): crates/vlf-gpu/src/render/upload.rs.
//
// Group 2, bindings 3–5, of the shaders that import it.

// Width of the light field's wrapped textures: atlas, tile words, tile values, frames (must
// match vlf_gpu::render::upload::ATLAS_WIDTH).
const ATLAS_WIDTH: u32 = 4096u;
// Face slot of a face without tiles (TileIndex::face_slot).
const NO_TILE_SLOT: u32 = 0xffffffffu;

// Index words, 4 per texel: a header [l, m, n, face_slot_off, index_start_off, tile_ids_off,
// coverage_off, words_per_slot], then the packed arrays of vlf_core::lightfield::TileIndex.
@group(2) @binding(3) var tile_words: texture_2d<u32>;
// Total outgoing radiance per tile value (rgb), in the atlas's texture format.
@group(2) @binding(4) var tile_values: texture_2d<f32>;
// Two texels per fixed direction: u, v of its twisted PSF frame.
@group(2) @binding(5) var tile_frames: texture_2d<f32>;

fn tile_word(k: u32) -> u32 {
    let t = k / 4u;
    return textureLoad(tile_words, vec2<u32>(t % ATLAS_WIDTH, t / ATLAS_WIDTH), 0)[k % 4u];
}

fn tile_frame_axis(k: u32) -> vec3<f32> {
    return textureLoad(tile_frames, vec2<u32>(k % ATLAS_WIDTH, k / ATLAS_WIDTH), 0).xyz;
}

// The tile slot of `face` (TileIndex::face_slot), NO_TILE_SLOT for faces without tiles.
fn tile_face_slot(face: u32) -> u32 {
    return tile_word(tile_word(3u) + face);
}

// Tile value slot of non-diffuse slot mf for fixed direction j and cell (ci, cj) in `sense`,
// or -1 when the face stores no tile there or the cell is not covered by the face.
fn tile_value_index(mf: u32, j: u32, ci: i32, cj: i32, sense: u32) -> i32 {
    let l = tile_word(0u);
    let m = tile_word(1u);
    let n = tile_word(2u);
    if (ci < 0 || cj < 0 || ci >= i32(n) || cj >= i32(n)) {
        return -1;
    }
    let k = mf * l + j;
    var lo = tile_word(tile_word(4u) + k);
    var hi = tile_word(tile_word(4u) + k + 1u);
    let uci = u32(ci);
    let ucj = u32(cj);
    let tile = (ucj / m) * (n / m) + uci / m;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        let t = tile_word(tile_word(5u) + mid);
        if (t == tile) {
            let local = (ucj % m) * m + uci % m;
            let cov = tile_word(tile_word(6u) + mid * tile_word(7u) + local / 32u);
            if (((cov >> (local % 32u)) & 1u) == 0u) {
                return -1;
            }
            return i32((mid * 2u + sense) * m * m + local);
        }
        if (t < tile) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return -1;
}

fn tile_value(i: i32) -> vec3<f32> {
    let u = u32(i);
    return textureLoad(tile_values, vec2<u32>(u % ATLAS_WIDTH, u / ATLAS_WIDTH), 0).rgb;
}

// Specular radiance leaving the face of tile slot `mf` (unit `normal`) at `p` towards `out`
// (any length; only its side of the face matters), given the sphere vertices `ids` and weights
// `wts` of the direction of travel *towards* p (-out): each vertex is taken in the opposite
// sense; per vertex, bilinear over the covered cells around p in that direction's ray grid.
// Vertices whose direction leaves the other side of the face are skipped.
fn tile_radiance(mf: u32, normal: vec3<f32>, p: vec3<f32>, out: vec3<f32>, ids: vec3<u32>, wts: vec3<f32>) -> vec3<f32> {
    let l = tile_word(0u);
    let n = f32(tile_word(2u));
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let v = ids[k];
        let j = v % l;
        // The opposite sense of the incoming direction's vertex: light travelling along out.
        let sense = 1u - v / l;
        let fu = tile_frame_axis(2u * j);
        let fv = tile_frame_axis(2u * j + 1u);
        let dir = cross(fu, fv) * select(1.0, -1.0, sense == 1u);
        if (dot(dir, normal) * dot(out, normal) <= 0.0) {
            continue;
        }
        let cx = (dot(p, fu) + 1.0) * 0.5 * n - 0.5;
        let cy = (dot(p, fv) + 1.0) * 0.5 * n - 0.5;
        let x0 = i32(floor(cx));
        let y0 = i32(floor(cy));
        let fx = cx - floor(cx);
        let fy = cy - floor(cy);
        var sum = vec3<f32>(0.0);
        var wsum = 0.0;
        for (var c = 0u; c < 4u; c++) {
            let dx = i32(c & 1u);
            let dy = i32(c >> 1u);
            let w = select(1.0 - fx, fx, dx == 1) * select(1.0 - fy, fy, dy == 1);
            let i = tile_value_index(mf, j, x0 + dx, y0 + dy, sense);
            if (i >= 0 && w > 0.0) {
                sum += tile_value(i) * w;
                wsum += w;
            }
        }
        if (wsum > 0.0) {
            acc += wts[k] * (sum / wsum);
        }
    }
    return acc;
}
