use super::upload::{
    ATLAS_WIDTH, FACE_RECORD_TEXELS, FACES_PER_ROW, FLAG_BASE_TEXTURE, FLAG_BASE_UV1, FLAG_COLORS,
    FLAG_DIFFUSE, FLAG_EMISSIVE, FLAG_EMISSIVE_TEXTURE, FLAG_EMISSIVE_UV1, FLAG_PANE, FLAG_SMOOTH,
};
use crate::shaders::{self, constant};
use vlf_core::scene::WrapMode;
use wgpu::naga::Literal;

/// The texture layouts and face flags of `upload.rs` are the ones pass 5 reads (the mirror
/// tiles' through `common/mirror_tiles.wgsl`, which the GPU final gather shares), the wrap-mode
/// ids the ones `common/texture.wgsl` knows, and the no-face id is the one pass 3 writes.
#[test]
fn shader_layout_constants_match_rust() {
    let module = shaders::RENDER_FINAL_RADIANCE.validate().unwrap();
    for (name, value) in [
        ("ATLAS_WIDTH", ATLAS_WIDTH),
        ("FACE_RECORD_TEXELS", FACE_RECORD_TEXELS),
        ("FACES_PER_ROW", FACES_PER_ROW),
        ("NO_FACE", super::NO_FACE),
        ("FLAG_DIFFUSE", FLAG_DIFFUSE),
        ("FLAG_BASE_TEXTURE", FLAG_BASE_TEXTURE),
        ("FLAG_EMISSIVE", FLAG_EMISSIVE),
        ("FLAG_EMISSIVE_TEXTURE", FLAG_EMISSIVE_TEXTURE),
        ("FLAG_PANE", FLAG_PANE),
        ("FLAG_SMOOTH", FLAG_SMOOTH),
        ("FLAG_COLORS", FLAG_COLORS),
        ("FLAG_BASE_UV1", FLAG_BASE_UV1),
        ("FLAG_EMISSIVE_UV1", FLAG_EMISSIVE_UV1),
        ("WRAP_REPEAT", WrapMode::Repeat.id()),
        ("WRAP_CLAMP_TO_EDGE", WrapMode::ClampToEdge.id()),
        ("WRAP_MIRRORED_REPEAT", WrapMode::MirroredRepeat.id()),
        ("FACE_MIRROR", vlf_core::lightfield::FACE_MIRROR),
        ("MIRROR_DEPTH", super::mirror_trace::MAX_DEPTH),
        ("LOBE_SAMPLES", super::mirror_trace::LOBE_SAMPLES),
        ("NO_TILE_SLOT", u32::MAX),
    ] {
        assert_eq!(
            constant(&module, name),
            Some(Literal::U32(value)),
            "render_final_radiance.wgsl (resolved): const {name}"
        );
    }
}
