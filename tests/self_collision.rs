//! Self-collision (`[self_collision]`, `src/cpu/self_collision.rs`) on the
//! CPU reference, `f64` and `f32`, every integrator: a cloth folded in
//! three layers dropped on the ground keeps its layers apart and no edge
//! pierces a triangle; a hanging sheet that never comes near itself moves
//! bit for bit as without it; bad values are refused naming the key; the
//! GPU solvers refuse it rather than leave it out.

mod common;
mod gpu_common;

use common::{crossing_pairs, differing, edges};
use gpu_common::agreement;
use gpu_common::{folded_model, folded_positions, FOLD_SPACING as SPACING};
use wgcloth::cpu::{CpuSolver, State};
use wgcloth::glam::DVec3;
use wgcloth::model::Model;
use wgcloth::params::{Ground, Integrator, Params, SelfCollision};
use wgcloth::real::Vec3;
use wgcloth::self_collision::{self, EXCLUDE_REST, STEP_CAP};
use wgcloth::{Error, Real, Scene};

/// The bound: no two particles the exclusion does not pair come
/// closer than this fraction of the thickness. The Jacobi response
/// separates a lone pair to the full thickness in one pass; the 10 % is
/// what a stack under gravity and a landing leave of a step's approach
/// (at most a thickness, see `STEP_CAP`) after the default two passes.
const MIN_GAP: f64 = 0.9;

/// Parameters of the drop: `integrator`, ground, self-collision at its
/// defaults.
fn drop_params(integrator: Integrator) -> Params {
    Params {
        integrator,
        dt: 1.0 / 600.0,
        ground: Some(Ground {
            height: 0.0,
            friction: 0.5,
        }),
        self_collision: Some(SelfCollision::default()),
        ..Params::default()
    }
}

/// A solver for `model` (the folded cloth) with `params`, the cloth
/// folded at rest 5 cm above the ground.
fn folded_solver<R: Real>(model: &Model, params: &Params) -> CpuSolver<R> {
    let mut solver = CpuSolver::<R>::new(model, params).expect("solver");
    let start = folded_positions(0.05);
    let n = start.len();
    solver
        .set_state(State {
            x: start.iter().map(|&p| Vec3::from_f64(p)).collect(),
            v: vec![Vec3::ZERO; n],
        })
        .expect("state");
    solver
}

/// Pairs `(p, q)`, `p < q`, that the exclusion does not pair: rest
/// distance at least `EXCLUDE_REST × thickness`.
fn colliding_pairs(model: &Model, thickness: f64) -> Vec<(usize, usize)> {
    let x = &model.rest_positions;
    let r = EXCLUDE_REST * thickness;
    let mut pairs = Vec::new();
    for p in 0..x.len() {
        for q in p + 1..x.len() {
            if (x[p] - x[q]).length() >= r {
                pairs.push((p, q));
            }
        }
    }
    pairs
}

/// The smallest distance \[m\] between the pairs.
fn min_distance(x: &[DVec3], pairs: &[(usize, usize)]) -> f64 {
    pairs
        .iter()
        .map(|&(p, q)| (x[p] - x[q]).length())
        .fold(f64::INFINITY, f64::min)
}

/// Edge–triangle crossings at `x` ([`common::crossing_pairs`]), counted
/// apart as `(between layers, local)`. A local crossing has an edge end
/// and a triangle corner closer at rest than the exclusion radius
/// `exclude` \[m\]: a cell folding over its neighbour, which no particle
/// pair the method looks at can see (the springs alone resist it).
fn crossings(model: &Model, edges: &[[u32; 2]], x: &[DVec3], exclude: f64) -> (usize, usize) {
    let rest = &model.rest_positions;
    let (mut far, mut near) = (0, 0);
    for (e, t) in crossing_pairs(model, edges, x) {
        let local = e.iter().any(|&p| {
            t.iter()
                .any(|&c| (rest[p as usize] - rest[c as usize]).length() < exclude)
        });
        if local {
            near += 1;
        } else {
            far += 1;
        }
    }
    (far, near)
}

/// Positions as `f64` vectors.
fn positions<R: Real>(solver: &CpuSolver<R>) -> Vec<DVec3> {
    solver
        .state()
        .x
        .iter()
        .map(|p| DVec3::from_array(p.to_f64()))
        .collect()
}

