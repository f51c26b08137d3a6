//! The linear bending model (`[material] bending`, `src/bending.rs`) on
//! the GPU: every integrator on every path — the multi-dispatch kernels
//! (the grid's own and the general ones), the workgroup kernels, a batch
//! holding cloths with and without it — steps it as the `f32` CPU mirror
//! does, bit for bit, on a grid (`Bending::grid`) and on a mesh
//! (`Bending::new`). The semi-implicit filter solved by CG, which the CPU
//! solves exactly instead, is checked kernel by kernel in
//! `tests/kernel_twins.rs`.

mod gpu_common;

use gpu_common::agreement;

use gpu_common::{busy_params, corners, gpu, grid, without_grid};
use wgcloth::bending::Bending;
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuBatch, GpuSolver, StepPath};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

/// The cloth's particles along a row and across rows (the kernel twin
/// tests' cloth: two blocks of 64 and a partial one).
const NX: usize = 12;
const NY: usize = 11;

/// Steps compared: enough for the bending force to shape the sagging
/// cloth (the test checks that it changes the result) and for the
/// implicit CG to take several iterations a step; few, because lavapipe
/// is slow.
const STEPS: u32 = 30;

/// Bending stiffness \[N·m\]: large enough to change the drape of the
/// 1 m, 0.1 kg test cloth within [`STEPS`] (Γ = ρ g L³ / B ≈ 1), small
/// enough for the explicit integrator at its 1 ms step.
const BENDING: f64 = 1e-3;

/// Rayleigh damping of the bending force \[s\] (non-zero, so its `β` term
/// is in every comparison).
const BENDING_DAMPING: f64 = 0.005;

/// `model` with the linear bending operator a material would give it:
/// Bergou's on its triangles where `mesh` (the general kernels then run
/// it: a mesh has no grid layout), else the grid's Hessian operator.
fn with_bending(model: Model, mesh: bool) -> Model {
    let mut model = if mesh { without_grid(&model) } else { model };
    model.bending = Some(if mesh {
        Bending::new(
            &model.rest_positions,
            &model.triangles,
            BENDING,
            &[],
            BENDING_DAMPING,
            &model.pinned,
        )
        .expect("a flat mesh")
    } else {
        let (hx, hy) = (1.0 / (NX - 1) as f64, 1.0 / (NY - 1) as f64);
        Bending::grid(NX, NY, hx, hy, BENDING, BENDING_DAMPING, &model.pinned).expect("a grid")
    });
    model
}

/// The cloths compared for `integrator`: a grid in the busy scene (wind,
/// ground, sphere) with its stretch springs limited (so the fix-up runs);
/// a mesh without wind or fix-up (the explicit general kernels would then
/// fuse the step and update the state in place, which the bending force's
/// reads of the neighbours forbid); and for the explicit integrator the
/// grid without wind or fix-up (one kernel per step, alternating the state
/// with a snapshot).
fn cloths(integrator: Integrator) -> Vec<(&'static str, Model, Params)> {
    let busy = {
        let mut p = busy_params(integrator);
        p.springs[0].max_stretch = Some(1.0);
        p
    };
    let calm = {
        let mut p = busy_params(integrator);
        p.wind = None;
        p.fixup.iterations = 0;
        p
    };
    let mut out = vec![
        (
            "grid",
            with_bending(grid(NX, NY, corners(), &busy), false),
            busy,
        ),
        (
            "mesh",
            with_bending(grid(NX, NY, corners(), &calm), true),
            calm.clone(),
        ),
    ];
    if integrator == Integrator::Explicit {
        let model = with_bending(grid(NX, NY, corners(), &calm), false);
        out.push(("grid without fix-up", model, calm));
    }
    out
}

/// The mirror after [`STEPS`].
fn mirror(model: &Model, params: &Params) -> CpuSolver<f32> {
    let mut c = CpuSolver::<f32>::new(model, params).expect("CPU solver");
    c.step_n(u64::from(STEPS)).expect("CPU steps");
    c
}

