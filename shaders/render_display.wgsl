// Display: shows one render pass's output (the debug view, g.view) on a colour target — the
// window's surface, a screenshot or a debug still. Not one of the five passes; it only
// visualises them. (For the final image the window skips this pass: pass 5 writes the surface
// itself, see render_final_radiance.wgsl's fs_surface and fs_sky.)
//
// view 0 direction ids: a colour per sphere triangle (hash of its index);
// view 1 barycentrics: rgb = the three weights;
// view 2 face id: a colour per face (hash), black where no face;
// view 3 position: VLF position mapped from [-1, 1] to [0, 1], black where no face;
// view 4 final radiance: g.exposure, then g.tonemap (0 none, 1 clamp, 2 ACES).
// g.encode_srgb = 1 applies the sRGB transfer function (targets without an *Srgb format).

#import "common/render_globals.wgsl"
#import "common/fullscreen.wgsl"
#import "common/display_mapping.wgsl"
#import "common/hash.wgsl"

// Group 0: `g` (common/render_globals.wgsl).

@group(1) @binding(0) var direction_ids: texture_2d<u32>;
@group(1) @binding(1) var barycentrics: texture_2d<f32>;
@group(1) @binding(2) var face_ids: texture_2d<u32>;
@group(1) @binding(3) var positions: texture_2d<f32>;
// Pass 5's radiance of the current frame (rgb).
@group(1) @binding(4) var radiance: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_vertex(vi);
}

fn hash_colour(x: u32) -> vec3<f32> {
    let h = pcg_hash(x);
    let c = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    return 0.2 + 0.8 * c;
}

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
            c = tonemap(textureLoad(radiance, ip, 0).rgb, g.exposure, g.tonemap);
        }
    }
    return encode(c, g.encode_srgb);
}
