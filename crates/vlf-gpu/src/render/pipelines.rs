//! Helpers shared by the render pass modules: bind-group layout entries, the group-1 layouts of
//! the sphere-mesh passes (1, 2) and the scene-geometry passes (3, 4), colour attachments, the
//! vertex-pulling render pipeline, the depth test against pass 3's depth, and [`MeshPass`], the
//! pipeline and render pass of passes 1, 2, 4 and 4b. Each pass still owns its objects and
//! labels them.

use super::upload::GpuLightField;
use crate::wgpu_util::storage_entry;

pub(crate) fn color_attachment(
    view: &wgpu::TextureView,
    clear: wgpu::Color,
) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: wgpu::StoreOp::Store,
        },
    }
}

/// Depth test against pass 3's depth buffer of `format`: greater or equal (reverse-Z: only the
/// visible surface, or where no face is seen the background at depth 0, passes), no writes,
/// with `stencil`. What pass 4, pass 4b and the window's fused pass 5 and sky draw with.
pub(super) fn pass_three_depth(
    format: wgpu::TextureFormat,
    stencil: wgpu::StencilState,
) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(false),
        depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
        stencil,
        bias: Default::default(),
    }
}

/// A colour target of a [`MeshPass`]: its view among the frame's targets, and the colour it is
/// cleared to first (`None`: loaded and kept — read only where a face is seen, all of which the
/// pass writes, so not cleared).
pub(super) struct ColorTarget {
    pub view: fn(&super::targets::Targets) -> &wgpu::TextureView,
    pub clear: Option<wgpu::Color>,
}

/// A pass drawing one of the light field's meshes with its pipeline, group 0 the globals and
/// group 1 its own bind group, into its colour targets: passes 1 and 2 (the sphere mesh,
/// [`MeshPass::sphere`]) and 4 and 4b (the scene over pass 3's depth,
/// [`MeshPass::over_pass_three`]).
pub(super) struct MeshPass {
    /// The pass's name, for labels (`"{pass}::thing"`).
    pass: &'static str,
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Drawn against pass 3's depth (loaded and kept), and its stencil where `Some(true)`; the
    /// scene's triangles then, else the sphere mesh.
    over_pass_three: Option<bool>,
    targets: Vec<ColorTarget>,
}

impl MeshPass {
    /// A pass of the sphere mesh writing `format` into `target`, no depth.
    pub(super) fn sphere(
        device: &wgpu::Device,
        (pass, shader): (&'static str, &crate::shaders::Shader),
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        format: wgpu::TextureFormat,
        target: ColorTarget,
    ) -> Self {
        let (pass_layout, bind_group) = sphere_pass_layout(device, pass, lf);
        let pipeline = render_pipeline(
            device,
            pass,
            shader,
            globals_layout,
            &pass_layout,
            &[format],
            None,
            ("vs_main", "fs_main"),
        );
        Self {
            pass,
            pipeline,
            bind_group,
            over_pass_three: None,
            targets: vec![target],
        }
    }

    /// A pass of the scene's triangles against pass 3's depth (of `depth_format`:
    /// [`pass_three_depth`], only the visible surface is shaded) writing `formats`, its group 1
    /// the light field's `buffers` (vertex stage, in binding order) and its alpha masks, into
    /// `targets`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn over_pass_three(
        device: &wgpu::Device,
        (pass, shader): (&'static str, &crate::shaders::Shader),
        globals_layout: &wgpu::BindGroupLayout,
        lf: &GpuLightField,
        buffers: &[&wgpu::Buffer],
        formats: &[wgpu::TextureFormat],
        depth_format: wgpu::TextureFormat,
        targets: Vec<ColorTarget>,
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
            over_pass_three: Some(depth_format == super::targets::DEPTH_STENCIL_FORMAT),
            targets,
        }
    }

    /// Clears its colour targets that are cleared and draws its mesh into them (and pass 3's
    /// depth and stencil, loaded and kept).
    pub(super) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        targets: &super::targets::Targets,
        lf: &GpuLightField,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        fn keep<V>() -> wgpu::Operations<V> {
            wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            }
        }
        let color: Vec<_> = self
            .targets
            .iter()
            .map(|c| {
                let view = (c.view)(targets);
                Some(match c.clear {
                    Some(clear) => color_attachment(view, clear),
                    None => wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: keep(),
                    },
                })
            })
            .collect();
        let vertices = 3 * match self.over_pass_three {
            Some(_) => lf.triangle_count,
            None => lf.sphere_triangle_count,
        };
        let depth = self
            .over_pass_three
            .map(|stencil| wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(keep()),
                stencil_ops: stencil.then(keep),
            });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(&format!("{}::pass", self.pass)),
            color_attachments: &color,
            depth_stencil_attachment: depth,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.draw(0..vertices, 0..1);
    }
}

