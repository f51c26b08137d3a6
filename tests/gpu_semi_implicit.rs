//! The GPU semi-implicit integrator against the CPU f32 mirror, on lavapipe
//! in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::model::{Corner, Pin};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn scene(pins: Vec<Pin>) -> (Model, Params) {
    let params = busy_params(Integrator::SemiImplicit);
    (grid(17, 13, pins, &params), params)
}

/// As for the other integrators: the same f32 operations in the same order,
/// up to fused multiply-adds and rounding of division and square root.
const ONE_STEP_TOL: f64 = 1e-6;
/// 100 steps through the filter (a product over all particles), the
/// torque compensation's global sums and the fix-up: 1e-4 m.
const HUNDRED_STEP_TOL: f64 = 1e-4;

#[test]
fn semi_implicit_matches_the_cpu_mirror() {
    let pinned = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    // Without pins the torque compensation runs too.
    for pins in [pinned, vec![]] {
        let (model, params) = scene(pins.clone());
        for (steps, tol) in [(1, ONE_STEP_TOL), (100, HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &params, steps);
            eprintln!("{} pins, {steps} steps: worst {d:e} m", pins.len());
            assert!(
                d < tol,
                "{steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
            );
        }
    }
}

/// The scalable filter is CG on the device (to relative tolerance 1e-5)
/// against the CPU's exact banded solve. One step moves each particle by
/// dt·Δv ≈ 5e-5 m under gravity; a 1e-5 relative error of that is 5e-10 m,
/// and f32 rounding of positions near 1 m is 6e-8 m: 1e-6 m covers both.
const SCALABLE_ONE_STEP_TOL: f64 = 1e-6;
/// Over 100 steps the per-step differences accumulate and feed back
/// through the springs and the fix-up: 1e-3 m.
const SCALABLE_HUNDRED_STEP_TOL: f64 = 1e-3;

#[test]
fn scalable_filter_matches_the_cpu_banded_filter() {
    let pinned = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    for pins in [pinned, vec![]] {
        let (model, mut params) = scene(pins.clone());
        params.semi_implicit.filter = wgcloth::params::FilterMethod::Banded;
        for (steps, tol) in [(1, SCALABLE_ONE_STEP_TOL), (100, SCALABLE_HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &params, steps);
            eprintln!(
                "scalable, {} pins, {steps} steps: worst {d:e} m",
                pins.len()
            );
            assert!(
                d < tol,
                "{steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
            );
        }
    }
}
