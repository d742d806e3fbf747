//! The five-pass renderer (vlf_gpu::render) against CPU evaluations of the same quantities, on a
//! Cornell box baked with the CPU reference at tiny settings. Small images (64×64) keep each test
//! well under a few seconds on lavapipe.

use std::collections::HashMap;
use std::path::Path;
use std::sync::OnceLock;
use vlf_tests::bakes;

use glam::{Vec2, Vec3, Vec4};
use vlf_core::lightfield::{BakeParams, Iterations, LightField};
use vlf_gpu::GpuContext;
use vlf_gpu::render::final_radiance::{SurfaceLookup, surface_radiance, visible_side};
use vlf_gpu::render::targets::read_texture;
use vlf_gpu::render::{CameraView, FrameData, NO_FACE, Pass, Renderer, Tonemap};
use vlf_tests::{gpu, repo_dir, shared_dir};

const W: u32 = 64;
const H: u32 = 64;

/// The brief's small development settings: 46 directions (k = 3: 46), 32 rays per side,
/// 8×8 tiles, two iterations.
fn small_params() -> BakeParams {
    bakes::params(46, 32, Iterations::Fixed(2))
}

fn bake(path: &Path, params: &BakeParams) -> LightField {
    let scene = vlf_core::scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    vlf_core::pipeline::bake_cpu(&scene, params).unwrap()
}

/// The repository's Cornell box, CPU-reference baked at [`small_params`] (once per test binary).
fn cornell() -> &'static LightField {
    static LF: OnceLock<LightField> = OnceLock::new();
    LF.get_or_init(|| {
        bake(
            &repo_dir().join("assets/cornell-box/cornell-box.gltf"),
            &small_params(),
        )
    })
}

fn gltf_camera(lf: &LightField) -> CameraView {
    CameraView::from_gltf(&lf.cameras[0], &lf.to_vlf)
}

/// A second view: wide angle, tilted and rolled, from inside the box, so the direction passes
/// see many sphere triangles and the geometry passes see faces at grazing angles.
fn inside_camera(lf: &LightField) -> CameraView {
    let c = gltf_camera(lf);
    let mut cam = CameraView::look_at(Vec3::new(0.2, -0.1, 0.3), Vec3::new(-0.6, 0.5, -0.4), 1.9);
    cam.rotation = glam::Quat::from_axis_angle(cam.forward(), 0.4) * cam.rotation;
    cam.znear = c.znear;
    cam
}

fn frame(ctx: &GpuContext, lf: &LightField, cam: &CameraView) -> FrameData {
    let mut r = Renderer::new(ctx, lf).unwrap();
    r.render_frame_data(ctx, cam, W, H).unwrap()
}

fn pixel_centre(x: u32, y: u32) -> Vec2 {
    Vec2::new(x as f32 + 0.5, y as f32 + 0.5)
}

#[test]
fn direction_barycentrics_match_cpu_lookup() {
    let Some(ctx) = gpu() else { return };
    let lf = cornell();
    for cam in [gltf_camera(lf), inside_camera(lf)] {
        let f = frame(ctx, lf, &cam);
        let mut checked = 0;
        let mut same_triangle = 0;
        let mut triangles = std::collections::HashSet::new();
        let mut max_err = 0f32;
        for y in (0..H).step_by(3) {
            for x in (0..W).step_by(3) {
                let i = (y * W + x) as usize;
                let d = cam.pixel_ray(W, H, pixel_centre(x, y));
                let cpu = lf.directions.lookup(d);
                let ids = f.direction_ids[i];
                let w = f.barycentrics[i];
                triangles.insert(ids[3]);
                // Compare as weight per sphere vertex: on a shared edge the GPU may pick the
                // neighbouring triangle, whose third vertex must then have ~zero weight.
                let mut gpu_w: HashMap<u32, f32> = HashMap::new();
                for n in 0..3 {
                    *gpu_w.entry(ids[n]).or_default() += w[n];
                }
                let mut cpu_w: HashMap<u32, f32> = HashMap::new();
                for n in 0..3 {
                    *cpu_w.entry(cpu.vertices[n]).or_default() += cpu.weights[n];
                }
                for v in gpu_w.keys().chain(cpu_w.keys()) {
                    let err = (gpu_w.get(v).copied().unwrap_or(0.0)
                        - cpu_w.get(v).copied().unwrap_or(0.0))
                    .abs();
                    max_err = max_err.max(err);
                    let (a, b) = (
                        gpu_w.get(v).copied().unwrap_or(0.0),
                        cpu_w.get(v).copied().unwrap_or(0.0),
                    );
                    assert!(
                        (a - b).abs() <= 1e-4,
                        "pixel ({x}, {y}) sphere vertex {v}: GPU weight {a}, CPU {b} (GPU {ids:?} {w:?}, CPU {cpu:?})"
                    );
                }
                assert!((w[0] + w[1] + w[2] - 1.0).abs() < 1e-4);
                same_triangle += usize::from(ids[3] == cpu.triangle);
                checked += 1;
            }
        }
        eprintln!(
            "barycentrics: {checked} pixels, max weight error {max_err:e}, {same_triangle} in the CPU's triangle, {} triangles seen",
            triangles.len()
        );
        assert!(
            same_triangle * 100 >= checked * 95,
            "{same_triangle}/{checked} in the CPU's triangle"
        );
        assert!(
            triangles.len() >= 4,
            "only {} sphere triangles seen",
            triangles.len()
        );
    }
}

