//! Mutation fuzzer for the `.vlf` reader on the stable toolchain (no cargo-fuzz).
//!
//! Seeds: a few small valid files (both radiance encodings, with and without geometry,
//! cameras, textures and final-gather settings). Each iteration applies 1–3 deterministic xorshift mutations: bit flips, byte
//! overwrites, truncation, appended bytes, preamble length-field edits (with a recomputed or a
//! stale header checksum), section-table and header-field edits (re-encoded, with a recomputed
//! or a stale header checksum), and section-data edits (with recomputed or stale section
//! checksums). Every input goes to `read_bytes` and `describe_bytes` inside `catch_unwind`. A
//! panic fails the test, and so does an accepted input that cannot be written back and read to
//! the same light field; the offending input is saved and its path printed.
//!
//! Run time: `VLF_FUZZ_SECONDS` (default 3 s). Seed: `VLF_FUZZ_SEED` (default fixed).
//! `VLF_FUZZ_SECONDS=60 cargo test --release -p vlf-core --test core fuzz_format:: -- --nocapture`

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::Rng;
use glam::{Quat, Vec3};
use vlf_core::directions::DirectionSet;
use vlf_core::format;
use vlf_core::format::disk::{self, FileHeader, PREAMBLE_LEN, Preamble, SectionEntry};
use vlf_core::hash;
use vlf_core::lightfield::encoding::f16_encode;
use vlf_core::lightfield::{
    BakeFace, BakeParams, BakeStats, BakeTriangle, DEFAULT_ENCODING, LightField, NO_TEXTURE,
    Radiance, RadianceEncoding, Shading, SurfaceMaterial, SurfaceTexture,
};
use vlf_core::scene::{Camera, SceneSummary, Similarity, WrapMode};

// ----- seeds --------------------------------------------------------------------------------

/// Two materials (the second emissive), with `textures` textures (0–2) in their slots.
fn shading(triangles: usize, textures: usize, rng: &mut Rng) -> Shading {
    let tex = |i: usize| if i < textures { i as u32 } else { NO_TEXTURE };
    let sizes = [
        (3u32, 2u32, WrapMode::ClampToEdge),
        (4, 4, WrapMode::MirroredRepeat),
    ];
    let texels: Vec<[f32; 4]> = sizes[..textures]
        .iter()
        .flat_map(|&(w, h, _)| 0..w * h)
        .map(|_| [rng.unit(), rng.unit(), rng.unit(), 0.0])
        .collect();
    Shading {
        materials: vec![
            SurfaceMaterial {
                base_color: [0.8, 0.5, 0.2],
                diffuse_weight: 0.5,
                emission: [0.0; 3],
                base_color_texture: tex(0),
                emissive_texture: NO_TEXTURE,
                specular_alpha: 0.0,
                // An alpha mask (so that the `surfaces` and `texture_alpha` sections are
                // fuzzed too when there are textures).
                alpha_cutoff: if textures > 0 { 0.5 } else { 0.0 },
                alpha_factor: 0.9,
                alpha_nearest: textures > 0,
                // And a pane (the `surfaces` section's pane words).
                pane: 0.5,
                ior: 1.45,
                base_color_texcoord: 0,
                emissive_texcoord: 0,
            },
            SurfaceMaterial {
                base_color: [0.3; 3],
                diffuse_weight: 0.5,
                emission: [4.0, 3.0, 2.0],
                base_color_texture: NO_TEXTURE,
                emissive_texture: tex(1),
                specular_alpha: 0.0,
                ..SurfaceMaterial::opaque_default()
            },
        ],
        uvs: (0..triangles)
            .map(|_| {
                [
                    [rng.unit(), rng.unit()],
                    [rng.unit() * 3.0, -rng.unit()],
                    [0.5, 0.25],
                ]
            })
            .collect(),
        uvs1: None,
        normals: None,
        colors: None,
        textures: sizes[..textures]
            .iter()
            .map(|&(width, height, wrap)| SurfaceTexture {
                width,
                height,
                wrap_s: wrap,
                wrap_t: WrapMode::Repeat,
            })
            .collect(),
        alpha: if textures > 0 {
            texels.iter().map(|t| f16_encode(t[0])).collect()
        } else {
            Vec::new()
        },
        texels: Radiance::from_f32(&texels, RadianceEncoding::RgbF16).unwrap(),
    }
}

