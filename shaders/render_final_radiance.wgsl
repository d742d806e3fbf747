// Render pass 5 of 5 (paper §4): final radiance. Entry points:
// * vs_main + fs_main (stills, debug views): one fragment per pixel (a triangle covering the
//   viewport) reading pass 3's face id and pass 4's position and uv, writing the radiance target.
// * vs_surface + fs_surface, vs_main + fs_sky (the window's final image): pass 4 fused into
//   this pass. The scene's triangles are drawn again against pass 3's depth (greater or equal,
//   no writes), each fragment with its position and uv interpolated as pass 4 interpolates them
//   and its face record as flat varyings read once per vertex, and write the exposed,
//   tonemapped colour onto the window's surface; fs_sky draws the background (the viewport
//   triangle at depth 0, test "greater or equal": the pixels no face covers, reverse-Z). Same values as fs_main, with
//   4 texel fetches per diffuse pixel instead of 11 (vlf_gpu::render::final_radiance).
// Per-pixel data is read from textures, not storage buffers (much faster on lavapipe); the
// face records and the atlas are linear arrays wrapped into texture rows (see
// crates/vlf-gpu/src/render/upload.rs for their layout).
//
// * No face (pass 3 = u32::MAX): the bake's sky radiance.
// * Every face, on the side facing the camera (side 0 = front/normal side):
//     L = Le(uv) [side 0 only] + ρ_d(uv) / π · E
//   E is the atlas irradiance read bilinearly at the pass-4 position. The chart is a width ×
//   height grid of square texels of edge texel_size on the face's (origin, u, v) basis; texel
//   centres sit at (i + 0.5, j + 0.5) · texel_size. Bilinear weights are taken in chart
//   coordinates with the texel indices clamped to the chart (clamp-to-edge), so filtering never
//   crosses into another face's or side's texels. Uncovered texels (outside the polygon) are
//   filled by the bake's dilation, so plain bilinear filtering is correct at polygon edges.
//   ρ_d / π (diffuse weight × base colour / π, 0 for mirrors) and Le (the emission factor) come
//   with the face record; a base-colour or emissive texture multiplies them, looked up at the
//   pixel's uv (pass 4's second target) bilinearly with its wrap modes (common/texture.wgsl).
//   Flags in the face record skip what a face does not need: faces without a diffuse part read
//   no atlas, untextured faces no uv and no texel, non-emitters no emission.
// * Mirror / mixed faces (kind 1, 2) add the specular part from the sparse per-direction
//   tiles: radiance towards the eye travels
//   against the view ray, so the three sphere vertices of pass 1 are taken in the opposite
//   sense, with the pass-2 weights; for each, the position maps into that direction's ray grid
//   and the tile values of the covered cells around it are filtered bilinearly.
//
// * With tracing (pipeline constant TRACING; vlf_gpu::render::mirror_trace has the rules and
//   their CPU specification), mirror and mixed faces trace the reflected view ray through the
//   scene's BVH instead (common/bvh.wgsl), following further mirrors up to MIRROR_DEPTH
//   mirrors, and read at the first diffuse face what this pass reads at a visible point there
//   (surface_radiance_uv), or the sky; a chain cut off by the bound or ending on a mixed face
//   falls back to the visible face's tiles. A glossy visible face (GGX α > 0 in its record)
//   traces LOBE_SAMPLES directions of its lobe per sample instead of the one mirror direction
//   (traced_specular); the share of them cut off reads the tiles.
//
// Output: this sample's radiance (rgb; a = 1 where a face is seen) in `radiance_out`. Stills
// with several jittered samples (sample_count > 1) also accumulate it into `accum` with weight
// sample_weight (sample 0 overwrites, later samples add), so after sample_count samples each
// pixel holds the mean over its square.
//
// Per-corner attributes (pipeline constant ATTRIBUTES; light fields with shading normals, vertex
// colours or a texture read with TEXCOORD_1; common/surface_attributes.wgsl): the visible point's
// interpolated normal, colour, TEXCOORD_1 and irradiance correction come from pass 4b's targets
// (fs_main) or as varyings (fs_surface), a traced hit's from the corner attributes
// (chain_surface); face flags say which faces use them. Vertex colours multiply ρ_d and the
// mirror reflectance after the base-colour texture; each texture reads the set its material
// names; on faces with smooth triangles the correction is added to the atlas's irradiance, which
// makes it continuous across the faces' edges (vlf_gpu::render::attributes); smooth mirrors and
// glossy lobes reflect about the interpolated normal, and a reflection below the geometric
// surface is black (vlf_gpu::render::mirror_trace).
//
// In the window (fs_surface), textured light fields are drawn in two parts where the device
// has a stencil for it (vlf_gpu::render::final_radiance): pixels showing a textured face (pass
// 3 marked them in the stencil) with the texture code, the others without (BASE_TEXTURES and
// EMISSIVE_TEXTURES false), so that only they pay for it: llvmpipe runs divergent branches
// under a mask, but skips a block of pixels that all fail the stencil test.

