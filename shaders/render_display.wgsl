// Display: shows one render pass's output (the debug view, g.view) on a colour target — the
// window's surface, a screenshot or a debug still. Not one of the five passes; it only
// visualises them. (For the final image the window skips this pass: pass 5 writes the surface
// itself, see render_final_radiance.wgsl's fs_present.)
//
// view 0 direction ids: a colour per sphere triangle (hash of its index);
// view 1 barycentrics: rgb = the three weights;
// view 2 face id: a colour per face (hash), black where no face;
// view 3 position: VLF position mapped from [-1, 1] to [0, 1], black where no face;
// view 4 final radiance: g.exposure, then g.tonemap (0 none, 1 clamp, 2 ACES).
// g.encode_srgb = 1 applies the sRGB transfer function (targets without an *Srgb format).

// Per-frame globals shared by every render pass (mirrors vlf_gpu::layout::RenderGlobals).
struct RenderGlobals {
    view_proj: mat4x4<f32>,
    dir_view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    sky: vec4<f32>,
    width: u32,
    height: u32,
    sample_index: u32,
    sample_count: u32,
    sample_weight: f32,
    face_count: u32,
    view: u32,
    tonemap: u32,
    exposure: f32,
    encode_srgb: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> g: RenderGlobals;

@group(1) @binding(0) var direction_ids: texture_2d<u32>;
@group(1) @binding(1) var barycentrics: texture_2d<f32>;
@group(1) @binding(2) var face_ids: texture_2d<u32>;
@group(1) @binding(3) var positions: texture_2d<f32>;
// Pass 5's radiance of the current frame (rgb).
@group(1) @binding(4) var radiance: texture_2d<f32>;

const NO_FACE: u32 = 0xffffffffu;

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the viewport.
    let x = f32(i32(vi & 1u) * 4 - 1);
    let y = f32(i32(vi >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn hash_colour(x: u32) -> vec3<f32> {
    let h = hash(x);
    let c = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    return 0.2 + 0.8 * c;
}

// ---- begin display mapping (identical in render_final_radiance.wgsl; a unit test checks) ----
// Narkowicz's fitted ACES filmic curve with his 0.6 pre-exposure: the same curve as
// vlf_core::image::aces (PNG stills, HDR-FLIP), so the window shows what a PNG would.
fn aces(v: vec3<f32>) -> vec3<f32> {
    let x = max(v, vec3<f32>(0.0)) * 0.6;
    let y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    return clamp(y, vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(max(c, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

// Radiance → displayed colour: exposure, tonemap.
fn tonemap(radiance: vec3<f32>) -> vec3<f32> {
    let l = radiance * g.exposure;
    if g.tonemap == 1u {
        return clamp(l, vec3<f32>(0.0), vec3<f32>(1.0));
    } else if g.tonemap == 2u {
        return aces(l);
    }
    return l;
}

// Colour → target encoding.
fn encode(c: vec3<f32>) -> vec4<f32> {
    if g.encode_srgb != 0u {
        return vec4<f32>(srgb_encode(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0))), 1.0);
    }
    return vec4<f32>(c, 1.0);
}
// ---- end display mapping ----

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let px = min(vec2<u32>(frag.xy), vec2<u32>(g.width - 1u, g.height - 1u));
    let ip = vec2<i32>(px);
    var c = vec3<f32>(0.0);
    switch g.view {
        case 0u: {
            c = hash_colour(textureLoad(direction_ids, ip, 0).w);
        }
        case 1u: {
            c = textureLoad(barycentrics, ip, 0).xyz;
        }
        case 2u: {
            let f = textureLoad(face_ids, ip, 0).r;
            if f != NO_FACE {
                c = hash_colour(f);
            }
        }
        case 3u: {
            let p = textureLoad(positions, ip, 0);
            if p.w > 0.0 {
                c = p.xyz * 0.5 + 0.5;
            }
        }
        default: {
            c = tonemap(textureLoad(radiance, ip, 0).rgb);
        }
    }
    return encode(c);
}