/// Drops the folded cloth for `steps` steps on `integrator` in precision
/// `R`, checking every step: no colliding pair closer than `MIN_GAP`
/// thicknesses, no edge–triangle crossing between layers. Returns the
/// lowest height of the cloth at the end \[m\] and the most local
/// crossings (a cell folded over its neighbour) at a step.
fn folded_drop<R: Real>(integrator: Integrator, steps: u64) -> (f64, usize) {
    let model = folded_model();
    let params = drop_params(integrator);
    let thickness = self_collision::thickness(&model, &params)
        .expect("default thickness")
        .expect("self-collision on");
    assert!(
        (thickness - SPACING).abs() <= SPACING_ROUNDING * SPACING,
        "the default {thickness} is the rest spacing"
    );
    let pairs = colliding_pairs(&model, thickness);
    let edges = edges(&model);
    let mut solver = folded_solver::<R>(&model, &params);
    let mut most_local = 0;
    for step in 1..=steps {
        solver.step().expect("finite");
        let x = positions(&solver);
        let gap = min_distance(&x, &pairs);
        assert!(
            gap >= MIN_GAP * thickness,
            "{integrator} {}: step {step}: two layers {gap} m apart, below {MIN_GAP} × {thickness}",
            R::NAME
        );
        let (crossed, local) = crossings(&model, &edges, &x, EXCLUDE_REST * thickness);
        assert_eq!(
            crossed,
            0,
            "{integrator} {}: step {step}: {crossed} edges pierce a triangle of another layer",
            R::NAME
        );
        most_local = most_local.max(local);
    }
    let lowest = positions(&solver)
        .iter()
        .map(|p| p.y)
        .fold(f64::INFINITY, f64::min);
    (lowest, most_local)
}

/// Relative rounding of a rest length computed from grid positions
/// (`size / (n − 1)` then a difference of two coordinates): a few `f64`
/// ulps.
const SPACING_ROUNDING: f64 = 1e-12;

/// Steps of the drop: 0.5 s, enough for the stack to land (it falls 5 cm)
/// and settle on the ground.
const DROP_STEPS: u64 = 300;

#[test]
fn folded_drop_keeps_layers_apart_f64() {
    for integrator in Integrator::ALL {
        let (lowest, local) = folded_drop::<f64>(integrator, DROP_STEPS);
        // The drop is real: the cloth reaches the ground.
        assert!(lowest < 0.5 * SPACING, "{integrator}: lowest {lowest} m");
        println!("{integrator} f64: at most {local} local crossings at a step");
    }
}

#[test]
fn folded_drop_keeps_layers_apart_f32() {
    for integrator in Integrator::ALL {
        let (_, local) = folded_drop::<f32>(integrator, DROP_STEPS);
        println!("{integrator} f32: at most {local} local crossings at a step");
    }
}

/// Without self-collision the same drop lets the layers into one another
/// and edges through triangles: the checks above can fail.
#[test]
fn without_self_collision_the_layers_meet() {
    let model = folded_model();
    let mut params = drop_params(Integrator::Explicit);
    params.self_collision = None;
    let pairs = colliding_pairs(&model, SPACING);
    let mut solver = folded_solver::<f64>(&model, &params);
    let edges = edges(&model);
    let (mut closest, mut crossed) = (f64::INFINITY, 0);
    for _ in 0..DROP_STEPS {
        solver.step().expect("finite");
        let x = positions(&solver);
        closest = closest.min(min_distance(&x, &pairs));
        crossed = crossed.max(crossings(&model, &edges, &x, EXCLUDE_REST * SPACING).0);
    }
    assert!(closest < MIN_GAP * SPACING, "closest {closest} m");
    assert!(crossed > 0, "no edge ever crossed a triangle");
}

/// A hanging sheet pinned at its top corners, swinging from rest: no
/// particle comes near another part of the cloth, so self-collision has
/// nothing to do, and the sheet must move bit for bit as without it.
#[test]
fn a_hanging_sheet_moves_exactly_as_without_it() {
    let model = common::swinging_sheet();
    for integrator in Integrator::ALL {
        let off = Params {
            integrator,
            ..Params::default()
        };
        let on = Params {
            self_collision: Some(SelfCollision::default()),
            ..off.clone()
        };
        let thickness = self_collision::thickness(&model, &on)
            .expect("thickness")
            .expect("on");
        let pairs = colliding_pairs(&model, thickness);
        let mut a = CpuSolver::<f32>::new(&model, &off).expect("off");
        let mut b = CpuSolver::<f32>::new(&model, &on).expect("on");
        let mut closest = f64::INFINITY;
        let mut fastest: f64 = 0.0;
        for step in 1..=300 {
            let before = positions(&a);
            a.step().expect("off");
            b.step().expect("on");
            let x = positions(&a);
            closest = closest.min(min_distance(&x, &pairs));
            for (p, q) in x.iter().zip(&before) {
                fastest = fastest.max((*p - *q).length());
            }
            assert_eq!(
                a.state(),
                b.state(),
                "{integrator}: step {step}: self-collision changed a sheet that never \
                 touches itself"
            );
        }
        // The premise: no pair came within the thickness and no particle
        // moved by the cap in a step, so equality is what must hold.
        assert!(closest > thickness, "{integrator}: closest {closest} m");
        assert!(
            fastest < STEP_CAP * thickness,
            "{integrator}: {fastest} m in a step"
        );
    }
}