#import "common/render_globals.wgsl"
#import "common/fullscreen.wgsl"
#import "common/display_mapping.wgsl"
#import "common/texture.wgsl"
#import "common/bvh.wgsl"
#import "common/bake_scene.wgsl"
#import "common/mirror_tiles.wgsl"
#import "common/sampling.wgsl"
#import "common/hash.wgsl"
#import "common/pane.wgsl"
#import "common/surface_attributes.wgsl"

// Group 0: `g` (common/render_globals.wgsl). Group 1, bindings 0 and 1: the mirror-tracing
// BVH's nodes and triangles (common/bvh.wgsl; triangle `material` = face, `prim` = triangle).

const FACE_DIFFUSE: u32 = 0u;
const FACE_MIRROR: u32 = 1u;
// Must match upload.rs (ATLAS_WIDTH: common/mirror_tiles.wgsl).
const FACE_RECORD_TEXELS: u32 = 8u;
const FACES_PER_ROW: u32 = 1024u;
// Face flags (bits of the face record's texel 0 w above the kind).
const KIND_MASK: u32 = 0xffu;
const FLAG_DIFFUSE: u32 = 0x100u;
const FLAG_BASE_TEXTURE: u32 = 0x200u;
const FLAG_EMISSIVE: u32 = 0x400u;
const FLAG_EMISSIVE_TEXTURE: u32 = 0x800u;
const FLAG_SMOOTH: u32 = 0x1000u;
const FLAG_COLORS: u32 = 0x2000u;
const FLAG_BASE_UV1: u32 = 0x4000u;
const FLAG_EMISSIVE_UV1: u32 = 0x8000u;
const FLAG_PANE: u32 = 0x10000u;
// Whether the light field has per-corner attributes (see the header); false compiles their
// reads out.
override ATTRIBUTES: bool = false;
// Whether the pixels this pipeline shades may show base-colour / emissive textures. Pipeline
// constants rather than flags: llvmpipe runs divergent branches under a mask at every pixel, so
// texture code no pixel needs is compiled out instead of skipped.
override BASE_TEXTURES: bool = true;
override EMISSIVE_TEXTURES: bool = true;
// Whether the pixels this pipeline shades may show mirror or mixed faces (false compiles the
// tile and tracing code out).
override SPECULAR: bool = true;
// Whether mirror and mixed faces trace their reflection (see the header); false compiles the
// traversal out.
override TRACING: bool = false;
// Whether the light field has alpha masks: fs_surface then discards the fragments they cut, as
// passes 3 and 4 do (a masked triangle's fragment in front of what pass 3 kept would pass the
// "greater or equal" test).
override MASKS: bool = false;
// Mirrors a traced chain follows, the visible one included (vlf_gpu::render::mirror_trace::
// MAX_DEPTH, a Rust test checks).
const MIRROR_DEPTH: u32 = 8u;
// Directions a glossy pixel traces per sample of pass 5 (vlf_gpu::render::mirror_trace::
// LOBE_SAMPLES, a Rust test checks).
const LOBE_SAMPLES: u32 = 4u;

