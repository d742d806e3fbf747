// The final gather's texel estimators on the GPU (vlf_gpu::gather; specification:
// vlf_core::gather, whose `indirect` and `direct` these mirror draw for draw): one invocation per
// texel of a chunk of one grid. Each texel draws its own stream (Rng::for_path(SEED, texel,
// stream)) in the CPU's order: the texel's stratified open sample points (gather/points.rs),
// then the shuffled strata and jitter of its rays; rays are traced inline through the ray
// engine's BVH (common/bvh.wgsl). Output per texel: the estimate (rgb) and a = 1, or a = 0 when
// the texel has no open point (the CPU's None).
//
// * indirect: cosine rays read the converged light field at their first hit: the
//   propagation's (dilated) irradiance times the hit point's albedo / π, plus the mirror tiles
//   in the ray's direction (common/mirror_tiles.wgsl, common/directions.wgsl). The irradiance
//   read stops at contacts as the CPU's (Field::irradiance_at; common/gather_field.wgsl), with
//   the contact bits the CPU computed (Contacts) and short visibility rays.
// * direct: light samples over the emitters and cosine rays combined with the power heuristic,
//   the sky by the cosine rays, suns, point and spot lights by shadow rays.
// * shading normals: each sample point keeps the chart triangle it lies on; where that triangle
//   is smooth, its rays, light samples and delta lights are taken about the interpolated normal
//   there (point_normal), from the geometric face, and directions below the geometric surface
//   bring nothing (vlf_core::gather::below).
// * thin glass panes (common/pane_trace.wgsl, vlf_core::gather::through): every ray goes on
//   through panes. A cosine ray sees the sky or an emitter behind a window weighted by the
//   panes' transmittance, a shadow ray towards a light sample, a sun, a point or a spot light is
//   attenuated instead of stopped, an indirect ray reads what each pane it crosses sends back
//   (its tiles and diffuse part) as well as the field behind it, and the openness probes count a
//   pane, or a surface light crosses (thin diffuse transmission), as open.
//
// Steps. A texel's estimate is split into steps, one dispatch each, in the order the CPU draws:
// begin (stream, class), draw_points (a batch of points each), finish_points (centroid
// fallback, first strata), then indirect_rays (a batch of rays each), indirect_end; or
// light_samples (batches), shuffle, cosine_rays (batches), delta_rays (batches of points),
// direct_end. Between steps the texel's state (random stream, points, strata order, partial
// sums in the CPU's order of addition) stays in `scratch`, so the result does not depend on
// the batch sizes. Why: llvmpipe (lavapipe) gives every shader invocation (a SIMD group of
// lanes) a budget of 65,535 loop trips shared by all its loops (gallivm's loop limiter,
// LP_MAX_TGSI_LOOP_ITERATIONS) and ends every loop after one trip once it is spent, silently;
// BVH traversals inlined in a texel's hundreds of rays spent it, and later rays found no hit
// (the indirect light came out low). Each step checks the budget still holds at its end
// (loops_intact) and marks the texel CUT otherwise, so vlf_gpu::gather retries with smaller
// batches rather than return a wrong result. Real GPUs have no such budget; the steps also keep
// every dispatch short there.

#import "common/rt_scene.wgsl"
#import "common/random.wgsl"
#import "common/sampling.wgsl"
#import "common/bake_scene.wgsl"
#import "common/directions.wgsl"
#import "common/mirror_tiles.wgsl"
#import "common/gather_field.wgsl"
#import "common/pane_trace.wgsl"