/// CPU ray cast: nearest triangle hit (face, VLF point) along `origin + t·d`, `t > near`.
fn ray_cast(lf: &LightField, origin: Vec3, d: Vec3, near: f32) -> Option<(u32, Vec3)> {
    let mut best: Option<(f32, u32)> = None;
    for t in &lf.triangles {
        let (p0, p1, p2) = (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2));
        // Möller–Trumbore in f64 for a trustworthy reference.
        let (o, d) = (origin.as_dvec3(), d.as_dvec3());
        let (e1, e2) = ((p1 - p0).as_dvec3(), (p2 - p0).as_dvec3());
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-14 {
            continue;
        }
        let s = o - p0.as_dvec3();
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let dist = e2.dot(q) / det;
        if u < 0.0 || v < 0.0 || u + v > 1.0 || dist <= f64::from(near) {
            continue;
        }
        if best.is_none_or(|(b, _)| (dist as f32) < b) {
            best = Some((dist as f32, t.face));
        }
    }
    best.map(|(t, f)| (f, origin + d * t))
}

#[test]
fn face_ids_and_positions_match_cpu_ray_cast() {
    let Some(ctx) = gpu() else { return };
    let lf = cornell();
    for cam in [gltf_camera(lf), inside_camera(lf)] {
        let f = frame(ctx, lf, &cam);
        // Depth along the ray of the near plane at pixel (x, y) (the plane is at znear along −Z).
        let cpu: Vec<Option<(u32, Vec3)>> = (0..W * H)
            .map(|i| {
                let d = cam.pixel_ray(W, H, pixel_centre(i % W, i / W));
                ray_cast(lf, cam.position, d, cam.znear / d.dot(cam.forward()))
            })
            .collect();
        let id = |o: &Option<(u32, Vec3)>| o.map_or(NO_FACE, |h| h.0);
        let (mut interior, mut agree, mut max_err) = (0usize, 0usize, 0f32);
        for y in 1..H - 1 {
            for x in 1..W - 1 {
                let i = (y * W + x) as usize;
                let want = id(&cpu[i]);
                // "Away from edges": the CPU sees the same face in the whole 3×3 neighbourhood.
                let edge = (-1i32..=1).any(|dy| {
                    (-1i32..=1).any(|dx| {
                        id(&cpu[((y as i32 + dy) as u32 * W + (x as i32 + dx) as u32) as usize])
                            != want
                    })
                });
                if edge {
                    continue;
                }
                interior += 1;
                if f.face_id[i] != want {
                    continue;
                }
                agree += 1;
                let pos = f.position[i];
                match cpu[i] {
                    Some((_, p)) => {
                        assert_eq!(pos[3], 1.0, "pixel ({x}, {y}) has a face but no position");
                        let err = (Vec4::from(pos).truncate() - p).abs().max_element();
                        max_err = max_err.max(err);
                    }
                    None => assert_eq!(pos[3], 0.0, "background pixel ({x}, {y}) has a position"),
                }
            }
        }
        eprintln!(
            "face ids agree on {agree}/{interior} interior pixels; max position error {max_err:e}"
        );
        assert!(
            interior > (W * H / 2) as usize,
            "only {interior} interior pixels"
        );
        assert!(
            agree * 100 >= interior * 99,
            "face ids agree on {agree} of {interior} interior pixels"
        );
        assert!(max_err <= 1e-4, "position error {max_err} (VLF units)");
    }
}

