//! Textures render at their own resolution, not the atlas's: the atlas holds irradiance and
//! pass 5 applies the base-colour and emissive textures per pixel at pass 4's uv (issue 14).
//! Checked on scenes where the expected image is known exactly, and against the CPU mirror of
//! pass 5 (`render::final_radiance::surface_radiance`).

use glam::{Vec2, Vec3, Vec4};
use vlf_core::lightfield::{BakeParams, Iterations, LightField};
use vlf_core::scene::{Material, MaterialKind, Scene, SceneBuilder, TexRef, Texture, WrapMode};
use vlf_gpu::render::final_radiance::{SurfaceLookup, surface_radiance, visible_side};
use vlf_gpu::render::{CameraView, NO_FACE, Renderer};
use vlf_tests::bakes;
use vlf_tests::{gpu, window_frame};

const W: u32 = 96;
const H: u32 = 96;

/// A `size × size` texture of `cell × cell`-texel checker squares of values `a` and `b`.
/// A grey `a`/`b` checker (scenes::checker) wrapping by `wrap`.
fn checker(size: u32, cell: u32, a: f32, b: f32, wrap: WrapMode) -> Texture {
    let grey = |v| Vec4::new(v, v, v, 1.0);
    Texture {
        name: Some("checker".into()),
        wrap_s: wrap,
        wrap_t: wrap,
        ..vlf_tests::scenes::checker(size, cell, grey(a), grey(b))
    }
}

fn material(
    base: Vec3,
    base_tex: Option<u32>,
    emission: Vec3,
    emissive_tex: Option<u32>,
) -> Material {
    let tex = |t: Option<u32>| t.map(|index| TexRef { index, texcoord: 0 });
    Material {
        name: "textured".into(),
        base_color: base,
        base_color_texture: tex(base_tex),
        emission,
        emissive_texture: tex(emissive_tex),
        double_sided: true,
        kind: MaterialKind::Diffuse,
        metallic: 0.0,
        roughness: 1.0,
        transparency: Default::default(),
    }
}

/// Gives the triangles of material `m` the uv `f(p)` at each corner (world `p`).
fn set_uvs(scene: &mut Scene, m: u32, f: impl Fn(Vec3) -> Vec2) {
    for t in scene.triangles.iter_mut().filter(|t| t.material == m) {
        t.uv = t.p.map(&f);
    }
}

fn bake(scene: &Scene, sky: Vec3) -> LightField {
    let params = BakeParams {
        sky,
        ..bakes::params(46, 32, Iterations::Fixed(2))
    };
    vlf_core::pipeline::bake_cpu(scene, &params).unwrap()
}

/// Every pixel showing a face equals the CPU mirror of pass 5 (same f32 operations; the
/// tolerance covers fused multiply-adds). Returns the pixels seen.
fn assert_matches_cpu_mirror(
    lf: &LightField,
    f: &vlf_gpu::render::FrameData,
    cam: &CameraView,
) -> usize {
    let lookup = SurfaceLookup::new(lf);
    let mut seen = 0;
    for i in 0..(f.width * f.height) as usize {
        let face = f.face_id[i];
        if face == NO_FACE {
            continue;
        }
        seen += 1;
        let bf = &lf.faces[face as usize];
        let p = Vec4::from(f.position[i]).truncate();
        let side = visible_side(bf, cam.position, p);
        let want = surface_radiance(lf, &lookup, face, side, p, &f.surface(i));
        let got = Vec4::from(f.radiance[i]).truncate();
        assert!(
            (got - want).abs().max_element() <= 1e-4 * want.max_element().max(1e-3),
            "pixel {i}: GPU {got} vs CPU mirror {want}"
        );
    }
    seen
}

