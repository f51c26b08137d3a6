//! What a world costs: two cloths stepped as one world against the same
//! two stepped apart, on the GPU and on the CPU reference in `f32`, as
//! ratios measured in one run.
//!
//! `cargo bench --bench world_step` prints, for two `hanging` cloths
//! grown to 65² (`benches/common`; `WGCLOTH_BENCH_SIZES` picks others)
//! hung side by side a metre apart (nothing of one comes near the other),
//! the median wall time per step of
//! - the two cloths apart: two solvers, their steps recorded into one
//!   encoder and submitted once on the GPU, one after the other on the CPU;
//! - the world of the two (`world::join`): one solver;
//!
//! each without and with `[self_collision]` (apart, each cloth keeps off
//! its own folds; in the world, off the other cloth's too), and the
//! world's time over the two apart. The solvers of a row are timed in
//! turn, sample by sample, so that a load on the machine hits each alike.
//! `WGCLOTH_BENCH_QUICK=1` shortens the run.

mod common;

use std::time::Instant;

use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::params::{Integrator, SelfCollision};
use wgcloth::{world, Model, Params};

/// Steps before timing.
const WARM_UP: u32 = 4;

/// How far apart the two cloths hang \[m\]: a metre between their facing
/// edges, far beyond any thickness.
const GAP: f64 = 1.0;

/// The two cloths of `n²` for `integrator`, side by side along x, with the
/// parameters they share.
fn cloths(integrator: Integrator, n: usize) -> ([Model; 2], Params) {
    let scene = common::grown_hanging(integrator, n);
    let width = scene.cloths[0].spec.size[0];
    let model = |shift: f64| {
        let mut spec = scene.cloths[0].spec.clone();
        spec.origin += DVec3::X * shift;
        Model::new(&spec, &scene.params.springs).unwrap_or_else(|e| panic!("cloth: {e}"))
    };
    let half = (width + GAP) / 2.0;
    ([model(-half), model(half)], scene.params)
}

/// The world of `cloths`, no seams.
fn joined(cloths: &[Model; 2], params: &Params) -> Model {
    let parts = cloths.iter().map(|m| (m.clone(), params.springs)).collect();
    world::join(parts, &params.springs, &[]).unwrap_or_else(|e| panic!("world: {e}"))
}

/// Seconds per step of each group of GPU solvers, every group's `batch`
/// steps recorded into one encoder and submitted once; medians of samples
/// taken group by group in turn.
fn gpu_times(ctx: &GpuContext, groups: &mut [Vec<GpuSolver>], batch: u32) -> Vec<f64> {
    let mut times = vec![Vec::new(); groups.len()];
    for _ in 0..common::samples() {
        for (group, t) in groups.iter_mut().zip(&mut times) {
            let start = Instant::now();
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            for g in group.iter_mut() {
                g.encode_steps(&mut encoder, batch);
            }
            ctx.queue.submit([encoder.finish()]);
            if let Err(e) = ctx.device.poll(wgpu::PollType::wait_indefinitely()) {
                panic!("poll: {e}");
            }
            t.push(start.elapsed().as_secs_f64() / f64::from(batch));
        }
    }
    times.into_iter().map(common::middle).collect()
}

/// Seconds per step of each group of CPU `f32` solvers (a group's solvers
/// stepped one after the other), medians of single steps taken in turn.
fn cpu_times(groups: &mut [Vec<CpuSolver<f32>>]) -> Vec<f64> {
    let mut times = vec![Vec::new(); groups.len()];
    for _ in 0..common::samples() {
        for (group, t) in groups.iter_mut().zip(&mut times) {
            let start = Instant::now();
            for c in group.iter_mut() {
                c.step().unwrap_or_else(|e| panic!("CPU step: {e}"));
            }
            t.push(start.elapsed().as_secs_f64());
        }
    }
    times.into_iter().map(common::middle).collect()
}

/// The solvers of a row: the two cloths apart, then their world, under
/// `params`.
fn models(cloths: &[Model; 2], params: &Params) -> [Vec<Model>; 2] {
    [cloths.to_vec(), vec![joined(cloths, params)]]
}

fn main() {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "\nTwo cloths as one world against the two apart, median ms per step, one run; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>26} {:>9} {:>9} {:>7} {:>9} {:>9} {:>7}",
        "scene", "GPU apart", "GPU world", "ratio", "CPU apart", "CPU world", "ratio"
    );
    for n in common::sizes(&[65]) {
        for integrator in [Integrator::Explicit, Integrator::Implicit] {
            let (cloths, plain) = cloths(integrator, n);
            let contact = Params {
                self_collision: Some(SelfCollision::default()),
                ..plain.clone()
            };
            for (what, params) in [("", plain), (" contact", contact)] {
                let rows = models(&cloths, &params);
                let mut gpu: Vec<Vec<GpuSolver>> = rows
                    .iter()
                    .map(|ms| {
                        ms.iter()
                            .map(|m| {
                                let mut g =
                                    GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, m, &params)
                                        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
                                g.step(WARM_UP)
                                    .unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
                                g
                            })
                            .collect()
                    })
                    .collect();
                let mut cpu: Vec<Vec<CpuSolver<f32>>> = rows
                    .iter()
                    .map(|ms| {
                        ms.iter()
                            .map(|m| {
                                let mut c = CpuSolver::<f32>::new(m, &params)
                                    .unwrap_or_else(|e| panic!("CPU solver: {e}"));
                                c.step_n(u64::from(WARM_UP))
                                    .unwrap_or_else(|e| panic!("CPU warm-up: {e}"));
                                c
                            })
                            .collect()
                    })
                    .collect();
                let batch = if integrator == Integrator::Explicit {
                    20
                } else {
                    2
                };
                let g = gpu_times(&ctx, &mut gpu, batch);
                let c = cpu_times(&mut cpu);
                println!(
                    "{:>26} {:>9.3} {:>9.3} {:>6.2}× {:>9.3} {:>9.3} {:>6.2}×",
                    format!("2 × {n}² {}{what}", integrator.as_str()),
                    g[0] * 1e3,
                    g[1] * 1e3,
                    g[1] / g[0],
                    c[0] * 1e3,
                    c[1] * 1e3,
                    c[1] / c[0]
                );
            }
        }
    }
}