@group(1) @binding(13) var direction_ids: texture_2d<u32>;
@group(1) @binding(14) var barycentrics: texture_2d<f32>;
@group(1) @binding(2) var face_ids: texture_2d<u32>;
@group(1) @binding(3) var positions: texture_2d<f32>;
// Face records: 8 texels per face (normal, kind | flags · origin, texel_size · u, width ·
// v, height · ρ_d/π, texel_base · Le, 0 · base-colour texture, emissive texture, 0, 0 ·
// mirror reflectance, GGX α), floats as bits. Also read by vs_surface.
@group(1) @binding(4) var face_records: texture_2d<u32>;
// Irradiance per atlas texel (rgb; a unused), both sides of every face, in the light field's
// stored encoding (Rgba16Float for f16 RGB, Rgb9e5Ufloat for RGB9E5): the texel fetch decodes
// it exactly, so the shader is the same for both.
@group(1) @binding(5) var atlas: texture_2d<f32>;
// Mean radiance per pixel (rgb), row-major, row 0 at the top; only for sample_count > 1.
@group(1) @binding(7) var<storage, read_write> accum: array<vec4<f32>>;
// Binding 6: alpha_masks (common/alpha_mask.wgsl, imported with common/bvh.wgsl), the light
// field's triangles' masks in its own order: the mirror BVH's `prim`, and the window's draws'
// triangles by BakeTriangle::_pad0 (which the upload sets to that index).
// Group 2: the mirror tiles (common/mirror_tiles.wgsl; see upload.rs).
// Pass 4's second target: the visible point's TEXCOORD_0.
@group(1) @binding(10) var uvs: texture_2d<f32>;
// Textures (see upload.rs): a record per texture ([first texel, width, height, wrap_s |
// wrap_t << 4]) and every texel (linear RGB, Rgba16Float), ATLAS_WIDTH wide.
@group(1) @binding(11) var texture_records: texture_2d<u32>;
@group(1) @binding(12) var texels: texture_2d<f32>;
// TEXCOORD_0 at the corners of the mirror-tracing BVH's triangles, three per triangle in leaf
// order.
@group(1) @binding(15) var<storage, read> mirror_uvs: array<vec2<f32>>;
// vs_surface only: the scene's triangles (as pass 4 binds them) and their corners' TEXCOORD_0.
@group(1) @binding(16) var<storage, read> surface_triangles: array<BakeTriangle>;
@group(1) @binding(17) var<storage, read> surface_uvs: array<vec2<f32>>;
// Pass 4b's targets: the visible point's attributes as common/surface_attributes.wgsl packs
// them.
@group(1) @binding(18) var attributes_a: texture_2d<f32>;
@group(1) @binding(19) var attributes_b: texture_2d<u32>;
// The corner attributes, CORNER_ENTRIES per corner, three corners per triangle in the light
// field's order (vlf_gpu::render::attributes::corner_attributes); the uploaded triangles and the
// mirror BVH's name their index (_pad0, prim).
@group(1) @binding(20) var<storage, read> corner_attributes: array<vec4<f32>>;

// What is interpolated at a point besides its position (vlf_gpu::render::attributes::
// PixelSurface): TEXCOORD_0, TEXCOORD_1, vertex colour, shading normal (not renormalised; zero
// on flat triangles), irradiance correction of the side seen.
struct Surface {
    uv: vec2<f32>,
    uv1: vec2<f32>,
    color: vec3<f32>,
    normal: vec3<f32>,
    irradiance: vec3<f32>,
}

fn plain_surface(uv: vec2<f32>) -> Surface {
    return Surface(uv, vec2<f32>(0.0), vec3<f32>(1.0), vec3<f32>(0.0), vec3<f32>(0.0));
}

// The surface of pass 4b's texels a, w (pack_surface) with TEXCOORD_0 uv.
fn surface_of(uv: vec2<f32>, a: vec4<f32>, w: vec4<u32>) -> Surface {
    return Surface(uv, a.zw, unpack_colour(w.x), oct_decode(a.xy), bitcast<vec3<f32>>(w.yzw));
}

// The texture coordinates of set 1 where `set1`, else set 0.
fn tex_uv(s: Surface, set1: bool) -> vec2<f32> {
    return select(s.uv, s.uv1, set1);
}

// Whether faces with flags `flags` read the per-corner attributes.
fn needs_attributes(flags: u32) -> bool {
    let any = FLAG_SMOOTH | FLAG_COLORS | FLAG_BASE_UV1 | FLAG_EMISSIVE_UV1;
    return ATTRIBUTES && (flags & any) != 0u;
}

struct Face {
    normal: vec3<f32>,
    kind: u32,
    flags: u32,
    origin: vec3<f32>,
    texel_size: f32,
    u: vec3<f32>,
    width: u32,
    v: vec3<f32>,
    height: u32,
    // Diffuse albedo factor / π.
    rho_over_pi: vec3<f32>,
    texel_base: u32,
    // Emission factor Le.
    emission: vec3<f32>,
}

