//! Where a bake's energy imbalance arises (development aid): the CPU propagation run iteration
//! by iteration, each split into its transport gap (power sent − received − escaped: ray
//! aliasing of projected areas) and its reflect gap (the specular power the texels of mirror and
//! mixed faces reserve for their tiles − what the tiles receive, lobe loss included).
//! `cargo run --release -p vlf-core --example energy_probe -- SCENE directions resolution tile
//! [texel_scale]`; `VLF_PERTURB=n` for perturbed directions. Emitters only (no sky, no suns).
//! Made for cornell-suzanne's small faces (docs/PROPAGATION.md, "Faces smaller than a ray
//! cell").
use glam::{Vec3, Vec4};
use vlf_core::bake::{BakeScene, reference};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::BakeParams;
use vlf_core::psf::PsfGrid;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        eprintln!("usage: energy_probe SCENE directions resolution tile [texel_scale]");
        std::process::exit(2);
    }
    let scene = vlf_core::scene::load(std::path::Path::new(&args[1])).unwrap();
    let mut p = BakeParams::paper();
    p.directions = args[2].parse().unwrap();
    p.resolution = args[3].parse().unwrap();
    p.tile = args[4].parse().unwrap();
    if let Some(s) = args.get(5) {
        p.texel_scale = s.parse().unwrap();
    }
    if let Ok(v) = std::env::var("VLF_PERTURB") {
        p.perturb = v.parse().unwrap();
    }
    let prep = BakeScene::new(&scene, &p).unwrap();
    let set = DirectionSet::at_least(p.directions).unwrap();
    let grid = PsfGrid::new(p.resolution, p.tile).unwrap();
    let (dirs, quadrature) = reference::all_directions(&prep, &set, &p);
    // What the share of the quadrature reaching the faces costs, against the tile index.
    let t = std::time::Instant::now();
    let index = reference::tile_index(&prep, &set, &grid);
    let t_index = t.elapsed();
    let reach = reference::reach_factors(&prep, &grid, &dirs, &index);
    println!(
        "tile index {t_index:?}, reach factors of {} faces {:?}",
        reach.len(),
        t.elapsed() - t_index
    );
    let Some(spec) = reference::SpecularSetup::new(&prep, &set, &grid, &dirs) else {
        eprintln!("no mirror or mixed face: the reflect gap is 0");
        std::process::exit(0);
    };
    let nd = spec.index.faces.len() as f32;
    println!(
        "{} non-diffuse faces, mean unresolved share {:.4}",
        nd,
        spec.unresolved.iter().sum::<f32>() / nd
    );
    let tex_face = reference::texel_faces(&prep);
    let n_tex = prep.texel_count();
    let mut unshot = prep.emission.clone();
    let mut unshot_tiles = vec![[0f32; 4]; spec.index.value_len()];
    let mut next = vec![[0f32; 4]; n_tex];
    let emitted: f64 = (0..n_tex)
        .map(|t| sum3(Vec4::from(unshot[t]).truncate()) * std::f64::consts::PI * area(&prep, t))
        .sum();
    let (mut transport_total, mut reflect_total) = (0f64, 0f64);
    for it in 0..64 {
        let mut acc = vec![reference::TexelAccum::default(); n_tex];
        let mut next_tiles = vec![[0f32; 4]; spec.index.value_len()];
        let sender = reference::Specular {
            index: &spec.index,
            set: &set,
            frames: &spec.frames,
            unshot: &unshot_tiles,
        };
        let mut spec_escaped = 0f64;
        for (di, d) in dirs.iter().enumerate().take(quadrature) {
            let jobs = spec.jobs[di].as_slice();
            let g = reference::gather_direction(
                &prep,
                &grid,
                d,
                &unshot,
                &tex_face,
                Some((&sender, jobs)),
                Vec3::ZERO,
            );
            g.add_to(&prep, d, &tex_face, &mut acc, &mut next_tiles);
            spec_escaped += g.escaped;
        }
        let mut irr = vec![[0f32; 4]; n_tex];
        let mut e = reference::finish_iteration(
            &prep,
            &tex_face,
            &spec.unresolved,
            &acc,
            &unshot,
            Vec3::ZERO,
            None,
            &mut next,
            &mut irr,
        );
        // What finish_iteration left for the tiles: ρ_s × (1 − unresolved) × E × area.
        let reserved: f64 = (0..n_tex)
            .map(|t| {
                let f = tex_face[t] as usize;
                let rho = Vec4::from(prep.specular[f]).truncate() * (1.0 - spec.unresolved[f]);
                sum3(rho * Vec4::from(irr[t]).truncate()) * area(&prep, t)
            })
            .sum();
        let tiles_sent = reference::tile_power(&spec.index, &unshot_tiles, &set, &grid);
        let loss = reference::take_tile_loss(&spec.index, &mut next_tiles, &set, &grid);
        let tiles = reference::tile_power(&spec.index, &next_tiles, &set, &grid);
        e.sent += tiles_sent;
        e.escaped += spec_escaped;
        let transport = e.sent - e.received - e.escaped;
        let reflect = reserved - tiles - loss;
        transport_total += transport;
        reflect_total += reflect;
        println!(
            "iteration {it:2}: sent {:.6} (tiles {tiles_sent:.6}), transport gap {transport:+.6}, \
             reflect gap {reflect:+.6} (reserved {reserved:.6}, tiles {tiles:.6}, loss {loss:.6})",
            e.sent
        );
        std::mem::swap(&mut unshot, &mut next);
        unshot_tiles = next_tiles;
        if e.next + tiles <= 1e-3 * emitted {
            break;
        }
    }
    println!(
        "of the emitted power: transport gap {:.3} %, reflect gap {:.3} %, imbalance {:.3} %",
        100.0 * transport_total / emitted,
        100.0 * reflect_total / emitted,
        100.0 * (transport_total + reflect_total) / emitted
    );
}

fn area(prep: &BakeScene, t: usize) -> f64 {
    f64::from(prep.texel_area[t])
}

fn sum3(v: Vec3) -> f64 {
    f64::from(v.x) + f64::from(v.y) + f64::from(v.z)
}
