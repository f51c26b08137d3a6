//! A batch of cloths against the CPU reference, per cloth-step, in one run.
//!
//! `cargo bench --bench batch_step` prints, for batches of 1, 16 and 64
//! copies of the `hanging` scene as it is (explicit, its 10 Jacobi fix-up
//! passes, its ground), the median wall time per cloth-step of the
//! [`GpuBatch`] (a run of steps recorded into one encoder, one submit, then
//! the status read-back, divided by steps × cloths), the median time per
//! step of one cloth on the CPU reference in f32, their ratio, and the
//! batch's dispatches per step; then criterion times one batch step
//! (`iter_custom`: submit plus wait) at each size. The adapter is the
//! default one (`WGPU_ADAPTER_NAME` picks another);
//! `WGCLOTH_BENCH_QUICK=1` shortens the run and `WGCLOTH_BENCH_SIZES=1,16`
//! picks the batch sizes.

mod common;

use std::time::{Duration, Instant};

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use wgcloth::gpu::{GpuBatch, GpuContext};
use wgcloth::{Model, Params, Scene};

/// Steps per timed submit: enough that a submit's fixed cost is spread.
const STEPS_PER_SUBMIT: u32 = 20;

fn batch_sizes() -> Vec<usize> {
    common::sizes(&[1, 16, 64])
}

/// The `hanging` scene as it is.
fn hanging() -> (Model, Params) {
    let scene = Scene::builtin("hanging").unwrap_or_else(|e| panic!("{e}"));
    let model = scene.model().unwrap_or_else(|e| panic!("{e}"));
    (model, scene.params)
}

/// A batch of `n` copies, stepped past the rest state.
fn batch(ctx: &GpuContext, model: &Model, params: &Params, n: usize) -> GpuBatch {
    let mut b = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    for _ in 0..n {
        b.add(model, params)
            .unwrap_or_else(|e| panic!("batch add: {e}"));
    }
    b.step(5).unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
    b
}

/// Median seconds per cloth-step over `samples` submits.
fn gpu_median(b: &mut GpuBatch, samples: usize) -> f64 {
    let cloths = b.cloth_count() as f64;
    common::median(samples, || {
        let t = Instant::now();
        b.step(STEPS_PER_SUBMIT)
            .unwrap_or_else(|e| panic!("GPU step: {e}"));
        t.elapsed().as_secs_f64() / (f64::from(STEPS_PER_SUBMIT) * cloths)
    })
}

fn table(ctx: &GpuContext) {
    let (model, params) = hanging();
    let samples = if common::quick() { 5 } else { 15 };
    println!(
        "\nbatches of `hanging` ({} particles, explicit, fix-up {}), per cloth-step, one run; GPU: {}",
        model.particle_count(),
        params.fixup.iterations,
        ctx.describe()
    );
    let cpu = common::cpu_f32_median(&model, &params, samples * 10);
    println!(
        "{:>7} {:>14} {:>14} {:>9} {:>20}",
        "cloths", "GPU ms/cloth", "CPU f32 ms", "GPU/CPU", "dispatches per step"
    );
    for n in batch_sizes() {
        let mut b = batch(ctx, &model, &params, n);
        let gpu = gpu_median(&mut b, samples);
        println!(
            "{n:>7} {:>14.4} {:>14.4} {:>8.2}× {:>20.0}",
            gpu * 1e3,
            cpu * 1e3,
            gpu / cpu,
            b.dispatches_per_step()
        );
    }
}

fn batch_step(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    let (model, params) = hanging();
    let mut group = c.benchmark_group("batch_step");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(if common::quick() { 1 } else { 3 }));
    for n in batch_sizes() {
        let mut b = batch(&ctx, &model, &params, n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("hanging", n), |bench| {
            bench.iter_custom(|steps| {
                let t = Instant::now();
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                b.encode_steps(&mut encoder, steps as u32);
                ctx.queue.submit([encoder.finish()]);
                if let Err(e) = ctx.device.poll(wgpu::PollType::wait_indefinitely()) {
                    panic!("poll: {e}");
                }
                t.elapsed()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, batch_step);

fn main() {
    match GpuContext::new(None) {
        Ok(ctx) => table(&ctx),
        Err(e) => panic!("the batch benchmark needs an adapter: {e}"),
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
