//! Opening a device: a convenience for the CLI, examples and tests. The
//! solver never calls this; it borrows whatever device its host made.

use std::future::Future;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::pin::pin;
use std::sync::{Arc, Mutex, PoisonError};
use std::task::Poll;

use super::errors::{block_on, one_line};
use super::kernels::GpuKernels;
use super::pipeline_cache;
use crate::error::{Error, Result};

/// The backend names `WGPU_BACKEND` may list (comma-separated), as wgpu
/// spells them; `vk`, `mtl`, `d3d12`, `opengl` and `gles` are accepted
/// too.
pub const BACKEND_NAMES: &str = "vulkan, metal, dx12, gl, webgpu, noop";

/// An adapter with its device and queue.
#[derive(Debug)]
pub struct GpuContext {
    /// The adapter (for its info and limits).
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The first device error no error scope captured, or the device's
    /// loss (see [`GpuContext::check`]).
    fault: Arc<Mutex<Option<String>>>,
    /// The device's kernel library (see [`GpuContext::kernels`]).
    kernels: GpuKernels,
    /// The file its pipeline cache is kept in (see
    /// [`GpuContext::keep_pipelines`]).
    kept: Option<PathBuf>,
}

/// The backends `WGPU_BACKEND` names, or `None` when it is not set. Unlike
/// wgpu's own reading, which skips a name it does not know (and with no
/// name left finds no adapter), an unknown name is an error naming the
/// variable and the names allowed.
pub fn backends_from_env() -> Result<Option<wgpu::Backends>> {
    let Some(value) = std::env::var_os("WGPU_BACKEND") else {
        return Ok(None);
    };
    let invalid = |got: String| Error::InvalidParameter {
        key: "WGPU_BACKEND".into(),
        allowed: format!(
            "a comma-separated list of {BACKEND_NAMES} \
             (the environment variable picks the graphics APIs searched)"
        ),
        got,
    };
    let text = value
        .into_string()
        .map_err(|v| invalid(format!("{v:?} (not UTF-8)")))?;
    let mut backends = wgpu::Backends::empty();
    for name in text.split(',') {
        let one = wgpu::Backends::from_comma_list(name);
        if one.is_empty() {
            return Err(invalid(format!(
                "`{text}` (`{}` is not a backend)",
                name.trim()
            )));
        }
        backends |= one;
    }
    Ok(Some(backends))
}

