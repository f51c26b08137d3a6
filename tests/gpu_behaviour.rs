//! GPU solver behaviour: determinism, pins and contacts, runtime changes,
//! device limits, blow-ups, normals, shared kernels and the pipeline
//! cache. On lavapipe in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::gpu::{
    pipeline_cache, GpuContext, GpuKernels, GpuSolver, GpuState, GridBlock, Kernel, StepPath,
    Variant,
};
use wgcloth::kernel_config::CG_BLOCK;
use wgcloth::model::{ClothSpec, Pin};
use wgcloth::params::Integrator;
use wgcloth::{Error, Model, Params};

fn model(pins: Vec<Pin>, p: &Params) -> Model {
    grid(13, 11, pins, p)
}

/// `steps` steps on the multi-dispatch path, whose grid kernels and
/// single-pass steps these tests reach (tests/workgroup.rs tests the
/// workgroup path), after `setup`.
fn run(model: &Model, p: &Params, steps: u32, setup: impl FnOnce(&mut GpuSolver)) -> GpuState {
    let mut g = solver_on(model, p, StepPath::MultiDispatch);
    g.tuning_mut().set_adaptive_cg_budget(false);
    setup(&mut g);
    g.step(steps).expect("GPU steps");
    g.read_state().expect("read-back")
}

fn assert_identical(a: &GpuState, b: &GpuState, what: &str) {
    let (d, p) = worst(&a.x, &b.x);
    assert!(d == 0.0, "{what}: particle {p} differs by {d:e} m");
}

#[test]
fn two_gpu_runs_are_bit_identical() {
    for integrator in Integrator::ALL {
        let p = busy_params(integrator);
        let m = model(corners(), &p);
        let a = run(&m, &p, 60, |_| {});
        let b = run(&m, &p, 60, |_| {});
        assert_identical(&a, &b, integrator.as_str());
        assert!(a
            .x
            .iter()
            .zip(&m.rest_positions)
            .any(|(x, r)| (x.y as f64 - r[1]).abs() > 1e-3));
    }
}

/// Collision projection leaves a particle on the surface up to f32
/// rounding of positions near 1 m (6e-8 m); 1e-6 m is "on", more is "in".
const PENETRATION_TOL: f32 = 1e-6;

/// How long the explicit cloth falls in `pins_and_contacts_hold_on_the_gpu`
/// [s]: 0.2 s (200 steps of 1 ms) bring it onto the sphere, whose top is
/// 0.1 m below it.
const EXPLICIT_FALL: f64 = 0.2;
/// How long the other integrators' cloth falls there [s]: 0.3 s (36 steps
/// of 1/120 s) bring it onto the sphere (a free fall reaches its top in
/// 0.14 s) and press it there for as long again.
const IMPLICIT_FALL: f64 = 0.3;

#[test]
fn pins_and_contacts_hold_on_the_gpu() {
    for integrator in Integrator::ALL {
        let p = busy_params(integrator);
        let m = model(corners(), &p);
        let fall = if integrator == Integrator::Explicit {
            EXPLICIT_FALL
        } else {
            IMPLICIT_FALL
        };
        let s = run(&m, &p, (fall / p.dt).ceil() as u32, |_| {});
        let mut touching = 0;
        for (i, x) in s.x.iter().enumerate() {
            if m.pinned[i] {
                let r = m.rest_positions[i];
                assert_eq!(
                    [x.x, x.y, x.z],
                    [r[0] as f32, r[1] as f32, r[2] as f32],
                    "{integrator}: pin {i} moved"
                );
                continue;
            }
            let sphere = (*x - Vec3::new(0.1, 0.7, 0.0)).length() - 0.2;
            assert!(
                x.y >= 0.75 - PENETRATION_TOL,
                "{integrator}: particle {i} below the ground: {x:?}"
            );
            assert!(
                sphere >= -PENETRATION_TOL,
                "{integrator}: particle {i} inside the sphere by {sphere}"
            );
            touching += usize::from(x.y < 0.75 + 1e-4 || sphere < 1e-4);
        }
        assert!(touching > 0, "{integrator}: nothing reached a collider");
    }
}

