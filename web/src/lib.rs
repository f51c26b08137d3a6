//! wgcloth in a browser: a built-in scene stepped by the GPU solver on the
//! page's WebGPU device and drawn into a canvas straight from the solver's
//! buffers, with the check `index.html?scene=NAME&steps=N&check=1` runs
//! (the GPU's steps against the `f32` CPU reference compiled into the
//! page; see `docs/web.md`).
//!
//! JavaScript (`web/main.js`) drives a [`Page`]: it calls one method at a
//! time and awaits it, so the page's state is never borrowed twice.
#![cfg(target_arch = "wasm32")]

mod cloth;
// The viewer example's picking geometry (ray under a pixel, nearest
// particle, drag target) and integrator hand-over, shared rather than
// copied.
#[path = "../../examples/viewer/handover.rs"]
mod handover;
#[path = "../../examples/viewer/pick.rs"]
mod pick;

use std::cell::RefCell;
use std::rc::Rc;

use js_sys::{Object, Promise, Reflect};
use wasm_bindgen::prelude::*;
use wasm_bindgen_futures::future_to_promise;
use wgcloth::glam::{Vec2, Vec3};
use wgcloth::params::FixupMethod;
use wgcloth::{CpuSolver, GpuSolver, Scene};

use cloth::Cloth;

/// The page's device, canvas and cloth.
struct State {
    canvas: web_sys::HtmlCanvasElement,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: String,
    /// The shared kernel library: a scene or integrator switch compiles
    /// only the variants not yet built.
    kernels: wgcloth::gpu::GpuKernels,
    depth: wgpu::TextureView,
    cloth: Option<Cloth>,
}

/// The page: one WebGPU device drawing into one canvas.
#[wasm_bindgen]
pub struct Page {
    state: Rc<RefCell<State>>,
}

/// The built-in scenes' names, for the picker.
#[wasm_bindgen(js_name = sceneNames)]
pub fn scene_names() -> Vec<String> {
    Scene::builtin_names()
        .iter()
        .map(|s| (*s).to_string())
        .collect()
}

/// A JavaScript error with the library's message.
fn js_error(e: impl std::fmt::Display) -> JsValue {
    js_sys::Error::new(&e.to_string()).into()
}

/// Milliseconds on the page's clock.
fn now_ms() -> f64 {
    web_sys::window()
        .and_then(|w| w.performance())
        .map_or(0.0, |p| p.now())
}

/// Sets `key` of `object` to `value`.
fn set(object: &Object, key: &str, value: impl Into<JsValue>) {
    // Reflect::set fails only on a frozen object or a throwing setter,
    // neither of which a fresh `Object` has.
    let _ = Reflect::set(object, &key.into(), &value.into());
}

/// Runs `body` on the page's state, as a promise. A second call while one
/// is pending is refused (JavaScript awaits each call).
#[allow(
    clippy::await_holding_refcell_ref,
    reason = "the borrow is the call's hold on the state; a call made meanwhile is refused by try_borrow_mut, never a panic"
)]
fn on_state<F, T>(state: &Rc<RefCell<State>>, body: F) -> Promise
where
    F: for<'a> FnOnce(
            &'a mut State,
        ) -> std::pin::Pin<
            Box<dyn std::future::Future<Output = Result<T, JsValue>> + 'a>,
        > + 'static,
    T: Into<JsValue>,
{
    let state = Rc::clone(state);
    future_to_promise(async move {
        let mut state = state
            .try_borrow_mut()
            .map_err(|_| js_error("the page is busy with another call"))?;
        body(&mut state).await.map(Into::into)
    })
}

