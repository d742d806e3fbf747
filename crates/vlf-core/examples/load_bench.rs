//! Load benchmark of the `.vlf` reader: writes a synthetic light field of at least `--mb` MB
//! (default 200) per radiance encoding to a temporary directory, then times, best of `--runs`
//! (default 7) after a warm-up so that every read comes from the page cache:
//!
//! - `plain`: `std::fs::read` of the file (the floor for any reader),
//! - `format::read` (header, checksums of every section, validation; the radiance stays in its
//!   stored encoding, as `LightField::irradiance` keeps it), run alternately with `plain` so both
//!   see the same machine load: `ratio` is of the best times, `paired` the median of the
//!   per-run ratios,
//! - `describe` (header and section table only),
//! - `to_f32`: decoding the loaded radiance to f32 RGBA (`Radiance::to_f32`, 16 bytes per
//!   texel) — what the load cost before the radiance was kept encoded, and what any caller
//!   that needs f32 pays on top of the load,
//! - `rgba16f`: expanding f16 RGB to the RGBA halves the renderer uploads (`rgba16f_into`,
//!   into a fresh buffer; RGB9E5 is uploaded as it is).
//!
//! `cargo run --release -p vlf-core --example load_bench [-- --mb 200 --runs 7 --encoding all]`
//! (`--encoding rgb16f | rgb9e5 | all`). Prints a table, then the figures as CSV.

use std::path::Path;
use std::time::Instant;

use vlf_core::directions::DirectionSet;
use vlf_core::format;
use vlf_core::lightfield::{
    BakeFace, BakeParams, BakeStats, BakeTriangle, LightField, NO_TEXTURE, Radiance,
    RadianceEncoding, Shading, SurfaceMaterial,
};
use vlf_core::scene::{SceneSummary, Similarity};

fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A light field of `faces` faces of `side × side` texels per side, with HDR radiance.
fn synthetic(faces: u32, side: u32, enc: RadianceEncoding) -> LightField {
    let mut fs = Vec::new();
    let mut tris = Vec::new();
    let mut base = 0u32;
    for i in 0..faces {
        let z = -0.9 + 1.8 * i as f32 / faces as f32;
        fs.push(BakeFace {
            normal: [0.0, 0.0, 1.0],
            offset: z,
            origin: [-0.5, -0.5, z],
            texel_size: 1.0 / side as f32,
            u: [1.0, 0.0, 0.0],
            width: side,
            v: [0.0, 1.0, 0.0],
            height: side,
            texel_base: base,
            kind: 0,
            specular: 0.0,
            material: 0,
        });
        base += 2 * side * side;
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
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let radiance: Vec<[f32; 4]> = (0..base)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let l = ((s >> 40) as f32 / (1u64 << 24) as f32 * 13.8 - 9.2).exp(); // 1e-4..1e2
            [
                l * (0.05 + (s & 0xff) as f32 / 270.0),
                l,
                l * (0.05 + ((s >> 8) & 0xff) as f32 / 270.0),
                0.0,
            ]
        })
        .collect();
    LightField {
        params: BakeParams::paper(),
        directions: DirectionSet::at_least(512).expect("direction set"),
        to_vlf: Similarity::IDENTITY,
        scene: SceneSummary {
            source: "synthetic".into(),
            triangles: tris.len(),
            faces: fs.len(),
            materials: 1,
            diffuse_materials: 1,
            mirror_materials: 0,
            mixed_materials: 0,
            emissive_materials: 0,
            emissive_faces: 0,
            emissive_triangles: 0,
            cameras: 0,
            suns: 0,
            textures: 0,
            bounds_min: [-1.0; 3],
            bounds_max: [1.0; 3],
            warnings: 0,
        },
        cameras: vec![],
        shading: Shading {
            materials: vec![SurfaceMaterial {
                base_color: [0.8; 3],
                diffuse_weight: 1.0,
                emission: [0.0; 3],
                base_color_texture: NO_TEXTURE,
                emissive_texture: NO_TEXTURE,
                specular_alpha: 0.0,
                base_color_texcoord: 0,
                emissive_texcoord: 0,
                ..SurfaceMaterial::opaque_default()
            }],
            uvs: vec![[[0.0; 2]; 3]; tris.len()],
            ..Shading::empty()
        },
        triangles: tris,
        faces: fs,
        irradiance: Radiance::from_f32(&radiance, enc).expect("finite irradiance"),
        tiles: None,
        stats: BakeStats::default(),
    }
}

/// Times `a` and `b` alternately `runs` times each (so both see the same machine load):
/// the best time of each and the median of the per-run ratios b / a.
fn alternating<A, B>(
    runs: usize,
    mut a: impl FnMut() -> A,
    mut b: impl FnMut() -> B,
) -> (f64, f64, f64) {
    let time = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    let (mut best_a, mut best_b, mut ratios) = (f64::INFINITY, f64::INFINITY, Vec::new());
    for _ in 0..runs {
        let ta = time(&mut || {
            std::hint::black_box(a());
        });
        let tb = time(&mut || {
            std::hint::black_box(b());
        });
        best_a = best_a.min(ta);
        best_b = best_b.min(tb);
        ratios.push(tb / ta);
    }
    ratios.sort_by(f64::total_cmp);
    (best_a, best_b, ratios[ratios.len() / 2])
}

