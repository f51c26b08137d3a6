//! `GpuBatch`: cloths stepped together give each cloth the bits it gets
//! alone; adding and removing cloths between steps keeps the others'
//! state; a cloth the workgroup kernels cannot step is stepped all the
//! same. GPU tests on lavapipe in CI.

mod gpu_common;

use gpu_common::{busy_params, corners, gpu, grid};
use wgcloth::glam::DVec3;
use wgcloth::gpu::{ClothId, GpuBatch, GpuSolver, GpuState, StepPath};
use wgcloth::kernel_config::WORKGROUP_STEP_MAX_PARTICLES;
use wgcloth::params::{Capsule, FilterMethod, FixupMethod, Integrator, PinTarget, Sphere, Wind};
use wgcloth::{Model, Params, Scene, StepStats};

/// Steps of the comparisons: enough for the falling cloths to reach the
/// busy parameters' ground and sphere and to stretch past the fix-up's
/// limit, so every phase of the step has moved something.
const STEPS: u32 = 50;

/// A cloth of a test: its model and parameters.
struct Cloth {
    name: &'static str,
    model: Model,
    params: Params,
}

/// Different sizes, a mesh, different stiffness, mass and dt, every
/// integrator (the workgroup kernels take those they can; the batch holds
/// the others as solvers of their own).
fn mixed_cloths() -> Vec<Cloth> {
    let mut cloths = Vec::new();
    let explicit = busy_params(Integrator::Explicit);
    cloths.push(Cloth {
        name: "explicit 9²",
        model: grid(9, 9, corners(), &explicit),
        params: explicit.clone(),
    });
    let mut stiff = explicit.clone();
    stiff.springs[0].stiffness *= 4.0;
    stiff.dt = 5e-4;
    stiff.wind = None;
    let mut heavy = grid(13, 11, corners(), &stiff);
    for m in &mut heavy.mass {
        *m *= 3.0;
    }
    cloths.push(Cloth {
        name: "explicit 13×11, stiffer, heavier, dt/2, no wind",
        model: heavy,
        params: stiff,
    });
    let mesh = Scene::resolve("scenes/tablecloth.toml").expect("the tablecloth scene");
    let mut mesh_params = mesh.params.clone();
    mesh_params.fixup.method = FixupMethod::Jacobi;
    cloths.push(Cloth {
        name: "tablecloth mesh",
        model: mesh.model().expect("the tablecloth mesh"),
        params: mesh_params,
    });
    // The CG filter has no workgroup kernel: a solver of its own.
    let mut banded = busy_params(Integrator::SemiImplicit);
    banded.semi_implicit.filter = FilterMethod::Banded;
    cloths.push(Cloth {
        name: "semi-implicit 7², banded filter",
        model: grid(7, 7, corners(), &banded),
        params: banded,
    });
    for integrator in [Integrator::SemiImplicit, Integrator::Implicit] {
        let p = busy_params(integrator);
        cloths.push(Cloth {
            name: if integrator == Integrator::Implicit {
                "implicit 9²"
            } else {
                "semi-implicit 9²"
            },
            model: grid(9, 9, corners(), &p),
            params: p,
        });
    }
    cloths
}

/// A lone solver of `cloth`, stepped `steps` steps.
fn alone(cloth: &Cloth, steps: u32) -> (GpuState, StepStats) {
    let ctx = gpu();
    let mut solver =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &cloth.model, &cloth.params)
            .unwrap_or_else(|e| panic!("{}: lone solver: {e}", cloth.name));
    let stats = solver
        .step(steps)
        .unwrap_or_else(|e| panic!("{}: lone run: {e}", cloth.name));
    let state = solver
        .read_state()
        .unwrap_or_else(|e| panic!("{}: lone read-back: {e}", cloth.name));
    (state, stats)
}

