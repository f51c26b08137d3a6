//! The async forms of the operations that wait on the device (what a
//! browser's event loop awaits: `GpuContext::new_async`,
//! `GpuSolver::new_async`, `step_async`, `check_async`,
//! `read_state_async`, the divergence check's, `read_buffers_async`, and
//! `GpuBatch`'s), driven natively on lavapipe
//! by `pollster::block_on`: they give the blocking forms' bits, and a
//! device error they capture is an `Err`, never a panic.

mod gpu_common;

use gpu_common::{busy_params, corners, gpu, grid};
use pollster::block_on;
use wgcloth::diagnostics::Divergence;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::gpu::readback::read_buffers_async;
use wgcloth::gpu::{GpuBatch, GpuContext, GpuSolver};
use wgcloth::params::Integrator;
use wgcloth::Error;

/// Steps of each run: enough for the fix-up, CG and the filter to move the
/// busy parameters' falling cloth, few enough for lavapipe.
const STEPS: u32 = 6;

/// The bits of each vector, so that equality is bit for bit.
fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// Every integrator: a solver built, stepped and read back through the
/// async forms holds the same bits as one through the blocking forms, and
/// both report the same step count.
#[test]
fn the_async_forms_give_the_blocking_forms_bits() {
    let ctx = gpu();
    for integrator in [
        Integrator::Explicit,
        Integrator::Implicit,
        Integrator::SemiImplicit,
    ] {
        let params = busy_params(integrator);
        let model = grid(10, 9, corners(), &params);

        let mut blocking = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params)
            .unwrap_or_else(|e| panic!("{integrator}: blocking solver: {e}"));
        let blocking_stats = blocking
            .step(STEPS)
            .unwrap_or_else(|e| panic!("{integrator}: blocking step: {e}"));
        let want = blocking
            .read_state()
            .unwrap_or_else(|e| panic!("{integrator}: blocking read-back: {e}"));

        let (async_stats, got) = block_on(async {
            let mut solver = GpuSolver::new_async(&ctx.device, &ctx.queue, &model, &params).await?;
            // Half through step_async, half recorded and then checked.
            let half = STEPS / 2;
            solver.step_async(half).await?;
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            solver.encode_steps(&mut encoder, STEPS - half);
            ctx.queue.submit([encoder.finish()]);
            let stats = solver.check_async().await?;
            Ok::<_, Error>((stats, solver.read_state_async().await?))
        })
        .unwrap_or_else(|e| panic!("{integrator}: async forms: {e}"));

        assert_eq!(async_stats.steps, blocking_stats.steps, "{integrator}");
        assert!(
            bits(&got.x) == bits(&want.x) && bits(&got.v) == bits(&want.v),
            "{integrator}: the async forms' state differs from the blocking forms' \
             (particle 0 at {:?} vs {:?} m)",
            got.x[0],
            want.x[0]
        );
        // The cloth moved: equal bits are not two untouched initial states.
        assert!(
            got.x
                .iter()
                .zip(&model.rest_positions)
                .any(|(g, p)| *g != p.as_vec3()),
            "{integrator}: no particle moved in {STEPS} steps"
        );
    }
}

/// `GpuContext::new_async` opens the adapter the blocking form opens, and
/// a solver runs on its device.
#[test]
fn the_async_context_opens_the_same_adapter() {
    let blocking = gpu();
    let ctx = block_on(GpuContext::new_async(None)).expect("async context");
    assert_eq!(ctx.adapter.get_info(), blocking.adapter.get_info());
    let params = busy_params(Integrator::Explicit);
    let model = grid(4, 4, corners(), &params);
    let mut solver = block_on(GpuSolver::with_kernels_async(
        ctx.kernels(),
        &ctx.queue,
        &model,
        &params,
    ))
    .expect("a solver on the async context's device");
    block_on(solver.step_async(2)).expect("two steps");
    ctx.check().expect("no uncaptured device error");
}

/// A read-back the device refuses (the buffer cannot be copied from) is an
/// `Error::Gpu` naming the read-back, captured by the async form's error
/// scopes rather than reaching the device's handler.
#[test]
fn an_async_read_back_the_device_refuses_is_an_error() {
    let ctx = GpuContext::new(None).expect("a context of its own");
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("not copyable"),
        size: 16,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let result = block_on(read_buffers_async(
        &ctx.device,
        &ctx.queue,
        &[(&buffer, 0, 16)],
    ));
    match result {
        Err(Error::Gpu(message)) => assert!(
            message.starts_with("a read-back"),
            "the error names what was done: {message}"
        ),
        other => panic!("expected Error::Gpu, got {other:?}"),
    }
    ctx.check()
        .expect("the scopes caught it: nothing reached the handler");
}

/// The divergence rule taken and applied through the async forms judges
/// the same state as through the blocking forms, and passes it.
#[test]
fn the_async_divergence_check_judges_the_same_state() {
    let ctx = gpu();
    let params = busy_params(Integrator::Implicit);
    let model = grid(8, 8, corners(), &params);
    let mut solver =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params).expect("solver");
    let rule = solver.divergence_rule().expect("blocking rule");
    let rule_async = block_on(solver.divergence_rule_async()).expect("async rule");
    solver.step(STEPS).expect("steps");
    let judged = solver.check_divergence(&rule).expect("blocking check");
    let judged_async = block_on(solver.check_divergence_async(&rule_async)).expect("async check");
    assert!(
        bits(&judged.x) == bits(&judged_async.x) && bits(&judged.v) == bits(&judged_async.v),
        "the async check judged another state"
    );
}

/// A `GpuBatch` of two cloths (explicit and implicit) added, stepped,
/// checked and read back through the async forms holds the blocking
/// forms' bits, and its divergence check judges the same state.
#[test]
fn the_async_batch_forms_give_the_blocking_forms_bits() {
    let ctx = gpu();
    let cloths: Vec<_> = [Integrator::Explicit, Integrator::Implicit]
        .into_iter()
        .map(|integrator| {
            let params = busy_params(integrator);
            (grid(6, 5, corners(), &params), params)
        })
        .collect();

    let mut blocking = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let ids: Vec<_> = cloths
        .iter()
        .map(|(model, params)| blocking.add(model, params).expect("blocking add"))
        .collect();
    blocking.step(STEPS).expect("blocking steps");
    let want: Vec<_> = ids
        .iter()
        .map(|&id| blocking.read_state(id).expect("blocking read-back"))
        .collect();

    let got = block_on(async {
        let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
        let mut ids = Vec::new();
        for (model, params) in &cloths {
            ids.push(batch.add_async(model, params).await?);
        }
        batch.step_async(STEPS).await?;
        batch.check_async().await?;
        let mut states = Vec::new();
        for (&id, (model, params)) in ids.iter().zip(&cloths) {
            // The rule from the cloth's start: at rest where it was made.
            let still = vec![DVec3::ZERO; model.rest_positions.len()];
            let rule = Divergence::new(model, params, 0.0, &model.rest_positions, &still);
            let judged = batch.check_divergence_async(id, &rule).await?;
            let read = batch.read_state_async(id).await?;
            assert!(
                bits(&judged.x) == bits(&read.x),
                "the check judged another state"
            );
            states.push(read);
        }
        Ok::<_, Error>(states)
    })
    .unwrap_or_else(|e| panic!("async batch forms: {e}"));

    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!(
            bits(&g.x) == bits(&w.x) && bits(&g.v) == bits(&w.v),
            "cloth {i}: the async forms' state differs from the blocking forms'"
        );
    }
}
