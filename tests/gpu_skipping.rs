//! The GPU solver skips what a scene does not use: specialised kernels give
//! the general kernels' results, switched-off features record fewer
//! dispatches, and the fix-up stops on the device. The step plan it records
//! is typed, and the debug API runs it dispatch by dispatch. On lavapipe in
//! CI. Every solver here takes the multi-dispatch path, whose plan these
//! tests read (tests/workgroup.rs tests the workgroup path).

mod gpu_common;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::gpu::{
    DebugBuffer, FixupPhase, GpuSolver, GpuState, Kernel, Launch, StepPath, Variant,
};
use wgcloth::model::{Corner, Pin};
use wgcloth::params::{Integrator, Wind};
use wgcloth::{Model, Params};

/// A solver on the multi-dispatch path with its kernels `specialised` or
/// not, recording the full CG budget.
fn variant(model: &Model, params: &Params, specialised: bool) -> GpuSolver {
    let mut g = solver_on(model, params, StepPath::MultiDispatch);
    g.tuning_mut().set_adaptive_cg_budget(false);
    g.tuning_mut()
        .set_specialised(specialised)
        .expect("variants");
    g
}

fn run(model: &Model, params: &Params, specialised: bool) -> (GpuState, f64) {
    let mut g = variant(model, params, specialised);
    g.step(40).expect("GPU steps");
    (
        g.read_state().expect("read-back"),
        g.tuning().dispatches_per_step(),
    )
}

/// Plain parameters: no wind, no colliders.
fn base(integrator: Integrator) -> Params {
    let mut p = busy_params(integrator);
    p.wind = None;
    p.ground = None;
    p.spheres.clear();
    p
}

fn model(p: &Params, pins: Vec<Pin>) -> Model {
    grid(11, 9, pins, p)
}

/// Specialised kernels drop code, never change arithmetic: results must be
/// bit-identical to the general kernels' (zero-valued signs aside, which
/// compare equal) where the adapter rounds as the mirror does; elsewhere
/// each is held to the mirror step by step.
#[test]
fn specialised_kernels_equal_the_general_ones_for_every_feature() {
    let corners = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    for integrator in Integrator::ALL {
        let mut scenes: Vec<(&str, Params, Vec<Pin>)> = Vec::new();
        let plain = base(integrator);
        scenes.push(("nothing: no pins, wind, colliders", plain.clone(), vec![]));
        scenes.push(("pins only", plain.clone(), corners.clone()));
        let mut undamped = plain.clone();
        for s in &mut undamped.springs {
            s.damping = 0.0;
        }
        scenes.push(("no damping", undamped, corners.clone()));
        let mut no_fixup = plain.clone();
        no_fixup.fixup.iterations = 0;
        scenes.push(("no fix-up", no_fixup, corners.clone()));
        // Wind, ground and a sphere the cloth reaches.
        scenes.push(("everything", busy_params(integrator), corners.clone()));
        for (what, params, pins) in scenes {
            let m = model(&params, pins);
            let (fewer, more) = if agreement::policy() == agreement::Policy::Bounded {
                // Each variant's own rounding (an adapter fuses what each
                // compiles to as it likes): each against the mirror.
                let dispatches = [true, false].map(|specialised| {
                    let mut g = variant(&m, &params, specialised);
                    let at = format!("{integrator}, {what}, specialised {specialised}");
                    if let Some(verdict) = bounded_steps(&at, || &mut g, &m, &params, 40) {
                        verdict.unwrap_or_else(|e| panic!("{e}"));
                    }
                    g.tuning().dispatches_per_step()
                });
                (dispatches[0], dispatches[1])
            } else {
                let (special, fewer) = run(&m, &params, true);
                let (general, more) = run(&m, &params, false);
                let (d, p) = worst(&special.x, &general.x);
                assert!(
                    d == 0.0,
                    "{integrator}, {what}: particle {p} differs by {d:e} m"
                );
                (fewer, more)
            };
            assert!(
                fewer <= more,
                "{integrator}, {what}: {fewer} vs {more} dispatches"
            );
        }
    }
}

