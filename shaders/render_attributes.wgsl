// Render pass 4b (after pass 4, for light fields with per-corner attributes only): the shading
// normal, vertex colour, TEXCOORD_1 and irradiance correction (vlf_gpu::render::attributes) of
// the visible surface, interpolated from the corners (perspective-correct) as pass 4
// interpolates position and TEXCOORD_0, into two targets as common/surface_attributes.wgsl packs
// them (the normal's direction, zero on flat triangles: pass 5 then uses the face's normal; the
// correction of the side the eye sees). Reuses pass 3's depth buffer (test "greater or equal", no depth writes); the targets
// are read by pass 5 only where a face is seen whose flags ask for them, so they are not
// cleared. Light fields with alpha masks draw with vs_masked + fs_masked, which discard what
// pass 3 discarded (render_face_id.wgsl).

#import "common/render_globals.wgsl"
#import "common/bake_scene.wgsl"
#import "common/surface_attributes.wgsl"
#import "common/alpha_mask.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

// The scene's triangles; `_pad0` holds each one's index in the light field's triangle order.
@group(1) @binding(0) var<storage, read> triangles: array<BakeTriangle>;
// CORNER_ENTRIES per corner, three corners per triangle in the light field's order.
@group(1) @binding(1) var<storage, read> corner_attributes: array<vec4<f32>>;
// TEXCOORD_0 per triangle corner (three per triangle, in triangle order): the masks read it.
@group(1) @binding(2) var<storage, read> corner_uvs: array<vec2<f32>>;
// Binding 6: alpha_masks (common/alpha_mask.wgsl; vs_masked, fs_masked).

struct AttributesOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) a: vec4<f32>,
    @location(1) b: vec4<f32>,
    @location(2) e: vec3<f32>,
}

struct AttributesTargets {
    @location(0) a: vec4<f32>,
    @location(1) w: vec4<u32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> AttributesOut {
    return attributes_out(vi);
}

// What both vertex stages output for vertex `vi` (an entry point cannot be called).
fn attributes_out(vi: u32) -> AttributesOut {
    let tri = triangles[vi / 3u];
    let p = corner_position(tri, vi % 3u);
    let k = CORNER_ENTRIES * (3u * tri._pad0 + vi % 3u);
    var out: AttributesOut;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.a = corner_attributes[k];
    out.b = corner_attributes[k + 1u];
    out.e = corner_attributes[k + correction_entry(tri, g.eye.xyz)].xyz;
    return out;
}

@fragment
fn fs_main(in: AttributesOut) -> AttributesTargets {
    let packed = pack_surface(in.a, in.b, in.e);
    return AttributesTargets(packed.a, packed.w);
}

struct MaskedAttributesOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) a: vec4<f32>,
    @location(1) b: vec4<f32>,
    @location(2) e: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) @interpolate(flat) tri: u32,
}

@vertex
fn vs_masked(@builtin(vertex_index) vi: u32) -> MaskedAttributesOut {
    let plain = attributes_out(vi);
    var out: MaskedAttributesOut;
    out.clip = plain.clip;
    out.a = plain.a;
    out.b = plain.b;
    out.e = plain.e;
    out.uv = corner_uvs[vi];
    out.tri = triangles[vi / 3u]._pad0;
    return out;
}

@fragment
fn fs_masked(in: MaskedAttributesOut) -> AttributesTargets {
    if alpha_cuts_uv(in.tri, in.uv) {
        discard;
    }
    let packed = pack_surface(in.a, in.b, in.e);
    return AttributesTargets(packed.a, packed.w);
}
