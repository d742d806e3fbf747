//! Mutation fuzzer for `scene::load` on the stable toolchain (no cargo-fuzz).
//!
//! Seeds: a hand-made `.gltf` exercising most loader paths (embedded data-URI buffer,
//! textures from a bufferView and a data URI, sparse and normalised accessors,
//! strips/fans/points, TRS/matrix/mirrored nodes, cameras, lights), the same scene as
//! a `.glb`, and the shared `cornell.gltf`. Each iteration applies 1–4 random
//! mutations (byte flips, truncation, chunk deletion/duplication, crossover between
//! seeds, numbers spliced into the JSON, huge counts/offsets/indices, GLB header and
//! chunk-length corruption), writes the input to a temp file and calls `load` inside
//! `catch_unwind`. A panic (or a violated invariant on an accepted scene) fails the
//! test; the offending input is saved and its path printed.
//!
//! Run time: `VLF_FUZZ_SECONDS` (default 3 s). Seed: `VLF_FUZZ_SEED` (default fixed).
//! `VLF_FUZZ_SECONDS=60 cargo test -p vlf-core --test core fuzz_loader:: -- --nocapture`

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::common::{Rng, base64, glb, png_rgb};
use vlf_core::scene::{self, Scene};

// ----- seeds --------------------------------------------------------------------------

/// A `width × height` RGB PNG of a fixed pattern keyed by `seed`.
fn pattern_png(width: u32, height: u32, seed: u8) -> Vec<u8> {
    let rgb: Vec<[u8; 3]> = (0..height)
        .flat_map(|y| {
            (0..width).map(move |x| {
                std::array::from_fn(|c| ((3 * x + c as u32) * 37 + y * 11) as u8 ^ seed)
            })
        })
        .collect();
    png_rgb(width, height, &rgb)
}

