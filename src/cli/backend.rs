//! The two solvers behind one interface, so that `wgcloth run` drives them
//! with one loop and reports them with one summary.
//!
//! The CPU solver steps on the host and every state is at hand; the GPU
//! solver runs a batch of steps per submission, checks the device's status
//! word after each batch and reads the state back only when asked.

use std::borrow::Cow;

use wgcloth::diagnostics::{Divergence, Motion};
use wgcloth::gpu::{Profile, Profiler, StepPath, Timestamps};
use wgcloth::real::Vec3;
use wgcloth::scene::animation::Animation;
use wgcloth::{CpuSolver, GpuContext, GpuSolver, Integrator, Model, Params, Real, StepStats};

use super::summary::{BatchSummary, CgDetail, CgSummary, FixupSummary, SolverStats};

/// Most steps one GPU submission records. Bounds the command buffer (the
/// steps are recorded, not looped on the device); `wgcloth run` asks for
/// fewer, up to its next divergence check.
pub const MAX_BATCH: u64 = 256;

/// Positions and velocities, borrowed from a CPU solver or read back from a
/// device.
pub struct State<'a, R: Clone> {
    /// Positions \[m\].
    pub x: Cow<'a, [Vec3<R>]>,
    /// Velocities [m/s].
    pub v: Cow<'a, [Vec3<R>]>,
}

/// What `wgcloth run` needs from a solver.
pub trait Solver {
    /// The solver's arithmetic.
    type Real: Real;
    /// `"cpu"` or `"gpu"`, as `--backend` spells it.
    const BACKEND: &'static str;

    /// The device the solver runs on, for the summary (`None`: the CPU).
    fn device(&self) -> Option<String>;
    /// Runs `n` more steps; an error names the first non-finite step.
    fn advance(&mut self, n: u64) -> wgcloth::Result<()>;
    /// Steps taken so far.
    fn steps(&self) -> u64;
    /// Simulated time so far \[s\].
    fn time(&self) -> f64;
    /// The current state (a read-back on the GPU).
    fn state(&mut self) -> wgcloth::Result<State<'_, Self::Real>>;
    /// The moving bodies as the solver has moved them (what
    /// [`Divergence::check_with`] bounds the work of).
    fn motion(&self) -> wgcloth::Result<Motion>;
    /// The divergence rule for `model` and `params`, starting from the
    /// current state.
    fn divergence_rule(&mut self, model: &Model, params: &Params) -> wgcloth::Result<Divergence> {
        let time = self.time();
        let s = self.state()?;
        Ok(Divergence::new(model, params, time, &s.x, &s.v))
    }
    /// Sets the colliders and pin targets of `animation` (a scene's
    /// character) for the frame of `frame_seconds` \[s\] from `t` \[s\]
    /// ([`Animation::apply`]).
    fn animate(&mut self, animation: &Animation, t: f64, frame_seconds: f64)
        -> wgcloth::Result<()>;
    /// The solver's statistics of the run so far, given its parameters.
    fn stats(&self, params: &Params) -> SolverStats;
    /// The passes one step records: (kernel, dispatches, invocations each);
    /// empty for the CPU, which dispatches nothing.
    fn passes(&self) -> Vec<(&'static str, u32, u32)> {
        Vec::new()
    }
    /// Dispatches per CG iteration, CG iterations recorded per step and
    /// the budget's hits so far (`--verbose`); `None` where a step records
    /// no CG iterations.
    fn cg_recording(&self) -> Option<(u32, u32, u64)> {
        None
    }
    /// How the GPU records a step and why (`--verbose`); `None` for the
    /// CPU.
    fn step_path(&self) -> Option<String> {
        None
    }
    /// The GPU profile of the steps so far (`--profile`); `None` when not
    /// profiling.
    fn profile(&self) -> Option<Profile> {
        None
    }
    /// With `--batch`: the cloths stepped and the batch's dispatches per
    /// step; `None` for a lone cloth.
    fn batch(&self) -> Option<BatchSummary> {
        None
    }
}

/// The CPU reference solver, with its per-step statistics summed.
pub struct Cpu<R: Real> {
    solver: CpuSolver<R>,
    totals: Totals,
}

impl<R: Real> Cpu<R> {
    /// Builds the solver; refuses invalid parameters.
    pub fn new(model: &Model, params: &Params) -> wgcloth::Result<Self> {
        Ok(Cpu {
            solver: CpuSolver::new(model, params)?,
            totals: Totals::new(params.implicit.max_iterations),
        })
    }
}

impl<R: Real> Solver for Cpu<R> {
    type Real = R;
    const BACKEND: &'static str = "cpu";