/// A floor under a white sky with a checker much finer than the atlas (about 3 checker squares
/// per atlas texel): its irradiance is π × sky everywhere on the top, so each pixel must read
/// base colour × checker(uv) × sky, squares and all, where an atlas storing radiance showed the
/// squares averaged into grey texels.
#[test]
fn a_checker_finer_than_the_atlas_renders_at_full_resolution() {
    let Some(ctx) = gpu() else { return };
    let (dark, light) = (0.05f32, 0.85f32);
    let mut b = SceneBuilder::new();
    let base = Vec3::new(1.0, 0.9, 0.8);
    let m = b.material(material(base, Some(0), Vec3::ZERO, None));
    vlf_tests::scenes::hquad(&mut b, 0.0, 1.0, true, m);
    let mut scene = b.build("checker floor");
    // 128 × 128 texels in 4 × 4-texel squares, tiled twice over the floor: 64 squares across.
    scene
        .textures
        .push(checker(128, 4, dark, light, WrapMode::Repeat));
    set_uvs(&mut scene, m, |p| Vec2::new(p.x + 1.0, p.z + 1.0));
    let sky = Vec3::ONE;
    let lf = bake(&scene, sky);
    // The atlas is coarse next to the checker.
    let face = &lf.faces[0];
    let square = 2.0 / 64.0 * scene.to_vlf.scale; // one checker square, VLF units
    assert!(
        face.texel_size > 2.5 * square,
        "{} vs {square}",
        face.texel_size
    );
    assert_eq!(lf.shading.textures.len(), 1);

    let xf = scene.to_vlf;
    let cam = CameraView::look_at(
        xf.apply(Vec3::new(0.0, 1.2, 0.9)),
        xf.apply(Vec3::new(0.0, 0.0, 0.1)),
        0.7,
    );
    let mut r = Renderer::new(ctx, &lf).unwrap();
    let f = r.render_frame_data(ctx, &cam, W, H).unwrap();
    let seen = assert_matches_cpu_mirror(&lf, &f, &cam);
    assert!(
        seen > (W * H) as usize / 2,
        "the floor fills the view ({seen} pixels)"
    );

    // The pixels follow the checker: radiance = base × checker(uv) × sky (the propagated
    // irradiance of an open plane under a uniform sky is π × sky within 1e-3).
    let offsets = lf.shading.texture_offsets();
    let (mut n_dark, mut n_light, mut transitions) = (0, 0, 0);
    let mut prev = None;
    for i in 0..(W * H) as usize {
        if f.face_id[i] == NO_FACE {
            prev = None;
            continue;
        }
        let uv = Vec2::from(f.uv[i]);
        let tau = lf.shading.sample(0, uv, &offsets);
        let got = Vec4::from(f.radiance[i]).truncate();
        let want = base * tau * sky;
        assert!(
            ((got - want).abs() / want).max_element() < 2e-3,
            "pixel {i} at uv {uv}: {got} vs base × checker × sky = {want}"
        );
        let is_light = tau.x > 0.5 * (dark + light);
        if tau.x < dark + 0.01 {
            n_dark += 1;
        } else if tau.x > light - 0.01 {
            n_light += 1;
        }
        if prev.is_some_and(|p| p != is_light) {
            transitions += 1;
        }
        prev = Some(is_light);
    }
    eprintln!(
        "checker floor: {seen} pixels, {n_dark} in dark squares, {n_light} in light ones, \
         {transitions} light/dark changes along rows; atlas texel {:.4} vs square {square:.4} VLF",
        face.texel_size
    );
    // Both kinds of square are seen in full, and rows cross many squares.
    assert!(
        n_dark > seen / 5 && n_light > seen / 5,
        "{n_dark} {n_light} of {seen}"
    );
    assert!(transitions > 10 * H as usize, "{transitions} transitions");
}

