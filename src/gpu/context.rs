//! Opening a device: a convenience for the CLI, examples and tests. The
//! solver never calls this; it borrows whatever device its host made.

use crate::error::{Error, Result};

/// An adapter with its device and queue.
#[derive(Debug)]
pub struct GpuContext {
    /// The adapter (for its info and limits).
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl GpuContext {
    /// Opens an adapter: the first whose name contains `name`
    /// (case-insensitive) if given, else the one named by the
    /// `WGPU_ADAPTER_NAME` environment variable, else the default
    /// high-performance adapter. Backends come from `WGPU_BACKEND` (default:
    /// Vulkan, Metal, DX12). The device gets the adapter's own limits. The
    /// instance skips wgpu's validation of indirect dispatches (see the
    /// comment inside; a host that embeds the solver may do the same).
    pub fn new(name: Option<&str>) -> Result<GpuContext> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        // wgpu validates each indirect dispatch with a compute pass of its
        // own (on by default, release builds too). The solver's only
        // indirect dispatches are its CG kernels', whose arguments its own
        // kernels write: zero or a workgroup count checked against the
        // device's limits when the solver is built. On lavapipe the extra
        // passes cost 5–10 % of a 128² implicit step, so this context turns
        // the check off; `WGPU_VALIDATION_INDIRECT_CALL=1` turns it on.
        desc.flags = wgpu::InstanceFlags::from_build_config()
            .difference(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL)
            .with_env();
        let instance = wgpu::Instance::new(desc);
        let wanted = name
            .map(str::to_owned)
            .or_else(|| std::env::var("WGPU_ADAPTER_NAME").ok());
        let adapter = match wanted {
            Some(want) => {
                let adapters =
                    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
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
                    })?
            }
            None => pollster::block_on(
                instance.request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::from_env()
                        .unwrap_or(wgpu::PowerPreference::HighPerformance),
                    force_fallback_adapter: false,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                }),
            )
            .map_err(|e| Error::NoAdapter {
                message: e.to_string(),
            })?,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("wgcloth.device"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| Error::NoAdapter {
            message: format!("{}: {e}", adapter.get_info().name),
        })?;
        Ok(GpuContext {
            adapter,
            device,
            queue,
        })
    }

    /// `"NAME (BACKEND, TYPE)"`, for reports.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
    }
}
