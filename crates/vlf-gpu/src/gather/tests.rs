use super::*;

fn est(
    kind: Kind,
    points: u32,
    light_samples: u32,
    cosine_rays: u32,
    delta_lights: bool,
) -> Estimator {
    Estimator {
        kind,
        stream: 0,
        points,
        light_samples,
        cosine_rays,
        delta_lights,
    }
}

/// The ranges of `entry`'s steps, in order.
fn ranges(steps: &[Step], entry: Entry) -> Vec<(u32, u32)> {
    steps
        .iter()
        .filter(|s| s.entry == entry)
        .map(|s| (s.k0, s.k1))
        .collect()
}

/// Batches of `batch` that cover 0..count once, in order.
fn covers(r: &[(u32, u32)], count: u32, batch: u32) -> bool {
    let mut k = 0;
    for &(k0, k1) in r {
        if k0 != k || k1 <= k0 || k1 - k0 > batch {
            return false;
        }
        k = k1;
    }
    k == count
}

#[test]
fn steps_run_in_the_cpu_order_and_cover_every_sample_once() {
    let opts = GatherOptions {
        chunk: 1,
        point_batch: 3,
        ray_batch: 7,
        threads: 0,
    };
    let ind = steps(&est(Kind::Indirect, 256, 0, 256, false), &opts);
    let order: Vec<Entry> = ind.iter().map(|s| s.entry).collect();
    assert_eq!(order[0], Entry::Begin);
    assert_eq!(*order.last().unwrap(), Entry::IndirectEnd);
    let finish = order
        .iter()
        .position(|e| *e == Entry::FinishPoints)
        .unwrap();
    assert!(order[1..finish].iter().all(|e| *e == Entry::DrawPoints));
    assert!(
        order[finish + 1..order.len() - 1]
            .iter()
            .all(|e| *e == Entry::IndirectRays)
    );
    assert_eq!(ind[finish].side, 16, "the cosine strata of 256 rays");
    assert!(covers(&ranges(&ind, Entry::DrawPoints), 256, 3));
    assert!(covers(&ranges(&ind, Entry::IndirectRays), 256, 7));

    let dir = steps(&est(Kind::Direct, 64, 64, 16, true), &opts);
    let first = |e| dir.iter().position(|s| s.entry == e).unwrap();
    let last = |e| dir.iter().rposition(|s| s.entry == e).unwrap();
    assert!(last(Entry::DrawPoints) < first(Entry::FinishPoints));
    assert!(first(Entry::FinishPoints) < first(Entry::LightSamples));
    assert!(last(Entry::LightSamples) < first(Entry::Shuffle));
    assert!(first(Entry::Shuffle) < first(Entry::CosineRays));
    assert!(last(Entry::CosineRays) < first(Entry::DeltaRays));
    assert_eq!(last(Entry::DeltaRays) + 1, first(Entry::DirectEnd));
    assert_eq!(
        dir[first(Entry::FinishPoints)].side,
        8,
        "light strata first"
    );
    assert_eq!(dir[first(Entry::Shuffle)].side, 4, "then the cosine strata");
    assert!(covers(&ranges(&dir, Entry::LightSamples), 64, 7));
    assert!(covers(&ranges(&dir, Entry::CosineRays), 16, 7));
    assert!(covers(&ranges(&dir, Entry::DeltaRays), 64, 7));

    // No suns, no emitters: no sun steps, no light-sample steps.
    let dir = steps(&est(Kind::Direct, 16, 0, 16, false), &opts);
    assert!(ranges(&dir, Entry::DeltaRays).is_empty());
    assert!(ranges(&dir, Entry::LightSamples).is_empty());
}

#[test]
fn scratch_holds_the_state_the_points_and_the_larger_strata() {
    assert_eq!(
        est(Kind::Indirect, 256, 0, 256, false).scratch_stride(),
        4 + 256 + 256
    );
    // 10 light samples: 4 × 4 strata; 3 cosine rays: 2 × 2.
    assert_eq!(
        est(Kind::Direct, 10, 10, 3, false).scratch_stride(),
        4 + 10 + 16
    );
    // Chunks shrink to fit one binding.
    let e = est(Kind::Indirect, 1024, 0, 1024, false);
    let per = u64::from(e.scratch_stride()) * 16;
    assert_eq!(chunk_texels(&e, 4096, 10_000, 100 * per).unwrap(), 100);
    assert_eq!(chunk_texels(&e, 4096, 50, 100 * per).unwrap(), 50);
    assert!(chunk_texels(&e, 4096, 50, per - 1).is_err());
}

/// The contact bits and lift of `common/gather_field.wgsl` are `vlf_core::gather::field`'s.
#[test]
fn contact_constants_match_vlf_core() {
    use crate::shaders::{self, constant};
    use vlf_core::gather::field as spec_field;
    use wgpu::naga::Literal;
    let module = shaders::COMMON_GATHER_FIELD.validate().unwrap();
    for (name, value) in [
        ("CONTACT_RIGHT", spec_field::CONTACT_RIGHT),
        ("CONTACT_UP", spec_field::CONTACT_UP),
        ("CONTACT_DIAGONAL", spec_field::CONTACT_DIAGONAL),
        ("CONTACT_ANTI_DIAGONAL", spec_field::CONTACT_ANTI_DIAGONAL),
        ("CONTACT_CUT", spec_field::CONTACT_CUT),
    ] {
        assert_eq!(
            constant(&module, name),
            Some(Literal::U32(u32::from(value))),
            "common/gather_field.wgsl: const {name}"
        );
    }
    assert_eq!(
        constant(&module, "CONTACT_LIFT"),
        Some(Literal::F32(spec_field::CONTACT_LIFT))
    );
}

/// Texel t's contact byte is byte t % 4 of word (t / 4) % 4 of entry t / 16, as the shader's
/// `contact_bits` reads it.
#[test]
fn contact_bits_pack_sixteen_to_an_entry() {
    let bits: Vec<u8> = (0..35u8).collect();
    let e = contact_entries(&bits);
    assert_eq!(e.len(), 3);
    for (t, &b) in bits.iter().enumerate() {
        let word = e[t / 16][(t / 4) % 4].to_bits();
        assert_eq!((word >> (8 * (t % 4))) & 0xff, u32::from(b), "texel {t}");
    }
    assert_eq!(e[2][0].to_bits() >> 24, 0, "padding is zero");
}