fn face_texel(face: u32, k: u32) -> vec4<u32> {
    let x = (face % FACES_PER_ROW) * FACE_RECORD_TEXELS + k;
    return textureLoad(face_records, vec2<u32>(x, face / FACES_PER_ROW), 0);
}

// Texels 0–5 of a face record as a Face.
fn face_from_record(r0: vec4<u32>, r1: vec4<u32>, r2: vec4<u32>, r3: vec4<u32>, r4: vec4<u32>,
             r5: vec4<u32>) -> Face {
    return Face(
        bitcast<vec3<f32>>(r0.xyz), r0.w & KIND_MASK, r0.w & ~KIND_MASK,
        bitcast<vec3<f32>>(r1.xyz), bitcast<f32>(r1.w),
        bitcast<vec3<f32>>(r2.xyz), r2.w,
        bitcast<vec3<f32>>(r3.xyz), r3.w,
        bitcast<vec3<f32>>(r4.xyz), r4.w,
        bitcast<vec3<f32>>(r5.xyz),
    );
}

fn load_face(face: u32) -> Face {
    return face_from_record(face_texel(face, 0u), face_texel(face, 1u), face_texel(face, 2u),
        face_texel(face, 3u), face_texel(face, 4u), face_texel(face, 5u));
}

fn atlas_texel(i: u32) -> vec3<f32> {
    return textureLoad(atlas, vec2<u32>(i % ATLAS_WIDTH, i / ATLAS_WIDTH), 0).rgb;
}

fn texel_rgb(i: u32) -> vec3<f32> {
    return textureLoad(texels, vec2<u32>(i % ATLAS_WIDTH, i / ATLAS_WIDTH), 0).rgb;
}

// Texture `t` at `uv`, bilinear with its wrap modes (common/texture.wgsl). Mirrored exactly on
// the CPU by vlf_core::lightfield::Shading::sample.
fn surface_texture(t: u32, uv: vec2<f32>) -> vec3<f32> {
    let r = textureLoad(texture_records, vec2<u32>(t % ATLAS_WIDTH, t / ATLAS_WIDTH), 0);
    let first = r.x;
    let w = r.y;
    let x = texel_axis(uv.x, w, r.w & 15u);
    let y = texel_axis(uv.y, r.z, r.w >> 4u);
    let row0 = first + y.i0 * w;
    let row1 = first + y.i1 * w;
    let top = mix(texel_rgb(row0 + x.i0), texel_rgb(row0 + x.i1), x.f);
    let bottom = mix(texel_rgb(row1 + x.i0), texel_rgb(row1 + x.i1), x.f);
    return mix(top, bottom, y.f);
}

// Atlas irradiance of face `f` at plane point `p` on `side`, bilinear within the chart.
// Mirrored exactly on the CPU by vlf_gpu::render::final_radiance::atlas_irradiance.
fn atlas_irradiance(f: Face, side: u32, p: vec3<f32>) -> vec3<f32> {
    let d = p - f.origin;
    let x = dot(d, f.u) / f.texel_size - 0.5;
    let y = dot(d, f.v) / f.texel_size - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let maxi = vec2<i32>(i32(f.width) - 1, i32(f.height) - 1);
    let i0 = u32(clamp(i32(x0), 0, maxi.x));
    let i1 = u32(clamp(i32(x0) + 1, 0, maxi.x));
    let j0 = u32(clamp(i32(y0), 0, maxi.y));
    let j1 = u32(clamp(i32(y0) + 1, 0, maxi.y));
    let base = f.texel_base + side * f.width * f.height;
    let l00 = atlas_texel(base + j0 * f.width + i0);
    let l10 = atlas_texel(base + j0 * f.width + i1);
    let l01 = atlas_texel(base + j1 * f.width + i0);
    let l11 = atlas_texel(base + j1 * f.width + i1);
    return mix(mix(l00, l10, fx), mix(l01, l11, fx), fy);
}

// Specular radiance leaving face `face` at p towards the eye (against the view ray): the
// mirror tiles (common/mirror_tiles.wgsl) with pass 1's sphere vertices and pass 2's weights.
fn specular_radiance(face: u32, normal: vec3<f32>, p: vec3<f32>, px: vec2<i32>) -> vec3<f32> {
    let mf = tile_face_slot(face);
    if (mf == NO_TILE_SLOT) {
        return vec3<f32>(0.0);
    }
    let ids = textureLoad(direction_ids, px, 0).xyz;
    let wts = textureLoad(barycentrics, px, 0).xyz;
    return tile_radiance(mf, normal, p, g.eye.xyz - p, ids, wts);
}

