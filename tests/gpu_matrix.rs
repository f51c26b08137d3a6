//! Every scene feature × integrator × step path, lone and batched, against
//! the `f32` CPU mirror under the agreement policy (bit for bit on
//! lavapipe and SwiftShader). Small cloths (9 × 9) keep the matrix cheap;
//! each scene is written as a user writes one (`Scene::from_toml`), so
//! what the CLI runs is what is compared.

mod gpu_common;

use std::path::Path;

use gpu_common::agreement;
use gpu_common::gpu;
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuBatch, GpuSolver, StepPath};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params, Scene};

/// Steps of each comparison: at 1/120 s the cloths fall onto what is
/// under them within 0.06 s and rest on it by 0.5 s; the explicit step's
/// cloth, at [`EXPLICIT_DT`], reaches it within 55 steps.
const STEPS: u32 = 60;

/// The explicit step: what the stiffest cloth (200 N/m on 0.125 m cells
/// and 3.7 g particles, four springs of each kind) with its bending is
/// stable at (the solver's refusal, a Gershgorin bound of the springs'
/// and bending's vibration, admits 1e-5 N·m of bending from 1.4 ms down).
const EXPLICIT_DT: f64 = 1e-3;

/// A 9 × 9 scene: a 1 m cloth with `cloth` (the cloth's mass or material
/// keys) a few centimetres above what `under` puts below it, pinned at
/// one corner, stepped by `integrator` with the GPU's fix-up (Jacobi) on
/// both sides.
fn scene(under: &Under, cloth: &str, integrator: Integrator) -> (Model, Params) {
    let (name, dt) = match integrator {
        Integrator::Explicit => ("explicit", EXPLICIT_DT),
        Integrator::Implicit => ("implicit", 1.0 / 120.0),
        Integrator::SemiImplicit => ("semi-implicit", 1.0 / 120.0),
    };
    let text = format!(
        "[simulation]\nintegrator = \"{name}\"\ndt = {dt}\nduration = 1.0\n\
         [cloth]\nresolution = [9, 9]\nsize = [1.0, 1.0]\norigin = [-0.5, {height}, -0.5]\n\
         orientation = \"horizontal\"\npins = [\"top-left\"]\n{cloth}\n\
         [implicit]\ntolerance = 1e-4\nmax_iterations = 60\n\
         [fixup]\nmethod = \"jacobi\"\n\
         [ground]\nheight = 0.0\nfriction = 0.5\n{colliders}\n",
        height = under.height,
        colliders = under.colliders,
    );
    // The scene's folder is scenes/, so a collider's mesh is found there.
    let scene = Scene::from_toml(&text, Path::new("scenes/matrix.toml"))
        .unwrap_or_else(|e| panic!("{text}\n{e}"));
    let model = scene.model().unwrap_or_else(|e| panic!("{text}\n{e}"));
    (model, scene.params)
}

/// Springs in spring units, soft enough (50 N/m) for the fix-up to move
/// particles as the cloth lands.
const SPRINGS: &str = "mass = 0.3\n\
    [springs.stretch]\nstiffness = 50.0\ndamping = 0.05\n\
    [springs.shear]\nstiffness = 20.0\ndamping = 0.02\n\
    [springs.bend]\nstiffness = 5.0\ndamping = 0.001";

/// A material without bending (the fix-up's limit applies to its stretch
/// springs too).
const MATERIAL: &str = "[material]\ndensity = 0.3\nstretch = 200.0\nshear = 50.0\ndamping = 0.002";

/// A material with the linear bending model, below the explicit step's
/// limit at [`EXPLICIT_DT`].
const MATERIAL_BENDING: &str =
    "[material]\ndensity = 0.3\nstretch = 200.0\nshear = 50.0\ndamping = 0.002\nbending = 1e-5";

/// What lies under the cloth besides the ground, and how high the cloth
/// starts \[m\].
struct Under {
    colliders: &'static str,
    height: f64,
}

/// A ball (its top at 0.75 m) under the cloth, and wind.
const BALL_AND_WIND: Under = Under {
    colliders: "[[sphere]]\ncenter = [0.0, 0.45, 0.0]\nradius = 0.3\nfriction = 0.4\n\
        [wind]\nvelocity = [2.0, 0.0, 1.0]\ndrag = 0.5\nlift = 0.1",
    height: 0.765,
};

/// The built-in table (a non-convex closed mesh, its top at 0.76 m, its
/// contact surface a thickness above) under the cloth.
const TABLE: Under = Under {
    colliders: "[[collider]]\nmesh = \"table.obj\"\nposition = [0.0, 0.0, 0.0]\n\
        rotation = [0.0, 1.0, 0.0, 0.0]\nfriction = 0.6\nresolution = 64\nthickness = 0.012",
    height: 0.785,
};

/// The ground alone, 5 cm below the cloth: the cloth lands within 0.1 s
/// and friction stops it, so velocities become zeros (kernels specialised
/// for a ground alone once stored some as −0).
const GROUND: Under = Under {
    colliders: "",
    height: 0.05,
};

/// How far below the ground \[m\] a particle may end a step: collisions
/// put it on the plane (`y = 0`), to the rounding of its position.
const BELOW_GROUND: f64 = 1e-6;