#[test]
fn runtime_changes_equal_building_with_the_new_values() {
    for integrator in Integrator::ALL {
        let full = busy_params(integrator);
        let m = model(corners(), &full);
        let reference = run(&m, &full, 40, |_| {});
        // The same scene, built bare and completed through the setters.
        let mut bare = full.clone();
        bare.wind = None;
        bare.ground = None;
        bare.spheres.clear();
        bare.gravity = DVec3::new(0.0, -1.0, 0.0);
        let changed = run(&m, &bare, 40, |g| {
            g.set_wind(full.wind).expect("wind");
            g.set_ground(full.ground).expect("ground");
            g.set_spheres(&full.spheres).expect("spheres");
            g.set_gravity(full.gravity).expect("gravity");
        });
        assert_identical(&reference, &changed, integrator.as_str());
        // Pins too (the semi-implicit dense filter is rebuilt for them).
        let unpinned = model(vec![], &full);
        let pinned_later = run(&unpinned, &full, 40, |g| {
            g.set_pinned(0, true).expect("pin");
            g.set_pinned(12, true).expect("pin");
        });
        assert_identical(&reference, &pinned_later, &format!("{integrator} pins"));
    }
}

#[test]
fn a_moved_pin_drags_the_cloth() {
    let p = busy_params(Integrator::Implicit);
    let m = model(corners(), &p);
    let still = run(&m, &p, 30, |_| {});
    let dragged = run(&m, &p, 30, |g| {
        g.set_position(0, Vec3::new(-0.8, 1.2, -0.5)).expect("move");
    });
    assert_eq!(dragged.x[0], Vec3::new(-0.8, 1.2, -0.5));
    let (d, _) = worst(&still.x, &dragged.x);
    assert!(d > 0.01, "moving a pin moved the cloth by only {d} m");
}

#[test]
fn a_cloth_too_large_for_the_device_is_refused_naming_the_limit() {
    let (device, queue) = small_device();
    let p = busy_params(Integrator::Explicit);
    let spec = ClothSpec {
        nx: 129,
        ny: 129,
        ..ClothSpec::default()
    };
    let m = Model::new(&spec, &p.springs).expect("valid");
    match GpuSolver::new(&device, &queue, &m, &p) {
        Err(e @ Error::DeviceLimit { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("max_storage_buffer_binding_size"), "{msg}");
            assert!(msg.contains("1048576"), "{msg}");
        }
        other => panic!("expected a device-limit error, got {other:?}"),
    }
}

#[test]
fn a_blow_up_is_reported_at_the_cpu_mirror_step_without_nan_vertices() {
    let mut p = busy_params(Integrator::Explicit);
    p.dt = 0.02;
    p.springs[0].stiffness = 1e5;
    p.fixup.iterations = 0;
    let m = model(corners(), &p);
    let mut cpu = CpuSolver::<f32>::new(&m, &p).expect("valid");
    let cpu_step = match cpu.step_n(1000) {
        Err(Error::NonFinite { step, .. }) => step,
        other => panic!("the CPU mirror should blow up: {other:?}"),
    };
    let ctx = gpu();
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &m, &p).expect("GPU solver");
    match g.step(1000) {
        Err(Error::NonFinite { step, .. }) => {
            gpu_common::agreement::assert_blow_up_step("GPU", step, cpu_step)
        }
        other => panic!("the GPU should report the blow-up: {other:?}"),
    }
    // The vertex buffer holds the last finite state, not NaN.
    let bytes = wgcloth::gpu::readback::read_buffers(
        &ctx.device,
        &ctx.queue,
        &[(g.positions_buffer(), 0, u64::from(g.particle_count()) * 16)],
    )
    .expect("read");
    let xs: &[f32] = bytemuck::cast_slice(&bytes[0]);
    assert!(
        xs.iter().all(|v| v.is_finite()),
        "NaN reached the vertex buffer"
    );
}