// Per-dispatch globals (mirrors vlf_gpu::layout::GatherGlobals).
struct GatherGlobals {
    // Sky radiance (rgb).
    sky: vec4<f32>,
    // World → VLF: (p − center) · scale.
    xf_center: vec3<f32>,
    xf_scale: f32,
    // The chunk: texels texel_base .. texel_base + texel_count of the grid.
    texel_base: u32,
    texel_count: u32,
    // Random stream selector (STREAM_INDIRECT or STREAM_DIRECT) and seed.
    stream: u32,
    seed: u32,
    // Sample points per texel and the side of their strata grid.
    points: u32,
    points_side: u32,
    // Probes along the normal closer than this close a point (world units).
    r_close: f32,
    // 1 when the light field has mirror tiles.
    has_tiles: u32,
    // Light samples and cosine rays, and the sides of their strata grids (direct: as the CPU
    // picks them; indirect: no light samples, one cosine ray per point).
    light_samples: u32,
    light_side: u32,
    cosine_rays: u32,
    cosine_side: u32,
    // Section offsets (vec4 units) of the grid buffer and of the field's irradiance.
    grid_texels: u32,
    chart_start: u32,
    chart_tris: u32,
    field_irradiance: u32,
    // Entries of `scratch` per invocation, and where its strata order starts.
    scratch_stride: u32,
    strata_at: u32,
    // 2 (see loops_intact).
    sentinel: u32,
    // This step: samples k0 .. k1 of its loop, the side of the strata a shuffle makes.
    k0: u32,
    k1: u32,
    side: u32,
    // Where the field buffer's contact bits start (16 texels' bytes per entry).
    field_contacts: u32,
    // Where the grid's chart normals start (three entries, the corners' unit shading normals,
    // per smooth chart triangle).
    chart_normals: u32,
}

// One entry per step of the chunk, bound at a dynamic offset. (Not a second uniform for the
// step: lavapipe 22.3 crashes on a pipeline with two uniform buffers in group 0 that also reads
// textures.)
@group(0) @binding(0) var<uniform> gg: GatherGlobals;
// The grid being gathered, in sections (vec4 each; offsets in gg): its faces (5 entries per
// BakeFace, at 0), per texel its covered part's centroid (VLF xyz) and area (w) then its face
// (x, as bits) (at grid_texels), per face the start of its chart triangles (x, as bits; faces +
// 1 entries, at chart_start), the chart-space triangles, two entries each: (p0, p1),
// (p2, normals, 0) with `normals` the triangle's first entry (as bits) in the chart normals
// (at chart_normals; NONE for a flat triangle) (at chart_tris), and the chart normals. One
// buffer, to keep within 8 storage buffers per stage.
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;
// The estimate per texel of the grid (rgb; a = 1 where the texel has an open point).
@group(0) @binding(2) var<storage, read_write> gather_out: array<vec4<f32>>;
// Per invocation of the chunk, the texel's state between steps (see HEADER); big private
// arrays would spill on real GPUs anyway.
@group(0) @binding(3) var<storage, read_write> scratch: array<vec4<f32>>;

// Group 1: the ray-tracing scene (common/rt_scene.wgsl).
// Group 2: directions (bindings 0, 1), mirror tiles (3–5), and what a gather ray reads at its
// hit (common/gather_field.wgsl, binding 6).

fn face_from(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, d: vec4<f32>, e: vec4<f32>) -> BakeFace {
    return BakeFace(
        a.xyz, a.w, b.xyz, b.w,
        c.xyz, bitcast<u32>(c.w), d.xyz, bitcast<u32>(d.w),
        bitcast<u32>(e.x), bitcast<u32>(e.y), e.z, bitcast<u32>(e.w),
    );
}

fn grid_face(f: u32) -> BakeFace {
    let o = 5u * f;
    return face_from(grid[o], grid[o + 1u], grid[o + 2u], grid[o + 3u], grid[o + 4u]);
}

fn field_face(f: u32) -> BakeFace {
    let o = 5u * f;
    return face_from(field[o], field[o + 1u], field[o + 2u], field[o + 3u], field[o + 4u]);
}

fn chart_start(f: u32) -> u32 {
    return bitcast<u32>(grid[gg.chart_start + f].x);
}

// Per invocation of the chunk, gg.scratch_stride entries of `scratch`: the texel's state
// (HEADER entries, see TexelState), its sample points (xyz, from HEADER), its strata order (x
// as bits, from gg.strata_at).
const HEADER: u32 = 4u;
const DRAWS_IN_STRATUM: u32 = 4u;
const DRAWS_IN_TEXEL: u32 = 4u;
// TexelState flags.
const TEST_EACH: u32 = 1u;
// No open point: the texel's estimate is the CPU's None (output a = 0).
const CLOSED: u32 = 2u;
// A step ran out of llvmpipe's loop budget (see the header): the estimate is wrong (a = 2).
const CUT: u32 = 4u;

// What a texel carries from one step to the next.
struct TexelState {
    rng: Rng,
    npts: u32,
    flags: u32,
    // The lit side's unit normal.
    n: vec3<f32>,
    // The estimate so far, and the delta lights' sum over points (direct).
    sum: vec3<f32>,
    sun: vec3<f32>,
}

