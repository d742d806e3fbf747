// The GPU ray engine (in the spirit of Purcell/Carr et al.'s "Ray Engine", 2002): closest-hit and
// any-hit queries for a batch of rays against the flattened BVH that the CPU path tracer builds
// (vlf_core::pathtrace::Bvh, uploaded unchanged). One invocation per ray; batches are a range of
// the ray buffer (`batch.base`, count in `queues[batch.queue]`), so the wavefront path tracer
// (raytrace_path.wgsl) drives these very entry points over its own queues.
//
// The traversal itself (`trace`, mirroring vlf_core::pathtrace::{bvh, geometry}) is in
// common/bvh.wgsl.

#import "common/bvh.wgsl"

@group(0) @binding(0) var<uniform> batch: RtBatch;

// Group 1 (nodes, triangles): see common/bvh.wgsl.

@group(2) @binding(0) var<storage, read> rays: array<Ray>;
@group(2) @binding(1) var<storage, read_write> hits: array<Hit>;
@group(2) @binding(2) var<storage, read_write> queues: array<RtQueue>;

@compute @workgroup_size(64)
fn closest_hit(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= atomicLoad(&queues[batch.queue].count) {
        return;
    }
    hits[batch.base + i] = trace(rays[batch.base + i], false);
}

@compute @workgroup_size(64)
fn any_hit(inv: Invocation) {
    let i = invocation_index(inv);
    if i >= atomicLoad(&queues[batch.queue].count) {
        return;
    }
    hits[batch.base + i] = trace(rays[batch.base + i], true);
}
