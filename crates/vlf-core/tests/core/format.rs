//! The `.vlf` file: round trips, every rejection (message and path), atomic writes, the
//! pinned on-disk layout, and the light-encoding error measurements of `docs/FORMAT.md`
//! (`cargo test -p vlf-core --test core format::encoding_error -- --nocapture` prints the table).

use crate::scenes;

use std::fs;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use vlf_core::directions::DirectionSet;
use vlf_core::format::disk::{
    self, FileFace, FileHeader, FileTriangle, PREAMBLE_LEN, Preamble, SectionEntry,
};
use vlf_core::format::shading::{FileMaterial, FileTexture, FileUvs};
use vlf_core::format::{self, FormatError};
use vlf_core::hash;
use vlf_core::lightfield::{
    BakeFace, BakeParams, BakeStats, BakeTriangle, DEFAULT_ENCODING, Iterations, LightField,
    NO_TEXTURE, NonFiniteRadiance, Radiance, RadianceEncoding, Shading, SurfaceMaterial,
    SurfaceTexture,
};
use vlf_core::scene::{Camera, SceneSummary, Similarity, WrapMode};

// ----- fixtures -----------------------------------------------------------------------------

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Log-uniform in [lo, hi).
    fn log_uniform(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + self.unit() * (hi.ln() - lo.ln())).exp()
    }
}

/// A unique scratch directory under the target dir.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("format-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// The radiance values of [`synthetic`] (f32, before encoding): HDR 1e-4..1e2 with zeros and
/// one clamped hot texel.
fn synthetic_values(texels: u32, seed: u64) -> Vec<[f32; 4]> {
    let mut rng = Rng(seed | 1);
    let mut radiance: Vec<[f32; 4]> = (0..texels)
        .map(|t| {
            if t % 17 == 0 {
                [0.0; 4]
            } else {
                let l = rng.log_uniform(1e-4, 1e2);
                [l * rng.unit(), l * rng.unit(), l, 0.0]
            }
        })
        .collect();
    if let Some(t) = radiance.get_mut(5) {
        *t = [1e6, 3.0, 1e-9, 0.0]; // clamped and underflowing components
    }
    radiance
}

/// Materials of [`synthetic`]: diffuse with a base-colour texture (5 × 3, repeat / clamp),
/// a mirror, mixed and emissive with an emissive texture (2 × 2, mirrored / repeat); face `i`
/// has material `i % 3` (its kind). Uvs spread over [−1, 2].
fn synthetic_shading(triangles: usize, seed: u64) -> Shading {
    let mut rng = Rng(seed.wrapping_mul(31) | 1);
    let texels: Vec<[f32; 4]> = (0..5 * 3 + 2 * 2)
        .map(|_| [rng.unit(), rng.unit(), rng.unit(), 0.0])
        .collect();
    Shading {
        materials: vec![
            SurfaceMaterial {
                base_color: [0.9, 0.8, 0.7],
                diffuse_weight: 1.0,
                emission: [0.0; 3],
                base_color_texture: 0,
                emissive_texture: NO_TEXTURE,
                specular_alpha: 0.0,
                ..SurfaceMaterial::opaque_default()
            },
            SurfaceMaterial {
                base_color: [1.0; 3],
                diffuse_weight: 0.0,
                emission: [0.0; 3],
                base_color_texture: NO_TEXTURE,
                emissive_texture: NO_TEXTURE,
                specular_alpha: 0.0625,
                ..SurfaceMaterial::opaque_default()
            },
            SurfaceMaterial {
                base_color: [0.5, 0.25, 0.125],
                diffuse_weight: 0.5,
                emission: [17.0, 12.0, 4.0],
                base_color_texture: NO_TEXTURE,
                emissive_texture: 1,
                specular_alpha: 0.2,
                ..SurfaceMaterial::opaque_default()
            },
        ],
        uvs: (0..triangles)
            .map(|_| {
                let mut uv = || 3.0 * rng.unit() - 1.0;
                [[uv(), uv()], [uv(), uv()], [uv(), uv()]]
            })
            .collect(),
        uvs1: None,
        normals: None,
        colors: None,
        textures: vec![
            SurfaceTexture {
                width: 5,
                height: 3,
                wrap_s: WrapMode::Repeat,
                wrap_t: WrapMode::ClampToEdge,
            },
            SurfaceTexture {
                width: 2,
                height: 2,
                wrap_s: WrapMode::MirroredRepeat,
                wrap_t: WrapMode::Repeat,
            },
        ],
        texels: Radiance::from_f32(&texels, RadianceEncoding::RgbF16).unwrap(),
        alpha: Vec::new(),
    }
}

/// A small synthetic light field: `faces` square-ish faces of `w × h` texels per side, two
/// triangles each, [`synthetic_values`] irradiance in the default encoding,
/// [`synthetic_shading`], two cameras.
fn synthetic(faces: u32, w: u32, h: u32, seed: u64) -> LightField {
    synthetic_in(faces, w, h, seed, DEFAULT_ENCODING)
}

/// [`synthetic`] with the irradiance encoded as `enc`.
fn synthetic_in(faces: u32, w: u32, h: u32, seed: u64, enc: RadianceEncoding) -> LightField {
    let mut fs_ = Vec::new();
    let mut tris = Vec::new();
    let mut base = 0;
    for i in 0..faces {
        let z = -0.5 + i as f32 * 0.1;
        fs_.push(BakeFace {
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
            specular: if i % 3 == 0 { 0.0 } else { 0.5 },
            material: i % 3,
        });
        base += 2 * w * h;
        tris.push(BakeTriangle {
            p0: [-0.5, -0.5, z],
            face: i,
            p1: [0.5, -0.5, z],
            _pad0: 0,
            p2: [0.5, 0.5, z],
            _pad1: 0,
        });
        tris.push(BakeTriangle {
            p0: [-0.5, -0.5, z],
            face: i,
            p1: [0.5, 0.5, z],
            _pad0: 0,
            p2: [-0.5, 0.5, z],
            _pad1: 0,
        });
    }
    let irradiance = Radiance::from_f32(&synthetic_values(base, seed), enc).unwrap();
    let params = BakeParams {
        directions: 21,
        iterations: Iterations::Fixed(3),
        final_gather: Some(crate::bakes::fixed_gather(0.5, 2.0, [64, 16, 256])),
        ..BakeParams::paper()
    };
    LightField {
        directions: DirectionSet::at_least(params.directions).unwrap(),
        params,
        to_vlf: Similarity {
            center: Vec3::new(0.25, -1.0, 3.5),
            scale: 0.125,
        },
        scene: SceneSummary {
            source: "synthetic/scene.gltf".into(),
            triangles: tris.len(),
            faces: fs_.len(),
            materials: 3,
            diffuse_materials: 1,
            mirror_materials: 1,
            mixed_materials: 1,
            emissive_materials: 1,
            emissive_faces: 1,
            emissive_triangles: 2,
            cameras: 2,
            suns: 0,
            textures: 2,
            bounds_min: [-4.0, -4.0, -4.0],
            bounds_max: [4.0, 4.0, 4.0],
            warnings: 0,
        },
        cameras: vec![
            Camera {
                name: Some("front".into()),
                position: Vec3::new(0.0, 1.0, 5.0),
                rotation: Quat::from_rotation_y(0.3),
                yfov: 0.7,
                aspect_ratio: Some(1.5),
                znear: 0.1,
                zfar: None,
            },
            Camera {
                name: None,
                position: Vec3::ZERO,
                rotation: Quat::IDENTITY,
                yfov: 1.0,
                aspect_ratio: None,
                znear: 0.01,
                zfar: Some(100.0),
            },
        ],
        shading: synthetic_shading(tris.len(), seed),
        triangles: tris,
        faces: fs_,
        irradiance,
        tiles: None,
        stats: BakeStats {
            iterations: 3,
            device: "cpu".into(),
            adapter: "CPU reference".into(),
            phases: vec![("prepare".into(), 0.25), ("propagate".into(), 2.5)],
            emitted: 1.5,
            injected: 0.0,
            absorbed: 1.2,
            escaped: 0.1,
            unshot: 0.2,
            unshot_history: vec![0.9, 0.45, 0.2],
        },
    }
}

