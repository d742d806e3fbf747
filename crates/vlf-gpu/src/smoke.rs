//! The smoke pass: `y = a·x + b` over a buffer, with the invocation index written alongside.
//! It proves the device, shader loading, our binding conventions and readback work end to end
//! (`vlf-bake gpu-check`, `tests/suite/gpu_smoke.rs`).

use crate::layout::SmokeParams;
use crate::readback::{read_buffer, storage_buffer};
use crate::shaders;
use crate::wgpu_util::{
    buffer_bind_group, compute_pipeline, compute_storage, dispatch_2d, pipeline_layout,
    uniform_entry,
};
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
            entries: &[uniform_entry::<SmokeParams>(
                0,
                wgpu::ShaderStages::COMPUTE,
                false,
            )],
        });
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Smoke::pass_layout"),
            entries: &[compute_storage(0, true), compute_storage(1, false)],
        });
        let layout = pipeline_layout(
            device,
            "Smoke::pipeline_layout",
            &[Some(&globals_layout), Some(&pass_layout)],
        );
        let module = shaders::SMOKE.module(device);
        let pipeline = compute_pipeline(device, "Smoke", &layout, &module, "main");
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
        let globals_bg = buffer_bind_group(
            device,
            "Smoke::globals_bind_group",
            &self.globals_layout,
            &[&globals],
        );
        let pass_bg = buffer_bind_group(
            device,
            "Smoke::pass_bind_group",
            &self.pass_layout,
            &[&x_buf, &y_buf],
        );
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
