//! Bake pass `Gather` (`shaders/bake_gather.wgsl`). Group 1 bindings, in order: faces (r), active (r), texel_center (r), cell_count (r), cells (r), crossings (r), acc (rw).

use super::common;

pub struct GatherPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl GatherPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let entries: Vec<_> = [true, true, true, true, true, true, false]
            .iter()
            .enumerate()
            .map(|(i, &ro)| common::storage(i as u32, ro))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Gather::pass_layout"),
            entries: &entries,
        });
        let pipeline = common::pipeline(
            device,
            "Gather",
            globals,
            &layout,
            &crate::shaders::BAKE_GATHER,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        common::bind_group(device, "Gather::bind_group", &self.layout, buffers)
    }
}
