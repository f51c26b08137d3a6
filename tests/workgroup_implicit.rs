//! The implicit step on the workgroup path (`shaders/cloth_implicit.wgsl`:
//! one workgroup steps the whole cloth, CG with its reductions and coarse
//! levels included) against the multi-dispatch path and the `f32` CPU
//! mirror: every particle's position and velocity bit for bit, and the CG
//! iterations of every step, on lavapipe in CI.

mod gpu_common;

use gpu_common::agreement::{self, Policy};

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::gpu::{GpuKernels, GpuSolver, StepPath};
use wgcloth::model::{ClothSpec, Orientation};
use wgcloth::params::{Capsule, Integrator};
use wgcloth::{Error, Model, Params, PinTarget, Scene};

/// Steps of the longer comparison: the busy scene's cloth swings in the
/// wind and reaches the sphere, the capsule and the ground within them, so
/// CG's filters include contact planes.
const LONG_STEPS: u32 = 60;

/// The kernel library every solver of this file shares (the test
/// adapter's), so each pipeline compiles once per test process.
fn kernels() -> &'static GpuKernels {
    gpu().kernels()
}

/// A GPU solver on `path` that records the whole CG budget every step (the
/// adaptive budget could cut a multi-dispatch step short of the mirror's
/// iterations; the workgroup path has no budget).
fn on_path(model: &Model, params: &Params, path: StepPath) -> GpuSolver {
    let mut g = GpuSolver::with_step_path(kernels(), &gpu().queue, model, params, path)
        .unwrap_or_else(|e| panic!("GPU solver on the {path} path: {e}"));
    g.tuning_mut().set_adaptive_cg_budget(false);
    assert_eq!(g.tuning().step_path(), path);
    g
}

/// Busy implicit parameters: wind, ground, a sphere and a capsule the
/// falling cloth reaches.
fn busy() -> Params {
    let mut p = busy_params(Integrator::Implicit);
    p.capsules = vec![Capsule {
        a: DVec3::new(-0.6, 0.55, 0.3),
        b: DVec3::new(0.6, 0.55, 0.3),
        radius: 0.1,
        friction: 0.4,
        velocity: DVec3::ZERO,
    }];
    p
}

/// The first word where two states differ: which vector, the particle,
/// and both values.
fn first_difference(what: &str, a: &[Vec3], b: &[Vec3]) -> Option<String> {
    if a.len() != b.len() {
        return Some(format!("{what}: {} against {} particles", a.len(), b.len()));
    }
    let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
    let p = a.iter().zip(b).position(|(u, w)| bits(u) != bits(w))?;
    Some(format!(
        "{what} of particle {p}: {:?} against {:?}",
        a[p], b[p]
    ))
}

/// The three solvers a case steps alike: each path with a mirror of its
/// own (the same mirror twice under the bits policy; under the bounded
/// one each is re-seeded with its path's state before every step).
struct Three {
    workgroup: GpuSolver,
    multi: GpuSolver,
    mirrors: [CpuSolver<f32>; 2],
    bound: agreement::Bound,
}

impl Three {
    fn new(model: &Model, params: &Params) -> Three {
        let mirror = || CpuSolver::new(model, params).unwrap_or_else(|e| panic!("CPU solver: {e}"));
        Three {
            workgroup: on_path(model, params, StepPath::Workgroup),
            multi: on_path(model, params, StepPath::MultiDispatch),
            mirrors: [mirror(), mirror()],
            bound: agreement::step_bound(params),
        }
    }

    /// One step of each, each path's state checked against its mirror's
    /// under the agreement policy; the CG iterations each reports
    /// (workgroup, multi-dispatch, their mirrors).
    fn step(&mut self, what: &str) -> [u32; 4] {
        let mut out = [0; 4];
        for (k, (g, mirror)) in [&mut self.workgroup, &mut self.multi]
            .into_iter()
            .zip(&mut self.mirrors)
            .enumerate()
        {
            let before = agreement::before_step(g, mirror);
            out[k] = g.step(1).expect("GPU step").cg_iterations;
            out[2 + k] = mirror.step().expect("CPU step").cg_iterations;
            let after = agreement::Stepper::state(g);
            agreement::check_after_step(
                &format!("{what}, {}", g.tuning().step_path()),
                &before,
                &after,
                mirror,
                &self.bound,
            )
            .unwrap_or_else(|e| panic!("{e}"));
        }
        out
    }