fn small() -> LightField {
    synthetic(3, 20, 30, 7) // 3600 texels
}

fn small_in(enc: RadianceEncoding) -> LightField {
    synthetic_in(3, 20, 30, 7, enc)
}

/// What reading back a file of `lf` written as `enc` must give: the irradiance and tiles
/// re-encoded when `lf` holds another encoding (textures stay f16), else `lf` itself.
fn expected(lf: &LightField, enc: RadianceEncoding) -> LightField {
    let mut e = lf.clone();
    e.irradiance = lf.irradiance.to_encoding(enc);
    if let Some(t) = e.tiles.as_mut() {
        t.radiance = t.radiance.to_encoding(enc);
    }
    e
}

fn assert_bit_exact(a: &LightField, b: &LightField) {
    assert_eq!(a, b);
    assert_eq!(a.irradiance.encoding(), b.irradiance.encoding());
    assert!(
        a.irradiance.as_bytes() == b.irradiance.as_bytes(),
        "irradiance differs bitwise"
    );
    assert!(
        a.shading.texels.as_bytes() == b.shading.texels.as_bytes(),
        "texels differ bitwise"
    );
    let bits = |l: &LightField| -> Vec<u32> {
        let floats = l.shading.materials.iter().flat_map(|m| {
            m.base_color
                .into_iter()
                .chain(m.emission)
                .chain([m.diffuse_weight])
        });
        let uvs = l.shading.uvs.iter().flatten().flatten().copied();
        (l.irradiance.iter().flatten())
            .chain(floats)
            .chain(uvs)
            .map(|x| x.to_bits())
            .collect()
    };
    assert!(bits(a) == bits(b), "decoded values differ bitwise");
}

fn bytes_of(lf: &LightField, enc: RadianceEncoding) -> Vec<u8> {
    format::to_bytes(lf, enc, Path::new("mem.vlf")).unwrap()
}

fn header_of(file: &[u8]) -> FileHeader {
    let p = Preamble::from_bytes(file[..PREAMBLE_LEN].try_into().unwrap());
    disk::decode_header(&file[PREAMBLE_LEN..PREAMBLE_LEN + p.header_len as usize]).unwrap()
}

fn entry<'h>(h: &'h mut FileHeader, name: &str) -> &'h mut SectionEntry {
    h.sections.iter_mut().find(|s| s.name == name).unwrap()
}

/// Edits the bytes of section `name` and stores its new checksum (and the header's).
fn patch_section(file: &[u8], name: &str, edit: impl FnOnce(&mut [u8])) -> Vec<u8> {
    let h = header_of(file);
    let s = h.sections.iter().find(|s| s.name == name).unwrap().clone();
    let mut f = file.to_vec();
    let range = s.offset as usize..(s.offset + s.byte_len) as usize;
    edit(&mut f[range.clone()]);
    let checksum = hash::section_checksum(&f[range]);
    disk::rewrite_header(&f, |h| entry(h, name).checksum = checksum).unwrap()
}

fn read_err(file: &[u8]) -> String {
    let path = Path::new("dir/bad.vlf");
    match format::read_bytes(file, path) {
        Ok(_) => panic!("accepted"),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.ends_with(": dir/bad.vlf"), "path not last: {msg}");
            msg
        }
    }
}

fn assert_msg(file: &[u8], expected: &str) {
    let msg = read_err(file);
    assert!(msg.contains(expected), "message {msg:?} lacks {expected:?}");
}

fn file_names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// ----- round trips --------------------------------------------------------------------------

#[test]
fn round_trip_is_bit_exact_for_both_encodings() {
    let dir = scratch("round-trip");
    for enc in RadianceEncoding::ALL {
        // In memory as stored: the file holds these bytes, and reading gives them back.
        let lf = small_in(enc);
        let path = dir.join(format!("{}.vlf", enc.name()));
        let n = format::write_atomic_with(&path, &lf, enc).unwrap();
        assert_eq!(n, fs::metadata(&path).unwrap().len());
        let back = format::read(&path).unwrap();
        assert_bit_exact(&back, &lf);
        let mem = format::read_bytes(&fs::read(&path).unwrap(), &path).unwrap();
        assert_bit_exact(&mem, &back);
        let file = fs::read(&path).unwrap();
        assert_eq!(file, bytes_of(&lf, enc), "deterministic bytes");
        let h = header_of(&file);
        let section = |name: &str| {
            let s = h.sections.iter().find(|s| s.name == name).unwrap();
            &file[s.offset as usize..(s.offset + s.byte_len) as usize]
        };
        assert_eq!(
            section("irradiance"),
            lf.irradiance.as_bytes(),
            "the section holds the in-memory bytes"
        );
        assert_eq!(section("texels"), lf.shading.texels.as_bytes());
        // Writing what was read gives the same file.
        assert_eq!(bytes_of(&back, enc), file);
        // The stored values are the f32 values quantised by the encoding.
        let want = enc.quantize(&synthetic_values(3600, 7)).unwrap();
        assert_eq!(back.irradiance.to_f32(), want);
        for (i, v) in want.iter().enumerate() {
            assert_eq!(back.irradiance.get(i), [v[0], v[1], v[2]]);
        }
        // Written in the other encoding: re-encoded, and read back as such; the textures stay
        // f16 whatever the encoding.
        for other in RadianceEncoding::ALL {
            let back = format::read_bytes(&bytes_of(&lf, other), &path).unwrap();
            assert_eq!(back.irradiance.encoding(), other);
            assert_eq!(back.shading.texels.encoding(), RadianceEncoding::RgbF16);
            assert_bit_exact(&back, &expected(&lf, other));
        }
    }
    let lf = small();
    // The default is half-float RGB.
    let path = dir.join("default.vlf");
    format::write_atomic(&path, &lf).unwrap();
    assert_eq!(
        format::describe(&path).unwrap().radiance_encoding,
        DEFAULT_ENCODING.name()
    );
    assert_eq!(DEFAULT_ENCODING, RadianceEncoding::RgbF16);
}

