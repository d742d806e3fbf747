// The scene as the GPU path tracer (raytrace_path.wgsl) and the GPU final gather (gather_*.wgsl)
// shade it: the BVH of common/bvh.wgsl (group 1, bindings 0 and 1) plus one array of vec4 (the
// "blob", binding 2) with texture coordinates, materials, the light list and textures, at the
// section offsets of the scene info (binding 3). Layout: crates/vlf-gpu/src/raytrace/scene.rs.
// Mirrors vlf_core::pathtrace (materials, lights, textures).

#import "common/bvh.wgsl"

// Where the blob's sections start (vec4 units) and the light list's counts (mirrors
// vlf_gpu::layout::RtSceneInfo).
struct RtSceneInfo {
    mat_base: u32,
    emitter_base: u32,
    emitter_count: u32,
    // Delta lights (suns, point and spot lights), four entries each.
    delta_base: u32,
    delta_count: u32,
    tex_base: u32,
    // Probability of sampling an emitter rather than a delta light.
    p_emitters: f32,
    // Where the per-triangle attributes (shading normals, vertex colours, TEXCOORD_1) start.
    attr_base: u32,
    // 1 when a material is (in part) a thin glass pane (common/pane_trace.wgsl).
    has_panes: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Group 1 bindings 0, 1 (nodes, triangles): see common/bvh.wgsl.
@group(1) @binding(2) var<storage, read> blob: array<vec4<f32>>;
@group(1) @binding(3) var<uniform> scene_info: RtSceneInfo;

struct Material {
    base_color: vec3<f32>,
    base_texture: u32,
    emission: vec3<f32>,
    emissive_texture: u32,
    // The path tracer's lobes (vlf_core::pathtrace::material::lobes).
    w_diffuse: f32,
    alpha: f32,
    // Weight of the baker's Lambertian lobe, a folded rough metal included
    // (vlf_core::bake::glossy::BakedMaterial::diffuse_weight).
    bake_diffuse: f32,
    // The texture coordinate set of the base-colour texture (bit 0) and of the emissive one
    // (bit 1): set 1 where the bit is set.
    texcoords: u32,
    // The thin glass pane's weight (0: none) and index of refraction
    // (vlf_core::pathtrace::SurfaceMaterial::w_pane, ior).
    w_pane: f32,
    ior: f32,
    // What the final gather's openness probes see through: MAT_PANE, MAT_SEE_THROUGH.
    openness: u32,
}

// Material openness flags (vlf_gpu::raytrace::scene::MAT_*; vlf_core::gather::Openness).
const MAT_PANE: u32 = 1u;
const MAT_SEE_THROUGH: u32 = 2u;

fn material(index: u32) -> Material {
    let o = scene_info.mat_base + 4u * index;
    let a = blob[o];
    let b = blob[o + 1u];
    let c = blob[o + 2u];
    let d = blob[o + 3u];
    return Material(a.xyz, bitcast<u32>(a.w), b.xyz, bitcast<u32>(b.w), c.x, c.y, c.z,
        bitcast<u32>(c.w), d.x, d.y, bitcast<u32>(d.z));
}

// Texture coordinates (TEXCOORD_0) of leaf-order triangle `tri` at barycentrics (b1, b2).
fn tri_uv(tri: u32, b1: f32, b2: f32) -> vec2<f32> {
    let a = blob[2u * tri];
    let b = blob[2u * tri + 1u];
    return a.xy * (1.0 - b1 - b2) + a.zw * b1 + b.xy * b2;
}

// Attribute flags (vlf_gpu::raytrace::scene::ATTR_*).
const ATTR_SMOOTH: u32 = 1u;
const ATTR_COLORS: u32 = 2u;

// The first attribute entry of leaf-order triangle `tri`, or NONE.
fn tri_attributes(tri: u32) -> u32 {
    let k = bitcast<u32>(blob[2u * tri + 1u].w);
    if k == NONE {
        return NONE;
    }
    return scene_info.attr_base + 8u * k;
}

// Texture coordinates of set `set` (0 or 1) of leaf-order triangle `tri` at (b1, b2)
// (vlf_core::scene::Triangle::uv_at; a missing TEXCOORD_1 reads 0).
fn tri_uv_set(tri: u32, uv_set: u32, b1: f32, b2: f32) -> vec2<f32> {
    if uv_set == 0u {
        return tri_uv(tri, b1, b2);
    }
    let o = tri_attributes(tri);
    if o == NONE {
        return vec2<f32>(0.0);
    }
    let a = blob[o + 6u];
    let b = blob[o + 7u];
    return a.xy * (1.0 - b1 - b2) + a.zw * b1 + b.xy * b2;
}

// The vertex colour of leaf-order triangle `tri` at (b1, b2): 1 without
// (vlf_core::scene::Triangle::color_at).
fn tri_color(tri: u32, b1: f32, b2: f32) -> vec3<f32> {
    let o = tri_attributes(tri);
    if o == NONE || (bitcast<u32>(blob[o].w) & ATTR_COLORS) == 0u {
        return vec3<f32>(1.0);
    }
    return blob[o + 3u].xyz * (1.0 - b1 - b2) + blob[o + 4u].xyz * b1 + blob[o + 5u].xyz * b2;
}

// The unit shading normal of leaf-order triangle `tri` at (b1, b2) on the side whose unit
// geometric normal is `n`; `n` itself for a flat triangle
// (vlf_core::pathtrace::PreparedScene::shading_normal).
fn tri_shading_normal(tri: u32, b1: f32, b2: f32, n: vec3<f32>) -> vec3<f32> {
    let o = tri_attributes(tri);
    if o == NONE || (bitcast<u32>(blob[o].w) & ATTR_SMOOTH) == 0u {
        return n;
    }
    let s = blob[o].xyz * (1.0 - b1 - b2) + blob[o + 1u].xyz * b1 + blob[o + 2u].xyz * b2;
    let len = length(s);
    if !(len > 0.0) {
        return n;
    }
    let m = s / len;
    return select(m, -m, dot(m, n) < 0.0);
}

// The base colour C (factor × texture × vertex colour) of leaf-order triangle `tri` of
// material `m` at (b1, b2) (vlf_core::pathtrace::PreparedScene::base_color).
fn base_color_at(tri: u32, m: Material, b1: f32, b2: f32) -> vec3<f32> {
    let uv = tri_uv_set(tri, m.texcoords & 1u, b1, b2);
    return m.base_color * sample_texture(m.base_texture, uv) * tri_color(tri, b1, b2);
}

// The planar face (vlf_core::scene::Triangle::face) of leaf-order triangle `tri`.
fn tri_face(tri: u32) -> u32 {
    return bitcast<u32>(blob[2u * tri + 1u].z);
}

fn wrap(mode: u32, i: i32, size: u32) -> u32 {
    let n = i32(max(size, 1u));
    if mode == 1u {
        return u32(clamp(i, 0, n - 1));
    }
    if mode == 2u {
        let m = ((i % (2 * n)) + 2 * n) % (2 * n);
        if m < n {
            return u32(m);
        }
        return u32(2 * n - 1 - m);
    }
    return u32(((i % n) + n) % n);
}

fn texel(offset: u32, w: u32, h: u32, modes: u32, i: i32, j: i32) -> vec3<f32> {
    let x = wrap(modes & 15u, i, w);
    let y = wrap(modes >> 4u, j, h);
    return blob[offset + y * w + x].xyz;
}

// Bilinear sample with wrap modes (mirrors vlf_core::scene::Texture::bilinear); NONE reads 1.
fn sample_texture(t: u32, uv: vec2<f32>) -> vec3<f32> {
    if t == NONE {
        return vec3<f32>(1.0);
    }
    let hd = blob[scene_info.tex_base + t];
    let offset = bitcast<u32>(hd.x);
    let w = bitcast<u32>(hd.y);
    let h = bitcast<u32>(hd.z);
    let modes = bitcast<u32>(hd.w);
    if w == 0u || h == 0u {
        return vec3<f32>(1.0);
    }
    let x = clamp(uv.x * f32(w) - 0.5, -1e9, 1e9);
    let y = clamp(uv.y * f32(h) - 0.5, -1e9, 1e9);
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let top = mix(texel(offset, w, h, modes, i, j), texel(offset, w, h, modes, i + 1, j), fx);
    let bottom = mix(texel(offset, w, h, modes, i, j + 1), texel(offset, w, h, modes, i + 1, j + 1), fx);
    return mix(top, bottom, fy);
}

// ---------------------------------------------------------------------------------------------
// Lights (mirrors vlf_core::pathtrace::lights). Emitter: [tri, area, pdf, cdf]; delta light
// (DeltaLight): [position (sun: direction towards it), kind], [intensity (sun: irradiance),
// pdf], [spot axis, cdf], [cone scale, cone offset, 1/range, 0].

// Index of the emitter whose CDF interval holds u (binary search).
fn pick_emitter(u: f32) -> u32 {
    var lo = 0u;
    var hi = scene_info.emitter_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if blob[scene_info.emitter_base + mid].w > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// The emitter whose CDF interval holds u.x, and u.x rescaled to [0, 1) within that interval
// (LightSet::pick_emitter_remapped): a stratified u stays stratified over all emitters.
struct RemappedEmitter {
    index: u32,
    u: vec2<f32>,
}

fn pick_emitter_remapped(u: vec2<f32>) -> RemappedEmitter {
    let i = pick_emitter(u.x);
    let e = blob[scene_info.emitter_base + i];
    let lo = e.w - e.z;
    let x = clamp((u.x - lo) / e.z, 0.0, 0.99999994);
    return RemappedEmitter(i, vec2<f32>(x, u.y));
}

// Index of the delta light whose CDF interval holds u (LightSet::pick_delta).
fn pick_delta(u: f32) -> u32 {
    for (var i = 0u; i < scene_info.delta_count; i++) {
        if blob[scene_info.delta_base + 4u * i + 2u].w > u {
            return i;
        }
    }
    return scene_info.delta_count - 1u;
}

// DeltaLight's kinds (vlf_core::pathtrace::lights::DELTA_SUN).
const DELTA_SUN: u32 = 0u;

// What delta light `i` brings to point p (DeltaLight::incident): the unit direction towards
// it, its distance (FAR for a sun) and the irradiance on a surface facing it, the spot's
// falloff clamp(cos · scale + offset, 0, 1)² and the range window clamp(1 − (d/range)⁴, 0, 1)
// included.
struct DeltaIncident {
    wi: vec3<f32>,
    dist: f32,
    irradiance: vec3<f32>,
}

fn delta_incident(i: u32, p: vec3<f32>) -> DeltaIncident {
    let o = scene_info.delta_base + 4u * i;
    let a = blob[o];
    let b = blob[o + 1u];
    if bitcast<u32>(a.w) == DELTA_SUN {
        return DeltaIncident(a.xyz, FAR, b.xyz);
    }
    let none = DeltaIncident(vec3<f32>(0.0, 0.0, 1.0), 0.0, vec3<f32>(0.0));
    let c = blob[o + 2u];
    let d = blob[o + 3u];
    let to = a.xyz - p;
    let d2 = dot(to, to);
    if !(d2 > 0.0) {
        return none;
    }
    let dist = sqrt(d2);
    let wi = to / dist;
    let t = clamp(-dot(wi, c.xyz) * d.x + d.y, 0.0, 1.0);
    let x = dist * d.z;
    let x2 = x * x;
    let window = clamp(1.0 - x2 * x2, 0.0, 1.0);
    let e = b.xyz * (t * t * window / d2);
    if any(e != e) || any(abs(e) > vec3<f32>(FAR)) {
        return none;
    }
    return DeltaIncident(wi, dist, e);
}

// The shadow ray from `origin` towards delta light `i` (DeltaLight::shadow_ray): along a sun's
// direction, the segment to a point or spot light's position.
fn delta_shadow_ray(i: u32, origin: vec3<f32>, inc: DeltaIncident) -> Ray {
    let a = blob[scene_info.delta_base + 4u * i];
    if bitcast<u32>(a.w) == DELTA_SUN {
        return Ray(origin, 0.0, inc.wi, FAR);
    }
    return Ray(origin, 0.0, a.xyz - origin, 1.0);
}

// Solid-angle pdf with which one light sample picks the point of emitter `light` seen at
// distance `dist` under cosine `cos_light` (0 if it cannot be sampled).
fn emitter_pdf(light: u32, dist: f32, cos_light: f32) -> f32 {
    if light == NONE || light >= scene_info.emitter_count || cos_light <= 0.0 {
        return 0.0;
    }
    let e = blob[scene_info.emitter_base + light];
    return scene_info.p_emitters * e.z * dist * dist / (e.y * cos_light);
}

// Emitted radiance of leaf-order triangle `tri` at barycentrics (b1, b2) (front face; none
// where its alpha mask leaves no surface).
fn emission_at(tri: u32, b1: f32, b2: f32) -> vec3<f32> {
    let t = triangles[tri];
    if alpha_cuts(t.prim, vec3<f32>(1.0 - b1 - b2, b1, b2)) {
        return vec3<f32>(0.0);
    }
    let m = material(t.material);
    let uv = tri_uv_set(tri, (m.texcoords >> 1u) & 1u, b1, b2);
    return m.emission * sample_texture(m.emissive_texture, uv);
}
