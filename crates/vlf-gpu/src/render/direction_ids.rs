//! Pass 1: direction ids. The direction set's sphere triangles drawn from the sphere centre with
//! the camera's orientation and projection; per pixel the three sphere-vertex ids of the view
//! ray's triangle (and the triangle index). Shader: `shaders/render_direction_ids.wgsl`.

use super::pipelines::MeshPass;
use super::targets::{DIRECTION_IDS_FORMAT, Targets};
use super::upload::GpuLightField;
use crate::shaders;

pub struct DirectionIdsPass(MeshPass);

impl DirectionIdsPass {
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
    ) -> Self {
        let shader = &shaders::RENDER_DIRECTION_IDS;
        let format = DIRECTION_IDS_FORMAT;
        Self(MeshPass::sphere(
            device,
            "DirectionIds",
            shader,
            globals_layout,
            lf,
            format,
        ))
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
        let none = f64::from(u32::MAX);
        let clear = wgpu::Color {
            r: none,
            g: none,
            b: none,
            a: none,
        };
        let color = [Some(super::color_attachment(
            &targets.direction_ids_view,
            clear,
        ))];
        let vertices = lf.sphere_triangle_count * 3;
        (self.0).encode(encoder, globals, targets, &color, vertices, timestamps);
    }
}