// Whether this pipeline reads a texture for face record `f`.
fn is_textured(f: Face) -> bool {
    return (BASE_TEXTURES && (f.flags & FLAG_BASE_TEXTURE) != 0u)
        || (EMISSIVE_TEXTURES && (f.flags & FLAG_EMISSIVE_TEXTURE) != 0u);
}

// Le(uv) [side 0] + ρ_d(uv) / π · E of face `face` (record `f`) at `p` with attributes `s` on
// `side`. Mirrored exactly on the CPU by vlf_gpu::render::final_radiance::surface_radiance.
fn surface_radiance_uv(face: u32, f: Face, side: u32, p: vec3<f32>, s: Surface) -> vec3<f32> {
    var tex = vec2<u32>(0u);
    if is_textured(f) {
        tex = face_texel(face, 6u).xy;
    }
    var l = vec3<f32>(0.0);
    if (f.flags & FLAG_DIFFUSE) != 0u {
        var rho = f.rho_over_pi;
        if BASE_TEXTURES && (f.flags & FLAG_BASE_TEXTURE) != 0u {
            rho = rho * surface_texture(tex.x, tex_uv(s, (f.flags & FLAG_BASE_UV1) != 0u));
        }
        if ATTRIBUTES && (f.flags & FLAG_COLORS) != 0u {
            rho = rho * s.color;
        }
        var e = atlas_irradiance(f, side, p);
        if ATTRIBUTES && (f.flags & FLAG_SMOOTH) != 0u {
            // Never below zero (vlf_gpu::render::final_radiance::surface_radiance).
            e = max(e + s.irradiance, vec3<f32>(0.0));
        }
        l = rho * e;
    }
    if side == 0u && (f.flags & FLAG_EMISSIVE) != 0u {
        var le = f.emission;
        if EMISSIVE_TEXTURES && (f.flags & FLAG_EMISSIVE_TEXTURE) != 0u {
            le = le * surface_texture(tex.y, tex_uv(s, (f.flags & FLAG_EMISSIVE_UV1) != 0u));
        }
        l = l + le;
    }
    return l;
}

// The metal lobe's reflectance of face `face` (record `f`) at a point with attributes `s`: its
// specular weight × base colour × base-colour texture × vertex colour (C of the glTF metal
// lobe). Mirrored on the CPU by vlf_gpu::render::mirror_trace::specular_reflectance.
fn specular_reflectance(face: u32, f: Face, s: Surface) -> vec3<f32> {
    var c = bitcast<vec3<f32>>(face_texel(face, 7u).xyz);
    if BASE_TEXTURES && (f.flags & FLAG_BASE_TEXTURE) != 0u {
        c = c * surface_texture(face_texel(face, 6u).x, tex_uv(s, (f.flags & FLAG_BASE_UV1) != 0u));
    }
    if ATTRIBUTES && (f.flags & FLAG_COLORS) != 0u {
        c = c * s.color;
    }
    return c;
}

// The unit normal face record `f` reflects about at a point with attributes `s`, turned to
// `side` (the geometric normal of the side the ray comes from), in xyz, and w = 1 where it is
// the point's own shading normal (vlf_gpu::render::final_radiance::shading_normal).
fn shading_normal(f: Face, s: Surface, side: vec3<f32>) -> vec4<f32> {
    if !ATTRIBUTES || (f.flags & FLAG_SMOOTH) == 0u || dot(s.normal, s.normal) <= 0.0 {
        return vec4<f32>(side, 0.0);
    }
    let m = normalize(s.normal);
    return vec4<f32>(select(m, -m, dot(m, side) < 0.0), 1.0);
}