    fn device(&self) -> Option<String> {
        None
    }

    fn advance(&mut self, n: u64) -> wgcloth::Result<()> {
        for _ in 0..n {
            let stats = self.solver.step()?;
            self.totals.add(&stats);
        }
        Ok(())
    }

    fn steps(&self) -> u64 {
        self.solver.steps()
    }

    fn motion(&self) -> wgcloth::Result<Motion> {
        Ok(self.solver.motion().clone())
    }

    fn time(&self) -> f64 {
        self.solver.time()
    }

    fn state(&mut self) -> wgcloth::Result<State<'_, R>> {
        Ok(State {
            x: Cow::Borrowed(&self.solver.state().x),
            v: Cow::Borrowed(&self.solver.state().v),
        })
    }

    fn animate(
        &mut self,
        animation: &Animation,
        t: f64,
        frame_seconds: f64,
    ) -> wgcloth::Result<()> {
        animation.apply(&mut self.solver, t, frame_seconds)
    }

    fn stats(&self, params: &Params) -> SolverStats {
        SolverStats {
            cg: self.totals.cg(params),
            fixup: self.totals.fixup(params.integrator),
            filter: self.solver.filter_name(),
        }
    }
}

/// Per-step statistics summed over the run.
struct Totals {
    steps: u64,
    cg_iterations: u64,
    cg_max: u32,
    /// The implicit solver's CG iteration cap.
    cg_cap: u32,
    /// Steps whose CG stopped at the cap rather than at the tolerance.
    cg_capped: u64,
    cg_max_residual: f64,
    fixup_passes: u64,
    fixup_max: u32,
}

impl Totals {
    fn new(cg_cap: u32) -> Self {
        Totals {
            steps: 0,
            cg_iterations: 0,
            cg_max: 0,
            cg_cap,
            cg_capped: 0,
            cg_max_residual: 0.0,
            fixup_passes: 0,
            fixup_max: 0,
        }
    }

    fn add(&mut self, s: &StepStats) {
        self.steps += 1;
        self.cg_iterations += u64::from(s.cg_iterations);
        self.cg_max = self.cg_max.max(s.cg_iterations);
        self.cg_capped += u64::from(s.cg_iterations >= self.cg_cap);
        // Steps without CG report no residual; the summary's maximum is
        // over the implicit steps.
        self.cg_max_residual = self.cg_max_residual.max(s.cg_residual.unwrap_or(0.0));
        self.fixup_passes += u64::from(s.fixup_passes);
        self.fixup_max = self.fixup_max.max(s.fixup_passes);
    }

    fn mean(&self, total: u64) -> Option<f64> {
        (self.steps > 0).then(|| total as f64 / self.steps as f64)
    }

    fn cg(&self, params: &Params) -> Option<CgSummary> {
        (params.integrator == Integrator::Implicit).then(|| CgSummary {
            max: self.cg_max,
            cap: self.cg_cap,
            tolerance: params.implicit.tolerance,
            detail: CgDetail::PerStep {
                mean: self.mean(self.cg_iterations),
                capped_steps: self.cg_capped,
                max_residual: self.cg_max_residual,
            },
        })
    }

    fn fixup(&self, integrator: Integrator) -> Option<FixupSummary> {
        (integrator != Integrator::Implicit).then(|| FixupSummary::Counted {
            mean: self.mean(self.fixup_passes),
            max: self.fixup_max,
        })
    }
}

/// The GPU solver on a device of its own.
pub struct Gpu {
    context: GpuContext,
    solver: GpuSolver,
    /// What the device reported after the last batch (`None` before the
    /// first).
    status: Option<StepStats>,
    /// The most CG iterations of any step so far (the device reports the
    /// most since its previous report).
    cg_max: u32,
    /// Times every step's dispatches (`--profile`).
    profiler: Option<Profiler>,
}

impl Gpu {
    /// Opens the adapter `adapter` names (see [`GpuContext::new`]) and
    /// builds the solver on it; refuses invalid parameters, what the GPU
    /// solver does not support, and a cloth beyond the device's limits.
    /// With `profile`, asks the device for timestamp queries and times
    /// every step, at best by `profile`'s timing. `path`: the step path
    /// forced (`None`: the solver's choice).
    pub fn new(
        adapter: Option<&str>,
        model: &Model,
        params: &Params,
        profile: Option<Timestamps>,
        path: Option<StepPath>,
    ) -> wgcloth::Result<Self> {
        let features = if profile.is_some() {
            Timestamps::FEATURES
        } else {
            wgpu::Features::empty()
        };
        let context = open_device(adapter, features)?;
        let profiler = profile
            .map(|most| Profiler::new(Timestamps::best(context.device.features()).min(most)));
        let solver = match path {
            Some(path) => {
                GpuSolver::with_step_path(context.kernels(), &context.queue, model, params, path)?
            }
            None => GpuSolver::with_kernels(context.kernels(), &context.queue, model, params)?,
        };
        keep_pipelines(&context);
        Ok(Gpu {
            context,
            solver,
            status: None,
            cg_max: 0,
            profiler,
        })
    }
}

