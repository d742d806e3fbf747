// The final gather's texel estimators on the GPU (vlf_gpu::gather; specification:
// vlf_core::gather, whose `indirect` and `direct` these mirror draw for draw): one invocation per
// texel of a chunk of one grid. Each texel draws its own stream (Rng::for_path(SEED, texel,
// stream)) in the CPU's order: the texel's stratified open sample points (gather/points.rs),
// then the shuffled strata and jitter of its rays; rays are traced inline through the ray
// engine's BVH (common/bvh.wgsl). Output per texel: the estimate (rgb) and a = 1, or a = 0 when
// the texel has no open point (the CPU's None).
//
// * `indirect`: cosine rays read the converged light field at their first hit: the
//   propagation's (dilated) irradiance times the hit point's albedo / π, plus the mirror tiles
//   in the ray's direction (common/mirror_tiles.wgsl, common/directions.wgsl).
// * `direct`: light samples over the emitters and cosine rays combined with the power heuristic,
//   the sky by the cosine rays, suns by shadow rays.

#import "common/rt_scene.wgsl"
#import "common/random.wgsl"
#import "common/sampling.wgsl"
#import "common/bake_scene.wgsl"
#import "common/directions.wgsl"
#import "common/mirror_tiles.wgsl"

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
}

@group(0) @binding(0) var<uniform> gg: GatherGlobals;
// The grid being gathered, in sections (vec4 each; offsets in gg): its faces (5 entries per
// BakeFace, at 0), per texel its covered part's centroid (VLF xyz) and area (w) then its face
// (x, as bits) (at grid_texels), per face the start of its chart triangles (x, as bits; faces +
// 1 entries, at chart_start), and the chart-space triangles, two entries each: (p0, p1),
// (p2, 0, 0) (at chart_tris). One buffer, to keep within 8 storage buffers per stage.
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;
// The estimate per texel of the grid (rgb; a = 1 where the texel has an open point).
@group(0) @binding(2) var<storage, read_write> gather_out: array<vec4<f32>>;
// Per invocation of the chunk, SCRATCH entries: its sample points (xyz, MAX_POINTS entries),
// then its strata order (x as bits, MAX_STRATA entries); big private arrays spill on real GPUs
// anyway.
@group(0) @binding(3) var<storage, read_write> scratch: array<vec4<f32>>;

// Group 1: the ray-tracing scene (common/rt_scene.wgsl).
// Group 2: directions (bindings 0, 1), mirror tiles (3–5), and what a gather ray reads at its
// hit: the propagation's faces (5 entries per BakeFace, at 0) and dilated irradiance (at
// gg.field_irradiance) in one buffer.
@group(2) @binding(6) var<storage, read> field: array<vec4<f32>>;

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

// Bounds of the per-texel arrays (checked by vlf_gpu::gather before dispatching).
const MAX_POINTS: u32 = 256u;
const MAX_STRATA: u32 = 256u;
const DRAWS_IN_STRATUM: u32 = 4u;
const DRAWS_IN_TEXEL: u32 = 4u;

const SCRATCH: u32 = MAX_POINTS + MAX_STRATA;

var<private> npts: u32;
// This invocation's first scratch entry.
var<private> scratch_base: u32;

fn point(k: u32) -> vec3<f32> {
    return scratch[scratch_base + k].xyz;
}

fn set_point(k: u32, p: vec3<f32>) {
    scratch[scratch_base + k] = vec4<f32>(p, 0.0);
}

fn order_at(k: u32) -> u32 {
    return bitcast<u32>(scratch[scratch_base + MAX_POINTS + k].x);
}

fn set_order(k: u32, v: u32) {
    scratch[scratch_base + MAX_POINTS + k] = vec4<f32>(bitcast<f32>(v), 0.0, 0.0, 0.0);
}

fn to_world_point(q: vec3<f32>) -> vec3<f32> {
    return q / gg.xf_scale + gg.xf_center;
}

fn to_vlf_point(p: vec3<f32>) -> vec3<f32> {
    return (p - gg.xf_center) * gg.xf_scale;
}

