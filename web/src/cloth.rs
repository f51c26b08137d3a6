//! The page's cloth: a scene's GPU solver, its renderer and camera, the
//! per-frame update and the particle held under the mouse (as the viewer
//! example's, with the async forms a browser awaits).

use wasm_bindgen::JsValue;
use wgcloth::glam::{Vec2, Vec3};
use wgcloth::gpu::GpuKernels;
use wgcloth::params::Integrator;
use wgcloth::render::{Camera, Renderer, RendererFormats};
use wgcloth::render_mesh::Embedding;
use wgcloth::scene::animation::Animation;
use wgcloth::{GpuSolver, Model, PinTarget, Scene};

use crate::handover::hand_over;
use crate::js_error;
use crate::pick::{self, Ray};

/// Simulated time of one frame \[s\]: the page advances at 60 frames a
/// second of simulated time, whatever the browser's frame rate.
const FRAME_SECONDS: f64 = 1.0 / 60.0;
/// Frames between status checks (one small read-back each), so a blow-up
/// stops the page within a fraction of a second.
const CHECK_EVERY_FRAMES: u32 = 10;
/// How far from the cursor's ray a particle can be grabbed \[fraction of
/// the scene's framing radius\]: the viewer's, about one particle spacing
/// of `hanging`.
const PICK_RADIUS: f32 = 0.04;
/// The depth format of the page's depth buffer.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A particle held under the mouse.
#[derive(Clone, Copy, Debug)]
struct Grab {
    particle: usize,
    /// Whether the scene pins it (it stays pinned when let go).
    was_pinned: bool,
    /// Where the cursor wants it \[m\].
    target: Vec3,
}

/// A scene's cloth on the page's device.
pub struct Cloth {
    /// The scene, its integrator the one running.
    pub scene: Scene,
    /// The model the solver was built from.
    pub model: Model,
    /// The solver.
    pub solver: GpuSolver,
    renderer: Renderer,
    camera: Camera,
    aspect: f32,
    animation: Option<Animation>,
    /// Simulated time since the start \[s\].
    time: f64,
    grab: Option<Grab>,
    frames_since_check: u32,
    /// The scene's render meshes, embedded in the cloth (each solver gets
    /// its own, which the renderer draws).
    embeddings: Vec<Embedding>,
}

/// The integrator named `name` (as scene files spell it).
pub fn integrator(name: &str) -> Result<Integrator, JsValue> {
    match name {
        "explicit" => Ok(Integrator::Explicit),
        "implicit" => Ok(Integrator::Implicit),
        "semi-implicit" => Ok(Integrator::SemiImplicit),
        _ => Err(js_error(format!(
            "integrator: `{name}` is not one of explicit, implicit, semi-implicit"
        ))),
    }
}