#[test]
fn the_gathers_sampling_and_denoiser_round_trip_in_an_optional_section() {
    use vlf_core::lightfield::Denoiser;
    let dir = scratch("gather-sampling");
    for denoise in [Denoiser::Edge, Denoiser::Oidn] {
        let mut lf = small();
        let g = lf.params.final_gather.as_mut().unwrap();
        g.sampling = vlf_core::lightfield::Sampling {
            guided: true,
            target_error: 0.05,
            max_rounds: 8,
        };
        g.denoise = denoise;
        let path = dir.join("sampled.vlf");
        format::write_atomic(&path, &lf).unwrap();
        let back = format::read(&path).unwrap();
        assert_eq!(back.params, lf.params);
        // `describe` (what `vlf-bake batch` reads to decide whether an output is up to date)
        // sees the same parameters: it read the header's alone, so every default bake looked
        // baked with other parameters and was baked again.
        assert_eq!(format::describe(&path).unwrap().params, lf.params);
        let file = fs::read(&path).unwrap();
        let h = header_of(&file);
        let s = h
            .sections
            .iter()
            .find(|s| s.name == "gather_sampling")
            .expect("the section is written");
        assert!(!s.required, "older readers skip it");
        // The denoiser's word (the record's last u32): vlf's filter is 1, as when the record
        // was a bool, so files from before OIDN read as they did; OIDN is 2.
        let word = |f: &[u8]| {
            let at = (s.offset + s.byte_len) as usize - 4;
            u32::from_le_bytes(f[at..at + 4].try_into().unwrap())
        };
        let expected = if denoise == Denoiser::Edge { 1 } else { 2 };
        assert_eq!(word(&file), expected);
        if denoise == Denoiser::Edge {
            // An older file that says "off" in the record (guided sampling, no filter).
            let off = patch_section(&file, "gather_sampling", |b| {
                let n = b.len();
                b[n - 4..].copy_from_slice(&0u32.to_le_bytes());
            });
            let back = format::read_bytes(&off, &path).unwrap();
            assert_eq!(back.params.final_gather.unwrap().denoise, Denoiser::Off);
            // A denoiser this build does not know: an error naming the value and the file.
            let bad = patch_section(&file, "gather_sampling", |b| {
                let n = b.len();
                b[n - 4..].copy_from_slice(&7u32.to_le_bytes());
            });
            let msg = read_err(&bad);
            assert!(msg.contains("unknown denoiser 7"), "{msg}");
        }
    }
    // A fixed-count gather writes no such section: its files are as before.
    let plain = small();
    let h = header_of(&bytes_of(&plain, DEFAULT_ENCODING));
    assert!(h.sections.iter().all(|s| s.name != "gather_sampling"));
}

/// A light field with alpha masks keeps them: the `surfaces` and `texture_alpha` sections
/// (required) round-trip, and the masks read back are the bake's; files without masks have
/// neither section.
#[test]
fn alpha_masks_round_trip_in_their_sections() {
    let dir = scratch("alpha-masks");
    let scene = scenes::striped_screen(true);
    let params = vlf_core::lightfield::BakeParams {
        directions: 21,
        resolution: 16,
        tile: 4,
        iterations: vlf_core::lightfield::Iterations::Fixed(1),
        ..vlf_core::lightfield::BakeParams::paper()
    };
    let lf = vlf_core::pipeline::bake_cpu(&scene, &params).unwrap();
    assert!(lf.shading.has_masks());
    let path = dir.join("masked.vlf");
    format::write_atomic(&path, &lf).unwrap();
    let back = format::read(&path).unwrap();
    assert_eq!(back.shading, lf.shading);
    assert_eq!(back.alpha_masks(), lf.alpha_masks());
    assert_eq!(
        back.alpha_masks(),
        vlf_core::lightfield::AlphaMasks::from_scene(&scene)
    );
    let h = header_of(&fs::read(&path).unwrap());
    for name in ["surfaces", "texture_alpha"] {
        let s = h.sections.iter().find(|s| s.name == name).unwrap();
        assert!(
            s.required,
            "{name}: a reader that skipped it would draw holes opaque"
        );
    }
    let h = header_of(&bytes_of(&small(), DEFAULT_ENCODING));
    assert!(
        h.sections
            .iter()
            .all(|s| s.name != "surfaces" && s.name != "texture_alpha")
    );
}

#[test]
fn round_trip_of_edge_cases() {
    // No geometry, materials or textures at all, and a field whose irradiance spans several
    // checksum blocks and the multi-threaded path (> 4 MiB encoded).
    let mut empty = small();
    empty.triangles.clear();
    empty.faces.clear();
    empty.cameras.clear();
    empty.shading = Shading::empty();
    empty.params.final_gather = None;
    empty.stats = BakeStats::default();
    for enc in RadianceEncoding::ALL {
        empty.irradiance = Radiance::new(enc);
        let back = format::read_bytes(&bytes_of(&empty, enc), Path::new("e.vlf")).unwrap();
        assert_bit_exact(&back, &empty);
    }
    let dir = scratch("big");
    for enc in RadianceEncoding::ALL {
        // 1 228 800 texels (odd blocks): 4.9 / 7.4 MB encoded, several threads.
        let big = synthetic_in(2, 512, 600, 3, enc);
        let path = dir.join("big.vlf");
        format::write_atomic_with(&path, &big, enc).unwrap();
        let back = format::read(&path).unwrap();
        assert_bit_exact(&back, &big);
        assert_eq!(
            back.irradiance.to_f32(),
            enc.quantize(&synthetic_values(2 * 2 * 512 * 600, 3))
                .unwrap()
        );
        // A flipped bit in a late block is caught by the threaded reader.
        let mut f = fs::read(&path).unwrap();
        let n = f.len();
        f[n - 10] ^= 4;
        assert_msg(&f, "checksum mismatch in irradiance");
    }
}

#[test]
fn describe_reads_the_header_only() {
    let dir = scratch("describe");
    let lf = small();
    let path = dir.join("d.vlf");
    let n = format::write_atomic(&path, &lf).unwrap();
    let info = format::describe(&path).unwrap();
    assert_eq!(info.file_bytes, n);
    assert_eq!(info.format_version, disk::VERSION);
    assert_eq!((info.triangles, info.faces, info.texels), (6, 3, 3600));
    assert_eq!(info.directions as usize, lf.directions.len());
    assert_eq!(info.params, lf.params);
    assert_eq!(info.stats, lf.stats);
    assert_eq!(info.cameras, ["front", "camera 1"]);
    let names: Vec<&str> = info.sections.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "triangles",
            "faces",
            "materials",
            "uvs",
            "textures",
            "texels",
            "irradiance"
        ]
    );
    assert_eq!(
        (info.materials, info.textures, info.texture_texels),
        (3, 2, 19)
    );
    assert_eq!(info.memory.light_file_bytes, 3600 * 6);
    assert_eq!(info.memory.light_f32_bytes, 3600 * 16);
    assert_eq!(info.memory.geometry_bytes, 6 * 48 + 3 * 80);
    let shading = 3 * 40 + 6 * 24 + 2 * 16 + 19 * 6;
    assert_eq!(info.memory.shading_bytes, shading);
    // Light and texels stay in their stored encoding once loaded.
    assert_eq!(
        info.memory.loaded_bytes,
        3600 * 6 + 6 * 48 + 3 * 80 + shading
    );
    let back = format::read(&path).unwrap();
    assert_eq!(back.light_bytes() as u64, info.memory.light_file_bytes);
    assert_eq!(back.shading.texels.byte_len(), 19 * 6);
    let text = info.to_string();
    for needle in [
        "d.vlf",
        "version 3",
        "irradiance in rgb16f; 3 materials, 2 textures (19 texels, f16 RGB)",
        "final gather  texel scale 0.5, indirect texel scale 2; 64 light samples, 16 direct rays, 256 indirect rays; atlas denoiser none",
        "6 triangles, 3 faces",
        "shading 410 B",
        "propagate",
    ] {
        assert!(text.contains(needle), "{needle:?} missing from\n{text}");
    }
    // Cheap: a file whose sections are corrupt still describes (their checksums are not read).
    let mut f = fs::read(&path).unwrap();
    let last = f.len() - 1;
    f[last] ^= 1;
    assert!(format::describe_bytes(&f, &path).is_ok());
    assert!(format::read_bytes(&f, &path).is_err());
    fn is_serialize<T: serde::Serialize>(_: &T) {}
    is_serialize(&info);
}

