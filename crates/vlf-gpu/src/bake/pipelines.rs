//! The bake's device-level objects: the per-direction globals layout and the four passes'
//! layouts and compute pipelines. Created once per device ([`BakePipelines::of`]) and reused
//! by every scene baked on it, as re_renderer's renderers are; the per-scene buffers and bind
//! groups are built separately ([`super::resources`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::{cells, gather, interface, reflect};
use crate::GpuContext;
use crate::layout::BakeDirection;

/// [`BakePipelines`] created by this process (all devices).
static CREATED: AtomicUsize = AtomicUsize::new(0);

pub struct BakePipelines {
    /// Group 0 of every bake pass: one `BakeDirection`, bound at a dynamic offset.
    pub globals_layout: wgpu::BindGroupLayout,
    pub cells: cells::CellsPass,
    pub interface: interface::InterfacePass,
    pub gather: gather::GatherPass,
    pub reflect: reflect::ReflectPass,
}

impl BakePipelines {
    /// Compiles the four bake passes on `device`. Use [`BakePipelines::of`] to get the
    /// device's shared ones instead of compiling them again.
    pub fn new(device: &wgpu::Device) -> BakePipelines {
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Bake::globals_layout"),
            entries: &[crate::wgpu_util::uniform_entry::<BakeDirection>(
                0,
                wgpu::ShaderStages::COMPUTE,
                true,
            )],
        });
        let pipelines = BakePipelines {
            cells: cells::CellsPass::new(device, &globals_layout),
            interface: interface::InterfacePass::new(device, &globals_layout),
            gather: gather::GatherPass::new(device, &globals_layout),
            reflect: reflect::ReflectPass::new(device, &globals_layout),
            globals_layout,
        };
        let n = CREATED.fetch_add(1, Ordering::Relaxed) + 1;
        log::info!(
            "created the bake pipelines (Cells, Interface, Gather, Reflect; {n} in this process)"
        );
        pipelines
    }

    /// The pipelines of `ctx`'s device: created on the first call, shared afterwards.
    pub fn of(ctx: &GpuContext) -> Arc<BakePipelines> {
        ctx.shared(|ctx| BakePipelines::new(&ctx.device))
    }

    /// How many times this process created bake pipelines (on any device).
    pub fn created() -> usize {
        CREATED.load(Ordering::Relaxed)
    }

    /// The group-0 bind group over the per-direction uniforms.
    pub fn globals(&self, device: &wgpu::Device, directions: &wgpu::Buffer) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Bake::globals"),
            layout: &self.globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: directions,
                    offset: 0,
                    size: wgpu::BufferSize::new(size_of::<BakeDirection>() as u64),
                }),
            }],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each pass's named bindings are the WGSL's group-1 variables: same names, same order,
    /// same access.
    #[test]
    fn named_bindings_match_the_wgsl() {
        use wgpu::naga;
        for (shader, layout) in [
            (&crate::shaders::BAKE_CELLS, cells::CellsBindings::LAYOUT),
            (
                &crate::shaders::BAKE_INTERFACE,
                interface::InterfaceBindings::LAYOUT,
            ),
            (&crate::shaders::BAKE_GATHER, gather::GatherBindings::LAYOUT),
            (
                &crate::shaders::BAKE_REFLECT,
                reflect::ReflectBindings::LAYOUT,
            ),
        ] {
            let module = shader.validate().unwrap();
            let mut wgsl: Vec<(u32, String, bool)> = module
                .global_variables
                .iter()
                .filter_map(|(_, v)| {
                    let b = v.binding.as_ref().filter(|b| b.group == 1)?;
                    let read_only = match v.space {
                        naga::AddressSpace::Storage { access } => {
                            !access.contains(naga::StorageAccess::STORE)
                        }
                        _ => panic!("{}: group 1 holds storage buffers only", shader.file),
                    };
                    Some((b.binding, v.name.clone().unwrap_or_default(), read_only))
                })
                .collect();
            wgsl.sort();
            let named: Vec<(u32, String, bool)> = layout
                .iter()
                .enumerate()
                .map(|(i, &(name, ro))| (i as u32, name.to_string(), ro))
                .collect();
            assert_eq!(named, wgsl, "{}", shader.file);
        }
    }
}