#[test]
fn switching_a_feature_off_records_fewer_dispatches() {
    let corners = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    let dispatches = |p: &Params, pins: Vec<Pin>| run(&model(p, pins), p, true).1;
    // Explicit: without fix-up a step on a grid is one pass, wind or not
    // (the state comes from a snapshot); fix-up adds passes.
    let mut minimal = base(Integrator::Explicit);
    minimal.fixup.iterations = 0;
    let mut windy = minimal.clone();
    windy.wind = Some(Wind {
        velocity: DVec3::new(3.0, 0.0, 0.0),
        drag: 0.6,
        lift: 0.0,
    });
    let mut fixed_up = minimal.clone();
    fixed_up.fixup.iterations = 5;
    let (a, b, c) = (
        dispatches(&minimal, vec![]),
        dispatches(&windy, vec![]),
        dispatches(&fixed_up, vec![]),
    );
    assert!(
        a == b && b < c,
        "explicit: minimal {a}, wind {b}, fix-up {c}"
    );
    // Semi-implicit: a pinned cloth needs no global torque passes.
    let semi = base(Integrator::SemiImplicit);
    let (free, pinned) = (dispatches(&semi, vec![]), dispatches(&semi, corners));
    assert!(pinned < free, "semi-implicit: pinned {pinned}, free {free}");
}

#[test]
fn the_fixup_stops_on_the_device_when_nothing_is_over_stretched() {
    // A hanging cloth: some steps need every pass, calm ones fewer. The GPU
    // runs the passes that moved something plus the one that found nothing
    // (the CPU's check before its `break`), never more.
    let mut p = base(Integrator::Explicit);
    p.fixup.iterations = 12;
    let m = model(
        &p,
        vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)],
    );
    let mut g = solver_on(&m, &p, StepPath::MultiDispatch);
    let mut c = CpuSolver::<f32>::new(&m, &p).expect("CPU solver");
    let mut early = 0;
    for step in 1..=60 {
        let gpu_passes = g.step(1).expect("GPU step").fixup_passes;
        let cpu_moved = c.step().expect("CPU step").fixup_passes;
        assert_eq!(gpu_passes, (cpu_moved + 1).min(12), "step {step}");
        early += usize::from(gpu_passes < 12);
    }
    assert!(
        early > 0,
        "the fix-up never stopped early: the test proves nothing"
    );
}

/// The plan is typed: a single-pass explicit step (a grid, no fix-up) is
/// the seed copy into the snapshot and the pass back from it; with fix-up
/// it is integration, the fix-up passes (the first its own variant) and
/// the step end.
#[test]
fn the_plan_names_kernels_and_variants() {
    let mut p = base(Integrator::Explicit);
    p.fixup.iterations = 0;
    let m = model(&p, vec![]);
    let g = solver_on(&m, &p, StepPath::MultiDispatch);
    let plan: Vec<(Kernel, Variant)> = g.debug_plan().iter().map(|d| d.pipeline()).collect();
    assert_eq!(
        plan,
        [
            (Kernel::ExplicitSeed, Variant::Plain),
            (Kernel::ExplicitIntegrate, Variant::FromSnapshot),
        ]
    );
    p.fixup.iterations = 3;
    let g = solver_on(&m, &p, StepPath::MultiDispatch);
    let plan: Vec<(Kernel, Variant)> = g.debug_plan().iter().map(|d| d.pipeline()).collect();
    let fixup = |k| (Kernel::FixupJacobi, Variant::Fixup(FixupPhase::of_pass(k)));
    assert_eq!(
        plan,
        [
            (Kernel::ExplicitIntegrate, Variant::Plain),
            (Kernel::FixupJacobi, Variant::FixupFirst),
            fixup(1),
            fixup(2),
            (Kernel::FinishStep, Variant::Plain),
        ]
    );
}