/// A scene with `[self_collision]` holding `keys`.
fn scene(keys: &str) -> wgcloth::Result<Scene> {
    let text =
        format!("[cloth]\nresolution = [9, 9]\nsize = [0.4, 0.4]\n\n[self_collision]\n{keys}\n");
    Scene::from_toml(&text, std::path::Path::new("t.toml"))
}

#[test]
fn bad_values_are_refused_naming_the_key() {
    for (keys, key) in [
        ("thickness = -0.01", "self_collision.thickness"),
        ("thickness = 0", "self_collision.thickness"),
        ("thickness = inf", "self_collision.thickness"),
        ("thickness = nan", "self_collision.thickness"),
        ("friction = -1", "self_collision.friction"),
        ("iterations = 0", "self_collision.iterations"),
        ("iterations = 101", "self_collision.iterations"),
    ] {
        let message = match scene(keys) {
            Ok(_) => panic!("`{keys}` accepted"),
            Err(e) => e.to_string(),
        };
        assert!(message.contains(key), "`{keys}`: {message}");
    }
    // The model's limits: a particle slips through a triangle's middle
    // below the gap; beyond `MAX_THICKNESS_DEFAULTS` the exclusion swallows
    // folds. The spacing here is 0.05 m, the gap 0.05/√2.
    for thickness in [0.03, 0.21] {
        let s = scene(&format!("thickness = {thickness}")).expect("in range for the file");
        let model = s.model().expect("model");
        match CpuSolver::<f64>::new(&model, &s.params) {
            Err(Error::InvalidParameter { key, .. }) => {
                assert_eq!(key, "self_collision.thickness");
            }
            other => panic!("thickness {thickness}: {other:?}"),
        }
    }
    let s = scene("thickness = 0.05").expect("scene");
    let model = s.model().expect("model");
    assert!(CpuSolver::<f64>::new(&model, &s.params).is_ok());
    // Present and empty: on, with defaults.
    let s = scene("").expect("empty table");
    assert_eq!(s.params.self_collision, Some(SelfCollision::default()));
    // Unknown keys are typos.
    assert!(scene("thicknes = 0.01").is_err());
}

