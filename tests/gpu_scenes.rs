//! Every built-in scene under every integrator: the GPU against the CPU f32
//! mirror after 1 step and after 100, on lavapipe in CI (under the bounded
//! policy each of 100 steps against the mirror re-seeded before it).

mod gpu_common;

use gpu_common::*;
use wgcloth::gpu::StepPath;
use wgcloth::params::{FixupMethod, Integrator};
use wgcloth::Scene;

/// One step: the same f32 operations in the same order on both sides; what
/// may differ is an adapter's freedom to fuse multiply-adds and its
/// division and square-root rounding — a few ulps of ~1 m. (On lavapipe the
/// two agree bit for bit except with the scalable semi-implicit filter,
/// which the GPU solves by CG to 1e-5 and the CPU exactly.)
const ONE_STEP_TOL: f64 = 1e-6;
/// 100 steps: ulp-level differences feed back through springs, fix-up and
/// CG; 1e-3 m bounds them with a margin and still catches any wrong term
/// (a 1 % error in one force moves these cloths by more within 100 steps).
const HUNDRED_STEP_TOL: f64 = 1e-3;

/// One test per built-in scene, so that the harness runs them side by
/// side (the CPU mirror of one beside the GPU steps of another).
macro_rules! each_scene {
    ($($scene:ident),* $(,)?) => {
        $(
            #[test]
            fn $scene() {
                scene_matches_the_cpu_mirror(stringify!($scene));
            }
        )*

        #[test]
        fn every_builtin_scene_has_its_test() {
            assert_eq!(Scene::builtin_names(), [$(stringify!($scene)),*]);
        }
    };
}

each_scene!(hanging, curtain, flag, drape, tablecloth, banner, cape, heap, table, layers, skirt);

/// The built-in scene `name` under every integrator: the GPU against the
/// mirror after 1 step and after 100.
fn scene_matches_the_cpu_mirror(name: &str) {
    let mut failures = Vec::new();
    for integrator in Integrator::ALL {
        let mut scene = Scene::builtin(name).expect("built in");
        scene.params.integrator = integrator;
        // The GPU's fix-up is Jacobi; the explicit scheme needs the small
        // step its stability bound asks for on the stiffer scenes.
        scene.params.fixup.method = FixupMethod::Jacobi;
        if integrator == Integrator::Explicit {
            scene.params.dt = scene.params.dt.min(1e-3);
        }
        let model = scene.model().expect("valid");
        // An adapter that rounds otherwise than the mirror: each step
        // against the mirror re-seeded with the device's state, since the
        // free runs of these chaotic scenes part within 100 steps.
        let what = format!("{name} {integrator}");
        let make = || exact_gpu(&model, &scene.params);
        if let Some(verdict) = bounded_steps(&what, make, &model, &scene.params, 100) {
            if let Err(e) = verdict {
                failures.push(e);
            }
            continue;
        }
        for (steps, tol) in [(1, ONE_STEP_TOL), (100, HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &scene.params, steps);
            let line = format!(
                "{name} {integrator} {steps} steps: worst {d:e} m at particle {p} (GPU {g:?}, CPU {c:?})"
            );
            eprintln!("{line}");
            if d.is_nan() || d >= tol {
                failures.push(line);
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// A cloth that is not a grid (here a grid's parts rebuilt with
/// `Model::from_parts`) runs the general adjacency kernels, a grid the grid
/// kernels (no per-spring force pass); both match the CPU mirror.
#[test]
fn grid_and_general_kernels_match_the_cpu_mirror() {
    let mut scene = Scene::builtin("drape").expect("built in");
    scene.params.fixup.method = FixupMethod::Jacobi;
    let grid = scene.model().expect("valid");
    let general = gpu_common::without_grid(&grid);
    for integrator in Integrator::ALL {
        scene.params.integrator = integrator;
        scene.params.dt = if integrator == Integrator::Explicit {
            1e-3
        } else {
            1.0 / 120.0
        };
        for (what, model, per_spring_pass) in [("grid", &grid, false), ("general", &general, true)]
        {
            // The multi-dispatch path's plan shows its layout (a small
            // explicit cloth would otherwise take the workgroup path).
            let mut g = solver_on(model, &scene.params, StepPath::MultiDispatch);
            g.tuning_mut().set_adaptive_cg_budget(false);
            if integrator == Integrator::Explicit {
                let plan = g.tuning().step_plan();
                assert_eq!(
                    plan.iter()
                        .any(|d| d.kernel == wgcloth::gpu::Kernel::SpringForces),
                    per_spring_pass,
                    "{what}: {plan:?}"
                );
            }
            let what = format!("{what} {integrator}");
            if let Some(verdict) = bounded_steps(&what, || g, model, &scene.params, 50) {
                verdict.unwrap_or_else(|e| panic!("{e}"));
                continue;
            }
            let (d, p, gp, cp) = compare(model, &scene.params, 50);
            assert!(
                d < HUNDRED_STEP_TOL,
                "{what} {integrator}: worst {d:e} m at particle {p} (GPU {gp:?}, CPU {cp:?})"
            );
        }
    }
}
