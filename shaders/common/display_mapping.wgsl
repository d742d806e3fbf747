// Radiance → displayed colour → target encoding: the display pass's final-radiance view and the
// window's fused display in pass 5 map alike, and like the PNG stills of vlf_core::image.

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

// Radiance → displayed colour: a linear `exposure` factor, then `mode`
// (vlf_gpu::render::Tonemap: 0 none, 1 clamp, 2 ACES).
fn tonemap(radiance: vec3<f32>, exposure: f32, mode: u32) -> vec3<f32> {
    let l = radiance * exposure;
    if mode == 1u {
        return clamp(l, vec3<f32>(0.0), vec3<f32>(1.0));
    } else if mode == 2u {
        return aces(l);
    }
    return l;
}

// Colour → target encoding; `srgb` != 0 for targets without an *Srgb format.
fn encode(c: vec3<f32>, srgb: u32) -> vec4<f32> {
    if srgb != 0u {
        return vec4<f32>(srgb_encode(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0))), 1.0);
    }
    return vec4<f32>(c, 1.0);
}