/// The hand-made seed scene: (JSON without the buffer entry, binary data).
fn seed_scene(glb: bool) -> (String, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views: Vec<String> = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8], stride: Option<usize>| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let o = bin.len();
        bin.extend_from_slice(bytes);
        let s = stride
            .map(|s| format!(r#","byteStride":{s}"#))
            .unwrap_or_default();
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{o},"byteLength":{}{s}}}"#,
            bytes.len()
        ));
        views.len() - 1
    };
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    // 0: cube positions, interleaved with uvs (stride 20).
    let cube = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0f32],
    ];
    let mut inter = Vec::new();
    for (k, p) in cube.iter().enumerate() {
        inter.extend(f32s(p));
        inter.extend(f32s(&[k as f32 / 8.0, 1.0 - k as f32 / 8.0]));
    }
    let v_inter = view(&mut bin, &inter, Some(20));
    let idx: Vec<u16> = vec![
        0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3,
        1, 2, 6, 1, 6, 5,
    ];
    let v_idx = view(
        &mut bin,
        &idx.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<_>>(),
        None,
    );
    let strip: Vec<u8> = vec![0, 1, 3, 2, 7, 6];
    let v_strip = view(&mut bin, &strip, None);
    // Sparse: move vertex 6 and 7 up.
    let v_sp_idx = view(&mut bin, &[6u8, 7, 0, 0], None);
    let v_sp_val = view(&mut bin, &f32s(&[1.0, 2.0, 1.0, 0.0, 2.0, 1.0]), None);
    let v_sp_idx2 = view(&mut bin, &[0u8, 2, 0, 0], None);
    // Normalised u16 uvs.
    let v_uvn = view(
        &mut bin,
        &[
            0u16, 0, 65535, 0, 65535, 65535, 0, 65535, 0, 0, 65535, 0, 65535, 65535, 0, 65535,
        ]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect::<Vec<_>>(),
        None,
    );
    let png = pattern_png(3, 2, 7);
    let v_png = view(&mut bin, &png, None);
    let accessors = format!(
        r#"[{{"bufferView":{v_inter},"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},
            {{"bufferView":{v_inter},"byteOffset":12,"componentType":5126,"count":8,"type":"VEC2"}},
            {{"bufferView":{v_idx},"componentType":5123,"count":36,"type":"SCALAR"}},
            {{"bufferView":{v_strip},"componentType":5121,"count":6,"type":"SCALAR"}},
            {{"bufferView":{v_inter},"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[1,2,1],
              "sparse":{{"count":2,"indices":{{"bufferView":{v_sp_idx},"componentType":5121}},"values":{{"bufferView":{v_sp_val}}}}}}},
            {{"bufferView":{v_uvn},"componentType":5123,"normalized":true,"count":8,"type":"VEC2"}},
            {{"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,2,1],
              "sparse":{{"count":2,"indices":{{"bufferView":{v_sp_idx2},"componentType":5121}},"values":{{"bufferView":{v_sp_val}}}}}}}]"#
    );
    let image1 = if glb {
        format!(r#"{{"bufferView":{v_png},"mimeType":"image/png"}}"#)
    } else {
        format!(
            r#"{{"uri":"data:image/png;base64,{}"}}"#,
            base64(&pattern_png(2, 2, 99))
        )
    };
    let rest = format!(
        r#""accessors":{accessors},
        "bufferViews":[{views}],
        "meshes":[
          {{"name":"cube","primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}},
          {{"name":"strip","primitives":[{{"attributes":{{"POSITION":4,"TEXCOORD_0":5}},"indices":3,"mode":5,"material":1}},
                                         {{"attributes":{{"POSITION":0}},"indices":3,"mode":6}},
                                         {{"attributes":{{"POSITION":6}},"mode":4,"material":2}},
                                         {{"attributes":{{"POSITION":0}},"mode":0}}]}}],
        "materials":[
          {{"name":"tex","pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"extensions":{{"KHR_texture_transform":{{"offset":[0.5,0]}}}}}},"metallicFactor":0.5,"roughnessFactor":0.2}},"doubleSided":true}},
          {{"name":"glow","emissiveFactor":[1,0.5,0.25],"emissiveTexture":{{"index":1,"texCoord":1}},
            "extensions":{{"KHR_materials_emissive_strength":{{"emissiveStrength":4}},"KHR_materials_ior":{{"ior":1.4}}}},
            "pbrMetallicRoughness":{{"metallicFactor":1,"roughnessFactor":0}},"alphaMode":"BLEND"}},
          {{"name":"plain"}}],
        "textures":[{{"source":0,"sampler":0}},{{"source":1}}],
        "samplers":[{{"wrapS":33071,"wrapT":33648,"magFilter":9728}}],
        "images":[{{"bufferView":{v_png},"mimeType":"image/png"}},{image1}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.1,"zfar":50,"aspectRatio":1.5}}}},
                   {{"type":"orthographic","orthographic":{{"xmag":1,"ymag":1,"znear":0.1,"zfar":10}}}}],
        "extensions":{{"KHR_lights_punctual":{{"lights":[
            {{"type":"directional","color":[1,0.9,0.8],"intensity":3,"name":"sun"}},
            {{"type":"point","intensity":10}},
            {{"type":"spot","spot":{{"innerConeAngle":0.1,"outerConeAngle":0.5}}}}]}}}},
        "extensionsUsed":["KHR_lights_punctual","KHR_materials_emissive_strength","KHR_texture_transform","KHR_materials_ior"],
        "extensionsRequired":["KHR_lights_punctual"],
        "nodes":[
          {{"name":"root","children":[1,2,3],"translation":[0,1,0]}},
          {{"mesh":0,"rotation":[0,0.38268343,0,0.92387953],"scale":[2,2,2]}},
          {{"mesh":0,"scale":[-1,1,1],"translation":[4,0,0]}},
          {{"mesh":1,"matrix":[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-3,1]}},
          {{"camera":0,"translation":[0,1,8]}},
          {{"camera":1}},
          {{"extensions":{{"KHR_lights_punctual":{{"light":0}}}},"rotation":[-0.5,0,0,0.8660254]}},
          {{"extensions":{{"KHR_lights_punctual":{{"light":1}}}}}},
          {{"extensions":{{"KHR_lights_punctual":{{"light":2}}}}}}],
        "scenes":[{{"nodes":[0,4,5,6,7,8]}}],"scene":0"#,
        views = views.join(",")
    );
    let buffer = if glb {
        format!(r#"{{"byteLength":{}}}"#, bin.len())
    } else {
        format!(
            r#"{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}"#,
            bin.len(),
            base64(&bin)
        )
    };
    (
        format!(r#"{{"asset":{{"version":"2.0"}},"buffers":[{buffer}],{rest}}}"#),
        bin,
    )
}

struct Seed {
    name: &'static str,
    ext: &'static str,
    bytes: Vec<u8>,
}

fn seeds() -> Vec<Seed> {
    let (json, _) = seed_scene(false);
    let (gjson, bin) = seed_scene(true);
    let mut seeds = vec![
        Seed {
            name: "handmade-gltf",
            ext: "gltf",
            bytes: json.into_bytes(),
        },
        Seed {
            name: "handmade-glb",
            ext: "glb",
            bytes: glb(&gjson, &bin),
        },
    ];
    let cornell = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/cornell-box/cornell.gltf"
    ));
    match std::fs::read(&cornell) {
        Ok(bytes) => seeds.push(Seed {
            name: "cornell",
            ext: "gltf",
            bytes,
        }),
        Err(e) => eprintln!("fuzz: shared seed {} unavailable ({e})", cornell.display()),
    }
    seeds
}

