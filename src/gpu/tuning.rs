//! Knobs and inspection of a [`GpuSolver`] for benchmarks and tests:
//! embedders need none of it.

use super::grid::GridBlock;
use super::kernel::Dispatch;
use super::path::StepPath;
use super::solver::GpuSolver;
use crate::error::Result;

/// Read-only inspection of a [`GpuSolver`], from [`GpuSolver::tuning`]:
/// for benchmarks, tests and `wgcloth run --verbose`; embedders need none
/// of it.
#[derive(Clone, Copy)]
pub struct GpuTuning<'a> {
    solver: &'a GpuSolver,
}

/// The knobs of a [`GpuSolver`], from [`GpuSolver::tuning_mut`]: for
/// benchmarks and tests; embedders need none of it. None changes results
/// except [`GpuTuningMut::set_adaptive_cg_budget`] (a step may then use
/// more CG iterations).
pub struct GpuTuningMut<'a> {
    solver: &'a mut GpuSolver,
}

impl GpuSolver {
    /// Inspection for benchmarks and tests (the step plan, the CG budget,
    /// dispatches per step); embedders need none of it.
    pub fn tuning(&self) -> GpuTuning<'_> {
        GpuTuning { solver: self }
    }

    /// Knobs for benchmarks and tests (kernel specialisation, grid block
    /// shape, adaptive CG budget); embedders need none of it.
    pub fn tuning_mut(&mut self) -> GpuTuningMut<'_> {
        GpuTuningMut { solver: self }
    }
}

impl GpuTuning<'_> {
    /// The dispatches of one step of a long run, in order (see
    /// `src/gpu/plan.rs` for what is recorded and why): with single-pass
    /// explicit steps, one that reads x and v; an odd number of steps
    /// first records `explicit_seed` ([`GpuSolver::debug_plan`] lists
    /// exactly what one step records).
    pub fn step_plan(&self) -> Vec<Dispatch> {
        self.solver.step_plan()
    }

    /// The step plan grouped by kernel, in order of first appearance:
    /// `(kernel, dispatches per step, invocations per dispatch)` — what
    /// `wgcloth run --verbose` prints.
    pub fn describe_step(&self) -> Vec<(&'static str, u32, u32)> {
        self.solver.describe_step()
    }

    /// CG iterations recorded per step at present (see
    /// [`GpuSolver::check`]).
    pub fn cg_budget(&self) -> u32 {
        self.solver.cg_budget()
    }

    /// Dispatches recorded per CG iteration (two on the multi-dispatch
    /// path, `cg_apply` and `cg_update`; 0 where a step records no CG
    /// iterations: no CG, or the workgroup path, whose one dispatch runs
    /// them all).
    pub fn dispatches_per_cg_iteration(&self) -> u32 {
        self.solver.dispatches_per_cg_iteration()
    }

    /// Compute dispatches per step in the last
    /// [`GpuSolver::encode_steps`] call (all in one compute pass of one
    /// encoder, one submit).
    pub fn dispatches_per_step(&self) -> f64 {
        self.solver.dispatches_per_step()
    }

    /// How a step is recorded: one workgroup per cloth, or a dispatch per
    /// phase (see [`StepPath`]; chosen when the solver is built, or forced
    /// with [`GpuSolver::with_step_path`]).
    pub fn step_path(&self) -> StepPath {
        self.solver.path.path
    }

    /// Why the solver takes [`GpuTuning::step_path`], in a sentence (what
    /// `wgcloth run --verbose` prints).
    pub fn step_path_reason(&self) -> &str {
        &self.solver.path.reason
    }

    /// The grid gather's block shape (see
    /// [`GpuTuningMut::set_grid_block`]).
    pub fn grid_block(&self) -> GridBlock {
        self.solver.grid_block()
    }
}

impl GpuTuningMut<'_> {
    /// With `false`, records the general kernels — every feature compiled
    /// in, absent ones made inert by their parameters (zero wind, no
    /// spheres, a ground out of reach, free filters, zero damping) — and no
    /// fused passes: for tests and benchmarks of what specialisation saves.
    /// With `true` (the default), the scene's own variants.
    pub fn set_specialised(&mut self, on: bool) -> Result<()> {
        self.solver.set_specialised(on)
    }

    /// Sets how many particles (columns × rows) each invocation of the grid
    /// gather kernels handles (see [`GridBlock`]; the default is
    /// [`GridBlock::ONE`]). Results are the same for every
    /// shape; speed is not. No effect on a cloth without grid layout.
    pub fn set_grid_block(&mut self, block: GridBlock) -> Result<()> {
        self.solver.set_grid_block(block)
    }

    /// Turns the adaptive CG iteration budget on (the default) or off (every
    /// step records the configured maximum: results equal the CPU
    /// reference's exactly, at the cost of empty dispatches).
    pub fn set_adaptive_cg_budget(&mut self, on: bool) {
        self.solver.set_adaptive_cg_budget(on)
    }
}
