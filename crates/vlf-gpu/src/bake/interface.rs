//! Bake pass `Interface` (`shaders/bake_interface.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per the scene), built from the named bindings [`InterfaceBindings`].

use crate::wgpu_util::{self, bindings};

bindings! {
    /// Group 1 of `Interface`, in binding order.
    InterfaceBindings {
        faces: READ,
        unshot: READ,
        cell_count: READ,
        cells: READ,
        crossings: READ_WRITE,
        tile_index: READ,
        frames: READ,
        spec_escape: READ_WRITE,
        panes: READ,
        pane_energy: READ_WRITE,
    }
}

pub struct InterfacePass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl InterfacePass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let layout = wgpu_util::pass_layout(device, "Interface", InterfaceBindings::LAYOUT);
        let pipeline = wgpu_util::pass_pipeline(
            device,
            "Interface",
            globals,
            &layout,
            &crate::shaders::BAKE_INTERFACE,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, b: &InterfaceBindings) -> wgpu::BindGroup {
        wgpu_util::buffer_bind_group(device, "Interface::bind_group", &self.layout, &b.buffers())
    }
}
