//! GPU step time against the CPU reference, measured in one run.
//!
//! `cargo bench --bench gpu_step` prints, for 15², 33², 65², 129² and 257²
//! cloths and each integrator, the median wall time per step of the GPU
//! solver (a batch of steps recorded into one encoder, one submit, then a
//! wait) and of the CPU reference in f32, their ratio, and the dispatches
//! and submits per step; the 128² yardstick (minimum and median);
//! the grid kernels against the general ones at 129²; what skipping saves
//! at 65²; the workgroup path (one workgroup steps the cloth, one dispatch
//! per step) against the multi-dispatch path and the CPU at the sizes it
//! takes (15², 33² of the default sizes); the host (CPU) time to record a
//! step, multi-dispatch against the automatic path (wgpu validates and
//! tracks each dispatch as it is recorded); then criterion times the GPU
//! step (`iter_custom`: submit plus wait) at the same sizes. The adapter is the default one
//! (`WGPU_ADAPTER_NAME` picks another). `WGCLOTH_BENCH_QUICK=1` shortens
//! the run; `WGCLOTH_BENCH_SIZES=33,65` picks sizes (on lavapipe the 257²
//! semi-implicit step takes over a second: leave it out for a short run).
//!
//! The material is the `hanging` scene grown at constant particle spacing
//! and mass (see `benches/cpu_step.rs`), explicit at dt = 1/1000 s without
//! fix-up (the yardstick), implicit and semi-implicit at
//! dt = 0.02 s, CG tolerance 1e-3.

mod common;

use std::time::Instant;

use criterion::{criterion_group, Criterion};
use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuSolver, StepPath};
use wgcloth::kernel_config::WORKGROUP_STEP_MAX_PARTICLES;
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn sizes() -> Vec<usize> {
    common::sizes(&[15, 33, 65, 129, 257])
}

fn scene(integrator: Integrator, n: usize) -> (Model, Params) {
    let mut scene = common::grown_hanging(integrator, n);
    scene.params.implicit.tolerance = 1e-3;
    if integrator == Integrator::Explicit {
        scene.params.fixup.iterations = 0;
    }
    let model = match scene.model() {
        Ok(m) => m,
        Err(e) => panic!("{n}²: {e}"),
    };
    (model, scene.params)
}

fn gpu_solver(ctx: &GpuContext, model: &Model, params: &Params) -> GpuSolver {
    gpu_solver_with(ctx, model, params, true)
}

fn gpu_solver_with(
    ctx: &GpuContext,
    model: &Model,
    params: &Params,
    specialised: bool,
) -> GpuSolver {
    let g = match GpuSolver::new(&ctx.device, &ctx.queue, model, params) {
        Ok(g) => g,
        Err(e) => panic!("GPU solver: {e}"),
    };
    warmed(g, specialised)
}

/// A solver on `path`, warmed up.
fn gpu_solver_on(ctx: &GpuContext, model: &Model, params: &Params, path: StepPath) -> GpuSolver {
    match GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, model, params, path) {
        Ok(g) => warmed(g, true),
        Err(e) => panic!("GPU solver on the {path} path: {e}"),
    }
}

/// `g` with its kernels `specialised` or not, stepped past the rest state.
fn warmed(mut g: GpuSolver, specialised: bool) -> GpuSolver {
    if let Err(e) = g.tuning_mut().set_specialised(specialised) {
        panic!("GPU kernels: {e}");
    }
    // Warm up past the rest state and let the CG budget adapt.
    for _ in 0..3 {
        if let Err(e) = g.step(5) {
            panic!("GPU warm-up: {e}");
        }
    }
    g
}

/// Median seconds per step over `samples` batches of `batch` steps.
fn gpu_median(g: &mut GpuSolver, batch: u32, samples: usize) -> f64 {
    common::median(samples, || {
        let t = Instant::now();
        if let Err(e) = g.step(batch) {
            panic!("GPU step: {e}");
        }
        t.elapsed().as_secs_f64() / f64::from(batch)
    })
}

fn table(ctx: &GpuContext) {
    println!(
        "\nGPU vs CPU (f32), median time per step, one run; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>6} {:>14} {:>11} {:>11} {:>9} {:>11} {:>8}",
        "size", "integrator", "GPU ms", "CPU ms", "GPU/CPU", "dispatches", "submits"
    );
    for n in sizes() {
        for integrator in Integrator::ALL {
            let (model, params) = scene(integrator, n);
            let mut g = gpu_solver(ctx, &model, &params);
            let big = n > 129;
            let batch = if integrator == Integrator::Explicit {
                20
            } else {
                2
            };
            let samples = if common::quick() || big { 3 } else { 7 };
            let gpu = gpu_median(&mut g, batch, samples);
            let cpu = common::cpu_f32_median(&model, &params, samples);
            println!(
                "{:>6} {:>14} {:>11.3} {:>11.3} {:>8.2}× {:>11.0} {:>8.2}",
                format!("{n}²"),
                integrator.as_str(),
                gpu * 1e3,
                cpu * 1e3,
                gpu / cpu,
                g.tuning().dispatches_per_step(),
                1.0 / f64::from(batch)
            );
        }
    }
}

