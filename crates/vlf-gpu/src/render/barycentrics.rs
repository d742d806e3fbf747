//! Pass 2: barycentric weights of the view direction in its sphere triangle, interpolated
//! perspective-correctly over the flat triangle (= `DirectionSet::lookup`'s gnomonic weights).
//! Component n belongs to pass 1's id n. Shader: `shaders/render_barycentrics.wgsl`.

use super::pipelines::MeshPass;
use super::targets::{BARYCENTRICS_FORMAT, Targets};
use super::upload::GpuLightField;
use crate::shaders;

pub struct BarycentricsPass(MeshPass);

impl BarycentricsPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let shader = &shaders::RENDER_BARYCENTRICS;
        Self(MeshPass::sphere(
            device,
            "Barycentrics",
            shader,
            globals_layout,
            lf,
            BARYCENTRICS_FORMAT,
        ))
    }

    /// Clears the target (zero weights) and draws the sphere mesh.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let zero = wgpu::Color::TRANSPARENT;
        let color = [Some(super::color_attachment(
            &targets.barycentrics_view,
            zero,
        ))];
        let vertices = lf.sphere_triangle_count * 3;
        (self.0).encode(encoder, globals, targets, &color, vertices, timestamps);
    }
}