/// A GPU solver on `path` with the scene's kernels (`specialised`: on a
/// grid, the grid's) or the general ones, recording the whole CG budget
/// every step as the mirror iterates.
fn solver(model: &Model, params: &Params, path: StepPath, specialised: bool) -> GpuSolver {
    let ctx = gpu();
    let mut g = GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, model, params, path)
        .unwrap_or_else(|e| panic!("GPU solver on the {path} path: {e}"));
    let mut tuning = g.tuning_mut();
    tuning.set_adaptive_cg_budget(false);
    tuning
        .set_specialised(specialised)
        .unwrap_or_else(|e| panic!("kernels: {e}"));
    g
}

#[test]
fn every_gpu_path_steps_the_linear_bending_model_as_the_f32_mirror_bit_for_bit() {
    let ctx = gpu();
    for integrator in Integrator::ALL {
        for (cloth, model, params) in cloths(integrator) {
            let want = mirror(&model, &params);
            let x = want.positions();
            // The bending model shapes the result: without it the same
            // cloth ends elsewhere (so a GPU that left it out would fail).
            let mut plain = model.try_clone().expect("clone");
            plain.bending = None;
            let without = mirror(&plain, &params);
            assert_ne!(
                without.positions(),
                x,
                "{integrator} {cloth}: the bending force changed nothing"
            );
            let mut solvers = vec![
                (
                    "workgroup",
                    solver(&model, &params, StepPath::Workgroup, true),
                ),
                (
                    "multi-dispatch",
                    solver(&model, &params, StepPath::MultiDispatch, true),
                ),
                (
                    "multi-dispatch, general kernels",
                    solver(&model, &params, StepPath::MultiDispatch, false),
                ),
            ];
            let bound = agreement::step_bound(&params);
            let fresh = |m: &Model| CpuSolver::<f32>::new(m, &params).expect("CPU solver");
            for (path, g) in &mut solvers {
                let what = format!("{integrator} {cloth} {path}");
                agreement::assert_steps(&what, g, &mut fresh(&model), STEPS, &bound);
            }
            // A batch steps a cloth with the model beside one without.
            for (which, m) in [("with", &model), ("without", &plain)] {
                let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
                let bent = batch.add(&model, &params).expect("add the bending cloth");
                let limp = batch.add(&plain, &params).expect("add the plain cloth");
                let id = if which == "with" { bent } else { limp };
                let what = format!("{integrator} {cloth} batch, {which} bending");
                let mut copy = agreement::BatchCloth { batch, id };
                agreement::assert_steps(&what, &mut copy, &mut fresh(m), STEPS, &bound);
            }
        }
    }
}

#[test]
fn an_explicit_solver_built_through_the_api_refuses_a_bending_too_stiff_for_its_step() {
    let ctx = gpu();
    let mut params = busy_params(Integrator::Explicit);
    params.dt = 0.01;
    let model = {
        let mut m = grid(NX, NY, corners(), &params);
        let (hx, hy) = (1.0 / (NX - 1) as f64, 1.0 / (NY - 1) as f64);
        m.bending = Some(Bending::grid(NX, NY, hx, hy, 10.0, 0.0, &[]).expect("a grid"));
        m
    };
    let refusals = [
        ("CPU", CpuSolver::<f32>::new(&model, &params).err()),
        (
            "GPU",
            GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params).err(),
        ),
        (
            "batch",
            GpuBatch::with_kernels(ctx.kernels(), &ctx.queue)
                .add(&model, &params)
                .err(),
        ),
    ];
    for (solver, e) in refusals {
        let e = e.unwrap_or_else(|| panic!("the {solver} solver took an unstable bending"));
        let text = e.to_string();
        assert!(
            text.contains("material.bending")
                && text.contains("explicit integrator")
                && text.contains("at most"),
            "{solver}: {text}"
        );
    }
    // The same cloth steps implicitly, on both backends.
    params.integrator = Integrator::Implicit;
    CpuSolver::<f32>::new(&model, &params).expect("implicit CPU solver");
    GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params)
        .expect("implicit GPU solver");
}
