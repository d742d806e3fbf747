//! Import of the subsurface models (`docs/SUBSURFACE.md`): `KHR_materials_ior`,
//! `KHR_materials_diffuse_transmission`, `KHR_materials_volume` and the draft
//! `KHR_materials_volume_scatter` mapped to `scene::Translucency`, and every malformed value an
//! error naming the material and the file.

use std::path::PathBuf;

use crate::common::base64;
use glam::Vec3;
use vlf_core::scene::{self, SceneError, Translucency, dipole};

/// A one-triangle glTF whose material has `extensions` (a JSON object's body), written to a
/// fresh file named after `test`.
fn fixture(test: &str, extensions: &str) -> PathBuf {
    let p: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let doc = format!(
        r#"{{"asset":{{"version":"2.0"}},
"buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
"materials":[{{"name":"wax","pbrMetallicRoughness":{{"metallicFactor":0}},"extensions":{{{extensions}}}}}],
"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        base64(&bytes)
    );
    let dir = std::env::temp_dir().join(format!("vlf-subsurface-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{test}.gltf"));
    std::fs::write(&path, doc).unwrap();
    path
}

fn model(test: &str, extensions: &str) -> Translucency {
    let path = fixture(test, extensions);
    let s = scene::load(&path).unwrap_or_else(|e| panic!("{test}: {e}"));
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.contains("is ignored") && w.contains("KHR_materials_diffuse")),
        "{test}: {:?}",
        s.warnings
    );
    s.translucency_of(0)
}

#[test]
fn no_extension_is_opaque() {
    assert_eq!(model("none", ""), Translucency::None);
}

#[test]
fn thin_diffuse_transmission() {
    let t = model(
        "thin",
        r#""KHR_materials_diffuse_transmission":{"diffuseTransmissionFactor":0.4,"diffuseTransmissionColorFactor":[1,0.5,0.25]}"#,
    );
    assert_eq!(
        t,
        Translucency::ThinDiffuseTransmission {
            factor: 0.4,
            color: Vec3::new(1.0, 0.5, 0.25)
        }
    );
    // Defaults: colour white; a factor of 0 transmits nothing.
    let t = model(
        "thin-default",
        r#""KHR_materials_diffuse_transmission":{"diffuseTransmissionFactor":1}"#,
    );
    assert_eq!(
        t,
        Translucency::ThinDiffuseTransmission {
            factor: 1.0,
            color: Vec3::ONE
        }
    );
    assert_eq!(
        model("thin-zero", r#""KHR_materials_diffuse_transmission":{}"#),
        Translucency::None
    );
}

/// A scattering volume maps to the dipole: σ_t from the attenuation, α′ inverted from the
/// multiscatter colour, so that the dipole's total diffuse reflectance reproduces
/// `multiscatterColor` (to the f32 rounding of the stored coefficients), and the anisotropy
/// reduces the scattering.
#[test]
fn scattering_volume_is_a_dipole() {
    let ms = [0.8f64, 0.5, 0.2];
    let (d, c) = (0.01f64, [0.5f64, 0.25, 1.0]);
    for g in [0.0f64, 0.6] {
        let t = model(
            &format!("dipole-{g}"),
            &format!(
                r#""KHR_materials_ior":{{"ior":1.4}},
"KHR_materials_volume":{{"thicknessFactor":0.05,"attenuationDistance":{d},"attenuationColor":[{},{},{}]}},
"KHR_materials_volume_scatter":{{"multiscatterColor":[{},{},{}],"scatterAnisotropy":{g}}}"#,
                c[0], c[1], c[2], ms[0], ms[1], ms[2]
            ),
        );
        let Translucency::Dipole {
            sigma_s_prime,
            sigma_a,
            eta,
        } = t
        else {
            panic!("g {g}: {t:?}");
        };
        assert_eq!(eta, 1.4);
        for k in 0..3 {
            let (sp, sa) = (f64::from(sigma_s_prime[k]), f64::from(sigma_a[k]));
            let r = dipole::Dipole::new(sp, sa, 1.4).total_reflectance();
            assert!(
                (r - ms[k]).abs() < 1e-5,
                "g {g} channel {k}: R_d {r} vs {}",
                ms[k]
            );
            // σ_t = σ_a + σ_s with σ_s = σ_s′/(1 − g): −ln c / d, or 1/d where c = 1.
            let sigma_t = if c[k] < 1.0 { -c[k].ln() / d } else { 1.0 / d };
            let total = sa + sp / (1.0 - g);
            assert!(
                (total - sigma_t).abs() < 1e-4 * sigma_t,
                "g {g} channel {k}: σ_t {total} vs {sigma_t}"
            );
        }
    }
}

/// A volume without scattering is not translucent here (glass, absorbing liquids); with diffuse
/// transmission it is the thin model.
#[test]
fn volume_without_scatter() {
    assert_eq!(
        model(
            "clear-volume",
            r#""KHR_materials_volume":{"thicknessFactor":1,"attenuationDistance":1}"#
        ),
        Translucency::None
    );
    assert!(matches!(
        model(
            "volume-dt",
            r#""KHR_materials_volume":{"thicknessFactor":1},"KHR_materials_diffuse_transmission":{"diffuseTransmissionFactor":0.5}"#
        ),
        Translucency::ThinDiffuseTransmission { .. }
    ));
}

#[test]
fn malformed_values_are_errors_naming_material_and_file() {
    let cases = [
        // An ior below 1 is a warning and the default 1.5, as for panes
        // (scene_import.rs: transmission_and_ior_make_a_thin_pane).
        ("ior-text", r#""KHR_materials_ior":{"ior":"glass"}"#, "ior"),
        (
            "dt-high",
            r#""KHR_materials_diffuse_transmission":{"diffuseTransmissionFactor":1.5}"#,
            "diffuseTransmissionFactor",
        ),
        (
            "dt-color",
            r#""KHR_materials_diffuse_transmission":{"diffuseTransmissionColorFactor":[1,2]}"#,
            "diffuseTransmissionColorFactor",
        ),
        (
            "distance-zero",
            r#""KHR_materials_volume":{"thicknessFactor":1,"attenuationDistance":0}"#,
            "attenuationDistance",
        ),
        (
            "distance-negative",
            r#""KHR_materials_volume":{"thicknessFactor":1,"attenuationDistance":-1}"#,
            "attenuationDistance",
        ),
        (
            "anisotropy",
            r#""KHR_materials_volume_scatter":{"scatterAnisotropy":1}"#,
            "scatterAnisotropy",
        ),
        (
            "multiscatter",
            r#""KHR_materials_volume_scatter":{"multiscatterColor":[0.5,-1,0.5]}"#,
            "multiscatterColor",
        ),
        (
            "not-object",
            r#""KHR_materials_volume":3"#,
            "not a JSON object",
        ),
    ];
    for (test, ext, what) in cases {
        let path = fixture(test, ext);
        let err = scene::load(&path).expect_err(test);
        let msg = err.to_string();
        assert!(matches!(err, SceneError::Invalid { .. }), "{test}: {msg}");
        assert!(msg.contains("material 0 (\"wax\")"), "{test}: {msg}");
        assert!(msg.contains(what), "{test}: {msg}");
        assert!(msg.contains(&path.display().to_string()), "{test}: {msg}");
    }
}
