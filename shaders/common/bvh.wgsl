// BVH traversal: the ray engine's kernels (raytrace_engine.wgsl) and the path tracer's
// megakernel (raytrace_path.wgsl) call `trace`. Mirrors vlf_core::pathtrace::{bvh, geometry}: stack traversal visiting the nearer child first, the
// robust slab test of Ize 2013, the watertight ray/triangle test of Woop et al. 2013.
//
// Bind group 1, bindings 0 and 1 of both raytrace shaders: the scene's flattened BVH and its
// triangles (vlf_gpu::raytrace::GpuScene, uploaded unchanged from vlf_core::pathtrace::Bvh),
// and binding 6, its alpha masks (common/alpha_mask.wgsl, looked up by RtTriangle::prim): a hit
// where a triangle's mask leaves no surface is skipped (vlf_core::pathtrace::Bvh::traverse).

#import "common/rays.wgsl"
#import "common/alpha_mask.wgsl"

// Flattened BVH node (mirrors vlf_core::pathtrace::BvhNode): a leaf when count > 0 (triangles
// index .. index + count), otherwise children node + 1 and index.
struct BvhNode {
    min: vec3<f32>,
    index: u32,
    max: vec3<f32>,
    count: u32,
}

// Triangle in BVH leaf order (mirrors vlf_core::pathtrace::RtTriangle).
struct RtTriangle {
    p0: vec3<f32>,
    material: u32,
    p1: vec3<f32>,
    prim: u32,
    p2: vec3<f32>,
    light: u32,
}

@group(1) @binding(0) var<storage, read> nodes: array<BvhNode>;
@group(1) @binding(1) var<storage, read> triangles: array<RtTriangle>;

// Traversal stack size (vlf_core::pathtrace::bvh::MAX_DEPTH; a Rust test checks).
const BVH_STACK: u32 = 32u;
// 1 + 2 gamma_3 for f32 (Ize 2013): widens box exits so rounding never culls a touched box.
const SLAB_WIDEN: f32 = 1.0000004;

// 1 / d with zero components replaced by a tiny signed value (no inf or NaN in the slab test).
fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = select(vec3<f32>(1e-30), vec3<f32>(-1e-30), d < vec3<f32>(0.0));
    return 1.0 / select(d, tiny, abs(d) < vec3<f32>(1e-30));
}

// Entry distance into the node's box, or -1 when the ray misses it over (tmin, tmax).
fn slab(n: BvhNode, o: vec3<f32>, inv: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let t0 = (n.min - o) * inv;
    let t1 = (n.max - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let near = max(max(max(lo.x, lo.y), lo.z), tmin);
    let far = min(min(hi.x, hi.y), hi.z) * SLAB_WIDEN;
    if near <= min(far, tmax) {
        return near;
    }
    return -1.0;
}

// Axes permuted so that z is the dominant axis kz (kx = kz + 1, ky = kz + 2 mod 3).
fn permute(v: vec3<f32>, kz: u32) -> vec3<f32> {
    if kz == 0u {
        return v.yzx;
    }
    if kz == 1u {
        return v.zxy;
    }
    return v;
}

// Watertight ray/triangle test (Woop, Benthin & Wald 2013) without the winding swap (both faces
// count). Returns (t, b1, b2), t < 0 for no hit in (tmin, tmax).
fn intersect(o: vec3<f32>, kz: u32, s: vec3<f32>, tri: RtTriangle, tmin: f32, tmax: f32) -> vec3<f32> {
    let a = permute(tri.p0 - o, kz);
    let b = permute(tri.p1 - o, kz);
    let c = permute(tri.p2 - o, kz);
    let ax = a.x - s.x * a.z;
    let ay = a.y - s.y * a.z;
    let bx = b.x - s.x * b.z;
    let by = b.y - s.y * b.z;
    let cx = c.x - s.x * c.z;
    let cy = c.y - s.y * c.z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let rcp = 1.0 / det;
    let t = s.z * (u * a.z + v * b.z + w * c.z) * rcp;
    if !(t > tmin && t < tmax) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    return vec3<f32>(t, v * rcp, w * rcp);
}

// Closest hit of the ray (any hit when `any_hit`), by stack traversal nearer child first.
fn trace(ray: Ray, any_hit: bool) -> Hit {
    var best = Hit(ray.tmax, NONE, 0.0, 0.0);
    if !(ray.tmax > ray.tmin) {
        return best;
    }
    let o = ray.origin;
    let d = ray.dir;
    let inv = safe_inverse(d);
    let ad = abs(d);
    var kz = 2u;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0u;
    } else if ad.y >= ad.z {
        kz = 1u;
    }
    let dp = permute(d, kz);
    let s = vec3<f32>(dp.x / dp.z, dp.y / dp.z, 1.0 / dp.z);
    var tmax = ray.tmax;
    if slab(nodes[0], o, inv, ray.tmin, tmax) < 0.0 {
        return best;
    }
    var stack: array<u32, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        if n.count > 0u {
            for (var i = n.index; i < n.index + n.count; i++) {
                let tri = triangles[i];
                let h = intersect(o, kz, s, tri, ray.tmin, tmax);
                if h.x >= 0.0 && !alpha_cuts(tri.prim, vec3<f32>(1.0 - h.y - h.z, h.y, h.z)) {
                    best = Hit(h.x, i, h.y, h.z);
                    tmax = h.x;
                    if any_hit {
                        return best;
                    }
                }
            }
        } else {
            let l = node + 1u;
            let r = n.index;
            let tl = slab(nodes[l], o, inv, ray.tmin, tmax);
            let tr = slab(nodes[r], o, inv, ray.tmin, tmax);
            if tl >= 0.0 && tr >= 0.0 {
                if tl <= tr {
                    stack[sp] = r;
                    node = l;
                } else {
                    stack[sp] = l;
                    node = r;
                }
                sp += 1u;
                continue;
            }
            if tl >= 0.0 {
                node = l;
                continue;
            }
            if tr >= 0.0 {
                node = r;
                continue;
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        node = stack[sp];
    }
    return best;
}
