//! Prints what the scene rules (`bake::refine`) choose for scenes at every preset: `cargo run -p vlf-core --example auto_params -- SCENE...`
fn main() {
    for path in std::env::args().skip(1) {
        match vlf_core::scene::load(std::path::Path::new(&path)) {
            Ok(scene) => {
                for q in vlf_core::bake::Quality::ALL {
                    let r = vlf_core::bake::refine::refine(&scene, q, true);
                    println!(
                        "{path} {q:?}: N={} m={} l={} perturb={} {:?}",
                        r.params.resolution,
                        r.params.tile,
                        r.params.directions,
                        r.params.perturb,
                        r.reasons
                    );
                }
            }
            Err(e) => println!("{path}: {e}"),
        }
    }
}
