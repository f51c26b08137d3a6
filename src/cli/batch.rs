//! `wgcloth run --batch N`: N copies of the scene's cloth stepped together
//! in one [`GpuBatch`]. Copy 0 is the run's cloth (its state, its outputs,
//! its statistics); the others only share its dispatches.

use std::borrow::Cow;

use wgcloth::diagnostics::Motion;
use wgcloth::gpu::{ClothId, GpuBatch, StepPath};
use wgcloth::params::{Capsule, PinTarget};
use wgcloth::real::Vec3;
use wgcloth::scene::animation::{Animated, Animation};
use wgcloth::{GpuContext, Model, Params, StepStats};

use super::backend::{gpu_stats, keep_pipelines, open_device, Solver, State, MAX_BATCH};
use super::summary::{BatchSummary, SolverStats};

/// Most copies `--batch` takes: the smallest
/// `max_compute_workgroups_per_dimension` WebGPU guarantees (65535), so a
/// batch of one integrator is one dispatch of a workgroup per cloth on
/// every device.
pub const MAX_COPIES: u64 = 65_535;

/// N copies of one cloth in a batch on a device of its own.
pub struct GpuCopies {
    context: GpuContext,
    batch: GpuBatch,
    /// Copy 0: the cloth the run reports.
    first: ClothId,
    dt: f64,
    /// What the device reported for copy 0 after the last batch of steps.
    status: Option<StepStats>,
    /// The most CG iterations of any step of copy 0 so far.
    cg_max: u32,
}

impl GpuCopies {
    /// Opens the adapter `adapter` names and adds `copies` (≥ 1) copies of
    /// the cloth to one batch; refuses what [`GpuBatch::add`] refuses.
    pub fn new(
        adapter: Option<&str>,
        model: &Model,
        params: &Params,
        copies: u32,
    ) -> wgcloth::Result<Self> {
        let context = open_device(adapter, wgpu::Features::empty())?;
        let mut batch = GpuBatch::with_kernels(context.kernels(), &context.queue);
        let first = batch.add(model, params)?;
        for _ in 1..copies {
            batch.add(model, params)?;
        }
        keep_pipelines(&context);
        Ok(GpuCopies {
            context,
            batch,
            first,
            dt: params.dt,
            status: None,
            cg_max: 0,
        })
    }
}

impl Solver for GpuCopies {
    type Real = f32;
    const BACKEND: &'static str = "gpu";

    fn device(&self) -> Option<String> {
        Some(self.context.describe())
    }

    fn passes(&self) -> Vec<(&'static str, u32, u32)> {
        self.batch.describe_step()
    }

    fn step_path(&self) -> Option<String> {
        let path = self.batch.step_path(self.first).ok()?;
        Some(match path {
            StepPath::Workgroup => format!("{path} (the batch's shared buffers, one dispatch)"),
            StepPath::MultiDispatch => format!("{path} (a solver of its own in the batch)"),
        })
    }

    fn advance(&mut self, mut n: u64) -> wgcloth::Result<()> {
        while n > 0 {
            let steps = n.min(MAX_BATCH);
            // MAX_BATCH fits a u32.
            let stats = self.batch.step(steps as u32)?;
            self.context.check()?;
            if let Some((_, s)) = stats.iter().find(|(id, _)| *id == self.first) {
                self.cg_max = self.cg_max.max(s.cg_max_iterations);
                self.status = Some(*s);
            }
            n -= steps;
        }
        Ok(())
    }

    fn steps(&self) -> u64 {
        self.batch.steps_recorded(self.first).unwrap_or(0)
    }

    fn time(&self) -> f64 {
        self.steps() as f64 * self.dt
    }

    fn motion(&self) -> wgcloth::Result<Motion> {
        self.batch.motion(self.first).cloned()
    }

    fn state(&mut self) -> wgcloth::Result<State<'_, f32>> {
        let state = self.batch.read_state(self.first)?;
        self.context.check()?;
        Ok(State {
            x: Cow::Owned(state.x.into_iter().map(Vec3::from).collect()),
            v: Cow::Owned(state.v.into_iter().map(Vec3::from).collect()),
        })
    }

    fn animate(
        &mut self,
        animation: &Animation,
        t: f64,
        frame_seconds: f64,
    ) -> wgcloth::Result<()> {
        for id in self.batch.cloths() {
            animation.apply(
                &mut BatchCloth {
                    batch: &mut self.batch,
                    id,
                },
                t,
                frame_seconds,
            )?;
        }
        Ok(())
    }

    fn stats(&self, params: &Params) -> SolverStats {
        gpu_stats(params, self.cg_max, self.status)
    }

    fn batch(&self) -> Option<BatchSummary> {
        Some(BatchSummary {
            cloths: self.batch.cloth_count() as u64,
            dispatches_per_step: self.batch.dispatches_per_step(),
        })
    }
}

/// One cloth of a batch, for [`Animation::apply`]: every copy is animated
/// as copy 0 is.
struct BatchCloth<'a> {
    batch: &'a mut GpuBatch,
    id: ClothId,
}

impl Animated for BatchCloth<'_> {
    fn set_capsules(&mut self, capsules: &[Capsule]) -> wgcloth::Result<()> {
        self.batch.set_capsules(self.id, capsules)
    }

    fn set_mesh_colliders(&mut self, poses: &[wgcloth::sdf::MeshPose]) -> wgcloth::Result<()> {
        self.batch.set_mesh_colliders(self.id, poses)
    }

    fn set_pin_targets(
        &mut self,
        targets: &[PinTarget],
        frame_seconds: f64,
    ) -> wgcloth::Result<()> {
        self.batch.set_pin_targets(self.id, targets, frame_seconds)
    }
}
