//! The semi-implicit integrator moves like cloth (issue #20): its torque
//! compensation is per spring, so a pinned cloth keeps it; its error on
//! `hanging` stays near the implicit integrator's; a small flag in the wind
//! moves about as much as the implicit one's. CPU only.

mod common;

use common::*;
use wgcloth::evidence::{self, AccuracyOptions, Backend};
use wgcloth::glam::DVec3;
use wgcloth::model::{Edge, Model, Pin};
use wgcloth::params::Integrator;
use wgcloth::real::Vec3;
use wgcloth::{CpuSolver, Scene};

/// The pendulum: a particle of 10 g on a 0.1 m spring of 10⁴ N/m from a
/// pin, swinging at 0.5 m/s, no gravity, no damping. At dt = 10 ms,
/// `dt² k / m = 100`: a filter that resists the spring's rotation with its
/// full stiffness keeps `m / (m + dt² k)`, 1 %, of the speed per step.
const PENDULUM: (f64, f64, f64, f64) = (1e4, 0.01, 0.1, 0.01);
/// Steps swung: one second, most of a turn.
const PENDULUM_STEPS: u64 = 100;
/// The share of its speed the compensated pendulum keeps after a second.
/// Its spring's tension gives it a transverse stiffness `m ω²`
/// (`ω = v / r` = 5 rad/s), which backward Euler damps by about
/// `dt² ω² / 2` per step, 12 % over the second, as the implicit
/// integrator does. Measured: 0.894; 0.85 leaves room for that and fails
/// on a filter that resists the rotation itself (1 % kept per step).
const PENDULUM_KEEPS: f64 = 0.85;
/// The share the uncompensated pendulum may keep: 1 % per step leaves
/// nothing after a second; 1e-3 says "stopped" with room for rounding.
const UNCOMPENSATED_KEEPS: f64 = 1e-3;

/// The pendulum's speed after [`PENDULUM_STEPS`], over its initial speed.
fn pendulum_keeps(compensation: bool) -> f64 {
    let (k, mass, rest, dt) = PENDULUM;
    let (model, mut params) = single_spring(Integrator::SemiImplicit, k, mass, rest, 0.0, dt);
    params.semi_implicit.torque_compensation = compensation;
    let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
    let mut state = rest_state(&model);
    let speed = 0.5;
    state.v[1] = Vec3::new(speed, 0.0, 0.0);
    s.set_state(state).expect("sizes match");
    s.step_n(PENDULUM_STEPS).expect("stable");
    s.velocities()[1].length() / speed
}

#[test]
fn a_pinned_pendulum_keeps_its_swing() {
    let kept = pendulum_keeps(true);
    eprintln!("compensated pendulum keeps {kept} of its speed");
    assert!(
        kept > PENDULUM_KEEPS,
        "compensated: keeps {kept} of its speed, expected > {PENDULUM_KEEPS}"
    );
    // The pin used to switch the compensation off; without it the filter
    // stops the swing, so the check above is not vacuous.
    let stopped = pendulum_keeps(false);
    assert!(
        stopped < UNCOMPENSATED_KEEPS,
        "uncompensated: keeps {stopped} of its speed, expected < {UNCOMPENSATED_KEEPS}"
    );
}

/// Semi-implicit over implicit RMS error on the 9 × 9 `hanging` at
/// dt = 4 ms, no fix-up, against a dt / 16 reference (the options of
/// `tests/evidence.rs`). Measured: 1.12 (3.36 mm over 3.00 mm; 4.9 before
/// the per-spring compensation).
const ERROR_RATIO_MEASURED: f64 = 1.12;
/// Room for harmless changes; the bound, 1.34, stays inside issue #20's
/// target of 2.
const ERROR_RATIO_MARGIN: f64 = 1.2;

#[test]
fn semi_implicit_error_stays_near_the_implicit_one() {
    let scene = Scene::builtin("hanging").expect("built-in scene");
    let options = AccuracyOptions {
        resolution: Some(9),
        sample_every: 80,
        samples: 3,
        dt_multiples: vec![4],
        reference_divisor: 16,
        fixup_iterations: vec![0],
        cg_tolerances: vec![1e-4],
        integrators: vec![Integrator::Implicit, Integrator::SemiImplicit],
        backends: vec![Backend::CpuF64],
    };
    let report = evidence::accuracy(&scene, &options, None).expect("accuracy");
    let rms = |integrator: Integrator| {
        let row = report
            .rows
            .iter()
            .find(|r| r.integrator == integrator)
            .expect("one row per integrator");
        assert!(row.stable, "{integrator} blew up");
        row.rms_error
    };
    let (implicit, semi) = (rms(Integrator::Implicit), rms(Integrator::SemiImplicit));
    let ratio = semi / implicit;
    eprintln!("RMS error: implicit {implicit:e} m, semi-implicit {semi:e} m, ratio {ratio}");
    let bound = ERROR_RATIO_MEASURED * ERROR_RATIO_MARGIN;
    assert!(ratio <= bound, "error ratio {ratio} > {bound}");
}