/// The first adapter whose name contains `want` (case-insensitive).
async fn find_adapter(instance: &wgpu::Instance, want: &str) -> Result<wgpu::Adapter> {
    let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
    let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
    let lower = want.to_lowercase();
    adapters
        .into_iter()
        .find(|a| a.get_info().name.to_lowercase().contains(&lower))
        .ok_or_else(|| Error::NoAdapter {
            message: format!(
                "none matches `{want}` (available: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        })
}

/// Awaits `call`, turning a panic inside it (wgpu's or the driver's, in
/// any of its polls) into `failed(its message)`. Whatever `call` touched is
/// dropped or not used again, so a half-done call leaves nothing behind to
/// observe.
async fn unwound<T>(
    call: impl Future<Output = Result<T>>,
    failed: impl FnOnce(String) -> Error,
) -> Result<T> {
    let mut call = pin!(call);
    let mut failed = Some(failed);
    std::future::poll_fn(
        |cx| match catch_unwind(AssertUnwindSafe(|| call.as_mut().poll(cx))) {
            Ok(poll) => poll,
            Err(payload) => {
                let message = payload
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "a panic without a message".to_string());
                let message = one_line_text(&message);
                Poll::Ready(Err(match failed.take() {
                    Some(failed) => failed(message),
                    None => Error::Gpu(message),
                }))
            }
        },
    )
    .await
}

/// `text` on one line, without the full stop a driver's message may end in
/// (the message goes inside a sentence).
fn one_line_text(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .trim_end_matches('.')
        .to_string()
}

/// Why a device could not be opened, as a user can act on it: a driver
/// out of memory says so, and what to do.
fn opening_failure(message: &str) -> String {
    let text = one_line_text(message);
    if text.to_lowercase().contains("memory") {
        format!(
            "out of memory ({text}); free memory, or raise the process's limit \
             (ulimit -v) if one is set"
        )
    } else {
        text
    }
}

impl GpuContext {
    /// Opens an adapter: the first whose name contains `name`
    /// (case-insensitive) if given, else the one named by the
    /// `WGPU_ADAPTER_NAME` environment variable, else the default
    /// high-performance adapter. Backends come from `WGPU_BACKEND` (default:
    /// Vulkan, Metal, DX12; a name not in [`BACKEND_NAMES`] is an
    /// [`Error::InvalidParameter`]). A device error no error scope captures
    /// is recorded rather than panicking, and so is the device's loss:
    /// [`GpuContext::check`] reports them. The device gets the adapter's own limits. The
    /// instance skips wgpu's validation of indirect dispatches (see the
    /// comment inside; a host that embeds the solver may do the same).
    ///
    /// Native only: a browser cannot wait for the adapter, so there it is
    /// an error saying to await [`GpuContext::new_async`].
    pub fn new(name: Option<&str>) -> Result<GpuContext> {
        GpuContext::with_features(name, wgpu::Features::empty())
    }

    /// [`GpuContext::new`], also asking for those of `features` the adapter
    /// has (the profiler's [`Timestamps::FEATURES`](super::Timestamps::FEATURES));
    /// the device's features tell which it got.
    pub fn with_features(name: Option<&str>, features: wgpu::Features) -> Result<GpuContext> {
        block_on(
            "GpuContext::with_features_async",
            GpuContext::with_features_async(name, features),
        )
    }

    /// [`GpuContext::new`] as a future, for a browser's event loop (in a
    /// page, the environment variables are never set: the browser's
    /// WebGPU adapter is the default).
    pub async fn new_async(name: Option<&str>) -> Result<GpuContext> {
        GpuContext::with_features_async(name, wgpu::Features::empty()).await
    }

    /// [`GpuContext::with_features`] as a future.
    pub async fn with_features_async(
        name: Option<&str>,
        features: wgpu::Features,
    ) -> Result<GpuContext> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends_from_env()?.unwrap_or(wgpu::Backends::PRIMARY);
        // wgpu validates each indirect dispatch with a compute pass of its
        // own (on by default, release builds too). The solver's only
        // indirect dispatches are its CG kernels', whose arguments its own
        // kernels write: zero or a workgroup count checked against the
        // device's limits when the solver is built. The extra passes would
        // cost an implicit step about as much as a few CG iterations, so
        // this context turns the check off;
        // `WGPU_VALIDATION_INDIRECT_CALL=1` turns it on.
        desc.flags = wgpu::InstanceFlags::from_build_config()
            .difference(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL)
            .with_env();
        let instance = wgpu::Instance::new(desc);
        let wanted = name
            .map(str::to_owned)
            .or_else(|| std::env::var("WGPU_ADAPTER_NAME").ok());
        // The driver is called through wgpu, which panics on some of its
        // failures (out of memory under `ulimit -v`, among them): each call
        // here is caught, so that no panic reaches the host.
        let adapter = unwound(
            async {
                match wanted {
                    Some(want) => find_adapter(&instance, &want).await,
                    None => instance
                        .request_adapter(&wgpu::RequestAdapterOptions {
                            power_preference: wgpu::PowerPreference::from_env()
                                .unwrap_or(wgpu::PowerPreference::HighPerformance),
                            force_fallback_adapter: false,
                            compatible_surface: None,
                            apply_limit_buckets: false,
                        })
                        .await
                        .map_err(|e| Error::NoAdapter {
                            message: e.to_string(),
                        }),
                }
            },
            |message| Error::NoAdapter {
                message: format!("the graphics driver failed while looking for one ({message})"),
            },
        )
        .await?;
        let adapter_name = adapter.get_info().name;
        let unavailable = |message: String| Error::DeviceUnavailable {
            adapter: adapter_name.clone(),
            message: opening_failure(&message),
        };
        let (device, queue) = unwound(
            async {
                adapter
                    .request_device(&wgpu::DeviceDescriptor {
                        label: Some("wgcloth.device"),
                        // Compiled pipelines can then be kept between runs (Vulkan).
                        required_features: adapter.features()
                            & (wgpu::Features::PIPELINE_CACHE | features),
                        required_limits: adapter.limits(),
                        experimental_features: wgpu::ExperimentalFeatures::disabled(),
                        memory_hints: wgpu::MemoryHints::Performance,
                        trace: wgpu::Trace::Off,
                    })
                    .await
                    .map_err(|e| unavailable(e.to_string()))
            },
            unavailable,
        )
        .await?;
        // wgpu's default handlers panic; this context records the first
        // error instead, for `check` to report.
        let fault = Arc::new(Mutex::new(None));
        let record = |fault: &Arc<Mutex<Option<String>>>, message: String| {
            let mut slot = fault.lock().unwrap_or_else(PoisonError::into_inner);
            slot.get_or_insert(message);
        };
        let sink = Arc::clone(&fault);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| record(&sink, one_line(&e))));
        let sink = Arc::clone(&fault);
        device.set_device_lost_callback(move |reason, message| {
            record(
                &sink,
                format!("the GPU device was lost ({reason:?}): {message}"),
            );
        });
        let kernels = unwound(async { Ok(GpuKernels::new(&device)) }, unavailable).await?;
        Ok(GpuContext {
            adapter,
            queue,
            kernels,
            device,
            fault,
            kept: None,
        })
    }

    /// The device's kernel library: solvers built with
    /// [`GpuSolver::with_kernels`](super::GpuSolver::with_kernels)`(context.kernels(), …)`
    /// share their pipelines (and the cache of
    /// [`GpuContext::keep_pipelines`]).
    pub fn kernels(&self) -> &GpuKernels {
        &self.kernels
    }

    /// Keeps the compiled pipelines between runs in `dir` (see
    /// [`pipeline_cache::default_dir`] for the CLI's): replaces
    /// [`GpuContext::kernels`] by a library whose pipeline cache is seeded
    /// with the adapter's cache file there if it holds an intact cache
    /// (anything else is ignored); [`GpuContext::save_pipelines`] writes it
    /// back. Returns `false`, doing nothing, where the backend keeps no
    /// pipeline cache (all but Vulkan).
    pub fn keep_pipelines(&mut self, dir: &Path) -> bool {
        let Some(path) = pipeline_cache::file(dir, &self.adapter.get_info()) else {
            return false;
        };
        if !self
            .device
            .features()
            .contains(wgpu::Features::PIPELINE_CACHE)
        {
            return false;
        }
        let data = pipeline_cache::load(&path);
        self.kernels = GpuKernels::with_cache(&self.device, data.as_deref());
        self.kept = Some(path);
        true
    }

    /// Writes the pipeline cache [`GpuContext::keep_pipelines`] seeded
    /// back to its file, atomically (nothing without one).
    pub fn save_pipelines(&self) -> Result<()> {
        let Some(path) = &self.kept else {
            return Ok(());
        };
        match self.kernels.cache_data() {
            Some(data) => pipeline_cache::save(path, &data),
            None => Ok(()),
        }
    }

    /// The first device error that no error scope captured (the library
    /// captures its own; this catches anything else done with the device),
    /// or the device's loss, as [`Error::Gpu`]. Polls the device first,
    /// without waiting, so that a pending loss is seen.
    pub fn check(&self) -> Result<()> {
        // Without waiting: lets a pending loss reach its callback.
        if let Err(e) = self.device.poll(wgpu::PollType::Poll) {
            return Err(Error::Gpu(format!("polling the GPU device: {e}")));
        }
        let fault = self.fault.lock().unwrap_or_else(PoisonError::into_inner);
        match fault.as_ref() {
            Some(message) => Err(Error::Gpu(message.clone())),
            None => Ok(()),
        }
    }

    /// `"NAME (BACKEND, TYPE)"`, for reports.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
    }
}
