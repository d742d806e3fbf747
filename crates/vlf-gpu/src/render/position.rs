//! Pass 4: VLF position of the visible surface, interpolated from the vertices. Reuses pass 3's
//! depth buffer (compare greater-or-equal, no writes) so only the visible surface is shaded.
//! Shader: `shaders/render_position.wgsl`.

use super::targets::{DEPTH_FORMAT, POSITION_FORMAT, Targets};
use super::upload::GpuLightField;
use super::{geometry_pass_layout, geometry_pipeline};
use crate::shaders;

pub struct PositionPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl PositionPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let (pass_layout, bind_group) = geometry_pass_layout(device, "Position", lf);
        let depth = wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let pipeline = geometry_pipeline(
            device,
            "Position",
            &shaders::RENDER_POSITION,
            globals_layout,
            &pass_layout,
            POSITION_FORMAT,
            depth,
        );
        Self {
            pipeline,
            bind_group,
        }
    }

    /// Clears positions to 0 (w = 0: no surface) and draws the scene against pass 3's depth.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Position::pass"),
            color_attachments: &[Some(super::color_attachment(
                &targets.position_view,
                wgpu::Color::TRANSPARENT,
            ))],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.draw(0..lf.triangle_count * 3, 0..1);
    }
}
