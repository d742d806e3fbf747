// One triangle covering the viewport, drawn with three vertices and no vertex buffer (the
// display pass and pass 5).

fn fullscreen_vertex(vi: u32) -> vec4<f32> {
    let x = f32(i32(vi & 1u) * 4 - 1);
    let y = f32(i32(vi >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}
