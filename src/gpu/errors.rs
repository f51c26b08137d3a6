//! Device errors as [`Error`]s: wgpu reports a failed operation (out of
//! memory, a validation failure, a lost device) to the device's
//! uncaptured-error handler, whose default panics. Every operation the
//! solver and the renderer drive runs inside [`guarded`]'s error scopes
//! instead, so a host gets an `Err`, never a panic.

use std::future::Future;

use crate::error::{Error, Result};

/// Runs `f` with the device's out-of-memory, validation and internal
/// errors captured (on this thread; wgpu's error scopes are per thread),
/// and turns the first captured one into an error naming `what` was being
/// done. An out-of-memory error becomes [`Error::OutOfMemory`] with
/// `needed` bytes when the caller knows them, else [`Error::Gpu`]. An
/// error `f` returns itself wins over what the scopes caught, being the
/// more specific.
///
/// The scopes are popped as soon as `f` returns (work after it is outside
/// them); the future resolves when the device has said what they caught:
/// at once on native backends, when the browser resolves its promises on
/// WebGPU.
pub(crate) async fn guarded_async<T>(
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
    let internal = internal.pop();
    let validation = validation.pop();
    let oom = oom.pop();
    let (internal, validation, oom) = (internal.await, validation.await, oom.await);
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

/// [`guarded_async`], waited for: the operations that build and step the
/// solver run inside it.
#[cfg(not(target_arch = "wasm32"))]
pub(crate) fn guarded<T>(
    device: &wgpu::Device,
    what: &str,
    needed: Option<u64>,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    pollster::block_on(guarded_async(device, what, needed, f))
}

/// In a browser nothing can wait for WebGPU's error scopes to resolve, so
/// `f` runs without scopes of its own: a device error is caught by the
/// scopes of the async entry point it runs inside (`GpuSolver::new_async`,
/// [`GpuSolver::step_async`](super::GpuSolver::step_async) …), else it
/// reaches the device's uncaptured-error handler.
#[cfg(target_arch = "wasm32")]
pub(crate) fn guarded<T>(
    _device: &wgpu::Device,
    _what: &str,
    _needed: Option<u64>,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    f()
}

/// In a browser, [`guarded_async`]: the scopes that capture what `f` does,
/// whose own guards run unscoped there. Natively `f` as it is, its own
/// guards capturing what it does (as the blocking forms always did).
pub(crate) async fn guarded_on_web<T>(
    device: &wgpu::Device,
    what: &str,
    needed: Option<u64>,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    #[cfg(target_arch = "wasm32")]
    {
        guarded_async(device, what, needed, f).await
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = (device, what, needed);
        f()
    }
}

/// Waits for `future` in a blocking entry point whose async form is
/// `async_form` (named in the error). Natively it blocks the thread; in a
/// browser, whose event loop must not be blocked (a read-back's map
/// resolves only when the browser runs it), a future not ready at once is
/// an [`Error::Gpu`] that says to await the async form.
pub(crate) fn block_on<T>(async_form: &str, future: impl Future<Output = Result<T>>) -> Result<T> {
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = async_form;
        pollster::block_on(future)
    }
    #[cfg(target_arch = "wasm32")]
    {
        let mut future = std::pin::pin!(future);
        let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
        match future.as_mut().poll(&mut cx) {
            std::task::Poll::Ready(out) => out,
            std::task::Poll::Pending => Err(Error::Gpu(format!(
                "a browser cannot wait for the GPU device: await `{async_form}` instead"
            ))),
        }
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
