//! Bake pass `Gather` (`shaders/bake_gather.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per the scene), built from the named bindings [`GatherBindings`].

use crate::wgpu_util::bake_pass;

bake_pass! {
    GatherPass("Gather", crate::shaders::BAKE_GATHER),
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
