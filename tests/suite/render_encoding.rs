//! The renderer uploads radiance in its stored encoding (`Rgb9e5Ufloat` for RGB9E5,
//! `Rgba16Float` for f16 RGB): the GPU's texel fetch must decode every value exactly as
//! `Radiance::get` does (so a loaded file renders as it did when the reader decoded to f32),
//! and both encodings must render the light field they hold.

use glam::Vec4;
use vlf_core::lightfield::{
    Iterations, LightField, Radiance, RadianceEncoding, encoding::f16_decode,
};
use vlf_gpu::readback::{read_buffer, storage_buffer};
use vlf_gpu::render::final_radiance::{
    SurfaceLookup, atlas_irradiance, surface_radiance, visible_side,
};
use vlf_gpu::render::upload::rho_over_pi;
use vlf_gpu::render::upload::{ATLAS_WIDTH, radiance_texture};
use vlf_gpu::render::{CameraView, NO_FACE, Renderer};
use vlf_tests::bakes;
use vlf_tests::{gpu, repo_dir};

/// Test-only shader: value `i` of the uploaded radiance texture, fetched like pass 5 does.
const FETCH_WGSL: &str = "
@group(0) @binding(0) var radiance: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
const ATLAS_WIDTH: u32 = 4096u;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) {
        return;
    }
    out[i] = textureLoad(radiance, vec2<u32>(i % ATLAS_WIDTH, i / ATLAS_WIDTH), 0);
}
";

