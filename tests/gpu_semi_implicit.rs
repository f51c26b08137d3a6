//! The GPU semi-implicit integrator against the CPU f32 mirror, on lavapipe
//! in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::model::{ClothSpec, Corner, Pin};
use wgcloth::params::{FixupMethod, Ground, Integrator, Sphere, Wind};
use wgcloth::{Model, Params};

fn scene(pins: Vec<Pin>) -> (Model, Params) {
    let mut params = Params {
        integrator: Integrator::SemiImplicit,
        dt: 1.0 / 200.0,
        ..Params::default()
    };
    params.fixup.method = FixupMethod::Jacobi;
    params.ground = Some(Ground {
        height: 0.7,
        friction: 0.4,
    });
    params.spheres = vec![Sphere {
        center: [0.0, 0.6, 0.0],
        radius: 0.25,
        friction: 0.3,
    }];
    params.wind = Some(Wind {
        velocity: [2.0, 0.0, 1.0],
        drag: 0.6,
        lift: 0.2,
    });
    let spec = ClothSpec {
        nx: 17,
        ny: 13,
        pins,
        ..ClothSpec::default()
    };
    (Model::new(&spec, &params.springs).expect("valid"), params)
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