fn field(faces: u32, w: u32, h: u32, cameras: bool, textures: usize, rng: &mut Rng) -> LightField {
    let mut fs = Vec::new();
    let mut tris = Vec::new();
    let mut base = 0;
    for i in 0..faces {
        let z = i as f32 * 0.1 - 0.3;
        fs.push(BakeFace {
            normal: [0.0, 0.0, 1.0],
            offset: z,
            origin: [-0.5, -0.5, z],
            texel_size: 1.0 / w as f32,
            u: [1.0, 0.0, 0.0],
            width: w,
            v: [0.0, 1.0, 0.0],
            height: h,
            texel_base: base,
            kind: i % 3,
            specular: 0.0,
            material: i % 2,
        });
        base += 2 * w * h;
        for k in 0..2 {
            tris.push(BakeTriangle {
                p0: [-0.5, -0.5, z],
                face: i,
                p1: [0.5, -0.5 + k as f32, z],
                _pad0: 0,
                p2: [0.5 - k as f32, 0.5, z],
                _pad1: 0,
            });
        }
    }
    let radiance: Vec<[f32; 4]> = (0..base)
        .map(|_| {
            let l = (rng.unit() * 14.0 - 9.0).exp();
            [l * rng.unit(), l, l * rng.unit(), 0.0]
        })
        .collect();
    let camera = Camera {
        name: Some("cam".into()),
        position: Vec3::new(0.0, 1.0, 4.0),
        rotation: Quat::IDENTITY,
        yfov: 0.8,
        aspect_ratio: None,
        znear: 0.1,
        zfar: Some(50.0),
    };
    let params = BakeParams {
        directions: 6,
        final_gather: (textures > 0).then_some(crate::bakes::fixed_gather(0.5, 1.0, [16, 4, 64])),
        ..BakeParams::paper()
    };
    LightField {
        directions: DirectionSet::at_least(params.directions).unwrap(),
        params,
        to_vlf: Similarity::IDENTITY,
        scene: SceneSummary {
            source: "fuzz.gltf".into(),
            triangles: tris.len(),
            faces: fs.len(),
            materials: 1,
            diffuse_materials: 1,
            mirror_materials: 0,
            mixed_materials: 0,
            emissive_materials: 0,
            emissive_faces: 0,
            emissive_triangles: 0,
            cameras: usize::from(cameras),
            suns: 0,
            textures: 0,
            bounds_min: [-1.0; 3],
            bounds_max: [1.0; 3],
            warnings: 0,
        },
        cameras: if cameras { vec![camera] } else { vec![] },
        shading: shading(tris.len(), textures, rng),
        triangles: tris,
        faces: fs,
        irradiance: Radiance::from_f32(&radiance, DEFAULT_ENCODING).unwrap(),
        tiles: None,
        stats: BakeStats {
            iterations: 2,
            device: "cpu".into(),
            adapter: "CPU reference".into(),
            phases: vec![("propagate".into(), 0.5)],
            unshot_history: vec![0.5, 0.25],
            ..Default::default()
        },
    }
}

fn seeds() -> Vec<Vec<u8>> {
    let mut rng = Rng(0xfeed);
    // (faces, width, height, cameras, textures, encoding) of each seed, drawn in this order.
    [
        (3, 6, 5, true, 2, RadianceEncoding::RgbF16),
        (2, 4, 4, false, 1, RadianceEncoding::Rgb9e5),
        (0, 1, 1, true, 0, RadianceEncoding::RgbF16),
        (1, 1, 1, false, 0, RadianceEncoding::Rgb9e5),
    ]
    .into_iter()
    .map(|(faces, w, h, cameras, textures, enc)| {
        let lf = field(faces, w, h, cameras, textures, &mut rng);
        format::to_bytes(&lf, enc, Path::new("seed.vlf")).unwrap()
    })
    .collect()
}

// ----- mutations ----------------------------------------------------------------------------

fn preamble(f: &[u8]) -> Option<Preamble> {
    Some(Preamble::from_bytes(
        f.get(..PREAMBLE_LEN)?.try_into().ok()?,
    ))
}

fn header(f: &[u8]) -> Option<FileHeader> {
    let p = preamble(f)?;
    disk::decode_header(f.get(PREAMBLE_LEN..PREAMBLE_LEN + p.header_len as usize)?).ok()
}

