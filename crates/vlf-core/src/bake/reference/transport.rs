//! The transport directions of a bake: the fixed directions of the set (both senses), their
//! perturbed copies, and the suns.

use glam::Vec3;

use crate::bake::BakeScene;
use crate::directions::DirectionSet;
use crate::lightfield::BakeParams;
use crate::psf::{PsfFrame, fixed_frame, twist_angle};

/// One transport direction: a PSF frame, its quadrature weight, and whether it carries both
/// senses (`w` and `−w`, the fixed and perturbed directions) or only `+w` (a sun).
#[derive(Clone, Copy, Debug)]
pub struct TransportDir {
    pub frame: PsfFrame,
    /// Solid angle per sense (steradians) for quadrature directions; 1 for suns.
    pub weight: f32,
    /// For suns: the irradiance entering along `+w`. `None` for quadrature directions.
    pub sun: Option<Vec3>,
}

/// The transport directions of a bake: every direction of the set (both senses), each with
/// `perturb` jittered copies inside its solid-angle cell (weights split evenly).
pub fn transport_directions(set: &DirectionSet, params: &BakeParams) -> Vec<TransportDir> {
    let mut out = Vec::with_capacity(set.len() * (1 + params.perturb as usize));
    let mut rng = SplitMix64(params.seed);
    for i in 0..set.len() {
        let w = set.direction(i);
        let omega = set.solid_angle(i as u32);
        if params.perturb == 0 {
            out.push(TransportDir {
                frame: fixed_frame(set, i),
                weight: omega,
                sun: None,
            });
            continue;
        }
        let n = params.perturb as usize;
        // Jitter inside the spherical cap of the same solid angle around ω_i: it covers the
        // direction's share of the sphere and is symmetric, so the mean stays at ω_i.
        let frame = PsfFrame::new(w);
        let cos_max = 1.0 - omega / (2.0 * std::f32::consts::PI);
        for s in 0..n {
            // Stratified in the cap's area: radius by sqrt-free area fraction, angle by a
            // golden-ratio sequence.
            let u = (s as f32 + rng.next_f32()) / n as f32;
            let phi = 2.0 * std::f32::consts::PI * fract(s as f32 * 0.618_034 + rng.next_f32());
            let cos_t = 1.0 - u * (1.0 - cos_max);
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let d = frame.w * cos_t + (frame.u * phi.cos() + frame.v * phi.sin()) * sin_t;
            out.push(TransportDir {
                frame: PsfFrame::new(d).twisted(twist_angle(set.len() + out.len())),
                weight: omega / n as f32,
                sun: None,
            });
        }
    }
    out
}

/// Transport directions followed by one per sun (the order reflect jobs are indexed in).
pub fn all_directions(
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
) -> (Vec<TransportDir>, usize) {
    let mut dirs = transport_directions(set, params);
    let quadrature = dirs.len();
    dirs.extend(scene.suns.iter().map(|&(d, e)| TransportDir {
        frame: PsfFrame::new(d),
        weight: 1.0,
        sun: Some(e),
    }));
    (dirs, quadrature)
}

fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// Tiny deterministic PRNG (SplitMix64).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}
