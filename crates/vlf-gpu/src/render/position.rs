//! Pass 4: VLF position and `TEXCOORD_0` of the visible surface, interpolated from the
//! vertices into two targets. Reuses pass 3's depth buffer (compare greater-or-equal, no
//! writes) so only the visible surface is shaded. Shader: `shaders/render_position.wgsl`.
//!
//! The uv target is what lets pass 5 apply textures at their own resolution; it is neither
//! cleared nor read where no face is seen, and pass 5 reads it for textured faces only.

use super::pipelines::MeshPass;
use super::targets::{
    ATTRIBUTE_WORDS_FORMAT, ATTRIBUTES_FORMAT, POSITION_FORMAT, Targets, UV_FORMAT,
};
use super::upload::GpuLightField;
use crate::shaders;

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

pub struct PositionPass(MeshPass);

impl PositionPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        Self(MeshPass::over_pass_three(
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
        let vertices = lf.triangle_count * 3;
        (self.0).encode(encoder, globals, targets, &color, vertices, timestamps);
    }
}

/// Pass 4b: the shading normal, vertex colour and `TEXCOORD_1` of the visible surface, for light
/// fields with per-corner attributes ([`super::attributes::has_attributes`]), into the attribute
/// targets (shader `shaders/render_attributes.wgsl`). A pass of its own rather than two more
/// targets of pass 4: the four would exceed the 32 bytes per pixel of colour attachments that
/// every device allows.
pub struct AttributesPass(MeshPass);

impl AttributesPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        depth_format: wgpu::TextureFormat,
    ) -> Self {
        Self(MeshPass::over_pass_three(
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
        let vertices = lf.triangle_count * 3;
        (self.0).encode(encoder, globals, targets, &color, vertices, None);
    }
}
