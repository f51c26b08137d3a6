//! The GPU implicit integrator (CG on the device) against the CPU f32
//! mirror, on lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::gpu::{GpuSolver, StepPath};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn scene() -> (Model, Params) {
    let mut params = busy_params(Integrator::Implicit);
    params.springs[0].stiffness = 500.0;
    params.implicit.tolerance = 1e-4;
    (grid(17, 13, corners(), &params), params)
}

/// The GPU sums every dot product in the CPU's (block) order, so the CG
/// iterates agree as closely as the explicit step: ulps from fused
/// multiply-adds or lavapipe's rounding, amplified by CG's sensitivity to
/// its inputs. One step: 1e-6 m.
const ONE_STEP_TOL: f64 = 1e-6;
/// After 100 steps a rounding difference can flip one CG iteration's
/// convergence test, moving that step's answer by up to the tolerance times
/// the velocity change (~1e-4 × 1 cm per step); 1e-3 m bounds that.
const HUNDRED_STEP_TOL: f64 = 1e-3;

#[test]
fn implicit_matches_the_cpu_mirror() {
    let (model, params) = scene();
    for (steps, tol) in [(1, ONE_STEP_TOL), (100, HUNDRED_STEP_TOL)] {
        let (d, p, g, c) = compare(&model, &params, steps);
        eprintln!("{steps} steps: worst {d:e} m at particle {p}");
        assert!(
            d < tol,
            "{steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
        );
    }
}

#[test]
fn gpu_cg_iterations_match_the_cpu() {
    let (model, params) = scene();
    let ctx = gpu();
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params).expect("GPU solver");
    g.tuning_mut().set_adaptive_cg_budget(false);
    let mut c = wgcloth::cpu::CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
    for step in 1..=20 {
        let status = g.step(1).expect("GPU step");
        let stats = c.step().expect("CPU step");
        assert!(
            status.cg_iterations > 0,
            "step {step}: the GPU did no CG iteration"
        );
        assert_eq!(
            status.cg_iterations, stats.cg_iterations,
            "step {step}: CG iterations"
        );
    }
}

/// Both backends report one `StepStats`: over a batch of steps the same
/// counts (CG iterations of the last step and the most of the batch, the
/// step number), and `None` exactly where a backend cannot know.
#[test]
fn both_backends_report_the_same_step_stats() {
    let (model, params) = scene();
    let ctx = gpu();
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params).expect("GPU solver");
    g.tuning_mut().set_adaptive_cg_budget(false);
    let mut c = wgcloth::CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
    for batch in [1, 7, 12] {
        let gpu = g.step(batch).expect("GPU steps");
        let cpu = c.step_n(u64::from(batch)).expect("CPU steps");
        let what = format!("after {} steps", cpu.steps);
        assert_eq!(gpu.steps, cpu.steps, "{what}: steps");
        assert_eq!(gpu.cg_iterations, cpu.cg_iterations, "{what}: last CG");
        assert_eq!(
            gpu.cg_max_iterations, cpu.cg_max_iterations,
            "{what}: most CG iterations of the batch"
        );
        assert!(
            cpu.cg_max_iterations >= cpu.cg_iterations,
            "{what}: {cpu:?}"
        );
        // The residual stays on the device; only the GPU has a budget.
        assert!(gpu.cg_residual.is_none(), "{what}: {gpu:?}");
        assert!(cpu.cg_residual.is_some(), "{what}: {cpu:?}");
        assert_eq!(gpu.cg_budget_hits, Some(0), "{what}: {gpu:?}");
        assert_eq!(cpu.cg_budget_hits, None, "{what}: {cpu:?}");
    }
}

#[test]
fn adaptive_cg_budget_shrinks_without_changing_the_result() {
    let (model, mut params) = scene();
    // The default cap, far above what CG needs here, for the budget to
    // shrink from (busy_params' is close above it).
    params.implicit.max_iterations = Params::default().implicit.max_iterations;
    let ctx = gpu();
    // The budget is the multi-dispatch path's (the workgroup path's loop
    // stops when CG does), which this small cloth would not take by itself.
    let multi = || {
        GpuSolver::with_step_path(
            ctx.kernels(),
            &ctx.queue,
            &model,
            &params,
            StepPath::MultiDispatch,
        )
        .expect("GPU solver")
    };
    let mut adaptive = multi();
    let mut exact = multi();
    exact.tuning_mut().set_adaptive_cg_budget(false);
    let mut hits = 0;
    for _ in 0..40 {
        hits = adaptive
            .step(1)
            .expect("GPU step")
            .cg_budget_hits
            .expect("the GPU counts budget hits");
        exact.step(1).expect("GPU step");
    }
    assert!(
        adaptive.tuning().cg_budget() < params.implicit.max_iterations / 2,
        "budget {} of {}",
        adaptive.tuning().cg_budget(),
        params.implicit.max_iterations
    );
    assert_eq!(hits, 0, "a solve was cut short");
    let a = adaptive.read_state().expect("read");
    let e = exact.read_state().expect("read");
    let (d, p) = worst(&a.x, &e.x);
    assert!(d == 0.0, "particle {p} differs by {d:e} m");
}
