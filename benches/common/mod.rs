//! Shared by the benches: the benchmark scene.

use std::time::{Duration, Instant};

use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params, Scene};

/// The `hanging` scene grown to `n × n` particles at constant particle
/// spacing and mass — every size has the same local dynamics and stays
/// stable at the same dt — without its ground (nothing to land on while
/// timing), for `integrator`: the scene's dt for explicit, the article's
/// 0.02 s for the other two.
#[allow(dead_code, reason = "batch_step times the scene as it is")]
pub fn grown_hanging(integrator: Integrator, n: usize) -> Scene {
    let Ok(mut scene) = Scene::builtin("hanging") else {
        panic!("the hanging scene is built in");
    };
    let grow = (n - 1) as f64 / (scene.cloths[0].spec.nx - 1) as f64;
    scene.cloths[0].spec.size = scene.cloths[0].spec.size.map(|s| s * grow);
    scene.cloths[0].spec.origin = DVec3::new(
        -scene.cloths[0].spec.size[0] / 2.0,
        1.0,
        -scene.cloths[0].spec.size[1] / 2.0,
    );
    scene.cloths[0].spec.mass *=
        (n * n) as f64 / (scene.cloths[0].spec.nx * scene.cloths[0].spec.ny) as f64;
    scene.cloths[0].spec.nx = n;
    scene.cloths[0].spec.ny = n;
    scene.params.ground = None;
    scene.params.integrator = integrator;
    if integrator != Integrator::Explicit {
        scene.params.dt = 0.02;
    }
    scene
}

/// Wall time of `steps` GPU steps recorded into one encoder, one submit,
/// then a wait: criterion's `iter_custom` body for a GPU step.
#[allow(dead_code, reason = "cpu_step times no GPU")]
pub fn submit_and_wait(ctx: &GpuContext, g: &mut GpuSolver, steps: u64) -> Duration {
    let t = Instant::now();
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    g.encode_steps(&mut encoder, steps as u32);
    ctx.queue.submit([encoder.finish()]);
    if let Err(e) = ctx.device.poll(wgpu::PollType::wait_indefinitely()) {
        panic!("poll: {e}");
    }
    t.elapsed()
}

/// `WGCLOTH_BENCH_QUICK` set: shorter criterion measurements.
pub fn quick() -> bool {
    std::env::var_os("WGCLOTH_BENCH_QUICK").is_some()
}

/// The cloth sizes (particles per side) to time: `WGCLOTH_BENCH_SIZES`
/// (comma-separated) or `default`.
#[allow(dead_code, reason = "cpu_step times its own sizes")]
pub fn sizes(default: &[usize]) -> Vec<usize> {
    std::env::var("WGCLOTH_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|t| t.trim().parse().ok()).collect())
        .unwrap_or_else(|| default.to_vec())
}

/// A criterion group `name` timing one GPU step of the solver `solver`
/// makes for each integrator and size, throughput in particles.
#[allow(dead_code, reason = "cpu_step times no GPU")]
pub fn gpu_step_group(
    c: &mut criterion::Criterion,
    ctx: &GpuContext,
    name: &str,
    sizes: &[usize],
    mut solver: impl FnMut(Integrator, usize) -> GpuSolver,
) {
    use criterion::{BenchmarkId, Throughput};
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(if quick() { 1 } else { 3 }));
    for &n in sizes {
        for integrator in Integrator::ALL {
            let mut g = solver(integrator, n);
            group.throughput(Throughput::Elements((n * n) as u64));
            group.bench_function(BenchmarkId::new(integrator.as_str(), n * n), |b| {
                b.iter_custom(|iters| submit_and_wait(ctx, &mut g, iters))
            });
        }
    }
    group.finish();
}

/// The median of `samples` calls of `time` (each returning seconds).
pub fn median(samples: usize, mut time: impl FnMut() -> f64) -> f64 {
    median_of((0..samples).map(|_| time()).collect())
}

/// The median of `times` (the upper middle one for an even count).
pub fn median_of(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Median seconds per step of the CPU reference in `f32` (the GPU's
/// arithmetic) over `samples` single steps, after five warm-up steps.
#[allow(dead_code, reason = "cpu_step times f64")]
pub fn cpu_f32_median(model: &Model, params: &Params, samples: usize) -> f64 {
    let mut c = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU solver: {e}"));
    c.step_n(5).unwrap_or_else(|e| panic!("CPU warm-up: {e}"));
    median(samples, || {
        let t = Instant::now();
        c.step().unwrap_or_else(|e| panic!("CPU step: {e}"));
        t.elapsed().as_secs_f64()
    })
}

/// The median of `times` (not empty).
#[allow(dead_code, reason = "the benches that time in turn take medians")]
pub fn middle(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Samples per median of the benches that time solvers in turn.
#[allow(dead_code, reason = "the benches that time in turn take medians")]
pub fn samples() -> usize {
    if quick() {
        3
    } else {
        7
    }
}
