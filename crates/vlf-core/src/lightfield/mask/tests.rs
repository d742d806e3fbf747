use super::*;
use crate::lightfield::encoding::f16_encode;
use crate::scene::{FilterMode, Material, SceneBuilder, TexRef, Texture, Transparency};
use glam::{Vec3, Vec4};

/// A 4 × 1 texture whose alphas are 0, ⅓, ⅔, 1.
fn ramp(filter: FilterMode, wrap: WrapMode) -> Texture {
    Texture {
        name: None,
        width: 4,
        height: 1,
        pixels: (0..4)
            .map(|i| Vec4::new(1.0, 1.0, 1.0, i as f32 / 3.0))
            .collect(),
        has_alpha: true,
        wrap_s: wrap,
        wrap_t: wrap,
        filter,
        gltf_texture: 0,
    }
}

fn masked_scene(filter: FilterMode, factor: f32, cutoff: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.material(Material {
        name: "screen".into(),
        base_color: Vec3::ONE,
        base_color_texture: Some(TexRef {
            index: 0,
            texcoord: 0,
        }),
        emission: Vec3::ZERO,
        emissive_texture: None,
        double_sided: true,
        kind: crate::scene::MaterialKind::Diffuse,
        metallic: 0.0,
        roughness: 1.0,
        transparency: Transparency {
            alpha_mode: crate::scene::AlphaMode::Mask,
            alpha_cutoff: cutoff,
            alpha: factor,
            ..Transparency::default()
        },
    });
    let plain = b.diffuse("plain", Vec3::splat(0.5), Vec3::ZERO);
    b.uv_quad(
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        [
            glam::Vec2::new(0.0, 0.0),
            glam::Vec2::new(1.0, 0.0),
            glam::Vec2::new(1.0, 1.0),
            glam::Vec2::new(0.0, 1.0),
        ],
        m,
    );
    b.quad(
        [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
        ],
        plain,
    );
    let mut scene = b.build("mask test");
    scene.textures.push(ramp(filter, WrapMode::ClampToEdge));
    scene
}

/// The weights of corners 0, 1, 2 of the masked quad's first triangle (corners (0,0), (1,0),
/// (1,1) in uv) at uv (u, v).
fn weights_at(u: f32, v: f32) -> [f32; 3] {
    [1.0 - u, u - v, v]
}

#[test]
fn nearest_reads_the_texel_under_the_point() {
    let scene = masked_scene(FilterMode::Nearest, 1.0, 0.5);
    let masks = AlphaMasks::from_scene(&scene);
    assert!(masks.is_masked(0) && masks.is_masked(1));
    assert!(!masks.is_masked(2) && !masks.is_masked(3));
    // Texels 0 and 1 (alpha 0, ⅓) cut, 2 and 3 (⅔, 1) do not.
    for (u, cut) in [
        (0.1, true),
        (0.3, true),
        (0.49, true),
        (0.51, false),
        (0.9, false),
    ] {
        assert_eq!(masks.cuts(0, weights_at(u, 0.05)), cut, "u = {u}");
    }
    assert!(!masks.cuts(2, [1.0, 0.0, 0.0]));
}

#[test]
fn linear_interpolates_before_the_cutoff() {
    // Alpha at texel centres 0.125, 0.375, 0.625, 0.875: 0, ⅓, ⅔, 1; ½ lies midway between the
    // second and third centres (u = 0.5).
    let scene = masked_scene(FilterMode::Linear, 1.0, 0.5);
    let masks = AlphaMasks::from_scene(&scene);
    assert!(masks.cuts(0, weights_at(0.49, 0.01)));
    assert!(!masks.cuts(0, weights_at(0.51, 0.01)));
    // The factor scales the coverage: at 0.6 only ⅔ × 0.6 = 0.4 < ½ is left.
    let scene = masked_scene(FilterMode::Linear, 0.6, 0.5);
    let masks = AlphaMasks::from_scene(&scene);
    assert!(masks.cuts(0, weights_at(0.7, 0.01)));
    assert!(!masks.cuts(0, weights_at(0.99, 0.01)));
}

#[test]
fn the_light_field_reads_the_masks_the_bake_reads() {
    for filter in [FilterMode::Nearest, FilterMode::Linear] {
        let scene = masked_scene(filter, 0.9, 0.4);
        let shading = Shading::from_scene(&scene);
        assert!(shading.has_masks());
        assert_eq!(shading.alpha.len(), 4);
        assert_eq!(shading.alpha[3], f16_encode(1.0));
        let tri_materials = scene.triangles.iter().map(|t| t.material);
        assert_eq!(
            AlphaMasks::from_shading(&shading, tri_materials),
            AlphaMasks::from_scene(&scene)
        );
    }
}

#[test]
fn words_lay_out_the_records() {
    let scene = masked_scene(FilterMode::Nearest, 1.0, 0.5);
    let masks = AlphaMasks::from_scene(&scene);
    let w = masks.words();
    let t = scene.triangles.len() as u32;
    assert_eq!(w[0], t);
    assert_eq!(w[1], 4 + t);
    assert_eq!(w[2], w[1] + 2 * RECORD_WORDS);
    assert_eq!(w[3], w[2] + MATERIAL_WORDS);
    assert_eq!(w.len() as u32, w[3] + 4);
    assert_eq!(w[4], w[1]);
    assert_eq!(w[6], NO_MASK);
    let m = w[2] as usize;
    assert_eq!(f32::from_bits(w[m]), 0.5);
    assert_eq!(w[m + 4], 1 | (1 << 4) | (1 << 8));
    assert_eq!(w[m + 5], w[3]);
    // No masks: the header alone.
    let opaque = AlphaMasks::from_scene(&SceneBuilder::new().build("empty"));
    assert!(opaque.is_empty());
    assert_eq!(opaque.words(), vec![0, 4, 4, 4]);
}
