// Rays, hits and the ray queues shared by the ray engine (raytrace_engine.wgsl) and the
// wavefront path tracer (raytrace_path.wgsl), which drives the engine over its own queues.

// "No triangle" / "no path" (vlf_core::pathtrace::NONE).
const NONE: u32 = 0xffffffffu;

// The largest finite f32: the tmax of rays without an end (portable where infinity is not).
const FAR: f32 = 3.4028235e38;

// A ray origin + t dir, t in (tmin, tmax) (mirrors vlf_core::pathtrace::Ray). tmax < tmin marks
// an inactive slot; "infinite" rays use the largest finite f32.
struct Ray {
    origin: vec3<f32>,
    tmin: f32,
    dir: vec3<f32>,
    tmax: f32,
}

// A surface point moved off its surface along n (the side a new ray leaves towards) so that the
// ray never re-hits it: Wächter & Binder 2019 (mirrors
// vlf_core::pathtrace::geometry::offset_ray_origin). Path tracer and pass 5's mirror tracing.
fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let of_i = vec3<i32>(256.0 * n);
    let bits = bitcast<vec3<i32>>(p);
    let moved = bitcast<vec3<f32>>(bits + select(of_i, -of_i, p < vec3<f32>(0.0)));
    return select(moved, p + (1.0 / 65536.0) * n, abs(p) < vec3<f32>(1.0 / 32.0));
}

// Closest (or any) hit: tri = NONE for a miss; u, v = barycentric weights of corners 1 and 2
// (mirrors vlf_core::pathtrace::Hit).
struct Hit {
    t: f32,
    tri: u32,
    u: f32,
    v: f32,
}

// Which slice of the ray buffer a dispatch works on (mirrors vlf_gpu::layout::RtBatch).
struct RtBatch {
    queue: u32,
    base: u32,
    next_queue: u32,
    next_base: u32,
    shadow_base: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Ray queue header (mirrors vlf_gpu::layout::RtQueue): the number of rays in the queue. The path
// tracer appends with atomicAdd; the engine only reads it (atomicLoad).
struct RtQueue {
    count: atomic<u32>,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// An invocation of a 2-D dispatch of 64-wide workgroups (vlf_gpu::wgpu_util::dispatch_2d): the
// input of every such entry point.
struct Invocation {
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
}

// Its index in the dispatch: ray, path, slot or texel index.
fn invocation_index(inv: Invocation) -> u32 {
    return (inv.wid.y * inv.nwg.x + inv.wid.x) * 64u + inv.lid;
}
