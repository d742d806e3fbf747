//! Pass 4: VLF position and `TEXCOORD_0` of the visible surface, interpolated from the
//! vertices into two targets. Reuses pass 3's depth buffer (compare greater-or-equal, no
//! writes) so only the visible surface is shaded. Shader: `shaders/render_position.wgsl`.
//!
//! The uv target is what lets pass 5 apply textures at their own resolution; it is neither
//! cleared nor read where no face is seen, and pass 5 reads it for textured faces only.

use super::pipelines::pass_three_depth;
use super::targets::{
    ATTRIBUTE_WORDS_FORMAT, ATTRIBUTES_FORMAT, DEPTH_STENCIL_FORMAT, POSITION_FORMAT, Targets,
    UV_FORMAT,
};
use super::upload::GpuLightField;
use super::{geometry_pass_layout, geometry_pipeline};
use crate::shaders;

/// A draw of the scene's triangles against pass 3's depth ([`super::pipelines::pass_three_depth`]:
/// only the visible surface is shaded) and its stencil where it has one (kept as it is): the
/// pipeline and group-1 bind group passes 4 and 4b share.
struct OverPassThree {
    /// Labels `"{pass}::…"`.
    pass: &'static str,
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Whether the depth buffer has pass 3's stencil.
    stencil: bool,
}

impl OverPassThree {
    /// The pipeline of `shader` writing `formats`, its group 1 the light field's `buffers`
    /// (vertex stage, in binding order) and its alpha masks.
    #[allow(clippy::too_many_arguments)]
    fn new(
        device: &wgpu::Device,
        pass: &'static str,
        shader: &shaders::Shader,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        buffers: &[&wgpu::Buffer],
        formats: &[wgpu::TextureFormat],
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        let (pass_layout, bind_group) =
            geometry_pass_layout(device, pass, buffers, &lf.alpha_masks);
        let pipeline = geometry_pipeline(
            device,
            pass,
            shader,
            globals_layout,
            &pass_layout,
            formats,
            pass_three_depth(depth_format, Default::default()),
            lf.has_masks,
        );
        Self {
            pass,
            pipeline,
            bind_group,
            stencil: depth_format == DEPTH_STENCIL_FORMAT,
        }
    }

    /// Draws the scene into `color`, loading and keeping pass 3's depth and stencil.
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &Targets,
        lf: &GpuLightField,
        color: &[Option<wgpu::RenderPassColorAttachment<'_>>],
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        fn keep<V>() -> wgpu::Operations<V> {
            wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            }
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(&format!("{}::pass", self.pass)),
            color_attachments: color,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(keep()),
                stencil_ops: self.stencil.then(keep),
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

/// A colour target loaded and kept: read only where a face is seen, all of which the pass
/// writes, so not cleared.
fn kept(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        },
    })
}

pub struct PositionPass(OverPassThree);

impl PositionPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        Self(OverPassThree::new(
            device,
            "Position",
            &shaders::RENDER_POSITION,
            globals_layout,
            lf,
            &[&lf.triangles, &lf.uvs],
            &[POSITION_FORMAT, UV_FORMAT],
            depth_format,
        ))
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
        let color = [
            Some(super::color_attachment(
                &targets.position_view,
                wgpu::Color::TRANSPARENT,
            )),
            kept(&targets.uv_view),
        ];
        self.0
            .encode(encoder, globals, targets, lf, &color, timestamps);
    }
}

/// Pass 4b: the shading normal, vertex colour and `TEXCOORD_1` of the visible surface, for light
/// fields with per-corner attributes ([`super::attributes::has_attributes`]), into the attribute
/// targets (shader `shaders/render_attributes.wgsl`). A pass of its own rather than two more
/// targets of pass 4: the four would exceed the 32 bytes per pixel of colour attachments that
/// every device allows.
pub struct AttributesPass(OverPassThree);

impl AttributesPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        Self(OverPassThree::new(
            device,
            "Attributes",
            &shaders::RENDER_ATTRIBUTES,
            globals_layout,
            lf,
            &[&lf.triangles, &lf.attributes, &lf.uvs],
            &[ATTRIBUTES_FORMAT, ATTRIBUTE_WORDS_FORMAT],
            depth_format,
        ))
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
        let color = [
            kept(&targets.attributes_view[0]),
            kept(&targets.attributes_view[1]),
        ];
        self.0.encode(encoder, globals, targets, lf, &color, None);
    }
}