// Whether chart point c (texel units) of grid face `fi` lies on one of its triangles.
fn chart_inside(fi: u32, c: vec2<f32>) -> bool {
    for (var t = chart_start(fi); t < chart_start(fi + 1u); t++) {
        let a = grid[gg.chart_tris + 2u * t];
        let q0 = a.xy;
        let q1 = a.zw;
        let q2 = grid[gg.chart_tris + 2u * t + 1u].xy;
        let e0 = q1 - q0;
        let e1 = q2 - q1;
        let e2 = q0 - q2;
        let d0 = e0.x * (c - q0).y - e0.y * (c - q0).x;
        let d1 = e1.x * (c - q1).y - e1.y * (c - q1).x;
        let d2 = e2.x * (c - q2).y - e2.y * (c - q2).x;
        if (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0) {
            return true;
        }
    }
    return false;
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

// Openness::is_open: point p of a surface whose lit side has unit normal n.
fn is_open(p: vec3<f32>, n: vec3<f32>) -> bool {
    let origin = offset_origin(p, n);
    if trace(Ray(origin, 0.0, n, gg.r_close), true).tri != NONE {
        return false;
    }
    let t = basis_t(n);
    let b = basis_b(n);
    var dirs = array<vec3<f32>, 3>(
        n,
        normalize(n * 0.5 + t * 0.8660254),
        normalize(n * 0.5 + (-t * 0.5 + b * 0.8660254) * 0.8660254),
    );
    for (var k = 0u; k < 3u; k++) {
        let d = dirs[k];
        let hit = trace(Ray(origin, 0.0, d, FAR), false);
        if hit.tri == NONE {
            return true;
        }
        if dot(tri_normal_raw(triangles[hit.tri]), d) <= 0.0 {
            return true;
        }
    }
    return false;
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

// TexelPoints::sample: up to gg.points stratified open points of texel t into `pts`; returns
// the lit side's unit normal.
fn sample_points(t: u32, r: ptr<function, Rng>) -> vec3<f32> {
    npts = 0u;
    let texel = grid[gg.grid_texels + 2u * t];
    let fi = bitcast<u32>(grid[gg.grid_texels + 2u * t + 1u].x);
    let f = grid_face(fi);
    let local = t - f.texel_base;
    let tps = f.width * f.height;
    let side = local / tps;
    let i = local % tps;
    let corner = vec2<f32>(f32(i % f.width), f32(i / f.width));
    let n = select(-f.normal, f.normal, side == 0u);
    if texel.w <= 0.0 || gg.points == 0u {
        return n;
    }
    let cls = classify(fi, corner, n);
    if cls == 0u {
        return n;
    }
    let test_each = cls == 2u;
    let g = gg.points_side;
    let inv = 1.0 / f32(g);
    for (var k = 0u; k < gg.points; k++) {
        let s = vec2<f32>(f32(k % g), f32(k / g % g));
        // Draws until one lands on the face where it is open.
        var found = false;
        for (var draw = 0u; draw < DRAWS_IN_STRATUM + DRAWS_IN_TEXEL; draw++) {
            if !found {
                let j = rng_2d(r);
                var c = corner + j;
                if draw < DRAWS_IN_STRATUM {
                    c = corner + (s + j) * inv;
                }
                if chart_inside(fi, c) {
                    let p = chart_world(fi, c);
                    if !test_each || is_open(p, n) {
                        set_point(npts, p);
                        npts++;
                        found = true;
                    }
                }
            }
        }
    }
    if npts == 0u {
        // A sliver of the face that no draw found: its covered part's centroid.
        let p = to_world_point(texel.xyz);
        if !test_each || is_open(p, n) {
            set_point(0u, p);
            npts = 1u;
        }
    }
    return n;
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

// A per-texel quantity of propagation face f on `side` read bilinearly at plane point p, texel
// indices clamped to the chart (vlf_core::gather::field::chart_bilinear).
fn field_bilinear(f: BakeFace, side: u32, p: vec3<f32>) -> vec3<f32> {
    let d = p - f.origin;
    let c = vec2<f32>(dot(d, f.u), dot(d, f.v)) / f.texel_size - vec2<f32>(0.5);
    let x0 = floor(c.x);
    let y0 = floor(c.y);
    let fx = c.x - x0;
    let fy = c.y - y0;
    let wi = i32(f.width) - 1;
    let hi = i32(f.height) - 1;
    let i0 = u32(clamp(i32(x0), 0, wi));
    let i1 = u32(clamp(i32(x0 + 1.0), 0, wi));
    let j0 = u32(clamp(i32(y0), 0, hi));
    let j1 = u32(clamp(i32(y0 + 1.0), 0, hi));
    let base = f.texel_base + side * f.width * f.height;
    let e = gg.field_irradiance + base;
    let top = mix(field[e + j0 * f.width + i0].xyz, field[e + j0 * f.width + i1].xyz, fx);
    let bottom = mix(field[e + j1 * f.width + i0].xyz, field[e + j1 * f.width + i1].xyz, fx);
    return mix(top, bottom, fy);
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
    let rho = m.base_color * m.bake_diffuse * sample_texture(m.base_texture, tri_uv(hit.tri, hit.u, hit.v));
    var l = rho * INV_PI * field_bilinear(f, side, p);
    if gg.has_tiles != 0u {
        let mf = tile_face_slot(face);
        if mf != NO_TILE_SLOT {
            let lk = direction_lookup(dir);
            l += tile_radiance(mf, f.normal, p, -dir, lk.vertices, lk.weights);
        }
    }
    return l;
}

fn chunk_texel(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    let i = invocation_index(wid, nwg, lid);
    if i >= gg.texel_count {
        return NONE;
    }
    scratch_base = i * SCRATCH;
    return gg.texel_base + i;
}

@compute @workgroup_size(64)
fn indirect(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = chunk_texel(wid, nwg, lid);
    if t == NONE {
        return;
    }
    var r = rng_for_path(gg.seed, t, gg.stream);
    let n = sample_points(t, &r);
    if npts == 0u {
        gather_out[t] = vec4<f32>(0.0);
        return;
    }
    shuffle_strata(gg.cosine_side, &r);
    var sum = vec3<f32>(0.0);
    let count = npts;
    for (var k = 0u; k < gg.cosine_rays; k++) {
        if k < count {
            let u = strata_point(k, gg.cosine_side, &r);
            let dir = to_world(cosine_hemisphere(u), n);
            let hit = trace(Ray(offset_origin(point(k), n), 0.0, dir, FAR), false);
            if hit.tri != NONE {
                sum += field_radiance(dir, hit);
            }
        }
    }
    gather_out[t] = vec4<f32>(sum * (PI / f32(npts)), 1.0);
}

@compute @workgroup_size(64)
fn direct(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = chunk_texel(wid, nwg, lid);
    if t == NONE {
        return;
    }
    var r = rng_for_path(gg.seed, t, gg.stream);
    let n = sample_points(t, &r);
    if npts == 0u {
        gather_out[t] = vec4<f32>(0.0);
        return;
    }
    let n_l = gg.light_samples;
    let n_b = gg.cosine_rays;
    let fl = f32(n_l);
    let fb = f32(n_b);
    var sum = vec3<f32>(0.0);
    // Light samples.
    shuffle_strata(gg.light_side, &r);
    for (var k = 0u; k < n_l; k++) {
        let p = point(k % npts);
        let u = strata_point(k, gg.light_side, &r);
        let pe = pick_emitter_remapped(u);
        let e = blob[scene_info.emitter_base + pe.index];
        let et = bitcast<u32>(e.x);
        let lt = triangles[et];
        let bary = triangle_barycentrics(pe.u);
        let x = lt.p0 * (1.0 - bary.x - bary.y) + lt.p1 * bary.x + lt.p2 * bary.y;
        let nl = normalize(tri_normal_raw(lt));
        let to = x - p;
        let d2 = dot(to, to);
        let wi = to / sqrt(d2);
        let cos_r = dot(n, wi);
        let cos_l = -dot(wi, nl);
        if cos_r <= 0.0 || cos_l <= 0.0 {
            continue;
        }
        let pdf_l = e.z / e.y * d2 / cos_l;
        let pdf_b = cos_r * INV_PI;
        let w = power_heuristic(fl * pdf_l, fb * pdf_b);
        let origin = offset_origin(p, n);
        let aim = offset_origin(x, nl);
        if w > 0.0 && trace(Ray(origin, 0.0, aim - origin, 1.0), true).tri == NONE {
            let le = emission_at(et, bary.x, bary.y);
            sum += le * (w * cos_r / (pdf_l * fl));
        }
    }
    // Cosine rays: the sky, and emitters weighted against the light samples.
    shuffle_strata(gg.cosine_side, &r);
    for (var k = 0u; k < n_b; k++) {
        let p = point(k % npts);
        let u = strata_point(k, gg.cosine_side, &r);
        let dir = to_world(cosine_hemisphere(u), n);
        let hit = trace(Ray(offset_origin(p, n), 0.0, dir, FAR), false);
        if hit.tri == NONE {
            sum += gg.sky.xyz * (PI / fb);
            continue;
        }
        let ht = triangles[hit.tri];
        if ht.light == NONE {
            continue;
        }
        let cos_l = -dot(dir, normalize(tri_normal_raw(ht)));
        if cos_l <= 0.0 {
            continue;
        }
        let pdf_b = dot(n, dir) * INV_PI;
        let pdf_l = emitter_pdf(ht.light, hit.t, cos_l) / scene_info.p_emitters;
        let w = power_heuristic(fb * pdf_b, fl * pdf_l);
        let le = emission_at(hit.tri, hit.u, hit.v);
        sum += le * (w * PI / fb);
    }
    // Suns: one shadow ray per point.
    if scene_info.sun_count > 0u {
        var sun = vec3<f32>(0.0);
        for (var k = 0u; k < npts; k++) {
            let origin = offset_origin(point(k), n);
            for (var s = 0u; s < scene_info.sun_count; s++) {
                let a = blob[scene_info.sun_base + 2u * s];
                let b = blob[scene_info.sun_base + 2u * s + 1u];
                let c = dot(n, a.xyz);
                if c > 0.0 && trace(Ray(origin, 0.0, a.xyz, FAR), true).tri == NONE {
                    sun += b.xyz * c;
                }
            }
        }
        sum += sun / f32(npts);
    }
    gather_out[t] = vec4<f32>(sum, 1.0);
}