#[wasm_bindgen]
impl Page {
    /// Opens the browser's WebGPU adapter (the device gets its limits) and
    /// configures `canvas` for it. `adapter_name` names the adapter where
    /// wgpu's adapter info has no name (browsers leave its description
    /// empty; the page passes WebGPU's vendor and architecture).
    pub async fn open(
        canvas: web_sys::HtmlCanvasElement,
        adapter_name: String,
    ) -> Result<Page, JsValue> {
        std::panic::set_hook(Box::new(|info| {
            web_sys::console::error_1(&format!("wgcloth panicked: {info}").into());
        }));
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::BROWSER_WEBGPU;
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(wgpu::SurfaceTarget::Canvas(canvas.clone()))
            .map_err(js_error)?;
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: Some(&surface),
                apply_limit_buckets: false,
            })
            .await
            .map_err(|e| js_error(format!("no WebGPU adapter: {e}")))?;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("wgcloth.page"),
                required_limits: adapter.limits(),
                ..Default::default()
            })
            .await
            .map_err(|e| js_error(format!("no WebGPU device: {e}")))?;
        // An error no async form's scopes captured goes to the console.
        device.on_uncaptured_error(std::sync::Arc::new(|e: wgpu::Error| {
            web_sys::console::error_1(&format!("wgcloth: device error: {e}").into());
        }));
        let (width, height) = (canvas.width().max(1), canvas.height().max(1));
        let config = surface
            .get_default_config(&adapter, width, height)
            .ok_or_else(|| js_error("the canvas cannot show this adapter's output"))?;
        surface.configure(&device, &config);
        let depth = cloth::depth_view(&device, width, height);
        let info = adapter.get_info();
        let adapter_name = match (info.name.is_empty(), adapter_name.is_empty()) {
            (false, _) => info.name,
            (true, false) => adapter_name,
            (true, true) => format!("{:?}", info.backend),
        };
        let kernels = wgcloth::gpu::GpuKernels::new(&device);
        Ok(Page {
            state: Rc::new(RefCell::new(State {
                canvas,
                surface,
                config,
                device,
                queue,
                adapter: adapter_name,
                kernels,
                depth,
                cloth: None,
            })),
        })
    }

    /// The adapter's name (WebGPU's adapter info; may be empty in a
    /// browser that hides it, then the backend).
    pub fn adapter(&self) -> String {
        self.state.borrow().adapter.clone()
    }

    /// Loads built-in scene `name` with `integrator` (its own if empty)
    /// and, for a grid cloth, `resolution` × `resolution` particles at the
    /// scene's spacing and particle mass (its own resolution if 0). Resolves to the particle count.
    pub fn load(&self, name: String, integrator: String, resolution: u32) -> Promise {
        on_state(&self.state, move |s| {
            Box::pin(async move {
                let cloth = s.build(&name, &integrator, resolution).await?;
                let particles = cloth.solver.particle_count();
                s.cloth = Some(cloth);
                s.draw()?;
                Ok(particles)
            })
        })
    }

    /// Switches the running cloth to `integrator`, keeping its state.
    #[wasm_bindgen(js_name = setIntegrator)]
    pub fn set_integrator(&self, integrator: String) -> Promise {
        on_state(&self.state, move |s| {
            Box::pin(async move {
                let integrator = cloth::integrator(&integrator)?;
                let (queue, kernels) = (s.queue.clone(), s.kernels.clone());
                let cloth = s.cloth_mut()?;
                cloth
                    .switch(&kernels, &queue, integrator)
                    .await
                    .map_err(js_error)?;
                Ok(JsValue::UNDEFINED)
            })
        })
    }

    /// The running cloth's integrator.
    pub fn integrator(&self) -> String {
        let state = self.state.borrow();
        state
            .cloth
            .as_ref()
            .map_or(String::new(), |c| c.scene.params.integrator.to_string())
    }

    /// One frame: when `advance`, the frame's steps (1/60 s of simulated
    /// time) with the held particle pulled to the cursor; then the cloth
    /// drawn. Every few frames the solver's status is read back, so a
    /// blow-up is reported. Resolves to the steps taken.
    pub fn frame(&self, advance: bool) -> Promise {
        on_state(&self.state, move |s| {
            Box::pin(async move {
                let steps = if advance {
                    let mut encoder = s.device.create_command_encoder(&Default::default());
                    let cloth = s.cloth_mut()?;
                    let steps = cloth.advance(&mut encoder).map_err(js_error)?;
                    s.queue.submit([encoder.finish()]);
                    steps
                } else {
                    0
                };
                s.draw()?;
                if advance {
                    s.cloth_mut()?
                        .check_now_and_then()
                        .await
                        .map_err(js_error)?;
                }
                Ok(steps)
            })
        })
    }

    /// The mouse pressed at canvas pixel (`x`, `y`) (CSS pixels): picks the
    /// particle under it (one read-back). Resolves to whether one was
    /// grabbed.
    pub fn press(&self, x: f32, y: f32) -> Promise {
        on_state(&self.state, move |s| {
            Box::pin(async move {
                let pixel = s.pixel(x, y);
                let size = s.size();
                let cloth = s.cloth_mut()?;
                cloth.grab_at(pixel, size).await.map_err(js_error)
            })
        })
    }

    /// The mouse moved to (`x`, `y`) (CSS pixels): the held particle, if
    /// any, follows at the depth it was grabbed.
    #[wasm_bindgen(js_name = moveTo)]
    pub fn move_to(&self, x: f32, y: f32) -> Result<(), JsValue> {
        let mut state = self.state.try_borrow_mut().map_err(|_| js_error("busy"))?;
        let pixel = state.pixel(x, y);
        let size = state.size();
        state.cloth_mut()?.drag_to(pixel, size);
        Ok(())
    }

    /// The mouse released: the held particle is let go.
    pub fn release(&self) -> Result<(), JsValue> {
        let mut state = self.state.try_borrow_mut().map_err(|_| js_error("busy"))?;
        state.cloth_mut()?.release().map_err(js_error)
    }

    /// The check: loads scene `name` (grid `resolution`², 0 for its own),
    /// runs `steps` steps on the GPU and the same on the `f32` CPU
    /// reference, draws the GPU's result and resolves to the check's
    /// record (see `docs/web.md`): `adapter`, `scene`, `integrator`,
    /// `particles`, `steps`, `max_diff_m`, `ms_per_step` (GPU, timed over
    /// `steps` steps of a second solver of the scene, once the compared
    /// ones have built and used every pipeline) and `cpu_ms_per_step`.
    pub fn check(&self, name: String, steps: u32, resolution: u32) -> Promise {
        on_state(&self.state, move |s| {
            Box::pin(async move {
                let mut cloth = s.build(&name, "", resolution).await?;
                // Every step records the full CG budget, as the CPU
                // reference iterates.
                cloth.solver.tuning_mut().set_adaptive_cg_budget(false);
                cloth.solver.step_async(steps).await.map_err(js_error)?;
                let gpu = cloth.solver.read_state_async().await.map_err(js_error)?;

                // The GPU's fix-up is always Jacobi (every particle
                // averages its corrections from one snapshot); the
                // reference runs the same method, whatever the scene asks
                // of the CPU solver.
                let mut reference = cloth.scene.params.clone();
                reference.fixup.method = FixupMethod::Jacobi;
                let mut cpu = CpuSolver::<f32>::new(&cloth.model, &reference).map_err(js_error)?;
                let start = now_ms();
                cpu.step_n(u64::from(steps)).map_err(js_error)?;
                let cpu_ms = now_ms() - start;
                let max_diff = gpu
                    .x
                    .iter()
                    .zip(cpu.positions())
                    .map(|(g, c): (&Vec3, Vec3)| f64::from((*g - c).length()))
                    .fold(0.0, |m: f64, d| if d.is_nan() || d > m { d } else { m });

                let record = Object::new();
                set(&record, "adapter", s.adapter.clone());
                set(&record, "scene", name.clone());
                set(
                    &record,
                    "integrator",
                    cloth.scene.params.integrator.to_string(),
                );
                set(&record, "particles", cloth.solver.particle_count());
                set(&record, "steps", steps);
                set(&record, "max_diff_m", max_diff);
                set(&record, "cpu_ms_per_step", cpu_ms / f64::from(steps.max(1)));

                // The timing: a second solver of the same scene, its
                // pipelines already built and used, so that what the
                // browser defers to a pipeline's first use is not counted;
                // the compared cloth stays the one drawn.
                let mut timed = GpuSolver::with_kernels_async(
                    &s.kernels,
                    &s.queue,
                    &cloth.model,
                    &cloth.scene.params,
                )
                .await
                .map_err(js_error)?;
                timed.tuning_mut().set_adaptive_cg_budget(false);
                let start = now_ms();
                timed.step_async(steps).await.map_err(js_error)?;
                let gpu_ms = now_ms() - start;
                set(&record, "ms_per_step", gpu_ms / f64::from(steps.max(1)));
                s.cloth = Some(cloth);
                s.draw()?;
                Ok(record)
            })
        })
    }
}

