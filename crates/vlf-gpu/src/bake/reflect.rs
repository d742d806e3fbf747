//! Bake pass `Reflect` (`shaders/bake_reflect.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per one chunk of directions), built from the named bindings [`ReflectBindings`].

use crate::wgpu_util::{self, bindings};

bindings! {
    /// Group 1 of `Reflect`, in binding order.
    ReflectBindings {
        faces: READ,
        cell_count: READ,
        cells: READ,
        crossings: READ,
        tile_index: READ,
        frames: READ,
        items: READ,
        next_tiles: READ_WRITE,
    }
}

pub struct ReflectPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl ReflectPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let layout = wgpu_util::pass_layout(device, "Reflect", ReflectBindings::LAYOUT);
        let pipeline = wgpu_util::pass_pipeline(
            device,
            "Reflect",
            globals,
            &layout,
            &crate::shaders::BAKE_REFLECT,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, b: &ReflectBindings) -> wgpu::BindGroup {
        wgpu_util::buffer_bind_group(device, "Reflect::bind_group", &self.layout, &b.buffers())
    }
}
