//! Bake pass `Cells` (`shaders/bake_cells.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per one chunk of directions), built from the named bindings [`CellsBindings`].

use crate::wgpu_util::{self, bindings};

bindings! {
    /// Group 1 of `Cells`, in binding order.
    CellsBindings {
        triangles: READ,
        bin_start: READ,
        bin_tris: READ,
        cell_count: READ_WRITE,
        cells: READ_WRITE,
        overflow: READ_WRITE,
        alpha_masks: READ,
    }
}

pub struct CellsPass {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl CellsPass {
    pub fn new(device: &wgpu::Device, globals: &wgpu::BindGroupLayout) -> Self {
        let layout = wgpu_util::pass_layout(device, "Cells", CellsBindings::LAYOUT);
        let pipeline = wgpu_util::pass_pipeline(
            device,
            "Cells",
            globals,
            &layout,
            &crate::shaders::BAKE_CELLS,
        );
        Self { layout, pipeline }
    }

    pub fn bind_group(&self, device: &wgpu::Device, b: &CellsBindings) -> wgpu::BindGroup {
        wgpu_util::buffer_bind_group(device, "Cells::bind_group", &self.layout, &b.buffers())
    }
}
