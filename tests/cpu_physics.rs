//! Physics of the CPU reference: every integrator against exact discrete
//! solutions and conservation laws.

mod common;

use common::*;
use wgcloth::cpu::{CpuSolver, State};
use wgcloth::glam::DVec3;
use wgcloth::model::{Model, Pin};
use wgcloth::params::{Integrator, Params};
use wgcloth::real::Vec3;
use wgcloth::Error;

/// Free fall in `f64`: the only error is rounding in `x += dt v` over a few
/// hundred steps (about 1e-16 relative each) plus, for the implicit
/// integrator, a CG solved to 1e-12. 1e-10 m on metre-scale positions leaves
/// two orders of margin over both and fails on any real modelling error.
const FREE_FALL_TOL: f64 = 1e-10;

#[test]
fn free_fall_matches_the_exact_discrete_solution() {
    let spec = cloth(5, 4, vec![]);
    let steps = 200u64;
    let dt = 1e-3;
    for integrator in Integrator::ALL {
        let params = exact_params(integrator, dt);
        let model = Model::new(&spec, &params.springs).expect("valid");
        let s = run::<f64>(&model, &params, steps);
        // Symplectic Euler, and backward Euler with springs at rest:
        // v_n = n dt g, x_n = x_0 + dt² g n(n+1)/2.
        let n = steps as f64;
        let drop = params.gravity[1] * dt * dt * n * (n + 1.0) / 2.0;
        for (p, x) in s.positions().iter().enumerate() {
            let x0 = model.rest_positions[p];
            let expected = DVec3::new(x0.x, x0.y + drop, x0.z);
            let err = (*x - expected).length();
            assert!(
                err < FREE_FALL_TOL,
                "{integrator}: particle {p} at {x:?}, expected {expected:?} (error {err:e} m)"
            );
        }
    }
}

/// One free-fall step's velocity, g·dt ≈ 0.02 m/s: rounding is ~1e-18 m/s
/// and the implicit CG (to 1e-12 relative) ~1e-14 m/s, while a step that
/// kept the old dt would be 1e-2 m/s off.
const ONE_STEP_VELOCITY_TOL: f64 = 1e-12;

#[test]
fn a_changed_step_is_validated_and_then_used() {
    let spec = cloth(4, 4, vec![]);
    for integrator in Integrator::ALL {
        let params = exact_params(integrator, 1e-3);
        let model = Model::new(&spec, &params.springs).expect("valid");
        let mut solver = CpuSolver::<f64>::new(&model, &params).expect("valid");
        for bad in [0.0, -1e-3, 2.0, f64::NAN, f64::INFINITY] {
            match solver.set_dt(bad) {
                Err(Error::InvalidParameter { key, .. }) => assert_eq!(key, "simulation.dt"),
                other => panic!("{integrator}: set_dt({bad}) gave {other:?}"),
            }
        }
        // A refused step leaves the old one; an accepted one is the next
        // step's: free fall from rest gains exactly g·dt (springs at rest).
        let dt = 2e-3;
        solver.set_dt(dt).expect("a valid step");
        solver.step().expect("a finite step");
        let expected = params.gravity[1] * dt;
        for (p, v) in solver.velocities().iter().enumerate() {
            let err = (v.y - expected).abs();
            assert!(
                err < ONE_STEP_VELOCITY_TOL,
                "{integrator}: particle {p} falls at {v:?} m/s, expected {expected} m/s"
            );
        }
    }
}

/// The single-spring oscillator in `f64` against its closed form: rounding
/// accumulates over 2000 steps to about 1e-13 of the amplitude; 1e-9
/// relative is far above that and far below any wrong factor in the scheme.
const OSCILLATOR_TOL: f64 = 1e-9;

#[test]
fn single_spring_follows_the_closed_form_discrete_oscillation() {
    let (k, m, rest, amp, dt): (f64, f64, f64, f64, f64) = (40.0, 0.05, 0.3, 0.02, 2e-3);
    let h = dt * (k / m).sqrt(); // ω dt
    let steps = 2000;
    for integrator in Integrator::ALL {
        let (model, params) = single_spring(integrator, k, m, rest, amp, dt);
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        // u_n: displacement of the free particle below its rest position.
        let exact = |n: f64| -> f64 {
            match integrator {
                Integrator::Explicit => {
                    // Symplectic Euler: cos θ = 1 − h²/2, period 2π/θ steps,
                    // amplitude exactly conserved.
                    let theta = (1.0 - h * h / 2.0).acos();
                    let v = -amp * h * h / (2.0 * theta.sin());
                    amp * (n * theta).cos() + v * (n * theta).sin()
                }
                // Backward Euler: per step the amplitude shrinks by
                // 1/sqrt(1 + h²) and the phase advances by atan(h).
                _ => amp * (1.0 + h * h).powf(-n / 2.0) * (n * h.atan()).cos(),
            }
        };
        let mut worst = (0.0f64, 0usize);
        for n in 1..=steps {
            s.step().expect("stable");
            let u = -s.positions()[1].y - rest;
            let err = (u - exact(n as f64)).abs() / amp;
            if err > worst.0 {
                worst = (err, n);
            }
            assert!(s.positions()[1].x == 0.0 && s.positions()[1].z == 0.0);
        }
        assert!(
            worst.0 < OSCILLATOR_TOL,
            "{integrator}: worst relative error {:e} at step {}",
            worst.0,
            worst.1
        );
    }
}

