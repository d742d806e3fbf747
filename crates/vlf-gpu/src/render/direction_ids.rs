//! Pass 1: direction ids. The direction set's sphere triangles drawn from the sphere centre with
//! the camera's orientation and projection; per pixel the three sphere-vertex ids of the view
//! ray's triangle (and the triangle index). Shader: `shaders/render_direction_ids.wgsl`.

use super::targets::{DIRECTION_IDS_FORMAT, Targets};
use super::upload::GpuLightField;
use super::{sphere_pass_layout, sphere_pipeline};
use crate::shaders;

pub struct DirectionIdsPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl DirectionIdsPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let (pass_layout, bind_group) = sphere_pass_layout(device, "DirectionIds", lf);
        let pipeline = sphere_pipeline(
            device,
            "DirectionIds",
            &shaders::RENDER_DIRECTION_IDS,
            globals_layout,
            &pass_layout,
            DIRECTION_IDS_FORMAT,
        );
        Self {
            pipeline,
            bind_group,
        }
    }

    /// Clears the target (ids u32::MAX) and draws the sphere mesh.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let clear = wgpu::Color {
            r: f64::from(u32::MAX),
            g: f64::from(u32::MAX),
            b: f64::from(u32::MAX),
            a: f64::from(u32::MAX),
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("DirectionIds::pass"),
            color_attachments: &[Some(super::color_attachment(
                &targets.direction_ids_view,
                clear,
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
