// The per-corner attributes of the renderer (vlf_gpu::render::attributes): four entries per
// triangle corner, [normal xyz, TEXCOORD_1 u], [colour rgb, TEXCOORD_1 v], [irradiance
// correction of side 0, 0], [of side 1, 0]. Pass 4b (render_attributes.wgsl) stores a pixel's
// interpolated values in two targets (pack_surface: 32 bytes, the most colour attachments every
// device allows per pixel): [octahedral normal, TEXCOORD_1] as f32, and [colour as 10-bit unorm
// per channel, correction's bits]; the window's pass 5 (render_final_radiance.wgsl, fs_surface) packs its
// interpolated values the same way, so both paths shade with the same bits.

#import "common/bake_scene.wgsl"

// Entries per triangle corner.
const CORNER_ENTRIES: u32 = 4u;
// The octahedral coordinates stored for a zero normal (a flat triangle).
const FLAT_NORMAL: f32 = 4.0;

// The entry (2 or 3) of a corner's entries holding the irradiance correction of the side of
// triangle `tri` that an eye at `eye` sees (the side of its plane the eye is on).
fn correction_entry(tri: BakeTriangle, eye: vec3<f32>) -> u32 {
    let n = cross(tri.p1 - tri.p0, tri.p2 - tri.p0);
    return select(2u, 3u, dot(n, eye - tri.p0) < 0.0);
}

// The octahedral coordinates of n's direction ([-1, 1]²; FLAT_NORMAL twice for zero).
// Mirrored by vlf_gpu::render::attributes::oct_encode.
fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let s = abs(n.x) + abs(n.y) + abs(n.z);
    if !(s > 0.0) {
        return vec2<f32>(FLAT_NORMAL);
    }
    let p = n.xy / s;
    if n.z >= 0.0 {
        return p;
    }
    return (vec2<f32>(1.0) - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
}

// The unit direction of octahedral coordinates o (zero for FLAT_NORMAL).
// Mirrored by vlf_gpu::render::attributes::oct_decode.
fn oct_decode(o: vec2<f32>) -> vec3<f32> {
    if o.x > 2.0 {
        return vec3<f32>(0.0);
    }
    var n = vec3<f32>(o.x, o.y, 1.0 - abs(o.x) - abs(o.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

// What pass 4b stores of a pixel's interpolated entries a = [n, t.x], b = [c, t.y] and
// correction e.
struct PackedSurface {
    a: vec4<f32>,
    w: vec4<u32>,
}

fn pack_surface(a: vec4<f32>, b: vec4<f32>, e: vec3<f32>) -> PackedSurface {
    return PackedSurface(
        vec4<f32>(oct_encode(a.xyz), a.w, b.w),
        vec4<u32>(pack_colour(b.xyz), bitcast<vec3<u32>>(e)),
    );
}

// A colour in [0, 1] as three 10-bit unorm values (r in the low bits; rounded half to even).
// Mirrored by vlf_gpu::render::attributes::pack_colour.
fn pack_colour(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(round(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 1023.0));
    return q.x | (q.y << 10u) | (q.z << 20u);
}

fn unpack_colour(w: u32) -> vec3<f32> {
    return vec3<f32>(f32(w & 1023u), f32((w >> 10u) & 1023u), f32((w >> 20u) & 1023u)) / 1023.0;
}
