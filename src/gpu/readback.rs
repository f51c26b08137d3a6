//! Reading buffers back to the host: staging buffer, `map_async`, a flume
//! channel, `poll`, copy out, drop the view, `unmap`. Never on the stepping
//! path: only tests, the CLI and explicit status checks call it.

use super::errors::{block_on, guarded_async};
use crate::error::{Error, Result};

/// Copies `size` bytes of each `(buffer, offset)` into one staging buffer,
/// waits, and returns their bytes in order. A device error (a lost
/// device, out of memory) is an [`Error`], never a panic. Native only:
/// in a browser it is an error saying to await [`read_buffers_async`].
pub fn read_buffers(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    parts: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Vec<Vec<u8>>> {
    block_on(
        "read_buffers_async",
        read_buffers_async(device, queue, parts),
    )
}

/// [`read_buffers`] as a future. Natively the wait is `device.poll` (the
/// map callback runs inside it), so the future is ready when first polled;
/// on WebGPU the device needs no polling and the future resolves when the
/// browser runs the map callback, so a page's event loop awaits it.
pub async fn read_buffers_async(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    parts: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Vec<Vec<u8>>> {
    let total: u64 = parts.iter().map(|p| p.2).sum();
    let (staging, rx) = guarded_async(device, "a read-back", Some(total), || {
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wgcloth.readback"),
            size: total.max(4),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("wgcloth.readback"),
        });
        let mut at = 0;
        for &(buffer, offset, size) in parts {
            encoder.copy_buffer_to_buffer(buffer, offset, &staging, at, size);
            at += size;
        }
        queue.submit([encoder.finish()]);
        let (tx, rx) = flume::bounded(1);
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Ok((staging, rx))
    })
    .await?;
    // A no-op on WebGPU, where the browser maps the buffer by itself.
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Gpu(format!("waiting for the read-back: {e}")))?;
    rx.recv_async()
        .await
        .map_err(|_| Error::Gpu("the read-back was never mapped".into()))?
        .map_err(|e| Error::Gpu(format!("mapping the read-back: {e}")))?;
    let out = {
        let view = staging
            .get_mapped_range(..)
            .map_err(|e| Error::Gpu(format!("reading the read-back: {e}")))?;
        let mut out = Vec::with_capacity(parts.len());
        let mut at = 0usize;
        for &(_, _, size) in parts {
            out.push(view[at..at + size as usize].to_vec());
            at += size as usize;
        }
        out
    };
    staging.unmap();
    Ok(out)
}
