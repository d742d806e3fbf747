//! Bake pass `Reflect` (`shaders/bake_reflect.wgsl`). Group 1 bindings, in order: faces (r), cell_count (r), cells (r), crossings (r), tile_index (r), frames (r), items (r), next_tiles (rw).

use super::common;

pub struct ReflectPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl ReflectPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let entries: Vec<_> = [true, true, true, true, true, true, true, false]
            .iter()
            .enumerate()
            .map(|(i, &ro)| common::storage(i as u32, ro))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Reflect::pass_layout"),
            entries: &entries,
        });
        let pipeline = common::pipeline(
            device,
            "Reflect",
            globals,
            &layout,
            &crate::shaders::BAKE_REFLECT,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        common::bind_group(device, "Reflect::bind_group", &self.layout, buffers)
    }
}