/// What skipping saves: a minimal scene (no pins, wind, colliders or bend
/// springs) against the full one (two pinned corners, wind, ground, a
/// sphere, bend springs) per integrator, specialised kernels against the
/// general ones, and CG with its adaptive budget against recording the
/// maximum iterations every step (stopped iterations return at once).
fn skipping_table(ctx: &GpuContext) {
    let n = 65;
    println!("\nSkipping what a {n}² scene does not use (GPU, median ms per step)");
    println!(
        "{:>14} {:>9} {:>9} {:>8} {:>13} {:>9}",
        "integrator", "minimal", "full", "ratio", "general/spec", "dispatch"
    );
    let samples = if common::quick() { 3 } else { 7 };
    for integrator in Integrator::ALL {
        let (model, mut minimal) = scene(integrator, n);
        minimal.springs[2].stiffness = 0.0;
        minimal.wind = None;
        minimal.ground = None;
        minimal.spheres.clear();
        minimal.fixup.iterations = 0;
        let mut spec = model.grid.clone().unwrap_or_default();
        spec.pins.clear();
        let Ok(minimal_model) = Model::new(&spec, &minimal.springs) else {
            panic!("minimal model");
        };
        let mut full = scene(integrator, n).1;
        full.wind = Some(wgcloth::params::Wind {
            velocity: DVec3::new(4.0, 0.0, 1.0),
            drag: 0.6,
            lift: 0.2,
        });
        full.ground = Some(wgcloth::params::Ground {
            height: -3.0,
            friction: 0.5,
        });
        full.spheres = vec![wgcloth::params::Sphere {
            center: DVec3::new(0.0, 0.5, 0.0),
            radius: 0.3,
            friction: 0.3,
            velocity: DVec3::ZERO,
        }];
        full.fixup.iterations = 10;
        let batch = if integrator == Integrator::Explicit {
            20
        } else {
            2
        };
        let mut g_min = gpu_solver(ctx, &minimal_model, &minimal);
        let t_min = gpu_median(&mut g_min, batch, samples);
        let d_min = g_min.tuning().dispatches_per_step();
        let mut g_full = gpu_solver(ctx, &model, &full);
        let t_full = gpu_median(&mut g_full, batch, samples);
        let d_full = g_full.tuning().dispatches_per_step();
        // The general kernels on a second solver with the same history (CG
        // warm starts make later steps cheaper, so one solver timed twice
        // would flatter whichever ran second).
        let mut g_general = gpu_solver_with(ctx, &model, &full, false);
        let t_general = gpu_median(&mut g_general, batch, samples);
        println!(
            "{:>14} {:>9.3} {:>9.3} {:>7.2}× {:>12.2}× {:>4.0}/{:<4.0}",
            integrator.as_str(),
            t_min * 1e3,
            t_full * 1e3,
            t_full / t_min,
            t_general / t_full,
            d_min,
            d_full
        );
    }
    println!("\nCG early exit ({n}² implicit, median ms per step)");
    let (model, params) = scene(Integrator::Implicit, n);
    let mut adaptive = gpu_solver(ctx, &model, &params);
    let t_adaptive = gpu_median(&mut adaptive, 2, samples);
    let budget = adaptive.tuning().cg_budget();
    let mut fixed = gpu_solver(ctx, &model, &params);
    fixed.tuning_mut().set_adaptive_cg_budget(false);
    let t_fixed = gpu_median(&mut fixed, 2, samples);
    println!(
        "adaptive budget ({budget} recorded) {:.3} ms, maximum ({} recorded) {:.3} ms: {:.2}×",
        t_adaptive * 1e3,
        params.implicit.max_iterations,
        t_fixed * 1e3,
        t_fixed / t_adaptive
    );
}