// This invocation's first scratch entry.
var<private> scratch_base: u32;

fn load_state() -> TexelState {
    let a = bitcast<vec4<u32>>(scratch[scratch_base]);
    let n = scratch[scratch_base + 1u].xyz;
    let sum = scratch[scratch_base + 2u].xyz;
    let sun = scratch[scratch_base + 3u].xyz;
    return TexelState(Rng(a.x, a.y), a.z, a.w, n, sum, sun);
}

fn save_state(s: TexelState) {
    let a = vec4<u32>(s.rng.state, s.rng.inc, s.npts, s.flags);
    scratch[scratch_base] = bitcast<vec4<f32>>(a);
    scratch[scratch_base + 1u] = vec4<f32>(s.n, 0.0);
    scratch[scratch_base + 2u] = vec4<f32>(s.sum, 0.0);
    scratch[scratch_base + 3u] = vec4<f32>(s.sun, 0.0);
}

// Whether this invocation's loops still run in full: a loop of gg.sentinel (= 2, a uniform so
// that it cannot be unrolled) trips. llvmpipe ends every loop after one trip once the
// invocation's budget is spent, so this runs once then.
fn loops_intact() -> bool {
    var trips = 0u;
    for (var i = 0u; i < gg.sentinel; i++) {
        trips++;
    }
    return trips == gg.sentinel;
}

// Ends a step: marks the texel CUT if the step's loops were cut short, and keeps its state.
fn end_step(s: ptr<function, TexelState>) {
    if !loops_intact() {
        (*s).flags |= CUT;
    }
    save_state(*s);
}

fn point(k: u32) -> vec3<f32> {
    return scratch[scratch_base + HEADER + k].xyz;
}

// The chart triangle (index into the grid's chart triangles) point k lies on, or NONE.
fn point_triangle(k: u32) -> u32 {
    return bitcast<u32>(scratch[scratch_base + HEADER + k].w);
}

fn set_point(k: u32, p: vec3<f32>, tri: u32) {
    scratch[scratch_base + HEADER + k] = vec4<f32>(p, bitcast<f32>(tri));
}

fn order_at(k: u32) -> u32 {
    return bitcast<u32>(scratch[scratch_base + gg.strata_at + k].x);
}

fn set_order(k: u32, v: u32) {
    scratch[scratch_base + gg.strata_at + k] = vec4<f32>(bitcast<f32>(v), 0.0, 0.0, 0.0);
}

fn to_world_point(q: vec3<f32>) -> vec3<f32> {
    return q / gg.xf_scale + gg.xf_center;
}

fn to_vlf_point(p: vec3<f32>) -> vec3<f32> {
    return (p - gg.xf_center) * gg.xf_scale;
}

// The first chart triangle (index into the grid's chart triangles) of grid face `fi` holding
// chart point c (texel units), or NONE when none does or when its alpha mask leaves no surface
// there (Charts::locate: the first triangle that holds it decides).
fn chart_locate(fi: u32, c: vec2<f32>) -> u32 {
    for (var t = chart_start(fi); t < chart_start(fi + 1u); t++) {
        let a = grid[gg.chart_tris + 2u * t];
        let q0 = a.xy;
        let q1 = a.zw;
        let b = grid[gg.chart_tris + 2u * t + 1u];
        let q2 = b.xy;
        let e0 = q1 - q0;
        let e1 = q2 - q1;
        let e2 = q0 - q2;
        let d0 = e0.x * (c - q0).y - e0.y * (c - q0).x;
        let d1 = e1.x * (c - q1).y - e1.y * (c - q1).x;
        let d2 = e2.x * (c - q2).y - e2.y * (c - q2).x;
        if (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0) {
            let sum = d0 + d1 + d2;
            if alpha_masks[0] == 0u || sum == 0.0 {
                return t;
            }
            if alpha_cuts(bitcast<u32>(b.w), vec3<f32>(d1 / sum, d2 / sum, d0 / sum)) {
                return NONE;
            }
            return t;
        }
    }
    return NONE;
}

// Whether chart point c (texel units) of grid face `fi` lies on one of its triangles.
fn chart_inside(fi: u32, c: vec2<f32>) -> bool {
    return chart_locate(fi, c) != NONE;
}

