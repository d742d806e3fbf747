use glam::Vec3;

use super::*;
use crate::lightfield::{BakeFace, BakeParams, Iterations};
use crate::scene::SceneBuilder;

fn face(width: u32, height: u32) -> BakeFace {
    BakeFace {
        width,
        height,
        texel_size: 0.1,
        ..Default::default()
    }
}

/// Page rectangles (gutter included) of every chart side: inside their page, disjoint.
#[test]
fn packing_keeps_charts_and_gutters_apart() {
    let faces: Vec<BakeFace> = (0..40)
        .map(|i| face(1 + (i * 7) % 23, 1 + (i * 5) % 17))
        .collect();
    for max_size in [64, 4096] {
        let layout = pack::pack(&faces, max_size, GUTTER).unwrap();
        if max_size == 64 {
            assert!(layout.pages.len() > 1, "{:?}", layout.pages);
        } else {
            assert_eq!(layout.pages.len(), 1);
        }
        let g = GUTTER;
        let rects: Vec<(u32, u32, u32, u32, u32)> = faces
            .iter()
            .enumerate()
            .flat_map(|(fi, f)| {
                let l = &layout;
                (0..2).map(move |s| {
                    let p = l.placements[2 * fi + s];
                    (p.page, p.x - g, p.y - g, f.width + 2 * g, f.height + 2 * g)
                })
            })
            .collect();
        for (i, a) in rects.iter().enumerate() {
            let (pw, ph) = layout.pages[a.0 as usize];
            assert!(pw <= max_size && ph <= max_size);
            assert!(
                a.1 + a.3 <= pw && a.2 + a.4 <= ph,
                "rect {i} {a:?} outside {pw}×{ph}"
            );
            for b in &rects[i + 1..] {
                let apart = a.0 != b.0
                    || a.1 + a.3 <= b.1
                    || b.1 + b.3 <= a.1
                    || a.2 + a.4 <= b.2
                    || b.2 + b.4 <= a.2;
                assert!(apart, "{a:?} overlaps {b:?}");
            }
        }
    }
    assert_eq!(
        pack::pack(&[face(70, 3)], 64, GUTTER).unwrap_err().face,
        0,
        "a chart wider than a page is refused"
    );
}

/// The gutter repeats the chart's edge texels (what clamp-to-edge bilinear filtering reads).
#[test]
fn gutter_repeats_the_edge_texels() {
    let faces = [face(3, 2), face(1, 1)];
    let layout = pack::pack(&faces, 64, GUTTER).unwrap();
    let value =
        |fi: usize, side: u32, i: u32, j: u32| [fi as f32, side as f32, (10 * j + i) as f32];
    let pages = pack::fill_pages(&faces, &layout, value);
    let g = GUTTER as i64;
    for (fi, f) in faces.iter().enumerate() {
        for side in 0..2u32 {
            let p = layout.placements[2 * fi + side as usize];
            let pw = layout.pages[p.page as usize].0 as i64;
            for j in -g..f.height as i64 + g {
                for i in -g..f.width as i64 + g {
                    let got =
                        pages[p.page as usize][((p.y as i64 + j) * pw + p.x as i64 + i) as usize];
                    let ci = i.clamp(0, f.width as i64 - 1) as u32;
                    let cj = j.clamp(0, f.height as i64 - 1) as u32;
                    assert_eq!(
                        got,
                        value(fi, side, ci, cj),
                        "face {fi} side {side} ({i}, {j})"
                    );
                }
            }
        }
    }
}

#[test]
fn rgbm_round_trips_within_its_step() {
    let values = [
        [0.0, 0.0, 0.0],
        [1.0, 0.5, 0.25],
        [13.0, 2.0, 0.01],
        [0.002, 0.001, 0.0],
    ];
    let range = rgbm_range(&values);
    assert_eq!(range, 16.0);
    let bytes = encode::rgbm(&values, range);
    for (k, v) in values.iter().enumerate() {
        let t = [0, 1, 2, 3].map(|c| bytes[4 * k + c]);
        let d = rgbm_decode(t, range);
        let max = v[0].max(v[1]).max(v[2]);
        for c in 0..3 {
            // Half a step of the texel's multiplier, plus the multiplier's own rounding.
            let step = f32::from(t[3]) / 255.0 * range / 255.0;
            assert!(
                (d[c] - v[c]).abs() <= 0.5 * step + 1e-6,
                "{v:?} → {d:?} ({max})"
            );
        }
    }
}