/// The yardstick: a 128 × 128 cloth with stretch, shear and bend
/// springs and two pinned corners; explicit without fix-up (target ≤ 0.75
/// ms per step on lavapipe on the 2-core machine) and implicit at CG
/// tolerance 1e-3 (target ≤ 18 ms), with the coarse levels (the default)
/// and with block Jacobi alone, each from the same start. Shared machines
/// are noisy: the minimum of many batches is printed beside the median,
/// and the mean CG iterations of the batches' last steps beside them.
fn yardstick(ctx: &GpuContext) {
    let n = 128;
    println!(
        "\nYardstick: {n}², ms per step over 15 batches (GPU: {})",
        ctx.describe()
    );
    println!(
        "{:>22} {:>8} {:>8} {:>8} {:>11} {:>8} {:>8}",
        "integrator", "min", "median", "target", "dispatches", "springs", "CG its"
    );
    let rows = [
        ("explicit", Integrator::Explicit, true, 0.75),
        ("implicit", Integrator::Implicit, true, 18.0),
        ("implicit, block Jacobi", Integrator::Implicit, false, 18.0),
    ];
    for (name, integrator, coarse_levels, target) in rows {
        let (model, mut params) = scene(integrator, n);
        params.implicit.coarse_levels = coarse_levels;
        let mut g = gpu_solver(ctx, &model, &params);
        let batch = if integrator == Integrator::Explicit {
            20
        } else {
            2
        };
        let mut its = 0u32;
        let mut times: Vec<f64> = (0..15)
            .map(|_| {
                let t = Instant::now();
                let status = match g.step(batch) {
                    Ok(s) => s,
                    Err(e) => panic!("GPU step: {e}"),
                };
                its += status.cg_iterations;
                t.elapsed().as_secs_f64() / f64::from(batch)
            })
            .collect();
        times.sort_by(f64::total_cmp);
        println!(
            "{:>22} {:>8.3} {:>8.3} {:>8.2} {:>11.0} {:>8} {:>8.1}",
            name,
            times[0] * 1e3,
            times[times.len() / 2] * 1e3,
            target,
            g.tuning().dispatches_per_step(),
            model.springs.len(),
            f64::from(its) / 15.0
        );
    }
}

/// The grid kernels (springs found by row and column) against the general
/// adjacency kernels, on the yardstick scene at 129², each on its
/// own solver with the same history.
fn grid_table(ctx: &GpuContext) {
    let n = 129;
    println!("\nGrid against general kernels ({n}², median ms per step)");
    println!(
        "{:>14} {:>9} {:>9} {:>8} {:>9}",
        "integrator", "grid", "general", "ratio", "dispatch"
    );
    let samples = if common::quick() { 3 } else { 7 };
    for integrator in Integrator::ALL {
        let (model, params) = scene(integrator, n);
        let batch = if integrator == Integrator::Explicit {
            20
        } else {
            2
        };
        let mut grid = gpu_solver(ctx, &model, &params);
        let t_grid = gpu_median(&mut grid, batch, samples);
        let mut general = gpu_solver_with(ctx, &model, &params, false);
        let t_general = gpu_median(&mut general, batch, samples);
        println!(
            "{:>14} {:>9.3} {:>9.3} {:>7.2}× {:>4.0}/{:<4.0}",
            integrator.as_str(),
            t_grid * 1e3,
            t_general * 1e3,
            t_general / t_grid,
            grid.tuning().dispatches_per_step(),
            general.tuning().dispatches_per_step()
        );
    }
}

/// The integrators with a workgroup kernel.
const WORKGROUP_INTEGRATORS: [Integrator; 3] = [
    Integrator::Explicit,
    Integrator::Implicit,
    Integrator::SemiImplicit,
];

/// The workgroup path against the multi-dispatch path and the `f32` CPU,
/// at the sizes the workgroup path takes: explicit with 10 fix-up passes
/// (the target), implicit (coarse levels, CG tolerance 1e-3),
/// semi-implicit with the dense filter; median ms
/// per step, each path's ratio to the CPU, dispatches per step.
fn workgroup_table(ctx: &GpuContext) {
    let sizes: Vec<usize> = sizes()
        .into_iter()
        .filter(|&n| n * n <= WORKGROUP_STEP_MAX_PARTICLES as usize)
        .collect();
    if sizes.is_empty() {
        return;
    }
    println!(
        "
One workgroup per cloth against multi-dispatch and the CPU (f32), ms per step"
    );
    println!(
        "{:>6} {:>14} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11}",
        "size", "integrator", "multi", "workgrp", "CPU", "multi/CPU", "wg/CPU", "dispatches"
    );
    let samples = if common::quick() { 3 } else { 7 };
    for n in sizes {
        for integrator in WORKGROUP_INTEGRATORS {
            let (model, mut params) = scene(integrator, n);
            if integrator == Integrator::Explicit {
                params.fixup.iterations = 10;
            }
            let batch = if integrator == Integrator::Explicit {
                20
            } else {
                5
            };
            let mut multi = gpu_solver_on(ctx, &model, &params, StepPath::MultiDispatch);
            let t_multi = gpu_median(&mut multi, batch, samples);
            let mut wg = gpu_solver_on(ctx, &model, &params, StepPath::Workgroup);
            let t_wg = gpu_median(&mut wg, batch, samples);
            let cpu = common::cpu_f32_median(&model, &params, samples);
            println!(
                "{:>6} {:>14} {:>9.3} {:>9.3} {:>9.3} {:>8.2}× {:>8.2}× {:>5.0}/{:<5.0}",
                format!("{n}²"),
                integrator.as_str(),
                t_multi * 1e3,
                t_wg * 1e3,
                cpu * 1e3,
                t_multi / cpu,
                t_wg / cpu,
                multi.tuning().dispatches_per_step(),
                wg.tuning().dispatches_per_step()
            );
        }
    }
}

