//! Shading normals, vertex colours and `TEXCOORD_1` (issue 25) on the GPU, against the CPU
//! specifications on one scene that has all three (smooth diffuse, mirror and glossy spheres, a
//! floor with vertex colours, a wall whose texture reads `TEXCOORD_1`, a lamp, a sun and a sky):
//! the final gather (`gather_texels.wgsl` against `vlf_core::gather`), the path tracer
//! (`raytrace_path.wgsl` against `vlf_core::pathtrace`) and pass 5 with pass 4b
//! (`render_final_radiance.wgsl`, `render_attributes.wgsl` against
//! `render::final_radiance::surface_radiance` and `render::mirror_trace::traced_specular`), plus
//! the window's fused drawing against stills, and vertex colours and the second uv set read
//! analytically under a uniform sky.

use glam::{Vec2, Vec3, Vec4};
use vlf_core::gather::{Converged, final_gather};
use vlf_core::lightfield::{BakeParams, FACE_DIFFUSE, Iterations};
use vlf_core::pathtrace::{PinholeCamera, PreparedScene, RenderSettings};
use vlf_core::scene::{
    Corners, FilterMode, Material, MaterialKind, Scene, SceneBuilder, Sun, TexRef, Texture,
    WrapMode,
};
use vlf_gpu::gather::{GatherOptions, GatherPipelines};
use vlf_gpu::render::final_radiance::{SurfaceLookup, surface_radiance, visible_side};
use vlf_gpu::render::mirror_trace;
use vlf_gpu::render::{CameraView, NO_FACE, Renderer};
use vlf_tests::bakes;
use vlf_tests::bakes::Propagation;
use vlf_tests::{gpu, window_frame};

/// A 2 × 2 texture of four colours.
fn four_colours() -> Texture {
    Texture {
        name: None,
        width: 2,
        height: 2,
        pixels: vec![
            Vec4::new(1.0, 0.2, 0.2, 1.0),
            Vec4::new(0.2, 1.0, 0.2, 1.0),
            Vec4::new(0.2, 0.2, 1.0, 1.0),
            Vec4::new(1.0, 1.0, 0.2, 1.0),
        ],
        has_alpha: false,
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        filter: FilterMode::Linear,
        gltf_texture: 0,
    }
}

/// The scene of the module docs.
fn attribute_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let floor = b.diffuse("floor", Vec3::splat(0.8), Vec3::ZERO);
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let mirror = b.mirror("mirror", Vec3::new(0.9, 0.8, 0.7));
    let glossy = b.material(Material {
        name: "glossy".into(),
        base_color: Vec3::new(0.8, 0.7, 0.9),
        base_color_texture: None,
        emission: Vec3::ZERO,
        emissive_texture: None,
        double_sided: true,
        kind: MaterialKind::Mirror,
        metallic: 1.0,
        roughness: 0.4,
        transparency: Default::default(),
    });
    let wall = b.diffuse("wall", Vec3::splat(0.9), Vec3::ZERO);
    let lamp = b.diffuse("lamp", Vec3::ZERO, Vec3::splat(4.0));
    let q = [
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -1.0),
    ];
    let colour = [
        Vec3::new(1.0, 0.3, 0.3),
        Vec3::new(0.3, 1.0, 0.3),
        Vec3::new(0.3, 0.3, 1.0),
        Vec3::ONE,
    ];
    for [i, j, k] in [[0, 1, 2], [0, 2, 3]] {
        let corners = Corners {
            colors: Some([colour[i], colour[j], colour[k]]),
            ..Corners::default()
        };
        b.triangle_with([q[i], q[j], q[k]], floor, corners);
    }
    b.sphere(Vec3::new(-0.4, 0.35, 0.0), 0.3, (16, 8), white, true);
    b.sphere(Vec3::new(0.45, 0.3, 0.35), 0.25, (16, 8), mirror, true);
    b.sphere(Vec3::new(0.4, 0.2, -0.5), 0.18, (12, 6), glossy, true);
    // The wall at z = −1 facing +z: TEXCOORD_0 constant, TEXCOORD_1 spanning the texture twice.
    let w = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 1.0, -1.0),
        Vec3::new(-1.0, 1.0, -1.0),
    ];
    for [i, j, k] in [[0, 1, 2], [0, 2, 3]] {
        let t = |p: Vec3| Vec2::new(p.x + 1.0, 1.0 - p.y);
        let corners = Corners {
            uv: [Vec2::splat(0.25); 3],
            uv1: Some([t(w[i]), t(w[j]), t(w[k])]),
            ..Corners::default()
        };
        b.triangle_with([w[i], w[j], w[k]], wall, corners);
    }
    vlf_tests::scenes::down_square(&mut b, 1.2, 0.2, lamp);
    let mut scene = b.build("attributes");
    scene.textures.push(four_colours());
    scene.materials[wall as usize].base_color_texture = Some(TexRef {
        index: 0,
        texcoord: 1,
    });
    scene.suns.push(Sun {
        name: None,
        direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
        irradiance: Vec3::splat(2.0),
    });
    assert!(scene.has_smooth_normals() && scene.has_vertex_colors() && scene.uses_texcoord1());
    scene
}

