//! What self-collision costs: a step with `[self_collision]` against the
//! same step without it, at 33², 65², 129², 257² and on a mesh, on the GPU
//! and on the CPU reference in `f32`, as ratios measured in one run.
//!
//! `cargo bench --bench self_collision_step` prints, for the `hanging`
//! scene grown at constant spacing (`benches/common`: no ground, explicit
//! at 1/1000 s without fix-up, implicit at 0.02 s) and for the
//! `tablecloth` mesh scene (631 vertices, implicit), the median wall time
//! per step without and with an empty `[self_collision]` table and their
//! ratio (and, on the CPU, with its triangle method at the default 2 mm,
//! which the GPU has not got yet): on the GPU a run of steps recorded into one encoder, one submit,
//! a wait; on the CPU single `f32` steps; the two solvers of a row timed
//! in turn, sample by sample, so that a load on the machine hits both.
//! Nothing in these scenes comes near another part of its cloth (the first
//! steps of the tablecloth's fall), so both solvers step the same states
//! and iterate CG as often: the ratio is what the grid's build and passes
//! add to a step. Then criterion times the GPU step with self-collision
//! (`iter_custom`: submit plus wait). `WGCLOTH_BENCH_QUICK=1` shortens the
//! run; `WGCLOTH_BENCH_SIZES=33,65` picks sizes.

mod common;

use std::time::Instant;

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::params::{ContactMethod, Integrator, SelfCollision};
use wgcloth::{Model, Params, Scene};

fn sizes() -> Vec<usize> {
    common::sizes(&[33, 65, 129, 257])
}

/// Steps before timing.
const WARM_UP: u32 = 8;

/// `scene`'s cloth and its parameters without self-collision, with it,
/// and with its triangle method.
fn variants(scene: Scene) -> (Model, [Params; 3]) {
    let model = scene
        .model()
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    let with = |method| Params {
        self_collision: Some(SelfCollision {
            method,
            ..SelfCollision::default()
        }),
        ..scene.params.clone()
    };
    let on = with(ContactMethod::Particles);
    let triangles = with(ContactMethod::Triangles);
    (model, [scene.params, on, triangles])
}

/// Seconds per GPU step without and with self-collision, medians of runs
/// of `batch` steps taken in turn.
fn gpu_times(ctx: &GpuContext, model: &Model, params: &[Params; 2], batch: u32) -> [f64; 2] {
    let mut solvers = params.clone().map(|p| {
        let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, model, &p)
            .unwrap_or_else(|e| panic!("GPU solver: {e}"));
        g.step(WARM_UP)
            .unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
        g
    });
    let mut times = [Vec::new(), Vec::new()];
    for _ in 0..common::samples() {
        for (g, t) in solvers.iter_mut().zip(&mut times) {
            let start = Instant::now();
            g.step(batch).unwrap_or_else(|e| panic!("GPU step: {e}"));
            t.push(start.elapsed().as_secs_f64() / f64::from(batch));
        }
    }
    times.map(common::middle)
}

/// Seconds per CPU `f32` step under each of `params`, medians of single
/// steps taken in turn.
fn cpu_times<const N: usize>(model: &Model, params: &[Params; N]) -> [f64; N] {
    let mut solvers = params.clone().map(|p| {
        let mut c = CpuSolver::<f32>::new(model, &p).unwrap_or_else(|e| panic!("CPU solver: {e}"));
        c.step_n(u64::from(WARM_UP))
            .unwrap_or_else(|e| panic!("CPU warm-up: {e}"));
        c
    });
    let mut times = [(); N].map(|_| Vec::new());
    for _ in 0..common::samples() {
        for (c, t) in solvers.iter_mut().zip(&mut times) {
            let start = Instant::now();
            c.step().unwrap_or_else(|e| panic!("CPU step: {e}"));
            t.push(start.elapsed().as_secs_f64());
        }
    }
    times.map(common::middle)
}

fn table(ctx: &GpuContext) {
    println!(
        "\nA step with self-collision against one without, median ms per step, one run; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>22} {:>9} {:>9} {:>7} {:>9} {:>9} {:>7} {:>9} {:>7}",
        "scene", "GPU off", "GPU on", "ratio", "CPU off", "CPU on", "ratio", "CPU tri", "ratio"
    );
    let mut rows: Vec<(String, Scene)> = Vec::new();
    for n in sizes() {
        for integrator in [Integrator::Explicit, Integrator::Implicit] {
            let mut scene = common::grown_hanging(integrator, n);
            scene.params.fixup.iterations = 0;
            rows.push((format!("hanging {n}² {}", integrator.as_str()), scene));
        }
    }
    let tablecloth = Scene::builtin("tablecloth").unwrap_or_else(|e| panic!("{e}"));
    rows.push(("tablecloth mesh implicit".to_string(), tablecloth));
    for (label, scene) in rows {
        let explicit = scene.params.integrator == Integrator::Explicit;
        let (model, [off, on, triangles]) = variants(scene);
        let batch = if explicit { 20 } else { 2 };
        let [g_off, g_on] = gpu_times(ctx, &model, &[off.clone(), on.clone()], batch);
        let [c_off, c_on, c_tri] = cpu_times(&model, &[off, on, triangles]);
        println!(
            "{label:>22} {:>9.3} {:>9.3} {:>6.2}× {:>9.3} {:>9.3} {:>6.2}× {:>9.3} {:>6.2}×",
            g_off * 1e3,
            g_on * 1e3,
            g_on / g_off,
            c_off * 1e3,
            c_on * 1e3,
            c_on / c_off,
            c_tri * 1e3,
            c_tri / c_off
        );
    }
}

fn self_collision_step(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    let mut group = c.benchmark_group("self_collision_step");
    group.sample_size(10);
    for n in sizes() {
        let (model, [_, params, _]) = variants(common::grown_hanging(Integrator::Implicit, n));
        let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params)
            .unwrap_or_else(|e| panic!("GPU solver: {e}"));
        g.step(WARM_UP)
            .unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
        group.throughput(Throughput::Elements((n * n) as u64));
        group.bench_function(BenchmarkId::new("hanging implicit", n * n), |b| {
            b.iter_custom(|iters| common::submit_and_wait(&ctx, &mut g, iters))
        });
    }
    group.finish();
}

criterion_group!(benches, self_collision_step);

fn main() {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    table(&ctx);
    benches();
    criterion::Criterion::default()
        .configure_from_args()
        .final_summary();
}
