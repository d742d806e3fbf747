//! Pass 2: barycentric weights of the view direction in its sphere triangle, interpolated
//! perspective-correctly over the flat triangle (= `DirectionSet::lookup`'s gnomonic weights).
//! Component n belongs to pass 1's id n. Shader: `shaders/render_barycentrics.wgsl`.

use super::targets::{BARYCENTRICS_FORMAT, Targets};
use super::upload::GpuLightField;
use super::{sphere_pass_layout, sphere_pipeline};
use crate::shaders;

pub struct BarycentricsPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl BarycentricsPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let (pass_layout, bind_group) = sphere_pass_layout(device, "Barycentrics", lf);
        let pipeline = sphere_pipeline(
            device,
            "Barycentrics",
            &shaders::RENDER_BARYCENTRICS,
            globals_layout,
            &pass_layout,
            BARYCENTRICS_FORMAT,
        );
        Self {
            pipeline,
            bind_group,
        }
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
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Barycentrics::pass"),
            color_attachments: &[Some(super::color_attachment(
                &targets.barycentrics_view,
                wgpu::Color::TRANSPARENT,
            ))],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.draw(0..lf.sphere_triangle_count * 3, 0..1);
    }
}
