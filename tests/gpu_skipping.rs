//! The GPU solver skips what a scene does not use: specialised kernels give
//! the general kernels' results, switched-off features record fewer
//! dispatches, and the fix-up stops on the device. On lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuSolver, GpuState};
use wgcloth::model::{Corner, Pin};
use wgcloth::params::{Integrator, Wind};
use wgcloth::{Model, Params};

fn run(model: &Model, params: &Params, specialised: bool) -> (GpuState, f64) {
    let ctx = gpu();
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, model, params).expect("GPU solver");
    g.tuning_mut().set_adaptive_cg_budget(false);
    g.tuning_mut()
        .set_specialised(specialised)
        .expect("variants");
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
/// compare equal).
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
            let (special, fewer) = run(&m, &params, true);
            let (general, more) = run(&m, &params, false);
            let (d, p) = worst(&special.x, &general.x);
            assert!(
                d == 0.0,
                "{integrator}, {what}: particle {p} differs by {d:e} m"
            );
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
        velocity: [3.0, 0.0, 0.0],
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
    // Semi-implicit: a pinned cloth needs no torque compensation.
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
    let ctx = gpu();
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &m, &p).expect("GPU solver");
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