const SKY: Vec3 = Vec3::new(0.2, 0.2, 0.3);

fn small_params(sky: Vec3) -> BakeParams {
    BakeParams {
        texel_scale: 1.0,
        sky,
        perturb: 0,
        final_gather: None,
        ..bakes::params(46, 32, Iterations::Fixed(3))
    }
}

/// The GPU gather against the CPU gather (the same grids and streams): smooth texels' points
/// carry their interpolated normals on both, the field's hit albedo the vertex colours and the
/// second uv set. Bounds as `gather_gpu`'s (mean relative difference 1e-4, texels beyond 1e-3
/// at most 1 %: f32 rounding of sin, cos and sqrt sends a ray another way now and then).
#[test]
fn gpu_gather_matches_cpu_with_shading_normals_colours_and_uv1() {
    let Some(ctx) = gpu() else { return };
    let scene = attribute_scene();
    let params = small_params(SKY);
    let prop = Propagation::new(&scene, &params);
    let field = Converged {
        first_bounce: None,
        ..prop.converged(SKY, 2.0 / 32.0)
    };
    let gp = vlf_tests::bakes::fixed_gather(1.0, 2.0, [16, 9, 16]);
    let cpu = final_gather(&scene, &field, &gp, 0).unwrap();
    let pipelines = GatherPipelines::of(ctx);
    let gpu = vlf_gpu::gather::final_gather_with(
        ctx,
        &pipelines,
        &scene,
        &field,
        &gp,
        &GatherOptions::default(),
    )
    .unwrap();
    let d = crate::gather_gpu::difference_sums(&cpu, &gpu);
    let (mean, beyond, covered) = (
        d.diff / d.total,
        d.beyond as f64 / d.covered as f64,
        d.covered,
    );
    eprintln!(
        "attribute scene: {covered} covered texels; GPU vs CPU gather: mean relative difference \
         {mean:.3e}, texels beyond 1e-3: {beyond:.4}"
    );
    assert!(d.total > 0.0);
    assert!(mean <= 1e-4, "mean relative difference {mean:.3e}");
    assert!(beyond <= 0.01, "{beyond:.4} of texels beyond 1e-3");
}

/// The GPU path tracer (both kernels) against the CPU tracer with the same streams: within the
/// difference of two independent CPU renders (relMSE), as `pathtrace_gpu`'s scenes.
#[test]
fn gpu_path_tracer_matches_cpu_with_shading_normals_colours_and_uv1() {
    let Some(ctx) = gpu() else { return };
    let scene = attribute_scene();
    let prep = PreparedScene::new(&scene);
    let s = RenderSettings {
        width: 64,
        height: 48,
        spp: 32,
        seed: 9,
        sky: SKY,
        threads: 0,
    };
    let camera = PinholeCamera::look_at(
        Vec3::new(0.3, 1.3, 2.2),
        Vec3::new(0.0, 0.3, -0.2),
        50.0,
        64,
        48,
    )
    .unwrap();
    crate::pathtrace_gpu::both_kernels_agree_with_cpu(
        ctx,
        &prep,
        &camera,
        &s,
        10,
        "attribute scene",
    );
}

