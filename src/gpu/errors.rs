//! Device errors as [`Error`]s: wgpu reports a failed operation (out of
//! memory, a validation failure, a lost device) to the device's
//! uncaptured-error handler, whose default panics. Every operation the
//! solver and the renderer drive runs inside [`guarded`]'s error scopes
//! instead, so a host gets an `Err`, never a panic.

use crate::error::{Error, Result};

/// Runs `f` with the device's out-of-memory, validation and internal
/// errors captured (on this thread; wgpu's error scopes are per thread),
/// and turns the first captured one into an error naming `what` was being
/// done. An out-of-memory error becomes [`Error::OutOfMemory`] with
/// `needed` bytes when the caller knows them, else [`Error::Gpu`]. An
/// error `f` returns itself wins over what the scopes caught, being the
/// more specific.
pub(crate) fn guarded<T>(
    device: &wgpu::Device,
    what: &str,
    needed: Option<u64>,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let internal = device.push_error_scope(wgpu::ErrorFilter::Internal);
    let out = f();
    // Popped in reverse order of pushing, as wgpu requires.
    let internal = pollster::block_on(internal.pop());
    let validation = pollster::block_on(validation.pop());
    let oom = pollster::block_on(oom.pop());
    let out = out?;
    // An allocation that failed makes later operations on it invalid too:
    // the out-of-memory error is the cause.
    if let Some(e) = oom {
        return Err(match needed {
            Some(needed) => Error::OutOfMemory {
                what: what.to_string(),
                needed,
                available: None,
                limit: format!("the GPU device could not allocate it ({})", one_line(&e)),
            },
            None => Error::Gpu(format!("{what}: out of device memory: {}", one_line(&e))),
        });
    }
    match validation.or(internal) {
        Some(e) => Err(Error::Gpu(format!("{what}: {}", one_line(&e)))),
        None => Ok(out),
    }
}

/// A wgpu error on one line: its message and causes, which wgpu prints on
/// lines of their own under `Caused by:`, joined by `: `.
pub(crate) fn one_line(e: &wgpu::Error) -> String {
    e.to_string()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "Caused by:")
        .collect::<Vec<_>>()
        .join(": ")
}