#[test]
fn normals_of_a_flat_cloth_point_up() {
    let p = busy_params(Integrator::Explicit);
    let m = model(corners(), &p);
    let ctx = gpu();
    let g = GpuSolver::new(&ctx.device, &ctx.queue, &m, &p).expect("GPU solver");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    g.encode_normals(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let bytes = wgcloth::gpu::readback::read_buffers(
        &ctx.device,
        &ctx.queue,
        &[(g.normals_buffer(), 0, u64::from(g.particle_count()) * 16)],
    )
    .expect("read");
    for n in bytemuck::cast_slice::<u8, [f32; 4]>(&bytes[0]) {
        assert!(
            (n[1] - 1.0).abs() < 1e-6 && n[0].abs() < 1e-6 && n[2].abs() < 1e-6,
            "{n:?}"
        );
    }
}

/// Single-pass explicit steps (a grid, no fix-up) alternate the state
/// between the state buffers and a snapshot, and read it, wind triangles
/// included, from where the previous step wrote it; a particle moved or a
/// pin changed between steps must reach them as it reaches the general
/// kernels, which read the state buffers — after an odd number of steps
/// (which starts with a copy into the snapshot) as after an even one.
#[test]
fn single_pass_explicit_steps_see_changes_between_steps() {
    for wind in [false, true] {
        single_pass_against_general(wind);
    }
}

fn single_pass_against_general(wind: bool) {
    let mut p = busy_params(Integrator::Explicit);
    if !wind {
        p.wind = None;
    }
    p.fixup.iterations = 0;
    let m = model(corners(), &p);
    let run = |specialised: bool| {
        let mut g = solver_on(&m, &p, StepPath::MultiDispatch);
        g.tuning_mut()
            .set_specialised(specialised)
            .expect("kernels");
        let plan = g.tuning().step_plan();
        let single = plan.len() == 1
            && plan[0].kernel == Kernel::ExplicitIntegrate
            && plan[0].variant == Variant::ToSnapshot;
        assert_eq!(single, specialised, "{plan:?}");
        g.step(21).expect("steps");
        g.set_position(40, Vec3::new(0.1, 1.3, 0.05)).expect("move");
        g.set_pinned(40, true).expect("pin");
        g.step(20).expect("steps");
        g.set_pinned(0, false).expect("release");
        g.step(1).expect("steps");
        g.step(18).expect("steps");
        g.read_state().expect("read-back")
    };
    let single = run(true);
    let general = run(false);
    assert_identical(
        &single,
        &general,
        &format!("single-pass against general kernels, wind {wind}"),
    );
    assert_eq!(single.x[40], Vec3::new(0.1, 1.3, 0.05));
}

/// The grid gather kernels give the same bits for every block shape (a
/// 13 × 11 cloth: blocks stick out of the last column and row for all but
/// one particle per invocation), for each integrator and for the
/// single-pass explicit step — and blocks really are in use.
#[test]
fn every_grid_block_shape_gives_the_same_bits() {
    // The adapter's default shape meets the CPU mirror in the other tests.
    // 3 × 2 sticks out of the last column and the last row; a transposed
    // shape would only repeat that in the other order.
    let shapes = [GridBlock::ONE, GridBlock { cols: 3, rows: 2 }];
    let mut cases: Vec<(String, Params)> = Integrator::ALL
        .iter()
        .map(|&i| (i.as_str().to_string(), busy_params(i)))
        .collect();
    let mut single = busy_params(Integrator::Explicit);
    single.fixup.iterations = 0;
    cases.push(("explicit single pass".into(), single));
    for (what, p) in cases {
        let m = model(corners(), &p);
        let runs: Vec<GpuState> = shapes
            .iter()
            .map(|&shape| {
                run(&m, &p, 15, |g| {
                    g.tuning_mut().set_grid_block(shape).expect("block shape");
                    let plan = g.tuning().step_plan();
                    let gather: Vec<u32> = plan
                        .iter()
                        .filter(|d| {
                            [
                                Kernel::ExplicitIntegrate,
                                Kernel::FixupJacobi,
                                Kernel::ImplicitPrepare,
                            ]
                            .contains(&d.kernel)
                        })
                        .map(|d| d.items)
                        .collect();
                    let blocks = shape.count(13, 11);
                    assert!(
                        !gather.is_empty() && gather.iter().all(|&i| i == blocks),
                        "{what} {shape:?}: {plan:?}"
                    );
                    // The CG kernels gather a particle per invocation
                    // whatever the shape (their partial sums cover CG
                    // blocks of particles).
                    assert!(
                        plan.iter()
                            .filter(|d| [Kernel::CgInit, Kernel::CgApply].contains(&d.kernel))
                            .all(|d| d.items == 13 * 11),
                        "{what} {shape:?}: {plan:?}"
                    );
                })
            })
            .collect();
        for (shape, state) in shapes.iter().zip(&runs).skip(1) {
            assert_identical(
                state,
                &runs[0],
                &format!("{what}, {shape:?} against one per invocation"),
            );
        }
    }
}

/// Every CG workgroup adds all the partial sums, lane `l` taking partials
/// `l`, `l + 256`, …: a 257 × 257 cloth has 259 CG blocks, so some lanes
/// add two, and the implicit step still matches the CPU mirror bit for
/// bit — every other test's cloth has fewer than 256 blocks.
#[test]
fn cg_sums_of_more_blocks_than_a_workgroup_match_the_cpu_mirror() {
    let p = busy_params(Integrator::Implicit);
    let m = grid(257, 257, corners(), &p);
    assert!(m.particle_count().div_ceil(CG_BLOCK) > CG_BLOCK);
    if let Some(verdict) = bounded_steps("257² implicit", || exact_gpu(&m, &p), &m, &p, 2) {
        verdict.unwrap_or_else(|e| panic!("{e}"));
        return;
    }
    let (d, worst, g, c) = compare(&m, &p, 2);
    assert!(
        d == 0.0,
        "particle {worst}: GPU {g:?} against CPU {c:?}, {d:e} m apart"
    );
}

/// A fresh device of the test adapter, so that its kernel library starts
/// empty.
fn fresh_device() -> (wgpu::Device, wgpu::Queue) {
    let ctx = gpu();
    pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("fresh"),
        required_limits: ctx.adapter.limits(),
        ..Default::default()
    }))
    .expect("a second device")
}