    /// Where the workgroup path's state differs from the multi-dispatch
    /// path's, if anywhere (under the bits policy: both are the mirror's,
    /// which `step` checks).
    fn differences(&self) -> Vec<String> {
        let wg = self.workgroup.read_state().expect("read workgroup");
        let md = self.multi.read_state().expect("read multi-dispatch");
        [
            first_difference("x against multi-dispatch", &wg.x, &md.x),
            first_difference("v against multi-dispatch", &wg.v, &md.v),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Steps `model` under `params` `steps` steps on the three solvers (`each`
/// runs before every step, on all three): the CG iterations agree at every
/// step, and x and v bit for bit after the first and the last. Returns the
/// iterations of each step.
fn check_case(
    name: &str,
    model: &Model,
    params: &Params,
    steps: u32,
    mut each: impl FnMut(u32, &mut Three),
) -> Vec<u32> {
    let mut three = Three::new(model, params);
    let mut iterations = Vec::new();
    for step in 1..=steps {
        each(step, &mut three);
        let [wg, md, cpu_wg, cpu_md] = three.step(&format!("{name}, step {step}"));
        let margin = agreement::cg_iteration_margin();
        assert!(
            wg.abs_diff(cpu_wg) <= margin && md.abs_diff(cpu_md) <= margin,
            "{name}, step {step}: CG iterations {wg} (workgroup), {md} (multi-dispatch), \
             {cpu_wg} and {cpu_md} (their mirrors; margin {margin})"
        );
        iterations.push(wg);
        if agreement::policy() == Policy::Bits && (step == 1 || step == steps) {
            let diff = three.differences();
            assert!(diff.is_empty(), "{name}, step {step}: {}", diff.join("; "));
        }
    }
    eprintln!("{name}: CG iterations {iterations:?}");
    iterations
}

#[test]
fn a_grid_with_coarse_levels_and_every_collider_matches_bit_for_bit() {
    let params = busy();
    assert!(
        params.implicit.coarse_levels,
        "coarse levels are the default"
    );
    let model = grid(17, 17, corners(), &params);
    let its = check_case("17² coarse", &model, &params, LONG_STEPS, |_, _| {});
    assert!(its.iter().all(|&k| k > 0), "CG ran every step: {its:?}");
}

#[test]
fn a_grid_without_coarse_levels_matches_bit_for_bit() {
    let mut params = busy();
    params.implicit.coarse_levels = false;
    let model = grid(17, 17, corners(), &params);
    check_case("17² block Jacobi", &model, &params, LONG_STEPS, |_, _| {});
}

/// Steps of the 33² comparison. What that cloth adds to the 17² ones is
/// its size — up to five particles per invocation in every phase (two at
/// 17²) and 18 reduction blocks (five) — which every step exercises; the
/// contacts the longer comparisons reach are theirs.
const SIZE_STEPS: u32 = 4;

#[test]
fn a_cloth_of_33_squared_matches_bit_for_bit() {
    let params = busy();
    let model = grid(33, 33, corners(), &params);
    assert_eq!(model.particle_count(), 1089);
    check_case("33²", &model, &params, SIZE_STEPS, |_, _| {});
}

#[test]
fn irregular_cloths_match_bit_for_bit() {
    // The grid's parts without its grid (no coarse levels): 132
    // particles, three reduction blocks, the last one partial.
    let params = busy();
    let g = grid(12, 11, corners(), &params);
    let parts = without_grid(&g);
    check_case("from_parts 12 × 11", &parts, &params, LONG_STEPS, |_, _| {});
    // A mesh cloth (the built-in glTF banner).
    let mut scene = Scene::builtin("banner").expect("built in");
    scene.params.integrator = Integrator::Implicit;
    let mesh = scene.model().expect("valid");
    check_case("banner mesh", &mesh, &scene.params, LONG_STEPS, |_, _| {});
}

#[test]
fn a_moving_pin_goal_matches_bit_for_bit() {
    let params = busy();
    let model = grid(17, 17, corners(), &params);
    // A new goal every 4 steps: the pins move a circle of 10 cm.
    const FRAME_STEPS: u32 = 4;
    let frame_seconds = f64::from(FRAME_STEPS) * params.dt;
    let pinned: Vec<usize> = (0..model.particle_count())
        .filter(|&p| model.pinned[p])
        .collect();
    check_case("moving pins", &model, &params, LONG_STEPS, |step, three| {
        if (step - 1) % FRAME_STEPS != 0 {
            return;
        }
        let angle = f64::from(step) * 0.05;
        let offset = DVec3::new(angle.cos() - 1.0, 0.0, angle.sin()) * 0.1;
        let targets: Vec<PinTarget> = pinned
            .iter()
            .map(|&p| PinTarget {
                particle: p,
                position: (model.rest_positions[p] + offset).as_vec3(),
            })
            .collect();
        three
            .workgroup
            .set_pin_targets(&targets, frame_seconds)
            .expect("targets");
        three
            .multi
            .set_pin_targets(&targets, frame_seconds)
            .expect("targets");
        for mirror in &mut three.mirrors {
            mirror
                .set_pin_targets(&targets, frame_seconds)
                .expect("targets");
        }
    });
}

#[test]
fn cg_stops_where_the_mirror_does_early_or_at_its_maximum() {
    let model = grid(17, 17, corners(), &busy());
    // A loose tolerance: CG converges within a few iterations.
    let mut loose = busy();
    loose.implicit.tolerance = 1e-2;
    let its = check_case("tolerance 1e-2", &model, &loose, 20, |_, _| {});
    assert!(
        its.iter().all(|&k| k < loose.implicit.max_iterations),
        "{its:?}"
    );
    // A tolerance f32 cannot reach: every step once the cloth moves runs
    // the maximum (the first, from rest, may break down before it when
    // the direction vanishes to rounding).
    let mut tight = busy();
    tight.implicit.tolerance = 1e-12;
    tight.implicit.max_iterations = 12;
    let its = check_case("tolerance 1e-12", &model, &tight, 20, |_, _| {});
    assert!(its[1..].iter().all(|&k| k == 12), "{its:?}");
}

/// A free cloth launched at this speed [m/s] leaves `f32`'s range after
/// ⌈f32::MAX / (speed dt)⌉ = 121 steps of 1/120 s: a blow-up at a step
/// well past the first, which every path must report at the same step.
const LAUNCH_SPEED: f32 = 3.0e38;

/// The CG cap of the blow-up test. Whether CG stops on its tolerance or at
/// the cap, each path stops where the mirror does (see
/// `cg_stops_where_the_mirror_does_early_or_at_its_maximum`), so the cap
/// changes nothing the test asserts; it bounds the dispatches the
/// multi-dispatch path records every step with the adaptive budget off
/// (the default cap, 200, over 120 steps).
const BLOW_UP_CG_MAX_ITERATIONS: u32 = 20;

#[test]
fn a_blow_up_is_reported_at_the_mirror_step() {
    let mut params = Params {
        integrator: Integrator::Implicit,
        dt: 1.0 / 120.0,
        ..Params::default()
    };
    params.implicit.max_iterations = BLOW_UP_CG_MAX_ITERATIONS;
    let spec = ClothSpec {
        nx: 9,
        ny: 9,
        orientation: Orientation::Vertical,
        pins: Vec::new(),
        ..ClothSpec::default()
    };
    let model = Model::new(&spec, &params.springs).expect("valid");
    let launch = Vec3::new(LAUNCH_SPEED, 0.0, 0.0);
    let mut mirror = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
    let x = mirror.positions();
    mirror
        .set_positions_and_velocities(&x, &vec![launch; x.len()])
        .expect("finite");
    let mirror_step = match mirror.step_n(1000) {
        Err(Error::NonFinite { step, .. }) => step,
        other => panic!("the CPU mirror should blow up: {other:?}"),
    };
    assert!(mirror_step > 100, "blew up at step {mirror_step}");
    for path in [StepPath::Workgroup, StepPath::MultiDispatch] {
        let mut g = on_path(&model, &params, path);
        for p in 0..model.particle_count() {
            g.set_velocity(p, launch).expect("finite");
        }
        match g.step(1000) {
            Err(Error::NonFinite { step, .. }) => {
                agreement::assert_blow_up_step(&format!("{path}"), step, mirror_step);
            }
            other => panic!("the {path} path should report the blow-up: {other:?}"),
        }
    }
}

#[test]
fn an_implicit_cloth_within_the_limit_takes_the_workgroup_path() {
    let params = busy();
    let ctx = gpu();
    let small = grid(17, 17, corners(), &params);
    // Whether it is also the automatic choice is the cost model's to say
    // (`src/gpu/path.rs`): here the path must accept the cloth.
    let g = GpuSolver::with_step_path(kernels(), &ctx.queue, &small, &params, StepPath::Workgroup)
        .expect("GPU solver");
    assert_eq!(g.tuning().step_path(), StepPath::Workgroup);
    // 65² = 4225 particles, past WORKGROUP_STEP_MAX_PARTICLES = 4096:
    // forcing the workgroup path is refused, naming the limit.
    let large = grid(65, 65, corners(), &params);
    match GpuSolver::with_step_path(kernels(), &ctx.queue, &large, &params, StepPath::Workgroup) {
        Err(e @ Error::InvalidParameter { .. }) => {
            let message = e.to_string();
            assert!(
                message.contains("WORKGROUP_STEP_MAX_PARTICLES"),
                "{message}"
            );
        }
        other => panic!("the workgroup path beyond its limit must be refused: {other:?}"),
    }
}
