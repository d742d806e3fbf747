// GPU reference path tracer: the estimator of vlf_core::pathtrace (same conventions, same random
// streams) as a wavefront over the ray engine of raytrace_engine.wgsl, plus a megakernel variant.
//
// Wavefront, per wave of `path_count` paths (samples_per_wave samples of every pixel, ordered in
// 8x8 pixel tiles so that primary rays are coherent):
//   wave_begin -> generate -> repeat { engine closest_hit -> shade -> engine any_hit (shadow rays)
//   -> resolve -> queue_end } until the queue is empty -> (after all waves) finish.
// Queues: region A = [0, P), B = [P, 2P) of rays/paths ping-pong (shade compacts surviving paths
// into the other region with an atomic counter); region S = [2P, 3P) holds each path's shadow ray
// and its NEE contribution at the path's own index (no compaction, tmax < 0 = no shadow ray).
// Radiance is summed per path slot in `accum` (one path per slot at a time: no atomics needed).

#import "common/rt_scene.wgsl"
#import "common/random.wgsl"
#import "common/sampling.wgsl"
#import "common/pane_trace.wgsl"

// Per-render globals (mirrors vlf_gpu::layout::RtGlobals). Blob offsets are in vec4 units.
struct RtGlobals {
    // xyz eye, w = tan(yfov / 2)
    cam_pos: vec4<f32>,
    // xyz forward, w = aspect (width / height)
    cam_forward: vec4<f32>,
    // xyz right
    cam_right: vec4<f32>,
    // xyz up
    cam_up: vec4<f32>,
    // rgb sky radiance
    sky: vec4<f32>,
    width: u32,
    height: u32,
    seed: u32,
    sample_base: u32,
    samples_per_wave: u32,
    path_count: u32,
    tiles_x: u32,
    max_groups: u32,
    spp: u32,
    rr_depth: u32,
    tile_base: u32,
    tile_count: u32,
}

// Path state (mirrors vlf_gpu::layout::RtPath). In region S: throughput = NEE contribution, and
// depth = SHADOW_THROUGH_PANES when the shadow ray goes on through panes (a delta light's).
// pdf < 0: the last bounce was a delta (or camera) sample.
struct RtPath {
    throughput: vec3<f32>,
    slot: u32,
    rng_state: u32,
    rng_inc: u32,
    depth: u32,
    pdf: f32,
}

@group(0) @binding(0) var<uniform> g: RtGlobals;
@group(0) @binding(1) var<uniform> batch: RtBatch;

// Group 1 (nodes, triangles, shading data, scene info): see common/rt_scene.wgsl.

@group(2) @binding(0) var<storage, read_write> rays: array<Ray>;
@group(2) @binding(1) var<storage, read> hits: array<Hit>;
@group(2) @binding(2) var<storage, read_write> paths: array<RtPath>;
@group(2) @binding(3) var<storage, read_write> queues: array<RtQueue>;
@group(2) @binding(4) var<storage, read_write> accum: array<vec4<f32>>;

// Control (wave_begin, queue_end, finish): queue counts, indirect dispatch arguments and the
// finished chunk of the image. Queue 2 counts the wave's extension rays, queue 3 its shadow rays.
@group(3) @binding(0) var<storage, read_write> ctl_queues: array<RtQueue>;
@group(3) @binding(1) var<storage, read_write> ctl_args: array<vec4<u32>>;
@group(3) @binding(2) var<storage, read_write> image: array<vec4<f32>>;

// Shadow rays counted by one workgroup of `resolve`.
var<workgroup> wg_shadow: atomic<u32>;

const RR_MAX_SURVIVAL: f32 = 0.95;
// A shadow record (region S) whose ray passes panes, attenuated (see RtPath).
const SHADOW_THROUGH_PANES: u32 = 1u;


// ---------------------------------------------------------------------------------------------
// BSDF (mirrors vlf_core::pathtrace::material).