// The unit shading normal of point k of the texel (grid face `fi`, lit side's geometric
// normal n): its chart triangle's corner normals interpolated at the point's chart position and
// renormalised, turned to n's side; n itself on a flat triangle (Charts::shading_normal).
fn point_normal(k: u32, fi: u32, n: vec3<f32>) -> vec3<f32> {
    let t = point_triangle(k);
    if t == NONE {
        return n;
    }
    let b = grid[gg.chart_tris + 2u * t + 1u];
    let o = bitcast<u32>(b.z);
    if o == NONE {
        return n;
    }
    let a = grid[gg.chart_tris + 2u * t];
    let f = grid_face(fi);
    let d = to_vlf_point(point(k)) - f.origin;
    let c = vec2<f32>(dot(d, f.u), dot(d, f.v)) / f.texel_size;
    let e1 = a.zw - a.xy;
    let e2 = b.xy - a.xy;
    let det = e1.x * e2.y - e1.y * e2.x;
    var b1 = 0.0;
    var b2 = 0.0;
    if det != 0.0 {
        let q = c - a.xy;
        b1 = (q.x * e2.y - q.y * e2.x) / det;
        b2 = (e1.x * q.y - e1.y * q.x) / det;
    }
    let at = gg.chart_normals + o;
    let s = grid[at].xyz * (1.0 - b1 - b2) + grid[at + 1u].xyz * b1 + grid[at + 2u].xyz * b2;
    let len = length(s);
    if !(len > 0.0) {
        return n;
    }
    let m = s / len;
    return select(m, -m, dot(m, n) < 0.0);
}

// Whether direction `dir` lies below the geometric surface (unit normal n of the lit side)
// for a point whose shading normal `ns` is its own (vlf_core::gather::below).
fn below(ns: vec3<f32>, n: vec3<f32>, dir: vec3<f32>) -> bool {
    return any(ns != n) && dot(dir, n) <= 0.0;
}

// World point of chart point c of grid face `fi`.
fn chart_world(fi: u32, c: vec2<f32>) -> vec3<f32> {
    let f = grid_face(fi);
    let p = f.origin + f.u * (c.x * f.texel_size) + f.v * (c.y * f.texel_size);
    return to_world_point(p);
}

fn tri_normal_raw(t: RtTriangle) -> vec3<f32> {
    return cross(t.p1 - t.p0, t.p2 - t.p0);
}

// Openness::closes: whether anything but a pane lies within gg.r_close of `origin` along n (a
// pane passes light, so a gap under one is lit).
fn closes(origin: vec3<f32>, n: vec3<f32>) -> bool {
    if scene_info.has_panes == 0u {
        return trace(Ray(origin, 0.0, n, gg.r_close), true).tri != NONE;
    }
    var start = origin;
    var left = gg.r_close;
    for (var i = 0u; i < MAX_PANES; i++) {
        let hit = trace(Ray(start, 0.0, n, left), false);
        if hit.tri == NONE {
            return false;
        }
        let tri = triangles[hit.tri];
        if (material(tri.material).openness & MAT_PANE) == 0u {
            return true;
        }
        let q = tri.p0 * (1.0 - hit.u - hit.v) + tri.p1 * hit.u + tri.p2 * hit.v;
        let ng = tri_normal_raw(tri);
        start = offset_origin(q, select(-normalize(ng), normalize(ng), dot(ng, n) > 0.0));
        left -= hit.t;
    }
    return true;
}

// Openness::is_open: point p of a surface whose lit side has unit normal n.
fn is_open(p: vec3<f32>, n: vec3<f32>) -> bool {
    let origin = offset_origin(p, n);
    if closes(origin, n) {
        return false;
    }
    let t = basis_t(n);
    let b = basis_b(n);
    var dirs = array<vec3<f32>, 3>(
        n,
        normalize(n * 0.5 + t * 0.8660254),
        normalize(n * 0.5 + (-t * 0.5 + b * 0.8660254) * 0.8660254),
    );
    // A majority of the three (points.rs says why).
    var open = 0u;
    for (var k = 0u; k < 3u; k++) {
        let d = dirs[k];
        let hit = trace(Ray(origin, 0.0, d, FAR), false);
        var front = hit.tri == NONE;
        if !front {
            // A pane or a see-through wall passes light: it counts as open.
            let tri = triangles[hit.tri];
            front = material(tri.material).openness != 0u || dot(tri_normal_raw(tri), d) <= 0.0;
        }
        if front {
            open++;
        }
        if open == 2u || open + 1u == k {
            break;
        }
    }
    return open >= 2u;
}