fn rgb(p: [f32; 4]) -> Vec3 {
    Vec4::from(p).truncate()
}

/// Pass 5 against its CPU specification on the attribute scene's light field, every pixel of
/// two views: diffuse pixels `surface_radiance` with pass 4's uv and pass 4b's attributes
/// (vertex colours, `TEXCOORD_1`), mirror and glossy pixels that plus `traced_specular` about
/// the interpolated normal (sample 0), the share cut off reading the tiles (taken from the
/// tracing-off frame, as `render_mirrors` does). Same arithmetic in f32 on both sides:
/// relative difference ≤ 1e-4 (`render_mirrors`' bound). Then the window's fused drawing
/// (attributes as varyings) against the stills, within 1e-6 as there.
#[test]
fn pass_five_matches_its_specification_with_attributes() {
    let Some(ctx) = gpu() else { return };
    let scene = attribute_scene();
    let lf = vlf_core::pipeline::bake_cpu(&scene, &small_params(SKY)).unwrap();
    assert!(lf.shading.normals.is_some() && lf.shading.colors.is_some());
    assert!(lf.shading.uvs1.is_some());
    let lookup = SurfaceLookup::new(&lf);
    let bvh = mirror_trace::build_bvh(&lf);
    let (w, h) = (64u32, 64u32);
    let views = [
        (Vec3::new(0.3, 1.3, 2.2), Vec3::new(0.0, 0.3, -0.2), 50.0f32),
        (Vec3::new(0.9, 0.5, 0.9), Vec3::new(0.45, 0.3, 0.35), 40.0),
    ];
    let (mut worst, mut smooth_specular, mut coloured, mut uv1) = (0.0f32, 0, 0, 0);
    let mut r = Renderer::new(ctx, &lf).unwrap();
    for (eye, target, fov) in views {
        let cam = CameraView::look_at(
            lf.to_vlf.apply(eye),
            lf.to_vlf.apply(target),
            fov.to_radians(),
        );
        r.set_mirror_tracing(true);
        let on = r.render_frame_data(ctx, &cam, w, h).unwrap();
        r.set_mirror_tracing(false);
        let off = r.render_frame_data(ctx, &cam, w, h).unwrap();
        assert_eq!(on.attributes.0.len(), (w * h) as usize, "pass 4b ran");
        for i in 0..(w * h) as usize {
            let face = on.face_id[i];
            if face == NO_FACE {
                continue;
            }
            let f = &lf.faces[face as usize];
            let p = Vec4::from(on.position[i]).truncate();
            let side = visible_side(f, cam.position, p);
            let s = on.surface(i);
            let flags = lookup.flags[face as usize];
            coloured += usize::from(flags & vlf_gpu::render::upload::FLAG_COLORS != 0);
            uv1 += usize::from(flags & vlf_gpu::render::upload::FLAG_BASE_UV1 != 0);
            let surface = surface_radiance(&lf, &lookup, face, side, p, &s);
            let want = if f.kind == FACE_DIFFUSE {
                surface
            } else {
                smooth_specular += usize::from(s.normal != Vec3::ZERO);
                let t = mirror_trace::traced_specular(
                    &lf,
                    &bvh,
                    &lookup,
                    cam.position,
                    face,
                    p,
                    &s,
                    i as u32,
                    0,
                );
                surface + t.radiance + t.tiles * (rgb(off.radiance[i]) - surface)
            };
            let got = rgb(on.radiance[i]);
            worst = worst.max((got - want).abs().max_element() / want.max_element().max(1e-3));
        }
        // The window: pass 4 and 4b fused into pass 5 (varyings), the same values.
        for tracing in [true, false] {
            r.set_mirror_tracing(tracing);
            let still = r.render_frame_data(ctx, &cam, w, h).unwrap();
            let shown = window_frame(ctx, &mut r, &cam, w, h);
            for (i, px) in shown.iter().enumerate() {
                let (got, want) = (rgb(*px), rgb(still.radiance[i]));
                assert!(
                    (got - want).abs().max_element() <= 1e-6 * want.max_element().max(1.0),
                    "tracing {tracing}: window pixel {i}: {got} vs still {want}"
                );
            }
        }
    }
    eprintln!(
        "attribute scene, pass 5: relative difference from the CPU specification at most \
         {worst:.2e}; {smooth_specular} smooth specular, {coloured} coloured, {uv1} TEXCOORD_1 \
         pixels"
    );
    assert!(smooth_specular > 200 && coloured > 200 && uv1 > 200);
    assert!(worst <= 1e-4, "relative difference {worst:.2e}");
}

