// Matrix radiosity on the GPU: one Jacobi sweep per dispatch (issue #8; the 2003 GPU radiosity
// paper, section 3). Mirrors vlf_core::radiosity::{jacobi_sweep, solve_jacobi}.
//
// `sweep`: one invocation per patch (matrix row): dst_i = S_i + rho_i * sum_j F_ij src_j over the
// CSR matrix, summed in column order as on the CPU. Each workgroup also reduces max |dst - src|
// and max |dst| (over its rows and the three channels) into `partials[group]`.
// `reduce`: one workgroup turns the partial maxima into the sweep's residual
// (max |dL| / max |L|), appends it to the history in `state`, counts the sweep, and raises the
// `done` flag when the residual falls below the threshold or the count reaches the maximum.
// Every later dispatch of the submission then returns at once, so the CPU reads `state` only once
// per batch of sweeps and the solution stops at exactly the sweep the CPU solver stops at. The
// two L buffers ping-pong (bound as src/dst in two bind groups). No atomics: deterministic.

struct RadiosityGlobals {
    patches: u32,
    // Workgroups along x of the 2-D dispatch (rows = (y * groups_x + x) * 64 + local).
    groups_x: u32,
    // Workgroups dispatched in all (= entries of `partials`).
    partial_count: u32,
    max_iterations: u32,
    // 0 = run max_iterations sweeps.
    threshold: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Per patch: the source term S (emission + reflected direct light) and the albedo rho.
struct PatchTerm {
    source: vec4<f32>,
    albedo: vec4<f32>,
}

@group(0) @binding(0) var<uniform> globals: RadiosityGlobals;

@group(1) @binding(0) var<storage, read> row_start: array<u32>;
@group(1) @binding(1) var<storage, read> columns: array<u32>;
@group(1) @binding(2) var<storage, read> values: array<f32>;
@group(1) @binding(3) var<storage, read> terms: array<PatchTerm>;
@group(1) @binding(4) var<storage, read> src: array<vec4<f32>>;
@group(1) @binding(5) var<storage, read_write> dst: array<vec4<f32>>;
@group(1) @binding(6) var<storage, read_write> partials: array<vec2<f32>>;
// [0] done flag, [1] sweeps run, [2], [3] unused, [4 + k] residual of sweep k + 1 (f32 bits).
@group(1) @binding(7) var<storage, read_write> state: array<u32>;

const WG: u32 = 64u;

var<workgroup> wg_delta: array<f32, 64>;
var<workgroup> wg_value: array<f32, 64>;
var<workgroup> wg_done: u32;

// Tree reduction (max) of wg_delta / wg_value; the result lands in slot 0.
fn reduce_workgroup(lid: u32) {
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s = s >> 1u) {
        if lid < s {
            wg_delta[lid] = max(wg_delta[lid], wg_delta[lid + s]);
            wg_value[lid] = max(wg_value[lid], wg_value[lid + s]);
        }
        workgroupBarrier();
    }
}

@compute @workgroup_size(64)
fn sweep(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        wg_done = state[0];
    }
    if workgroupUniformLoad(&wg_done) != 0u {
        return;
    }
    let group = wid.y * globals.groups_x + wid.x;
    let i = group * WG + lid;
    var delta = 0.0;
    var value = 0.0;
    if i < globals.patches {
        var acc = vec3<f32>(0.0);
        let end = row_start[i + 1u];
        for (var k = row_start[i]; k < end; k = k + 1u) {
            acc = acc + src[columns[k]].xyz * values[k];
        }
        let t = terms[i];
        let l = t.source.xyz + t.albedo.xyz * acc;
        dst[i] = vec4<f32>(l, 0.0);
        let d = abs(l - src[i].xyz);
        delta = max(d.x, max(d.y, d.z));
        let a = abs(l);
        value = max(a.x, max(a.y, a.z));
    }
    wg_delta[lid] = delta;
    wg_value[lid] = value;
    reduce_workgroup(lid);
    if lid == 0u && group < globals.partial_count {
        partials[group] = vec2<f32>(wg_delta[0], wg_value[0]);
    }
}

@compute @workgroup_size(64)
fn reduce(@builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        wg_done = state[0];
    }
    if workgroupUniformLoad(&wg_done) != 0u {
        return;
    }
    var delta = 0.0;
    var value = 0.0;
    for (var g = lid; g < globals.partial_count; g = g + WG) {
        let p = partials[g];
        delta = max(delta, p.x);
        value = max(value, p.y);
    }
    wg_delta[lid] = delta;
    wg_value[lid] = value;
    reduce_workgroup(lid);
    if lid == 0u {
        var r = 0.0;
        if wg_value[0] > 0.0 {
            r = wg_delta[0] / wg_value[0];
        }
        let k = state[1];
        state[4u + k] = bitcast<u32>(r);
        state[1] = k + 1u;
        if (globals.threshold > 0.0 && r < globals.threshold) || k + 1u >= globals.max_iterations {
            state[0] = 1u;
        }
    }
}
