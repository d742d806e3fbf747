//! Bake pass `Interface` (`shaders/bake_interface.wgsl`). Group 1 bindings, in order: faces (r), unshot texels+tiles (r), cell_count (r), cells (r), crossings (rw), tile_index (r), frames (r), spec_escape (rw).

use super::common;

pub struct InterfacePass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl InterfacePass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let entries: Vec<_> = [true, true, true, true, false, true, true, false]
            .iter()
            .enumerate()
            .map(|(i, &ro)| common::storage(i as u32, ro))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Interface::pass_layout"),
            entries: &entries,
        });
        let pipeline = common::pipeline(
            device,
            "Interface",
            globals,
            &layout,
            &crate::shaders::BAKE_INTERFACE,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        common::bind_group(device, "Interface::bind_group", &self.layout, buffers)
    }
}
