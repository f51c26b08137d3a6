//! The GPU explicit integrator against the CPU f32 mirror, on lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn scene(fixup: u32) -> (Model, Params) {
    let mut params = busy_params(Integrator::Explicit);
    params.fixup.iterations = fixup;
    (grid(17, 13, corners(), &params), params)
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
