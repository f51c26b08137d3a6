//! The GPU implicit integrator (CG on the device) against the CPU f32
//! mirror, on lavapipe in CI.

mod gpu_common;

use gpu_common::agreement::{self, Policy, Stepper};
use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuSolver, StepPath};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn scene() -> (Model, Params) {
    let mut params = busy_params(Integrator::Implicit);
    params.springs[0].stiffness = 500.0;
    params.implicit.tolerance = 1e-4;
    (grid(17, 13, corners(), &params), params)
}

/// Steps of the long comparison: long enough for the busy scene's cloth to
/// reach its sphere and the ground, where contacts switch on and off.
const LONG: u32 = 100;

/// The GPU sums every dot product in the CPU's (block) order, so under
/// the bits policy its CG iterates are the mirror's, iteration counts
/// included, after 1 and after [`LONG`] steps; under the bounded policy
/// each step, from the mirror re-seeded with the device's state, lies
/// within what CG's tolerance allows (`agreement::implicit_step`).
#[test]
fn implicit_matches_the_cpu_mirror() {
    let (model, params) = scene();
    let bound = agreement::implicit_step(params.implicit.tolerance);
    for steps in [1, LONG] {
        let mut g = exact_gpu(&model, &params);
        let mut c = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
        agreement::assert_steps("implicit", &mut g, &mut c, steps, &bound);
    }
}

/// The implicit scene's step bound at its tolerance, a GPU solver that
/// records the whole CG budget, its `f32` mirror and an `f64` judge.
fn judged() -> (agreement::Bound, GpuSolver, CpuSolver<f32>, CpuSolver<f64>) {
    let (model, params) = scene();
    (
        agreement::implicit_step(params.implicit.tolerance),
        exact_gpu(&model, &params),
        CpuSolver::<f32>::new(&model, &params).expect("CPU solver"),
        CpuSolver::<f64>::new(&model, &params).expect("f64 judge"),
    )
}

/// On every adapter, whatever the policy: each step's `Δv`, from the
/// mirror re-seeded with the device's state, satisfies the system an `f64`
/// solver assembles at that state to CG's tolerance (plus what `f32`
/// rounding of CG's recursive residual allows), its constraint decisions
/// the `f64` solver's but for a counted few (`agreement::FILTER_FLIPS`).
#[test]
fn each_implicit_step_satisfies_its_system_in_f64() {
    let (bound, mut g, mut c, mut judge) = judged();
    agreement::check_reseeded_judged("implicit", &mut g, &mut c, Some(&mut judge), LONG, &bound)
        .unwrap_or_else(|e| panic!("{e}"));
}

/// The `f64` residual can fail: the device's own answer passes it, and the
/// same answer scaled by ten times what it admits does not.
#[test]
fn the_f64_residual_rejects_an_answer_ten_bounds_off() {
    const WARM: u32 = 20;
    let (bound, mut g, mut c, mut judge) = judged();
    agreement::check_reseeded_judged("warm-up", &mut g, &mut c, Some(&mut judge), WARM, &bound)
        .unwrap_or_else(|e| panic!("{e}"));
    let before = Stepper::state(&g);
    g.step(1).expect("GPU step");
    let (dv, kinds) = g.implicit_answer().expect("the GPU keeps its Δv");
    agreement::check_implicit_residual("as it is", &mut judge.clone(), &before, &dv, &kinds, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let admitted = scene().1.implicit.tolerance + agreement::RESIDUAL_GAP;
    let off: Vec<_> = dv
        .iter()
        .map(|d| *d * (1.0 + 10.0 * admitted) as f32)
        .collect();
    let verdict =
        agreement::check_implicit_residual("scaled", &mut judge, &before, &off, &kinds, false);
    assert!(verdict.is_err(), "an answer ten bounds off passed");
}

#[test]
fn gpu_cg_iterations_match_the_cpu() {
    let (model, params) = scene();
    let mut g = exact_gpu(&model, &params);
    let mut c = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
    let bounded = agreement::policy() == Policy::Bounded;
    for step in 1..=20 {
        if bounded {
            let s = g.read_state().expect("GPU read-back");
            agreement::reseed(&mut c, &(s.x, s.v));
        }
        let status = g.step(1).expect("GPU step");
        let stats = c.step().expect("CPU step");
        assert!(
            status.cg_iterations > 0,
            "step {step}: the GPU did no CG iteration"
        );
        let margin = agreement::cg_iteration_margin();
        assert!(
            status.cg_iterations.abs_diff(stats.cg_iterations) <= margin,
            "step {step}: CG iterations {} on the GPU, {} on the mirror (margin {margin})",
            status.cg_iterations,
            stats.cg_iterations
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
        // Under the bounded policy the runs part within rounding, and
        // their CG counts within the margin of one step's.
        let margin = agreement::cg_iteration_margin();
        assert!(
            gpu.cg_iterations.abs_diff(cpu.cg_iterations) <= margin,
            "{what}: last CG {gpu:?} {cpu:?}"
        );
        assert!(
            gpu.cg_max_iterations.abs_diff(cpu.cg_max_iterations) <= margin,
            "{what}: most CG iterations of the batch {gpu:?} {cpu:?}"
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
    for _ in 0..40 {
        // A step the budget cuts short is counted and run again with a
        // larger one (the bits below), so hits may occur.
        adaptive
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
    let a = adaptive.read_state().expect("read");
    let e = exact.read_state().expect("read");
    let (d, p) = worst(&a.x, &e.x);
    assert!(d == 0.0, "particle {p} differs by {d:e} m");
}