// ----- mutations ------------------------------------------------------------------------

const NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "5",
    "6",
    "7",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9007199254740993",
    "18446744073709551615",
    "18446744073709551616",
    "1e39",
    "-1e39",
    "1e308",
    "1e-45",
    "-0",
    "0.5",
    "3.4e38",
    "1e-300",
    "5126",
    "5123",
    "5125",
    "5121",
    "5120",
    "5122",
    "34962",
    "33071",
    "10497",
];

const KEYS: &[&str] = &[
    "\"count\":",
    "\"byteOffset\":",
    "\"byteLength\":",
    "\"byteStride\":",
    "\"bufferView\":",
    "\"buffer\":",
    "\"indices\":",
    "\"POSITION\":",
    "\"TEXCOORD_0\":",
    "\"mode\":",
    "\"material\":",
    "\"mesh\":",
    "\"componentType\":",
    "\"source\":",
    "\"index\":",
    "\"sampler\":",
    "\"camera\":",
    "\"light\":",
    "\"scene\":",
    "\"texCoord\":",
    "\"yfov\":",
    "\"intensity\":",
    "\"emissiveStrength\":",
    "\"metallicFactor\":",
    "\"scale\":",
    "\"children\":",
    "\"nodes\":",
];

fn is_num(b: u8) -> bool {
    b.is_ascii_digit() || b == b'-' || b == b'.' || b == b'e' || b == b'E' || b == b'+'
}

/// Replaces the number starting at or after `pos` with `with`.
fn replace_number(data: &mut Vec<u8>, pos: usize, with: &str) {
    let Some(start) = (pos..data.len()).find(|&i| data[i].is_ascii_digit() || data[i] == b'-')
    else {
        return;
    };
    let mut end = start;
    while end < data.len() && is_num(data[end]) {
        end += 1;
    }
    data.splice(start..end, with.bytes());
}

fn find_all(data: &[u8], needle: &[u8]) -> Vec<usize> {
    if needle.is_empty() || data.len() < needle.len() {
        return Vec::new();
    }
    (0..=data.len() - needle.len())
        .filter(|&i| &data[i..i + needle.len()] == needle)
        .collect()
}