/// `wgcloth run --backend gpu` steps a self-collision scene (on both step
/// paths) and `--verbose` lists its kernels on the multi-dispatch path.
#[test]
fn the_gpu_backend_runs_it_and_shows_its_kernels() {
    let dir = std::env::temp_dir().join(format!("wgcloth-selfcol-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let scene = dir.join("folded.toml");
    std::fs::write(
        &scene,
        "[simulation]\nduration = 0.02\n[cloth]\nresolution = [9, 9]\n[self_collision]\n",
    )
    .expect("write scene");
    for path in ["multi-dispatch", "workgroup"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_wgcloth"))
            .args([
                "run",
                scene.to_str().expect("utf-8 path"),
                "--backend",
                "gpu",
                "--step-path",
                path,
                "--verbose",
            ])
            .output()
            .expect("run wgcloth");
        let all = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(out.status.code(), Some(0), "{path}: {all}");
        if path == "multi-dispatch" {
            for kernel in [
                "self_collision_count",
                "self_collision_scan",
                "self_collision_scatter",
                "self_collision_rank",
                "self_collision_respond",
            ] {
                assert!(all.contains(kernel), "{path}: no {kernel} in: {all}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Steps of the GPU drops: the stack lands (it falls 5 cm in ~60 steps)
/// and its layers press on one another for the rest.
const GPU_STEPS: u32 = 120;

/// CG's cap in the GPU drops: the GPU records the whole cap every step
/// (adaptive budget off, as the mirror comparisons run it), and the stack
/// needs far fewer; both sides use the same cap.
const GPU_CG_MAX_ITERATIONS: u32 = 40;

/// The drop's parameters for the GPU comparisons: the GPU's Jacobi
/// fix-up (the CPU's default is Gauss–Seidel).
fn gpu_drop_params(integrator: Integrator) -> Params {
    let mut p = drop_params(integrator);
    p.implicit.max_iterations = GPU_CG_MAX_ITERATIONS;
    p.fixup.method = wgcloth::params::FixupMethod::Jacobi;
    p
}

/// The folded drop on the GPU, on both step paths and every integrator:
/// the `f32` mirror's state under the agreement policy (bit for bit after
/// every layer has landed, or each step within its bound), and a second
/// run's bytes the same (the grid's order does not depend on
/// scheduling).
#[test]
fn the_gpu_drop_is_the_f32_mirrors_bit_for_bit() {
    use wgcloth::gpu::{GpuSolver, StepPath};
    let ctx = gpu_common::gpu();
    let model = folded_model();
    let start = folded_positions(0.05);
    for integrator in Integrator::ALL {
        let params = gpu_drop_params(integrator);
        for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
            let start_on_gpu = || {
                let mut g =
                    GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &model, &params, path)
                        .unwrap_or_else(|e| panic!("{integrator} on {path}: {e}"));
                g.tuning_mut().set_adaptive_cg_budget(false);
                for (p, x) in start.iter().enumerate() {
                    g.set_position(p, x.as_vec3()).expect("position");
                }
                g
            };
            let mut g = start_on_gpu();
            let mut mirror = folded_solver::<f32>(&model, &params);
            let bound = agreement::step_bound(&params);
            let what = format!("{integrator} on {path}");
            agreement::assert_steps(&what, &mut g, &mut mirror, GPU_STEPS, &bound);
            // The same device runs the same kernels the same way: bits on
            // every adapter.
            let first = g.read_state().expect("read-back").x;
            let mut again = start_on_gpu();
            for _ in 0..GPU_STEPS / agreement::SUBMIT_STEPS {
                again.step(agreement::SUBMIT_STEPS).expect("GPU run");
            }
            assert_eq!(
                differing(&first, &again.read_state().expect("read-back").x).0,
                0,
                "{integrator} on {path}: two runs differ"
            );
        }
    }
}

/// A batch of the folded drop, one cloth per integrator plus a second
/// implicit one, steps each cloth as a lone solver on the workgroup path
/// does, bit for bit.
#[test]
fn a_batch_drops_it_as_lone_solvers_do() {
    use wgcloth::gpu::{GpuBatch, GpuSolver, StepPath};
    let ctx = gpu_common::gpu();
    let model = folded_model();
    let start = folded_positions(0.05);
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let integrators = [
        Integrator::Implicit,
        Integrator::Explicit,
        Integrator::SemiImplicit,
        Integrator::Implicit,
    ];
    let ids: Vec<_> = integrators
        .iter()
        .map(|&i| {
            let id = batch.add(&model, &gpu_drop_params(i)).expect("added");
            for (p, x) in start.iter().enumerate() {
                batch.set_position(id, p, x.as_vec3()).expect("position");
            }
            id
        })
        .collect();
    batch.step(GPU_STEPS).expect("batch run");
    for (&id, &integrator) in ids.iter().zip(&integrators) {
        let params = gpu_drop_params(integrator);
        let mut lone = GpuSolver::with_step_path(
            ctx.kernels(),
            &ctx.queue,
            &model,
            &params,
            StepPath::Workgroup,
        )
        .expect("lone solver");
        for (p, x) in start.iter().enumerate() {
            lone.set_position(p, x.as_vec3()).expect("position");
        }
        lone.step(GPU_STEPS).expect("lone run");
        let (n, p) = differing(
            &batch.read_state(id).expect("batch read-back").x,
            &lone.read_state().expect("lone read-back").x,
        );
        assert_eq!(
            n, 0,
            "{integrator}: {n} positions differ from the lone solver's, the first {p:?}"
        );
    }
}

/// Steps of the tablecloth mesh with self-collision: it falls onto its
/// ball and starts to drape (its folds near), colliders and all.
const MESH_STEPS: u32 = 60;

/// The `tablecloth` scene (an irregular triangle mesh falling onto a ball
/// on the ground) with self-collision, on the GPU on both step paths: the
/// `f32` mirror's state under the agreement policy (bit for bit on
/// lavapipe).
#[test]
fn a_mesh_with_colliders_is_the_f32_mirrors_bit_for_bit() {
    use wgcloth::gpu::{GpuSolver, StepPath};
    let ctx = gpu_common::gpu();
    let mut scene = Scene::builtin("tablecloth").expect("built in");
    scene.params.self_collision = Some(SelfCollision::default());
    scene.params.implicit.max_iterations = GPU_CG_MAX_ITERATIONS;
    let model = scene.model().expect("mesh model");
    for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
        let mut g =
            GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &model, &scene.params, path)
                .unwrap_or_else(|e| panic!("{path}: {e}"));
        g.tuning_mut().set_adaptive_cg_budget(false);
        let mut mirror = CpuSolver::<f32>::new(&model, &scene.params).expect("CPU solver");
        let bound = agreement::step_bound(&scene.params);
        agreement::assert_steps(
            &format!("tablecloth on {path}"),
            &mut g,
            &mut mirror,
            MESH_STEPS,
            &bound,
        );
    }
}
