use super::upload::{ATLAS_WIDTH, FACE_RECORD_TEXELS, FACES_PER_ROW};
use crate::shaders::{self, constant};
use wgpu::naga::Literal;

/// The texture layouts of `upload.rs` are the ones pass 5 reads, and the no-face id is the one
/// pass 3 writes.
#[test]
fn shader_layout_constants_match_rust() {
    let module = shaders::RENDER_FINAL_RADIANCE.validate().unwrap();
    for (name, value) in [
        ("ATLAS_WIDTH", ATLAS_WIDTH),
        ("FACE_RECORD_TEXELS", FACE_RECORD_TEXELS),
        ("FACES_PER_ROW", FACES_PER_ROW),
        ("NO_FACE", super::NO_FACE),
    ] {
        assert_eq!(
            constant(&module, name),
            Some(Literal::U32(value)),
            "render_final_radiance.wgsl (resolved): const {name}"
        );
    }
}