/// Panics unless `got` equals `want` bit for bit, naming the first
/// particle that differs.
fn assert_bits(what: &str, got: &GpuState, want: &GpuState) {
    assert_eq!(got.x.len(), want.x.len(), "{what}: particle count");
    let bits = |v: &[wgcloth::glam::Vec3]| -> Vec<[u32; 3]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    for (name, g, w) in [("x", &got.x, &want.x), ("v", &got.v, &want.v)] {
        let (gb, wb) = (bits(g), bits(w));
        if let Some(p) = (0..gb.len()).find(|&p| gb[p] != wb[p]) {
            panic!(
                "{what}: {name} of particle {p} is {:?} batched, {:?} alone",
                g[p], w[p]
            );
        }
    }
}

/// The stats a comparison holds equal (the CG budget's hits count checks,
/// which the batch and the lone solver make as often here).
fn stats_eq(what: &str, got: &StepStats, want: &StepStats) {
    assert_eq!(got, want, "{what}: StepStats batched vs alone");
}

#[test]
fn a_mixed_batch_steps_each_cloth_as_it_steps_alone() {
    let cloths = mixed_cloths();
    let ctx = gpu();
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let ids: Vec<ClothId> = cloths
        .iter()
        .map(|c| {
            batch
                .add(&c.model, &c.params)
                .unwrap_or_else(|e| panic!("{}: add: {e}", c.name))
        })
        .collect();
    assert_eq!(batch.cloth_count(), cloths.len());
    // Both ways of stepping are in the batch: the shared buffers and a
    // cloth held as its own solver.
    let paths: Vec<StepPath> = ids
        .iter()
        .map(|&id| batch.step_path(id).expect("path"))
        .collect();
    assert!(paths.contains(&StepPath::Workgroup), "{paths:?}");
    assert!(paths.contains(&StepPath::MultiDispatch), "{paths:?}");
    let stats = batch.step(STEPS).expect("batch run");
    for ((cloth, id), (sid, got_stats)) in cloths.iter().zip(&ids).zip(&stats) {
        assert_eq!(id, sid, "stats in slot order");
        let got = batch.read_state(*id).expect("batch read-back");
        let (want, want_stats) = alone(cloth, STEPS);
        assert_bits(cloth.name, &got, &want);
        stats_eq(cloth.name, got_stats, &want_stats);
    }
}

#[test]
fn adding_and_removing_cloths_keeps_the_others_state() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let small = grid(9, 9, corners(), &p);
    let large = grid(17, 17, corners(), &p);
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let a = batch.add(&small, &p).expect("a");
    let b = batch.add(&small, &p).expect("b");
    batch.step(20).expect("20 steps");
    batch.remove(a).expect("remove a");
    assert!(batch.read_state(a).is_err(), "a removed cloth is refused");
    // Reuses a's slot (and, on the workgroup path, its ranges).
    let c = batch.add(&small, &p).expect("c");
    assert_eq!(c.index(), a.index(), "the freed slot is reused");
    assert_ne!(c, a, "a reused slot has a new id");
    // Larger than anything freed: the shared buffers grow.
    let d = batch.add(&large, &p).expect("d");
    batch.step(STEPS - 20).expect("the rest");
    let (want_b, _) = alone(
        &Cloth {
            name: "b",
            model: small.try_clone().expect("model"),
            params: p.clone(),
        },
        STEPS,
    );
    assert_bits(
        "b, stepped through removes and adds",
        &batch.read_state(b).expect("b"),
        &want_b,
    );
    for (id, model, name) in [
        (c, &small, "c (a reused slot)"),
        (d, &large, "d (grown buffers)"),
    ] {
        let (want, _) = alone(
            &Cloth {
                name,
                model: model.try_clone().expect("model"),
                params: p.clone(),
            },
            STEPS - 20,
        );
        assert_bits(name, &batch.read_state(id).expect(name), &want);
        assert_eq!(batch.steps_recorded(id).ok(), Some(u64::from(STEPS - 20)));
    }
}

