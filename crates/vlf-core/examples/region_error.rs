//! relMSE, MSE and mean radiance of a test image against a reference over a pixel rectangle
//! (both linear EXR of equal size): the error of one object of a scene, e.g. lamp-room's smooth
//! sphere, which whole-image figures drown in the rest's.
//!
//! `cargo run --release -p vlf-core --example region_error -- TEST.exr REF.exr X0 Y0 X1 Y1`
//! (pixels x0..x1 × y0..y1, row 0 at the top).

use vlf_core::image::read_exr;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 6 {
        eprintln!("usage: region_error TEST.exr REF.exr X0 Y0 X1 Y1");
        std::process::exit(2);
    }
    let test = read_exr(&args[0]).unwrap_or_else(|e| panic!("{}: {e}", args[0]));
    let reference = read_exr(&args[1]).unwrap_or_else(|e| panic!("{}: {e}", args[1]));
    assert_eq!(
        (test.width, test.height),
        (reference.width, reference.height),
        "image sizes differ"
    );
    let n: Vec<u32> = args[2..]
        .iter()
        .map(|a| a.parse().expect("pixel coordinates"))
        .collect();
    let (x0, y0) = (n[0].min(test.width), n[1].min(test.height));
    let (x1, y1) = (n[2].min(test.width), n[3].min(test.height));
    let (mut rel, mut mse, mut mean_t, mut mean_r, mut count) = (0.0, 0.0, [0.0; 3], [0.0; 3], 0);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * test.width + x) as usize;
            for c in 0..3 {
                let (t, r) = (
                    f64::from(test.pixels[i][c]),
                    f64::from(reference.pixels[i][c]),
                );
                rel += (t - r).powi(2) / (r * r + 0.01);
                mse += (t - r).powi(2);
                mean_t[c] += t;
                mean_r[c] += r;
            }
            count += 1;
        }
    }
    let k = f64::from(count.max(1));
    println!(
        "{} px: relMSE {:.4e}, MSE {:.4e}, mean test {:?} reference {:?}",
        count,
        rel / (3.0 * k),
        mse / (3.0 * k),
        mean_t.map(|v| (v / k * 1e4).round() / 1e4),
        mean_r.map(|v| (v / k * 1e4).round() / 1e4)
    );
}