/// Vertex colours and the second uv set, analytically: a floor of albedo 0.5 whose corners are
/// coloured c under a uniform sky L, its texture (read through `TEXCOORD_1` at a texel's
/// centre) τ; the final gather gives it E = π L exactly (every ray leaves the scene), so pass 5
/// shows 0.5 · τ · c · L at every pixel, also where the view is the window's (within the
/// rounding of E to f16, 2⁻¹¹ relative, and of the interpolated colour to 10 bits, 0.5/1023 of
/// a channel at most, 2e-3 of the smallest, 0.25: 2.5e-3 relative).
#[test]
fn colours_and_second_uv_set_render_analytically_under_a_sky() {
    let Some(ctx) = gpu() else { return };
    let c = Vec3::new(0.25, 0.5, 1.0);
    let mut b = SceneBuilder::new();
    let m = b.diffuse("floor", Vec3::splat(0.5), Vec3::ZERO);
    let q = [
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -1.0),
    ];
    let corners = Corners {
        colors: Some([c; 3]),
        uv: [Vec2::splat(0.25); 3],
        uv1: Some([Vec2::new(0.75, 0.25); 3]),
        ..Corners::default()
    };
    b.triangle_with([q[0], q[1], q[2]], m, corners.clone());
    b.triangle_with([q[0], q[2], q[3]], m, corners);
    let mut scene = b.build("coloured floor");
    scene.textures.push(four_colours());
    scene.materials[0].base_color_texture = Some(TexRef {
        index: 0,
        texcoord: 1,
    });
    let sky = Vec3::new(1.0, 2.0, 3.0);
    let params = BakeParams {
        final_gather: Some(vlf_tests::bakes::fixed_gather(1.0, 2.0, [4, 4, 4])),
        ..small_params(sky)
    };
    let lf = vlf_core::pipeline::bake_cpu(&scene, &params).unwrap();
    // τ: texel (1, 0) of the texture, green.
    let want = 0.5 * Vec3::new(0.2, 1.0, 0.2) * c * sky;
    let cam = CameraView::look_at(
        lf.to_vlf.apply(Vec3::new(0.2, 1.5, 0.3)),
        lf.to_vlf.apply(Vec3::ZERO),
        50f32.to_radians(),
    );
    let mut r = Renderer::new(ctx, &lf).unwrap();
    let still = r.render_frame_data(ctx, &cam, 32, 32).unwrap();
    let shown = window_frame(ctx, &mut r, &cam, 32, 32);
    let mut seen = 0;
    for i in 0..32 * 32 {
        if still.face_id[i] == NO_FACE {
            continue;
        }
        seen += 1;
        for got in [rgb(still.radiance[i]), rgb(shown[i])] {
            assert!(
                ((got - want) / want).abs().max_element() <= 2.5e-3,
                "pixel {i}: {got} vs {want}"
            );
        }
    }
    assert!(seen > 500, "{seen} floor pixels");
}