impl State {
    /// Scene `name`'s cloth on this device (see [`Page::load`]).
    async fn build(&self, name: &str, integrator: &str, resolution: u32) -> Result<Cloth, JsValue> {
        let mut scene = Scene::builtin(name).map_err(js_error)?;
        if !integrator.is_empty() {
            scene.params.integrator = cloth::integrator(integrator)?;
        }
        if resolution > 0 {
            if scene.cloths[0].mesh.is_some() {
                return Err(js_error(format!(
                    "resolution: `{name}` is a mesh cloth; a resolution applies to a grid"
                )));
            }
            // Grown (or shrunk) at constant particle spacing and mass, as
            // the benches grow `hanging`: every size has the same local
            // dynamics and stays stable at the scene's dt.
            let n = resolution as usize;
            let cloth = &mut scene.cloths[0].spec;
            let along =
                |old: usize| n.saturating_sub(1) as f64 / old.saturating_sub(1).max(1) as f64;
            cloth.size = [
                cloth.size[0] * along(cloth.nx),
                cloth.size[1] * along(cloth.ny),
            ];
            cloth.mass *= (n * n) as f64 / (cloth.nx * cloth.ny).max(1) as f64;
            cloth.nx = n;
            cloth.ny = n;
            cloth.validate().map_err(js_error)?;
        }
        let aspect = self.config.width as f32 / self.config.height.max(1) as f32;
        Cloth::new(
            scene,
            &self.device,
            &self.queue,
            &self.kernels,
            self.config.format,
            aspect,
        )
        .await
        .map_err(js_error)
    }

