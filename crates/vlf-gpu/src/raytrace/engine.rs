//! The ray engine: closest-hit and any-hit compute kernels (`shaders/raytrace_engine.wgsl`) over
//! batches of rays, against a [`GpuScene`].
//!
//! Bind groups: 0 = the batch selector ([`RtBatch`], dynamic offset), 1 = the scene (BVH nodes
//! and triangles), 2 = rays, hits and queue headers. The host API ([`RayEngine::trace`],
//! [`RayBatch`]) serves tests, benchmarks and host-driven rendering (the paper's model: the host
//! organises rays, the GPU intersects them); the wavefront path tracer drives the same
//! pipelines over its own queues with indirect dispatches.

use wgpu::util::DeviceExt;

use super::{GpuScene, RaytraceError};
use crate::GpuContext;
use crate::layout::{RtBatch, RtQueue};
use crate::readback::read_buffer;
use crate::shaders;
use crate::wgpu_util::{
    compute_pipeline, compute_storage, dispatch_2d, pipeline_layout, uniform_entry,
};
use vlf_core::pathtrace::{Hit, Ray};

/// Invocations per workgroup of every ray-tracing kernel.
pub const WORKGROUP: u32 = 64;

/// Which query a dispatch answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// The nearest hit in `(tmin, tmax)`.
    Closest,
    /// Whether anything is hit in `(tmin, tmax)` (the first hit found is reported).
    Any,
}

/// Pipelines and layouts of the ray engine.
pub struct RayEngine {
    pub(crate) batch_layout: wgpu::BindGroupLayout,
    pub(crate) scene_layout: wgpu::BindGroupLayout,
    pub(crate) rays_layout: wgpu::BindGroupLayout,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
}

impl RayEngine {
    /// Compiles the kernels.
    pub fn new(device: &wgpu::Device) -> Self {
        let batch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("RayEngine::batch_layout"),
            entries: &[uniform_entry::<RtBatch>(
                0,
                wgpu::ShaderStages::COMPUTE,
                true,
            )],
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("RayEngine::scene_layout"),
            entries: &[
                compute_storage(0, true),
                compute_storage(1, true),
                compute_storage(6, true),
            ],
        });
        let rays_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("RayEngine::rays_layout"),
            entries: &[
                compute_storage(0, true),
                compute_storage(1, false),
                // Read only, but `RtQueue::count` is atomic (the path tracer appends to the same
                // queues), and WGSL atomics need read_write storage.
                compute_storage(2, false),
            ],
        });
        let layout = pipeline_layout(
            device,
            "RayEngine::pipeline_layout",
            &[Some(&batch_layout), Some(&scene_layout), Some(&rays_layout)],
        );
        let module = shaders::RAYTRACE_ENGINE.module(device);
        let pipeline = |entry: &str| compute_pipeline(device, "RayEngine", &layout, &module, entry);
        Self {
            closest: pipeline("closest_hit"),
            any: pipeline("any_hit"),
            batch_layout,
            scene_layout,
            rays_layout,
        }
    }

    /// The pipeline of a query.
    pub(crate) fn pipeline(&self, query: Query) -> &wgpu::ComputePipeline {
        match query {
            Query::Closest => &self.closest,
            Query::Any => &self.any,
        }
    }

    /// Bind group 1 over an uploaded scene.
    pub fn scene_bind_group(&self, device: &wgpu::Device, scene: &GpuScene) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("RayEngine::scene_bind_group"),
            layout: &self.scene_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: scene.nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: scene.triangles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: scene.masks.as_entire_binding(),
                },
            ],
        })
    }

    /// Bind group 2 over rays, hits and queue headers.
    pub(crate) fn rays_bind_group(
        &self,
        device: &wgpu::Device,
        label: &str,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        queues: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.rays_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: rays.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: hits.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: queues.as_entire_binding(),
                },
            ],
        })
    }

    /// Bind group 0 over a buffer of [`RtBatch`] entries (bound at a dynamic offset).
    pub(crate) fn batch_bind_group(
        &self,
        device: &wgpu::Device,
        batches: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("RayEngine::batch_bind_group"),
            layout: &self.batch_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: batches,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<RtBatch>() as u64),
                }),
            }],
        })
    }

    /// Intersects `rays` (uploaded, traced, read back) in one call. Infinite `tmax` is fine.
    pub fn trace(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        rays: &[Ray],
        query: Query,
    ) -> Result<Vec<Hit>, RaytraceError> {
        let batch = RayBatch::new(ctx, self, scene, rays)?;
        batch.run(ctx, self, query, 1);
        batch.hits(ctx)
    }
}

