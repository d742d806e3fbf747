//! Bake benchmark: writes CSV rows `case,device,adapter,faces,triangles,texels,directions,
//! resolution,tile,iterations,seconds` to stdout (and to `--out FILE`).
//!
//! `cargo run --release -p vlf-gpu --example bake_bench -- [--quick] [--out FILE]`
//! (`cargo xtask bench` runs it and stores the CSV under docs/bench/).
//!
//! Cases: the Cornell box at the paper's settings (512 directions, 64² rays, 8×8 tiles,
//! 3 iterations) and at default quality, on the GPU adapter and on the CPU reference; and a
//! ladder of scenes of growing face count (a room filled with k×k boxes) at fixed settings, to
//! show how time grows with faces.

use std::io::Write;
use std::time::Instant;

use glam::Vec3;
use vlf_core::bake::{BakeScene, Quality, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, Iterations};
use vlf_core::scene::{Scene, SceneBuilder};

fn room_with_boxes(k: u32) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::splat(0.7), Vec3::splat(10.0));
    b.aabox(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, 1.0),
        true,
        white,
    );
    // Ceiling light facing down.
    b.quad(
        [
            Vec3::new(-0.2, 1.99, -0.2),
            Vec3::new(0.2, 1.99, -0.2),
            Vec3::new(0.2, 1.99, 0.2),
            Vec3::new(-0.2, 1.99, 0.2),
        ],
        light,
    );
    let cell = 1.6 / k as f32;
    for i in 0..k {
        for j in 0..k {
            let c = Vec3::new(
                -0.8 + (i as f32 + 0.5) * cell,
                0.0,
                -0.8 + (j as f32 + 0.5) * cell,
            );
            let h = 0.1 + 0.3 * (((i * 7 + j * 13) % 10) as f32 / 10.0);
            let s = 0.3 * cell;
            b.aabox(
                c - Vec3::new(s, 0.0, s),
                c + Vec3::new(s, h, s),
                false,
                white,
            );
        }
    }
    b.build(&format!("room with {k}×{k} boxes"))
}

struct Row {
    tile_bytes: usize,
    case: String,
    device: String,
    adapter: String,
    prep: BakeScene,
    directions: usize,
    params: BakeParams,
    iterations: u32,
    seconds: f64,
}

fn run(case: &str, scene: &Scene, params: &BakeParams, gpu: Option<&vlf_gpu::GpuContext>) -> Row {
    let prep = BakeScene::new(scene, params).expect("params");
    let set = DirectionSet::at_least(params.directions).expect("directions");
    let t = Instant::now();
    let (out, device, adapter) = match gpu {
        Some(ctx) => (
            vlf_gpu::bake::propagate(ctx, &prep, &set, params, &mut |_| {}).expect("GPU bake"),
            "gpu",
            ctx.summary.to_string(),
        ),
        None => (
            reference::propagate(&prep, &set, params),
            "cpu",
            "CPU reference (1 thread)".into(),
        ),
    };
    let seconds = t.elapsed().as_secs_f64();
    eprintln!(
        "{case:24} {device}: {seconds:8.2} s ({} iterations)",
        out.iterations
    );
    Row {
        tile_bytes: out.tiles.as_ref().map_or(0, |t| t.1.len() * 16),
        case: case.into(),
        device: device.into(),
        adapter,
        prep,
        directions: set.len(),
        params: params.clone(),
        iterations: out.iterations,
        seconds,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .map(|i| args[i + 1].clone());
    let ctx = vlf_gpu::GpuContext::new(&Default::default()).ok();
    if ctx.is_none() {
        eprintln!("no GPU adapter: CPU rows only");
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let cornell = vlf_core::scene::load(&root.join("assets/cornell-box/cornell-box.gltf"))
        .expect("Cornell box");
    let mut rows = Vec::new();
    if args.iter().any(|a| a == "--mirror") {
        // Mirror tiles against the number of directions (the original VLF paper: linear).
        let mirror = vlf_core::scene::load(&root.join("assets/cornell-mirror/cornell-mirror.gltf"))
            .expect("mirror box");
        for l in [46u32, 126, 501, 1001, 2001] {
            let p = BakeParams {
                directions: l,
                resolution: 32,
                tile: 8,
                iterations: Iterations::Fixed(2),
                ..BakeParams::paper()
            };
            rows.push(run(
                &format!("mirror-{l}-directions"),
                &mirror,
                &p,
                ctx.as_ref(),
            ));
        }
    } else {
        let paper = BakeParams::paper();
        let auto = Quality::Auto.preset().params(false);
        for gpu in [ctx.as_ref(), None] {
            if gpu.is_none() && ctx.is_some() && quick {
                continue;
            }
            rows.push(run("cornell-paper", &cornell, &paper, gpu));
            if !quick {
                rows.push(run("cornell-auto", &cornell, &auto, gpu));
            }
        }
        // Face-count ladder at reduced settings (126 directions, 64² rays, 2 iterations).
        let ladder = BakeParams {
            directions: 126,
            resolution: 64,
            tile: 4,
            iterations: Iterations::Fixed(2),
            ..BakeParams::paper()
        };
        let ks: &[u32] = if quick { &[1, 4] } else { &[1, 2, 4, 8, 16] };
        for &k in ks {
            let scene = room_with_boxes(k);
            rows.push(run(
                &format!("ladder-{}-faces", scene.faces.len()),
                &scene,
                &ladder,
                ctx.as_ref(),
            ));
        }
    }
    let mut csv = String::from(
        "case,device,adapter,faces,triangles,texels,directions,resolution,tile,iterations,seconds,tile_bytes\n",
    );
    for r in &rows {
        let s = r.prep.summary();
        csv += &format!(
            "{},{},\"{}\",{},{},{},{},{},{},{},{:.3},{}\n",
            r.case,
            r.device,
            r.adapter,
            s.faces,
            s.triangles,
            s.covered_texels,
            r.directions,
            r.params.resolution,
            r.params.tile,
            r.iterations,
            r.seconds,
            r.tile_bytes
        );
    }
    print!("{csv}");
    if let Some(path) = out {
        std::fs::File::create(&path)
            .and_then(|mut f| f.write_all(csv.as_bytes()))
            .unwrap_or_else(|e| panic!("cannot write {path}: {e}"));
    }
}
