//! The host's side, as a game has it: its own instance, adapter, device and
//! queue, the window's surface configured in the format the surface
//! prefers, and one command encoder per frame holding the solver's steps,
//! the normals and the render pass onto the swap-chain texture.

use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};

use anyhow::{bail, Context as _};
use winit::window::Window;

use wgcloth::gpu::GpuKernels;
use wgcloth::render::{self, Camera, FrameTarget, Renderer, RendererFormats};

use crate::sim::Sim;

/// The device, the window's swap chain and what draws into it.
pub struct Host {
    surface: wgpu::Surface<'static>,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    /// The depth buffer the window's pass uses, and the offscreen colour
    /// target a screenshot is drawn into when the swap chain cannot be
    /// copied from.
    target: FrameTarget,
    renderer: Renderer,
    /// The swap-chain textures can be copied from (`COPY_SRC`): a
    /// screenshot reads the very texture presented.
    copyable: bool,
    /// The first device error nothing else caught.
    fault: Arc<Mutex<Option<String>>>,
    /// A one-line description of the adapter.
    pub adapter: String,
    /// The [`Sim::generation`] whose solver the renderer's render meshes
    /// follow.
    generation: u64,
}

impl Host {
    /// Opens a device that can present to `window`, configures its surface
    /// and builds `scene`'s renderer and cloth on that device. With
    /// `offscreen_screenshots`, screenshots are redrawn offscreen even
    /// where the swap chain could be copied (to test that path).
    pub fn new(
        window: Arc<Window>,
        scene: &wgcloth::Scene,
        offscreen_screenshots: bool,
    ) -> anyhow::Result<(Host, Sim)> {
        // wgpu's defaults, adjusted by its environment variables; the
        // backends, unless `WGPU_BACKEND` names them, are those
        // `GpuContext` searches (Vulkan, Metal, DX12), not OpenGL.
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let size = window.inner_size();
        let surface = instance
            .create_surface(window)
            .context("creating the window's surface")?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .context("no adapter can present to the window (on Linux without a GPU, install Mesa's lavapipe: mesa-vulkan-drivers)")?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("viewer.device"),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .with_context(|| format!("opening {}", adapter.get_info().name))?;
        // A host's own handler: record the first error nothing caught and
        // stop at the end of the frame, instead of wgpu's default panic.
        let fault = Arc::new(Mutex::new(None));
        let sink = Arc::clone(&fault);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(PoisonError::into_inner);
            slot.get_or_insert(e.to_string());
        }));
        let caps = surface.get_capabilities(&adapter);
        let Some(&format) = caps.formats.first() else {
            bail!(
                "the window's surface is incompatible with {}",
                adapter.get_info().name
            );
        };
        let copyable =
            caps.usages.contains(wgpu::TextureUsages::COPY_SRC) && !offscreen_screenshots;
        let config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .context("the window's surface has no configuration on this adapter")?;
        let config = wgpu::SurfaceConfiguration {
            format,
            usage: if copyable {
                config.usage | wgpu::TextureUsages::COPY_SRC
            } else {
                config.usage
            },
            present_mode: wgpu::PresentMode::AutoVsync,
            ..config
        };
        surface.configure(&device, &config);
        // The library the solvers take their pipelines from: an integrator
        // switch compiles only what the new one adds.
        let sim = Sim::new(scene.clone(), &GpuKernels::new(&device), &queue)?;
        let formats = RendererFormats {
            color: format,
            depth: render::DEPTH_FORMAT,
        };
        let camera = Camera::for_scene(scene, sim.model(), aspect(&config));
        let mut renderer =
            Renderer::with_formats(&device, &queue, &scene.params, &camera, formats)?;
        renderer.set_embeddings(&sim.solver, sim.embeddings())?;
        renderer.set_cloth_colors(&device, sim.model(), &scene.cloth_colors());
        let target = FrameTarget::with_formats(&device, config.width, config.height, formats);
        let info = adapter.get_info();
        let host = Host {
            surface,
            target,
            renderer,
            copyable,
            fault,
            adapter: format!("{} ({:?}), {format:?}", info.name, info.backend),
            generation: sim.generation,
            device,
            queue,
            config,
        };
        Ok((host, sim))
    }

    /// Width / height of the swap chain.
    pub fn aspect(&self) -> f32 {
        aspect(&self.config)
    }

    /// The swap chain's size \[pixels\].
    pub fn size(&self) -> (u32, u32) {
        (self.config.width, self.config.height)
    }

    /// Follows the window to `width` × `height` \[pixels\] (a minimised
    /// window's zero size is skipped).
    pub fn resize(&mut self, width: u32, height: u32) {
        if width == 0 || height == 0 || (width, height) == self.size() {
            return;
        }
        self.config.width = width;
        self.config.height = height;
        self.surface.configure(&self.device, &self.config);
        self.target =
            FrameTarget::with_formats(&self.device, width, height, self.renderer.formats());
    }

    /// One frame: `steps` solver steps (none when paused) and the cloth
    /// drawn with `camera`, in one encoder and one submit, then presented.
    /// With `screenshot`, the presented picture is also written there as a
    /// PNG. Returns whether a frame was presented (a swap chain that is
    /// momentarily unavailable skips it).
    pub fn frame(
        &mut self,
        sim: &mut Sim,
        camera: &Camera,
        steps: u32,
        screenshot: Option<&Path>,
    ) -> anyhow::Result<bool> {
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(false)
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.surface.configure(&self.device, &self.config);
                return Ok(false);
            }
            other => bail!("the window's swap chain failed: {other:?}"),
        };
        let view = texture.texture.create_view(&Default::default());
        self.renderer.set_camera(camera);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("viewer.frame"),
            });
        if steps > 0 {
            sim.advance(&mut encoder, steps, f64::from(steps) * sim.dt())?;
            // Colliders drawn where the frame's steps leave them.
            let (spheres, capsules) = sim.solver.colliders();
            self.renderer.set_colliders(&spheres, &capsules);
        }
        // A reset or an integrator switch built a new solver: its own
        // render meshes.
        if sim.generation != self.generation {
            self.renderer
                .set_embeddings(&sim.solver, sim.embeddings())?;
            self.generation = sim.generation;
        }
        self.renderer.encode_render_meshes(&mut encoder);
        {
            let mut pass = self
                .renderer
                .begin_pass(&mut encoder, &view, &self.target.depth_view);
            self.renderer.draw(&mut pass, &sim.solver);
        }
        let offscreen = screenshot.is_some() && !self.copyable;
        if offscreen {
            // The same frame once more, into a target that can be copied.
            self.renderer
                .encode_frame(&mut encoder, &sim.solver, &self.target);
        }
        self.queue.submit([encoder.finish()]);
        if let Some(path) = screenshot {
            let shown = if offscreen {
                &self.target.color
            } else {
                &texture.texture
            };
            self.save(shown, path)?;
        }
        self.queue.present(texture);
        self.check()?;
        Ok(true)
    }

    /// Writes `texture` (of the swap chain's format) as an RGBA PNG: its
    /// bytes are the picture's on an 8-bit RGBA or BGRA format, sRGB or not
    /// (see `RendererFormats`).
    fn save(&self, texture: &wgpu::Texture, path: &Path) -> anyhow::Result<()> {
        let bgra = bgra(texture.format())?;
        let mut rgba = render::read_rgba(&self.device, &self.queue, texture)?;
        if bgra {
            rgba.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
        }
        // `--screenshot out/viewer.png` on a fresh clone: out/ need not exist.
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        render::write_png(&render::Frame {
            path: path.to_path_buf(),
            width: texture.width(),
            height: texture.height(),
            rgba,
        })
        .with_context(|| format!("writing the screenshot {}", path.display()))
    }

    /// Fails with the first device error nothing else caught.
    pub fn check(&self) -> anyhow::Result<()> {
        let fault = self.fault.lock().unwrap_or_else(PoisonError::into_inner);
        match fault.as_ref() {
            Some(e) => bail!("device error: {e}"),
            None => Ok(()),
        }
    }

    /// Refuses, before any frame runs, a swap chain no screenshot can be
    /// taken of.
    pub fn check_screenshot(&self) -> anyhow::Result<()> {
        bgra(self.config.format).map(|_| ())
    }

    /// Whether a screenshot reads the swap-chain texture itself.
    pub fn copies_swap_chain(&self) -> bool {
        self.copyable
    }
}

/// Whether a screenshot of a `format` texture has its bytes in BGRA order
/// (else RGBA); an error for a format that is not 8-bit RGBA or BGRA.
fn bgra(format: wgpu::TextureFormat) -> anyhow::Result<bool> {
    use wgpu::TextureFormat as F;
    match format {
        F::Rgba8Unorm | F::Rgba8UnormSrgb => Ok(false),
        F::Bgra8Unorm | F::Bgra8UnormSrgb => Ok(true),
        other => {
            bail!("screenshots are taken of 8-bit RGBA or BGRA swap chains; this one is {other:?}")
        }
    }
}

fn aspect(config: &wgpu::SurfaceConfiguration) -> f32 {
    config.width as f32 / config.height as f32
}