    fn cloth_mut(&mut self) -> Result<&mut Cloth, JsValue> {
        self.cloth
            .as_mut()
            .ok_or_else(|| js_error("no scene is loaded"))
    }

    /// Draws the cloth (its normals first) into the canvas.
    fn draw(&mut self) -> Result<(), JsValue> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            other => {
                // Outdated or lost: configure again and skip this frame.
                self.surface.configure(&self.device, &self.config);
                return Err(js_error(format!("the canvas's texture: {other:?}")));
            }
        };
        let view = frame.texture.create_view(&Default::default());
        let mut encoder = self.device.create_command_encoder(&Default::default());
        if let Some(cloth) = &self.cloth {
            cloth.draw(&mut encoder, &view, &self.depth);
        }
        self.queue.submit([encoder.finish()]);
        self.queue.present(frame);
        Ok(())
    }

    /// The canvas pixel under CSS pixel (`x`, `y`).
    fn pixel(&self, x: f32, y: f32) -> Vec2 {
        let css_width = self.canvas.client_width().max(1) as f32;
        let css_height = self.canvas.client_height().max(1) as f32;
        let (w, h) = self.size().into();
        Vec2::new(x * w / css_width, y * h / css_height)
    }

    /// The canvas's size in pixels.
    fn size(&self) -> Vec2 {
        Vec2::new(self.config.width as f32, self.config.height as f32)
    }
}