/// Recomputes the header checksum in place (when the header is within the input).
fn fix_header_checksum(f: &mut [u8]) {
    if let Some(p) = preamble(f)
        && let Some(h) = f.get(PREAMBLE_LEN..PREAMBLE_LEN + p.header_len as usize)
    {
        let sum = disk::header_checksum(&p, h);
        f[24..32].copy_from_slice(&sum.to_le_bytes());
    }
}

fn edit_entry(rng: &mut Rng, s: &mut SectionEntry, names: &[String]) -> String {
    match rng.below(9) {
        0 => {
            s.offset = rng.interesting_u64(s.offset);
            format!("offset {}", s.offset)
        }
        1 => {
            s.byte_len = rng.interesting_u64(s.byte_len);
            format!("byte_len {}", s.byte_len)
        }
        2 => {
            s.count = rng.interesting_u64(s.count);
            format!("count {}", s.count)
        }
        3 => {
            // Consistent count and length, possibly absurd.
            s.count = rng.interesting_u64(s.count) >> rng.below(40);
            s.byte_len = s.count.wrapping_mul(u64::from(s.elem_size));
            format!("count+len {} {}", s.count, s.byte_len)
        }
        4 => {
            s.elem_size = rng.interesting_u64(u64::from(s.elem_size)) as u32;
            format!("elem_size {}", s.elem_size)
        }
        5 => {
            s.kind = rng.below(6) as u32;
            format!("kind {}", s.kind)
        }
        6 => {
            s.required = !s.required;
            "required".into()
        }
        7 => {
            s.name = if rng.chance(2) && !names.is_empty() {
                names[rng.below(names.len())].clone()
            } else {
                format!("x{}", rng.below(100))
            };
            format!("name {}", s.name)
        }
        _ => {
            s.checksum = rng.next();
            "checksum".into()
        }
    }
}

/// Edits the header (section table or another field); returns a description.
fn edit_header(rng: &mut Rng, h: &mut FileHeader) -> String {
    let names: Vec<String> = h.sections.iter().map(|s| s.name.clone()).collect();
    match rng.below(16) {
        0..=7 if !h.sections.is_empty() => {
            let i = rng.below(h.sections.len());
            format!(
                "section {i} {}",
                edit_entry(rng, &mut h.sections[i], &names)
            )
        }
        8 if !h.sections.is_empty() => {
            let i = rng.below(h.sections.len());
            h.sections.remove(i);
            format!("remove section {i}")
        }
        9 if !h.sections.is_empty() => {
            let i = rng.below(h.sections.len());
            let mut s = h.sections[i].clone();
            let what = edit_entry(rng, &mut s, &names);
            h.sections.push(s);
            format!("add copy of section {i} with {what}")
        }
        10 => {
            if rng.chance(2) && h.sections.len() > 1 {
                let i = rng.below(h.sections.len());
                h.sections.swap(0, i);
                format!("swap sections 0 and {i}")
            } else {
                h.texels = rng.interesting_u64(h.texels);
                format!("texels {}", h.texels)
            }
        }
        11 => {
            h.radiance_encoding = rng.below(4) as u32;
            format!("encoding {}", h.radiance_encoding)
        }
        12 => {
            match rng.below(3) {
                0 => h.directions.frequency = rng.below(70) as u32,
                1 => h.directions.scheme = rng.below(3) as u32,
                _ => h.directions.count = rng.interesting_u32(h.directions.count),
            }
            format!("directions {:?}", h.directions)
        }
        13 => {
            match rng.below(7) {
                0 => h.params.resolution = rng.interesting_u32(h.params.resolution),
                1 => h.params.tile = rng.interesting_u32(h.params.tile),
                2 => h.params.texel_scale = f32::from_bits(rng.interesting_u32(0)),
                3 => h.params.sky[rng.below(3)] = f32::from_bits(rng.interesting_u32(0)),
                4 => h.params.perturb = rng.interesting_u32(h.params.perturb),
                5 => h.params.final_gather = None,
                _ => {
                    let g = h.params.final_gather.get_or_insert(disk::FileGather {
                        texel_scale: 1.0,
                        indirect_texel_scale: 1.0,
                        light_samples: 1,
                        direct_rays: 1,
                        indirect_rays: 1,
                    });
                    match rng.below(3) {
                        0 => g.texel_scale = f32::from_bits(rng.interesting_u32(0)),
                        1 => g.indirect_texel_scale = f32::from_bits(rng.interesting_u32(0)),
                        _ => g.indirect_rays = rng.interesting_u32(g.indirect_rays),
                    }
                }
            }
            format!("params {:?}", h.params)
        }
        14 => {
            h.transform.scale = f32::from_bits(rng.interesting_u32(0));
            format!("transform {:?}", h.transform)
        }
        _ => {
            if let Some(c) = h.cameras.first_mut() {
                c.yfov = f32::from_bits(rng.interesting_u32(0));
                c.zfar = Some(f32::from_bits(rng.interesting_u32(0)));
            }
            "camera".into()
        }
    }
}

