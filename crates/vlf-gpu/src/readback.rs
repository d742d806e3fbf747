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

/// Reads `buffer` (which needs `COPY_SRC`; its size a multiple of 4) back as a `Vec<T>`,
/// blocking until done: [`read_buffers`] of that one buffer.
pub fn read_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
) -> Result<Vec<T>, wgpu::BufferAsyncError> {
    let encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("Readback::encoder"),
    });
    let parts = read_buffers(device, queue, encoder, &[(buffer, buffer.size())])?;
    Ok(parts
        .first()
        .map_or_else(Vec::new, |p| bytemuck::pod_collect_to_vec(p)))
}

/// Submits `encoder` with copies of every `(buffer, bytes)` of `sources` (each needs
/// `COPY_SRC`; sizes multiples of 4) appended into one staging buffer, and reads them back
/// with one blocking wait: the bytes of each, in order.
pub fn read_buffers(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut encoder: wgpu::CommandEncoder,
    sources: &[(&wgpu::Buffer, u64)],
) -> Result<Vec<Vec<u8>>, wgpu::BufferAsyncError> {
    // 8-byte aligned parts, so that each can be cast to u64 timestamps too.
    let mut offsets = Vec::with_capacity(sources.len());
    let mut size = 0u64;
    for &(_, bytes) in sources {
        offsets.push(size);
        size += bytes.next_multiple_of(8);
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("Readback::staging"),
        size: size.max(8),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    for (&(buffer, bytes), &at) in sources.iter().zip(&offsets) {
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(buffer, 0, &staging, at, bytes);
        }
    }
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
        sources
            .iter()
            .zip(&offsets)
            .map(|(&(_, bytes), &at)| view[at as usize..(at + bytes) as usize].to_vec())
            .collect()
    };
    staging.unmap();
    Ok(out)
}
