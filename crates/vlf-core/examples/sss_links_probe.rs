//! Probe: link counts of one receiver of the marble box (development aid for issue 28).
use glam::{Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::bake::subsurface::{LinkParams, ObjectTree};
use vlf_core::scene::SceneBuilder;
use vlf_core::scene::dipole::Dipole;

fn main() {
    let tol: f64 = std::env::args().nth(1).map_or(0.25, |s| s.parse().unwrap());
    let mut b = SceneBuilder::new();
    let m = b.diffuse("marble", Vec3::ONE, Vec3::ZERO);
    b.aabox(
        Vec3::new(-0.06, 0.0, -0.06),
        Vec3::new(0.06, 0.05, 0.06),
        false,
        m,
    );
    let scene = b.build("marble box");
    let scale = scene.to_vlf.scale;
    let prep = BakeScene::with_texel_size(&scene, 0.002 * scale).unwrap();
    let (mut tex, mut faces) = (Vec::new(), Vec::new());
    for (fi, f) in prep.faces.iter().enumerate() {
        for t in f.texel_base..f.texel_base + f.texels_per_side() {
            if prep.texel_area[t as usize] > 0.0 {
                tex.push(t);
                faces.push(fi as u32);
            }
        }
    }
    let mm = 1e3 / f64::from(scale);
    let s = [2.19, 2.62, 3.00];
    let a = [0.0021, 0.0041, 0.0071];
    let d: [Dipole; 3] = std::array::from_fn(|c| Dipole::new(s[c] * mm, a[c] * mm, 1.5));
    let params = LinkParams {
        tolerance: tol,
        ..LinkParams::default()
    };
    let tree = ObjectTree::new(&prep, &tex, &faces, d, params);
    println!("near {:.2} mm", tree.near_radius() * mm);
    let top = (0..scene.faces.len())
        .find(|&f| scene.faces[f].normal.y > 0.99)
        .unwrap();
    let t = prep.faces[top].texel_at(scene.to_vlf.apply(Vec3::new(0.001, 0.05, 0.001)), 0);
    let i = tex.iter().position(|&x| x == t).unwrap();
    let (l, dropped) = tree.links_for(&prep, i);
    let p = Vec4::from(prep.texel_center[t as usize]).truncate();
    let mut hist = [0usize; 12];
    let mut leaves = [0usize; 12];
    for k in &l {
        let (count, _r, c) = tree.node(k.node);
        let dist = f64::from(c.distance(p)) * mm;
        let bin = ((dist / 8.0) as usize).min(11);
        if count == 1 {
            leaves[bin] += 1
        } else {
            hist[bin] += 1
        }
    }
    println!("by 8 mm distance bins: leaves {leaves:?} clusters {hist:?}");
    println!("links {} dropped {dropped:.2e}", l.len());
    let _ = (p, &mut hist);
}
