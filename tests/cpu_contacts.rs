//! Colliders on the CPU: contacts hold and friction stops sliding, for every
//! integrator.

mod common;

use common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::model::Model;
use wgcloth::params::{Ground, Integrator, Params, Sphere};

/// Collision projection is exact up to rounding of `x − n·d` (~1e-16 m in
/// f64 near 1 m); 1e-12 m separates "on the surface" from "inside".
const PENETRATION_TOL: f64 = 1e-12;

fn dropped_cloth(integrator: Integrator, friction: f64) -> (Model, Params) {
    let mut params = Params {
        integrator,
        dt: 1e-3,
        ..Params::default()
    };
    params.ground = Some(Ground {
        height: 0.0,
        friction,
    });
    params.spheres = vec![Sphere {
        center: DVec3::new(0.0, 0.6, 0.0),
        radius: 0.15,
        friction,
        velocity: DVec3::ZERO,
    }];
    let model = Model::new(&cloth(9, 9, vec![]), &params.springs).expect("valid");
    (model, params)
}

#[test]
fn no_particle_ends_a_step_inside_a_collider() {
    for integrator in Integrator::ALL {
        let (model, params) = dropped_cloth(integrator, 0.5);
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let mut touched = 0;
        for step in 0..800 {
            s.step().expect("stable");
            for (p, x) in s.positions().iter().enumerate() {
                let sphere = (*x - DVec3::new(0.0, 0.6, 0.0)).length() - 0.15;
                assert!(
                    x.y >= -PENETRATION_TOL && sphere >= -PENETRATION_TOL,
                    "{integrator}: step {step} particle {p} inside: y = {:e}, sphere distance {sphere:e}",
                    x.y
                );
                touched += usize::from(x.y < 1e-9 || sphere < 1e-9);
            }
        }
        assert!(
            touched > 0,
            "{integrator}: the cloth never reached a collider"
        );
    }
}

#[test]
fn friction_stops_a_sliding_cloth_and_its_absence_does_not() {
    for integrator in Integrator::ALL {
        let speed_after = |friction: f64| {
            let (model, mut params) = dropped_cloth(integrator, friction);
            params.spheres.clear();
            let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
            // Lay the cloth on the ground, sliding along +x at 1 m/s.
            let (mut x, mut v) = (s.positions(), s.velocities());
            for (x, v) in x.iter_mut().zip(v.iter_mut()) {
                x.y = 0.0;
                *v = DVec3::new(1.0, 0.0, 0.0);
            }
            s.set_positions_and_velocities(&x, &v).expect("sizes match");
            s.step_n(500).expect("stable");
            let v = s.velocities();
            v.iter().map(|v| v.x).sum::<f64>() / v.len() as f64
        };
        // μ g t = 0.5 · 9.81 · 0.5 s ≈ 2.5 m/s of braking: enough to stop.
        let with = speed_after(0.5);
        let without = speed_after(0.0);
        assert!(
            with.abs() < 1e-3,
            "{integrator}: still sliding at {with} m/s with friction"
        );
        assert!(
            without > 0.99,
            "{integrator}: slowed to {without} m/s without friction"
        );
    }
}

/// Coulomb's law on a sliding cloth: its speed falls by `μ g` per second
/// (the ground's normal force is the weight). The implicit integrator's
/// friction takes the last step's normal impulse, so its first step on the
/// ground slides free: it lags one step. CG's relative tolerance bounds the
/// normal impulses' relative error, hence the speed's error to that
/// tolerance times the speed lost.
#[test]
fn a_cloth_sliding_on_the_ground_slows_at_mu_g() {
    const MU: f64 = 0.5;
    for integrator in Integrator::ALL {
        let (model, mut params) = dropped_cloth(integrator, MU);
        params.spheres.clear();
        let (dt, g) = (params.dt, -params.gravity.y);
        let lag = if integrator == Integrator::Implicit {
            dt
        } else {
            0.0
        };
        let tolerance = params.implicit.tolerance;
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let (mut x, mut v) = (s.positions(), s.velocities());
        for (x, v) in x.iter_mut().zip(v.iter_mut()) {
            x.y = 0.0;
            *v = DVec3::new(1.0, 0.0, 0.0);
        }
        s.set_positions_and_velocities(&x, &v).expect("sizes match");
        for steps in [50u64, 100] {
            s.step_n(steps - s.steps()).expect("stable");
            let v = s.velocities();
            let mean = v.iter().map(|v| v.x).sum::<f64>() / v.len() as f64;
            let lost = MU * g * (steps as f64 * dt - lag);
            assert!(
                (mean - (1.0 - lost)).abs() <= tolerance * lost,
                "{integrator}: {mean} m/s after {steps} steps, Coulomb says {}",
                1.0 - lost
            );
        }
    }
}
