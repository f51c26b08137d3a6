//! Shared by the GPU tests: the device, GPU-vs-CPU comparison, and
//! decoding the pictures the renderer writes.
#![allow(dead_code, reason = "each test binary uses a different subset")]

pub mod agreement;
pub mod layers;

use std::sync::OnceLock;

use wgcloth::cpu::CpuSolver;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::gpu::{GpuContext, GpuSolver, StepPath};
use wgcloth::model::{ClothSpec, Corner, Orientation, Pin};
use wgcloth::params::{FixupMethod, Ground, Integrator, Sphere, Wind};
use wgcloth::{Model, Params};

/// The adapter every GPU test runs on, opened once per test binary (each
/// solver of a binary built with `ctx.kernels()` shares its compiled
/// pipelines too). A machine without one fails the test with the library's
/// message saying how to get one (lavapipe) — a GPU test never passes
/// silently.
pub fn gpu() -> &'static GpuContext {
    static CONTEXT: OnceLock<GpuContext> = OnceLock::new();
    CONTEXT.get_or_init(|| match GpuContext::new(None) {
        Ok(c) => {
            eprintln!("GPU tests on {}", c.describe());
            c
        }
        Err(e) => panic!("GPU tests need an adapter: {e}"),
    })
}

/// The largest distance between GPU and CPU positions, with the particle.
pub fn worst(gpu: &[Vec3], cpu: &[Vec3]) -> (f64, usize) {
    gpu.iter()
        .zip(cpu)
        .enumerate()
        .map(|(p, (a, b))| (f64::from((*a - *b).length()), p))
        .fold(
            (0.0, 0),
            |m, c| if c.0 > m.0 || c.0.is_nan() { c } else { m },
        )
}

/// The bound of one step of `model` under `params` against the mirror
/// re-seeded before it: [`agreement::step_bound`], or where the device
/// solves the semi-implicit filter by CG (beyond the dense filter's size)
/// and the mirror exactly, the implicit step's bound at that CG's
/// tolerance.
pub fn scene_bound(model: &Model, params: &Params) -> agreement::Bound {
    let free = model.pinned.iter().filter(|&&p| !p).count();
    if params.integrator == Integrator::SemiImplicit && !params.semi_implicit.filter.is_dense(free)
    {
        agreement::implicit_step(wgcloth::gpu::FILTER_CG_TOLERANCE)
    } else {
        agreement::step_bound(params)
    }
}

/// Under the bounded policy, `steps` steps of the device `make` builds,
/// each against the mirror of `model` re-seeded before it, within
/// [`scene_bound`]; `None` under bits, where the caller compares its own
/// way.
pub fn bounded_steps<S: agreement::Stepper>(
    what: &str,
    make: impl FnOnce() -> S,
    model: &Model,
    params: &Params,
    steps: u32,
) -> Option<Result<(), String>> {
    if agreement::policy() == agreement::Policy::Bits {
        return None;
    }
    let mut device = make();
    let mut c = match CpuSolver::<f32>::new(model, params) {
        Ok(c) => c,
        Err(e) => return Some(Err(format!("{what}: CPU solver: {e}"))),
    };
    let bound = scene_bound(model, params);
    Some(agreement::check_reseeded(
        what,
        &mut device,
        &mut c,
        steps,
        &bound,
    ))
}

/// Runs `steps` on both backends and returns the largest position
/// difference [m], the particle, and both positions there.
pub fn compare(model: &Model, params: &Params, steps: u32) -> (f64, usize, Vec3, Vec3) {
    let ctx = gpu();
    let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, model, params)
        .unwrap_or_else(|e| panic!("GPU solver: {e}"));
    g.step(steps).unwrap_or_else(|e| panic!("GPU run: {e}"));
    let gs = g
        .read_state()
        .unwrap_or_else(|e| panic!("GPU read-back: {e}"));
    let mut c = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU solver: {e}"));
    c.step_n(u64::from(steps))
        .unwrap_or_else(|e| panic!("CPU run: {e}"));
    let cx = c.positions();
    let (d, p) = worst(&gs.x, &cx);
    (d, p, gs.x[p], cx[p])
}

