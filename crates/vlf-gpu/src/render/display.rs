//! Display: draws one pass's output (the debug view) or the tonemapped final radiance onto a
//! colour target — the window's surface, a screenshot or a debug still. Not one of the five
//! passes; it only visualises them. What to show and how (view, exposure, tonemap, sRGB
//! encoding) comes from the per-frame globals. Shader: `shaders/render_display.wgsl`.
//!
//! The window shows the final image without this pass: pass 5 writes the surface itself
//! ([`super::final_radiance::FinalRadiancePass::encode_present`]).

use std::collections::HashMap;

use super::targets::Targets;
use super::texture_entry;
use crate::shaders;

pub struct DisplayPass {
    pass_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    /// One pipeline per target format, created on first use.
    pipelines: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
}

impl DisplayPass {
    pub fn new(device: &wgpu::Device, globals_layout: &wgpu::BindGroupLayout) -> Self {
        let vis = wgpu::ShaderStages::FRAGMENT;
        let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Display::pass_layout"),
            entries: &[
                texture_entry(0, vis, wgpu::TextureSampleType::Uint),
                texture_entry(1, vis, unfiltered),
                texture_entry(2, vis, wgpu::TextureSampleType::Uint),
                texture_entry(3, vis, unfiltered),
                texture_entry(4, vis, unfiltered),
            ],
        });
        let pipeline_layout = crate::wgpu_util::pipeline_layout(
            device,
            "Display::pipeline_layout",
            &[Some(globals_layout), Some(&pass_layout)],
        );
        Self {
            pass_layout,
            pipeline_layout,
            module: shaders::RENDER_DISPLAY.module(device),
            pipelines: HashMap::new(),
        }
    }

    fn pipeline(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
    ) -> &wgpu::RenderPipeline {
        self.pipelines.entry(format).or_insert_with(|| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("Display::pipeline"),
                layout: Some(&self.pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &self.module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &self.module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }

    /// The pass's resources for one set of targets (rebuilt when the view is resized).
    pub fn bind(&self, device: &wgpu::Device, targets: &Targets) -> wgpu::BindGroup {
        let tex = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Display::pass_bind_group"),
            layout: &self.pass_layout,
            entries: &[
                tex(0, &targets.direction_ids_view),
                tex(1, &targets.barycentrics_view),
                tex(2, &targets.face_id_view),
                tex(3, &targets.position_view),
                tex(4, &targets.radiance_view),
            ],
        })
    }

    /// Draws the globals' debug view of the current frame onto `target` (format `format`, the
    /// size of the pass targets).
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        bind_group: &wgpu::BindGroup,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let pipeline = self.pipeline(device, format);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Display::pass"),
            color_attachments: &[Some(super::color_attachment(target, wgpu::Color::BLACK))],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// 1 when the shader must apply the sRGB transfer function itself: 8-bit unorm targets
/// without an sRGB view. Float targets hold linear values.
pub fn needs_srgb_encoding(format: wgpu::TextureFormat) -> bool {
    let float = matches!(
        format,
        wgpu::TextureFormat::Rgba16Float
            | wgpu::TextureFormat::Rgba32Float
            | wgpu::TextureFormat::Rg11b10Ufloat
    );
    !format.is_srgb() && !float
}
