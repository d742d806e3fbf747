// Records of the prepared bake scene (vlf_core::lightfield geometry, vlf_core::bake::prep), as the
// bake passes and the render passes 3 and 4 bind them.

// A triangle in VLF coordinates (mirrors vlf_core::lightfield::BakeTriangle).
struct BakeTriangle {
    p0: vec3<f32>,
    face: u32,
    p1: vec3<f32>,
    _pad0: u32,
    p2: vec3<f32>,
    _pad1: u32,
}

// Corner 0, 1 or 2 of a triangle (vertex pulling; passes 3 and 4 transform the same corners, so
// pass 4 reproduces pass 3's depths exactly).
fn corner_position(tri: BakeTriangle, corner: u32) -> vec3<f32> {
    if corner == 1u {
        return tri.p1;
    }
    if corner == 2u {
        return tri.p2;
    }
    return tri.p0;
}

// A planar face with its atlas chart (mirrors vlf_core::lightfield::BakeFace).
struct BakeFace {
    normal: vec3<f32>,
    offset: f32,
    origin: vec3<f32>,
    texel_size: f32,
    u: vec3<f32>,
    width: u32,
    v: vec3<f32>,
    height: u32,
    texel_base: u32,
    kind: u32,
    specular: f32,
    material: u32,
}
