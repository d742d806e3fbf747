//! The dipole links' memory and time against the object's texel count (`docs/PERFORMANCE.md`):
//! a 12 × 5 × 12 cm box of Jensen's marble at several texel sizes, the links built on
//! every core, then one scatter step (what each propagation iteration adds).
//!
//! `cargo run --release -p vlf-core --example subsurface_bench [texel mm ...]`

use std::time::Instant;

use glam::Vec3;
use vlf_core::bake::BakeScene;
use vlf_core::bake::subsurface::{LinkParams, Subsurface};
use vlf_core::scene::{SceneBuilder, Translucency};

fn main() {
    let sizes: Vec<f32> = std::env::args()
        .skip(1)
        .map(|s| s.parse().expect("texel size in mm"))
        .collect();
    let sizes = if sizes.is_empty() {
        vec![8.0, 4.0, 2.0]
    } else {
        sizes
    };
    println!("texel_mm,texels,links,links_per_texel,link_mib,build_s,scatter_ms,near_mm");
    for h_mm in sizes {
        let mut b = SceneBuilder::new();
        let m = b.diffuse("marble", Vec3::ONE, Vec3::ZERO);
        b.translucent(
            m,
            Translucency::Dipole {
                sigma_s_prime: Vec3::new(2190.0, 2620.0, 3000.0),
                sigma_a: Vec3::new(2.1, 4.1, 7.1),
                eta: 1.5,
            },
        );
        b.aabox(
            Vec3::new(-0.06, 0.0, -0.06),
            Vec3::new(0.06, 0.05, 0.06),
            false,
            m,
        );
        let scene = b.build("marble box");
        let scale = scene.to_vlf.scale;
        let prep = BakeScene::with_texel_size(&scene, h_mm * 1e-3 * scale).unwrap();
        let t = Instant::now();
        let sss = Subsurface::new(&prep, &LinkParams::default(), 0).unwrap();
        let build = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let out = sss.exitance(&prep, |_| Vec3::ONE);
        let scatter = t.elapsed().as_secs_f64() * 1e3;
        assert!(!out.is_empty());
        let st = sss.stats();
        println!(
            "{h_mm},{},{},{:.0},{:.1},{build:.2},{scatter:.1},{:.1}",
            st.dipole_texels,
            st.links,
            st.links as f64 / st.dipole_texels as f64,
            st.link_bytes as f64 / 1048576.0,
            sss.objects[0].tree.near_radius() * 1e3 / f64::from(scale)
        );
    }
}
