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
    sun_base: u32,
    sun_count: u32,
    tex_base: u32,
    // Probability of sampling an emitter rather than a sun.
    p_emitters: f32,
    _pad: u32,
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
}

fn material(index: u32) -> Material {
    let o = scene_info.mat_base + 3u * index;
    let a = blob[o];
    let b = blob[o + 1u];
    let c = blob[o + 2u];
    return Material(a.xyz, bitcast<u32>(a.w), b.xyz, bitcast<u32>(b.w), c.x, c.y, c.z);
}

// Texture coordinates of leaf-order triangle `tri` at barycentrics (b1, b2).
fn tri_uv(tri: u32, b1: f32, b2: f32) -> vec2<f32> {
    let a = blob[2u * tri];
    let b = blob[2u * tri + 1u];
    return a.xy * (1.0 - b1 - b2) + a.zw * b1 + b.xy * b2;
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
// Lights (mirrors vlf_core::pathtrace::lights). Emitter: [tri, area, pdf, cdf]; sun:
// [to_sun, pdf], [irradiance, cdf].

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

fn pick_sun(u: f32) -> u32 {
    for (var i = 0u; i < scene_info.sun_count; i++) {
        if blob[scene_info.sun_base + 2u * i + 1u].w > u {
            return i;
        }
    }
    return scene_info.sun_count - 1u;
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
    return m.emission * sample_texture(m.emissive_texture, tri_uv(tri, b1, b2));
}