// Non-delta f(wo, wi) in xyz and the BSDF-sampling pdf in w.
fn bsdf_eval(m: Material, color: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec4<f32> {
    let cos_i = dot(n, wi);
    let cos_o = dot(n, wo);
    if cos_i <= 0.0 || cos_o <= 0.0 {
        return vec4<f32>(0.0);
    }
    var f = color * (m.w_diffuse * INV_PI);
    var pdf = m.w_diffuse * cos_i * INV_PI;
    let w_metal = 1.0 - m.w_diffuse - m.w_pane;
    if m.alpha > 0.0 && w_metal > 0.0 {
        let h = normalize(wi + wo);
        let d = ggx_d(max(dot(n, h), 0.0), m.alpha);
        let g1o = ggx_g1(cos_o, m.alpha);
        let g1i = ggx_g1(cos_i, m.alpha);
        f += color * (w_metal * d * g1o * g1i / (4.0 * cos_o * cos_i));
        pdf += w_metal * g1o * d / (4.0 * cos_o);
    }
    return vec4<f32>(f, pdf);
}

struct BsdfSample {
    wi: vec3<f32>,
    weight: vec3<f32>,
    // solid-angle pdf; -1 for the delta lobes (mirror, pane), 0 for no sample
    pdf: f32,
    // Whether it passed through the pane (wi = -wo, on the other side of the surface).
    transmitted: bool,
}

fn bsdf_sample(m: Material, color: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> BsdfSample {
    var wi: vec3<f32>;
    if u_lobe < m.w_diffuse {
        wi = to_world(cosine_hemisphere(u), n);
    } else if u_lobe < m.w_diffuse + m.w_pane {
        // The pane: reflect with probability R(θ), else pass straight through (the lobe's
        // choice probabilities cancel its weights; the transmission is tinted).
        let r = pane_reflectance(dot(n, wo), m.ior);
        if (u_lobe - m.w_diffuse) < m.w_pane * r {
            return BsdfSample(normalize(reflect_about(wo, n)), vec3<f32>(1.0), -1.0, false);
        }
        return BsdfSample(-wo, color, -1.0, true);
    } else if m.alpha == 0.0 {
        return BsdfSample(normalize(reflect_about(wo, n)), color, -1.0, false);
    } else {
        let wo_l = to_local(wo, n);
        let h = ggx_sample_vndf(normalize(wo_l), m.alpha, u);
        wi = normalize(to_world(reflect_about(wo_l, h), n));
    }
    let cos_i = dot(n, wi);
    if cos_i <= 0.0 {
        return BsdfSample(wi, vec3<f32>(0.0), 0.0, false);
    }
    let e = bsdf_eval(m, color, n, wo, wi);
    if e.w <= 0.0 {
        return BsdfSample(wi, vec3<f32>(0.0), 0.0, false);
    }
    return BsdfSample(wi, e.xyz * (cos_i / e.w), e.w, false);
}

// ---------------------------------------------------------------------------------------------
// One path vertex, shared by the wavefront `shade` kernel and the megakernel.

struct Vertex {
    // radiance to add now (emission or sky, throughput applied)
    emitted: vec3<f32>,
    // NEE: shadow ray (tmax < 0: none) and its unoccluded contribution (throughput applied)
    shadow: Ray,
    shadow_contrib: vec3<f32>,
    // Whether the shadow ray goes on through panes, attenuated (a delta light's in a scene
    // with panes: PreparedScene::shadow_transmittance); an emitter's stops at a pane.
    shadow_panes: bool,
    // continuation ray (tmax < 0: the path ends)
    next: Ray,
}

fn no_ray() -> Ray {
    return Ray(vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 0.0, 1.0), -1.0);
}

// Shades the vertex `hit` of path `p` (its random stream kept in the path state).
fn shade_vertex(p: ptr<function, RtPath>, ray: Ray, hit: Hit) -> Vertex {
    var r = Rng((*p).rng_state, (*p).rng_inc);
    let v = shade_with(p, &r, ray, hit);
    (*p).rng_state = r.state;
    (*p).rng_inc = r.inc;
    return v;
}

fn shade_with(p: ptr<function, RtPath>, r: ptr<function, Rng>, ray: Ray, hit: Hit) -> Vertex {
    var out = Vertex(vec3<f32>(0.0), no_ray(), vec3<f32>(0.0), false, no_ray());
    let beta = (*p).throughput;
    if hit.tri == NONE {
        out.emitted = beta * g.sky.xyz;
        return out;
    }
    let tri = triangles[hit.tri];
    let ng = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
    let d = ray.dir;
    let cos_d = dot(d, ng);
    let front = cos_d < 0.0;
    let m = material(tri.material);
    if front && any(m.emission != vec3<f32>(0.0)) {
        let le = emission_at(hit.tri, hit.u, hit.v);
        var w = 1.0;
        if (*p).pdf >= 0.0 {
            w = power_heuristic((*p).pdf, emitter_pdf(tri.light, hit.t, -cos_d));
        }
        out.emitted = beta * le * w;
    }
    // The geometric normal and the shading normal on the side the ray arrived at; rays leave
    // from the geometric surface, and directions below it (own_normal vertices only) bring nothing.
    let nside = select(-ng, ng, front);
    let n = tri_shading_normal(hit.tri, hit.u, hit.v, nside);
    let own_normal = any(n != nside);
    let wo = -d;
    let pos = tri.p0 * (1.0 - hit.u - hit.v) + tri.p1 * hit.u + tri.p2 * hit.v;
    let color = base_color_at(hit.tri, m, hit.u, hit.v);
    let origin = offset_origin(pos, nside);
    // Next-event estimation: one light sample.
    let u_class = rng_f32(r);
    let u_light = rng_f32(r);
    let u_point = rng_2d(r);
    // Only a BSDF with a non-delta part (SurfaceMaterial::has_smooth_part).
    if m.w_diffuse > 0.0 || (m.alpha > 0.0 && 1.0 - m.w_diffuse - m.w_pane > 0.0) {
        if u_class < scene_info.p_emitters {
            let e = blob[scene_info.emitter_base + pick_emitter(u_light)];
            let lt = triangles[bitcast<u32>(e.x)];
            let bary = triangle_barycentrics(u_point);
            let b1 = bary.x;
            let b2 = bary.y;
            let x = lt.p0 * (1.0 - b1 - b2) + lt.p1 * b1 + lt.p2 * b2;
            let nl = normalize(cross(lt.p1 - lt.p0, lt.p2 - lt.p0));
            let to = x - pos;
            let dist2 = dot(to, to);
            let wi = to / sqrt(dist2);
            let cos_l = -dot(wi, nl);
            let cos_s = dot(n, wi);
            if cos_l > 0.0 && cos_s > 0.0 && !(own_normal && dot(wi, nside) <= 0.0) {
                let f = bsdf_eval(m, color, n, wo, wi);
                let pdf_light = scene_info.p_emitters * e.z * dist2 / (e.y * cos_l);
                let le = emission_at(bitcast<u32>(e.x), b1, b2);
                let contrib = beta * f.xyz * le * (cos_s * power_heuristic(pdf_light, f.w) / pdf_light);
                if any(contrib > vec3<f32>(0.0)) {
                    let light_point = offset_origin(x, nl);
                    out.shadow = Ray(origin, 0.0, light_point - origin, 1.0);
                    out.shadow_contrib = contrib;
                }
            }
        } else if scene_info.delta_count > 0u {
            // A delta light (sun, point or spot): no MIS.
            let li = pick_delta(u_light);
            let inc = delta_incident(li, pos);
            let pdf = blob[scene_info.delta_base + 4u * li + 1u].w;
            let cos_i = dot(n, inc.wi);
            if cos_i > 0.0 && !(own_normal && dot(inc.wi, nside) <= 0.0) {
                let f = bsdf_eval(m, color, n, wo, inc.wi);
                let contrib = beta * f.xyz * inc.irradiance * (cos_i / ((1.0 - scene_info.p_emitters) * pdf));
                if any(contrib > vec3<f32>(0.0)) {
                    out.shadow = delta_shadow_ray(li, origin, inc);
                    out.shadow_contrib = contrib;
                    // A delta light reaches through panes (no path could find it otherwise:
                    // a delta light behind a delta transmission).
                    out.shadow_panes = scene_info.has_panes != 0u;
                }
            }
        }
    }
    // Continue the path.
    let u_lobe = rng_f32(r);
    let u_dir = rng_2d(r);
    let s = bsdf_sample(m, color, n, wo, u_lobe, u_dir);
    if s.pdf == 0.0 || (own_normal && dot(s.wi, nside) <= 0.0) {
        return out;
    }
    var nb = beta * s.weight;
    if (*p).depth >= g.rr_depth {
        let q = min(max(max(nb.x, nb.y), nb.z), RR_MAX_SURVIVAL);
        if rng_f32(r) >= q {
            return out;
        }
        nb = nb / q;
    }
    if all(nb == vec3<f32>(0.0)) {
        return out;
    }
    (*p).throughput = nb;
    (*p).depth += 1u;
    (*p).pdf = s.pdf;
    // Through a pane the path goes on from the surface's other side.
    var start = origin;
    if s.transmitted {
        start = offset_origin(pos, -n);
    }
    out.next = Ray(start, 0.0, s.wi, FAR);
    return out;
}

// ---------------------------------------------------------------------------------------------
// Camera and the slot <-> (pixel, sample) mapping: slot = ((tile * k) + j) * 64 + local, with
// 8x8-pixel tiles in row-major order and local = (y % 8) * 8 + x % 8.

// Starts the path of `slot`: its camera ray, or an inactive path (slot NONE) outside the image.
fn camera_path(slot: u32, ray: ptr<function, Ray>) -> RtPath {
    let local = slot % 64u;
    let rest = slot / 64u;
    let j = rest % g.samples_per_wave;
    let tile = g.tile_base + rest / g.samples_per_wave;
    let px = (tile % g.tiles_x) * 8u + local % 8u;
    let py = (tile / g.tiles_x) * 8u + local / 8u;
    if px >= g.width || py >= g.height {
        *ray = no_ray();
        return RtPath(vec3<f32>(0.0), NONE, 0u, 1u, 0u, -1.0);
    }
    var r = rng_for_path(g.seed, py * g.width + px, g.sample_base + j);
    let jit = rng_2d(&r);
    let fx = (f32(px) + jit.x) / f32(g.width);
    let fy = (f32(py) + jit.y) / f32(g.height);
    let sx = (2.0 * fx - 1.0) * g.cam_pos.w * g.cam_forward.w;
    let sy = (1.0 - 2.0 * fy) * g.cam_pos.w;
    let dir = normalize(g.cam_forward.xyz + g.cam_right.xyz * sx + g.cam_up.xyz * sy);
    *ray = Ray(g.cam_pos.xyz, 0.0, dir, FAR);
    return RtPath(vec3<f32>(1.0), slot, r.state, r.inc, 0u, -1.0);
}

fn add_radiance(slot: u32, l: vec3<f32>) {
    // Drop non-finite values like the CPU tracer does (x != x is NaN; inf > FAR).
    let ok = all(l == l) && all(abs(l) <= vec3<f32>(FAR));
    if ok && any(l != vec3<f32>(0.0)) {
        accum[slot] += vec4<f32>(l, 0.0);
    }
}

fn dispatch_args(count: u32) -> vec4<u32> {
    let groups = max((count + 63u) / 64u, 1u);
    if groups <= g.max_groups {
        return vec4<u32>(groups, 1u, 1u, count);
    }
    let y = (groups + g.max_groups - 1u) / g.max_groups;
    return vec4<u32>((groups + y - 1u) / y, y, 1u, count);
}

// ---------------------------------------------------------------------------------------------
// Wavefront kernels.

@compute @workgroup_size(1)
fn wave_begin() {
    atomicStore(&ctl_queues[0].count, g.path_count);
    atomicStore(&ctl_queues[1].count, 0u);
    atomicStore(&ctl_queues[2].count, g.path_count);
    atomicStore(&ctl_queues[3].count, 0u);
    ctl_args[0] = dispatch_args(g.path_count);
}

@compute @workgroup_size(64)
fn generate(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= g.path_count {
        return;
    }
    var ray: Ray;
    let p = camera_path(i, &ray);
    rays[i] = ray;
    paths[i] = p;
}

@compute @workgroup_size(64)
fn shade(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= atomicLoad(&queues[batch.queue].count) {
        return;
    }
    let si = batch.shadow_base + i;
    rays[si] = no_ray();
    var p = paths[batch.base + i];
    if p.slot == NONE {
        return;
    }
    let v = shade_vertex(&p, rays[batch.base + i], hits[batch.base + i]);
    add_radiance(p.slot, v.emitted);
    if v.shadow.tmax > 0.0 {
        rays[si] = v.shadow;
        let through = select(0u, SHADOW_THROUGH_PANES, v.shadow_panes);
        paths[si] = RtPath(v.shadow_contrib, p.slot, 0u, 0u, through, 0.0);
    }
    if v.next.tmax > 0.0 {
        let j = atomicAdd(&queues[batch.next_queue].count, 1u);
        rays[batch.next_base + j] = v.next;
        paths[batch.next_base + j] = p;
    }
}

@compute @workgroup_size(64)
fn resolve(inv: Invocation) {
    let i = invocation_index(inv);
    if inv.lid == 0u {
        atomicStore(&wg_shadow, 0u);
    }
    workgroupBarrier();
    if i < atomicLoad(&queues[batch.queue].count) {
        let si = batch.shadow_base + i;
        if rays[si].tmax > 0.0 {
            atomicAdd(&wg_shadow, 1u);
            let rec = paths[si];
            if hits[si].tri == NONE {
                add_radiance(rec.slot, rec.throughput);
            } else if rec.depth == SHADOW_THROUGH_PANES {
                // Blocked: by panes only? Their transmittance, traced here from the start.
                add_radiance(rec.slot, rec.throughput * shadow_transmittance(rays[si], 1u));
            }
        }
    }
    workgroupBarrier();
    if inv.lid == 0u {
        atomicAdd(&queues[3].count, atomicLoad(&wg_shadow));
    }
}

@compute @workgroup_size(1)
fn queue_end() {
    let next = atomicLoad(&ctl_queues[batch.next_queue].count);
    ctl_args[batch.next_queue] = dispatch_args(next);
    atomicStore(&ctl_queues[batch.queue].count, 0u);
    atomicAdd(&ctl_queues[2].count, next);
}

// image[i] = mean over the slots of chunk pixel i (tile-local order: i = tile * 64 + local) of
// accum / spp, after all waves of the chunk.
@compute @workgroup_size(64)
fn finish(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= g.tile_count * 64u {
        return;
    }
    let tile = i / 64u;
    let local = i % 64u;
    var sum = vec3<f32>(0.0);
    for (var j = 0u; j < g.samples_per_wave; j++) {
        sum += accum[(tile * g.samples_per_wave + j) * 64u + local].xyz;
    }
    image[i] = vec4<f32>(sum / f32(g.spp), 1.0);
}

// ---------------------------------------------------------------------------------------------
// Megakernel: one invocation traces a whole path (same estimator, same random stream).

@compute @workgroup_size(64)
fn megakernel(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= g.path_count {
        return;
    }
    var ray: Ray;
    var p = camera_path(i, &ray);
    if p.slot == NONE {
        return;
    }
    var l = vec3<f32>(0.0);
    loop {
        let hit = trace(ray, false);
        let v = shade_vertex(&p, ray, hit);
        l += v.emitted;
        if v.shadow.tmax > 0.0 {
            if trace(v.shadow, true).tri == NONE {
                l += v.shadow_contrib;
            } else if v.shadow_panes {
                l += v.shadow_contrib * shadow_transmittance(v.shadow, 1u);
            }
        }
        if v.next.tmax <= 0.0 {
            break;
        }
        ray = v.next;
    }
    add_radiance(p.slot, l);
}