#[test]
fn implicit_schemes_damp_the_oscillator_and_explicit_does_not() {
    // The same oscillator after many periods: backward Euler has lost most
    // of its amplitude, symplectic Euler none. A guard against a scheme that
    // is accidentally the other one.
    let (k, m, rest, amp, dt) = (40.0, 0.05, 0.3, 0.02, 2e-3);
    for integrator in Integrator::ALL {
        let (model, params) = single_spring(integrator, k, m, rest, amp, dt);
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let mut peak: f64 = 0.0;
        for n in 0..20_000 {
            s.step().expect("stable");
            if n >= 19_000 {
                peak = peak.max((-s.positions()[1].y - rest).abs());
            }
        }
        match integrator {
            Integrator::Explicit => assert!(peak > 0.99 * amp, "explicit lost amplitude: {peak}"),
            _ => assert!(peak < 0.01 * amp, "{integrator} kept amplitude {peak}"),
        }
    }
}

#[test]
fn pinned_particles_never_move() {
    let spec = cloth(
        9,
        7,
        vec![Pin::Edge(wgcloth::model::Edge::Left), Pin::Index(30)],
    );
    for integrator in Integrator::ALL {
        let mut params = Params {
            integrator,
            dt: 2e-3,
            ..Params::default()
        };
        params.ground = Some(wgcloth::params::Ground {
            height: 0.9,
            friction: 0.3,
        });
        params.wind = Some(wgcloth::params::Wind {
            velocity: DVec3::new(3.0, 0.0, 1.0),
            drag: 0.6,
            lift: 0.3,
        });
        let model = Model::new(&spec, &params.springs).expect("valid");
        let s = run::<f64>(&model, &params, 300);
        for (p, x) in s.positions().iter().enumerate() {
            if model.pinned[p] {
                assert_eq!(*x, model.rest_positions[p], "{integrator}: pin {p} moved");
                assert_eq!(s.velocities()[p], DVec3::ZERO);
            }
        }
        // The free particles did move (the test is not vacuous).
        let (moved, _) = max_distance(&s.positions(), &rest_state(&model).x);
        assert!(moved > 0.01, "{integrator}: nothing moved");
    }
}

/// A state with pseudo-random velocities and a stretched, perturbed shape.
fn agitated(model: &Model) -> State<f64> {
    let mut st = rest_state(model);
    for p in 0..model.particle_count() {
        let s = p as u64 * 6;
        st.x[p] += Vec3::new(noise(s), noise(s + 1), noise(s + 2)) * 0.01;
        st.v[p] = Vec3::new(noise(s + 3), noise(s + 4), noise(s + 5)) * 0.5;
    }
    st
}

fn momentum(model: &Model, v: &[DVec3]) -> DVec3 {
    v.iter()
        .zip(&model.mass)
        .fold(DVec3::ZERO, |acc, (v, &m)| acc + *v * m)
}

fn angular_momentum(model: &Model, x: &[DVec3], v: &[DVec3]) -> DVec3 {
    (0..x.len()).fold(DVec3::ZERO, |acc, p| acc + x[p].cross(v[p] * model.mass[p]))
}

/// Momentum is about 0.1 kg × 0.5 m/s; rounding over 200 steps of sums of
/// ~300 spring forces moves it by ~1e-15 kg·m/s, the CG (tolerance 1e-12)
/// by less than 1e-12. 1e-10 kg·m/s catches any force that is not equal and
/// opposite.
const MOMENTUM_TOL: f64 = 1e-10;

#[test]
fn without_gravity_or_pins_momentum_is_conserved() {
    let spec = cloth(8, 6, vec![]);
    for integrator in Integrator::ALL {
        let mut params = exact_params(integrator, 1e-3);
        params.gravity = DVec3::ZERO;
        params.fixup.iterations = 10; // Provot corrections conserve it too.
        let model = Model::new(&spec, &params.springs).expect("valid");
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        s.set_state(agitated(&model)).expect("sizes match");
        let before = momentum(&model, &s.velocities());
        s.step_n(200).expect("stable");
        let after = momentum(&model, &s.velocities());
        let drift = (after - before).length();
        assert!(
            drift < MOMENTUM_TOL,
            "{integrator}: momentum {before:?} → {after:?}"
        );
    }
}

/// Angular momentum of the agitated cloth is ~1e-2 kg·m²/s; the same
/// rounding argument as for momentum.
const ANGULAR_TOL: f64 = 1e-10;

