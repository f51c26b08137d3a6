//! What self-collision costs: a step with `[self_collision]` against the
//! same step without it, at 33², 65², 129², 257² and on a mesh, on the GPU
//! and on the CPU reference in `f32`, as ratios measured in one run.
//!
//! `cargo bench --bench self_collision_step` prints, for the `heap` scene
//! (a 1 m cloth folding onto itself on the floor, implicit at 1/240 s)
//! grown to each size at constant extent, and for the `tablecloth` mesh
//! scene (631 vertices) with `[self_collision]` added, the median wall
//! time per step with and without self-collision and their ratio: on the
//! GPU a run of steps recorded into one encoder, one submit, a wait; on the
//! CPU single `f32` steps. Each solver is first stepped to where the heap
//! has folded (96 steps, 0.4 s) at up to 65², and 8 steps beyond (the
//! grid's build and passes cost the same whether or not particles touch;
//! the contacts' own work is what the folded state adds). Then criterion
//! times the GPU step with self-collision (`iter_custom`: submit plus
//! wait). `WGCLOTH_BENCH_QUICK=1` shortens the run; `WGCLOTH_BENCH_SIZES=33,65`
//! picks sizes.

mod common;

use std::time::Instant;

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::params::SelfCollision;
use wgcloth::{Model, Params, Scene};

fn sizes() -> Vec<usize> {
    common::sizes(&[33, 65, 129, 257])
}

/// The built-in scene `name` at `n × n` particles (`None`: as it is),
/// with self-collision on or off.
fn scene(name: &str, n: Option<usize>, on: bool) -> (Model, Params) {
    let mut scene = Scene::builtin(name).unwrap_or_else(|e| panic!("{e}"));
    if let Some(n) = n {
        scene.cloth.nx = n;
        scene.cloth.ny = n;
    }
    scene.params.self_collision = on.then(SelfCollision::default);
    let model = scene.model().unwrap_or_else(|e| panic!("{name}: {e}"));
    (model, scene.params)
}

/// Steps before timing: to the folded heap where that is cheap.
fn warm_up(particles: usize) -> u32 {
    if particles <= 65 * 65 {
        96
    } else {
        8
    }
}

/// Seconds per GPU step, median of runs of `batch` steps.
fn gpu_time(ctx: &GpuContext, model: &Model, params: &Params) -> f64 {
    let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, model, params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    g.step(warm_up(model.particle_count()))
        .unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
    let batch = if model.particle_count() <= 65 * 65 {
        8
    } else {
        2
    };
    common::median(if common::quick() { 3 } else { 5 }, || {
        let t = Instant::now();
        g.step(batch).unwrap_or_else(|e| panic!("GPU step: {e}"));
        t.elapsed().as_secs_f64() / f64::from(batch)
    })
}

/// Seconds per CPU `f32` step, median of single steps.
fn cpu_time(model: &Model, params: &Params) -> f64 {
    let mut c = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU solver: {e}"));
    c.step_n(u64::from(warm_up(model.particle_count())))
        .unwrap_or_else(|e| panic!("CPU warm-up: {e}"));
    common::median(if common::quick() { 3 } else { 5 }, || {
        let t = Instant::now();
        c.step().unwrap_or_else(|e| panic!("CPU step: {e}"));
        t.elapsed().as_secs_f64()
    })
}

fn table(ctx: &GpuContext) {
    println!(
        "\nA step with self-collision against one without, median ms per step, one run; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>16} {:>9} {:>9} {:>7} {:>9} {:>9} {:>7}",
        "scene", "GPU off", "GPU on", "ratio", "CPU off", "CPU on", "ratio"
    );
    let mut rows: Vec<(String, &str, Option<usize>)> = sizes()
        .into_iter()
        .map(|n| (format!("heap {n}²"), "heap", Some(n)))
        .collect();
    rows.push(("tablecloth mesh".to_string(), "tablecloth", None));
    for (label, name, n) in rows {
        let (off_model, off) = scene(name, n, false);
        let (on_model, on) = scene(name, n, true);
        let (g_off, g_on) = (
            gpu_time(ctx, &off_model, &off),
            gpu_time(ctx, &on_model, &on),
        );
        let (c_off, c_on) = (cpu_time(&off_model, &off), cpu_time(&on_model, &on));
        println!(
            "{label:>16} {:>9.3} {:>9.3} {:>6.2}× {:>9.3} {:>9.3} {:>6.2}×",
            g_off * 1e3,
            g_on * 1e3,
            g_on / g_off,
            c_off * 1e3,
            c_on * 1e3,
            c_on / c_off
        );
    }
}

fn self_collision_step(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    let mut group = c.benchmark_group("self_collision_step");
    group.sample_size(10);
    for n in sizes() {
        let (model, params) = scene("heap", Some(n), true);
        let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params)
            .unwrap_or_else(|e| panic!("GPU solver: {e}"));
        g.step(warm_up(model.particle_count()))
            .unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
        group.throughput(Throughput::Elements((n * n) as u64));
        group.bench_function(BenchmarkId::new("heap", n * n), |b| {
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