/// A depth buffer of `width` × `height` pixels.
pub fn depth_view(device: &wgpu::Device, width: u32, height: u32) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("wgcloth.page.depth"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

impl Cloth {
    /// `scene`'s solver (pipelines from `kernels`) and a renderer drawing
    /// into a `color` canvas of `aspect` (width / height).
    pub async fn new(
        scene: Scene,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        kernels: &GpuKernels,
        color: wgpu::TextureFormat,
        aspect: f32,
    ) -> wgcloth::Result<Cloth> {
        let model = scene.model()?;
        let embeddings = scene.embeddings(&model)?;
        let solver = GpuSolver::with_kernels_async(kernels, queue, &model, &scene.params).await?;
        let camera = camera(&scene, &model, aspect, 0.0);
        let mut renderer = Renderer::with_formats(
            device,
            queue,
            &scene.params,
            &camera,
            RendererFormats {
                color,
                depth: DEPTH_FORMAT,
            },
        )?;
        renderer.set_embeddings(&solver, &embeddings)?;
        renderer.set_cloth_colors(device, &model, &scene.cloth_colors());
        let animation = scene.animation(&model);
        Ok(Cloth {
            scene,
            model,
            solver,
            renderer,
            camera,
            aspect,
            animation,
            time: 0.0,
            grab: None,
            frames_since_check: 0,
            embeddings,
        })
    }

    /// Records one frame's steps (the animation's and the held particle's
    /// moves set first) and the normals; returns the steps.
    pub fn advance(&mut self, encoder: &mut wgpu::CommandEncoder) -> wgcloth::Result<u32> {
        let steps = (FRAME_SECONDS / self.scene.params.dt).round().max(1.0) as u32;
        let frame_seconds = f64::from(steps) * self.scene.params.dt;
        if let Some(animation) = &self.animation {
            animation.apply(&mut self.solver, self.time, frame_seconds)?;
        }
        if let Some(grab) = self.grab {
            self.solver.set_pinned(grab.particle, true)?;
            // A moving pin: reached at constant velocity across the
            // frame's steps, so a release lets it go with that velocity.
            self.solver.set_pin_targets(
                &[PinTarget {
                    particle: grab.particle,
                    position: grab.target,
                }],
                frame_seconds,
            )?;
        }
        self.time += frame_seconds;
        self.solver.encode_steps(encoder, steps);
        self.frames_since_check += 1;
        if self.animation.is_some() {
            self.camera = camera(&self.scene, &self.model, self.aspect, self.time);
            self.renderer.set_camera(&self.camera);
            let (spheres, capsules) = self.solver.colliders();
            self.renderer.set_colliders(&spheres, &capsules);
        }
        Ok(steps)
    }

    /// Every [`CHECK_EVERY_FRAMES`] frames: did the cloth stay finite?
    pub async fn check_now_and_then(&mut self) -> wgcloth::Result<()> {
        if self.frames_since_check < CHECK_EVERY_FRAMES {
            return Ok(());
        }
        self.frames_since_check = 0;
        self.solver.check_async().await.map(|_| ())
    }

    /// Records the normals, the render meshes' skin passes and a pass
    /// drawing the cloth (or its render meshes) and its colliders into
    /// `color` and `depth`.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) {
        self.solver.encode_normals(encoder);
        self.renderer.encode_render_meshes(encoder);
        let mut pass = self.renderer.begin_pass(encoder, color, depth);
        self.renderer.draw(&mut pass, &self.solver);
    }

    /// Holds the particle under `pixel` of a `size` canvas, if one is near
    /// enough (one read-back of the positions).
    pub async fn grab_at(&mut self, pixel: Vec2, size: Vec2) -> wgcloth::Result<bool> {
        let Some(ray) = Ray::through_pixel(&self.camera.view_proj, pixel, size) else {
            return Ok(false);
        };
        let positions = self.solver.read_state_async().await?.x;
        let radius = PICK_RADIUS * self.camera.radius;
        let Some(particle) = pick::nearest(&positions, &ray, radius) else {
            return Ok(false);
        };
        self.release()?;
        self.grab = Some(Grab {
            particle,
            was_pinned: self.model.pinned.get(particle).copied().unwrap_or(false),
            target: positions[particle],
        });
        Ok(true)
    }

    /// Wants the held particle under `pixel`, at the depth it was grabbed.
    pub fn drag_to(&mut self, pixel: Vec2, size: Vec2) {
        let forward = (self.camera.target - self.camera.eye).normalize_or_zero();
        let Some(grab) = &mut self.grab else {
            return;
        };
        if let Some(target) = Ray::through_pixel(&self.camera.view_proj, pixel, size)
            .and_then(|ray| pick::drag_target(&ray, grab.target, forward))
        {
            grab.target = target;
        }
    }

    /// Lets go of the held particle (pinned again only if the scene pins
    /// it).
    pub fn release(&mut self) -> wgcloth::Result<()> {
        match self.grab.take() {
            Some(grab) => self.solver.set_pinned(grab.particle, grab.was_pinned),
            None => Ok(()),
        }
    }

    /// Switches to `integrator`: a solver built with it from the shared
    /// kernel library, given the current positions and velocities (a state
    /// that stopped being finite starts over from rest). A held particle
    /// is let go. On an error the running solver is kept.
    pub async fn switch(
        &mut self,
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        integrator: Integrator,
    ) -> wgcloth::Result<()> {
        self.release()?;
        let state = self.solver.read_state_async().await.ok();
        let mut params = self.scene.params.clone();
        params.integrator = integrator;
        let mut solver =
            GpuSolver::with_kernels_async(kernels, queue, &self.model, &params).await?;
        if let Some(state) = state {
            hand_over(&mut solver, state, &self.model.pinned)?;
        }
        self.renderer.set_embeddings(&solver, &self.embeddings)?;
        self.solver = solver;
        self.scene.params.integrator = integrator;
        Ok(())
    }
}

/// The scene's camera at time `t` \[s\]: following its character if it
/// has one.
fn camera(scene: &Scene, model: &Model, aspect: f32, t: f64) -> Camera {
    Camera::following(scene, model, aspect, t)
        .unwrap_or_else(|| Camera::for_scene(scene, model, aspect))
}
