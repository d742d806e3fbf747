//! Pass 3: face id of the visible surface. The scene's triangles drawn with the camera,
//! depth-tested (reverse-Z, depth written), no culling; background = [`super::NO_FACE`].
//! With a stencil ([`DEPTH_STENCIL_FORMAT`]) the triangles are drawn in groups by their face's
//! stencil value ([`super::upload::stencil_value`]: `TEXTURED_STENCIL` for textured faces,
//! | `MIRROR_STENCIL` for mirror and mixed ones) with that reference, replaced wherever depth
//! passes, so the stencil ends up marking the pixels whose visible face is textured or a
//! mirror (0 elsewhere).
//! Light fields with alpha masks draw with the shader's masked entry points, which discard the
//! fragments a mask cuts (the depth buffer then holds what lies behind the holes).
//! Shader: `shaders/render_face_id.wgsl`.

use super::targets::{DEPTH_STENCIL_FORMAT, FACE_ID_FORMAT, Targets};
use super::upload::GpuLightField;
use super::{NO_FACE, geometry_pass_layout, geometry_pipeline};
use crate::shaders;

pub struct FaceIdPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Whether the depth buffer has a stencil to mark textured and mirror faces in.
    stencil: bool,
}

impl FaceIdPass {
    /// `depth_format`: `DEPTH_FORMAT`, or [`DEPTH_STENCIL_FORMAT`] to mark textured and mirror
    /// faces.
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        let (pass_layout, bind_group) =
            geometry_pass_layout(device, "FaceId", &[&lf.triangles, &lf.uvs], &lf.alpha_masks);
        let stencil = depth_format == DEPTH_STENCIL_FORMAT;
        let replace = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Always,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Replace,
        };
        let depth = wgpu::DepthStencilState {
            format: depth_format,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: if stencil {
                wgpu::StencilState {
                    front: replace,
                    back: replace,
                    read_mask: 0xff,
                    write_mask: 0xff,
                }
            } else {
                Default::default()
            },
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
            lf.has_masks,
        );
        Self {
            pipeline,
            bind_group,
            stencil,
        }
    }

    /// Clears face ids to [`NO_FACE`], depth to 0 (infinitely far) and the stencil to 0, then
    /// draws the scene (with a stencil: one group of triangles per stencil value).
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
                stencil_ops: self.stencil.then_some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0),
                    store: wgpu::StoreOp::Store,
                }),
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
        if self.stencil {
            for (s, w) in lf.stencil_starts.windows(2).enumerate() {
                if w[0] < w[1] {
                    pass.set_stencil_reference(s as u32);
                    pass.draw(w[0] * 3..w[1] * 3, 0..1);
                }
            }
        } else {
            pass.draw(0..lf.triangle_count * 3, 0..1);
        }
    }
}
