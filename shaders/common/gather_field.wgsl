// What a GPU final-gather ray reads at its first hit (vlf_gpu::gather; specification:
// vlf_core::gather::field::Field): the propagation's atlas irradiance, dilated, read bilinearly
// except where the bilinear quad straddles a contact (Field::irradiance_at). The contact bits
// per texel are computed on the CPU (vlf_core::gather::field::Contacts, once per field) and
// uploaded; visibility between the (lifted) hit and texel centres is a short any-hit ray
// through the ray engine's BVH (common/bvh.wgsl), which counts in the caller's loop budget.

#import "common/bvh.wgsl"
#import "common/bake_scene.wgsl"

// Group 2, binding 6: the propagation's faces (5 entries per BakeFace, at 0), its dilated
// irradiance (rgb per texel, at FieldSections.irradiance) and its contact bits (at
// FieldSections.contacts: texel t's byte is byte t % 4, little-endian, of word (t / 4) % 4 of
// entry t / 16) in one buffer.
@group(2) @binding(6) var<storage, read> field: array<vec4<f32>>;

// Where the sections of `field` start (vec4 entries) and the world → VLF map
// ((p − xf_center) · xf_scale).
struct FieldSections {
    irradiance: u32,
    contacts: u32,
    xf_scale: f32,
    xf_center: vec3<f32>,
}

// Contact bits of a propagation texel (vlf_core::gather::field::CONTACT_*): its centre sees its
// right, upper, (+1, +1) neighbour's centre; its (+1, 0) neighbour sees its (0, +1) neighbour;
// it is cut.
const CONTACT_RIGHT: u32 = 1u;
const CONTACT_UP: u32 = 2u;
const CONTACT_DIAGONAL: u32 = 4u;
const CONTACT_ANTI_DIAGONAL: u32 = 8u;
const CONTACT_CUT: u32 = 16u;
// How far visibility rays' ends are lifted off their side (texels;
// vlf_core::gather::field::CONTACT_LIFT).
const CONTACT_LIFT: f32 = 1e-3;

fn contact_bits(at: FieldSections, t: u32) -> u32 {
    let e = bitcast<vec4<u32>>(field[at.contacts + t / 16u]);
    return (e[(t / 4u) % 4u] >> (8u * (t % 4u))) & 0xffu;
}

fn field_value(at: FieldSections, t: u32) -> vec3<f32> {
    return field[at.irradiance + t].xyz;
}

// World point p of propagation face f lifted off the side with unit normal n (Contacts::lift).
fn contact_lift(at: FieldSections, f: BakeFace, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return offset_origin(p + n * (CONTACT_LIFT * f.texel_size / at.xf_scale), n);
}

// The lifted world centre of texel t of propagation face f (Contacts::centre).
fn contact_centre(at: FieldSections, f: BakeFace, t: u32, n: vec3<f32>) -> vec3<f32> {
    let i = (t - f.texel_base) % (f.width * f.height);
    let c = vec2<f32>(f32(i % f.width) + 0.5, f32(i / f.width) + 0.5) * f.texel_size;
    let world = (f.origin + f.u * c.x + f.v * c.y) / at.xf_scale + at.xf_center;
    return contact_lift(at, f, world, n);
}

// Whether nothing lies between world points a and b (Contacts::sees).
fn contact_sees(a: vec3<f32>, b: vec3<f32>) -> bool {
    return all(a == b) || trace(Ray(a, 0.0, b - a, 1.0), true).tri == NONE;
}

