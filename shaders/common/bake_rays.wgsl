// What the bake passes of one transport direction pass along each ray of the PSF grid: the
// sorted crossings of pass 1 and the arriving radiance of pass 2.

// One crossing of a ray: depth along w and the face crossed (mirrors vlf_gpu::layout::CellEntry).
struct CellEntry {
    depth: f32,
    face: u32,
}

// Arriving radiance at one crossing (mirrors vlf_gpu::layout::Crossing):
// below.rgb travelling +w, below.w = 1 if first; above.rgb travelling −w, above.w = 1 if last.
struct Crossing {
    below: vec4<f32>,
    above: vec4<f32>,
}

// Faces closer to edge-on than this (|n·w|) neither gather nor reflect along a direction
// (vlf_core::bake::reference::MIN_COS).
const MIN_COS: f32 = 1e-6;