/// Solvers built with one kernel library share it: a second solver of the
/// same scene compiles nothing, one with wind only the variants wind
/// changes; a solver built with `new` compiles into a library of its own.
#[test]
fn solvers_sharing_kernels_compile_each_variant_once() {
    let (device, queue) = fresh_device();
    let mut p = busy_params(Integrator::Explicit);
    p.wind = None;
    let m = model(corners(), &p);
    let kernels = GpuKernels::new(&device);
    assert_eq!(kernels.compiled(), 0);
    // The multi-dispatch path's variants (the workgroup path, which a
    // discrete GPU's cost model picks for this cloth, has one kernel).
    let md = StepPath::MultiDispatch;
    let first = GpuSolver::with_step_path(&kernels, &queue, &m, &p, md).expect("GPU solver");
    let one = kernels.compiled();
    // The plan's pipelines and normals, no other variant.
    let mut distinct: Vec<_> = first.debug_plan().iter().map(|d| d.pipeline()).collect();
    distinct.sort();
    distinct.dedup();
    assert_eq!(one, distinct.len() + 1, "{distinct:?}");
    let second =
        GpuSolver::with_step_path(&kernels.clone(), &queue, &m, &p, md).expect("GPU solver");
    assert_eq!(kernels.compiled(), one, "the second solver compiled again");
    let third = GpuSolver::new(&device, &queue, &m, &p).expect("GPU solver");
    assert_eq!(
        kernels.compiled(),
        one,
        "`new` compiled into the shared library"
    );
    let mut windy = p.clone();
    windy.wind = busy_params(Integrator::Explicit).wind;
    let fourth = GpuSolver::with_step_path(&kernels, &queue, &m, &windy, md).expect("GPU solver");
    let with_wind = kernels.compiled();
    assert!(
        with_wind > one && with_wind <= 2 * one,
        "{one} then {with_wind}"
    );
    drop((first, second, third, fourth));
}

/// A pipeline-cache file that is not one (garbage, or a cache cut short)
/// is ignored: the solver builds and steps as without it, and saving
/// writes a cache that the next run reads.
#[test]
fn a_corrupt_pipeline_cache_file_does_not_fail_a_run() {
    let dir = std::env::temp_dir().join(format!("wgcloth-cache-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let mut ctx = GpuContext::new(None).expect("adapter");
    let info = ctx.adapter.get_info();
    let Some(file) = pipeline_cache::file(&dir, &info) else {
        eprintln!("{}: no pipeline cache on this backend", ctx.describe());
        return;
    };
    let p = busy_params(Integrator::Implicit);
    let m = model(corners(), &p);
    let reference = run(&m, &p, 10, |_| {});
    for garbage in [b"not a cache at all".to_vec(), vec![0u8; 4096]] {
        std::fs::write(&file, &garbage).expect("write the corrupt file");
        assert!(ctx.keep_pipelines(&dir), "{}", ctx.describe());
        // The reference's path: another path may round apart from it on
        // an adapter that fuses.
        let mut g =
            GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &m, &p, StepPath::MultiDispatch)
                .expect("GPU solver");
        g.tuning_mut().set_adaptive_cg_budget(false);
        g.step(10).expect("steps");
        assert_identical(&reference, &g.read_state().expect("read-back"), "cached");
        ctx.save_pipelines().expect("save");
        let saved = std::fs::read(&file).expect("the cache file");
        assert_ne!(saved, garbage, "the corrupt file was not replaced");
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}
