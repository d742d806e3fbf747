//! Pass 2: barycentric weights of the view direction in its sphere triangle, interpolated
//! perspective-correctly over the flat triangle (= `DirectionSet::lookup`'s gnomonic weights).
//! Component n belongs to pass 1's id n. Shader: `shaders/render_barycentrics.wgsl`.

use super::pipelines::{ColorTarget, MeshPass};
use super::targets::BARYCENTRICS_FORMAT;
use super::upload::GpuLightField;
use crate::shaders;

/// The pass: it clears its target (zero weights) and draws the sphere mesh.
pub(super) fn pass(
    device: &wgpu::Device,
    globals_layout: &wgpu::BindGroupLayout,
    lf: &GpuLightField,
) -> MeshPass {
    let target = ColorTarget {
        view: |t| &t.barycentrics_view,
        clear: Some(wgpu::Color::TRANSPARENT),
    };
    let shader = ("Barycentrics", &shaders::RENDER_BARYCENTRICS);
    MeshPass::sphere(
        device,
        shader,
        globals_layout,
        lf,
        BARYCENTRICS_FORMAT,
        target,
    )
}
