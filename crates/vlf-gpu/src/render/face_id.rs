//! Pass 3: face id of the visible surface. The scene's triangles drawn with the camera,
//! depth-tested (reverse-Z, depth written), no culling; background = [`super::NO_FACE`].
//! Shader: `shaders/render_face_id.wgsl`.

use super::targets::{DEPTH_FORMAT, FACE_ID_FORMAT, Targets};
use super::upload::GpuLightField;
use super::{NO_FACE, geometry_pass_layout, geometry_pipeline};
use crate::shaders;

pub struct FaceIdPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl FaceIdPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let (pass_layout, bind_group) = geometry_pass_layout(device, "FaceId", &[&lf.triangles]);
        let depth = wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let pipeline = geometry_pipeline(
            device,
            "FaceId",
            &shaders::RENDER_FACE_ID,
            globals_layout,
            &pass_layout,
            &[FACE_ID_FORMAT],
            depth,
        );
        Self {
            pipeline,
            bind_group,
        }
    }

    /// Clears face ids to [`NO_FACE`] and depth to 0 (infinitely far), then draws the scene.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let clear = wgpu::Color {
            r: f64::from(NO_FACE),
            g: 0.0,
            b: 0.0,
            a: 0.0,
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("FaceId::pass"),
            color_attachments: &[Some(super::color_attachment(&targets.face_id_view, clear))],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
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