/// The CG iterations launch their two kernels from the iteration's slots;
/// CG's start is launched directly.
#[test]
fn cg_iterations_launch_from_their_slots() {
    let p = base(Integrator::Implicit);
    let m = model(&p, vec![]);
    let mut g = solver_on(&m, &p, StepPath::MultiDispatch);
    g.tuning_mut().set_adaptive_cg_budget(false);
    let plan = g.debug_plan();
    let launches = |k: Kernel| -> Vec<Launch> {
        plan.iter()
            .filter(|d| d.kernel == k)
            .map(|d| d.launch)
            .collect()
    };
    let budget = g.tuning().cg_budget();
    let apply: Vec<Launch> = (0..budget).map(Launch::ApplySlot).collect();
    let update: Vec<Launch> = (0..budget).map(Launch::UpdateSlot).collect();
    assert_eq!(launches(Kernel::CgApply), apply);
    // The iterations' cg_update (with coarse levels a first one before
    // them preconditions the initial residual, launched directly).
    let iterations: Vec<Launch> = plan
        .iter()
        .filter(|d| d.kernel == Kernel::CgUpdate && d.variant == Variant::Plain)
        .map(|d| d.launch)
        .collect();
    assert_eq!(iterations, update);
    assert_eq!(launches(Kernel::CgInit), [Launch::Direct]);
    assert_eq!(g.tuning().dispatches_per_cg_iteration(), 2);
}

/// A step run through the debug API in pieces — one dispatch at a time
/// for the first ten, then the rest at once — leaves every buffer as
/// `step(1)` does, bit for bit, for every integrator and the single-pass
/// explicit step; and the step count advances once.
#[test]
fn a_step_run_dispatch_by_dispatch_equals_one_step() {
    let mut cases: Vec<(String, Params)> = Integrator::ALL
        .iter()
        .map(|&i| (i.to_string(), busy_params(i)))
        .collect();
    let mut single = busy_params(Integrator::Explicit);
    single.fixup.iterations = 0;
    cases.push(("explicit single pass".into(), single));
    let corners = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    for (what, p) in cases {
        let m = model(&p, corners.clone());
        let solver = || {
            let mut g = solver_on(&m, &p, StepPath::MultiDispatch);
            g.tuning_mut().set_adaptive_cg_budget(false);
            // Some steps first, so the pieces start from a moving cloth.
            g.step(3).expect("steps");
            g
        };
        let mut whole = solver();
        whole.step(1).expect("step");
        let mut pieces = solver();
        let len = pieces.debug_plan().len();
        let cut = len.min(10);
        for k in 0..cut {
            pieces.debug_run(k..k + 1).expect("one dispatch");
        }
        pieces.debug_run(cut..len).expect("the rest");
        let status = pieces.check().expect("status");
        assert_eq!(status.steps, 4, "{what}");
        assert_eq!(pieces.steps_recorded(), 4, "{what}");
        for buffer in DebugBuffer::ALL {
            let (a, b) = (
                whole.debug_read(buffer).expect("read"),
                pieces.debug_read(buffer).expect("read"),
            );
            let first = a.iter().zip(&b).position(|(x, y)| x != y);
            assert!(
                first.is_none(),
                "{what}: {buffer:?} differs at word {first:?}"
            );
        }
    }
}

/// A range past the plan or a write larger than its buffer is refused,
/// naming what is allowed; a write lands at the buffer's start.
#[test]
fn the_debug_api_refuses_what_does_not_fit() {
    let p = base(Integrator::Explicit);
    let m = model(&p, vec![]);
    let mut g = solver_on(&m, &p, StepPath::MultiDispatch);
    let len = g.debug_plan().len();
    let e = g.debug_run(0..len + 1).expect_err("past the plan");
    assert!(e.to_string().contains(&format!("0..{len}")), "{e}");
    let x = g.debug_read(DebugBuffer::X).expect("read");
    let too_many = vec![0u32; x.len() + 1];
    assert!(g.debug_write(DebugBuffer::X, &too_many).is_err());
    let words: Vec<u32> = (0..8).map(|k| 1.5f32.to_bits() + k).collect();
    g.debug_write(DebugBuffer::X, &words).expect("write");
    let back = g.debug_read(DebugBuffer::X).expect("read");
    assert_eq!(&back[..8], &words[..]);
    assert_eq!(&back[8..], &x[8..]);
    // The work buffer holds its 17 sections of four words per particle.
    let layout = g.debug_layout();
    let work = g.debug_read(DebugBuffer::Work).expect("read");
    assert_eq!(
        work.len(),
        layout.work_section_words * wgcloth::kernel_config::work::COUNT as usize
    );
}