/// A small room baked on the CPU, exported, read back with the `gltf` crate: every primitive
/// has TEXCOORD_1, the lightmap page decodes, and at the centre of every covered texel the
/// lightmap read through TEXCOORD_1 reproduces the stored radiance (`Lₑ + ρE/π`).
#[test]
fn exported_lightmap_reproduces_the_atlas() {
    let mut b = SceneBuilder::new();
    let wall = b.diffuse("wall", Vec3::new(0.7, 0.5, 0.3), Vec3::ZERO);
    let lamp = b.diffuse("lamp", Vec3::splat(0.5), Vec3::new(4.0, 3.0, 2.0));
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, wall);
    b.quad(
        [
            Vec3::new(-0.3, 0.99, -0.3),
            Vec3::new(-0.3, 0.99, 0.3),
            Vec3::new(0.3, 0.99, 0.3),
            Vec3::new(0.3, 0.99, -0.3),
        ],
        lamp,
    );
    let scene = b.build("test/room.gltf");
    let params = BakeParams {
        directions: 21,
        resolution: 16,
        iterations: Iterations::Fixed(2),
        final_gather: None,
        ..BakeParams::paper()
    };
    let lf = crate::pipeline::bake_cpu(&scene, &params).unwrap();
    let out = export_glb(&lf, &scene, &ExportOptions::default()).unwrap();
    assert_eq!(out.summary.pages.len(), 1);

    let gltf = gltf::Gltf::from_slice(&out.glb).unwrap();
    let bin = gltf.blob.as_deref().unwrap();
    let doc = &gltf.document;
    assert!(doc.extensions_used().any(|e| e == "MOZ_lightmap"));
    let prims: Vec<_> = doc.meshes().flat_map(|m| m.primitives()).collect();
    assert!(!prims.is_empty());
    for p in &prims {
        assert!(p.get(&gltf::Semantic::TexCoords(1)).is_some());
    }
    assert_eq!(out.summary.triangles, 2 * scene.triangles.len());

    // The page, decoded.
    // The JSON chunk as written (the `gltf` crate drops unknown extensions).
    let json_len = u32::from_le_bytes(out.glb[12..16].try_into().unwrap()) as usize;
    let root: serde_json::Value = serde_json::from_slice(&out.glb[20..20 + json_len]).unwrap();
    let ext = &root["textures"][0]["extensions"][EXR_EXTENSION];
    assert_eq!(ext["mimeType"], EXR_MIME);
    let view = doc
        .views()
        .nth(ext["bufferView"].as_u64().unwrap() as usize)
        .unwrap();
    let bytes = &bin[view.offset()..view.offset() + view.length()];
    let tmp = std::env::temp_dir().join(format!("vlf-export-test-{}.exr", std::process::id()));
    std::fs::write(&tmp, bytes).unwrap();
    let decoded = crate::image::read_exr(&tmp).unwrap();
    std::fs::remove_file(&tmp).unwrap();
    let (pw, texels) = (decoded.width as usize, decoded.pixels);
    let (page_w, page_h) = out.summary.pages[0];
    assert_eq!(pw as u32, page_w);

    // Every front triangle's centroid: its TEXCOORD_1 (the export's mapping, recomputed from
    // the written data) lands in the texel the viewer reads there.
    prepare(&lf, &scene).unwrap();
    let mut checked = 0;
    for p in &prims {
        let reader = p.reader(|_| Some(bin));
        let pos: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        let uv1: Vec<[f32; 2]> = reader.read_tex_coords(1).unwrap().into_f32().collect();
        let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        for t in idx.chunks(3) {
            let c = (Vec3::from(pos[t[0] as usize])
                + Vec3::from(pos[t[1] as usize])
                + Vec3::from(pos[t[2] as usize]))
                / 3.0;
            let uv = [0, 1].map(|a| {
                (uv1[t[0] as usize][a] + uv1[t[1] as usize][a] + uv1[t[2] as usize][a]) / 3.0
            });
            let (x, y) = (
                (uv[0] * page_w as f32) as usize,
                (uv[1] * page_h as f32) as usize,
            );
            let e = texels[y * pw + x];
            // Which face and side: the scene face whose plane holds c, seen from the normal.
            let n = {
                let a = Vec3::from(pos[t[0] as usize]);
                (Vec3::from(pos[t[1] as usize]) - a)
                    .cross(Vec3::from(pos[t[2] as usize]) - a)
                    .normalize()
            };
            let cv = lf.to_vlf.apply(c);
            let (fi, side) =
                lf.faces
                    .iter()
                    .enumerate()
                    .find_map(|(fi, f)| {
                        let d = f.normal().dot(cv) - f.offset;
                        let s = f.normal().dot(n);
                        (d.abs() < 1e-4
                            && s.abs() > 0.99
                            && scene.faces[fi].triangles.clone().any(|ti| {
                                scene.triangles[ti as usize].centroid().distance(c) < 1e-4
                            }))
                        .then_some((fi, if s > 0.0 { 0 } else { 1 }))
                    })
                    .expect("the triangle's face");
            let k = lf.faces[fi].texel_at(cv, side) as usize;
            let stored = lf.irradiance.get(k);
            for ch in 0..3 {
                let (want, got) = (stored[ch], e[ch]);
                assert!(
                    (got - want).abs() <= 2e-3 * want.abs() + 1e-5,
                    "face {fi} side {side} texel {k} channel {ch}: lightmap {got} vs stored irradiance {want}"
                );
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 2 * scene.triangles.len());

    // The file says what it is and what it leaves out.
    let vlf = &root["extras"]["vlf"];
    assert_eq!(vlf["notExported"], NOT_EXPORTED);
    assert_eq!(vlf["lightmap"]["quantity"], "irradiance");
    assert_eq!(
        root["materials"][0]["extensions"]["MOZ_lightmap"]["texCoord"],
        1
    );
}

#[test]
fn ktx2_is_refused_and_a_foreign_scene_too() {
    let mut b = SceneBuilder::new();
    let lamp = b.diffuse("lamp", Vec3::splat(0.5), Vec3::ONE);
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, lamp);
    let scene = b.build("test/box.gltf");
    let params = BakeParams {
        directions: 21,
        resolution: 8,
        iterations: Iterations::Fixed(1),
        final_gather: None,
        ..BakeParams::paper()
    };
    let lf = crate::pipeline::bake_cpu(&scene, &params).unwrap();
    let ktx2 = ExportOptions {
        encoding: LightmapEncoding::Ktx2,
        ..Default::default()
    };
    let err = export_glb(&lf, &scene, &ktx2).unwrap_err();
    assert!(err.to_string().contains("not implemented"), "{err}");

    let mut other = SceneBuilder::new();
    let m = other.diffuse("m", Vec3::splat(0.5), Vec3::ONE);
    other.quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y], m);
    let other = other.build("test/other.gltf");
    let err = export_glb(&lf, &other, &ExportOptions::default()).unwrap_err();
    assert!(matches!(err, ExportError::SceneMismatch(_)), "{err}");
}

