//! The workgroup path (`StepPath::Workgroup`: one workgroup steps a whole
//! cloth, `shaders/cloth_*.wgsl`) against the multi-dispatch path and the
//! `f32` CPU mirror, bit for bit, on lavapipe in CI; the automatic choice
//! between the paths and its limit; a blow-up reported at its step.

mod gpu_common;

use gpu_common::agreement::{self, Policy};

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::gpu::{GpuSolver, Kernel, Launch, StepPath};
use wgcloth::kernel_config::WORKGROUP_STEP_MAX_PARTICLES;
use wgcloth::model::Pin;
use wgcloth::params::{Capsule, FilterMethod, Integrator, PinTarget};
use wgcloth::StepStats;
use wgcloth::{Error, Model, Params, Scene};

/// Steps after the first at which the paths and the mirror are compared
/// again: long enough for the busy scenes' cloths to reach the ground and
/// the colliders, and for the fix-up to stop early in some steps.
const LONG: u32 = 99;

/// The state's words: positions then velocities, as bits.
fn bits(x: &[Vec3], v: &[Vec3]) -> Vec<[u32; 3]> {
    x.iter()
        .chain(v)
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// The CPU mirror's state as [`bits`].
fn cpu_bits(c: &CpuSolver<f32>) -> Vec<[u32; 3]> {
    let st = c.state();
    let x: Vec<Vec3> = st.x.iter().map(|p| Vec3::new(p.x, p.y, p.z)).collect();
    let v: Vec<Vec3> = st.v.iter().map(|p| Vec3::new(p.x, p.y, p.z)).collect();
    bits(&x, &v)
}

/// The GPU solver's state as [`bits`].
fn gpu_bits(g: &GpuSolver) -> Vec<[u32; 3]> {
    let s = g.read_state().unwrap_or_else(|e| panic!("read-back: {e}"));
    bits(&s.x, &s.v)
}

/// What both GPU paths report of a submit (the CG budget aside, which only
/// the multi-dispatch path adapts).
fn reported(s: &StepStats) -> (u64, u32, u32, u32) {
    (
        s.steps,
        s.fixup_passes,
        s.cg_iterations,
        s.cg_max_iterations,
    )
}

/// Steps `model` under `params` on both paths and the mirror, `setup`
/// applied to every solver first, and panics unless all three agree bit
/// for bit after 1 and after 1 + [`LONG`] steps and the paths report the
/// same statistics (under the bounded policy: each path within one step's
/// bound of the mirror, re-seeded each step).
fn assert_paths_agree(
    what: &str,
    model: &Model,
    params: &Params,
    setup: impl Fn(&mut GpuSolver, &mut CpuSolver<f32>),
) {
    if agreement::policy() == Policy::Bounded {
        // Each path against the mirror, re-seeded every step: the paths
        // are different kernels, which such an adapter may round apart.
        for path in [StepPath::Workgroup, StepPath::MultiDispatch] {
            let mut g = solver_on(model, params, path);
            let mut c = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU: {e}"));
            setup(&mut g, &mut c);
            let bound = agreement::step_bound(params);
            agreement::check_reseeded(&format!("{what}, {path}"), &mut g, &mut c, 1 + LONG, &bound)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        return;
    }
    let mut wg = solver_on(model, params, StepPath::Workgroup);
    let mut md = solver_on(model, params, StepPath::MultiDispatch);
    let mut cpu = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU: {e}"));
    setup(&mut wg, &mut cpu);
    let mut spare = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU: {e}"));
    setup(&mut md, &mut spare);
    let plan = wg.tuning().step_plan();
    assert!(
        plan.len() == 1 && matches!(plan[0].launch, Launch::Cloths(1)),
        "{what}: one workgroup dispatch per step: {plan:?}"
    );
    let mut done = 0;
    for steps in [1, LONG] {
        let a = wg
            .step(steps)
            .unwrap_or_else(|e| panic!("{what}: workgroup: {e}"));
        let b = md
            .step(steps)
            .unwrap_or_else(|e| panic!("{what}: multi-dispatch: {e}"));
        cpu.step_n(u64::from(steps))
            .unwrap_or_else(|e| panic!("{what}: CPU: {e}"));
        done += steps;
        assert_eq!(
            reported(&a),
            reported(&b),
            "{what}: statistics after {done} steps"
        );
        let (w, m, c) = (gpu_bits(&wg), gpu_bits(&md), cpu_bits(&cpu));
        let first = |other: &[[u32; 3]]| w.iter().zip(other).position(|(p, q)| p != q);
        assert_eq!(
            first(&m),
            None,
            "{what}: workgroup ≠ multi-dispatch after {done} steps"
        );
        assert_eq!(
            first(&c),
            None,
            "{what}: workgroup ≠ CPU mirror after {done} steps"
        );
    }
}

/// The busy explicit scene (wind, ground, a sphere, two pinned corners,
/// Jacobi fix-up) with `fixup` passes and its stretch springs limited to
/// their rest length, so every pass moves something until the last.
fn busy(fixup: u32) -> Params {
    let mut p = busy_params(Integrator::Explicit);
    p.fixup.iterations = fixup;
    p.springs[0].max_stretch = Some(1.0);
    p
}

/// The parts of `model` with every seventh spring left out and the
/// particles moved off the grid: an irregular cloth with no grid.
fn irregular(model: &Model) -> Model {
    let jitter = |k: usize| ((k * 37 % 11) as f64 - 5.0) * 2e-3;
    let x = model
        .rest_positions
        .iter()
        .enumerate()
        .map(|(k, p)| *p + DVec3::new(jitter(k), 0.0, jitter(k + 3)))
        .collect();
    let springs = model
        .springs
        .iter()
        .enumerate()
        .filter(|(k, _)| k % 7 != 3)
        .map(|(_, s)| *s)
        .collect();
    Model::from_parts(
        x,
        model.mass.clone(),
        model.pinned.clone(),
        springs,
        model.triangles.clone(),
    )
    .unwrap_or_else(|e| panic!("parts: {e}"))
}

#[test]
fn explicit_steps_equal_the_multi_dispatch_path_and_the_cpu_mirror() {
    // 12 × 11: three reduction blocks, the last partial; 5 × 4: fewer
    // particles than the workgroup has invocations.
    let (large, small) = (
        grid(12, 11, corners(), &busy(10)),
        grid(5, 4, corners(), &busy(10)),
    );
    let none = |_: &mut GpuSolver, _: &mut CpuSolver<f32>| {};
    assert_paths_agree("10 fix-up passes", &large, &busy(10), none);
    assert_paths_agree("no fix-up", &large, &busy(0), none);
    assert_paths_agree("smaller than the workgroup", &small, &busy(10), none);
    assert_paths_agree("irregular parts", &irregular(&large), &busy(10), none);
    let mut still = busy(4);
    still.wind = None;
    still.ground = None;
    still.spheres.clear();
    assert_paths_agree("no wind, ground or sphere", &large, &still, none);
    let mut capsule = busy(4);
    capsule.capsules = vec![Capsule {
        a: DVec3::new(-0.6, 0.85, 0.2),
        b: DVec3::new(0.6, 0.85, 0.2),
        radius: 0.08,
        friction: 0.4,
        velocity: DVec3::new(0.0, 0.5, 0.0),
    }];
    assert_paths_agree("sphere and moving capsule", &large, &capsule, none);
}

#[test]
fn semi_implicit_steps_equal_the_multi_dispatch_path_and_the_cpu_mirror() {
    let mut p = busy_params(Integrator::SemiImplicit);
    p.springs[0].max_stretch = Some(1.0);
    assert!(p.semi_implicit.torque_compensation);
    let none = |_: &mut GpuSolver, _: &mut CpuSolver<f32>| {};
    // Pinned: the per-spring torque compensation; free: the global
    // passes, whose sums the workgroup reduces itself. Both reach the
    // ground and the sphere.
    let pinned = grid(12, 11, corners(), &p);
    assert_paths_agree("semi-implicit, pinned", &pinned, &p, none);
    let free = grid(12, 11, Vec::new(), &p);
    assert_paths_agree("semi-implicit, free", &free, &p, none);
    assert_paths_agree("semi-implicit, irregular", &irregular(&pinned), &p, none);
}

#[test]
fn a_moving_pin_goal_is_followed_on_the_workgroup_path() {
    let p = busy(4);
    let model = grid(12, 11, corners(), &p);
    let pinned: Vec<usize> = (0..model.particle_count())
        .filter(|&k| model.pinned[k])
        .collect();
    let targets: Vec<PinTarget> = pinned
        .iter()
        .map(|&k| PinTarget {
            particle: k,
            position: model.rest_positions[k].as_vec3() + Vec3::new(0.05, 0.1, -0.02),
        })
        .collect();
    assert_paths_agree("moving pins", &model, &p, |g, c| {
        g.set_pin_targets(&targets, 0.03)
            .unwrap_or_else(|e| panic!("GPU pin targets: {e}"));
        c.set_pin_targets(&targets, 0.03)
            .unwrap_or_else(|e| panic!("CPU pin targets: {e}"));
    });
}

#[test]
fn a_mesh_cloth_steps_the_same_on_both_paths() {
    let mut scene = Scene::builtin("banner").expect("built in");
    scene.params.integrator = Integrator::Explicit;
    scene.params.fixup.method = wgcloth::params::FixupMethod::Jacobi;
    // The explicit scheme's stability bound on the mesh's smallest cells.
    scene.params.dt = 2e-4;
    let model = scene.model().expect("valid");
    assert!(model.grid.is_none(), "banner is a mesh");
    assert_paths_agree("banner mesh", &model, &scene.params, |_, _| {});
}

/// A grid cloth on the workgroup path is uploaded in general layout (the
/// workgroup kernels read the adjacency lists) and steps as the grid
/// kernels do.
#[test]
fn a_grid_cloth_takes_the_general_layout_on_the_workgroup_path() {
    let p = busy(10);
    let model = grid(12, 11, corners(), &p);
    assert!(model.grid.is_some());
    let g = solver_on(&model, &p, StepPath::Workgroup);
    assert_eq!(g.tuning().step_path(), StepPath::Workgroup);
    let kernels: Vec<Kernel> = g.tuning().step_plan().iter().map(|d| d.kernel).collect();
    assert_eq!(kernels, [Kernel::ClothExplicit]);
}

/// The workgroup path steps a cloth up to its limit (forced there: the
/// automatic choice between the two paths is the cost model's, see
/// `src/gpu/path.rs`'s tests); beyond it the automatic choice is the
/// multi-dispatch path and forcing the workgroup path is refused.
#[test]
fn the_workgroup_path_is_chosen_up_to_its_limit() {
    let p = busy(2);
    let ctx = gpu();
    let auto = |model: &Model, params: &Params| {
        GpuSolver::new(&ctx.device, &ctx.queue, model, params)
            .unwrap_or_else(|e| panic!("GPU solver: {e}"))
            .tuning()
            .step_path()
    };
    let side = (WORKGROUP_STEP_MAX_PARTICLES as f64).sqrt() as usize;
    assert_eq!(side * side, WORKGROUP_STEP_MAX_PARTICLES as usize);
    let at = grid(side, side, corners(), &p);
    assert_eq!(
        solver_on(&at, &p, StepPath::Workgroup).tuning().step_path(),
        StepPath::Workgroup,
        "{} particles",
        side * side
    );
    // 4097 = 17 × 241 particles: one over.
    let over = grid(17, 241, corners(), &p);
    assert_eq!(
        over.particle_count(),
        WORKGROUP_STEP_MAX_PARTICLES as usize + 1
    );
    assert_eq!(auto(&over, &p), StepPath::MultiDispatch);
    let forced =
        GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &over, &p, StepPath::Workgroup);
    match forced {
        Err(e @ Error::InvalidParameter { .. }) => {
            let message = e.to_string();
            assert!(
                message.contains("WORKGROUP_STEP_MAX_PARTICLES") && message.contains("4096"),
                "{message}"
            );
        }
        other => panic!("the workgroup path beyond its limit must be refused: {other:?}"),
    }
    // Semi-implicit with the dense filter takes the workgroup path; the
    // scalable filter (CG) has no workgroup kernel.
    let dense = busy_params(Integrator::SemiImplicit);
    let small = grid(6, 5, corners(), &dense);
    assert_eq!(auto(&small, &dense), StepPath::Workgroup);
    let mut banded = dense.clone();
    banded.semi_implicit.filter = FilterMethod::Banded;
    assert_eq!(auto(&small, &banded), StepPath::MultiDispatch);
}

#[test]
fn a_blow_up_is_reported_at_its_step_on_the_workgroup_path() {
    let mut p = busy_params(Integrator::Explicit);
    p.dt = 0.02;
    p.springs[0].stiffness = 1e5;
    p.fixup.iterations = 0;
    let m = grid(
        13,
        11,
        vec![Pin::Corner(wgcloth::model::Corner::TopLeft)],
        &p,
    );
    let mut cpu = CpuSolver::<f32>::new(&m, &p).expect("valid");
    let cpu_step = match cpu.step_n(1000) {
        Err(Error::NonFinite { step, .. }) => step,
        other => panic!("the CPU mirror should blow up: {other:?}"),
    };
    let reports = [StepPath::Workgroup, StepPath::MultiDispatch].map(|path| {
        match solver_on(&m, &p, path).step(1000) {
            Err(Error::NonFinite { step, particle, .. }) => (step, particle),
            other => panic!("{path}: the GPU should report the blow-up: {other:?}"),
        }
    });
    for ((step, _), path) in reports.iter().zip(["workgroup", "multi-dispatch"]) {
        agreement::assert_blow_up_step(path, *step, cpu_step);
    }
    if agreement::policy() == Policy::Bits {
        assert_eq!(reports[0], reports[1], "step and particle on both paths");
    }
}
