// Smoke test pass: y[i] = a * x[i] + b, plus the invocation index written back so the CPU can check
// that every element was visited exactly once. Exercises the project's binding conventions:
// group 0 = per-dispatch globals (uniform), group 1 = per-pass resources (storage).

struct SmokeParams {
    a: f32,
    b: f32,
    count: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: SmokeParams;
@group(1) @binding(0) var<storage, read> xs: array<f32>;
@group(1) @binding(1) var<storage, read_write> ys: array<vec2<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    // 2D dispatch so large arrays stay under the 65535-workgroups-per-dimension limit.
    let i = gid.x + gid.y * nwg.x * 64u;
    if (i >= params.count) {
        return;
    }
    ys[i] = vec2<f32>(params.a * xs[i] + params.b, f32(i));
}
