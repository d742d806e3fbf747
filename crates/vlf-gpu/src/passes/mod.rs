//! One module per GPU pass. Each owns its pipeline, its explicit bind-group layouts (group 0 =
//! per-dispatch globals, group 1 = per-pass resources) and its WGSL file, and labels every wgpu
//! object `"Pass::thing"`.
//!
//! Pass order (the one place it is written down):
//! * bake: (not built yet; see docs/ARCHITECTURE.md)
//! * render: (not built yet)
//! * self-test: [`smoke::SmokePass`]

pub mod smoke;

/// Number of workgroups for `n` invocations of `size` each, split over x and y so neither exceeds
/// `max_per_dim` (65535 on most adapters).
pub fn dispatch_2d(n: u32, size: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = n.div_ceil(size).max(1);
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

#[cfg(test)]
mod tests {
    use super::dispatch_2d;

    #[test]
    fn dispatch_2d_covers_every_invocation() {
        for &(n, max) in &[
            (1, 65535),
            (64 * 65535, 65535),
            (64 * 65535 + 1, 65535),
            (10_000, 20),
        ] {
            let (x, y) = dispatch_2d(n, 64, max);
            assert!(x <= max && y <= max);
            assert!(u64::from(x) * u64::from(y) * 64 >= u64::from(n));
            // No more than one extra row of workgroups.
            assert!(u64::from(x) * u64::from(y - 1) * 64 < u64::from(n));
        }
    }
}
