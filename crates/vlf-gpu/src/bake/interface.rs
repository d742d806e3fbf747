//! Bake pass `Interface` (`shaders/bake_interface.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per the scene), built from the named bindings [`InterfaceBindings`].

use crate::wgpu_util::bake_pass;

bake_pass! {
    InterfacePass("Interface", crate::shaders::BAKE_INTERFACE),
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