/// Opens the adapter `adapter` names (see [`GpuContext::new`]) with
/// `features`, its kernel library seeded from the pipelines kept by
/// earlier runs.
pub fn open_device(adapter: Option<&str>, features: wgpu::Features) -> wgcloth::Result<GpuContext> {
    let mut context = GpuContext::with_features(adapter, features)?;
    if let Some(dir) = wgcloth::gpu::pipeline_cache::default_dir() {
        context.keep_pipelines(&dir);
    }
    Ok(context)
}

/// Keeps the pipelines compiled so far for the next run (a failure is
/// only a note: the next run compiles them again).
pub fn keep_pipelines(context: &GpuContext) {
    if let Err(e) = context.save_pipelines() {
        note!("note: compiled pipelines not kept for the next run: {e}");
    }
}

impl Solver for Gpu {
    type Real = f32;
    const BACKEND: &'static str = "gpu";

    fn device(&self) -> Option<String> {
        Some(self.context.describe())
    }

    fn passes(&self) -> Vec<(&'static str, u32, u32)> {
        self.solver.tuning().describe_step()
    }

    fn cg_recording(&self) -> Option<(u32, u32, u64)> {
        let tuning = self.solver.tuning();
        let per = tuning.dispatches_per_cg_iteration();
        let hits = self.status.and_then(|s| s.cg_budget_hits).unwrap_or(0);
        (per > 0).then(|| (per, tuning.cg_budget(), hits))
    }

    fn step_path(&self) -> Option<String> {
        let tuning = self.solver.tuning();
        Some(format!(
            "{} ({})",
            tuning.step_path(),
            tuning.step_path_reason()
        ))
    }

    fn profile(&self) -> Option<Profile> {
        self.profiler.as_ref().map(|p| self.solver.profile(p))
    }

    fn advance(&mut self, mut n: u64) -> wgcloth::Result<()> {
        while n > 0 {
            let batch = n.min(MAX_BATCH);
            // MAX_BATCH fits a u32.
            let status = match &mut self.profiler {
                Some(profiler) => self.solver.step_profiled(batch as u32, profiler)?,
                None => self.solver.step(batch as u32)?,
            };
            self.context.check()?;
            self.cg_max = self.cg_max.max(status.cg_max_iterations);
            self.status = Some(status);
            n -= batch;
        }
        Ok(())
    }

    fn steps(&self) -> u64 {
        self.solver.steps_recorded()
    }

    fn motion(&self) -> wgcloth::Result<Motion> {
        Ok(self.solver.motion().clone())
    }

    fn time(&self) -> f64 {
        self.solver.time()
    }

    fn state(&mut self) -> wgcloth::Result<State<'_, f32>> {
        let state = self.solver.read_state()?;
        self.context.check()?;
        Ok(State {
            x: state.x.into_iter().map(Vec3::from).collect(),
            v: state.v.into_iter().map(Vec3::from).collect(),
        })
    }

    fn animate(
        &mut self,
        animation: &Animation,
        t: f64,
        frame_seconds: f64,
    ) -> wgcloth::Result<()> {
        animation.apply(&mut self.solver, t, frame_seconds)
    }

    fn stats(&self, params: &Params) -> SolverStats {
        gpu_stats(params, self.cg_max, self.status)
    }
}

/// What a GPU cloth reports: `cg_max`, the most CG iterations of any step,
/// and `status`, what the device reported after the last batch of steps.
pub fn gpu_stats(params: &Params, cg_max: u32, status: Option<StepStats>) -> SolverStats {
    SolverStats {
        cg: (params.integrator == Integrator::Implicit).then(|| CgSummary {
            max: cg_max,
            cap: params.implicit.max_iterations,
            tolerance: params.implicit.tolerance,
            detail: CgDetail::Last(status.map(|s| s.cg_iterations)),
        }),
        fixup: (params.integrator != Integrator::Implicit).then_some(FixupSummary::GpuJacobi {
            iterations: params.fixup.iterations,
            last: status.map(|s| s.fixup_passes),
        }),
        filter: None,
    }
}
