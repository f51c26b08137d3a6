//! The solver on a device created with `wgpu::Limits::default()` — what
//! WebGPU guarantees every device, and what a host that asks for nothing
//! more gets — runs every integrator on both step paths and in a
//! `GpuBatch`, and gives the `f32` CPU mirror's bits (the banded filter,
//! which the GPU solves by CG, within a tolerance). GPU tests on
//! lavapipe in CI, whose adapter grants more: the device here is asked for
//! the defaults only, so wgpu refuses any binding or workgroup beyond them.

mod gpu_common;

use gpu_common::agreement::{self, Policy};

use gpu_common::{bounded_steps, busy_params, corners, gpu, grid, scene_bound, worst};
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::Vec3;
use wgcloth::gpu::{GpuBatch, GpuKernels, GpuSolver, GpuState, StepPath};
use wgcloth::params::{FilterMethod, Integrator};
use wgcloth::{Model, Params};

/// Steps of each comparison: enough for every phase of a step (fix-up,
/// CG, the filter, the colliders' contacts) to have moved something in the
/// busy parameters' falling cloth, few enough for lavapipe.
const STEPS: u32 = 8;

/// A device on the test adapter with exactly WebGPU's default limits.
fn default_device() -> (wgpu::Device, wgpu::Queue) {
    let ctx = gpu();
    pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("wgcloth.default_limits"),
        required_limits: wgpu::Limits::default(),
        ..Default::default()
    }))
    .expect("a device with the default limits")
}

/// One case: a name, the model and its parameters.
struct Case {
    name: &'static str,
    model: Model,
    params: Params,
}

/// Every integrator, the semi-implicit one with both filters, on a 10 × 9
/// cloth (90 particles: two reduction blocks, the second partial).
fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for (name, integrator, filter) in [
        ("explicit", Integrator::Explicit, FilterMethod::Auto),
        ("implicit", Integrator::Implicit, FilterMethod::Auto),
        (
            "semi-implicit, dense filter",
            Integrator::SemiImplicit,
            FilterMethod::Dense,
        ),
        (
            "semi-implicit, banded filter (CG)",
            Integrator::SemiImplicit,
            FilterMethod::Banded,
        ),
    ] {
        let mut params = busy_params(integrator);
        params.semi_implicit.filter = filter;
        cases.push(Case {
            name,
            model: grid(10, 9, corners(), &params),
            params,
        });
    }
    cases
}

/// The `f32` mirror's state after [`STEPS`] steps of `case`.
fn mirror(case: &Case) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut c = CpuSolver::<f32>::new(&case.model, &case.params)
        .unwrap_or_else(|e| panic!("{}: CPU solver: {e}", case.name));
    c.step_n(u64::from(STEPS))
        .unwrap_or_else(|e| panic!("{}: CPU run: {e}", case.name));
    (c.positions(), c.velocities())
}

/// How far the banded filter's cloth may be from the mirror after
/// [`STEPS`] steps \[m\]: the GPU solves that filter by CG (to relative
/// 1e-5) where the CPU applies the exact banded factor, so the two differ
/// by up to 1e-6 m a step (see `tests/gpu_semi_implicit.rs`); eight steps,
/// 1e-5 m. Every other case is compared bit for bit.
const CG_FILTER_TOL: f64 = 1e-5;

/// `got` is the mirror's state bit for bit, or within [`CG_FILTER_TOL`]
/// for the banded filter's `case`; on failure names the worst particle.
fn check(what: &str, case: &Case, got: &GpuState, want: &(Vec<Vec3>, Vec<Vec3>)) {
    if case.params.semi_implicit.filter == FilterMethod::Banded {
        let (dx, px) = worst(&got.x, &want.0);
        assert!(
            dx < CG_FILTER_TOL,
            "{what}: position off by {dx:e} m at particle {px}"
        );
    } else {
        assert_mirrors(what, got, want);
    }
}

