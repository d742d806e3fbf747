//! Bake pass `Gather` (`shaders/bake_gather.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per the scene), built from the named bindings [`GatherBindings`].

use crate::wgpu_util::{self, bindings};

bindings! {
    /// Group 1 of `Gather`, in binding order.
    GatherBindings {
        faces: READ,
        active_texels: READ,
        texel_center: READ,
        cell_count: READ,
        cells: READ,
        crossings: READ,
        acc: READ_WRITE,
    }
}

pub struct GatherPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl GatherPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let layout = wgpu_util::pass_layout(device, "Gather", GatherBindings::LAYOUT);
        let pipeline = wgpu_util::pass_pipeline(
            device,
            "Gather",
            globals,
            &layout,
            &crate::shaders::BAKE_GATHER,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, b: &GatherBindings) -> wgpu::BindGroup {
        wgpu_util::buffer_bind_group(device, "Gather::bind_group", &self.layout, &b.buffers())
    }
}
