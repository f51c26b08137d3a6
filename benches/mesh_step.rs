//! What the grid specialisation buys: the same cloth as a grid scene and as
//! a mesh, measured in one run.
//!
//! `cargo bench --bench mesh_step` prints, for 65² and 129² cloths and each
//! integrator, the median wall time per step of the grid (the grid kernels
//! on the GPU) and of the same cloth loaded as an OBJ quad mesh (the
//! general adjacency kernels; its springs are the grid's, see
//! `tests/meshes.rs`), on the GPU (a batch of steps, one submit, a wait)
//! and on the CPU reference in `f32`, with the mesh/grid ratios; then
//! criterion times the mesh's GPU step (`iter_custom`: submit plus wait).
//! `WGCLOTH_BENCH_QUICK=1` shortens the run; `WGCLOTH_BENCH_SIZES=65`
//! picks sizes.
//!
//! The material is `benches/gpu_step.rs`'s: the `hanging` scene grown at
//! constant spacing and mass, explicit at dt = 1/1000 s without fix-up,
//! implicit and semi-implicit at dt = 0.02 s, CG tolerance 1e-3. The mesh
//! shares the grid's springs and pins; its masses are lumped by area (the
//! border's particles are lighter than the grid's equal shares).

mod common;

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::mesh::{Mesh, Placement};
use wgcloth::model::Pin;
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn sizes() -> Vec<usize> {
    common::sizes(&[65, 129])
}

/// The grid cloth of size `n` and the same cloth as an OBJ quad mesh
/// (vertices in the grid's order, so the pins are the same indices).
fn grid_and_mesh(integrator: Integrator, n: usize) -> (Model, Model, Params) {
    let mut scene = common::grown_hanging(integrator, n);
    scene.params.implicit.tolerance = 1e-3;
    if integrator == Integrator::Explicit {
        scene.params.fixup.iterations = 0;
    }
    let grid = scene.model().unwrap_or_else(|e| panic!("{n}² grid: {e}"));
    let spec = &scene.cloths[0].spec;
    let mut obj = String::new();
    for p in 0..spec.particle_count() {
        let [x, y, z] = spec.rest_position(p).to_array();
        let _ = writeln!(obj, "v {x:?} {y:?} {z:?}");
    }
    for row in 0..n - 1 {
        for col in 0..n - 1 {
            let a = row * n + col + 1;
            let _ = writeln!(obj, "f {a} {} {} {}", a + n, a + n + 1, a + 1);
        }
    }
    let mesh = Mesh::parse(obj.as_bytes(), Path::new("grid.obj"), None, &|_| {
        Err("no external buffers".to_string())
    })
    .unwrap_or_else(|e| panic!("{n}² mesh: {e}"));
    let pins: Vec<Pin> = grid
        .pinned
        .iter()
        .enumerate()
        .filter(|(_, pinned)| **pinned)
        .map(|(p, _)| Pin::Index(p))
        .collect();
    let placement = Placement {
        scale: 1.0,
        origin: DVec3::ZERO,
    };
    let model = mesh
        .model(placement, spec.mass, &pins, &scene.params.springs)
        .unwrap_or_else(|e| panic!("{n}² mesh model: {e}"));
    (grid, model, scene.params)
}

/// A GPU solver past its warm-up (kernels compiled, CG budget adapted).
fn gpu_solver(ctx: &GpuContext, model: &Model, params: &Params) -> GpuSolver {
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, model, params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    g.step(10).unwrap_or_else(|e| panic!("GPU warm-up: {e}"));
    g
}

/// Seconds per GPU step, median of batches of `batch` steps.
fn gpu_time(ctx: &GpuContext, model: &Model, params: &Params, batch: u32) -> f64 {
    let mut g = gpu_solver(ctx, model, params);
    common::median(if common::quick() { 3 } else { 7 }, || {
        let t = Instant::now();
        g.step(batch).unwrap_or_else(|e| panic!("GPU step: {e}"));
        t.elapsed().as_secs_f64() / f64::from(batch)
    })
}

/// Seconds per CPU `f32` step, median of single steps.
fn cpu_time(model: &Model, params: &Params) -> f64 {
    common::cpu_f32_median(model, params, if common::quick() { 3 } else { 9 })
}

fn table(ctx: &GpuContext) {
    println!(
        "\nGrid against the same cloth as a mesh, median ms per step, one run; GPU: {}",
        ctx.describe()
    );
    println!(
        "{:>6} {:>14} {:>9} {:>9} {:>7} {:>9} {:>9} {:>7}",
        "size", "integrator", "GPU grid", "GPU mesh", "ratio", "CPU grid", "CPU mesh", "ratio"
    );
    for n in sizes() {
        for integrator in Integrator::ALL {
            let (grid, mesh, params) = grid_and_mesh(integrator, n);
            let batch = if integrator == Integrator::Explicit {
                20
            } else {
                2
            };
            let (g_grid, g_mesh) = (
                gpu_time(ctx, &grid, &params, batch),
                gpu_time(ctx, &mesh, &params, batch),
            );
            let (c_grid, c_mesh) = (cpu_time(&grid, &params), cpu_time(&mesh, &params));
            println!(
                "{:>6} {:>14} {:>9.3} {:>9.3} {:>6.2}× {:>9.3} {:>9.3} {:>6.2}×",
                format!("{n}²"),
                integrator.as_str(),
                g_grid * 1e3,
                g_mesh * 1e3,
                g_mesh / g_grid,
                c_grid * 1e3,
                c_mesh * 1e3,
                c_mesh / c_grid
            );
        }
    }
}

fn mesh_step(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    common::gpu_step_group(c, &ctx, "mesh_step", &sizes(), |integrator, n| {
        let (_, mesh, params) = grid_and_mesh(integrator, n);
        gpu_solver(&ctx, &mesh, &params)
    });
}

criterion_group!(benches, mesh_step);

fn main() {
    match GpuContext::new(None) {
        Ok(ctx) => table(&ctx),
        Err(e) => panic!("the mesh benchmark needs an adapter: {e}"),
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
