//! The smoke pass: `y = a·x + b` over a buffer, with the invocation index written alongside.
//! It proves the device, shader loading, our binding conventions and readback work end to end.

use crate::layout::SmokeParams;
use crate::passes::dispatch_2d;
use crate::readback::{read_buffer, storage_buffer};
use crate::shaders;
use wgpu::util::DeviceExt;

pub struct SmokePass {
    globals_layout: wgpu::BindGroupLayout,
    pass_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

const WORKGROUP: u32 = 64;

impl SmokePass {
    pub fn new(device: &wgpu::Device) -> Self {
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Smoke::globals_layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<SmokeParams>() as u64
                    ),
                },
                count: None,
            }],
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Smoke::pass_layout"),
            entries: &[storage(0, true), storage(1, false)],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Smoke::pipeline_layout"),
            bind_group_layouts: &[Some(&globals_layout), Some(&pass_layout)],
            immediate_size: 0,
        });
        let module = shaders::SMOKE.module(device);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("Smoke::pipeline"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            globals_layout,
            pass_layout,
            pipeline,
        }
    }

    /// Runs the pass on `xs` and returns `(a·x + b, index)` per element.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        a: f32,
        b: f32,
        xs: &[f32],
    ) -> Result<Vec<[f32; 2]>, wgpu::BufferAsyncError> {
        let count = xs.len() as u32;
        let params = SmokeParams {
            a,
            b,
            count,
            _pad: 0,
        };
        let globals = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("Smoke::globals"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let x_buf = storage_buffer(device, "Smoke::xs", xs, wgpu::BufferUsages::empty());
        let init = vec![[f32::NAN; 2]; xs.len().max(1)];
        let y_buf = storage_buffer(device, "Smoke::ys", &init, wgpu::BufferUsages::COPY_SRC);
        let globals_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Smoke::globals_bind_group"),
            layout: &self.globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let pass_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Smoke::pass_bind_group"),
            layout: &self.pass_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: x_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: y_buf.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Smoke::encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("Smoke::pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &globals_bg, &[]);
            pass.set_bind_group(1, &pass_bg, &[]);
            let (gx, gy) = dispatch_2d(
                count,
                WORKGROUP,
                device.limits().max_compute_workgroups_per_dimension,
            );
            pass.dispatch_workgroups(gx, gy, 1);
        }
        queue.submit(Some(encoder.finish()));
        let mut out: Vec<[f32; 2]> = read_buffer(device, queue, &y_buf)?;
        out.truncate(xs.len());
        Ok(out)
    }
}
