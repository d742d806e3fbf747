//! Test | reference | HDR-FLIP map as one PNG (ACES, exposure in stops), and the images' mean
//! radiance: `cargo run --release -p vlf-core --example side_by_side -- TEST.exr REF.exr OUT.png [EXPOSURE]`
use vlf_core::image::{Image, Tonemap, flip, magma, read_exr, srgb_to_linear, write_png};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let test = read_exr(&a[0]).expect("test");
    let reference = read_exr(&a[1]).expect("reference");
    let exposure: f32 = a.get(3).map_or(0.0, |e| e.parse().expect("exposure"));
    let f = flip(&test, &reference);
    let (w, h) = (test.width, test.height);
    let scale = (-exposure).exp2();
    let out = Image::from_fn(3 * w, h, |x, y| match x / w {
        0 => test.get(x, y),
        1 => reference.get(x - w, y),
        _ => magma(f.map[(y * w + x - 2 * w) as usize]).map(|c| srgb_to_linear(c) * scale),
    });
    write_png(&a[2], &out, exposure, Tonemap::Aces).expect("png");
    let (mt, mr) = (test.mean(), reference.mean());
    println!(
        "mean test {:.4?} reference {:.4?} ratio {:.3?} flip {:.4}",
        mt,
        mr,
        [0, 1, 2].map(|c| mt[c] / mr[c]),
        f.mean
    );
}
