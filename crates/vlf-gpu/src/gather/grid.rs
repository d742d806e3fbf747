//! What the gather uploads of a [`Grid`]: its texels, charts (triangles with their shading
//! normals and scene triangles) and contact bits, in the layout `shaders/gather_texels.wgsl`
//! reads.

use vlf_core::gather::Grid;

/// Per-texel contact bits packed 16 to a vec4 entry: texel t's byte is byte t % 4
/// (little-endian) of word (t / 4) % 4 of entry t / 16 (`contact_bits` in the shader).
pub(super) fn contact_entries(bits: &[u8]) -> Vec<[f32; 4]> {
    bits.chunks(16)
        .map(|c| {
            let mut b = [0u8; 16];
            b[..c.len()].copy_from_slice(c);
            std::array::from_fn(|w| {
                f32::from_bits(u32::from_le_bytes([
                    b[4 * w],
                    b[4 * w + 1],
                    b[4 * w + 2],
                    b[4 * w + 3],
                ]))
            })
        })
        .collect()
}

/// The grid buffer's contents (see `gather_texels.wgsl`) and its section offsets (texels,
/// chart starts, chart triangles, chart normals).
pub(super) fn grid_data(grid: &Grid) -> (Vec<[f32; 4]>, [u32; 4]) {
    let atlas = &grid.atlas;
    let mut data: Vec<[f32; 4]> = bytemuck::cast_slice(&atlas.faces).to_vec();
    let grid_texels = data.len() as u32;
    for ((c, a), f) in atlas
        .texel_center
        .iter()
        .zip(&atlas.texel_area)
        .zip(&grid.tex_face)
    {
        data.push([c[0], c[1], c[2], *a]);
        data.push([f32::from_bits(*f), 0.0, 0.0, 0.0]);
    }
    let chart_start = data.len() as u32;
    let mut tris: Vec<[f32; 4]> = Vec::new();
    let mut normals: Vec<[f32; 4]> = Vec::new();
    for fi in 0..atlas.faces.len() {
        data.push([f32::from_bits((tris.len() / 2) as u32), 0.0, 0.0, 0.0]);
        let first = grid.charts.first_triangle(fi);
        for (k, (t, n)) in grid
            .charts
            .triangles(fi)
            .iter()
            .zip(grid.charts.normals(fi))
            .enumerate()
        {
            let at = match n {
                Some(n) => {
                    let at = normals.len() as u32;
                    normals.extend(n.map(|n| n.extend(0.0).to_array()));
                    at
                }
                None => u32::MAX,
            };
            tris.push([t[0].x, t[0].y, t[1].x, t[1].y]);
            // Its shading normals' offset (point_normal) and the scene triangle, whose alpha
            // mask `chart_locate` reads.
            tris.push([
                t[2].x,
                t[2].y,
                f32::from_bits(at),
                f32::from_bits(first + k as u32),
            ]);
        }
    }
    data.push([f32::from_bits((tris.len() / 2) as u32), 0.0, 0.0, 0.0]);
    let chart_tris = data.len() as u32;
    data.extend(tris);
    let chart_normals = data.len() as u32;
    data.extend(normals);
    (data, [grid_texels, chart_start, chart_tris, chart_normals])
}
