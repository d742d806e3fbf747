//! Pass 1: direction ids. The direction set's sphere triangles drawn from the sphere centre with
//! the camera's orientation and projection; per pixel the three sphere-vertex ids of the view
//! ray's triangle (and the triangle index). Shader: `shaders/render_direction_ids.wgsl`.

use super::pipelines::{ColorTarget, MeshPass};
use super::targets::DIRECTION_IDS_FORMAT;
use super::upload::GpuLightField;
use crate::shaders;

/// The pass: it clears its target (ids u32::MAX) and draws the sphere mesh.
pub(super) fn pass(
    device: &wgpu::Device,
    globals_layout: &wgpu::BindGroupLayout,
    lf: &GpuLightField,
) -> MeshPass {
    let none = f64::from(u32::MAX);
    let target = ColorTarget {
        view: |t| &t.direction_ids_view,
        clear: Some(wgpu::Color {
            r: none,
            g: none,
            b: none,
            a: none,
        }),
    };
    let shader = ("DirectionIds", &shaders::RENDER_DIRECTION_IDS);
    MeshPass::sphere(
        device,
        shader,
        globals_layout,
        lf,
        DIRECTION_IDS_FORMAT,
        target,
    )
}