#[test]
fn a_cloth_beyond_the_workgroup_limit_is_stepped_in_the_batch() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    // One row past the limit's square.
    let side = (f64::from(WORKGROUP_STEP_MAX_PARTICLES).sqrt()) as usize;
    let beyond = grid(side, side + 1, corners(), &p);
    assert!(beyond.particle_count() > WORKGROUP_STEP_MAX_PARTICLES as usize);
    let small = grid(9, 9, corners(), &p);
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let s = batch.add(&small, &p).expect("small");
    let big = batch.add(&beyond, &p).expect("beyond the limit");
    assert_eq!(batch.step_path(s).ok(), Some(StepPath::Workgroup));
    assert_eq!(batch.step_path(big).ok(), Some(StepPath::MultiDispatch));
    let steps = 10;
    batch.step(steps).expect("steps");
    for (id, model, name) in [(s, &small, "small"), (big, &beyond, "beyond the limit")] {
        let (want, _) = alone(
            &Cloth {
                name,
                model: model.try_clone().expect("model"),
                params: p.clone(),
            },
            steps,
        );
        assert_bits(name, &batch.read_state(id).expect(name), &want);
    }
}

#[test]
fn a_blow_up_names_the_cloth_and_the_step() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let mut wild = p.clone();
    // Far past explicit's stability limit at this dt: blows up in steps.
    wild.springs[0].stiffness = 1e9;
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    batch.add(&grid(9, 9, corners(), &p), &p).expect("calm");
    let bad = batch
        .add(&grid(9, 9, corners(), &wild), &wild)
        .expect("wild");
    let err = batch.step(200).expect_err("the wild cloth blows up");
    match &err {
        wgcloth::Error::InBatch { cloth, source } => {
            assert_eq!(*cloth, bad.index(), "{err}");
            assert!(
                matches!(**source, wgcloth::Error::NonFinite { .. }),
                "{source}"
            );
        }
        other => panic!("expected the cloth named, got {other}"),
    }
}

#[test]
fn each_cloth_is_drawn_from_its_range_with_the_normals_it_has_alone() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let (first, second) = (grid(9, 9, corners(), &p), grid(11, 7, corners(), &p));
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    batch.add(&first, &p).expect("first");
    let id = batch.add(&second, &p).expect("second");
    let mut lone = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &second, &p).expect("lone");
    batch.step(STEPS).expect("batch");
    lone.step(STEPS).expect("lone");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    batch.encode_normals(&mut encoder);
    lone.encode_normals(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let range = batch.draw_range(id).expect("draw range");
    let n = second.particle_count() as u64 * 16;
    let at = range.base_vertex as u64 * 16;
    assert!(at > 0, "the second cloth starts after the first");
    let tris = second.triangles.len() as u64 * 12;
    let parts = wgcloth::gpu::readback::read_buffers(
        &ctx.device,
        &ctx.queue,
        &[
            (range.normals, at, n),
            (lone.normals_buffer(), 0, n),
            (range.index_buffer, u64::from(range.indices.start) * 4, tris),
        ],
    )
    .expect("read-back");
    assert_eq!(range.indices.len() as u32, lone.index_count());
    assert!(parts[0] == parts[1], "normals differ from the lone cloth's");
    // The cloth's own triangles, relative to its first vertex.
    let want: Vec<u8> = second
        .triangles
        .iter()
        .flatten()
        .flat_map(|i| i.to_ne_bytes())
        .collect();
    assert!(parts[2] == want, "indices are not the cloth's triangles");
}

/// A change a game makes between frames.
enum Change {
    Gravity(DVec3),
    Wind(Option<Wind>),
    Spheres(Vec<Sphere>),
    Capsules(Vec<Capsule>),
    Pinned(usize, bool),
    Targets(Vec<PinTarget>),
    Position(usize, wgcloth::glam::Vec3),
}

