//! What the solvers report about the steps they ran: one type for both
//! backends, so a host reads a CPU and a GPU cloth the same way.

/// What a solver reports about the steps it ran, besides moving the cloth.
///
/// [`CpuSolver::step`](crate::CpuSolver::step) and
/// [`CpuSolver::step_n`](crate::CpuSolver::step_n) return it for the steps
/// they ran; [`GpuSolver::step`](crate::GpuSolver::step) and
/// [`GpuSolver::check`](crate::GpuSolver::check) read it from the device's
/// status words. A number a backend cannot know is `None` there, as each
/// field says.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Steps the solver has run in all.
    pub steps: u64,
    /// CG iterations of the last step (implicit only; 0 otherwise).
    pub cg_iterations: u32,
    /// Largest CG iteration count of any step since the last report: of the
    /// steps this call ran on the CPU, since the last check on the GPU.
    pub cg_max_iterations: u32,
    /// Final relative preconditioned residual of the last step's CG
    /// (dimensionless). CPU implicit steps only: the GPU keeps CG's
    /// residual on the device and never reads it back, and the other
    /// integrators run no CG.
    pub cg_residual: Option<f64>,
    /// Checks whose window had a step stop at the adaptive CG budget rather
    /// than at convergence (see [`GpuSolver::check`](crate::GpuSolver::check)).
    /// GPU only: the CPU has no budget, every CG runs to convergence or to
    /// `implicit.max_iterations`.
    pub cg_budget_hits: Option<u64>,
    /// Fix-up passes of the last step (explicit and semi-implicit): on the
    /// CPU those that moved something; on the GPU those run, the last of
    /// which found nothing over-stretched when it stopped early.
    pub fixup_passes: u32,
}
