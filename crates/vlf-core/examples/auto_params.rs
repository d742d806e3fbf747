//! Prints the `--quality auto` choices for scenes: `cargo run -p vlf-core --example auto_params -- SCENE...`
fn main() {
    for path in std::env::args().skip(1) {
        match vlf_core::scene::load(std::path::Path::new(&path)) {
            Ok(scene) => {
                for q in [
                    vlf_core::bake::Quality::Draft,
                    vlf_core::bake::Quality::Auto,
                    vlf_core::bake::Quality::High,
                ] {
                    let r = vlf_core::bake::auto::choose(&scene, q, true);
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