fn best<R>(runs: usize, mut f: impl FnMut() -> R) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..runs {
        let t = Instant::now();
        std::hint::black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

struct Row {
    encoding: &'static str,
    file_bytes: u64,
    texels: usize,
    plain: f64,
    read: f64,
    /// Median of the per-run ratios read / plain (runs alternate).
    paired: f64,
    describe: f64,
    to_f32: f64,
    rgba16f: Option<f64>,
}

fn main() {
    let mb: f64 = arg("--mb", 200.0);
    let runs: usize = arg("--runs", 7usize).max(1);
    let which: String = arg("--encoding", "all".to_string());
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(8);
    let dir = std::env::temp_dir().join(format!("vlf-load-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut rows = Vec::new();
    for enc in RadianceEncoding::ALL {
        if which != "all" && which != enc.name() {
            continue;
        }
        // Faces of 1024 × 1024 texels per side, enough for `mb` megabytes of radiance.
        let side = 1024u32;
        let per_face = 2 * (side as u64) * (side as u64) * enc.bytes_per_texel() as u64;
        let faces = ((mb * 1e6) / per_face as f64).ceil().max(1.0) as u32;
        let lf = synthetic(faces, side, enc);
        let path = dir.join(format!("bench-{}.vlf", enc.name()));
        let t = Instant::now();
        let bytes = format::write_atomic_with(&path, &lf, enc).expect("write");
        let write_s = t.elapsed().as_secs_f64();
        let texels = lf.irradiance.len();
        drop(lf);
        eprintln!(
            "{}: {:.1} MB, {texels} texels, written in {write_s:.2} s; timing best of {runs}…",
            enc.name(),
            bytes as f64 / 1e6
        );
        // Warm-up: both paths once, so that the file is in the page cache.
        let plain_len = std::fs::read(&path).expect("read").len();
        assert_eq!(plain_len as u64, bytes);
        let back = format::read(&path).expect("format::read");
        assert_eq!(back.irradiance.len(), texels);
        drop(back);
        let (plain, read, paired) = alternating(
            runs,
            || std::fs::read(&path).expect("read").len(),
            || format::read(&path).expect("format::read").irradiance.len(),
        );
        let describe = best(runs, || format::describe(&path).expect("describe").texels);
        let back = format::read(&path).expect("format::read");
        let to_f32 = best(runs, || back.irradiance.to_f32().len());
        let rgba16f = (enc == RadianceEncoding::RgbF16).then(|| {
            best(runs, || {
                let mut out = vec![[0u16; 4]; texels];
                back.irradiance.rgba16f_into(0, &mut out);
                out.len()
            })
        });
        drop(back);
        std::fs::remove_file(&path).expect("remove");
        rows.push(Row {
            encoding: enc.name(),
            file_bytes: bytes,
            texels,
            plain,
            read,
            paired,
            describe,
            to_f32,
            rgba16f,
        });
    }
    let _ = std::fs::remove_dir(&dir);
    let gbps = |bytes: u64, s: f64| bytes as f64 / s / 1e9;
    println!("threads available: {threads}");
    println!(
        "{:<8} {:>10} {:>11} {:>18} {:>18} {:>7} {:>7} {:>11} {:>11} {:>11}",
        "encoding",
        "file MB",
        "texels",
        "plain read",
        "format::read",
        "ratio",
        "paired",
        "describe",
        "to_f32",
        "rgba16f"
    );
    let ms = |s: Option<f64>| s.map_or("-".to_string(), |s| format!("{:.1} ms", s * 1e3));
    for r in &rows {
        println!(
            "{:<8} {:>10.1} {:>11} {:>8.1} ms {:>4.2} GB/s {:>8.1} ms {:>4.2} GB/s {:>7.2} {:>7.2} {:>8.3} ms {:>11} {:>11}",
            r.encoding,
            r.file_bytes as f64 / 1e6,
            r.texels,
            r.plain * 1e3,
            gbps(r.file_bytes, r.plain),
            r.read * 1e3,
            gbps(r.file_bytes, r.read),
            r.read / r.plain,
            r.paired,
            r.describe * 1e3,
            ms(Some(r.to_f32)),
            ms(r.rgba16f)
        );
    }
    println!();
    println!(
        "encoding,file_bytes,texels,runs,threads,plain_read_s,plain_read_gb_per_s,format_read_s,format_read_gb_per_s,ratio,paired_ratio,describe_s,to_f32_s,rgba16f_s"
    );
    for r in &rows {
        println!(
            "{},{},{},{runs},{threads},{:.6},{:.3},{:.6},{:.3},{:.3},{:.3},{:.6},{:.6},{}",
            r.encoding,
            r.file_bytes,
            r.texels,
            r.plain,
            gbps(r.file_bytes, r.plain),
            r.read,
            gbps(r.file_bytes, r.read),
            r.read / r.plain,
            r.paired,
            r.describe,
            r.to_f32,
            r.rgba16f.map_or(String::new(), |s| format!("{s:.6}"))
        );
    }
    if !Path::new(&dir).exists() {
        eprintln!("temporary files removed");
    }
}