// TexelPoints::classify: 1 = all probes open, 0 = all closed, 2 = they disagree.
fn classify(fi: u32, corner: vec2<f32>, n: vec3<f32>) -> u32 {
    var open = 0u;
    var closed = 0u;
    var probes = array<vec2<f32>, 5>(
        vec2<f32>(0.5, 0.5),
        vec2<f32>(0.1, 0.1),
        vec2<f32>(0.9, 0.1),
        vec2<f32>(0.1, 0.9),
        vec2<f32>(0.9, 0.9),
    );
    for (var k = 0u; k < 5u; k++) {
        let c = corner + probes[k];
        if chart_inside(fi, c) {
            if is_open(chart_world(fi, c), n) {
                open++;
            } else {
                closed++;
            }
        }
    }
    if closed == 0u {
        return 1u;
    }
    if open == 0u {
        return 0u;
    }
    return 2u;
}

// Texel t of the grid: its face, side and chart corner (TexelPoints::locate).
struct TexelAt {
    fi: u32,
    side: u32,
    corner: vec2<f32>,
}

fn locate(t: u32) -> TexelAt {
    let fi = bitcast<u32>(grid[gg.grid_texels + 2u * t + 1u].x);
    let f = grid_face(fi);
    let local = t - f.texel_base;
    let tps = f.width * f.height;
    let i = local % tps;
    return TexelAt(fi, local / tps, vec2<f32>(f32(i % f.width), f32(i / f.width)));
}

// shuffled_strata: a g × g grid of strata in a random order (into `order`).
fn shuffle_strata(g: u32, r: ptr<function, Rng>) {
    let len = g * g;
    for (var i = 0u; i < len; i++) {
        set_order(i, i);
    }
    for (var i = len - 1u; i >= 1u; i--) {
        let j = rng_next(r) % (i + 1u);
        let tmp = order_at(i);
        set_order(i, order_at(j));
        set_order(j, tmp);
    }
}

// Strata::point: a jittered point of the stratum paired with sample k.
fn strata_point(k: u32, g: u32, r: ptr<function, Rng>) -> vec2<f32> {
    let s = order_at(k % (g * g));
    let j = rng_2d(r);
    return vec2<f32>(f32(s % g) + j.x, f32(s / g) + j.y) / f32(g);
}

// gather::spread_point: the point that sample k of n starts from when the texel has len points:
// k % len when n >= len, else a random one of the k-th of n equal runs of the (stratum-ordered)
// points, one draw.
fn spread_point(k: u32, n: u32, len: u32, r: ptr<function, Rng>) -> u32 {
    if n >= len {
        return k % len;
    }
    let j = rng_next(r) % len;
    return (k * len + j) / n;
}

// Radiance arriving along dir from the first hit (emission excluded): Gatherer::field_radiance.
fn field_radiance(dir: vec3<f32>, hit: Hit) -> vec3<f32> {
    let tri = triangles[hit.tri];
    let face = tri_face(hit.tri);
    let pw = tri.p0 * (1.0 - hit.u - hit.v) + tri.p1 * hit.u + tri.p2 * hit.v;
    let p = to_vlf_point(pw);
    let f = field_face(face);
    let side = select(1u, 0u, dot(f.normal, -dir) >= 0.0);
    let m = material(tri.material);
    let uv = tri_uv_set(hit.tri, m.texcoords & 1u, hit.u, hit.v);
    let rho = m.base_color * m.bake_diffuse * sample_texture(m.base_texture, uv)
        * tri_color(hit.tri, hit.u, hit.v);
    var l = vec3<f32>(0.0);
    // Field::diffuse: no read (and no visibility rays) where the albedo is zero.
    if any(rho != vec3<f32>(0.0)) {
        let at = FieldSections(gg.field_irradiance, gg.field_contacts, gg.xf_scale, gg.xf_center);
        l = rho * INV_PI * field_irradiance_at(at, f, side, p, pw);
    }
    if gg.has_tiles != 0u {
        let mf = tile_face_slot(face);
        if mf != NO_TILE_SLOT {
            let lk = direction_lookup(dir);
            l += tile_radiance(mf, f.normal, p, -dir, lk.vertices, lk.weights);
        }
    }
    return l;
}

