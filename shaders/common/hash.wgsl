// PCG-RXS-M-XS 32-bit hash (mirrors vlf_core::pathtrace::sampling::pcg_hash): path-tracer
// random streams and the display's colour per id.

fn pcg_hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