/// Group-1 layout and bind group of a sphere-mesh pass (1, 2): vertices, triangles.
pub(super) fn sphere_pass_layout(
    device: &wgpu::Device,
    pass: &str,
    lf: &GpuLightField,
) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let vis = wgpu::ShaderStages::VERTEX;
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{pass}::pass_layout")),
        entries: &[storage_entry(0, vis, true), storage_entry(1, vis, true)],
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&format!("{pass}::pass_bind_group")),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: lf.sphere_vertices.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: lf.sphere_triangles.as_entire_binding(),
            },
        ],
    });
    (layout, bind_group)
}

/// The binding of the alpha masks in group 1 (`shaders/common/alpha_mask.wgsl`).
pub(crate) const MASK_BINDING: u32 = 6;

/// Group-1 layout and bind group of a scene-geometry pass (3, 4): `buffers` (the triangles,
/// then any per-vertex data the pass pulls) as read-only storage bindings 0, 1, …, and the
/// light field's alpha masks at [`MASK_BINDING`]
pub(super) fn geometry_pass_layout(
    device: &wgpu::Device,
    pass: &str,
    buffers: &[&wgpu::Buffer],
    alpha_masks: &wgpu::Buffer,
) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let mut entries: Vec<_> = (0..buffers.len() as u32)
        .map(|i| storage_entry(i, wgpu::ShaderStages::VERTEX, true))
        .collect();
    // The alpha masks (`common/alpha_mask.wgsl`), read by the masked entry points' fragments.
    entries.push(storage_entry(
        MASK_BINDING,
        wgpu::ShaderStages::FRAGMENT,
        true,
    ));
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{pass}::pass_layout")),
        entries: &entries,
    });
    let entries: Vec<_> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| (i as u32, *b))
        .chain([(MASK_BINDING, alpha_masks)])
        .map(|(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&format!("{pass}::pass_bind_group")),
        layout: &layout,
        entries: &entries,
    });
    (layout, bind_group)
}

/// A vertex-pulling render pipeline (no vertex buffers, no culling) writing one colour target
/// per format of `formats`.
#[allow(clippy::too_many_arguments)]
fn render_pipeline(
    device: &wgpu::Device,
    pass: &str,
    shader: &crate::shaders::Shader,
    globals_layout: &wgpu::BindGroupLayout,
    pass_layout: &wgpu::BindGroupLayout,
    formats: &[wgpu::TextureFormat],
    depth: Option<wgpu::DepthStencilState>,
    (vs, fs): (&str, &str),
) -> wgpu::RenderPipeline {
    let layout = crate::wgpu_util::pipeline_layout(
        device,
        &format!("{pass}::pipeline_layout"),
        &[Some(globals_layout), Some(pass_layout)],
    );
    let module = shader.module(device);
    let targets: Vec<_> = formats
        .iter()
        .map(|&format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        })
        .collect();
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(&format!("{pass}::pipeline")),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: depth,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A scene-geometry pass's pipeline; `masked` draws with the entry points that discard the
/// fragments an alpha mask cuts (`vs_masked`, `fs_masked`), else `vs_main`, `fs_main`.
#[allow(clippy::too_many_arguments)]
pub(super) fn geometry_pipeline(
    device: &wgpu::Device,
    pass: &str,
    shader: &crate::shaders::Shader,
    globals_layout: &wgpu::BindGroupLayout,
    pass_layout: &wgpu::BindGroupLayout,
    formats: &[wgpu::TextureFormat],
    depth: wgpu::DepthStencilState,
    masked: bool,
) -> wgpu::RenderPipeline {
    render_pipeline(
        device,
        pass,
        shader,
        globals_layout,
        pass_layout,
        formats,
        Some(depth),
        if masked {
            ("vs_masked", "fs_masked")
        } else {
            ("vs_main", "fs_main")
        },
    )
}
