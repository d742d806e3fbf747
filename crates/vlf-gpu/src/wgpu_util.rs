//! The one home of the wgpu boilerplate every pass shares (as re_renderer's `wgpu_resources`):
//! bind-group layout entries, compute pipelines from a module and a layout, bind groups of
//! buffers in binding order, plain 2D textures, and the split of a large dispatch over two
//! dimensions. A pass
//! module keeps what is its own (its layouts, its WGSL file, its labels); what is the same
//! everywhere lives here, and `cargo xtask check-modules` fails on a second definition
//! (`wgpu::BindGroupLayoutEntry {` or `create_compute_pipeline(` outside this file).

/// A 2D texture of `format`, `width` × `height`, one mip level, one sample.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A storage buffer at `binding`, seen by `visibility`.
pub(crate) fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A read-only or read-write storage buffer of a compute pass.
pub(crate) fn compute_storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    storage_entry(binding, wgpu::ShaderStages::COMPUTE, read_only)
}

/// A uniform buffer holding a `T` at `binding` (a dynamic offset when `dynamic`).
pub(crate) fn uniform_entry<T>(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<T>() as u64),
        },
        count: None,
    }
}

/// A 2-D texture of `sample_type` at `binding` (not multisampled).
pub(crate) fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// The pipeline layout `"{pass}::{what}"` of bind groups `groups` (`None`: a group the
/// pipelines do not use).
pub(crate) fn pipeline_layout(
    device: &wgpu::Device,
    label: &str,
    groups: &[Option<&wgpu::BindGroupLayout>],
) -> wgpu::PipelineLayout {
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: groups,
        immediate_size: 0,
    })
}

/// The compute pipeline `"{pass}::{entry}_pipeline"` of entry point `entry` of `module`.
pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    pass: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(&format!("{pass}::{entry}_pipeline")),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A bind group of `layout` binding `buffers` whole at bindings 0, 1, ….
pub(crate) fn buffer_bind_group(
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

/// Access of a binding in [`bindings!`]: the shader only reads it.
pub(crate) const READ: bool = true;
/// Access of a binding in [`bindings!`]: the shader writes it.
pub(crate) const READ_WRITE: bool = false;

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
                &[$((stringify!($field), $crate::wgpu_util::$access)),+];

            /// The buffers in binding order.
            pub fn buffers(&self) -> Vec<&wgpu::Buffer> {
                vec![$(self.$field),+]
            }
        }
    };
}
pub(crate) use bindings;

/// Declares a bake pass: its [`bindings!`] and the pass struct holding its group-1 layout and
/// its pipeline (`main` of `shader`), labelled `"{label}::…"`, with `new` and a `bind_group`
/// that takes the named bindings. The four bake passes differ only in these.
macro_rules! bake_pass {
    (
        $(#[$pass_meta:meta])* $pass:ident($label:literal, $shader:path),
        $(#[$meta:meta])* $name:ident { $($field:ident: $access:ident),+ $(,)? }
    ) => {
        $crate::wgpu_util::bindings! { $(#[$meta])* $name { $($field: $access),+ } }

        $(#[$pass_meta])*
        pub struct $pass {
            pub layout: wgpu::BindGroupLayout,
            pub pipeline: wgpu::ComputePipeline,
        }

        impl $pass {
            pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
                let layout = $crate::wgpu_util::pass_layout(device, $label, $name::LAYOUT);
                let pipeline =
                    $crate::wgpu_util::pass_pipeline(device, $label, globals, &layout, &$shader);
                Self { layout, pipeline }
            }

            pub fn bind_group(&self, device: &wgpu::Device, b: &$name) -> wgpu::BindGroup {
                $crate::wgpu_util::buffer_bind_group(
                    device,
                    concat!($label, "::bind_group"),
                    &self.layout,
                    &b.buffers(),
                )
            }
        }
    };
}
pub(crate) use bake_pass;

/// The group-1 layout of pass `name` from its bindings' `LAYOUT`.
pub(crate) fn pass_layout(
    device: &wgpu::Device,
    name: &str,
    layout: &[(&str, bool)],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = layout
        .iter()
        .enumerate()
        .map(|(i, &(_, read_only))| compute_storage(i as u32, read_only))
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{name}::pass_layout")),
        entries: &entries,
    })
}

/// The pipeline of a pass whose shader's entry point is `main`, with group 0 = per-dispatch
/// globals and group 1 = the pass's own resources (the bake passes).
pub(crate) fn pass_pipeline(
    device: &wgpu::Device,
    name: &str,
    globals: &wgpu::BindGroupLayout,
    pass: &wgpu::BindGroupLayout,
    shader: &crate::shaders::Shader,
) -> wgpu::ComputePipeline {
    let layout = pipeline_layout(
        device,
        &format!("{name}::pipeline_layout"),
        &[Some(globals), Some(pass)],
    );
    compute_pipeline(device, name, &layout, &shader.module(device), "main")
}

/// Number of workgroups for `n` invocations of `size` each, split over x and y so neither exceeds
/// `max_per_dim` (65535 on most adapters).
pub fn dispatch_2d(n: u32, size: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = n.div_ceil(size).max(1);
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

#[cfg(test)]
mod tests {
    use super::dispatch_2d;

    #[test]
    fn dispatch_2d_covers_every_invocation() {
        for &(n, max) in &[
            (1, 65535),
            (64 * 65535, 65535),
            (64 * 65535 + 1, 65535),
            (10_000, 20),
        ] {
            let (x, y) = dispatch_2d(n, 64, max);
            assert!(x <= max && y <= max);
            assert!(u64::from(x) * u64::from(y) * 64 >= u64::from(n));
            // No more than one extra row of workgroups.
            assert!(u64::from(x) * u64::from(y - 1) * 64 < u64::from(n));
        }
    }
}
