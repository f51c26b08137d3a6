//! The GPU implicit integrator (CG on the device) against the CPU f32
//! mirror, on lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::gpu::GpuSolver;
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

#[test]
fn adaptive_cg_budget_shrinks_without_changing_the_result() {
    let (model, params) = scene();
    let ctx = gpu();
    let mut adaptive =
        GpuSolver::new(&ctx.device, &ctx.queue, &model, &params).expect("GPU solver");
    let mut exact = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params).expect("GPU solver");
    exact.tuning_mut().set_adaptive_cg_budget(false);
    let mut hits = 0;
    for _ in 0..40 {
        hits = adaptive.step(1).expect("GPU step").cg_budget_hits;
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