/// `got` is the mirror's state bit for bit; on failure names the worst
/// particle.
fn assert_mirrors(what: &str, got: &GpuState, want: &(Vec<Vec3>, Vec<Vec3>)) {
    let same = |a: &[Vec3], b: &[Vec3]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
    };
    let (dx, px) = worst(&got.x, &want.0);
    let (dv, pv) = worst(&got.v, &want.1);
    assert!(
        same(&got.x, &want.0) && same(&got.v, &want.1),
        "{what}: not the f32 mirror's bits: position off by {dx:e} m at particle {px}, \
         velocity by {dv:e} m/s at particle {pv}"
    );
}

/// Every case on each step path that steps it, on a default-limits device.
#[test]
fn every_integrator_runs_on_both_paths_within_webgpu_default_limits() {
    let (device, queue) = default_device();
    let kernels = GpuKernels::new(&device);
    let mut ran = 0;
    for case in cases() {
        let want = mirror(&case);
        for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
            let built =
                GpuSolver::with_step_path(&kernels, &queue, &case.model, &case.params, path);
            let mut g = match built {
                Ok(g) => g,
                // The CG filter has no workgroup kernel (the solver says
                // so; any other refusal fails).
                Err(e)
                    if path == StepPath::Workgroup
                        && case.params.semi_implicit.filter == FilterMethod::Banded =>
                {
                    assert!(
                        e.to_string().contains("multi-dispatch"),
                        "{}: {e}",
                        case.name
                    );
                    continue;
                }
                Err(e) => panic!("{} on the {path} path: {e}", case.name),
            };
            g.tuning_mut().set_adaptive_cg_budget(false);
            let what = format!("{} on the {path} path", case.name);
            // Each step against the mirror re-seeded with the GPU's state
            // where the adapter rounds apart from the mirror.
            let bounded = (case.params.semi_implicit.filter != FilterMethod::Banded)
                .then(|| bounded_steps(&what, || &mut g, &case.model, &case.params, STEPS))
                .flatten();
            if let Some(verdict) = bounded {
                verdict.unwrap_or_else(|e| panic!("{e}"));
                ran += 1;
                continue;
            }
            g.step(STEPS)
                .unwrap_or_else(|e| panic!("{} on the {path} path: {e}", case.name));
            let got = g
                .read_state()
                .unwrap_or_else(|e| panic!("{}: read-back: {e}", case.name));
            check(
                &format!("{} on the {path} path", case.name),
                &case,
                &got,
                &want,
            );
            ran += 1;
        }
    }
    // Seven solvers: four cases on the multi-dispatch path, three on the
    // workgroup path.
    assert_eq!(ran, 7);
}

/// Every case in one `GpuBatch` on a default-limits device: the table
/// cloths share the workgroup kernels' dispatches, the banded filter's
/// cloth keeps a solver of its own.
#[test]
fn a_batch_of_every_integrator_runs_within_webgpu_default_limits() {
    let (device, queue) = default_device();
    let mut batch = GpuBatch::new(&device, &queue);
    let cases = cases();
    let ids: Vec<_> = cases
        .iter()
        .map(|c| {
            batch
                .add(&c.model, &c.params)
                .unwrap_or_else(|e| panic!("{}: adding to the batch: {e}", c.name))
        })
        .collect();
    if agreement::policy() == Policy::Bounded {
        // Each cloth's steps against the mirror re-seeded before each
        // (stepping the batch steps the others too).
        for (case, id) in cases.iter().zip(ids) {
            let what = format!("{} in a batch", case.name);
            let mut cloth = agreement::BatchCloth { batch, id };
            let mut c = CpuSolver::<f32>::new(&case.model, &case.params)
                .unwrap_or_else(|e| panic!("{what}: CPU solver: {e}"));
            let bound = scene_bound(&case.model, &case.params);
            agreement::check_reseeded(&what, &mut cloth, &mut c, STEPS, &bound)
                .unwrap_or_else(|e| panic!("{e}"));
            batch = cloth.batch;
        }
        return;
    }
    batch
        .step(STEPS)
        .unwrap_or_else(|e| panic!("the batch: {e}"));
    for (case, id) in cases.iter().zip(ids) {
        let got = batch
            .read_state(id)
            .unwrap_or_else(|e| panic!("{}: read-back: {e}", case.name));
        check(
            &format!("{} in a batch", case.name),
            case,
            &got,
            &mirror(case),
        );
    }
}