/// The GPU's view of `r`: every value fetched from the uploaded texture.
fn fetch_on_gpu(r: &Radiance) -> Vec<[f32; 4]> {
    let ctx = gpu().expect("checked by the caller");
    let (device, queue) = (&ctx.device, &ctx.queue);
    let mut bytes = 0;
    let view = radiance_texture(device, queue, "Test::radiance", r, &mut bytes).unwrap();
    let out = storage_buffer(
        device,
        "Test::fetched",
        &vec![[f32::NAN; 4]; r.len()],
        wgpu::BufferUsages::COPY_SRC,
    );
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("Test::fetch"),
        source: wgpu::ShaderSource::Wgsl(FETCH_WGSL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("Test::fetch_pipeline"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("Test::fetch_bind_group"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((r.len() as u32).div_ceil(64), 1, 1);
    }
    queue.submit(Some(encoder.finish()));
    read_buffer(device, queue, &out).unwrap()
}

#[test]
fn gpu_texel_fetch_decodes_both_encodings_exactly() {
    if gpu().is_none() {
        return;
    }
    assert_eq!(ATLAS_WIDTH, 4096);
    // RGB9E5: every exponent with assorted mantissas per channel (incl. 0 and 511).
    let mut words = Vec::new();
    for e in 0..32u32 {
        for k in 0..160u32 {
            let m = |c: u32| (k * 37 + c * 101 + e * 13) % 512;
            let m = if k == 0 {
                [0, 511, 1]
            } else {
                [m(0), m(1), m(2)]
            };
            words.push(m[0] | (m[1] << 9) | (m[2] << 18) | (e << 27));
        }
    }
    // (Also words no encoder produces, with denormalised mantissas: files may hold them.)
    let le: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let rgb9e5 = Radiance::from_stored(RadianceEncoding::Rgb9e5, &le).unwrap();
    // f16: every finite non-negative half (subnormals included), three per texel, and a
    // count that leaves a partial last texture row.
    let halves: Vec<f32> = (0..0x7C00u16).map(f16_decode).collect();
    let values: Vec<[f32; 4]> = halves
        .chunks(3)
        .map(|h| [h[0], h[h.len() / 2], h[h.len() - 1], 0.0])
        .collect();
    let f16 = Radiance::from_f32(&values, RadianceEncoding::RgbF16).unwrap();
    // Large: uploaded in several bands (8 MiB each), the last with a partial row.
    let many: Vec<[f32; 4]> = (0..1_300_001)
        .map(|i| values[(i * 7) % values.len()])
        .collect();
    let large = Radiance::from_f32(&many, RadianceEncoding::RgbF16).unwrap();
    let le: Vec<u8> = (0..2_200_003u32)
        .flat_map(|i| words[(i as usize * 5) % words.len()].to_le_bytes())
        .collect();
    let large9e5 = Radiance::from_stored(RadianceEncoding::Rgb9e5, &le).unwrap();
    for r in [rgb9e5, f16, large, large9e5] {
        let got = fetch_on_gpu(&r);
        assert!(r.len() > ATLAS_WIDTH as usize && r.len() % ATLAS_WIDTH as usize != 0);
        for (i, g) in got.iter().enumerate() {
            let want = r.get(i);
            assert!(
                g[..3]
                    .iter()
                    .zip(&want)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{}: value {i}: GPU {g:?}, CPU {want:?}",
                r.encoding().name()
            );
        }
        eprintln!(
            "{}: {} values fetched bit-exactly",
            r.encoding().name(),
            r.len()
        );
    }
}

fn bake(scene: &str) -> LightField {
    let scene = vlf_core::scene::load(&repo_dir().join(scene)).unwrap();
    let params = bakes::params(46, 32, Iterations::Fixed(2));
    vlf_core::pipeline::bake_cpu(&scene, &params).unwrap()
}

fn with_encoding(lf: &LightField, enc: RadianceEncoding) -> LightField {
    let mut lf = lf.clone();
    lf.irradiance = lf.irradiance.to_encoding(enc);
    if let Some(t) = lf.tiles.as_mut() {
        t.radiance = t.radiance.to_encoding(enc);
    }
    lf
}

#[test]
fn both_encodings_render_their_radiance() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (64, 64);
    let diffuse = bake("assets/cornell-box/cornell-box.gltf");
    let mirror = bake("assets/cornell-mirror/cornell-mirror.gltf");
    assert_eq!(diffuse.irradiance.encoding(), RadianceEncoding::RgbF16);
    for lf in [&diffuse, &mirror] {
        let cam = CameraView::from_gltf(&lf.cameras[0], &lf.to_vlf);
        let mut images = Vec::new();
        for enc in RadianceEncoding::ALL {
            let lf = with_encoding(lf, enc);
            let lookup = SurfaceLookup::new(&lf);
            let mut r = Renderer::new(ctx, &lf).unwrap();
            // Mirror pixels read their stored tiles (the bound below is theirs); traced ones
            // read the atlas at their hit (tests/suite/render_mirrors.rs).
            r.set_mirror_tracing(false);
            let f = r.render_frame_data(ctx, &cam, w, h).unwrap();
            // Diffuse faces: the CPU lookup of the same stored values.
            for i in 0..(w * h) as usize {
                let face = f.face_id[i];
                if face == NO_FACE || lf.faces[face as usize].kind != 0 {
                    continue;
                }
                let bf = &lf.faces[face as usize];
                let p = Vec4::from(f.position[i]).truncate();
                let side = visible_side(bf, cam.position, p);
                let want = surface_radiance(&lf, &lookup, face, side, p, &f.surface(i));
                let got = Vec4::from(f.radiance[i]).truncate();
                let tol = 1e-4 * want.abs().max_element().max(1e-3);
                assert!(
                    (got - want).abs().max_element() <= tol,
                    "{}: pixel {i}: GPU {got} vs CPU {want}",
                    enc.name()
                );
            }
            images.push(f);
        }
        // RGB9E5 vs f16: within RGB9E5's error, ≤ 1/511 of a stored value's largest channel:
        // of the irradiance (times ρ_d/π per channel) on diffuse faces, of the tile radiance on
        // mirrors.
        let (mut diff, mut sum) = (0f64, 0f64);
        assert_eq!(RadianceEncoding::ALL[1], RadianceEncoding::RgbF16);
        let f16 = &images[1];
        for (i, (a, b)) in images[0]
            .radiance
            .iter()
            .zip(&images[1].radiance)
            .enumerate()
        {
            let (a, b) = (Vec4::from(*a).truncate(), Vec4::from(*b).truncate());
            let face = f16.face_id[i];
            let bound = if face != NO_FACE && lf.faces[face as usize].kind == 0 {
                let bf = &lf.faces[face as usize];
                let p = Vec4::from(f16.position[i]).truncate();
                let e = atlas_irradiance(bf, &lf.irradiance, visible_side(bf, cam.position, p), p);
                let m = &lf.shading.materials[bf.material as usize];
                rho_over_pi(m) * e.max_element()
            } else {
                glam::Vec3::splat(a.max(b).max_element())
            };
            assert!(
                (a - b).abs().cmple(bound / 400.0 + 1e-6).all(),
                "pixel {i}: {a} vs {b}"
            );
            diff += f64::from((a - b).abs().element_sum());
            sum += f64::from((a + b).element_sum()) / 2.0;
        }
        eprintln!(
            "{}: RGB9E5 vs f16 image, mean |difference| / mean = {:.2e}",
            lf.scene.source,
            diff / sum
        );
        assert!(diff / sum < 2e-3);
    }
}