// The texel of this invocation (NONE past the chunk); sets scratch_base.
fn chunk_texel(inv: Invocation) -> u32 {
    let i = invocation_index(inv);
    if i >= gg.texel_count {
        return NONE;
    }
    scratch_base = i * gg.scratch_stride;
    return gg.texel_base + i;
}

// The texel of a step that works on open texels, with its state in *s: NONE past the chunk or
// when the texel is CLOSED (the step has nothing to do).
fn open_texel(inv: Invocation, s: ptr<function, TexelState>) -> u32 {
    let t = chunk_texel(inv);
    if t == NONE {
        return NONE;
    }
    *s = load_state();
    if ((*s).flags & CLOSED) != 0u {
        return NONE;
    }
    return t;
}

// ---------------------------------------------------------------------------------------------
// Sample points (TexelPoints::sample), shared by both estimators.

// Starts texel t: its random stream, lit side and class (TexelPoints::classify: enclosed
// texels are CLOSED, those whose probes disagree test each point).
@compute @workgroup_size(64)
fn begin(inv: Invocation) {
    let t = chunk_texel(inv);
    if t == NONE {
        return;
    }
    let at = locate(t);
    let f = grid_face(at.fi);
    let n = select(-f.normal, f.normal, at.side == 0u);
    let z = vec3<f32>(0.0);
    var s = TexelState(rng_for_path(gg.seed, t, gg.stream), 0u, 0u, n, z, z);
    if grid[gg.grid_texels + 2u * t].w <= 0.0 || gg.points == 0u {
        s.flags = CLOSED;
    } else {
        let cls = classify(at.fi, at.corner, n);
        if cls == 0u {
            s.flags = CLOSED;
        } else if cls == 2u {
            s.flags = TEST_EACH;
        }
    }
    end_step(&s);
}

// Points gg.k0 .. gg.k1 of gg.points: each drawn in its stratum, then anywhere in the texel,
// until one lands on the face where it is open.
@compute @workgroup_size(64)
fn draw_points(inv: Invocation) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    var rng = s.rng;
    let at = locate(t);
    let test_each = (s.flags & TEST_EACH) != 0u;
    let g = gg.points_side;
    let inv_g = 1.0 / f32(g);
    for (var k = gg.k0; k < min(gg.k1, gg.points); k++) {
        let st = vec2<f32>(f32(k % g), f32(k / g % g));
        var found = false;
        for (var draw = 0u; draw < DRAWS_IN_STRATUM + DRAWS_IN_TEXEL; draw++) {
            if !found {
                let j = rng_2d(&rng);
                var c = at.corner + j;
                if draw < DRAWS_IN_STRATUM {
                    c = at.corner + (st + j) * inv_g;
                }
                let tri = chart_locate(at.fi, c);
                if tri != NONE {
                    let p = chart_world(at.fi, c);
                    if !test_each || is_open(p, s.n) {
                        set_point(s.npts, p, tri);
                        s.npts++;
                        found = true;
                    }
                }
            }
        }
    }
    s.rng = rng;
    end_step(&s);
}

// After the draws: a texel no draw found falls back to its covered part's centroid (or is
// CLOSED); then the strata of side gg.side are shuffled for the first rays.
@compute @workgroup_size(64)
fn finish_points(inv: Invocation) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    var rng = s.rng;
    if s.npts == 0u {
        // A sliver of the face that no draw found: its covered part's centroid.
        let q = grid[gg.grid_texels + 2u * t].xyz;
        let p = to_world_point(q);
        if (s.flags & TEST_EACH) == 0u || is_open(p, s.n) {
            let at = locate(t);
            let f = grid_face(at.fi);
            let d = q - f.origin;
            let c = vec2<f32>(dot(d, f.u), dot(d, f.v)) / f.texel_size;
            set_point(0u, p, chart_locate(at.fi, c));
            s.npts = 1u;
        }
    }
    if s.npts == 0u {
        s.flags |= CLOSED;
    } else {
        shuffle_strata(gg.side, &rng);
    }
    s.rng = rng;
    end_step(&s);
}

// Shuffles the strata of side gg.side (the direct estimator's cosine rays).
@compute @workgroup_size(64)
fn shuffle(inv: Invocation) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    var rng = s.rng;
    shuffle_strata(gg.side, &rng);
    s.rng = rng;
    end_step(&s);
}

