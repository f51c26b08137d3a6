//! What a render mesh costs beside the step it follows: the `skin` pass
//! (with the normals pass it reads) against one step of the cloth, in one
//! run on one device.
//!
//! `cargo bench --bench skin` prints, for the `hanging` scene grown to 33²
//! (implicit, dt = 0.02 s, CG tolerance 1e-3) and a render mesh of about
//! 50 000 vertices over its rest rectangle (a 224 × 224 grid, a
//! millimetre above the cloth), the median wall time of a step (one
//! submit, a wait) and of the normals and skin passes (one submit, a
//! wait), and their ratio. `WGCLOTH_BENCH_QUICK=1` takes fewer samples.

mod common;

use std::path::Path;
use std::time::Instant;

use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuRenderMesh, GpuSolver, SkinLayout};
use wgcloth::mesh::Mesh;
use wgcloth::params::Integrator;
use wgcloth::render_mesh::{Embedding, RenderMesh};

/// Render vertices along each side of the render mesh: 224² = 50 176.
const SIDE: usize = 224;

fn main() {
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("no GPU: {e}"));
    let scene = common::grown_hanging(Integrator::Implicit, 33);
    let mut scene = scene;
    scene.params.implicit.tolerance = 1e-3;
    let model = scene.model().unwrap_or_else(|e| panic!("model: {e}"));
    let spec = &scene.cloths[0].spec;
    let (nx, ny) = (spec.nx, spec.ny);
    let x = &model.rest_positions;
    let [c00, c10, c01] = [x[0], x[nx - 1], x[(ny - 1) * nx]];
    let normal = (c10 - c00).cross(c01 - c00).normalize();
    let mut positions = Vec::with_capacity(SIDE * SIDE);
    for j in 0..SIDE {
        for i in 0..SIDE {
            let (s, t) = (i as f64 / (SIDE - 1) as f64, j as f64 / (SIDE - 1) as f64);
            positions.push(c00 + (c10 - c00) * s + (c01 - c00) * t + normal * 0.001);
        }
    }
    let mut triangles = Vec::new();
    for j in 0..SIDE - 1 {
        for i in 0..SIDE - 1 {
            let a = (j * SIDE + i) as u32;
            let (b, c, d) = (a + 1, a + SIDE as u32, a + SIDE as u32 + 1);
            triangles.extend([[a, c, b], [b, c, d]]);
        }
    }
    let mesh = Mesh::from_triangles("bench render mesh", positions, &triangles)
        .unwrap_or_else(|e| panic!("mesh: {e}"));
    let render = RenderMesh::from_mesh(Path::new("bench"), &mesh, 1.0, DVec3::ZERO);
    let embedding = Embedding::new(&model, &render, 0.01).unwrap_or_else(|e| panic!("{e}"));
    let mut solver = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &scene.params)
        .unwrap_or_else(|e| panic!("solver: {e}"));
    let skin = GpuRenderMesh::new(&solver, &embedding, SkinLayout::POSITION_NORMAL)
        .unwrap_or_else(|e| panic!("render mesh: {e}"));
    let samples = if common::quick() { 9 } else { 31 };
    // Warm up: pipelines, the CG budget.
    solver.step(10).unwrap_or_else(|e| panic!("steps: {e}"));
    let step = common::median(samples, || {
        common::submit_and_wait(&ctx, &mut solver, 1).as_secs_f64()
    });
    let pass = common::median(samples, || {
        let t = Instant::now();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        solver.encode_normals(&mut encoder);
        skin.encode(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        if let Err(e) = ctx.device.poll(wgpu::PollType::wait_indefinitely()) {
            panic!("poll: {e}");
        }
        t.elapsed().as_secs_f64()
    });
    println!("device: {}", ctx.describe());
    println!(
        "33² implicit step {:.3} ms; normals + skin of {} render vertices {:.3} ms; ratio {:.2}",
        step * 1e3,
        embedding.vertex_count(),
        pass * 1e3,
        pass / step
    );
}