/// Frame `frame`'s changes: gravity and wind, a moving sphere and a
/// capsule, a corner released and a middle particle pinned (frame 1), the
/// other corner dragged by a pin target, the middle particle moved.
fn frame_changes(frame: u32) -> Vec<Change> {
    let f = f64::from(frame);
    let mut out = vec![
        Change::Gravity(DVec3::new(0.5 * f, -9.81, 0.0)),
        Change::Wind(Some(Wind {
            velocity: DVec3::new(1.0 + f, 0.0, 2.0),
            drag: 0.5,
            lift: 0.1,
        })),
        Change::Spheres(vec![Sphere {
            center: DVec3::new(0.3, 0.6 + 0.05 * f, 0.4),
            radius: 0.15,
            friction: 0.2,
            velocity: DVec3::new(0.0, 0.5, 0.0),
        }]),
        Change::Capsules(vec![Capsule {
            a: DVec3::new(0.0, 0.5, 0.6),
            b: DVec3::new(1.0, 0.5, 0.6),
            radius: 0.05,
            friction: 0.1,
            velocity: DVec3::ZERO,
        }]),
    ];
    if frame == 1 {
        out.extend([Change::Pinned(0, false), Change::Pinned(40, true)]);
    }
    let up = 0.01 * frame as f32;
    out.extend([
        Change::Position(40, wgcloth::glam::Vec3::new(0.5, 1.0 + up, 0.5)),
        Change::Targets(vec![PinTarget {
            particle: 8,
            position: wgcloth::glam::Vec3::new(1.0 + 2.0 * up, 1.0, 0.0),
        }]),
    ]);
    out
}

/// Seconds a pin target's move takes.
const FRAME_SECONDS: f64 = 0.01;

fn change_lone(s: &mut GpuSolver, c: &Change) -> wgcloth::Result<()> {
    match c {
        Change::Gravity(g) => s.set_gravity(*g),
        Change::Wind(w) => s.set_wind(*w),
        Change::Spheres(v) => s.set_spheres(v),
        Change::Capsules(v) => s.set_capsules(v),
        Change::Pinned(p, on) => s.set_pinned(*p, *on),
        Change::Targets(t) => s.set_pin_targets(t, FRAME_SECONDS),
        Change::Position(p, x) => s.set_position(*p, *x),
    }
}

fn change_in_batch(b: &mut GpuBatch, id: ClothId, c: &Change) -> wgcloth::Result<()> {
    match c {
        Change::Gravity(g) => b.set_gravity(id, *g),
        Change::Wind(w) => b.set_wind(id, *w),
        Change::Spheres(v) => b.set_spheres(id, v),
        Change::Capsules(v) => b.set_capsules(id, v),
        Change::Pinned(p, on) => b.set_pinned(id, *p, *on),
        Change::Targets(t) => b.set_pin_targets(id, t, FRAME_SECONDS),
        Change::Position(p, x) => b.set_position(id, *p, *x),
    }
}

#[test]
fn a_batch_cloths_setters_change_it_as_a_lone_solvers_change_it() {
    let ctx = gpu();
    let p = busy_params(Integrator::Explicit);
    let (first, second) = (grid(9, 9, corners(), &p), grid(9, 9, corners(), &p));
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let untouched = batch.add(&first, &p).expect("first");
    let id = batch.add(&second, &p).expect("second");
    assert_eq!(batch.step_path(id).ok(), Some(StepPath::Workgroup));
    let mut lone = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &second, &p).expect("lone");
    let frames = 5;
    for frame in 1..=frames {
        for c in frame_changes(frame) {
            change_lone(&mut lone, &c).expect("lone change");
            change_in_batch(&mut batch, id, &c).expect("batch change");
        }
        batch.step(STEPS / frames).expect("batch steps");
        lone.step(STEPS / frames).expect("lone steps");
    }
    assert_bits(
        "the changed cloth",
        &batch.read_state(id).expect("read"),
        &lone.read_state().expect("read"),
    );
    let (want, _) = alone(
        &Cloth {
            name: "untouched",
            model: first.try_clone().expect("model"),
            params: p.clone(),
        },
        STEPS / frames * frames,
    );
    assert_bits(
        "the untouched cloth",
        &batch.read_state(untouched).expect("read"),
        &want,
    );
}
