//! Pass 4: VLF position and `TEXCOORD_0` of the visible surface, interpolated from the
//! vertices into two targets. Reuses pass 3's depth buffer (compare greater-or-equal, no
//! writes) so only the visible surface is shaded. Shader: `shaders/render_position.wgsl`.
//!
//! The uv target is what lets pass 5 apply textures at their own resolution; it is neither
//! cleared nor read where no face is seen, and pass 5 reads it for textured faces only.

use super::targets::{
    ATTRIBUTE_WORDS_FORMAT, ATTRIBUTES_FORMAT, DEPTH_STENCIL_FORMAT, POSITION_FORMAT, Targets,
    UV_FORMAT,
};
use super::upload::GpuLightField;
use super::{geometry_pass_layout, geometry_pipeline};
use crate::shaders;

pub struct PositionPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Whether the depth buffer has pass 3's stencil (kept as it is).
    stencil: bool,
}

impl PositionPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        let (pass_layout, bind_group) = geometry_pass_layout(
            device,
            "Position",
            &[&lf.triangles, &lf.uvs],
            &lf.alpha_masks,
        );
        let depth = wgpu::DepthStencilState {
            format: depth_format,
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
            &[POSITION_FORMAT, UV_FORMAT],
            depth,
            lf.has_masks,
        );
        Self {
            pipeline,
            bind_group,
            stencil: depth_format == DEPTH_STENCIL_FORMAT,
        }
    }

    /// Clears positions to 0 (w = 0: no surface) and draws the scene against pass 3's depth,
    /// writing positions and uvs.
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
            color_attachments: &[
                Some(super::color_attachment(
                    &targets.position_view,
                    wgpu::Color::TRANSPARENT,
                )),
                // Read only where a face is seen, all of which this pass writes: not cleared.
                Some(wgpu::RenderPassColorAttachment {
                    view: &targets.uv_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                }),
            ],
            depth_stencil_attachment: Some(pass_three_depth(targets, self.stencil)),
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

/// Pass 4b: the shading normal, vertex colour and `TEXCOORD_1` of the visible surface, for light
/// fields with per-corner attributes ([`super::attributes::has_attributes`]), into the attribute
/// targets (shader `shaders/render_attributes.wgsl`). A pass of its own rather than two more
/// targets of pass 4: the four would exceed the 32 bytes per pixel of colour attachments that
/// every device allows.
pub struct AttributesPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    stencil: bool,
}

impl AttributesPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        let (pass_layout, bind_group) = geometry_pass_layout(
            device,
            "Attributes",
            &[&lf.triangles, &lf.attributes, &lf.uvs],
            &lf.alpha_masks,
        );
        let depth = wgpu::DepthStencilState {
            format: depth_format,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let pipeline = geometry_pipeline(
            device,
            "Attributes",
            &shaders::RENDER_ATTRIBUTES,
            globals_layout,
            &pass_layout,
            &[ATTRIBUTES_FORMAT, ATTRIBUTE_WORDS_FORMAT],
            depth,
            lf.has_masks,
        );
        Self {
            pipeline,
            bind_group,
            stencil: depth_format == DEPTH_STENCIL_FORMAT,
        }
    }

    /// Draws the scene against pass 3's depth, writing the attribute targets (not cleared:
    /// pass 5 reads them only where a face is seen).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
    ) {
        let keep = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Attributes::pass"),
            color_attachments: &[
                keep(&targets.attributes_view[0]),
                keep(&targets.attributes_view[1]),
            ],
            depth_stencil_attachment: Some(pass_three_depth(targets, self.stencil)),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.draw(0..lf.triangle_count * 3, 0..1);
    }
}

/// Pass 3's depth (and stencil, where it marks faces), read again by passes 4 and 4b: loaded
/// and kept.
fn pass_three_depth(
    targets: &Targets,
    stencil: bool,
) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view: &targets.depth_view,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        }),
        stencil_ops: stencil.then_some(wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        }),
    }
}
