//! Bind-group layout helpers shared by the bake passes.

/// Access of a binding in [`bindings!`]: the shader only reads it.
pub const READ: bool = true;
/// Access of a binding in [`bindings!`]: the shader writes it.
pub const READ_WRITE: bool = false;

/// Declares the group-1 bindings of a bake pass by name: a struct with one buffer per
/// binding, fields in binding order and named as the WGSL variables, each with its access
/// ([`READ`] or [`READ_WRITE`]). The pass builds its layout from `LAYOUT` and its bind group
/// from the struct, so a bind group is written with names, never as a positional list (a
/// test checks the names and access against the WGSL).
macro_rules! bindings {
    ($(#[$meta:meta])* $name:ident { $($field:ident: $access:ident),+ $(,)? }) => {
        $(#[$meta])*
        pub struct $name<'a> {
            $(pub $field: &'a wgpu::Buffer,)+
        }

        impl $name<'_> {
            /// (WGSL variable, read-only) of each binding, in binding order.
            pub const LAYOUT: &'static [(&'static str, bool)] =
                &[$((stringify!($field), common::$access)),+];

            /// The buffers in binding order.
            pub fn buffers(&self) -> Vec<&wgpu::Buffer> {
                vec![$(self.$field),+]
            }
        }
    };
}
pub(crate) use bindings;

/// The group-1 layout of pass `name` from its bindings' `LAYOUT`.
pub fn pass_layout(
    device: &wgpu::Device,
    name: &str,
    layout: &[(&str, bool)],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = layout
        .iter()
        .enumerate()
        .map(|(i, &(_, read_only))| storage(i as u32, read_only))
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{name}::pass_layout")),
        entries: &entries,
    })
}

pub fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Creates a compute pipeline for `shader` with group 0 = per-direction globals and group 1 =
/// the pass's own resources.
pub fn pipeline(
    device: &wgpu::Device,
    name: &str,
    globals: &wgpu::BindGroupLayout,
    pass: &wgpu::BindGroupLayout,
    shader: &crate::shaders::Shader,
) -> wgpu::ComputePipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(&format!("{name}::pipeline_layout")),
        bind_group_layouts: &[Some(globals), Some(pass)],
        immediate_size: 0,
    });
    let module = shader.module(device);
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(&format!("{name}::pipeline")),
        layout: Some(&layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

pub fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}
