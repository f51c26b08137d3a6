//! A running cloth moved into a new solver: positions and velocities set
//! through `set_position` and `set_velocity` carry the motion on exactly
//! (what the viewer's integrator switch relies on). On lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::glam::Vec3;
use wgcloth::gpu::GpuSolver;
use wgcloth::params::Integrator;
use wgcloth::Error;

/// Steps before the hand-over, and after it.
const BEFORE: u32 = 20;
const AFTER: u32 = 10;

/// An explicit cloth's whole state is its positions and velocities: one
/// solver stepped `BEFORE + AFTER` times and one handed the state of
/// another after `BEFORE` steps, then stepped `AFTER`, agree bit for bit.
#[test]
fn a_state_handed_to_a_new_solver_carries_on_exactly() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let m = grid(13, 11, corners(), &p);
    let solver = || GpuSolver::new(&ctx.device, &ctx.queue, &m, &p).expect("GPU solver");
    let mut through = solver();
    through.step(BEFORE + AFTER).expect("steps");
    let expected = through.read_state().expect("read-back");

    let mut first = solver();
    first.step(BEFORE).expect("steps");
    let handed = first.read_state().expect("read-back");
    assert!(
        handed.v.iter().any(|v| v.length() > 0.0),
        "the cloth must be moving for the hand-over to mean something"
    );
    let mut second = solver();
    for (i, (x, v)) in handed.x.iter().zip(&handed.v).enumerate() {
        second.set_position(i, *x).expect("position");
        second.set_velocity(i, *v).expect("velocity");
    }
    second.step(AFTER).expect("steps");
    let got = second.read_state().expect("read-back");
    let (dx, at) = worst(&got.x, &expected.x);
    assert_eq!(
        got, expected,
        "worst position difference {dx} m at particle {at}"
    );
}

/// A pinned particle takes only a zero velocity; a non-finite velocity or
/// an index beyond the cloth is refused, naming what is allowed.
#[test]
fn a_velocity_the_solver_cannot_take_is_refused() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let m = grid(13, 11, corners(), &p);
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &m, &p).expect("GPU solver");
    let pinned = m.pinned.iter().position(|&p| p).expect("a pinned corner");
    let free = m.pinned.iter().position(|&p| !p).expect("a free particle");
    g.set_velocity(pinned, Vec3::ZERO).expect("zero on a pin");
    for (p, v, allowed) in [
        (pinned, Vec3::X, "zero"),
        (free, Vec3::new(f32::NAN, 0.0, 0.0), "finite"),
        (m.pinned.len(), Vec3::ZERO, "an index below"),
    ] {
        match g.set_velocity(p, v) {
            Err(Error::InvalidParameter { allowed: a, .. }) => {
                assert!(a.contains(allowed), "particle {p}, {v}: allowed `{a}`");
            }
            other => panic!("particle {p}, {v}: {other:?}"),
        }
    }
}
