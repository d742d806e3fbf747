//! The direction set on the GPU: `vlf_core::directions::DirectionSet::lookup` as WGSL
//! (`shaders/common/directions.wgsl`, for passes that must find the sphere triangle of an
//! arbitrary direction, like the final gather reading the mirror tiles), its data
//! ([`GpuDirections`], bound as group 2 with [`tables_layout`]), and [`DirectionLookup`], a pass
//! that runs the lookup over a batch of directions (what the tests compare with the CPU).
//!
//! The WGSL lookup is the CPU's algorithm in f32 instead of f64: the icosahedron face by sign
//! octant, the grid cell of the central projection, the gnomonic barycentrics against the
//! stored (f32) sphere vertices. Directions within rounding of a triangle edge may land in the
//! neighbouring triangle; there the vertex not shared carries a weight of about zero, so the
//! interpolated value is the same to rounding.

use glam::Vec3;
use vlf_core::directions::{DirectionSet, Lookup};

use crate::GpuContext;
use crate::layout::DirTables;
use crate::readback::{read_buffer, storage_buffer};
use crate::shaders;
use crate::wgpu_util::{
    compute_pipeline, compute_storage, dispatch_2d, pipeline_layout, uniform_entry,
};
use wgpu::util::DeviceExt;

/// The lookup tables of `set` as `shaders/common/directions.wgsl` binds them.
pub fn tables(set: &DirectionSet) -> DirTables {
    let t = set.lookup_tables();
    let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
    DirTables {
        face_normals: t.face_normals.map(v4),
        edge0: t.edge_normals.map(|e| v4(e[0])),
        edge1: t.edge_normals.map(|e| v4(e[1])),
        edge2: t.edge_normals.map(|e| v4(e[2])),
        octant_faces: t.octant_faces,
        k: t.k,
        l: set.len() as u32,
        _pad0: 0,
        _pad1: 0,
    }
}

/// The layout of group 2 of the shaders that import `common/directions.wgsl`: the tables
/// (uniform) and the sphere mesh (storage).
pub fn tables_layout(device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[
            uniform_entry::<DirTables>(0, wgpu::ShaderStages::COMPUTE, false),
            compute_storage(1, true),
        ],
    })
}

/// A direction set uploaded for the WGSL lookup.
pub struct GpuDirections {
    pub tables: wgpu::Buffer,
    /// The sphere mesh (vec4 each): the unit sphere-vertex positions by sphere-vertex id, then
    /// the sphere triangles (three sphere-vertex ids as bits).
    pub mesh: wgpu::Buffer,
}

impl GpuDirections {
    pub fn new(device: &wgpu::Device, set: &DirectionSet) -> Self {
        let mut mesh: Vec<[f32; 4]> = set
            .sphere_vertices()
            .iter()
            .map(|p| p.extend(0.0).into())
            .collect();
        mesh.extend(
            set.sphere_triangles()
                .iter()
                .map(|t| [t[0], t[1], t[2], 0].map(f32::from_bits)),
        );
        Self {
            tables: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("Directions::tables"),
                contents: bytemuck::bytes_of(&tables(set)),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            mesh: storage_buffer(
                device,
                "Directions::mesh",
                &mesh,
                wgpu::BufferUsages::empty(),
            ),
        }
    }

    /// The group-2 bind group of these tables for `layout` (made by [`tables_layout`]).
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        label: &str,
    ) -> wgpu::BindGroup {
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[entry(0, &self.tables), entry(1, &self.mesh)],
        })
    }
}

const WORKGROUP: u32 = 64;

/// The lookup over a batch of directions (`shaders/directions_lookup.wgsl`). Bind groups:
/// 0 = directions in, lookups out; 2 = the tables ([`tables_layout`]).
pub struct DirectionLookup {
    io_layout: wgpu::BindGroupLayout,
    /// Group 1 (unused by this pass).
    empty_layout: wgpu::BindGroupLayout,
    tables_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl DirectionLookup {
    pub fn new(device: &wgpu::Device) -> Self {
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("DirectionLookup::io_layout"),
            entries: &[compute_storage(0, true), compute_storage(1, false)],
        });
        let tables_layout = tables_layout(device, "DirectionLookup::tables_layout");
        let empty = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("DirectionLookup::empty_layout"),
            entries: &[],
        });
        let layout = pipeline_layout(
            device,
            "DirectionLookup::pipeline_layout",
            &[Some(&io_layout), Some(&empty), Some(&tables_layout)],
        );
        let module = shaders::DIRECTIONS_LOOKUP.module(device);
        let pipeline = compute_pipeline(device, "DirectionLookup", &layout, &module, "main");
        Self {
            io_layout,
            empty_layout: empty,
            tables_layout,
            pipeline,
        }
    }

    /// The lookup of every direction of `dirs` in the uploaded set `set`.
    pub fn run(
        &self,
        ctx: &GpuContext,
        set: &GpuDirections,
        dirs: &[Vec3],
    ) -> Result<Vec<Lookup>, wgpu::BufferAsyncError> {
        let device = &ctx.device;
        if dirs.is_empty() {
            return Ok(Vec::new());
        }
        let input: Vec<[f32; 4]> = dirs.iter().map(|d| d.extend(0.0).into()).collect();
        let in_buf = storage_buffer(
            device,
            "DirectionLookup::dirs",
            &input,
            wgpu::BufferUsages::empty(),
        );
        let out_buf = storage_buffer(
            device,
            "DirectionLookup::out",
            &vec![[u32::MAX; 4]; 2 * dirs.len()],
            wgpu::BufferUsages::COPY_SRC,
        );
        let io_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("DirectionLookup::io_bind_group"),
            layout: &self.io_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: in_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: out_buf.as_entire_binding(),
                },
            ],
        });
        let empty_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("DirectionLookup::empty_bind_group"),
            layout: &self.empty_layout,
            entries: &[],
        });
        let tables_bg = set.bind_group(
            device,
            &self.tables_layout,
            "DirectionLookup::tables_bind_group",
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("DirectionLookup::encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("DirectionLookup::pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &io_bg, &[]);
            pass.set_bind_group(1, &empty_bg, &[]);
            pass.set_bind_group(2, &tables_bg, &[]);
            let (gx, gy) = dispatch_2d(
                dirs.len() as u32,
                WORKGROUP,
                device.limits().max_compute_workgroups_per_dimension,
            );
            pass.dispatch_workgroups(gx, gy, 1);
        }
        ctx.queue.submit(Some(encoder.finish()));
        let out: Vec<[u32; 4]> = read_buffer(device, &ctx.queue, &out_buf)?;
        Ok(out
            .chunks_exact(2)
            .map(|c| Lookup {
                vertices: [c[0][0], c[0][1], c[0][2]],
                weights: [c[1][0], c[1][1], c[1][2]].map(f32::from_bits),
                triangle: c[0][3],
            })
            .collect())
    }
}