#[test]
fn final_radiance_matches_cpu_bilinear_lookup() {
    let Some(ctx) = gpu() else { return };
    let lf = cornell();
    let lookup = SurfaceLookup::new(lf);
    for cam in [gltf_camera(lf), inside_camera(lf)] {
        let f = frame(ctx, lf, &cam);
        let mut faces_seen = 0;
        for i in 0..(W * H) as usize {
            let got = Vec4::from(f.radiance[i]).truncate();
            let face = f.face_id[i];
            if face == NO_FACE {
                assert_eq!(got, lf.params.sky, "background pixel {i} is not the sky");
                continue;
            }
            faces_seen += 1;
            let bf = &lf.faces[face as usize];
            let p = Vec4::from(f.position[i]).truncate();
            let side = visible_side(bf, cam.position, p);
            let want = surface_radiance(lf, &lookup, face, side, p, &f.surface(i));
            let tol = 1e-4 * want.abs().max_element().max(1e-3);
            assert!(
                (got - want).abs().max_element() <= tol,
                "pixel ({}, {}) face {face}: GPU {got} vs CPU {want}",
                i as u32 % W,
                i as u32 / W
            );
        }
        assert!(faces_seen > 100);
    }
}

/// `mean_rgb` of a reference's JSON sidecar (tiny parser: the test crate has no JSON dependency).
fn reference_mean(json: &str) -> [f64; 3] {
    let start = json
        .find("\"mean_rgb\"")
        .expect("mean_rgb in the reference JSON");
    let open = start + json[start..].find('[').unwrap();
    let close = open + json[open..].find(']').unwrap();
    let v: Vec<f64> = json[open + 1..close]
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    [v[0], v[1], v[2]]
}

/// A Cornell-box still at tiny bake settings is not blank and its mean is within 20% of the
/// path-traced reference's mean per channel. Loose on purpose: 46 directions, 32×32 rays and
/// only two bounces lose energy and blur the light; this checks conventions (camera, scale,
/// emission, box filter, row order), not accuracy.
#[test]
fn cornell_still_mean_is_near_the_reference() {
    let Some(ctx) = gpu() else { return };
    let dir = shared_dir();
    let scene = dir.join("scenes/cornell-box/cornell.gltf");
    let json = dir.join("reference/cornell-ref.json");
    if !scene.exists() || !json.exists() {
        panic!(
            "shared scene/reference missing: {} {}",
            scene.display(),
            json.display()
        );
    }
    let want = reference_mean(&std::fs::read_to_string(&json).unwrap());
    let lf = bake(&scene, &small_params());
    let mut r = Renderer::new(ctx, &lf).unwrap();
    let cam = gltf_camera(&lf);
    let px = r.render_still(ctx, &cam, W, H, 4).unwrap();
    assert_eq!(px.len(), (W * H) as usize);
    let mut mean = [0f64; 3];
    for p in &px {
        for c in 0..3 {
            assert!(p[c].is_finite() && p[c] >= 0.0);
            mean[c] += f64::from(p[c]) / px.len() as f64;
        }
    }
    let max = px.iter().flatten().fold(0f32, |m, v| m.max(*v));
    let distinct = px
        .iter()
        .map(|p| p[0].to_bits())
        .collect::<std::collections::HashSet<_>>()
        .len();
    assert!(
        max > 1.0 && distinct > 100,
        "blank still: max {max}, {distinct} distinct values"
    );
    eprintln!("Cornell still 64×64, 4 spp: mean {mean:?}, reference {want:?}");
    for c in 0..3 {
        let rel = (mean[c] - want[c]).abs() / want[c];
        assert!(
            rel <= 0.2,
            "channel {c}: mean {} vs reference {} ({:.1}% off)",
            mean[c],
            want[c],
            rel * 100.0
        );
    }
    // The top rows see the ceiling light: row 0 is the top of the image.
    let row_mean = |y: u32| (0..W).map(|x| px[(y * W + x) as usize][0]).sum::<f32>() / W as f32;
    let top = (0..H / 4).map(row_mean).sum::<f32>();
    let bottom = (3 * H / 4..H).map(row_mean).sum::<f32>();
    assert!(
        top > bottom,
        "the light should be in the top quarter (row 0 = top)"
    );
}