/// An emitter whose emissive texture is a checker finer than the atlas, and no diffuse part:
/// its front reads emission × texture(uv) per pixel, its back nothing (emission is one-sided).
#[test]
fn an_emissive_texture_renders_per_pixel_on_the_front_only() {
    let Some(ctx) = gpu() else { return };
    let mut b = SceneBuilder::new();
    let le = Vec3::new(4.0, 3.0, 2.0);
    let m = b.material(material(Vec3::ZERO, None, le, Some(0)));
    // A vertical panel facing +z.
    b.quad(
        [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        m,
    );
    let mut scene = b.build("striped emitter");
    // Squares of 2 × 2 texels on a 64 × 64 texture, mirrored once across the panel: 64 squares
    // across, about 2 per atlas texel.
    scene
        .textures
        .push(checker(64, 2, 0.1, 1.0, WrapMode::MirroredRepeat));
    set_uvs(&mut scene, m, |p| Vec2::new(p.x + 1.0, 0.5 * (1.0 - p.y)));
    let lf = bake(&scene, Vec3::ZERO);
    let xf = scene.to_vlf;
    let offsets = lf.shading.texture_offsets();
    for (eye, front) in [
        (Vec3::new(0.1, 0.2, 2.5), true),
        (Vec3::new(-0.1, 0.1, -2.5), false),
    ] {
        let cam = CameraView::look_at(xf.apply(eye), xf.apply(Vec3::ZERO), 0.8);
        let mut r = Renderer::new(ctx, &lf).unwrap();
        let f = r.render_frame_data(ctx, &cam, W, H).unwrap();
        let seen = assert_matches_cpu_mirror(&lf, &f, &cam);
        assert!(seen > (W * H) as usize / 3, "{seen} pixels");
        let mut levels = std::collections::BTreeSet::new();
        for i in 0..(W * H) as usize {
            if f.face_id[i] == NO_FACE {
                continue;
            }
            let got = Vec4::from(f.radiance[i]).truncate();
            if front {
                let tau = lf.shading.sample(0, Vec2::from(f.uv[i]), &offsets);
                let want = le * tau;
                assert!(
                    ((got - want).abs() / want).max_element() < 1e-5,
                    "front pixel {i}: {got} vs Le × texture = {want}"
                );
                levels.insert((tau.x * 100.0).round() as u32);
            } else {
                assert_eq!(got, Vec3::ZERO, "back pixel {i}");
            }
        }
        if front {
            // Pure squares (0.1 and 1) and the bilinear ramps between them.
            assert!(levels.contains(&10) && levels.contains(&100) && levels.len() > 10);
        }
    }
}

/// Textured and untextured faces in one view, through both entry points of pass 5 (stills and
/// the window's fused display), which draw textured pixels separately where the device has a
/// stencil for it: every pixel equals the CPU mirror, and the window shows the still's
/// radiance.
#[test]
fn textured_and_untextured_faces_render_alike_in_stills_and_the_window() {
    let Some(ctx) = gpu() else { return };
    let mut b = SceneBuilder::new();
    let floor = b.material(material(Vec3::splat(0.9), Some(0), Vec3::ZERO, None));
    let wall = b.diffuse("wall", Vec3::new(0.2, 0.6, 0.3), Vec3::ZERO);
    let lamp = b.diffuse("lamp", Vec3::ZERO, Vec3::splat(5.0));
    vlf_tests::scenes::hquad(&mut b, 0.0, 1.0, true, floor);
    b.quad(
        [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 1.5, -1.0),
            Vec3::new(-1.0, 1.5, -1.0),
        ],
        wall,
    );
    vlf_tests::scenes::down_square(&mut b, 1.4, 0.3, lamp);
    let mut scene = b.build("checker floor, wall, lamp");
    scene
        .textures
        .push(checker(64, 4, 0.1, 0.8, WrapMode::Repeat));
    set_uvs(&mut scene, floor, |p| Vec2::new(p.x + 1.0, p.z + 1.0));
    let lf = bake(&scene, Vec3::splat(0.2));
    let xf = scene.to_vlf;
    let cam = CameraView::look_at(
        xf.apply(Vec3::new(0.3, 1.0, 1.8)),
        xf.apply(Vec3::new(0.0, 0.3, -0.5)),
        1.0,
    );
    let mut r = Renderer::new(ctx, &lf).unwrap();
    let f = r.render_frame_data(ctx, &cam, W, H).unwrap();
    assert_matches_cpu_mirror(&lf, &f, &cam);
    let count = |m: u32| {
        (f.face_id.iter())
            .filter(|&&id| id != NO_FACE && lf.faces[id as usize].material == m)
            .count()
    };
    let (n_floor, n_wall) = (count(floor), count(wall));
    assert!(
        n_floor > 1000 && n_wall > 1000,
        "both kinds of face in view: floor {n_floor}, wall {n_wall} pixels"
    );

    // The window path (fused display, raw values) shows the same radiance: drawn in two parts
    // by stencil where the device has the format for it (lavapipe has).
    eprintln!(
        "window path split by stencil: {}",
        ctx.device
            .features()
            .contains(wgpu::Features::DEPTH32FLOAT_STENCIL8)
    );
    let shown = window_frame(ctx, &mut r, &cam, W, H);
    for (i, px) in shown.iter().enumerate() {
        let (got, want) = (
            Vec4::from(*px).truncate(),
            Vec4::from(f.radiance[i]).truncate(),
        );
        assert!(
            (got - want).abs().max_element() <= 1e-6,
            "window pixel {i}: {got} vs still {want}"
        );
    }
    // A still of several samples (accumulated in a buffer) averages the same shading.
    let still = r.render_still(ctx, &cam, W, H, 4).unwrap();
    let mean =
        |v: &mut dyn Iterator<Item = Vec3>| v.fold(Vec3::ZERO, |a, b| a + b) / (W * H) as f32;
    let (m4, m1) = (
        mean(&mut still.iter().map(|p| Vec3::from(*p))),
        mean(&mut f.radiance.iter().map(|p| Vec4::from(*p).truncate())),
    );
    assert!(((m4 - m1).abs() / m1).max_element() < 0.02, "{m4} vs {m1}");
}
