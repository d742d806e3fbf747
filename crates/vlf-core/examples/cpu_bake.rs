//! Quick CPU-reference bake of a scene, printing timing and energy (development aid).
//! `cargo run -p vlf-core --example cpu_bake -- SCENE [directions] [resolution] [iterations]`
use vlf_core::bake::{BakeScene, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, Iterations};

fn main() {
    env_logger::init();
    let args: Vec<String> = std::env::args().collect();
    let scene = vlf_core::scene::load(std::path::Path::new(&args[1])).unwrap();
    let mut p = BakeParams::paper();
    if let Some(d) = args.get(2) {
        p.directions = d.parse().unwrap();
    }
    if let Some(r) = args.get(3) {
        p.resolution = r.parse().unwrap();
    }
    if let Some(s) = args.get(5) {
        p.texel_scale = s.parse().unwrap();
    }
    if let Some(i) = args.get(4) {
        p.iterations = Iterations::Fixed(i.parse().unwrap());
    }
    if let Ok(v) = std::env::var("VLF_PERTURB") {
        p.perturb = v.parse().unwrap();
    }
    let t = std::time::Instant::now();
    let prep = BakeScene::new(&scene, &p).unwrap();
    let set = DirectionSet::at_least(p.directions).unwrap();
    println!("prep {:?} {:?}", t.elapsed(), prep.summary());
    if std::env::var("COUNT_FACE").is_ok() {
        let face: u32 = std::env::var("COUNT_FACE").unwrap().parse().unwrap();
        let grid = vlf_core::psf::PsfGrid::new(p.resolution, p.tile).unwrap();
        let f = prep.faces[face as usize];
        let area: f32 = (f.texel_base as usize..(f.texel_base + f.texels_per_side()) as usize)
            .map(|t| prep.texel_area[t])
            .sum();
        let (mut ray, mut exact) = (0f64, 0f64);
        for d in reference::transport_directions(&set, &p) {
            let lists = reference::build_cell_lists(&prep, &grid, &d.frame);
            let count = lists.entries.iter().filter(|e| e.1 == face).count();
            ray += count as f64 * (grid.cell_size() as f64).powi(2) * d.weight as f64;
            exact += (area * f.normal().dot(d.frame.w).abs()) as f64 * d.weight as f64;
        }
        println!(
            "face {face}: ray-projected {ray:.6} exact {exact:.6} ratio {:.5} (area {area})",
            ray / exact
        );
    }
    let t = std::time::Instant::now();
    let out = reference::propagate(&prep, &set, &p);
    println!(
        "propagate {:?} iterations {} energy {:?} imbalance {:.4}%",
        t.elapsed(),
        out.iterations,
        out.energy,
        100.0 * out.energy.relative_imbalance()
    );
    // mean radiance per face (side 0)
    let radiance = prep.outgoing_radiance(&out.irradiance);
    for (i, f) in prep.faces.iter().enumerate() {
        let n = f.texels_per_side() as usize;
        let s = f.texel_base as usize;
        let mut sum = glam::Vec3::ZERO;
        let mut a = 0.0;
        for t in s..s + n {
            sum += glam::Vec4::from(radiance[t]).truncate() * prep.texel_area[t];
            a += prep.texel_area[t];
        }
        let mut sumb = glam::Vec3::ZERO;
        for t in s + n..s + 2 * n {
            sumb += glam::Vec4::from(radiance[t]).truncate() * prep.texel_area[t];
        }
        println!(
            "face {i:2} {}x{} mean front {:?} back {:?}",
            f.width,
            f.height,
            sum / a,
            sumb / a
        );
    }
}
