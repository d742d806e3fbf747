// Alpha masks: where a triangle's coverage (baseColorFactor.a × the base-colour texture's alpha,
// read with the texture's filter and wrap modes) is below its material's cutoff, there is no
// surface. Mirrors vlf_core::lightfield::mask::AlphaMasks operation for operation (the
// propagation's cell lists stay bit-identical to the CPU's). The words are
// AlphaMasks::words (header [T, first record, first material, first alpha], per triangle its
// record's word offset or MASK_NONE, records [uv0, uv1, uv2, material offset, 0], materials
// [cutoff, factor, width, height, wrap_s | wrap_t << 4 | nearest << 8, first alpha or
// MASK_NONE, 0, 0], alphas as f32); without masks the header alone (T = 0).
//
// Group 1, binding 6 in every shader that imports it: the propagation's cell lists
// (bake_cells.wgsl), the BVH traversal (common/bvh.wgsl: the path tracer, the final gather,
// pass 5's mirror tracing) and the passes that rasterise the scene (pass 3, pass 5's window
// draws). Triangles are numbered as the buffer was built: the light field's (or the scene's)
// order; the BVH looks its triangles up by RtTriangle::prim.

#import "common/texture.wgsl"

const MASK_NONE: u32 = 0xffffffffu;

@group(1) @binding(6) var<storage, read> alpha_masks: array<u32>;

fn mask_f32(i: u32) -> f32 {
    return bitcast<f32>(alpha_masks[i]);
}

// The texel index along one axis under coordinate u with NEAREST filtering (reduced to one
// period as texel_axis does, floor(u × size), wrapped; vlf_core's mask::nearest_axis).
fn nearest_axis(u: f32, size: u32, mode: u32) -> u32 {
    var r = clamp(u, -1e9, 1e9);
    if mode != WRAP_CLAMP_TO_EDGE {
        let p = select(1.0, 2.0, mode == WRAP_MIRRORED_REPEAT);
        r = r - p * floor(r / p);
    }
    let x = clamp(r * f32(size), -1e9, 1e9);
    return wrap_reduced(i32(floor(x)), i32(size), mode);
}

// Whether the material entry at word `m` leaves no surface at uv (MaskMaterial::coverage below
// its cutoff).
fn mask_material_cuts(m: u32, uv: vec2<f32>) -> bool {
    let cutoff = mask_f32(m);
    let factor = mask_f32(m + 1u);
    let first = alpha_masks[m + 5u];
    if first == MASK_NONE {
        return factor < cutoff;
    }
    let w = alpha_masks[m + 2u];
    let h = alpha_masks[m + 3u];
    let modes = alpha_masks[m + 4u];
    let ws = modes & 15u;
    let wt = (modes >> 4u) & 15u;
    var a: f32;
    if (modes & 256u) != 0u {
        let i = nearest_axis(uv.x, w, ws);
        let j = nearest_axis(uv.y, h, wt);
        a = mask_f32(first + j * w + i);
    } else {
        let x = texel_axis(uv.x, w, ws);
        let y = texel_axis(uv.y, h, wt);
        let top = mask_f32(first + y.i0 * w + x.i0) * (1.0 - x.f) + mask_f32(first + y.i0 * w + x.i1) * x.f;
        let bottom = mask_f32(first + y.i1 * w + x.i0) * (1.0 - x.f) + mask_f32(first + y.i1 * w + x.i1) * x.f;
        a = top * (1.0 - y.f) + bottom * y.f;
    }
    return factor * a < cutoff;
}

// Whether triangle `tri` has no surface at glTF uv `uv` (the rasterising passes interpolate uv
// themselves).
fn alpha_cuts_uv(tri: u32, uv: vec2<f32>) -> bool {
    if tri >= alpha_masks[0] {
        return false;
    }
    let r = alpha_masks[4u + tri];
    if r == MASK_NONE {
        return false;
    }
    return mask_material_cuts(alpha_masks[r + 6u], uv);
}

// Whether triangle `tri` has no surface at barycentric weights w (of corners 0, 1, 2):
// AlphaMasks::cuts, uv = uv0·w0 + uv1·w1 + uv2·w2 in that order.
fn alpha_cuts(tri: u32, w: vec3<f32>) -> bool {
    if tri >= alpha_masks[0] {
        return false;
    }
    let r = alpha_masks[4u + tri];
    if r == MASK_NONE {
        return false;
    }
    let u = mask_f32(r) * w.x + mask_f32(r + 2u) * w.y + mask_f32(r + 4u) * w.z;
    let v = mask_f32(r + 1u) * w.x + mask_f32(r + 3u) * w.y + mask_f32(r + 5u) * w.z;
    return mask_material_cuts(alpha_masks[r + 6u], vec2<f32>(u, v));
}