fn mutate(rng: &mut Rng, data: &mut Vec<u8>, seeds: &[Seed]) {
    let n = 1 + rng.below(4);
    for _ in 0..n {
        let len = data.len();
        match rng.below(12) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = *rng.pick(&[
                    0u8, 0xFF, 0x7F, 0x80, b'"', b'{', b'}', b'[', b']', b',', b'9', b'-',
                ]);
            }
            2 => data.truncate(rng.below(len + 1)),
            3 if len > 0 => {
                let a = rng.below(len);
                let b = (a + 1 + rng.below(64.min(len - a))).min(len);
                data.drain(a..b);
            }
            4 if len > 0 => {
                let a = rng.below(len);
                let b = (a + 1 + rng.below(256.min(len - a))).min(len);
                let chunk = data[a..b].to_vec();
                let at = rng.below(len + 1);
                data.splice(at..at, chunk);
            }
            5 => {
                // Crossover with another seed.
                let other = &rng.pick(seeds).bytes;
                if !other.is_empty() && len > 0 {
                    let a = rng.below(other.len());
                    let b = (a + 1 + rng.below(128.min(other.len() - a))).min(other.len());
                    let at = rng.below(len);
                    let end = (at + rng.below(128)).min(len);
                    data.splice(at..end, other[a..b].iter().copied());
                }
            }
            6..=8 => {
                // A known key gets an interesting number.
                let key = rng.pick(KEYS);
                let hits = find_all(data, key.as_bytes());
                if !hits.is_empty() {
                    let at = *rng.pick(&hits) + key.len();
                    let num = rng.pick(NUMBERS);
                    replace_number(data, at, num);
                }
            }
            9 if len > 0 => {
                // Any number in the JSON.
                let at = rng.below(len);
                let num = rng.pick(NUMBERS);
                replace_number(data, at, num);
            }
            10 if data.starts_with(b"glTF") => {
                // GLB header / chunk lengths and chunk types.
                let offsets: Vec<usize> = [4usize, 8, 12, 16]
                    .into_iter()
                    .chain(find_all(data, b"BIN\0").into_iter().map(|o| o - 4))
                    .filter(|&o| o + 4 <= data.len())
                    .collect();
                if !offsets.is_empty() {
                    let o = *rng.pick(&offsets);
                    let v: u32 =
                        *rng.pick(&[0, 1, 11, 12, 13, 20, 0x7FFF_FFFF, 0xFFFF_FFF0, u32::MAX]);
                    let v = if rng.chance(2) {
                        u32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]])
                            .wrapping_add(rng.below(9) as u32)
                            .wrapping_sub(4)
                    } else {
                        v
                    };
                    data[o..o + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
            _ => {
                // Structural JSON edits: swap modes/semantics, drop a required field.
                let edits: &[(&str, &str)] = &[
                    ("\"POSITION\"", "\"TEXCOORD_0\""),
                    ("\"TEXCOORD_0\"", "\"POSITION\""),
                    ("\"VEC3\"", "\"VEC2\""),
                    ("\"VEC2\"", "\"MAT4\""),
                    ("\"SCALAR\"", "\"VEC4\""),
                    ("\"perspective\"", "\"orthographic\""),
                    ("\"directional\"", "\"spot\""),
                    ("base64,", "base64,!"),
                    ("\"uri\":\"data:", "\"uri\":\"missing/"),
                    ("\"children\":[", "\"children\":[0,"),
                    ("\"nodes\":[", "\"nodes\":[0,"),
                    ("image/png", "image/ktx2"),
                    (
                        "\"extensionsRequired\":[",
                        "\"extensionsRequired\":[\"KHR_draco_mesh_compression\",",
                    ),
                ];
                let (from, to) = *rng.pick(edits);
                let hits = find_all(data, from.as_bytes());
                if !hits.is_empty() {
                    let at = *rng.pick(&hits);
                    data.splice(at..at + from.len(), to.bytes());
                }
            }
        }
    }
}

// ----- invariants of accepted scenes ------------------------------------------------------

fn check_accepted(s: &Scene) -> Result<(), String> {
    if s.triangles.is_empty() {
        return Err("accepted scene without triangles".into());
    }
    let mut next = 0u32;
    for (fi, f) in s.faces.iter().enumerate() {
        if f.triangles.start != next || f.triangles.end <= f.triangles.start {
            return Err(format!("face {fi}: bad triangle range {:?}", f.triangles));
        }
        next = f.triangles.end;
        if f.material as usize >= s.materials.len() {
            return Err(format!("face {fi}: bad material"));
        }
        if !f.normal.is_finite() || !f.extent.is_finite() || !f.basis.origin.is_finite() {
            return Err(format!("face {fi}: non-finite plane data"));
        }
    }
    if next as usize != s.triangles.len() {
        return Err("faces do not cover the triangles".into());
    }
    for t in &s.triangles {
        if t.p.iter().any(|p| !p.is_finite()) || t.uv.iter().any(|u| !u.is_finite()) {
            return Err("non-finite triangle data".into());
        }
        for p in t.p {
            if s.to_vlf.apply(p).length() > 1.0 + 1e-5 {
                return Err(format!("vertex {p} maps outside the unit sphere"));
            }
        }
    }
    for m in &s.materials {
        for r in [m.base_color_texture, m.emissive_texture]
            .into_iter()
            .flatten()
        {
            if r.index as usize >= s.textures.len() {
                return Err(format!("material {}: bad texture index", m.name));
            }
        }
    }
    for t in &s.textures {
        if t.pixels.len() != t.width as usize * t.height as usize {
            return Err("texture size mismatch".into());
        }
    }
    Ok(())
}

// ----- driver ----------------------------------------------------------------------------