/// A GPU solver for `model` on the step path `path` (for the tests of one
/// path's plan; both paths give the same bits).
pub fn solver_on(model: &Model, params: &Params, path: StepPath) -> GpuSolver {
    let ctx = gpu();
    GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, model, params, path)
        .unwrap_or_else(|e| panic!("GPU solver on the {path} path: {e}"))
}

/// A GPU solver that records the full CG budget every step, so its
/// implicit steps iterate as the `f32` mirror's do (the adaptive budget
/// may stop a step whose colliders or pins just changed earlier).
pub fn exact_gpu(model: &Model, params: &Params) -> GpuSolver {
    let ctx = gpu();
    let mut g =
        GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, model, params).expect("GPU solver");
    g.tuning_mut().set_adaptive_cg_budget(false);
    g
}

/// The CG cap of [`busy_params`] (the default is 200). CG needs at most 14
/// iterations a step on the tests' 13 × 11 busy cloth, 20 on a 17² one with
/// a capsule, 30 on a 33² one (200 steps each; `wgcloth run SCENE --steps
/// 200 --precision f32`, whose summary gives the most a step took), so the
/// cap is never reached and every result is what the default cap gives.
/// It matters for time: a GPU solver with the adaptive budget off (as the
/// tests that compare bits run it) records the cap's CG dispatches every
/// step, each with its launch and barrier even once CG has stopped.
pub const BUSY_CG_MAX_ITERATIONS: u32 = 50;

/// Parameters that exercise every force and collider: wind with lift, a
/// ground and a sphere the falling cloth reaches within ~100 steps; Jacobi
/// fix-up (the GPU's); dt 1 ms for explicit, 1/120 s otherwise; CG capped
/// at [`BUSY_CG_MAX_ITERATIONS`].
pub fn busy_params(integrator: Integrator) -> Params {
    let mut p = Params {
        integrator,
        dt: if integrator == Integrator::Explicit {
            1e-3
        } else {
            1.0 / 120.0
        },
        ..Params::default()
    };
    p.implicit.max_iterations = BUSY_CG_MAX_ITERATIONS;
    p.fixup.method = FixupMethod::Jacobi;
    p.ground = Some(Ground {
        height: 0.75,
        friction: 0.5,
    });
    p.spheres = vec![Sphere {
        center: DVec3::new(0.1, 0.7, 0.0),
        radius: 0.2,
        friction: 0.3,
        velocity: DVec3::ZERO,
    }];
    p.wind = Some(Wind {
        velocity: DVec3::new(3.0, 0.0, 1.0),
        drag: 0.6,
        lift: 0.2,
    });
    p
}

/// The two top corners.
pub fn corners() -> Vec<Pin> {
    vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)]
}

/// A horizontal `nx × ny` cloth (1 m square, 1 m up) with `pins`.
pub fn grid(nx: usize, ny: usize, pins: Vec<Pin>, params: &Params) -> Model {
    let spec = ClothSpec {
        nx,
        ny,
        pins,
        ..ClothSpec::default()
    };
    Model::new(&spec, &params.springs).expect("valid grid")
}

/// The parts of `model` without its grid: the GPU runs the general
/// kernels on it, with the springs in the model's order.
pub fn without_grid(model: &Model) -> Model {
    Model::from_parts(
        model.rest_positions.clone(),
        model.mass.clone(),
        model.pinned.clone(),
        model.springs.clone(),
        model.triangles.clone(),
    )
    .unwrap_or_else(|e| panic!("parts: {e}"))
}

/// A device on the test adapter whose storage buffer bindings are limited
/// to 1 MiB, so a 129² cloth is beyond it.
pub fn small_device() -> (wgpu::Device, wgpu::Queue) {
    let ctx = gpu();
    let small = wgpu::Limits {
        max_storage_buffer_binding_size: 1 << 20,
        ..ctx.adapter.limits()
    };
    pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("small"),
        required_limits: small,
        ..Default::default()
    }))
    .expect("a device with lower limits")
}

