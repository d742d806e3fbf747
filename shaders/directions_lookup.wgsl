// The direction lookup over a batch of directions (vlf_gpu::directions::DirectionLookup): what
// common/directions.wgsl answers for each, read back to test it against the CPU's
// DirectionSet::lookup. One invocation per direction, 2-D dispatch (x fastest).

#import "common/directions.wgsl"

// Directions (xyz; w unused).
@group(0) @binding(0) var<storage, read> lookup_dirs: array<vec4<f32>>;
// Two entries per direction: [v0, v1, v2, triangle], [w0, w1, w2 as bits, 0].
@group(0) @binding(1) var<storage, read_write> lookup_out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.y * groups.x * 64u + gid.x;
    if i >= arrayLength(&lookup_dirs) {
        return;
    }
    let lk = direction_lookup(lookup_dirs[i].xyz);
    lookup_out[2u * i] = vec4<u32>(lk.vertices, lk.triangle);
    lookup_out[2u * i + 1u] = vec4<u32>(bitcast<vec3<u32>>(lk.weights), 0u);
}
