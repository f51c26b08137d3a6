//! Mesh colliders: the bake's time against the mesh's size and the grid's
//! resolution, and a step's cost with a mesh collider against the same
//! step with a capsule, on the CPU reference in `f32` and the GPU, in one
//! run.
//!
//! `cargo bench --bench mesh_collider` prints two tables: the median bake
//! time of UV spheres of 128 to 8 192 triangles at 32, 64 and 128 cells
//! across; then, for the `drape` cloth (33 × 33, implicit) falling onto a
//! ball of radius 0.35 m — a capsule without length, or the baked 4 096
//! triangle sphere (64 cells across) — the median time per step of each on
//! the CPU in `f32` and on the GPU (a run of steps in one submit), and
//! their ratios. Then criterion times one bake and one GPU step with each
//! collider. `WGCLOTH_BENCH_QUICK=1` shortens the run; the adapter is the
//! default one (`WGPU_ADAPTER_NAME` picks another).

#[path = "../tests/common/closed_meshes.rs"]
mod closed_meshes;
mod common;

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, Criterion};
use wgcloth::glam::{DQuat, DVec3};
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::mesh::Mesh;
use wgcloth::params::Capsule;
use wgcloth::sdf::{bake, DistanceGrid, MeshCollider};
use wgcloth::{Model, Params, Scene};

/// The ball's radius and centre in the `drape` scene \[m\].
const RADIUS: f64 = 0.35;

/// A UV sphere of `rings` × 2 `rings` (4 `rings`² triangles less the
/// poles' halves), unit radius.
fn sphere(rings: usize) -> Mesh {
    let text = closed_meshes::uv_sphere(rings, 2 * rings);
    Mesh::parse(text.as_bytes(), Path::new("sphere.obj"), None, &|_| {
        Err("none".into())
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

fn baked(mesh: &Mesh, resolution: u32) -> DistanceGrid {
    bake(
        mesh,
        Path::new("sphere.obj"),
        "collider[0]",
        RADIUS,
        resolution,
        0.005,
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn bake_table() {
    let samples = if common::quick() { 3 } else { 7 };
    println!("\nbake: median ms (lattice points), one core");
    println!(
        "{:>10} {:>22} {:>22} {:>22}",
        "triangles", "32 cells", "64 cells", "128 cells"
    );
    for rings in [8, 16, 32, 64] {
        let mesh = sphere(rings);
        let triangles: usize = mesh.faces.iter().map(|f| f.triangles().count()).sum();
        let cells = [32, 64, 128].map(|r| {
            let mut points = 0;
            let t = common::median(samples, || {
                let t = Instant::now();
                points = baked(&mesh, r).samples.len();
                t.elapsed().as_secs_f64()
            });
            format!("{:.1} ({points})", t * 1e3)
        });
        println!(
            "{triangles:>10} {:>22} {:>22} {:>22}",
            cells[0], cells[1], cells[2]
        );
    }
}

/// The `drape` scene with its ball as a capsule of no length, or as the
/// baked sphere.
fn drape(mesh: Option<&Arc<DistanceGrid>>) -> (Model, Params) {
    let scene = Scene::builtin("drape").unwrap_or_else(|e| panic!("{e}"));
    let model = scene.model().unwrap_or_else(|e| panic!("{e}"));
    let mut params = scene.params;
    let ball = params.spheres.remove(0);
    match mesh {
        None => params.capsules.push(Capsule {
            a: ball.center,
            b: ball.center,
            radius: ball.radius,
            friction: ball.friction,
            velocity: DVec3::ZERO,
        }),
        Some(grid) => params.mesh_colliders.push(MeshCollider {
            path: "sphere.obj".into(),
            grid: grid.clone(),
            position: ball.center,
            rotation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            friction: ball.friction,
            thickness: 0.0,
        }),
    }
    (model, params)
}

/// Steps per timed GPU submit, and steps before timing (the cloth reaches
/// the ball after about 40 steps of 1/120 s).
const STEPS_PER_SUBMIT: u64 = 20;
const WARM_STEPS: u64 = 60;

fn gpu_solver(ctx: &GpuContext, model: &Model, params: &Params) -> GpuSolver {
    let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, model, params)
        .unwrap_or_else(|e| panic!("{e}"));
    g.step(WARM_STEPS as u32).unwrap_or_else(|e| panic!("{e}"));
    g
}

fn step_table(ctx: &GpuContext, grid: &Arc<DistanceGrid>) {
    let samples = if common::quick() { 5 } else { 15 };
    println!(
        "\na step of `drape` (33 × 33, implicit) on a ball, median ms; GPU: {}",
        ctx.describe()
    );
    println!("{:>14} {:>10} {:>10}", "collider", "CPU f32", "GPU");
    let mut rows = Vec::new();
    for (name, mesh) in [("capsule", None), ("mesh (64)", Some(grid))] {
        let (model, params) = drape(mesh);
        let mut c =
            wgcloth::CpuSolver::<f32>::new(&model, &params).unwrap_or_else(|e| panic!("{e}"));
        c.step_n(WARM_STEPS).unwrap_or_else(|e| panic!("{e}"));
        let cpu = common::median(samples * 4, || {
            let t = Instant::now();
            c.step().unwrap_or_else(|e| panic!("{e}"));
            t.elapsed().as_secs_f64()
        });
        let mut g = gpu_solver(ctx, &model, &params);
        let gpu = common::median(samples, || {
            common::submit_and_wait(ctx, &mut g, STEPS_PER_SUBMIT).as_secs_f64()
                / STEPS_PER_SUBMIT as f64
        });
        println!("{name:>14} {:>10.3} {:>10.3}", cpu * 1e3, gpu * 1e3);
        rows.push((cpu, gpu));
    }
    println!(
        "{:>14} {:>9.2}× {:>9.2}×",
        "mesh/capsule",
        rows[1].0 / rows[0].0,
        rows[1].1 / rows[0].1
    );
}

fn mesh_collider(c: &mut Criterion) {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
    let mesh = sphere(32);
    let mut group = c.benchmark_group("mesh_collider");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(if common::quick() { 1 } else { 3 }));
    group.bench_function("bake 4096 triangles, 64 cells", |b| {
        b.iter(|| baked(&mesh, 64))
    });
    let grid = Arc::new(baked(&mesh, 64));
    for (name, m) in [("gpu step, capsule", None), ("gpu step, mesh", Some(&grid))] {
        let (model, params) = drape(m);
        let mut g = gpu_solver(&ctx, &model, &params);
        group.bench_function(name, |b| {
            b.iter_custom(|steps| common::submit_and_wait(&ctx, &mut g, steps))
        });
    }
    group.finish();
}

criterion_group!(benches, mesh_collider);

fn main() {
    bake_table();
    let grid = Arc::new(baked(&sphere(32), 64));
    match GpuContext::new(None) {
        Ok(ctx) => step_table(&ctx, &grid),
        Err(e) => panic!("the mesh collider benchmark needs an adapter: {e}"),
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