// The dilated irradiance of propagation face f on `side` at plane point p (world point pw):
// vlf_core::gather::field::Field::irradiance_at. Bilinear over the four texels around p
// (indices clamped to the chart) where their quad is clear of contacts; otherwise the quad's
// uncut texels whose centres the lifted point sees (weights renormalised), then such texels
// within two texels (tent weights), then the quad's texels it sees, then the texel under it.
fn field_irradiance_at(
    at: FieldSections,
    f: BakeFace,
    side: u32,
    p: vec3<f32>,
    pw: vec3<f32>,
) -> vec3<f32> {
    let d = p - f.origin;
    let cc = vec2<f32>(dot(d, f.u), dot(d, f.v)) / f.texel_size;
    let c = cc - vec2<f32>(0.5);
    let x0 = floor(c.x);
    let y0 = floor(c.y);
    let fx = c.x - x0;
    let fy = c.y - y0;
    let wi = i32(f.width) - 1;
    let hi = i32(f.height) - 1;
    let i0 = u32(clamp(i32(x0), 0, wi));
    let i1 = u32(clamp(i32(x0 + 1.0), 0, wi));
    let j0 = u32(clamp(i32(y0), 0, hi));
    let j1 = u32(clamp(i32(y0 + 1.0), 0, hi));
    let base = f.texel_base + side * f.width * f.height;
    var texel = array<u32, 4>(
        base + j0 * f.width + i0,
        base + j0 * f.width + i1,
        base + j1 * f.width + i0,
        base + j1 * f.width + i1,
    );
    let b0 = contact_bits(at, texel[0]);
    let b1 = contact_bits(at, texel[1]);
    let b2 = contact_bits(at, texel[2]);
    let b3 = contact_bits(at, texel[3]);
    let wide = i1 > i0;
    let tall = j1 > j0;
    var clear = ((b0 | b1 | b2 | b3) & CONTACT_CUT) == 0u;
    if wide {
        clear = clear && (b0 & b2 & CONTACT_RIGHT) != 0u;
    }
    if tall {
        clear = clear && (b0 & b1 & CONTACT_UP) != 0u;
    }
    if wide && tall {
        let both = CONTACT_DIAGONAL | CONTACT_ANTI_DIAGONAL;
        clear = clear && (b0 & both) == both;
    }
    if clear {
        let top = mix(field_value(at, texel[0]), field_value(at, texel[1]), fx);
        let bottom = mix(field_value(at, texel[2]), field_value(at, texel[3]), fx);
        return mix(top, bottom, fy);
    }
    let n = select(-f.normal, f.normal, side == 0u);
    let eye = contact_lift(at, f, pw, n);
    // The quad's texels the point sees, per class (uncut, cut): Σ w·E and Σ w.
    var qsum = array<vec3<f32>, 2>(vec3<f32>(0.0), vec3<f32>(0.0));
    var qw = array<f32, 2>(0.0, 0.0);
    for (var k = 0u; k < 4u; k++) {
        let t = texel[k];
        let w = select(1.0 - fx, fx, (k & 1u) == 1u) * select(1.0 - fy, fy, (k & 2u) == 2u);
        if w > 0.0 && contact_sees(eye, contact_centre(at, f, t, n)) {
            let cls = select(0u, 1u, (contact_bits(at, t) & CONTACT_CUT) != 0u);
            qsum[cls] += field_value(at, t) * w;
            qw[cls] += w;
        }
    }
    if qw[0] > 0.0 {
        return qsum[0] / qw[0];
    }
    // Uncut texels it sees within two texels (tent weights).
    let ci = i32(floor(cc.x));
    let cj = i32(floor(cc.y));
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var j = max(cj - 2, 0); j <= min(cj + 2, hi); j++) {
        for (var i = max(ci - 2, 0); i <= min(ci + 2, wi); i++) {
            let dd = abs(vec2<f32>(f32(i) + 0.5, f32(j) + 0.5) - cc);
            let w = max(1.0 - dd.x * 0.5, 0.0) * max(1.0 - dd.y * 0.5, 0.0);
            let t = base + u32(j) * f.width + u32(i);
            if w > 0.0 && (contact_bits(at, t) & CONTACT_CUT) == 0u
                && contact_sees(eye, contact_centre(at, f, t, n)) {
                sum += field_value(at, t) * w;
                wsum += w;
            }
        }
    }
    if wsum > 0.0 {
        return sum / wsum;
    }
    if qw[1] > 0.0 {
        return qsum[1] / qw[1];
    }
    let nearest = select(0u, 1u, fx >= 0.5) | select(0u, 2u, fy >= 0.5);
    return field_value(at, texel[nearest]);
}