/// One mutation of `f`; returns its description.
fn mutate(rng: &mut Rng, f: &mut Vec<u8>) -> String {
    let len = f.len();
    match rng.below(12) {
        0 | 1 => {
            // Bit flips, half of the time in the preamble + header.
            let n = 1 + rng.below(8);
            let head = preamble(f).map_or(len, |p| (PREAMBLE_LEN + p.header_len as usize).min(len));
            for _ in 0..n {
                let range = if rng.chance(2) {
                    head.max(1)
                } else {
                    len.max(1)
                };
                let i = rng.below(range);
                if let Some(b) = f.get_mut(i) {
                    *b ^= 1 << rng.below(8);
                }
            }
            format!("{n} bit flips")
        }
        2 => {
            let n = rng.below(len + 1);
            f.truncate(n);
            format!("truncate to {n}")
        }
        3 => {
            let at = rng.below(len + 1);
            let n = 1 + rng.below(32);
            for i in at..(at + n).min(len) {
                f[i] = rng.next() as u8;
            }
            format!("random bytes at {at}")
        }
        4 => {
            let n = 1 + rng.below(64);
            f.extend((0..n).map(|_| rng.next() as u8));
            format!("append {n}")
        }
        5 => {
            // Preamble length fields, with a recomputed or a stale header checksum.
            let Some(p) = preamble(f) else {
                return "no preamble".into();
            };
            let what = if rng.chance(2) {
                let v = rng.interesting_u64(u64::from(p.header_len)) as u32;
                f[12..16].copy_from_slice(&v.to_le_bytes());
                format!("header_len {v}")
            } else {
                let v = rng.interesting_u64(p.file_len);
                f[16..24].copy_from_slice(&v.to_le_bytes());
                format!("file_len {v}")
            };
            let fix = rng.chance(2);
            if fix {
                fix_header_checksum(f);
            }
            format!(
                "{what} (checksum {})",
                if fix { "recomputed" } else { "stale" }
            )
        }
        6..=8 => {
            // Header / section-table edit, re-encoded.
            let mut what = String::new();
            let Ok(mut g) = disk::rewrite_header(f, |h| what = edit_header(rng, h)) else {
                return "header edit impossible".into();
            };
            let stale = rng.chance(3);
            if stale {
                g[24..32].copy_from_slice(&f[24..32]);
            }
            *f = g;
            format!(
                "header edit: {what} (checksum {})",
                if stale { "stale" } else { "recomputed" }
            )
        }
        _ => {
            // Section data edit, with recomputed (2/3) or stale section checksums.
            let Some(h) = header(f) else {
                return "no header".into();
            };
            if h.sections.is_empty() {
                return "no sections".into();
            }
            let s = h.sections[rng.below(h.sections.len())].clone();
            let (Ok(start), Ok(n)) = (usize::try_from(s.offset), usize::try_from(s.byte_len))
            else {
                return "section out of range".into();
            };
            let Some(data) = f.get_mut(start..start.saturating_add(n)) else {
                return "section out of range".into();
            };
            if data.len() < 4 {
                return "empty section".into();
            }
            for _ in 0..1 + rng.below(4) {
                let at = rng.below(data.len() / 4) * 4;
                let v =
                    rng.interesting_u32(u32::from_le_bytes(data[at..at + 4].try_into().unwrap()));
                data[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
            let sum = hash::section_checksum(data);
            if rng.chance(3) {
                return format!("data edit in {} (checksum stale)", s.name);
            }
            match disk::rewrite_header(f, |h| {
                if let Some(e) = h.sections.iter_mut().find(|e| e.name == s.name) {
                    e.checksum = sum;
                }
            }) {
                Ok(g) => *f = g,
                Err(_) => return "rewrite failed".into(),
            }
            format!("data edit in {} (checksum recomputed)", s.name)
        }
    }
}

// ----- driver -------------------------------------------------------------------------------

/// Runs the reader on `input`: `Ok(None)` when accepted, `Ok(Some(error variant))` when
/// rejected; `Err` describes a failure (panic or broken round trip).
fn check(input: &[u8]) -> Result<Option<String>, String> {
    let path = Path::new("fuzz.vlf");
    let r = catch_unwind(AssertUnwindSafe(|| {
        if let Ok(info) = format::describe_bytes(input, path) {
            let _ = info.to_string();
        }
        format::read_bytes(input, path)
    }))
    .map_err(|p| panic_message(&p))?;
    let lf = match r {
        Ok(lf) => lf,
        Err(e) => {
            let dbg = format!("{e:?}");
            let variant = dbg.split([' ', '(', '{']).next().unwrap_or_default();
            return Ok(Some(variant.to_string()));
        }
    };
    // An accepted file must be writable, and writing what is read back gives the same bytes
    // (compared as bytes: informational fields such as scene bounds may hold NaN).
    let enc = header(input)
        .and_then(|h| RadianceEncoding::from_id(h.radiance_encoding))
        .ok_or("accepted without a decodable header")?;
    let (first, second) = catch_unwind(AssertUnwindSafe(|| {
        let first = format::to_bytes(&lf, enc, path).map_err(|e| e.to_string())?;
        let again = format::read_bytes(&first, path).map_err(|e| e.to_string())?;
        let second = format::to_bytes(&again, enc, path).map_err(|e| e.to_string())?;
        Ok::<_, String>((first, second))
    }))
    .map_err(|p| panic_message(&p))?
    .map_err(|e| format!("accepted, but the light field does not round-trip: {e}"))?;
    if first != second {
        return Err("accepted, but writing what was read back gives different bytes".into());
    }
    Ok(None)
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    let msg = p
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default();
    format!("panic: {msg}")
}

#[test]
fn fuzz_read_bytes() {
    let seconds: f64 = std::env::var("VLF_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3.0);
    let seed: u64 = std::env::var("VLF_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed_f0f0_1234_5678);
    let seeds = seeds();
    for s in &seeds {
        assert_eq!(check(s), Ok(None), "a seed is rejected");
    }
    let mut rng = Rng(seed | 1);
    // Silence the panics this test provokes (on its thread and on the unnamed rayon workers
    // `read_bytes` uses), not those of the other tests running beside it in this binary.
    let hook: std::sync::Arc<dyn Fn(&std::panic::PanicHookInfo) + Send + Sync> =
        std::panic::take_hook().into();
    let fuzzer = std::thread::current().id();
    let others = hook.clone();
    std::panic::set_hook(Box::new(move |info| {
        let t = std::thread::current();
        if t.id() != fuzzer && t.name().is_some() {
            others(info);
        }
    }));
    let deadline = Instant::now() + Duration::from_secs_f64(seconds);
    let (mut executed, mut accepted) = (0u64, 0u64);
    let mut rejected = std::collections::BTreeMap::<String, u64>::new();
    let mut failure = None;
    let mut current = seeds[0].clone();
    let mut log = Vec::new();
    while Instant::now() < deadline && failure.is_none() {
        for _ in 0..32 {
            // Mostly fresh from a seed; sometimes stack more mutations on the last input.
            if !rng.chance(4) {
                let i = rng.below(seeds.len());
                current = seeds[i].clone();
                log = vec![format!("seed {i}")];
            }
            for _ in 0..1 + rng.below(3) {
                log.push(mutate(&mut rng, &mut current));
            }
            executed += 1;
            match check(&current) {
                Ok(None) => accepted += 1,
                Ok(Some(variant)) => *rejected.entry(variant).or_default() += 1,
                Err(e) => {
                    failure = Some((e, log.clone(), current.clone()));
                    break;
                }
            }
        }
    }
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| hook(info)));
    println!("fuzz_format: {executed} inputs in {seconds} s ({accepted} accepted), seed {seed:#x}");
    println!("rejections by error variant: {rejected:?}");
    if let Some((e, log, input)) = failure {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz_format_failure.vlf");
        std::fs::write(&out, &input).unwrap();
        panic!(
            "{e}\nmutations: {log:?}\ninput saved to {} ({} bytes)",
            out.display(),
            input.len()
        );
    }
}