// The surface of a traced hit on the mirror BVH's triangle `hit.tri` (record `hf`) seen from
// `side`: its TEXCOORD_0 from the leaf-order uvs (textured faces), its other attributes from the
// corner attributes (faces that read them) (vlf_gpu::render::attributes::PixelSurface::
// of_triangle).
fn chain_surface(hit: Hit, prim: u32, hf: Face, side: u32) -> Surface {
    let b0 = 1.0 - hit.u - hit.v;
    var s = plain_surface(vec2<f32>(0.0));
    if is_textured(hf) {
        let k = 3u * hit.tri;
        s.uv = mirror_uvs[k] * b0 + mirror_uvs[k + 1u] * hit.u + mirror_uvs[k + 2u] * hit.v;
    }
    if needs_attributes(hf.flags) {
        let k = 3u * CORNER_ENTRIES * prim;
        let c1 = k + CORNER_ENTRIES;
        let c2 = k + 2u * CORNER_ENTRIES;
        let a = corner_attributes[k] * b0 + corner_attributes[c1] * hit.u
            + corner_attributes[c2] * hit.v;
        let b = corner_attributes[k + 1u] * b0 + corner_attributes[c1 + 1u] * hit.u
            + corner_attributes[c2 + 1u] * hit.v;
        let j = 2u + side;
        let e = corner_attributes[k + j] * b0 + corner_attributes[c1 + j] * hit.u
            + corner_attributes[c2 + j] * hit.v;
        s = Surface(s.uv, vec2<f32>(a.w, b.w), b.xyz, a.xyz, e.xyz);
    }
    return s;
}

// The radiance (rgb) the traced chain brings back along `dir` from `origin`, a point of the
// visible non-diffuse face, times `throughput`; w = 1 where the chain is cut off (by the depth
// bound or on a mixed face) and the pixel falls back to its tiles. Mirrored on the CPU by
// vlf_gpu::render::mirror_trace::trace_chain.
fn trace_chain(origin0: vec3<f32>, dir0: vec3<f32>, throughput0: vec3<f32>) -> vec4<f32> {
    var origin = origin0;
    var dir = dir0;
    var throughput = throughput0;
    var depth = 1u;
    // The diffuse part of panes passed on the way.
    var seen = vec3<f32>(0.0);
    loop {
        let hit = trace(Ray(origin, 0.0, dir, 3.40282347e38), false);
        if hit.tri == NONE {
            return vec4<f32>(seen + throughput * g.sky.rgb, 0.0);
        }
        let t = triangles[hit.tri];
        let hface = t.material;
        let b0 = 1.0 - hit.u - hit.v;
        let q = t.p0 * b0 + t.p1 * hit.u + t.p2 * hit.v;
        let hf = load_face(hface);
        let n = hf.normal;
        let hside = select(1u, 0u, dot(n, -dir) >= 0.0);
        let hs = chain_surface(hit, t.prim, hf, hside);
        if (hf.flags & FLAG_PANE) != 0u && depth < MIRROR_DEPTH {
            // A pane along the chain: its diffuse part, then on straight through it.
            seen = seen + throughput * surface_radiance_uv(hface, hf, hside, q, hs);
            let ior = bitcast<f32>(face_texel(hface, 6u).z);
            throughput = throughput
                * (specular_reflectance(hface, hf, hs) * (1.0 - pane_reflectance(dot(dir, n), ior)));
            origin = offset_origin(q, select(-n, n, dot(n, dir) > 0.0));
            depth += 1u;
            continue;
        }
        if hf.kind == FACE_DIFFUSE {
            return vec4<f32>(seen + throughput * surface_radiance_uv(hface, hf, hside, q, hs), 0.0);
        }
        if hf.kind != FACE_MIRROR || depth >= MIRROR_DEPTH {
            return vec4<f32>(seen, 1.0);
        }
        throughput = throughput * specular_reflectance(hface, hf, hs);
        let off = select(-n, n, dot(n, -dir) > 0.0);
        let ns = shading_normal(hf, hs, off);
        dir = normalize(dir - 2.0 * dot(dir, ns.xyz) * ns.xyz);
        if ns.w > 0.0 && dot(dir, off) <= 0.0 {
            return vec4<f32>(0.0);
        }
        origin = offset_origin(q, off);
        depth += 1u;
    }
    return vec4<f32>(0.0, 0.0, 0.0, 1.0);
}

// Sample point k of pixel `pixel`'s lobe directions: the R2 sequence (Roberts 2018) shifted by
// a per-pixel hash (Cranley–Patterson rotation), so that a pixel's points over all its samples
// stay evenly spread and neighbouring pixels' errors do not line up. Mirrored on the CPU by
// vlf_gpu::render::mirror_trace::lobe_point.
fn lobe_point(pixel: u32, k: u32) -> vec2<f32> {
    let h = pcg_hash(pixel);
    let shift = vec2<f32>(f32(h & 0xffffu), f32(h >> 16u)) * (1.0 / 65536.0);
    let x = shift + f32(k) * vec2<f32>(0.7548777, 0.5698403);
    return x - floor(x);
}

