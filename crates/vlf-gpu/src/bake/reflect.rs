//! Bake pass `Reflect` (`shaders/bake_reflect.wgsl`): its pipeline, its group-1 layout and its bind
//! group (one per one chunk of directions), built from the named bindings [`ReflectBindings`].

use crate::wgpu_util::bake_pass;

bake_pass! {
    ReflectPass("Reflect", crate::shaders::BAKE_REFLECT),
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
