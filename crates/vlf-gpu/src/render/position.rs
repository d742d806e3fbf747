//! Pass 4: VLF position and `TEXCOORD_0` of the visible surface, interpolated from the
//! vertices into two targets. Reuses pass 3's depth buffer (compare greater-or-equal, no
//! writes) so only the visible surface is shaded. Shader: `shaders/render_position.wgsl`.
//!
//! The uv target is what lets pass 5 apply textures at their own resolution; it is neither
//! cleared nor read where no face is seen, and pass 5 reads it for textured faces only.

use super::pipelines::{ColorTarget, MeshPass};
use super::targets::{ATTRIBUTE_WORDS_FORMAT, ATTRIBUTES_FORMAT, POSITION_FORMAT, UV_FORMAT};
use super::upload::GpuLightField;
use crate::shaders;

/// The pass: it clears positions to 0 (w = 0: no surface) and draws the scene against pass 3's
/// depth, writing positions and uvs (the uv target not cleared).
pub(super) fn position_pass(
    device: &wgpu::Device,
    globals_layout: &wgpu::BindGroupLayout,
    lf: &GpuLightField,
    depth_format: wgpu::TextureFormat,
) -> MeshPass {
    let targets = vec![
        ColorTarget {
            view: |t| &t.position_view,
            clear: Some(wgpu::Color::TRANSPARENT),
        },
        ColorTarget {
            view: |t| &t.uv_view,
            clear: None,
        },
    ];
    MeshPass::over_pass_three(
        device,
        ("Position", &shaders::RENDER_POSITION),
        globals_layout,
        lf,
        &[&lf.triangles, &lf.uvs],
        &[POSITION_FORMAT, UV_FORMAT],
        depth_format,
        targets,
    )
}

/// Pass 4b: the shading normal, vertex colour and `TEXCOORD_1` of the visible surface, for light
/// fields with per-corner attributes ([`super::attributes::has_attributes`]), into the attribute
/// targets (shader `shaders/render_attributes.wgsl`; not cleared: pass 5 reads them only where a
/// face is seen). A pass of its own rather than two more targets of pass 4: the four would
/// exceed the 32 bytes per pixel of colour attachments that every device allows.
pub(super) fn attributes_pass(
    device: &wgpu::Device,
    globals_layout: &wgpu::BindGroupLayout,
    lf: &GpuLightField,
    depth_format: wgpu::TextureFormat,
) -> MeshPass {
    let targets = vec![
        ColorTarget {
            view: |t| &t.attributes_view[0],
            clear: None,
        },
        ColorTarget {
            view: |t| &t.attributes_view[1],
            clear: None,
        },
    ];
    MeshPass::over_pass_three(
        device,
        ("Attributes", &shaders::RENDER_ATTRIBUTES),
        globals_layout,
        lf,
        &[&lf.triangles, &lf.attributes, &lf.uvs],
        &[ATTRIBUTES_FORMAT, ATTRIBUTE_WORDS_FORMAT],
        depth_format,
        targets,
    )
}
