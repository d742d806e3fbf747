//! Bake pass `Cells` (`shaders/bake_cells.wgsl`). Group 1 bindings, in order: triangles (r), bin_start (r), bin_tris (r), cell_count (rw), cells (rw), overflow (rw).

use super::common;

pub struct CellsPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl CellsPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let entries: Vec<_> = [true, true, true, false, false, false]
            .iter()
            .enumerate()
            .map(|(i, &ro)| common::storage(i as u32, ro))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Cells::pass_layout"),
            entries: &entries,
        });
        let pipeline = common::pipeline(
            device,
            "Cells",
            globals,
            &layout,
            &crate::shaders::BAKE_CELLS,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        common::bind_group(device, "Cells::bind_group", &self.layout, buffers)
    }
}