// The estimate of texel t: rgb, a = 1; a = 0 without an open point; a = 2 when a step was cut.
fn write_estimate(t: u32, s: TexelState, e: vec3<f32>) {
    var a = 1.0;
    var v = e;
    if (s.flags & CLOSED) != 0u {
        a = 0.0;
        v = vec3<f32>(0.0);
    }
    if (s.flags & CUT) != 0u {
        a = 2.0;
    }
    gather_out[t] = vec4<f32>(v, a);
}

// ---------------------------------------------------------------------------------------------
// Indirect estimator (Gatherer::indirect): one cosine ray per point.

// Rays gg.k0 .. gg.k1 (of the texel's points).
@compute @workgroup_size(64)
fn indirect_rays(inv: Invocation) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    var rng = s.rng;
    var sum = s.sum;
    let n = s.n;
    let fi = locate(t).fi;
    let k1 = min(gg.k1, s.npts);
    for (var k = gg.k0; k < k1; k++) {
        let u = strata_point(k, gg.cosine_side, &rng);
        let ns = point_normal(k, fi, n);
        let dir = to_world(cosine_hemisphere(u), ns);
        if below(ns, n, dir) {
            continue;
        }
        // Through panes: each sends back what it reflects, then the field behind them
        // (Gatherer::gather_ray over through::trace).
        var ray = Ray(offset_origin(point(k), n), 0.0, dir, FAR);
        var throughput = vec3<f32>(1.0);
        var l = vec3<f32>(0.0);
        for (var i = 0u; i < MAX_PANES; i++) {
            let hit = trace(ray, false);
            if hit.tri == NONE {
                break;
            }
            let passed = pane_pass(hit, dir, 0u);
            l += throughput * field_radiance(dir, hit);
            if passed.w == 0.0 {
                break;
            }
            throughput *= passed.xyz;
            ray = Ray(pane_beyond(hit, dir), 0.0, dir, FAR);
        }
        sum += l;
    }
    s.rng = rng;
    s.sum = sum;
    end_step(&s);
}

@compute @workgroup_size(64)
fn indirect_end(inv: Invocation) {
    let t = chunk_texel(inv);
    if t == NONE {
        return;
    }
    let s = load_state();
    write_estimate(t, s, s.sum * (PI / f32(max(s.npts, 1u))));
}

// ---------------------------------------------------------------------------------------------
// Direct estimator (Gatherer::direct): light samples and cosine rays combined with the power
// heuristic, the sky by the cosine rays, suns, point and spot lights by shadow rays.

// One sample of the direct estimator: the texel's point it starts from (picked at random among
// them, gather::spread_point), that point's shading normal, and the sample's jittered stratum.
struct DirectSample {
    p: vec3<f32>,
    ns: vec3<f32>,
    u: vec2<f32>,
}

// Light sample k (stratified over the emitters' sample space, paired at random with the point
// strata), added to (*s).sum.
fn light_sample(ds: DirectSample, s: ptr<function, TexelState>) {
    let n = (*s).n;
    let fl = f32(gg.light_samples);
    let fb = f32(gg.cosine_rays);
    let pe = pick_emitter_remapped(ds.u);
    let e = blob[scene_info.emitter_base + pe.index];
    let et = bitcast<u32>(e.x);
    let lt = triangles[et];
    let bary = triangle_barycentrics(pe.u);
    let x = lt.p0 * (1.0 - bary.x - bary.y) + lt.p1 * bary.x + lt.p2 * bary.y;
    let nl = normalize(tri_normal_raw(lt));
    let to = x - ds.p;
    let d2 = dot(to, to);
    let wi = to / sqrt(d2);
    let cos_r = dot(ds.ns, wi);
    let cos_l = -dot(wi, nl);
    if cos_r <= 0.0 || cos_l <= 0.0 || below(ds.ns, n, wi) {
        return;
    }
    let pdf_l = e.z / e.y * d2 / cos_l;
    let pdf_b = cos_r * INV_PI;
    let w = power_heuristic(fl * pdf_l, fb * pdf_b);
    let origin = offset_origin(ds.p, n);
    let aim = offset_origin(x, nl);
    if w > 0.0 {
        // Through panes, attenuated.
        let passed = segment_transmittance(origin, aim - origin, 0u);
        if any(passed != vec3<f32>(0.0)) {
            let le = emission_at(et, bary.x, bary.y);
            (*s).sum += le * (w * cos_r / (pdf_l * fl)) * passed;
        }
    }
}

