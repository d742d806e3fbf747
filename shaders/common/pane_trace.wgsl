// Rays that go on through thin glass panes (docs/TRANSMISSION.md), in the ray-tracing scene of
// common/rt_scene.wgsl: a pane passes w_pane × T(θ) × C of the light along a ray straight
// through (no refraction). Mirrors vlf_core::gather::through (the final gather's rays) and the
// pane crossings of vlf_core::pathtrace::PreparedScene::shadow_transmittance (the path tracer's
// shadow rays towards delta lights, raytrace_path.wgsl). Without panes in the scene
// (scene_info.has_panes = 0) the transmittance functions trace as before: one any-hit query.

#import "common/rt_scene.wgsl"
#import "common/pane.wgsl"

// Panes a ray passes before it gives up (vlf_core::gather::through::MAX_PANES; a Rust test
// checks).
const MAX_PANES: u32 = 16u;

// What crossing `hit` of a ray along `dir` passes straight through: rgb w_pane × T(θ) × C, C the
// base colour factor × its texture (no vertex colour) read at TEXCOORD_0 (`uv_set` 0: the
// gather's through::pane_pass) or at the set the material names (`uv_set` 1: the path
// tracer's PreparedScene::shadow_transmittance); w = 1 on a pane, and all 0 elsewhere.
fn pane_pass(hit: Hit, dir: vec3<f32>, uv_set: u32) -> vec4<f32> {
    let tri = triangles[hit.tri];
    let m = material(tri.material);
    if m.w_pane <= 0.0 {
        return vec4<f32>(0.0);
    }
    let ng = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
    let passed = m.w_pane * (1.0 - pane_reflectance(dot(ng, dir), m.ior));
    let uv = tri_uv_set(hit.tri, select(0u, m.texcoords & 1u, uv_set == 1u), hit.u, hit.v);
    return vec4<f32>(m.base_color * sample_texture(m.base_texture, uv) * passed, 1.0);
}

// The point of `hit` moved off its surface to the side `dir` leaves towards (through::beyond).
fn pane_beyond(hit: Hit, dir: vec3<f32>) -> vec3<f32> {
    let tri = triangles[hit.tri];
    let ng = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
    let p = tri.p0 * (1.0 - hit.u - hit.v) + tri.p1 * hit.u + tri.p2 * hit.v;
    return offset_origin(p, select(-ng, ng, dot(ng, dir) > 0.0));
}

// The first hit along a ray that is not a pane (tri = NONE when the ray leaves the scene; t
// the whole distance through the panes) and the panes' transmittance product up to it
// (through::Traced).
struct Traced {
    hit: Hit,
    throughput: vec3<f32>,
}

// through::trace without its callback: follows the ray from `origin` along unit `dir` through
// panes to its first other hit. Panes beyond MAX_PANES stop the ray (zero throughput).
fn trace_through_panes(origin: vec3<f32>, dir: vec3<f32>) -> Traced {
    var throughput = vec3<f32>(1.0);
    var ray = Ray(origin, 0.0, dir, FAR);
    var t = 0.0;
    for (var i = 0u; i < MAX_PANES; i++) {
        let hit = trace(ray, false);
        if hit.tri == NONE {
            return Traced(hit, throughput);
        }
        let passed = pane_pass(hit, dir, 0u);
        if passed.w == 0.0 {
            return Traced(Hit(t + hit.t, hit.tri, hit.u, hit.v), throughput);
        }
        throughput *= passed.xyz;
        t += hit.t;
        ray = Ray(pane_beyond(hit, dir), 0.0, dir, FAR);
    }
    return Traced(Hit(FAR, NONE, 0.0, 0.0), vec3<f32>(0.0));
}

// 1 where nothing blocks `ray`, else 0 (one any-hit query).
fn unoccluded(ray: Ray) -> vec3<f32> {
    return select(vec3<f32>(1.0), vec3<f32>(0.0), trace(ray, true).tri != NONE);
}

// What reaches `origin` from the end of the segment origin + s·d, s in (0, 1) (d not
// normalised): 1 through nothing, the panes' transmittance product (tints read as `uv_set`
// says, see pane_pass) through panes only, 0 where anything else blocks it
// (through::segment_transmittance; PreparedScene::shadow_transmittance of a ray with an end).
fn segment_transmittance(origin: vec3<f32>, d: vec3<f32>, uv_set: u32) -> vec3<f32> {
    return transmittance_past_panes(origin, d, true, uv_set);
}

// segment_transmittance of a ray without an end along `dir` (towards a sun): the panes'
// product when it leaves the scene, else 0 (through::ray_transmittance; the path tracer passes
// its direction normalised, which PreparedScene::shadow_transmittance goes on along after the
// first pane: a sun's direction is unit already, so the two differ by rounding at most).
fn ray_transmittance(origin: vec3<f32>, dir: vec3<f32>, uv_set: u32) -> vec3<f32> {
    return transmittance_past_panes(origin, dir, false, uv_set);
}

// The one loop of segment_transmittance (`end`: the segment origin + s·d ends at s = 1) and
// ray_transmittance (no end: `d` is the direction, used as given); through::transmittance.
fn transmittance_past_panes(origin: vec3<f32>, d: vec3<f32>, end: bool, uv_set: u32) -> vec3<f32> {
    let tmax = select(FAR, 1.0, end);
    if scene_info.has_panes == 0u {
        return unoccluded(Ray(origin, 0.0, d, tmax));
    }
    let dir = select(d, normalize(d), end);
    var throughput = vec3<f32>(1.0);
    var ray = Ray(origin, 0.0, d, tmax);
    for (var i = 0u; i < MAX_PANES; i++) {
        let hit = trace(ray, false);
        if hit.tri == NONE {
            return throughput;
        }
        let passed = pane_pass(hit, dir, uv_set);
        if passed.w == 0.0 {
            return vec3<f32>(0.0);
        }
        throughput *= passed.xyz;
        let next = pane_beyond(hit, dir);
        if end {
            let rest = origin + d - next;
            // Past the segment's end (the pane lies within an ulp of it): done.
            if dot(rest, d) <= 0.0 {
                return throughput;
            }
            ray = Ray(next, 0.0, rest, 1.0);
        } else {
            ray = Ray(next, 0.0, dir, FAR);
        }
    }
    return vec3<f32>(0.0);
}

// What a shadow ray towards a delta light passes (through::shadow_transmittance with `uv_set`
// 0; PreparedScene::shadow_transmittance with 1): ray_transmittance towards a sun (no end),
// segment_transmittance up to a point or spot light (tmax 1).
fn shadow_transmittance(ray: Ray, uv_set: u32) -> vec3<f32> {
    if ray.tmax < FAR {
        return segment_transmittance(ray.origin, ray.dir * ray.tmax, uv_set);
    }
    var dir = ray.dir;
    if uv_set == 1u {
        dir = normalize(dir);
    }
    return ray_transmittance(ray.origin, dir, uv_set);
}
