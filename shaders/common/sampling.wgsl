// Sampling routines shared by the GPU path tracer, the GPU final gather and pass 5's traced
// reflections (the ray-origin offset is common/rays.wgsl's offset_origin). Mirror
// vlf_core::pathtrace::sampling.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const TAU: f32 = 6.28318530717959;

// copysign(1, z): −1 where z's sign bit is set, −0.0 included (vlf_core's basis takes
// `1.0f32.copysign(n.z)`; `z >= 0.0` would call −0.0 positive and turn the basis of a normal
// such as (1, −0, −0), the back side of a face along −x, the other way round).
fn basis_sign(z: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(z) & 0x80000000u) != 0u);
}

// An orthonormal basis (t, b, n) around the unit vector n (Duff et al. 2017): t and b.
fn basis_t(n: vec3<f32>) -> vec3<f32> {
    let sign = basis_sign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
}

fn basis_b(n: vec3<f32>) -> vec3<f32> {
    let sign = basis_sign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sign + n.y * n.y * a, -n.y);
}

// Local (z = normal) -> world.
fn to_world(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return basis_t(n) * v.x + basis_b(n) * v.y + n * v.z;
}

// World -> local (z = normal).
fn to_local(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, basis_t(n)), dot(v, basis_b(n)), dot(v, n));
}

// Cosine-weighted direction on the hemisphere around +z; pdf = z / pi.
fn cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = TAU * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// Uniform barycentrics (b1, b2) of a point on a triangle (weights of p1 and p2).
fn triangle_barycentrics(u: vec2<f32>) -> vec2<f32> {
    let su = sqrt(u.x);
    return vec2<f32>(1.0 - su, u.y * su);
}

// Power heuristic (beta = 2) weight of a sample drawn with pdf a against a strategy of pdf b.
fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if a2 + b2 > 0.0 {
        return a2 / (a2 + b2);
    }
    return 0.0;
}

// GGX (Trowbridge–Reitz) normal distribution D(h) for cos θ_h = cos_h, isotropic alpha.
fn ggx_d(cos_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Smith's masking term G1(v) for GGX, cos θ_v = cos_v > 0.
fn ggx_g1(cos_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    return 2.0 * cos_v / (cos_v + sqrt(a2 + (1.0 - a2) * cos_v * cos_v));
}

// A GGX microfacet normal from the distribution of normals visible from wo (local frame,
// wo.z > 0; Heitz 2018).
fn ggx_sample_vndf(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let vh = normalize(vec3<f32>(alpha * wo.x, alpha * wo.y, wo.z));
    let lensq = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if lensq > 0.0 {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(lensq);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = TAU * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = t1 * p1 + t2 * p2 + vh * sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0));
    return normalize(vec3<f32>(alpha * nh.x, alpha * nh.y, max(nh.z, 1e-7)));
}

// Mirror reflection of v about n (both pointing away from the surface).
fn reflect_about(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return 2.0 * dot(v, n) * n - v;
}