/// What holds of the device's own run on any adapter (the bounded tier
/// re-seeds the mirror, never the device): every position and velocity
/// finite, the pinned particle exactly where it was put, no particle
/// below the ground.
fn invariants(what: &str, model: &Model, state: &agreement::States) -> Result<(), String> {
    let (x, v) = state;
    if let Some(p) = (0..x.len()).find(|&p| !x[p].is_finite() || !v[p].is_finite()) {
        return Err(format!("{what}: particle {p} is not finite"));
    }
    for (p, _) in model
        .pinned
        .iter()
        .enumerate()
        .filter(|(_, &pinned)| pinned)
    {
        let rest = model.rest_positions[p].as_vec3();
        if x[p].to_array().map(f32::to_bits) != rest.to_array().map(f32::to_bits) {
            return Err(format!(
                "{what}: pinned particle {p} at {}, not {rest}",
                x[p]
            ));
        }
    }
    if let Some(p) = (0..x.len()).find(|&p| f64::from(x[p].y) < -BELOW_GROUND) {
        return Err(format!("{what}: particle {p} below the ground at {}", x[p]));
    }
    Ok(())
}

/// The GPU on each step path, and copy 0 of a batch of two, against the
/// mirror for every integrator; `what` names the scene.
fn check_every_path(what: &str, under: &Under, cloth: &str) {
    let ctx = gpu();
    let mut failures = Vec::new();
    for integrator in [
        Integrator::Explicit,
        Integrator::Implicit,
        Integrator::SemiImplicit,
    ] {
        let (model, params) = scene(under, cloth, integrator);
        let bound = agreement::step_bound(&params);
        let mirror = || CpuSolver::<f32>::new(&model, &params).expect("CPU mirror");
        // The implicit step's answers are held to their f64 residual too
        // (under the bounded policy).
        let judge = || CpuSolver::<f64>::new(&model, &params).expect("f64 judge");
        for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
            let mut g = GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &model, &params, path)
                .unwrap_or_else(|e| panic!("{what}, {integrator}, {path}: {e}"));
            let label = format!("{what}, {integrator}, {path}");
            let mut j = judge();
            if let Err(e) = agreement::check_steps_judged(
                &label,
                &mut g,
                &mut mirror(),
                Some(&mut j),
                STEPS,
                &bound,
            )
            .and_then(|()| invariants(&label, &model, &agreement::Stepper::state(&g)))
            {
                failures.push(e);
            }
        }
        let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
        let id = batch.add(&model, &params).expect("batch copy 0");
        batch.add(&model, &params).expect("batch copy 1");
        let mut copy = agreement::BatchCloth { batch, id };
        let label = format!("{what}, {integrator}, batch copy 0 of 2");
        if let Err(e) = agreement::check_steps(&label, &mut copy, &mut mirror(), STEPS, &bound)
            .and_then(|()| invariants(&label, &model, &agreement::Stepper::state(&copy)))
        {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn springs_with_a_ball_and_wind() {
    check_every_path("springs, ball, wind", &BALL_AND_WIND, SPRINGS);
}

#[test]
fn a_material() {
    check_every_path("material", &BALL_AND_WIND, MATERIAL);
}

#[test]
fn a_material_with_bending() {
    check_every_path("material with bending", &BALL_AND_WIND, MATERIAL_BENDING);
}

#[test]
fn a_non_convex_closed_mesh() {
    check_every_path("springs on the table mesh", &TABLE, SPRINGS);
}

#[test]
fn resting_on_the_ground() {
    check_every_path("springs on the ground", &GROUND, SPRINGS);
}

/// `GpuSolver::step` never depends on the CG budget: on the built-in
/// `table` (33 × 27, implicit, on its own path), whose CG needs 20
/// iterations a step in the air and up to 60 as the cloth lands, a budget
/// adapted between one-step submits is cut short at the landing (a hit is
/// counted), and the steps are then run again with the full budget — the
/// same bits as a solver that always records the full budget, on every
/// adapter (one device, the same kernels).
#[test]
fn a_step_cut_short_by_the_cg_budget_is_run_again() {
    let scene = Scene::builtin("table").expect("the table scene");
    let model = scene.model().expect("the table's cloth");
    let ctx = gpu();
    let solver = |adaptive: bool| {
        let mut g = GpuSolver::with_step_path(
            ctx.kernels(),
            &ctx.queue,
            &model,
            &scene.params,
            StepPath::MultiDispatch,
        )
        .expect("GPU solver");
        g.tuning_mut().set_adaptive_cg_budget(adaptive);
        g
    };
    let (mut adaptive, mut full) = (solver(true), solver(false));
    let mut hits = 0;
    for _ in 0..TABLE_LANDING_STEPS {
        hits = adaptive
            .step(1)
            .expect("adaptive step")
            .cg_budget_hits
            .expect("the GPU counts budget hits");
        full.step(1).expect("full step");
    }
    assert!(
        hits > 0,
        "the budget never cut a step short: nothing tested"
    );
    let (a, f) = (
        adaptive.read_state().expect("read-back"),
        full.read_state().expect("read-back"),
    );
    let words = |s: &wgcloth::gpu::GpuState| -> Vec<u32> {
        agreement::flat(&s.x)
            .into_iter()
            .chain(agreement::flat(&s.v))
            .map(f32::to_bits)
            .collect()
    };
    agreement::check_bits(
        "table, adaptive against full budget",
        &words(&a),
        &words(&f),
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

/// Steps of the `table` scene until its cloth has landed (it touches the
/// table at step 20).
const TABLE_LANDING_STEPS: u32 = 30;