#[test]
fn torque_compensation_keeps_angular_momentum_of_a_free_cloth() {
    let spec = cloth(8, 6, vec![]);
    let drift = |integrator: Integrator, compensation: bool| {
        let mut params = exact_params(integrator, 1e-3);
        params.gravity = DVec3::ZERO;
        params.semi_implicit.torque_compensation = compensation;
        let model = Model::new(&spec, &params.springs).expect("valid");
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        s.set_state(agitated(&model)).expect("sizes match");
        let before = angular_momentum(&model, &s.positions(), &s.velocities());
        s.step_n(200).expect("stable");
        (angular_momentum(&model, &s.positions(), &s.velocities()) - before).length()
    };
    // Symplectic Euler with central forces conserves it exactly.
    assert!(drift(Integrator::Explicit, true) < ANGULAR_TOL);
    let with = drift(Integrator::SemiImplicit, true);
    let without = drift(Integrator::SemiImplicit, false);
    assert!(with < ANGULAR_TOL, "compensated drift {with:e}");
    // Without compensation the linear split visibly spins the cloth: the
    // check above is not vacuous.
    assert!(
        without > 1e3 * ANGULAR_TOL,
        "uncompensated drift only {without:e}"
    );
}

#[test]
fn a_blow_up_is_reported_at_the_step_it_happens() {
    let mut params = Params {
        dt: 0.05,
        ..Params::default()
    };
    params.springs[0].stiffness = 1e6;
    params.fixup.iterations = 0;
    let model = Model::new(&cloth(6, 6, four_corners()), &params.springs).expect("valid");
    let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
    match s.step_n(10_000) {
        Err(Error::NonFinite { step, .. }) => {
            assert_eq!(step, s.steps(), "reported step is the step that failed");
            assert!(step > 1 && step < 10_000);
            assert!(s.positions().iter().any(|x| !x.is_finite()));
        }
        other => panic!("expected a blow-up, got {other:?}"),
    }
}

#[test]
fn impossible_parameters_are_refused_before_running() {
    let model = Model::new(&cloth(4, 4, vec![]), &Params::default().springs).expect("valid");
    for (edit, key) in [
        (
            Box::new(|p: &mut Params| p.dt = 0.0) as Box<dyn Fn(&mut Params)>,
            "simulation.dt",
        ),
        (Box::new(|p: &mut Params| p.dt = f64::NAN), "simulation.dt"),
        (
            Box::new(|p: &mut Params| p.springs[1].stiffness = -1.0),
            "springs.shear.stiffness",
        ),
        (
            Box::new(|p: &mut Params| p.gravity[2] = f64::INFINITY),
            "simulation.gravity",
        ),
        (
            Box::new(|p: &mut Params| p.implicit.tolerance = 0.0),
            "implicit.tolerance",
        ),
    ] {
        let mut params = Params::default();
        edit(&mut params);
        let err = CpuSolver::<f64>::new(&model, &params).expect_err("must refuse");
        assert!(err.to_string().contains(key), "{err} should name {key}");
    }
}

/// `step_n` reports what `step` reports for its last step, with the most
/// CG iterations of all the steps it ran and the solver's step count; the
/// residual only where a CG ran.
#[test]
fn step_n_reports_the_batch_as_the_steps_would() {
    let spec = cloth(6, 5, vec![Pin::Index(0)]);
    for integrator in Integrator::ALL {
        let params = exact_params(integrator, 1e-2);
        let model = Model::new(&spec, &params.springs).expect("valid");
        let mut single = CpuSolver::<f64>::new(&model, &params).expect("valid");
        // Agitated, the cloth calms down: CG needs fewer iterations at the
        // end of the batch than at its start.
        single.set_state(agitated(&model)).expect("sizes match");
        let mut batched = single.clone();
        let mut most = 0;
        let mut last = single.step().expect("stable");
        for _ in 1..15 {
            most = most.max(last.cg_iterations);
            last = single.step().expect("stable");
        }
        most = most.max(last.cg_iterations);
        let batch = batched.step_n(15).expect("stable");
        assert_eq!(batch.steps, 15, "{integrator}");
        assert_eq!(batch.cg_iterations, last.cg_iterations, "{integrator}");
        assert_eq!(batch.cg_max_iterations, most, "{integrator}");
        assert_eq!(batch.fixup_passes, last.fixup_passes, "{integrator}");
        assert_eq!(
            batch.cg_budget_hits, None,
            "{integrator}: no budget on the CPU"
        );
        match integrator {
            Integrator::Implicit => {
                assert!(
                    most > last.cg_iterations,
                    "the batch's most ({most}) should exceed its last step's ({})",
                    last.cg_iterations
                );
                let r = batch
                    .cg_residual
                    .expect("an implicit step reports its residual");
                assert!(r <= params.implicit.tolerance, "residual {r:e}");
            }
            _ => assert_eq!(batch.cg_residual, None, "{integrator}: no CG"),
        }
    }
}
