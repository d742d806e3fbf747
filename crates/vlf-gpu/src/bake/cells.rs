//! Bake pass `Cells` (`shaders/bake_cells.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per one chunk of directions), built from the named bindings [`CellsBindings`].

use crate::wgpu_util::bake_pass;

bake_pass! {
    CellsPass("Cells", crate::shaders::BAKE_CELLS),
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