// ----- rejections ---------------------------------------------------------------------------

#[test]
fn rejects_missing_and_non_files() {
    let dir = scratch("missing");
    let e = format::read(&dir.join("nope.vlf")).unwrap_err();
    assert!(matches!(e, FormatError::Read { .. }), "{e}");
    assert!(e.to_string().starts_with("cannot read light-field file ("));
    assert!(e.to_string().ends_with("nope.vlf"));
    let e = format::read(&dir).unwrap_err().to_string();
    assert!(e.contains("not a regular file"), "{e}");
    assert!(format::describe(&dir).is_err());
}

#[test]
fn rejects_bad_magic() {
    assert_msg(
        b"glTF\x02\0\0\0rest of a glb",
        "not a vlf light-field file (it starts with \"glTF\\x02\\x00\\x00\\x00\"",
    );
    assert_msg(
        b"",
        "not a vlf light-field file (it starts with nothing (the file is empty)",
    );
    assert_msg(b"VLFX", "not a vlf light-field file");
    let mut f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    f[0] = b'v';
    assert_msg(&f, "not a vlf light-field file");
}

#[test]
fn rejects_unsupported_versions() {
    let f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    for (v, why) in [
        (4u32, "; the file was written by a newer vlf"),
        (
            2,
            "; the file was written by an older vlf: bake the scene again",
        ),
        (
            1,
            "; the file was written by an older vlf: bake the scene again",
        ),
        (
            0,
            "; the file was written by an older vlf: bake the scene again",
        ),
    ] {
        let mut g = f.clone();
        g[8..12].copy_from_slice(&v.to_le_bytes());
        let msg = read_err(&g);
        let want =
            format!("unsupported .vlf format version {v} (this build reads version 3 only{why}): ");
        assert!(msg.starts_with(&want), "{msg}");
        assert!(format::describe_bytes(&g, Path::new("x.vlf")).is_err());
    }
}

#[test]
fn rejects_truncated_files() {
    let f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    let n = f.len();
    assert_msg(
        &f[..n - 100],
        &format!("truncated file (expected {n} bytes, found {})", n - 100),
    );
    assert_msg(
        &f[..n - 1],
        &format!("truncated file (expected {n} bytes, found {})", n - 1),
    );
    // Inside the header and inside the preamble.
    assert_msg(
        &f[..40],
        &format!("truncated file (expected {n} bytes, found 40)"),
    );
    assert_msg(&f[..20], "truncated file (expected 32 bytes, found 20)");
    assert_msg(&f[..5], "truncated file (expected 32 bytes, found 5)");
    // And too long.
    let mut g = f.clone();
    g.extend_from_slice(&[0; 16]);
    assert_msg(
        &g,
        &format!(
            "file is longer than its header says (expected {n} bytes, found {})",
            n + 16
        ),
    );
}

#[test]
fn rejects_checksum_mismatches_naming_the_section() {
    let f = bytes_of(&small(), RadianceEncoding::RgbF16);
    let h = header_of(&f);
    for s in &h.sections {
        let mut g = f.clone();
        g[(s.offset + s.byte_len / 2) as usize] ^= 0x10;
        assert_msg(&g, &format!("checksum mismatch in {} (stored", s.name));
    }
    let mut g = f.clone();
    g[PREAMBLE_LEN + 3] ^= 1;
    assert_msg(&g, "checksum mismatch in header");
    // The preamble's lengths are covered by the header checksum too.
    let mut g = f.clone();
    g[16] ^= 1; // file_len
    assert_msg(&g, "checksum mismatch in header");
    // A stale section checksum in an otherwise consistent file.
    let g = disk::rewrite_header(&f, |h| entry(h, "faces").checksum ^= 1).unwrap();
    assert_msg(&g, "checksum mismatch in faces");
}