/// Decodes an RGBA PNG the renderer wrote: its size and RGBA bytes.
pub fn decode_png(path: &std::path::Path) -> (u32, u32, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()));
    let mut rgba = vec![0; reader.output_buffer_size().expect("a PNG size")];
    let info = reader.next_frame(&mut rgba).expect("a PNG frame");
    assert_eq!(info.color_type, png::ColorType::Rgba, "{}", path.display());
    rgba.truncate(info.buffer_size());
    (info.width, info.height, rgba)
}

// The folded cloth of the self-collision tests (tests/self_collision.rs,
// tests/kernel_twins.rs).

/// Columns of the folded cloth.
pub const FOLD_NX: usize = 10;
/// Rows per layer of the folded cloth.
pub const FOLD_LAYER_ROWS: usize = 7;
/// Layers of the folded cloth.
pub const FOLD_LAYERS: usize = 3;
/// Rest spacing of the folded cloth \[m\] (the default thickness).
pub const FOLD_SPACING: f64 = 0.02;

/// A grid cloth of `FOLD_LAYERS × FOLD_LAYER_ROWS` rows, its rest flat.
pub fn folded_model() -> Model {
    let rows = FOLD_LAYERS * FOLD_LAYER_ROWS;
    let spec = ClothSpec {
        nx: FOLD_NX,
        ny: rows,
        size: [
            FOLD_SPACING * (FOLD_NX - 1) as f64,
            FOLD_SPACING * (rows - 1) as f64,
        ],
        origin: DVec3::ZERO,
        orientation: Orientation::Horizontal,
        mass: 0.05,
        pins: vec![],
    };
    Model::new(&spec, &Params::default().springs).expect("valid cloth")
}

/// The cloth folded in a Z: layer `l` of rows `l·FOLD_LAYER_ROWS ..` lies one
/// thickness (the spacing) above layer `l − 1`, each fold a single stretch
/// spring standing vertical; the lowest layer `height` above the ground.
pub fn folded_positions(height: f64) -> Vec<DVec3> {
    (0..FOLD_NX * FOLD_LAYERS * FOLD_LAYER_ROWS)
        .map(|p| {
            let (i, j) = (p % FOLD_NX, p / FOLD_NX);
            let (layer, s) = (j / FOLD_LAYER_ROWS, j % FOLD_LAYER_ROWS);
            let along = if layer % 2 == 0 {
                s
            } else {
                FOLD_LAYER_ROWS - 1 - s
            };
            DVec3::new(
                i as f64 * FOLD_SPACING,
                height + layer as f64 * FOLD_SPACING,
                along as f64 * FOLD_SPACING,
            )
        })
        .collect()
}

/// `steps` of `model` in `f64` from rest, each judged by the divergence
/// rule the CLI applies (a step that passes its energy bound panics,
/// naming the step): the reference run of a scene that must not blow up.
pub fn run_checked_f64(model: &Model, params: &Params, steps: u64) -> CpuSolver<f64> {
    let mut s = CpuSolver::<f64>::new(model, params).expect("valid");
    let rule =
        wgcloth::diagnostics::Divergence::new(model, params, 0.0, &s.positions(), &s.velocities());
    for step in 1..=steps {
        if let Err(e) = s.step().and_then(|_| s.check_divergence(&rule)) {
            panic!("step {step}: {e}");
        }
    }
    s
}

/// `steps` of `model` on the GPU against the `f32` mirror under the
/// agreement policy, on both step paths (`what` names the run).
pub fn assert_both_paths_agree(what: &str, model: &Model, params: &Params, steps: u32) {
    let bound = agreement::step_bound(params);
    for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
        let mut f32s = CpuSolver::<f32>::new(model, params).expect("valid");
        let mut g = GpuSolver::with_step_path(gpu().kernels(), &gpu().queue, model, params, path)
            .expect("GPU solver");
        g.tuning_mut().set_adaptive_cg_budget(false);
        let what = format!("{what}, {path} path");
        agreement::assert_steps(&what, &mut g, &mut f32s, steps, &bound);
    }
}