/// An engine's diffuse albedo, baseColor × (1 − metallicFactor), is the one vlf-view shades the
/// lightmap with: 1 − the bake's diffuse weight, also for a rough metal the bake folded into
/// its diffuse part (exported as plain diffuse before).
#[test]
fn metallic_factor_is_one_minus_the_baked_diffuse_weight() {
    let mut b = SceneBuilder::new();
    let lamp = b.diffuse("lamp", Vec3::splat(0.5), Vec3::ONE);
    let rough = b.material(crate::scene::Material {
        name: "rough metal".into(),
        base_color: Vec3::splat(0.9),
        base_color_texture: None,
        emission: Vec3::ZERO,
        emissive_texture: None,
        double_sided: true,
        kind: crate::scene::MaterialKind::Mirror,
        metallic: 1.0,
        roughness: 0.9,
        transparency: Default::default(),
    });
    b.aabox(Vec3::splat(-1.0), Vec3::splat(1.0), true, lamp);
    b.quad(
        [
            Vec3::new(-0.5, -0.9, -0.5),
            Vec3::new(-0.5, -0.9, 0.5),
            Vec3::new(0.5, -0.9, 0.5),
            Vec3::new(0.5, -0.9, -0.5),
        ],
        rough,
    );
    let scene = b.build("test/metal.gltf");
    let params = BakeParams {
        directions: 21,
        resolution: 8,
        iterations: Iterations::Fixed(1),
        final_gather: None,
        ..BakeParams::paper()
    };
    let lf = crate::pipeline::bake_cpu(&scene, &params).unwrap();
    let w = lf.shading.materials[rough as usize].diffuse_weight;
    assert!(w > 0.3 && w < 1.0, "folded weight {w}");
    let out = export_glb(&lf, &scene, &ExportOptions::default()).unwrap();
    let json_len = u32::from_le_bytes(out.glb[12..16].try_into().unwrap()) as usize;
    let root: serde_json::Value = serde_json::from_slice(&out.glb[20..20 + json_len]).unwrap();
    let mats = root["materials"].as_array().unwrap();
    let metal: Vec<f64> = mats
        .iter()
        .filter(|m| m["name"].as_str().unwrap().starts_with("rough metal"))
        .map(|m| {
            m["pbrMetallicRoughness"]["metallicFactor"]
                .as_f64()
                .unwrap()
        })
        .collect();
    assert!(!metal.is_empty());
    for m in metal {
        assert!(
            (m - f64::from(1.0 - w)).abs() < 1e-6,
            "metallic {m}, want {}",
            1.0 - w
        );
    }
}
