//! Copying GPU buffers back to the CPU.

use wgpu::util::DeviceExt;

/// Creates a storage buffer initialised with `data`, labelled `label`.
pub fn storage_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(data),
        usage: wgpu::BufferUsages::STORAGE | extra,
    })
}

/// Reads `buffer` (which needs `COPY_SRC`) back as a `Vec<T>`, blocking until done.
pub fn read_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
) -> Result<Vec<T>, wgpu::BufferAsyncError> {
    let size = buffer.size();
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("Readback::staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("Readback::encoder"),
    });
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    queue.submit(Some(encoder.finish()));
    let (tx, rx) = std::sync::mpsc::channel();
    staging
        .slice(..)
        .map_async(wgpu::MapMode::Read, move |r| drop(tx.send(r)));
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    rx.recv().map_err(|_| wgpu::BufferAsyncError)??;
    let out = {
        let view = staging
            .slice(..)
            .get_mapped_range()
            .map_err(|_| wgpu::BufferAsyncError)?;
        bytemuck::cast_slice(&view).to_vec()
    };
    staging.unmap();
    Ok(out)
}
