//! The cloth the viewer shows: a scene's GPU solver on the host's device,
//! the per-frame update, the grab under the mouse and the integrator
//! switch.

use anyhow::Context as _;
use wgcloth::glam::Vec3;
use wgcloth::gpu::GpuKernels;
use wgcloth::params::Integrator;
use wgcloth::render_mesh::Embedding;
use wgcloth::scene::animation::Animation;
use wgcloth::{GpuSolver, Model, PinTarget, Scene};

use crate::handover::hand_over;

/// Frames between the viewer's status checks: one small read-back each,
/// so a blow-up stops the cloth within a fraction of a second.
const CHECK_EVERY_FRAMES: u64 = 10;

/// A particle held under the mouse.
#[derive(Clone, Copy, Debug)]
pub struct Grab {
    /// Its index.
    pub particle: usize,
    /// Whether the scene pins it (it stays pinned when let go).
    was_pinned: bool,
    /// Where the cursor wants it \[m\].
    pub target: Vec3,
}

/// A scene's cloth on the GPU and what the user did to it.
pub struct Sim {
    /// The scene, its integrator the one running.
    pub scene: Scene,
    model: Model,
    kernels: GpuKernels,
    queue: wgpu::Queue,
    /// The solver (rebuilt on reset and on an integrator switch).
    pub solver: GpuSolver,
    /// The particle held under the mouse, if any.
    pub grab: Option<Grab>,
    /// The scene's scripted character (`cape`), if it has one.
    animation: Option<Animation>,
    /// Simulated time since the start \[s\] (the animation's clock).
    time: f64,
    /// Frames advanced since the last status check.
    frames_since_check: u64,
    /// The scene's render meshes, embedded in the cloth.
    embeddings: Vec<Embedding>,
    /// Solvers built so far: a host's render meshes follow the solver of
    /// the generation they were made for.
    pub generation: u64,
}

impl Sim {
    /// Builds `scene`'s solver from the host's kernel library (its device)
    /// and queue.
    pub fn new(scene: Scene, kernels: &GpuKernels, queue: &wgpu::Queue) -> anyhow::Result<Sim> {
        let model = scene.model()?;
        let embeddings = scene.embeddings(&model)?;
        let solver = GpuSolver::with_kernels(kernels, queue, &model, &scene.params)
            .with_context(|| format!("building the solver of `{}`", scene.name))?;
        let animation = scene.animation(&model);
        Ok(Sim {
            scene,
            model,
            kernels: kernels.clone(),
            queue: queue.clone(),
            solver,
            grab: None,
            animation,
            time: 0.0,
            frames_since_check: 0,
            embeddings,
            generation: 0,
        })
    }

    /// The scene's render meshes, embedded in the cloth (none: the cloth
    /// is drawn itself).
    pub fn embeddings(&self) -> &[Embedding] {
        &self.embeddings
    }

    /// The model the solver was built from.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Solver time step \[s\].
    pub fn dt(&self) -> f64 {
        self.scene.params.dt
    }

    /// The per-frame scene update and the frame's `steps` solver steps
    /// (`frame_seconds` = `steps` × dt \[s\]), recorded into the host's
    /// `encoder` with the normals the drawing needs. Everything that moves
    /// with the frame (the grabbed particle; an animated scene's colliders
    /// and pins) is set here, before the steps are recorded.
    pub fn advance(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        steps: u32,
        frame_seconds: f64,
    ) -> anyhow::Result<()> {
        if let Some(animation) = &self.animation {
            animation.apply(&mut self.solver, self.time, frame_seconds)?;
        }
        if let Some(grab) = self.grab {
            drag_to(&mut self.solver, grab.particle, grab.target, frame_seconds)?;
        }
        self.time += frame_seconds;
        self.solver.encode_steps(encoder, steps);
        self.solver.encode_normals(encoder);
        self.frames_since_check += 1;
        Ok(())
    }

    /// Every [`CHECK_EVERY_FRAMES`] frames, after the frame was submitted:
    /// did the cloth stay finite? (One small read-back.)
    pub fn check_now_and_then(&mut self) -> wgcloth::Result<()> {
        if self.frames_since_check < CHECK_EVERY_FRAMES {
            return Ok(());
        }
        self.frames_since_check = 0;
        self.solver.check().map(|_| ())
    }

    /// The particles' positions \[m\], read back (blocking): once per
    /// mouse press, for picking.
    pub fn positions(&self) -> wgcloth::Result<Vec<Vec3>> {
        Ok(self.solver.read_state()?.x)
    }

    /// Holds `particle` under the mouse, wanting it at `target` \[m\].
    pub fn grab(&mut self, particle: usize, target: Vec3) {
        let was_pinned = self.model.pinned.get(particle).copied().unwrap_or(false);
        self.grab = Some(Grab {
            particle,
            was_pinned,
            target,
        });
    }

    /// Wants the held particle, if any, at `target` \[m\] from the next
    /// frame on.
    pub fn pull_to(&mut self, target: Vec3) {
        if let Some(grab) = &mut self.grab {
            grab.target = target;
        }
    }

    /// Lets go of the held particle: it is free again (unless the scene
    /// pins it).
    pub fn release(&mut self) -> wgcloth::Result<()> {
        match self.grab.take() {
            Some(grab) => self.solver.set_pinned(grab.particle, grab.was_pinned),
            None => Ok(()),
        }
    }

    /// Starts the scene over with the running integrator.
    pub fn reset(&mut self) -> anyhow::Result<()> {
        self.grab = None;
        self.solver = self.build(self.scene.params.integrator)?;
        self.generation += 1;
        self.time = 0.0;
        Ok(())
    }

    /// Switches to `integrator`: a solver built from the scene with it,
    /// its pipelines taken from the shared kernel library, given the
    /// current positions and velocities (read back once; a state that
    /// stopped being finite starts over from rest). A held particle stays
    /// held. On an error the running solver is kept.
    pub fn switch(&mut self, integrator: Integrator) -> anyhow::Result<()> {
        let state = self.solver.read_state().ok();
        let mut solver = self.build(integrator)?;
        if let Some(state) = state {
            hand_over(&mut solver, state, &self.model.pinned)?;
        }
        self.solver = solver;
        self.generation += 1;
        self.scene.params.integrator = integrator;
        Ok(())
    }

    fn build(&self, integrator: Integrator) -> anyhow::Result<GpuSolver> {
        let mut params = self.scene.params.clone();
        params.integrator = integrator;
        GpuSolver::with_kernels(&self.kernels, &self.queue, &self.model, &params)
            .with_context(|| format!("building the {integrator} solver of `{}`", self.scene.name))
    }
}

/// Moves the grabbed `particle` to `target` \[m\] over the coming frame
/// of `frame_seconds` \[s\]: pins it (a no-op once pinned) and gives it
/// the target as a moving pin, which the solver reaches at constant
/// velocity across the frame's steps, so the drag is smooth and a release
/// lets it go with that velocity (a flick).
fn drag_to(
    solver: &mut GpuSolver,
    particle: usize,
    target: Vec3,
    frame_seconds: f64,
) -> wgcloth::Result<()> {
    solver.set_pinned(particle, true)?;
    solver.set_pin_targets(
        &[PinTarget {
            particle,
            position: target,
        }],
        frame_seconds,
    )
}