// The specular radiance (rgb) reaching the eye from point `p` of non-diffuse face `face`
// (record `f`, attributes `s` at p); w = the share of it that falls back to the pixel's tiles
// instead. A perfect mirror (GGX α 0) traces its reflected view ray; a glossy lobe traces
// LOBE_SAMPLES directions drawn from its visible normals (points `first` … of pixel `pixel`'s
// sequence), each weighing C · G1(wi) (f cos / pdf of the lobe, no Fresnel). A smooth point
// reflects about its shading normal; a direction below the geometric surface is black.
// Mirrored on the CPU by vlf_gpu::render::mirror_trace::traced_specular.
fn traced_specular(face: u32, f: Face, p: vec3<f32>, s: Surface, pixel: u32,
                   first: u32) -> vec4<f32> {
    let d = normalize(p - g.eye.xyz);
    let n = f.normal;
    let side = select(-n, n, dot(n, g.eye.xyz - p) >= 0.0);
    let sn = shading_normal(f, s, side);
    let ns = sn.xyz;
    let own = sn.w > 0.0;
    let c = specular_reflectance(face, f, s);
    let origin = offset_origin(p, side);
    if (f.flags & FLAG_PANE) != 0u {
        // A pane: its reflection (pane weight × R, untinted) and what lies behind it (c × T);
        // the tiles stand in for the reflection only.
        let pane = face_texel(face, 6u);
        let r = pane_reflectance(dot(d, n), bitcast<f32>(pane.z));
        let reflected = trace_chain(origin, normalize(d - 2.0 * dot(d, n) * n),
            vec3<f32>(bitcast<f32>(pane.w) * r));
        let passed = trace_chain(offset_origin(p, -side), d, c * (1.0 - r));
        return vec4<f32>(reflected.rgb + passed.rgb, reflected.w);
    }
    let alpha = bitcast<f32>(face_texel(face, 7u).w);
    if alpha <= 0.0 {
        let r = normalize(d - 2.0 * dot(d, ns) * ns);
        if own && dot(r, side) <= 0.0 {
            return vec4<f32>(0.0);
        }
        return trace_chain(origin, r, c);
    }
    let wo = to_local(-d, ns);
    if own && wo.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < LOBE_SAMPLES; k += 1u) {
        let wi = reflect_about(wo, ggx_sample_vndf(wo, alpha, lobe_point(pixel, first + k)));
        if wi.z > 0.0 {
            let dir = normalize(to_world(wi, ns));
            if !(own && dot(dir, side) <= 0.0) {
                sum += trace_chain(origin, dir, c * ggx_g1(wi.z, alpha));
            }
        }
    }
    return sum * (1.0 / f32(LOBE_SAMPLES));
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_vertex(vi);
}

// The radiance towards the eye of the visible point `p` of face `face` (record `f`) at pixel
// `px`, `s` its interpolated attributes (TEXCOORD_0 used only for textured faces, the others
// only where the face's flags ask).
fn shade_surface(face: u32, f: Face, p: vec3<f32>, s: Surface, px: vec2<i32>) -> vec3<f32> {
    // The side facing the camera: front (0) when the eye is on the normal's side.
    let side = select(1u, 0u, dot(f.normal, g.eye.xyz - p) >= 0.0);
    var l = surface_radiance_uv(face, f, side, p, s);
    if SPECULAR && f.kind != FACE_DIFFUSE {
        var traced = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        if TRACING {
            let pixel = u32(px.y) * g.width + u32(px.x);
            traced = traced_specular(face, f, p, s, pixel, g.sample_index * LOBE_SAMPLES);
        }
        l += traced.rgb;
        if traced.w != 0.0 {
            l += traced.w * specular_radiance(face, f.normal, p, px);
        }
    }
    return l;
}

