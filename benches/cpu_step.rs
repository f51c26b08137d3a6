//! CPU step time per integrator and cloth size, and a table of steps per
//! second beside the figures of the article the project grew from.
//!
//! `cargo bench --bench cpu_step` runs criterion over the article's sizes
//! (15², 25², 33²) and 65², 129², 257² for each integrator on the `hanging`
//! scene grown to each resolution at constant particle spacing and particle
//! mass (so every size has the same local dynamics and stays stable at the
//! same dt), at the scene's dt (1/1000 s) for the explicit integrator and
//! the article's 0.02 s for the other two. It also times the two ways of
//! applying the semi-implicit filter, to locate their crossover. Set
//! `WGCLOTH_BENCH_QUICK=1` for a short run.

use std::hint::black_box;
use std::time::{Duration, Instant};

mod common;

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use wgcloth::cpu::CpuSolver;
use wgcloth::params::{FilterMethod, Integrator};

/// Sizes benchmarked (particles per side).
const SIZES: [usize; 6] = [15, 25, 33, 65, 129, 257];

/// The article's frame rates (Pentium III 600 MHz, dt = 0.02 s, rendering
/// included), by size and integrator (explicit, implicit, semi-implicit).
const ARTICLE_FPS: [(usize, [f64; 3]); 3] = [
    (15, [142.0, 28.0, 90.0]),
    (25, [52.0, 6.0, 19.0]),
    (33, [30.0, 2.0, 7.0]),
];

fn solver(integrator: Integrator, n: usize, filter: FilterMethod) -> CpuSolver<f64> {
    solver_with(integrator, n, filter, None)
}

fn solver_with(
    integrator: Integrator,
    n: usize,
    filter: FilterMethod,
    cg_tolerance: Option<f64>,
) -> CpuSolver<f64> {
    let mut scene = common::grown_hanging(integrator, n);
    scene.params.semi_implicit.filter = filter;
    if let Some(tol) = cg_tolerance {
        scene.params.implicit.tolerance = tol;
    }
    let model = match scene.model() {
        Ok(m) => m,
        Err(e) => panic!("hanging at {n}²: {e}"),
    };
    let mut s = match CpuSolver::new(&model, &scene.params) {
        Ok(s) => s,
        Err(e) => panic!("hanging at {n}²: {e}"),
    };
    // Start from a moving, deformed cloth, not the flat rest state where
    // CG converges trivially.
    if let Err(e) = s.step_n(10) {
        panic!("hanging at {n}² {integrator}: {e}");
    }
    s
}

fn step_time(c: &mut Criterion) {
    let mut group = c.benchmark_group("cpu_step");
    group.sample_size(if common::quick() { 10 } else { 20 });
    group.measurement_time(Duration::from_secs(if common::quick() { 1 } else { 3 }));
    for integrator in Integrator::ALL {
        for n in SIZES {
            let mut s = solver(integrator, n, FilterMethod::Auto);
            group.throughput(Throughput::Elements((n * n) as u64));
            group.bench_function(BenchmarkId::new(integrator.as_str(), n * n), |b| {
                b.iter(|| black_box(s.step()))
            });
        }
    }
    group.finish();
}

/// Median seconds per step over `samples` timed batches.
fn median_step(s: &mut CpuSolver<f64>, samples: usize) -> f64 {
    common::median(samples, || {
        let t = Instant::now();
        let _ = black_box(s.step());
        t.elapsed().as_secs_f64()
    })
}

fn article_table() {
    println!("\nCPU steps per second (median), hanging scene material, f64, one thread");
    println!(
        "{:>6} {:>14} {:>10} {:>10} {:>8}",
        "size", "integrator", "steps/s", "article", "ratio"
    );
    for (n, fps) in ARTICLE_FPS {
        for (k, integrator) in Integrator::ALL.into_iter().enumerate() {
            let mut s = solver(integrator, n, FilterMethod::Auto);
            let rate = 1.0 / median_step(&mut s, if common::quick() { 15 } else { 101 });
            println!(
                "{:>6} {:>14} {:>10.0} {:>10.0} {:>7.0}×",
                format!("{n}²"),
                integrator.as_str(),
                rate,
                fps[k],
                rate / fps[k]
            );
        }
    }
}

/// Sizes at which both semi-implicit filters are timed (the dense one needs
/// `N²` memory: 65² is 143 MB in f64, the last size tried).
const FILTER_SIZES: [usize; 5] = [15, 25, 33, 45, 65];

fn filter_crossover(c: &mut Criterion) {
    let mut group = c.benchmark_group("semi_implicit_filter");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(if common::quick() { 1 } else { 2 }));
    for n in FILTER_SIZES {
        for filter in [FilterMethod::Dense, FilterMethod::Banded] {
            let mut s = solver(Integrator::SemiImplicit, n, filter);
            group.bench_function(BenchmarkId::new(filter.as_str(), n * n), |b| {
                b.iter(|| black_box(s.step()))
            });
        }
    }
    group.finish();
}

/// The yardstick: a 128² implicit step at CG tolerance 1e-3 should
/// take at most 2 × 32 ms on one core of this machine.
fn implicit_yardstick() {
    let mut s = solver_with(Integrator::Implicit, 128, FilterMethod::Auto, Some(1e-3));
    let seconds = median_step(&mut s, if common::quick() { 9 } else { 31 });
    println!(
        "\n128² implicit, CG tolerance 1e-3, dt 0.02 s: median {:.1} ms per step ({} CG iterations in the last step; target ≤ 64 ms)",
        seconds * 1e3,
        s.last_stats().cg_iterations
    );
}

criterion_group!(benches, step_time, filter_crossover);

fn main() {
    article_table();
    implicit_yardstick();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