#[test]
fn fuzz_loader() {
    let seconds: f64 = std::env::var("VLF_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3.0);
    let seed: u64 = std::env::var("VLF_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5EED_F00D_CAFE_0001);
    let dir = std::env::temp_dir().join(format!("vlf-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let crash_dir = std::env::temp_dir().join("vlf-fuzz-crashes");
    let seeds = seeds();

    // The seeds themselves must load.
    for s in &seeds {
        let p = dir.join(format!("seed-{}.{}", s.name, s.ext));
        std::fs::write(&p, &s.bytes).unwrap();
        let t0 = Instant::now();
        let scene =
            scene::load(&p).unwrap_or_else(|e| panic!("seed {} does not load: {e}", s.name));
        println!(
            "fuzz: seed {} ({} bytes, loads in {:.2} ms): {} triangles, {} faces, {} textures, {} cameras, {} suns, {} warnings",
            s.name,
            s.bytes.len(),
            t0.elapsed().as_secs_f64() * 1e3,
            scene.triangles.len(),
            scene.faces.len(),
            scene.textures.len(),
            scene.cameras.len(),
            scene.suns.len(),
            scene.warnings.len()
        );
        check_accepted(&scene).unwrap();
    }

    let mut rng = Rng(seed | 1);
    let mut corpus: Vec<(usize, Vec<u8>)> = Vec::new();
    let (mut executed, mut accepted, mut rejected) = (0u64, 0u64, 0u64);
    let mut failures: Vec<PathBuf> = Vec::new();
    let mut slowest = (Duration::ZERO, 0u64);
    let start = Instant::now();
    let budget = Duration::from_secs_f64(seconds);
    let input_path = dir.join("input");
    while start.elapsed() < budget {
        let (si, mut data) = if !corpus.is_empty() && rng.chance(3) {
            corpus[rng.below(corpus.len())].clone()
        } else {
            let si = rng.below(seeds.len());
            (si, seeds[si].bytes.clone())
        };
        mutate(&mut rng, &mut data, &seeds);
        let path = input_path.with_extension(seeds[si].ext);
        std::fs::write(&path, &data).unwrap();
        let t0 = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            scene::load(&path).map(|s| check_accepted(&s).map(|()| s.triangles.len()))
        }));
        let took = t0.elapsed();
        if took > slowest.0 {
            slowest = (took, executed);
        }
        executed += 1;
        let problem = match outcome {
            Ok(Ok(Ok(_))) => {
                accepted += 1;
                if corpus.len() < 256 {
                    corpus.push((si, data.clone()));
                } else {
                    let k = rng.below(corpus.len());
                    corpus[k] = (si, data.clone());
                }
                None
            }
            Ok(Ok(Err(invariant))) => Some(format!("invariant violated: {invariant}")),
            Ok(Err(e)) => {
                rejected += 1;
                let msg = e.to_string();
                if !msg.ends_with(&path.display().to_string()) {
                    Some(format!("error message does not end with the path: {msg}"))
                } else {
                    None
                }
            }
            Err(_) => Some("panic".to_string()),
        };
        if let Some(problem) = problem {
            std::fs::create_dir_all(&crash_dir).unwrap();
            let saved = crash_dir.join(format!("crash-{executed}.{}", seeds[si].ext));
            std::fs::write(&saved, &data).unwrap();
            eprintln!(
                "fuzz: {problem} on input {executed}, saved to {}",
                saved.display()
            );
            failures.push(saved);
            if failures.len() >= 10 {
                break;
            }
        }
    }
    let elapsed = start.elapsed().as_secs_f64();
    println!(
        "fuzz: {executed} inputs in {elapsed:.1} s ({:.0}/s): {accepted} accepted, {rejected} rejected, {} failures; slowest input {:.1} ms (#{})",
        executed as f64 / elapsed.max(1e-9),
        failures.len(),
        slowest.0.as_secs_f64() * 1e3,
        slowest.1
    );
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        failures.is_empty(),
        "loader failures, inputs saved: {failures:#?}"
    );
}

/// Replays saved crash inputs: `VLF_FUZZ_REPLAY=path cargo test --test core fuzz_loader::replay`.
#[test]
fn replay() {
    let Ok(path) = std::env::var("VLF_FUZZ_REPLAY") else {
        return;
    };
    let result = scene::load(Path::new(&path));
    println!("{path}: {:?}", result.map(|s| s.summary()));
}
