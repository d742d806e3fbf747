// Per-path (or per-texel) random streams: PCG-RXS-M-XS 32/32 with an odd per-stream increment,
// seeded by hashing (seed, sample, pixel). Mirrors vlf_core::pathtrace::sampling::Rng exactly
// (integer arithmetic), so the GPU path tracer and the GPU final gather draw the numbers of the
// CPU's streams.

#import "common/hash.wgsl"

// Generator state (mirrors vlf_core::pathtrace::sampling::Rng).
struct Rng {
    state: u32,
    inc: u32,
}

// Next 32 random bits.
fn rng_next(r: ptr<function, Rng>) -> u32 {
    let old = (*r).state;
    (*r).state = old * 747796405u + (*r).inc;
    let word = ((old >> ((old >> 28u) + 4u)) ^ old) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) with 24 bits of resolution.
fn rng_f32(r: ptr<function, Rng>) -> f32 {
    return f32(rng_next(r) >> 8u) * (1.0 / 16777216.0);
}

fn rng_2d(r: ptr<function, Rng>) -> vec2<f32> {
    let x = rng_f32(r);
    return vec2<f32>(x, rng_f32(r));
}

// The stream of sample `sample` of pixel `pixel` under `seed` (Rng::for_path).
fn rng_for_path(seed: u32, pixel: u32, sample: u32) -> Rng {
    let a = pcg_hash(seed ^ 0x9e3779b9u);
    let b = pcg_hash(a ^ sample);
    let state = pcg_hash(b ^ (pixel * 0x85ebca6bu));
    var r = Rng(state, (pcg_hash(state ^ 0x68e31da4u) << 1u) | 1u);
    rng_next(&r);
    return r;
}
