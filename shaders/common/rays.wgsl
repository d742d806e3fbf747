// Rays, hits and the ray queues shared by the ray engine (raytrace_engine.wgsl) and the
// wavefront path tracer (raytrace_path.wgsl), which drives the engine over its own queues.

// "No triangle" / "no path" (vlf_core::pathtrace::NONE).
const NONE: u32 = 0xffffffffu;

// A ray origin + t dir, t in (tmin, tmax) (mirrors vlf_core::pathtrace::Ray). tmax < tmin marks
// an inactive slot; "infinite" rays use the largest finite f32.
struct Ray {
    origin: vec3<f32>,
    tmin: f32,
    dir: vec3<f32>,
    tmax: f32,
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

// Index of an invocation of a 2-D dispatch of 64-wide workgroups (vlf_gpu::passes::dispatch_2d):
// ray, path or slot index.
fn invocation_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * nwg.x + wid.x) * 64u + lid;
}