/// The small flag: the built-in `flag` at 9 × 6 particles (cells of 0.2 m),
/// its own dt, wind and fix-up, for 2 s.
const FLAG_RESOLUTION: [usize; 2] = [9, 6];
const FLAG_SECONDS: f64 = 2.0;
/// The free edge's RMS speed is taken over the second half, after the
/// flag has blown out.
const FLAG_FROM: f64 = 1.0;
/// Semi-implicit over implicit free-edge RMS speed on the small flag.
/// Measured: 0.62.
const FLAG_MOTION_MEASURED: f64 = 0.62;
/// Room for harmless changes; the board-like flag is far below it.
const FLAG_MOTION_MARGIN: f64 = 0.8;
/// The same ratio without the compensation (the old rule for every pinned
/// cloth) stays under this. Measured: 0.026.
const BOARD_MOTION: f64 = 0.1;

/// RMS speed \[m/s\] of the flag's free (right) edge from [`FLAG_FROM`] to
/// [`FLAG_SECONDS`], sampled every step.
fn flag_edge_speed(integrator: Integrator, compensation: bool) -> f64 {
    let mut scene = Scene::builtin("flag").expect("built-in scene");
    scene.cloths[0].spec.nx = FLAG_RESOLUTION[0];
    scene.cloths[0].spec.ny = FLAG_RESOLUTION[1];
    scene.cloths[0].spec.pins = vec![Pin::Edge(Edge::Left)];
    scene.params.integrator = integrator;
    scene.params.semi_implicit.torque_compensation = compensation;
    let model: Model = scene.model().expect("valid");
    let mut s = CpuSolver::<f64>::new(&model, &scene.params).expect("valid");
    let dt = scene.params.dt;
    let nx = scene.cloths[0].spec.nx;
    let (mut sum, mut count) = (0.0, 0usize);
    while s.time() < FLAG_SECONDS - dt / 2.0 {
        s.step().expect("stable");
        if s.time() >= FLAG_FROM {
            for v in s.velocities().iter().skip(nx - 1).step_by(nx) {
                sum += DVec3::length_squared(*v);
                count += 1;
            }
        }
    }
    (sum / count as f64).sqrt()
}

#[test]
fn a_small_flag_moves_like_the_implicit_one() {
    let implicit = flag_edge_speed(Integrator::Implicit, true);
    let semi = flag_edge_speed(Integrator::SemiImplicit, true);
    let board = flag_edge_speed(Integrator::SemiImplicit, false) / implicit;
    let ratio = semi / implicit;
    eprintln!(
        "free edge RMS speed: implicit {implicit} m/s, semi-implicit {semi} m/s \
         (ratio {ratio}; uncompensated {board})"
    );
    let bound = FLAG_MOTION_MEASURED * FLAG_MOTION_MARGIN;
    assert!(
        ratio >= bound,
        "the semi-implicit flag moves at {ratio} of the implicit one's speed, expected ≥ {bound}"
    );
    // Without the compensation the flag is a board: the check above is
    // not vacuous.
    assert!(
        board < BOARD_MOTION,
        "uncompensated, the flag moves at {board} of the implicit one's speed"
    );
}

/// The drape's cloth at 17 × 17 particles, dropped on its sphere at the
/// scene's 1/120 s: contact starts after about 0.23 s.
const DRAPE_RESOLUTION: usize = 17;
/// Simulated time: contact and the first half second on the sphere.
const DRAPE_SECONDS: f64 = 0.75;
/// The divergence rule's check interval (as `wgcloth run`).
const CHECK_EVERY: u64 = 10;

#[test]
fn a_cloth_landing_on_a_sphere_stays_bounded() {
    let mut scene = Scene::builtin("drape").expect("built-in scene");
    scene.cloths[0].spec.nx = DRAPE_RESOLUTION;
    scene.cloths[0].spec.ny = DRAPE_RESOLUTION;
    scene.params.integrator = Integrator::SemiImplicit;
    let model: Model = scene.model().expect("valid");
    let mut s = CpuSolver::<f64>::new(&model, &scene.params).expect("valid");
    let rule = common::divergence_rule(&model, &scene.params, &s);
    while s.time() < DRAPE_SECONDS {
        s.step_n(CHECK_EVERY).expect("finite");
        if let Err(e) = rule.check(s.steps(), s.time(), &s.positions(), &s.velocities()) {
            panic!("the semi-implicit drape diverged: {e}");
        }
    }
}