// Cosine ray k: the sky, and emitters weighted against the light samples, added to (*s).sum.
fn cosine_ray(ds: DirectSample, s: ptr<function, TexelState>) {
    let n = (*s).n;
    let fl = f32(gg.light_samples);
    let fb = f32(gg.cosine_rays);
    let dir = to_world(cosine_hemisphere(ds.u), ds.ns);
    if below(ds.ns, n, dir) {
        return;
    }
    // Through panes, attenuated (hit.t the whole distance, for the light samples' pdf).
    let traced = trace_through_panes(offset_origin(ds.p, n), dir);
    let hit = traced.hit;
    if hit.tri == NONE {
        (*s).sum += gg.sky.xyz * (PI / fb) * traced.throughput;
        return;
    }
    let ht = triangles[hit.tri];
    if ht.light == NONE {
        return;
    }
    let cos_l = -dot(dir, normalize(tri_normal_raw(ht)));
    if cos_l <= 0.0 {
        return;
    }
    let pdf_b = dot(ds.ns, dir) * INV_PI;
    let pdf_l = emitter_pdf(ht.light, hit.t, cos_l) / scene_info.p_emitters;
    let w = power_heuristic(fb * pdf_b, fl * pdf_l);
    let le = emission_at(hit.tri, hit.u, hit.v);
    (*s).sum += le * (w * PI / fb) * traced.throughput;
}

// Samples gg.k0 .. gg.k1 of `count` (strata of side `side`): light samples when `lights`, else
// cosine rays. Each draws its point, then its stratum's jitter, in the CPU's order.
fn direct_samples(inv: Invocation, count: u32, side: u32, lights: bool) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    var rng = s.rng;
    let fi = locate(t).fi;
    for (var k = gg.k0; k < min(gg.k1, count); k++) {
        let kp = spread_point(k, count, s.npts, &rng);
        let p = point(kp);
        let ns = point_normal(kp, fi, s.n);
        let u = strata_point(k, side, &rng);
        if lights {
            light_sample(DirectSample(p, ns, u), &s);
        } else {
            cosine_ray(DirectSample(p, ns, u), &s);
        }
    }
    s.rng = rng;
    end_step(&s);
}

// Light samples gg.k0 .. gg.k1 of gg.light_samples.
@compute @workgroup_size(64)
fn light_samples(inv: Invocation) {
    direct_samples(inv, gg.light_samples, gg.light_side, true);
}

// Cosine rays gg.k0 .. gg.k1 of gg.cosine_rays.
@compute @workgroup_size(64)
fn cosine_rays(inv: Invocation) {
    direct_samples(inv, gg.cosine_rays, gg.cosine_side, false);
}

// Delta lights (suns, point and spot lights): one shadow ray per point and light, points
// gg.k0 .. gg.k1.
@compute @workgroup_size(64)
fn delta_rays(inv: Invocation) {
    var s: TexelState;
    let t = open_texel(inv, &s);
    if t == NONE {
        return;
    }
    let fi = locate(t).fi;
    for (var k = gg.k0; k < min(gg.k1, s.npts); k++) {
        let p = point(k);
        let origin = offset_origin(p, s.n);
        let ns = point_normal(k, fi, s.n);
        for (var i = 0u; i < scene_info.delta_count; i++) {
            let inc = delta_incident(i, p);
            let c = dot(ns, inc.wi);
            if c > 0.0 && !below(ns, s.n, inc.wi) {
                // Through panes, attenuated.
                let passed = shadow_transmittance(delta_shadow_ray(i, origin, inc), 0u);
                if any(passed != vec3<f32>(0.0)) {
                    s.sun += inc.irradiance * c * passed;
                }
            }
        }
    }
    end_step(&s);
}

@compute @workgroup_size(64)
fn direct_end(inv: Invocation) {
    let t = chunk_texel(inv);
    if t == NONE {
        return;
    }
    let s = load_state();
    var sum = s.sum;
    if scene_info.delta_count > 0u && s.npts > 0u {
        sum += s.sun / f32(s.npts);
    }
    write_estimate(t, s, sum);
}