#[test]
fn stills_average_jittered_samples_and_debug_views_render() {
    let Some(ctx) = gpu() else { return };
    let lf = cornell();
    let cam = gltf_camera(lf);
    let mut r = Renderer::new(ctx, lf).unwrap();
    // One sample = the pixel-centre frame; many samples = a smoother image with similar mean.
    let one = r.render_still(ctx, &cam, W, H, 1).unwrap();
    let data = r.render_frame_data(ctx, &cam, W, H).unwrap();
    for (a, b) in one.iter().zip(&data.radiance) {
        assert_eq!(*a, [b[0], b[1], b[2]]);
    }
    let many = r.render_still(ctx, &cam, W, H, 8).unwrap();
    let mean = |px: &[[f32; 3]]| {
        px.iter()
            .map(|p| f64::from(p[0] + p[1] + p[2]))
            .sum::<f64>()
            / px.len() as f64
    };
    let (m1, m8) = (mean(&one), mean(&many));
    assert!(
        (m1 - m8).abs() < 0.1 * m8,
        "means {m1} (1 spp) vs {m8} (8 spp)"
    );
    assert_ne!(one, many);
    // A different size re-creates the targets.
    assert_eq!(r.render_still(ctx, &cam, 40, 24, 2).unwrap().len(), 40 * 24);
    // Every debug view shows something.
    for pass in Pass::ALL {
        let img = r.render_debug_still(ctx, &cam, W, H, 1, pass).unwrap();
        let distinct = img
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect::<std::collections::HashSet<_>>()
            .len();
        assert!(
            distinct > 4,
            "debug view {} shows {distinct} colours",
            pass.name()
        );
    }
}

/// The window path (`render_to_view`): the final image comes from pass 5's fused display
/// (`fs_surface`/`fs_sky`), debug views from the display pass. On a float target with no tonemap both
/// must show exactly the raw pass outputs.
#[test]
fn window_path_shows_the_pass_outputs() {
    let Some(ctx) = gpu() else { return };
    let lf = cornell();
    let cam = gltf_camera(lf);
    let mut r = Renderer::new(ctx, lf).unwrap();
    let data = r.render_frame_data(ctx, &cam, W, H).unwrap();
    let format = wgpu::TextureFormat::Rgba32Float;
    let target =
        vlf_gpu::render::targets::readback_target(&ctx.device, "Test::view_target", W, H, format);
    let view = target.create_view(&Default::default());
    for pass in [Pass::FinalRadiance, Pass::Position] {
        r.set_debug_view(pass);
        for _ in 0..3 {
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            r.render_to_view(
                ctx,
                &mut encoder,
                &cam,
                &view,
                format,
                W,
                H,
                1.0,
                Tonemap::None,
            )
            .unwrap();
            ctx.queue.submit(Some(encoder.finish()));
            r.frame_submitted(ctx);
        }
        if pass == Pass::FinalRadiance && r.has_pass_times() {
            // The final image of a light field without mirrors runs pass 3 and pass 5 (with
            // pass 4 and the display fused into it) only. The timings arrive once the frame's
            // queries are read back: wait for them rather than skip the check.
            let mut times = None;
            for _ in 0..10 {
                ctx.wait_idle();
                r.frame_submitted(ctx);
                if let Some(t) = r.pass_times() {
                    times = Some(t.to_vec());
                    break;
                }
            }
            let t = times.expect("pass timings of the final-image frame");
            let ran: Vec<bool> = t.iter().map(Option::is_some).collect();
            assert_eq!(ran, [false, false, true, false, true, false], "{t:?}");
        }
        let shown: Vec<[f32; 4]> = read_texture(&ctx.device, &ctx.queue, &target, 16).unwrap();
        for (i, px) in shown.iter().enumerate() {
            let want = match pass {
                Pass::FinalRadiance => Vec4::from(data.radiance[i]).truncate(),
                _ if data.position[i][3] > 0.0 => {
                    Vec4::from(data.position[i]).truncate() * 0.5 + 0.5
                }
                _ => Vec3::ZERO,
            };
            let got = Vec4::from(*px).truncate();
            assert!(
                (got - want).abs().max_element() <= 1e-6,
                "{} pixel {i}: {got} vs {want}",
                pass.name()
            );
        }
    }
    if r.has_pass_times() {
        ctx.wait_idle();
        r.frame_submitted(ctx);
        // Timings arrive asynchronously; when they do, a debug view times all six passes.
        if let Some(t) = r.pass_times() {
            assert!(
                t.len() == 6
                    && t.iter()
                        .all(|ms| ms.is_some_and(|ms| ms.is_finite() && ms >= 0.0)),
                "{t:?}"
            );
        }
    }
}
