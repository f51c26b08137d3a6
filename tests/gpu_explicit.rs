//! The GPU explicit integrator against the CPU f32 mirror, on lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::model::{ClothSpec, Corner, Pin};
use wgcloth::params::{FixupMethod, Ground, Integrator, Sphere, Wind};
use wgcloth::{Model, Params};

fn scene(fixup: u32) -> (Model, Params) {
    let mut params = Params {
        integrator: Integrator::Explicit,
        dt: 1e-3,
        ..Params::default()
    };
    params.fixup.method = FixupMethod::Jacobi;
    params.fixup.iterations = fixup;
    params.ground = Some(Ground {
        height: 0.85,
        friction: 0.4,
    });
    params.spheres = vec![Sphere {
        center: [0.0, 0.7, 0.0],
        radius: 0.2,
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
        pins: vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)],
        ..ClothSpec::default()
    };
    (Model::new(&spec, &params.springs).expect("valid"), params)
}

/// One step: both sides evaluate the same f32 expressions in the same order;
/// what may differ is the GPU compiler's freedom to fuse multiply-adds and
/// lavapipe's sqrt/division rounding, a few ulps of ~1 m: 1e-6 m.
const ONE_STEP_TOL: f64 = 1e-6;
/// 100 steps: those ulps feed back through the springs (a relative error
/// grows by at most ~(1 + ω dt) per step) and through the fix-up; 1e-4 m is
/// a tenth of a millimetre on a cloth that moved ~5 cm.
const HUNDRED_STEP_TOL: f64 = 1e-4;

#[test]
fn explicit_matches_the_cpu_mirror() {
    for fixup in [0, 4, 5] {
        let (model, params) = scene(fixup);
        for (steps, tol) in [(1, ONE_STEP_TOL), (100, HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &params, steps);
            eprintln!("fix-up {fixup}, {steps} steps: worst {d:e} m at particle {p}");
            assert!(
                d < tol,
                "fix-up {fixup}, {steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
            );
        }
    }
}