/// A batch of rays resident on the GPU, for repeated queries (benchmarks) or one-off tracing.
pub struct RayBatch {
    count: u32,
    hits: wgpu::Buffer,
    batch_bg: wgpu::BindGroup,
    scene_bg: wgpu::BindGroup,
    rays_bg: wgpu::BindGroup,
}

impl RayBatch {
    /// Uploads `rays` (an infinite `tmax` becomes the largest finite `f32`, which WGSL handles
    /// portably).
    pub fn new(
        ctx: &GpuContext,
        engine: &RayEngine,
        scene: &GpuScene,
        rays: &[Ray],
    ) -> Result<Self, RaytraceError> {
        let device = &ctx.device;
        let count = u32::try_from(rays.len()).map_err(|_| RaytraceError::TooLarge {
            what: "ray batch",
            bytes: std::mem::size_of_val(rays) as u64,
            limit: u64::from(u32::MAX),
        })?;
        let limit = device.limits().max_storage_buffer_binding_size;
        let bytes = std::mem::size_of_val(rays) as u64;
        if bytes > limit {
            return Err(RaytraceError::TooLarge {
                what: "ray batch",
                bytes,
                limit,
            });
        }
        let mut upload: Vec<Ray> = rays.to_vec();
        for r in &mut upload {
            if r.tmax > f32::MAX {
                r.tmax = f32::MAX;
            }
        }
        if upload.is_empty() {
            upload.push(Ray::default());
        }
        let rays_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("RayEngine::rays"),
            contents: bytemuck::cast_slice(&upload),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let hits = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("RayEngine::hits"),
            size: (upload.len() * std::mem::size_of::<Hit>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let queues = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("RayEngine::queue"),
            contents: bytemuck::bytes_of(&RtQueue {
                count,
                ..Default::default()
            }),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let batches = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("RayEngine::batch"),
            contents: bytemuck::bytes_of(&RtBatch::default()),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        Ok(Self {
            count,
            batch_bg: engine.batch_bind_group(device, &batches),
            scene_bg: engine.scene_bind_group(device, scene),
            rays_bg: engine.rays_bind_group(
                device,
                "RayEngine::rays_bind_group",
                &rays_buf,
                &hits,
                &queues,
            ),
            hits,
        })
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Submits `repeat` dispatches of `query` over the batch (no wait).
    pub fn run(&self, ctx: &GpuContext, engine: &RayEngine, query: Query, repeat: u32) {
        if self.count == 0 {
            return;
        }
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("RayEngine::encoder"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("RayEngine::pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(engine.pipeline(query));
            pass.set_bind_group(0, &self.batch_bg, &[0]);
            pass.set_bind_group(1, &self.scene_bg, &[]);
            pass.set_bind_group(2, &self.rays_bg, &[]);
            let (x, y) = dispatch_2d(
                self.count,
                WORKGROUP,
                ctx.device.limits().max_compute_workgroups_per_dimension,
            );
            for _ in 0..repeat {
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        ctx.queue.submit(Some(encoder.finish()));
    }

    /// Reads the hits back (waits for the GPU).
    pub fn hits(&self, ctx: &GpuContext) -> Result<Vec<Hit>, RaytraceError> {
        let mut hits: Vec<Hit> = read_buffer(&ctx.device, &ctx.queue, &self.hits)?;
        hits.truncate(self.count as usize);
        Ok(hits)
    }
}