// One pixel from the targets of passes 3 and 4.
fn shade(frag: vec4<f32>) -> vec4<f32> {
    let pu = vec2<u32>(frag.xy);
    let px = vec2<i32>(pu);
    let face = textureLoad(face_ids, px, 0).r;
    var l = g.sky.rgb;
    var hit = 0.0;
    if face != NO_FACE && face < g.face_count {
        let p = textureLoad(positions, px, 0).xyz;
        let f = load_face(face);
        var s = plain_surface(vec2<f32>(0.0));
        if is_textured(f) {
            s.uv = textureLoad(uvs, px, 0).xy;
        }
        if needs_attributes(f.flags) {
            s = surface_of(s.uv, textureLoad(attributes_a, px, 0), textureLoad(attributes_b, px, 0));
        }
        l = shade_surface(face, f, p, s, px);
        hit = 1.0;
    }
    return vec4<f32>(l, hit);
}

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let sample = shade(frag);
    if g.sample_count > 1u {
        let pu = vec2<u32>(frag.xy);
        let i = pu.y * g.width + pu.x;
        if g.sample_index == 0u {
            accum[i] = sample * g.sample_weight;
        } else {
            accum[i] = accum[i] + sample * g.sample_weight;
        }
    }
    return sample;
}

// The window's colour of radiance `l` (exposed, tonemapped, encoded).
fn present(l: vec3<f32>) -> vec4<f32> {
    return encode(tonemap(l, g.exposure, g.tonemap), g.encode_srgb);
}

// A vertex of the scene for the window's final image: what pass 4 interpolates (the same
// corners and transform, so the depths equal pass 3's) and the face record, flat.
struct SurfaceVertex {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) position: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) @interpolate(flat) face: u32,
    @location(3) @interpolate(flat) r0: vec4<u32>,
    @location(4) @interpolate(flat) r1: vec4<u32>,
    @location(5) @interpolate(flat) r2: vec4<u32>,
    @location(6) @interpolate(flat) r3: vec4<u32>,
    @location(7) @interpolate(flat) r4: vec4<u32>,
    @location(8) @interpolate(flat) r5: vec4<u32>,
    // The corner attributes (zero without ATTRIBUTES): entries 0 and 1 and the correction of
    // the side the eye sees.
    @location(9) attr_a: vec4<f32>,
    @location(10) attr_b: vec4<f32>,
    @location(11) attr_e: vec3<f32>,
    // The triangle's index in the light field (alpha masks).
    @location(12) @interpolate(flat) tri: u32,
}

@vertex
fn vs_surface(@builtin(vertex_index) vi: u32) -> SurfaceVertex {
    let tri = surface_triangles[vi / 3u];
    let p = corner_position(tri, vi % 3u);
    let face = tri.face;
    var out: SurfaceVertex;
    out.clip = g.view_proj * vec4<f32>(p, 1.0);
    out.position = p;
    out.uv = surface_uvs[vi];
    out.face = face;
    out.tri = tri._pad0;
    out.r0 = face_texel(face, 0u);
    out.r1 = face_texel(face, 1u);
    out.r2 = face_texel(face, 2u);
    out.r3 = face_texel(face, 3u);
    out.r4 = face_texel(face, 4u);
    out.r5 = face_texel(face, 5u);
    out.attr_a = vec4<f32>(0.0);
    out.attr_b = vec4<f32>(0.0);
    out.attr_e = vec3<f32>(0.0);
    if ATTRIBUTES {
        let k = CORNER_ENTRIES * (3u * tri._pad0 + vi % 3u);
        out.attr_a = corner_attributes[k];
        out.attr_b = corner_attributes[k + 1u];
        out.attr_e = corner_attributes[k + correction_entry(tri, g.eye.xyz)].xyz;
    }
    return out;
}

// The window's final image where a face is seen (pass 4 fused into pass 5, see the header).
// Writes only its colour target, so the depth and stencil tests run before it.
@fragment
fn fs_surface(in: SurfaceVertex) -> @location(0) vec4<f32> {
    if MASKS && alpha_cuts_uv(in.tri, in.uv) {
        discard;
    }
    let f = face_from_record(in.r0, in.r1, in.r2, in.r3, in.r4, in.r5);
    let px = vec2<i32>(vec2<u32>(in.clip.xy));
    var s = plain_surface(in.uv);
    if needs_attributes(f.flags) {
        // Packed and unpacked as pass 4b stores them, so the window shades with the stills' bits.
        let packed = pack_surface(in.attr_a, in.attr_b, in.attr_e);
        s = surface_of(in.uv, packed.a, packed.w);
    }
    return present(shade_surface(in.face, f, in.position, s, px));
}

// The window's final image where no face is seen: the sky, as fs_main shades it.
@fragment
fn fs_sky() -> @location(0) vec4<f32> {
    return present(g.sky.rgb);
}