/// Host seconds per step to record `batch` steps: `encode_steps` into a
/// fresh encoder plus `finish`, neither submitted nor waited on (the
/// solver's count of recorded steps runs ahead of the device's; it is
/// dropped after).
fn recording_once(ctx: &GpuContext, g: &mut GpuSolver, batch: u32) -> f64 {
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let t = Instant::now();
    g.encode_steps(&mut encoder, batch);
    let commands = encoder.finish();
    let elapsed = t.elapsed();
    drop(commands);
    elapsed.as_secs_f64() / f64::from(batch)
}

/// The host's cost of recording a step (no submit, no wait) on the
/// multi-dispatch path and on the path the solver picks (the workgroup
/// path where its cost model expects it faster): median µs per step,
/// dispatches per step and µs per dispatch, and the automatic path's time
/// over multi-dispatch's. The two solvers' recordings alternate, so a
/// change in the host's load falls on both; recording is cheap next to a
/// step, so more are taken than steps are timed elsewhere.
fn recording_table(ctx: &GpuContext) {
    println!(
        "\nRecording a step on the CPU (encode_steps + finish, no submit), median µs per step; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>6} {:>14} {:>9} {:>6} {:>8} {:>9} {:>9} {:>6} {:>8} {:>10}",
        "size",
        "integrator",
        "multi µs",
        "disp",
        "µs/disp",
        "auto path",
        "auto µs",
        "disp",
        "µs/disp",
        "auto/multi"
    );
    let samples = if common::quick() { 11 } else { 31 };
    for n in sizes() {
        for integrator in Integrator::ALL {
            let (model, params) = scene(integrator, n);
            // The batches the other tables submit: even, so single-pass
            // explicit steps record no seed dispatch.
            let batch = if integrator == Integrator::Explicit {
                20
            } else {
                2
            };
            let mut multi = gpu_solver_on(ctx, &model, &params, StepPath::MultiDispatch);
            let mut auto = gpu_solver(ctx, &model, &params);
            let (mut t_multi, mut t_auto) = (Vec::new(), Vec::new());
            for _ in 0..samples {
                t_multi.push(recording_once(ctx, &mut multi, batch));
                t_auto.push(recording_once(ctx, &mut auto, batch));
            }
            let (t_multi, t_auto) = (common::median_of(t_multi), common::median_of(t_auto));
            let d_multi = multi.tuning().dispatches_per_step();
            let d_auto = auto.tuning().dispatches_per_step();
            let path = match auto.tuning().step_path() {
                StepPath::Workgroup => "workgroup",
                StepPath::MultiDispatch => "multi",
            };
            println!(
                "{:>6} {:>14} {:>9.1} {:>6.0} {:>8.2} {:>9} {:>9.1} {:>6.0} {:>8.2} {:>9.2}×",
                format!("{n}²"),
                integrator.as_str(),
                t_multi * 1e6,
                d_multi,
                t_multi * 1e6 / d_multi,
                path,
                t_auto * 1e6,
                d_auto,
                t_auto * 1e6 / d_auto,
                t_auto / t_multi
            );
        }
    }
}

fn gpu_step(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    common::gpu_step_group(c, &ctx, "gpu_step", &sizes(), |integrator, n| {
        let (model, params) = scene(integrator, n);
        gpu_solver(&ctx, &model, &params)
    });
}

criterion_group!(benches, gpu_step);

fn main() {
    match GpuContext::new(None) {
        Ok(ctx) => {
            table(&ctx);
            yardstick(&ctx);
            grid_table(&ctx);
            skipping_table(&ctx);
            workgroup_table(&ctx);
            recording_table(&ctx);
        }
        Err(e) => panic!("the GPU benchmark needs an adapter: {e}"),
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
