// Bilinear texture lookups with the glTF wrap modes and no mipmaps (shared/reference/README.md),
// for shaders that read surface textures (pass 5 of the renderer). Each caller fetches its own
// texels at the footprint computed here. Mirrored exactly on the CPU by
// vlf_core::lightfield::Shading::sample.
//
// No integer division: llvmpipe (lavapipe) turns a vector `%` into one scalar division per lane,
// and, executing every branch of divergent control flow under a mask, would pay for them at
// every pixel. Repeat and mirrored repeat first reduce the coordinate to one period in float
// (u − p·floor(u/p) with p = 1 or 2), which keeps the texel indices within one period of the
// texture, so that wrapping them takes comparisons only.

// Wrap mode ids (vlf_core::scene::WrapMode::id).
const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP_TO_EDGE: u32 = 1u;
const WRAP_MIRRORED_REPEAT: u32 = 2u;

// One axis of a bilinear footprint: the wrapped indices of the two texels around the sample
// point and the weight of the second.
struct TexelAxis {
    i0: u32,
    i1: u32,
    f: f32,
}

// Index `i` of a reduced coordinate (see texel_axis) wrapped into 0..n.
fn wrap_reduced(i: i32, n: i32, mode: u32) -> u32 {
    if mode == WRAP_CLAMP_TO_EDGE {
        return u32(clamp(i, 0, n - 1));
    }
    // Repeat: i in -1..=n; mirrored repeat: i in -1..=2n, period 2n, then folded.
    let period = select(n, 2 * n, mode == WRAP_MIRRORED_REPEAT);
    var m = select(i, i + period, i < 0);
    m = select(m, m - period, m >= period);
    return u32(select(m, 2 * n - 1 - m, m >= n));
}

// The footprint along one axis of texture coordinate `u` on `size` texels with wrap `mode`:
// texel coordinate x = u × size − ½ (u reduced to one period first unless clamped; x clamped to
// ±1e9 so that it converts to i32), texels floor(x) and floor(x) + 1, weight x − floor(x).
fn texel_axis(u: f32, size: u32, mode: u32) -> TexelAxis {
    var r = clamp(u, -1e9, 1e9);
    if mode != WRAP_CLAMP_TO_EDGE {
        let p = select(1.0, 2.0, mode == WRAP_MIRRORED_REPEAT);
        r = r - p * floor(r / p);
    }
    let x = clamp(r * f32(size) - 0.5, -1e9, 1e9);
    let x0 = floor(x);
    let i = i32(x0);
    let n = i32(size);
    return TexelAxis(wrap_reduced(i, n, mode), wrap_reduced(i + 1, n, mode), x - x0);
}