#[test]
fn rejects_absurd_header_lengths_without_allocating() {
    let f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    let mut g = f.clone();
    g[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_msg(
        &g,
        "header length 4294967295 bytes exceeds the limit of 16777216 bytes",
    );
    let mut g = f.clone();
    g[12..16].copy_from_slice(&(1u32 << 24).to_le_bytes()); // within the cap, beyond the file
    assert_msg(
        &g,
        &format!(
            "truncated file (expected 16777248 bytes, found {})",
            f.len()
        ),
    );
}

#[test]
fn rejects_corrupt_headers() {
    let f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    // Garbage with a valid checksum: bincode fails (or finds a huge length) without allocating.
    let p = Preamble::from_bytes(f[..PREAMBLE_LEN].try_into().unwrap());
    let mut g = f.clone();
    for b in &mut g[PREAMBLE_LEN + 40..PREAMBLE_LEN + p.header_len as usize] {
        *b = 0xFF;
    }
    let sum = disk::header_checksum(&p, &g[PREAMBLE_LEN..PREAMBLE_LEN + p.header_len as usize]);
    g[24..32].copy_from_slice(&sum.to_le_bytes());
    assert_msg(&g, "corrupt header (");
    let g = disk::rewrite_header(&f, |h| h.radiance_encoding = 9).unwrap();
    assert_msg(
        &g,
        "corrupt header (unknown radiance encoding 9 (this build reads 1 (rgb9e5), 2 (rgb16f)))",
    );
}

#[test]
fn rejects_inconsistent_section_tables() {
    let f = bytes_of(&small(), RadianceEncoding::Rgb9e5);
    let h = header_of(&f);
    let faces = h
        .sections
        .iter()
        .find(|s| s.name == "faces")
        .unwrap()
        .clone();
    type Edit = Box<dyn Fn(&mut FileHeader)>;
    let cases: Vec<(Edit, String)> = vec![
        (
            Box::new(|h| entry(h, "faces").count += 1),
            "section faces: 4 elements × 80 bytes ≠ its byte length 240".into(),
        ),
        (
            Box::new(|h| entry(h, "triangles").byte_len -= 48),
            "section triangles: 6 elements × 48 bytes ≠ its byte length 240".into(),
        ),
        (
            Box::new(|h| entry(h, "faces").offset += 8),
            format!("section faces: offset {} is not a multiple of 16", faces.offset + 8),
        ),
        (
            Box::new(move |h| entry(h, "faces").offset -= 16),
            "overlap section triangles".into(),
        ),
        (
            Box::new(|h| entry(h, "irradiance").offset += 1 << 20),
            "section irradiance: bytes".into(),
        ),
        (
            Box::new(|h| entry(h, "faces").offset = 16),
            "section faces: offset 16 lies inside the header".into(),
        ),
        (
            // Absurd but self-consistent sizes: rejected against the file size, no allocation.
            Box::new(|h| {
                let r = entry(h, "irradiance");
                r.count = 1 << 40;
                r.byte_len = 4 << 40;
            }),
            "lie beyond the end of the file".into(),
        ),
        (
            Box::new(|h| {
                let r = entry(h, "triangles");
                r.count = u64::MAX / 2;
            }),
            "elements × 48 bytes ≠ its byte length".into(),
        ),
        (
            Box::new(|h| entry(h, "faces").elem_size = 64),
            "section faces: kind 2 with 64-byte elements, expected kind 2 with 80-byte elements".into(),
        ),
        (
            Box::new(|h| entry(h, "faces").kind = 1),
            "section faces: kind 1 with 80-byte elements, expected kind 2".into(),
        ),
        (
            Box::new(|h| {
                h.sections.retain(|s| s.name != "faces");
            }),
            "section faces: missing from the section table".into(),
        ),
        (
            Box::new(|h| {
                h.sections.retain(|s| s.name != "textures");
            }),
            "section textures: missing from the section table".into(),
        ),
        (
            Box::new(|h| {
                let dup = h.sections[0].clone();
                h.sections.push(dup);
            }),
            "section triangles: appears twice in the section table".into(),
        ),
        (
            Box::new(|h| h.texels += 1),
            "section irradiance: 3600 texels, but the header says 3601".into(),
        ),
        (
            Box::new(|h| {
                let u = entry(h, "uvs");
                u.count -= 1;
                u.byte_len -= 24;
            }),
            "section uvs: 5 uv triples for 6 triangles".into(),
        ),
        (
            Box::new(|h| entry(h, "texels").elem_size = 8),
            "section texels: kind 8 with 8-byte elements, expected kind 8 with 6-byte elements"
                .into(),
        ),
        (
            Box::new(|h| entry(h, "materials").kind = 3),
            "section materials: kind 3 with 40-byte elements, expected kind 5".into(),
        ),
        (
            Box::new(|h| {
                h.sections.push(SectionEntry {
                    name: "mirror_tiles".into(),
                    kind: 77,
                    required: true,
                    offset: 0,
                    byte_len: 0,
                    count: 0,
                    elem_size: 64,
                    checksum: 0,
                })
            }),
            "section mirror_tiles: required section of kind 77 unknown to this build (written by a newer vlf?)".into(),
        ),
    ];
    for (edit, want) in cases {
        let g = disk::rewrite_header(&f, edit).unwrap();
        assert_msg(&g, &want);
    }
    // An unknown optional section is skipped.
    let g = disk::rewrite_header(&f, |h| {
        h.sections.push(SectionEntry {
            name: "future".into(),
            kind: 99,
            required: false,
            offset: faces.offset,
            byte_len: 0,
            count: 0,
            elem_size: 8,
            checksum: 0,
        })
    })
    .unwrap();
    assert_bit_exact(
        &format::read_bytes(&g, Path::new("x.vlf")).unwrap(),
        &expected(&small(), RadianceEncoding::Rgb9e5),
    );
}

#[test]
fn rejects_inconsistent_content() {
    let f = bytes_of(&small(), RadianceEncoding::RgbF16);
    let face_field = |i: usize, word: usize, value: u32| {
        move |b: &mut [u8]| {
            let at = i * size_of::<FileFace>() + 4 * word;
            b[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
    };
    // Face 2 (texel_base is word 16) reaching beyond the 3600 texels.
    let g = patch_section(&f, "faces", face_field(2, 16, 3000));
    assert_msg(
        &g,
        "face 2: texels 3000..4200 lie beyond the irradiance array (3600 texels): ",
    );
    let g = patch_section(&f, "faces", face_field(1, 19, 3)); // material
    assert_msg(&g, "face 1: material 3 is out of range (3 materials): ");
    let g = patch_section(&f, "faces", face_field(1, 15, 0)); // height
    assert_msg(&g, "face 1: empty chart (20 × 0 texels)");
    let g = patch_section(&f, "faces", face_field(0, 17, 9)); // kind
    assert_msg(&g, "face 0: unknown face kind 9");
    let g = patch_section(&f, "faces", face_field(0, 1, f32::NAN.to_bits()));
    assert_msg(&g, "face 0: non-finite value");
    // Triangle 4's face index (word 3).
    let g = patch_section(&f, "triangles", |b| {
        let at = 4 * size_of::<FileTriangle>() + 12;
        b[at..at + 4].copy_from_slice(&3u32.to_le_bytes());
    });
    assert_msg(&g, "triangle 4: face index 3 is out of range (3 faces)");
    let g = patch_section(&f, "triangles", |b| {
        b[4 * 9..4 * 10].copy_from_slice(&f32::INFINITY.to_bits().to_le_bytes());
    });
    assert_msg(&g, "triangle 0: non-finite vertex coordinate");
    // Half-float irradiance and texels that no writer produces.
    let g = patch_section(&f, "irradiance", |b| {
        b[6 * 7 + 2..6 * 7 + 4].copy_from_slice(&[0, 0x7C])
    });
    assert_msg(
        &g,
        "irradiance texel 7: not a stored rgb16f value (negative, infinite or NaN)",
    );
    let g = patch_section(&f, "irradiance", |b| b[6 * 9 + 1] |= 0x80);
    assert_msg(&g, "irradiance texel 9: not a stored rgb16f value");
    let g = patch_section(&f, "texels", |b| b[6 * 4 + 3] = 0xFE); // NaN
    assert_msg(&g, "texture texel 4: not a stored rgb16f value");
    // Also in a late block of a large section, checked on another thread.
    let big = synthetic(2, 512, 600, 3);
    let g = patch_section(
        &bytes_of(&big, RadianceEncoding::RgbF16),
        "irradiance",
        |b| {
            b[6 * 1_200_001 + 5] = 0xFC; // -inf
        },
    );
    assert_msg(&g, "irradiance texel 1200001: not a stored rgb16f value");
    // Materials (10 words: base colour, diffuse weight, emission, texture indices, GGX α).
    let word = |i: usize, size: usize, w: usize, value: u32| {
        move |b: &mut [u8]| {
            let at = i * size + 4 * w;
            b[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
    };
    let mat = |i, w, value| {
        patch_section(
            &f,
            "materials",
            word(i, size_of::<FileMaterial>(), w, value),
        )
    };
    assert_msg(
        &mat(0, 7, 2),
        "material 0: base-colour texture 2 is out of range (2 textures): ",
    );
    assert_msg(
        &mat(2, 8, 5),
        "material 2: emissive texture 5 is out of range (2 textures)",
    );
    assert_msg(
        &mat(1, 4, (-1.0f32).to_bits()),
        "material 1: colour factors must be finite and non-negative",
    );
    assert_msg(
        &mat(1, 2, f32::NAN.to_bits()),
        "material 1: colour factors must be finite and non-negative",
    );
    assert_msg(
        &mat(0, 3, 1.5f32.to_bits()),
        "material 0: diffuse weight 1.5 is not in [0, 1]",
    );
    assert_msg(
        &mat(1, 9, f32::NAN.to_bits()),
        "material 1: GGX α NaN is not in [0, 1]",
    );
    // Uvs (6 floats per triangle) and textures (width, height, wrap_s, wrap_t).
    let g = patch_section(
        &f,
        "uvs",
        word(4, size_of::<FileUvs>(), 3, f32::INFINITY.to_bits()),
    );
    assert_msg(&g, "uvs of triangle 4: non-finite value");
    let tex =
        |i, w, value| patch_section(&f, "textures", word(i, size_of::<FileTexture>(), w, value));
    assert_msg(
        &tex(1, 3, 7),
        "texture 1: unknown wrap mode 7 (0 repeat, 1 clamp to edge, 2 mirrored repeat)",
    );
    assert_msg(
        &tex(0, 0, 0),
        "texture 0: size 0 × 3 is outside 1..=65536 per side",
    );
    assert_msg(
        &tex(1, 1, 70_000),
        "texture 1: size 2 × 70000 is outside 1..=65536 per side",
    );
    assert_msg(
        &tex(0, 1, 2),
        "textures: 2 textures need 14 texels, but there are 19",
    );
    // Final-gather settings.
    let g = disk::rewrite_header(&f, |h| {
        h.params.final_gather.as_mut().unwrap().indirect_texel_scale = 0.001
    })
    .unwrap();
    assert_msg(
        &g,
        "parameters: gather indirect_texel_scale = 0.001 is out of range (0.01..=64): ",
    );
    let g = disk::rewrite_header(&f, |h| {
        h.params.final_gather.as_mut().unwrap().texel_scale = f32::NAN
    })
    .unwrap();
    assert_msg(&g, "parameters: gather texel_scale = NaN is out of range");
    let g = disk::rewrite_header(&f, |h| {
        h.params.final_gather.as_mut().unwrap().indirect_rays = 1 << 20
    })
    .unwrap();
    assert_msg(
        &g,
        "parameters: gather indirect_rays = 1048576 is out of range",
    );
    // Header content.
    let g = disk::rewrite_header(&f, |h| h.params.resolution = 0).unwrap();
    assert_msg(
        &g,
        "parameters: resolution = 0 is out of range (1..=4096): ",
    );
    let g = disk::rewrite_header(&f, |h| h.directions.scheme = 5).unwrap();
    assert_msg(&g, "direction set: unknown construction scheme 5");
    let g = disk::rewrite_header(&f, |h| h.directions.frequency = 65).unwrap();
    assert_msg(
        &g,
        "direction set: direction-set frequency 65 is outside 1..=64",
    );
    let g = disk::rewrite_header(&f, |h| h.directions.count += 1).unwrap();
    assert_msg(
        &g,
        "direction set: frequency 2 gives 21 directions, but the header says 22",
    );
    let g = disk::rewrite_header(&f, |h| h.transform.scale = 0.0).unwrap();
    assert_msg(&g, "transform: centre");
    let g = disk::rewrite_header(&f, |h| h.cameras[1].position[0] = f32::NAN).unwrap();
    assert_msg(&g, "camera 1: non-finite value");
}

// ----- writing ------------------------------------------------------------------------------

#[test]
fn writer_rejects_unstorable_fields_before_touching_the_disk() {
    let dir = scratch("unstorable");
    let path = dir.join("out.vlf");
    fs::write(&path, b"old").unwrap();
    // NaN and infinity cannot even enter a light field: encoding names the value.
    let mut values = synthetic_values(3600, 7);
    for enc in RadianceEncoding::ALL {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            values[42][1] = bad;
            let e = Radiance::from_f32(&values, enc).unwrap_err();
            assert_eq!(e.index, 42);
            assert_eq!(e.value[0].to_bits(), values[42][0].to_bits());
            let msg = e.to_string();
            assert!(
                msg.starts_with("value 42: [")
                    && msg.ends_with("is not finite (NaN and infinity cannot be stored)"),
                "{msg}"
            );
        }
    }
    // The first one, also from a later block on another thread.
    let mut big = synthetic_values(1_300_000, 3);
    big[1_299_999][2] = f32::NAN;
    big[1_000_000][0] = f32::INFINITY;
    assert!(matches!(
        Radiance::from_f32(&big, RadianceEncoding::RgbF16),
        Err(NonFiniteRadiance {
            index: 1_000_000,
            ..
        })
    ));
    let mut lf = small();
    lf.faces[1].texel_base = 3590;
    let e = format::write_atomic(&path, &lf).unwrap_err().to_string();
    assert!(
        e.starts_with("face 1: texels 3590..4790 lie beyond the irradiance array"),
        "{e}"
    );
    // Shading that does not fit the geometry, or textures stored in another encoding.
    let mut lf = small();
    lf.shading.uvs.pop();
    let e = format::write_atomic(&path, &lf).unwrap_err().to_string();
    assert!(e.starts_with("uvs: 5 uv triples for 6 triangles: "), "{e}");
    let mut lf = small();
    lf.shading.texels = lf.shading.texels.to_encoding(RadianceEncoding::Rgb9e5);
    let e = format::write_atomic(&path, &lf).unwrap_err().to_string();
    assert!(
        e.starts_with("texels: stored as rgb9e5, not rgb16f: "),
        "{e}"
    );
    let mut lf = small();
    lf.faces[0].material = 3;
    assert!(format::write_atomic(&path, &lf).is_err());
    let mut lf = small();
    lf.triangles[0].face = 7;
    assert!(format::write_atomic(&path, &lf).is_err());
    assert_eq!(fs::read(&path).unwrap(), b"old");
    assert_eq!(file_names(&dir), ["out.vlf"]);
}

#[test]
fn atomic_write_replaces_and_leaves_no_temp_file() {
    let dir = scratch("atomic-ok");
    let path = dir.join("scene.vlf");
    let lf = small();
    format::write_atomic(&path, &lf).unwrap();
    assert_eq!(file_names(&dir), ["scene.vlf"]);
    // Overwrite an existing file with a different field.
    let other = synthetic(2, 8, 8, 99);
    format::write_atomic(&path, &other).unwrap();
    assert_eq!(file_names(&dir), ["scene.vlf"]);
    assert_bit_exact(
        &format::read(&path).unwrap(),
        &expected(&other, DEFAULT_ENCODING),
    );
}

#[test]
fn atomic_write_failures_leave_the_old_file_and_no_temp_file() {
    let dir = scratch("atomic-fail");
    let lf = small();
    // A directory at the target path: the rename fails after the temp file was written.
    let target = dir.join("taken.vlf");
    fs::create_dir(&target).unwrap();
    fs::write(target.join("inside"), b"keep").unwrap();
    let e = format::write_atomic(&target, &lf).unwrap_err().to_string();
    assert!(
        e.starts_with("cannot write light-field file (renaming .taken.vlf.tmp."),
        "{e}"
    );
    assert!(e.ends_with("taken.vlf"), "{e}");
    assert_eq!(file_names(&dir), ["taken.vlf"]);
    assert_eq!(fs::read(target.join("inside")).unwrap(), b"keep");
    // A missing directory.
    let e = format::write_atomic(&dir.join("no/such/dir.vlf"), &lf)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("cannot write light-field file (creating temporary file .dir.vlf.tmp."),
        "{e}"
    );
    // A read-only directory holding an old file (meaningless as root, which may write anyway).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.join("ro");
        fs::create_dir(&ro).unwrap();
        let old = ro.join("old.vlf");
        format::write_atomic(&old, &synthetic(1, 4, 4, 5)).unwrap();
        let before = fs::read(&old).unwrap();
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
        let probe = ro.join("probe");
        if fs::write(&probe, b"").is_ok() {
            fs::remove_file(&probe).unwrap();
            eprintln!("running as a user that ignores permissions: read-only case skipped");
        } else {
            let e = format::write_atomic(&old, &lf).unwrap_err().to_string();
            assert!(e.contains("creating temporary file"), "{e}");
            assert_eq!(fs::read(&old).unwrap(), before);
            assert_eq!(file_names(&ro), ["old.vlf"]);
        }
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
    }
}

// ----- pinned layout ------------------------------------------------------------------------

#[test]
fn on_disk_struct_layout_is_pinned() {
    use std::mem::offset_of;
    assert_eq!(size_of::<Preamble>(), 32);
    assert_eq!(offset_of!(Preamble, version), 8);
    assert_eq!(offset_of!(Preamble, header_len), 12);
    assert_eq!(offset_of!(Preamble, file_len), 16);
    assert_eq!(offset_of!(Preamble, header_checksum), 24);
    assert_eq!(size_of::<FileTriangle>(), 48);
    assert_eq!(offset_of!(FileTriangle, face), 12);
    assert_eq!(offset_of!(FileTriangle, p1), 16);
    assert_eq!(offset_of!(FileTriangle, p2), 32);
    assert_eq!(size_of::<FileFace>(), 80);
    assert_eq!(offset_of!(FileFace, offset), 12);
    assert_eq!(offset_of!(FileFace, origin), 16);
    assert_eq!(offset_of!(FileFace, texel_size), 28);
    assert_eq!(offset_of!(FileFace, u), 32);
    assert_eq!(offset_of!(FileFace, width), 44);
    assert_eq!(offset_of!(FileFace, v), 48);
    assert_eq!(offset_of!(FileFace, height), 60);
    assert_eq!(offset_of!(FileFace, texel_base), 64);
    assert_eq!(offset_of!(FileFace, kind), 68);
    assert_eq!(offset_of!(FileFace, specular), 72);
    assert_eq!(offset_of!(FileFace, material), 76);
    assert_eq!(size_of::<FileMaterial>(), 40);
    assert_eq!(offset_of!(FileMaterial, diffuse_weight), 12);
    assert_eq!(offset_of!(FileMaterial, emission), 16);
    assert_eq!(offset_of!(FileMaterial, base_color_texture), 28);
    assert_eq!(offset_of!(FileMaterial, emissive_texture), 32);
    assert_eq!(size_of::<FileUvs>(), 24);
    assert_eq!(size_of::<FileTexture>(), 16);
    assert_eq!(offset_of!(FileTexture, wrap_s), 8);
    assert_eq!(disk::TEXEL_BYTES, 6);
    assert_eq!(WrapMode::ALL.map(WrapMode::id), [0, 1, 2]);
    assert_eq!(WrapMode::from_id(2), Some(WrapMode::MirroredRepeat));
    assert_eq!(WrapMode::from_id(3), None);
    assert_eq!(RadianceEncoding::Rgb9e5.bytes_per_texel(), 4);
    assert_eq!(RadianceEncoding::RgbF16.bytes_per_texel(), 6);
    assert_eq!(
        (RadianceEncoding::Rgb9e5.id(), RadianceEncoding::RgbF16.id()),
        (1, 2)
    );
}

/// A tiny field whose file is small enough to pin byte for byte at its start.
fn tiny() -> LightField {
    let mut lf = synthetic(1, 1, 1, 1);
    lf.cameras.clear();
    lf.scene.source = "t".into();
    lf.stats = BakeStats::default();
    lf.params.final_gather = None;
    lf.shading.materials.truncate(1);
    lf.shading.materials[0].base_color_texture = NO_TEXTURE;
    lf.shading.textures.clear();
    lf.shading.texels = Radiance::new(RadianceEncoding::RgbF16);
    lf.irradiance =
        Radiance::from_f32(&[[1.0, 0.5, 0.25, 0.0], [0.0; 4]], DEFAULT_ENCODING).unwrap();
    lf
}

fn hex(b: &[u8]) -> String {
    b.iter()
        .map(|x| format!("{x:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn golden_bytes_of_a_tiny_file() {
    let f = bytes_of(&tiny(), RadianceEncoding::Rgb9e5);
    let p = Preamble::from_bytes(f[..32].try_into().unwrap());
    // Preamble: magic, version 3, header length, file length, header checksum.
    assert_eq!(&f[..8], b"VLFIELD\0");
    assert_eq!(hex(&f[8..24]), GOLDEN_PREAMBLE_8_24);
    assert_eq!(hex(&f[24..32]), GOLDEN_HEADER_CHECKSUM);
    // Header start (bincode standard: varints, little-endian floats): params.directions = 21,
    // resolution = 64, tile = 8, texel_scale = 1.0f32, iterations = Fixed(3), sky = 0, 0, 0,
    // perturb = 0, seed = 0x5eed0001 (varint 0xfc + u32), no final gather (0), direction
    // scheme 1, frequency 2, count 21, transform centre (0.25, -1, 3.5), scale 0.125.
    assert_eq!(hex(&f[32..80]), GOLDEN_HEADER_32_80);
    // The irradiance texel (1, 0.5, 0.25) in RGB9E5 is 256 | 128 << 9 | 64 << 18 | 16 << 27,
    // the last section, at the end of the file.
    let n = f.len();
    assert_eq!(hex(&f[n - 8..]), "00 01 01 81 00 00 00 00");
    assert_eq!(n as u64, p.file_len);
    assert_eq!(n, GOLDEN_LEN);
}

const GOLDEN_LEN: usize = 632;
const GOLDEN_PREAMBLE_8_24: &str = "03 00 00 00 37 01 00 00 78 02 00 00 00 00 00 00";
const GOLDEN_HEADER_CHECKSUM: &str = "41 db 66 fe 36 84 c7 9a";
const GOLDEN_HEADER_32_80: &str = "15 40 08 00 00 80 3f 00 03 00 00 00 00 00 00 00 00 00 00 00 00 00 fc 01 00 ed 5e 00 01 02 15 00 00 80 3e 00 00 80 bf 00 00 60 40 00 00 00 3e 01";

// ----- encoding measurements ----------------------------------------------------------------

/// Error statistics of one encoding on one data set.
#[derive(Default)]
struct ErrStats {
    /// Per-channel relative error |q − x| / x over components x > 0.
    chan: Vec<f64>,
    /// Relative error of the luminance (Rec. 709 weights).
    lum: Vec<f64>,
    /// Per-texel max channel error relative to the texel's largest component.
    rel_max: Vec<f64>,
    /// Per-texel max channel error in 8-bit sRGB steps, exposed so that its largest
    /// component displays as 1 (the exposure at which its errors are most visible).
    srgb_steps: Vec<f64>,
}

fn srgb(x: f64) -> f64 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn measure(data: &[[f32; 4]], enc: RadianceEncoding) -> ErrStats {
    let q = enc.quantize(data).unwrap();
    let mut s = ErrStats::default();
    let lum = |c: &[f32; 4]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
    for (x, y) in data.iter().zip(&q) {
        let m = x[..3].iter().fold(0f32, |a, &b| a.max(b)) as f64;
        if m < 1e-4 {
            continue; // black: zeros, and float noise on unlit back sides of baked atlases
        }
        let mut worst = 0f64;
        let mut steps = 0f64;
        for c in 0..3 {
            let d = (y[c] as f64 - x[c] as f64).abs();
            worst = worst.max(d / m);
            steps = steps.max(255.0 * (srgb(y[c] as f64 / m) - srgb(x[c] as f64 / m)).abs());
            if x[c] > 0.0 {
                s.chan.push(d / x[c] as f64);
            }
        }
        s.rel_max.push(worst);
        s.srgb_steps.push(steps);
        s.lum.push((lum(y) - lum(x)).abs() / lum(x));
    }
    s
}

/// Data sets: realistic HDR radiance and a Cornell-box-like atlas.
fn datasets() -> Vec<(&'static str, Vec<[f32; 4]>)> {
    let n = 200_000;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    // Luminance log-uniform in 1e-4..1e2, chroma of a random albedo in [0.05, 1]³.
    let realistic: Vec<[f32; 4]> = (0..n)
        .map(|_| {
            let l = rng.log_uniform(1e-4, 1e2);
            let a = [
                0.05 + 0.95 * rng.unit(),
                0.05 + 0.95 * rng.unit(),
                0.05 + 0.95 * rng.unit(),
            ];
            let k = l / (0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2]);
            [a[0] * k, a[1] * k, a[2] * k, 0.0]
        })
        .collect();
    // Grey radiance, log-uniform 1e-4..1e2.
    let grey: Vec<[f32; 4]> = (0..n)
        .map(|_| {
            let l = rng.log_uniform(1e-4, 1e2);
            [l, l, l, 0.0]
        })
        .collect();
    // Each channel independently log-uniform 1e-4..1e2 (a stress case for a shared exponent).
    let independent: Vec<[f32; 4]> = (0..n)
        .map(|_| {
            [
                rng.log_uniform(1e-4, 1e2),
                rng.log_uniform(1e-4, 1e2),
                rng.log_uniform(1e-4, 1e2),
                0.0,
            ]
        })
        .collect();
    // Cornell box: white / red / green walls (the classic albedos) lit by irradiance that
    // varies smoothly over 0.02..3 with colour bleeding from the coloured walls, plus the
    // emitter (17, 12, 4) and empty (uncovered) texels.
    let white = [0.73f32, 0.73, 0.73];
    let red = [0.63f32, 0.065, 0.05];
    let green = [0.14f32, 0.45, 0.091];
    let cornell: Vec<[f32; 4]> = (0..n)
        .map(|i| {
            let r = rng.unit();
            if r < 0.03 {
                return [0.0; 4];
            }
            if r < 0.04 {
                return [
                    17.0 + rng.unit() * 0.1,
                    12.0 + rng.unit() * 0.1,
                    4.0 + rng.unit() * 0.05,
                    0.0,
                ];
            }
            let albedo = if r < 0.24 {
                red
            } else if r < 0.44 {
                green
            } else {
                white
            };
            let e = rng.log_uniform(0.02, 3.0) * (1.0 + 0.2 * ((i as f32) * 0.001).sin());
            let (br, bg) = (0.3 * rng.unit(), 0.3 * rng.unit());
            let irr: [f32; 3] = std::array::from_fn(|c| e * (1.0 + br * red[c] + bg * green[c]));
            let c: [f32; 3] = std::array::from_fn(|c| albedo[c] * irr[c] / std::f32::consts::PI);
            [c[0], c[1], c[2], 0.0]
        })
        .collect();
    let mut sets = vec![
        ("realistic 1e-4..1e2", realistic),
        ("grey 1e-4..1e2", grey),
        ("independent channels", independent),
        ("Cornell-like", cornell),
    ];
    // Opt-in: a real CPU bake (126 directions, 64 × 64 rays, 3 iterations) of a scene, in
    // f32 as propagated and dilated (what `bake::assemble` encodes).
    if let Some(scene) = std::env::var_os("VLF_ENCODING_SCENE") {
        let scene = vlf_core::scene::load(Path::new(&scene)).unwrap();
        let params = BakeParams {
            directions: 126,
            ..BakeParams::paper()
        };
        let prep = vlf_core::bake::BakeScene::new(&scene, &params).unwrap();
        let set = DirectionSet::at_least(params.directions).unwrap();
        let mut irradiance = vlf_core::bake::reference::propagate(&prep, &set, &params).irradiance;
        vlf_core::bake::dilate(&prep, &mut irradiance);
        sets.push(("baked scene", irradiance));
    }
    sets
}

#[test]
fn encoding_error_measurements() {
    println!(
        "| data | encoding | bytes/texel | channel rel. err. mean | p99 | max | luminance rel. err. mean | max | err. / max channel, max | sRGB 8-bit steps, p99 | max |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, data) in datasets() {
        for enc in RadianceEncoding::ALL {
            let mut s = measure(&data, enc);
            let pct = |x: f64| format!("{:.4} %", 100.0 * x);
            let (cm, lm) = (mean(&s.chan), mean(&s.lum));
            let c99 = percentile(&mut s.chan, 0.99);
            let cmax = percentile(&mut s.chan, 1.0);
            let lmax = percentile(&mut s.lum, 1.0);
            let rmax = percentile(&mut s.rel_max, 1.0);
            let s99 = percentile(&mut s.srgb_steps, 0.99);
            let smax = percentile(&mut s.srgb_steps, 1.0);
            println!(
                "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {s99:.3} | {smax:.3} |",
                enc.name(),
                enc.bytes_per_texel(),
                pct(cm),
                pct(c99),
                pct(cmax),
                pct(lm),
                pct(lmax),
                pct(rmax)
            );
            // The guarantees docs/FORMAT.md states.
            match enc {
                RadianceEncoding::Rgb9e5 => {
                    // Half a step of the shared exponent, which may have been bumped by the
                    // rounding of the largest component (511.5/512 → 1).
                    assert!(rmax <= 1.0 / 511.0, "{name}: {rmax}");
                }
                RadianceEncoding::RgbF16 => {
                    assert!(rmax <= 1.0 / 2048.0, "{name}: {rmax}");
                }
            }
        }
    }
}

/// A baked scene with mirror tiles survives write → read (tiles bit-exact in the encoding),
/// and a corrupted tile index is rejected with a precise message.
#[test]
fn mirror_tiles_round_trip_and_reject_corruption() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/cornell-mirror/cornell-mirror.gltf");
    let scene = vlf_core::scene::load(&path).unwrap();
    let params = BakeParams {
        directions: 21,
        resolution: 16,
        tile: 4,
        iterations: Iterations::Fixed(2),
        ..BakeParams::paper()
    };
    let lf = vlf_core::pipeline::bake_cpu(&scene, &params).unwrap();
    let tiles = lf.tiles.as_ref().expect("the mirror box has tiles");
    assert!(
        tiles.radiance.iter().any(|v| v[0] > 0.0),
        "tiles carry light"
    );
    // The bake keeps atlas and tiles in the default encoding; both sections store them as is.
    let enc = DEFAULT_ENCODING;
    assert_eq!(tiles.radiance.encoding(), enc);
    let bytes = bytes_of(&lf, enc);
    let back = format::read_bytes(&bytes, Path::new("mem.vlf")).unwrap();
    assert_bit_exact(&back, &lf);
    let other = RadianceEncoding::Rgb9e5;
    let back = format::read_bytes(&bytes_of(&lf, other), Path::new("mem.vlf")).unwrap();
    assert_bit_exact(&back, &expected(&lf, other));
    assert_eq!(back.tiles.as_ref().unwrap().radiance.encoding(), other);

    // Break the tile index (a tile id beyond the grid), with a valid checksum.
    let mut h = header_of(&bytes);
    let s = entry(&mut h, disk::SECTION_TILE_INDEX).clone();
    let mut bad = bytes.clone();
    let words_at = s.offset as usize;
    let n_words = s.count as usize;
    let words: Vec<u32> = bad[words_at..words_at + 4 * n_words]
        .chunks(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    // tile_ids start after the header (8 words), face_slot, faces and index_start.
    let first_tile_id = 8 + (words[3] + words[4] + words[5]) as usize;
    let at = words_at + 4 * first_tile_id;
    bad[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let sum = hash::section_checksum(&bad[words_at..words_at + 4 * n_words]);
    let bad =
        disk::rewrite_header(&bad, |h| entry(h, disk::SECTION_TILE_INDEX).checksum = sum).unwrap();
    let err = format::read_bytes(&bad, Path::new("bad.vlf"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("tile index") && err.contains("tile ids") && err.ends_with("bad.vlf"),
        "{err}"
    );
}
