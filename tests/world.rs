//! A world of several cloths (`[[cloth]]`, `[[seam]]`, `src/world.rs`):
//! a world of one cloth is that cloth; cloths apart step as each alone;
//! cloths dropped onto one another never pass through each other, on the
//! CPU in `f64` and `f32` and on the GPU as its mirror; seams close; bad
//! worlds are refused naming the keys.

mod common;
mod gpu_common;

use std::path::Path;

use common::{crossing_pairs, differing, edges};
use gpu_common::{assert_both_paths_agree, run_checked_f64};
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::model::Model;
use wgcloth::params::{FixupMethod, Integrator};
use wgcloth::{Real, Scene};

fn scene(text: &str) -> Scene {
    Scene::from_toml(text, Path::new("world.toml")).expect("a valid world")
}

fn refusal(text: &str) -> String {
    match Scene::from_toml(text, Path::new("world.toml")) {
        Ok(_) => panic!("should be refused:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The springs every world here shares (the built-in scenes' cloth,
/// softened so that the explicit step runs at `EXPLICIT_DT`).
const SPRINGS: &str = "
[springs.stretch]
stiffness = 200.0
damping = 0.05
[springs.shear]
stiffness = 50.0
damping = 0.01
[springs.bend]
stiffness = 1.0
damping = 0.001
";

/// The explicit integrator's step for these springs \[s\]: within
/// symplectic Euler's bound for the stiffest cloth here.
const EXPLICIT_DT: f64 = 5e-4;

/// The implicit and semi-implicit integrators' step \[s\].
const STEP: f64 = 1.0 / 240.0;

/// `integrator`'s step here.
fn dt(integrator: Integrator) -> f64 {
    match integrator {
        Integrator::Explicit => EXPLICIT_DT,
        _ => STEP,
    }
}

/// Every built-in scene written with `[[cloth]]` for `[cloth]` builds the
/// same model and parameters: a world of one cloth is that cloth.
#[test]
fn a_world_of_one_cloth_is_that_cloth() {
    for &name in Scene::builtin_names() {
        let path = Path::new("scenes").join(format!("{name}.toml"));
        let text = std::fs::read_to_string(&path).expect("scene file");
        if !text.contains("\n[cloth]") {
            continue;
        }
        let one = Scene::load(&path).expect("built-in");
        let world =
            Scene::from_toml(&text.replace("\n[cloth]", "\n[[cloth]]"), &path).expect("as a world");
        assert_eq!(world.params, one.params, "{name}");
        assert_eq!(
            world.model().expect("model"),
            one.model().expect("model"),
            "{name}"
        );
    }
}

/// A cloth pinned at its top corners at `x` \[m\] across, `n` × `n`.
fn hanging(n: usize, x: f64, extra: &str) -> String {
    format!(
        "[[cloth]]\nresolution = [{n}, {n}]\nsize = [0.5, 0.5]\norigin = [{x}, 1.0, 0.0]\n\
         orientation = \"vertical\"\nmass = 0.1\npins = [\"top-left\", \"top-right\"]\n{extra}"
    )
}

/// The world's particles of cloth `c` after `steps` of `model` with
/// `integrator`, run in `R`.
fn run_world<R: Real>(
    model: &Model,
    scene: &Scene,
    integrator: Integrator,
    steps: u64,
) -> Vec<[f64; 3]> {
    let params = wgcloth::Params {
        integrator,
        dt: dt(integrator),
        ..scene.params.clone()
    };
    let mut s = CpuSolver::<R>::new(model, &params).expect("solver");
    s.step_n(steps).expect("finite");
    s.state().x.iter().map(|p| p.to_f64()).collect()
}

/// Steps of the cloths-apart comparison.
const APART_STEPS: u64 = 60;

/// Two cloths of different resolutions and springs, far apart, step as
/// each alone does (as a mesh of its triangles): to rounding on the
/// explicit and semi-implicit integrators (their particles' updates and
/// filter rows never mix the cloths, but a step whose fix-up moves either
/// cloth rebuilds every velocity from its displacement), and within the
/// CG's tolerance on the implicit one, whose global dot products mix
/// them.
#[test]
fn cloths_apart_step_as_each_alone() {
    let b_springs = "[cloth.springs.stretch]\nstiffness = 120.0\n";
    let world = scene(&format!(
        "{}{}{SPRINGS}",
        hanging(9, -1.0, ""),
        hanging(13, 1.0, b_springs)
    ));
    let a = scene(&format!("{}{SPRINGS}", hanging(9, -1.0, "")));
    let b = scene(&format!("{}{SPRINGS}", hanging(13, 1.0, b_springs)));
    // Each alone as a model without its grid: a world of several cloths
    // is stepped by the general (adjacency-ordered) kernels and their
    // twins, where a lone grid's sums run in its stencil's order — other
    // roundings, not other physics. Each keeps its coarse levels, as the
    // world's cloths do.
    let (world_model, mut a_model, mut b_model) = (
        world.model().expect("world"),
        a.model().expect("a"),
        b.model().expect("b"),
    );
    a_model.grid = None;
    b_model.grid = None;
    assert_eq!(world_model.cloth_starts, [0, 81]);
    for integrator in [
        Integrator::Explicit,
        Integrator::SemiImplicit,
        Integrator::Implicit,
    ] {
        let steps = match integrator {
            Integrator::Explicit => 8 * APART_STEPS,
            _ => APART_STEPS,
        };
        let together = run_world::<f64>(&world_model, &world, integrator, steps);
        let alone: Vec<[f64; 3]> = run_world::<f64>(&a_model, &a, integrator, steps)
            .into_iter()
            .chain(run_world::<f64>(&b_model, &b, integrator, steps))
            .collect();
        let worst = together
            .iter()
            .zip(&alone)
            .map(|(p, q)| (DVec3::from_array(*p) - DVec3::from_array(*q)).length())
            .fold(0.0, f64::max);
        let bound = match integrator {
            Integrator::Implicit => IMPLICIT_APART,
            _ => REBUILT_APART,
        };
        assert!(
            worst <= bound,
            "{integrator}: the world's cloths {worst} m from each alone, above {bound}"
        );
    }
}

/// Mean CG iterations a step of `model` under `scene`'s parameters made
/// implicit at dt 0.02 s (the article's), over `steps` steps in `f32`.
fn mean_cg_iterations(model: &Model, scene: &Scene, steps: u32) -> f64 {
    let params = wgcloth::Params {
        integrator: Integrator::Implicit,
        dt: 0.02,
        ..scene.params.clone()
    };
    let mut s = CpuSolver::<f32>::new(model, &params).expect("solver");
    let total: u32 = (0..steps)
        .map(|_| s.step().expect("finite").cg_iterations)
        .sum();
    f64::from(total) / f64::from(steps)
}

/// How many more CG iterations a step of a world of two grid cloths may
/// take than the slower cloth alone, as a fraction: CG on two uncoupled
/// systems at once must resolve both spectra, a little more than the
/// slower's alone (measured 4 % for the 33² and 25² cloths here, under
/// 1 % for two 65² ones); without coarse levels on the world, 39 % more.
const WORLD_CG_EXTRA: f64 = 0.1;

/// A world of grid cloths keeps each cloth's coarse levels: its CG
/// iterates as often as its slower cloth alone.
#[test]
fn a_world_of_grids_iterates_as_its_cloths_alone() {
    let (a_text, b_text) = (hanging(33, -1.0, ""), hanging(25, 1.0, ""));
    let world = scene(&format!("{a_text}{b_text}{SPRINGS}"));
    let a = scene(&format!("{a_text}{SPRINGS}"));
    let b = scene(&format!("{b_text}{SPRINGS}"));
    const STEPS: u32 = 20;
    let alone = [&a, &b]
        .map(|s| mean_cg_iterations(&s.model().expect("model"), s, STEPS))
        .into_iter()
        .fold(0.0, f64::max);
    let together = mean_cg_iterations(&world.model().expect("world"), &world, STEPS);
    assert!(
        together <= alone * (1.0 + WORLD_CG_EXTRA),
        "the world iterates {together} times a step, the slower cloth alone {alone}"
    );
}

/// How far the widest of `seams` stands open at positions `x` \[m\].
fn widest_seam(seams: &[wgcloth::world::SeamSpring], x: &[wgcloth::real::Vec3<f64>]) -> f64 {
    seams
        .iter()
        .map(|seam| (x[seam.a as usize] - x[seam.b as usize]).length())
        .fold(0.0, f64::max)
}

/// How far the explicit and semi-implicit world's cloths may end from
/// each alone \[m\]: a rebuilt velocity `(x* − x) / dt` differs from `v*`
/// by a few ulps of the step's displacement, a position by a few ulps of
/// its metre (2.2e-16 m each) a step; 480 steps of 4 ulps each are 4e-13
/// m, and 1e-12 m leaves room for the stable cloth to carry them
/// (measured 3.2e-15 m).
const REBUILT_APART: f64 = 1e-12;

/// How far the implicit world's cloths may end from each alone \[m\]:
/// each step's CG stops at a relative residual of `tolerance` (1e-4 by
/// default) over the *world's* right-hand side rather than each cloth's,
/// so either solve may stop a different iteration early: an error in Δv
/// of up to that fraction of a step's velocity change (gravity's 9.81 ×
/// dt ≈ 0.04 m/s at 1/240 s), 4e-6 m/s, 2e-8 m of position a step; 60
/// steps of them are 1e-6 m, doubled for the two solves (measured 6e-8 m).
/// A cloth given another's springs ends millimetres away.
const IMPLICIT_APART: f64 = 2e-6;

/// Two cloths dropped flat onto a ball, one above the other, the upper
/// smaller and denser, with self-collision.
fn stack(integrator: Integrator, self_collision: bool) -> Scene {
    let cloth = |n: usize, size: f64, y: f64, mass: f64| {
        format!(
            "[[cloth]]\nresolution = [{n}, {n}]\nsize = [{size}, {size}]\n\
             origin = [{}, {y}, {}]\norientation = \"horizontal\"\nmass = {mass}\npins = []\n",
            -size / 2.0,
            -size / 2.0
        )
    };
    let collide = if self_collision {
        "[self_collision]\n"
    } else {
        ""
    };
    scene(&format!(
        "[simulation]\nintegrator = \"{integrator}\"\ndt = {}\n{}{}{SPRINGS}\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 0.15\n{collide}",
        dt(integrator),
        cloth(17, 0.5, 0.2, 0.05),
        cloth(11, 0.3125, 0.26, 0.04)
    ))
}

/// Simulated time of the stack's drop \[s\]: the lower cloth lands at
/// about 0.1 s, the upper on it by 0.15 s, and both drape the ball.
const STACK_SECONDS: f64 = 0.5;

/// The crossings between the two cloths of a stack at `x`: edges of one
/// through triangles of the other.
fn crossings_between(model: &Model, edges: &[[u32; 2]], x: &[DVec3]) -> usize {
    let cloth = |p: u32| usize::from(p >= model.cloth_starts[1]);
    crossing_pairs(model, edges, x)
        .into_iter()
        .filter(|(e, t)| cloth(e[0]) != cloth(t[0]))
        .count()
}

/// Runs the stack in `R`, checking every step that no edge of one cloth
/// crosses a triangle of the other; returns the most crossings seen at a
/// step and the upper cloth's lowest height at the end \[m\].
fn drop_stack<R: Real>(scene: &Scene) -> (usize, f64) {
    let model = scene.model().expect("model");
    let edges = edges(&model);
    let mut s = CpuSolver::<R>::new(&model, &scene.params).expect("solver");
    let steps = (STACK_SECONDS / scene.params.dt).round() as u64;
    let mut most = 0;
    for _ in 0..steps {
        s.step().expect("finite");
        let x: Vec<DVec3> = s
            .state()
            .x
            .iter()
            .map(|p| DVec3::from_array(p.to_f64()))
            .collect();
        most = most.max(crossings_between(&model, &edges, &x));
    }
    let upper = model.cloth_starts[1] as usize;
    let lowest = s.state().x[upper..]
        .iter()
        .map(|p| p.to_f64()[1])
        .fold(f64::INFINITY, f64::min);
    (most, lowest)
}

#[test]
fn cloths_dropped_onto_each_other_never_pass_through() {
    for integrator in [
        Integrator::Implicit,
        Integrator::SemiImplicit,
        Integrator::Explicit,
    ] {
        let s = stack(integrator, true);
        for (precision, (crossed, lowest)) in [
            ("f64", drop_stack::<f64>(&s)),
            ("f32", drop_stack::<f32>(&s)),
        ] {
            assert_eq!(
                crossed, 0,
                "{integrator} {precision}: an edge of one cloth through the other"
            );
            // The upper cloth rests on the lower, on the ball (radius
            // 0.15 m): not fallen through to the floor below it.
            assert!(
                lowest > 0.0,
                "{integrator} {precision}: the upper cloth fell to {lowest} m"
            );
        }
    }
    // Without contact between them the upper cloth falls through the
    // lower: the check above can fail.
    let (crossed, _) = drop_stack::<f64>(&stack(Integrator::Implicit, false));
    assert!(
        crossed > 0,
        "without self-collision the cloths should cross"
    );
}

/// A tube sewn from two panels facing each other `apart` \[m\] apart, the
/// first hung by its top corners, the second by the seams alone: its two
/// side seams zip each panel's left edge to the other's, and right to
/// right.
fn tube(integrator: Integrator, apart: f64) -> Scene {
    tube_with(integrator, apart, "")
}

/// The tube of [`tube`] with self-collision: its panels, laid closer than
/// a thickness, pushed apart everywhere but at and around the seams.
fn tube_with_self_collision(integrator: Integrator, apart: f64) -> Scene {
    tube_with(integrator, apart, "[self_collision]\n")
}

/// The tube of [`tube`], the scene ending with `extra`.
fn tube_with(integrator: Integrator, apart: f64, extra: &str) -> Scene {
    let panel = |z: f64, pins: &str| {
        format!(
            "[[cloth]]\nresolution = [9, 17]\nsize = [0.25, 0.5]\norigin = [-0.125, 1.0, {z}]\n\
             orientation = \"vertical\"\nmass = 0.05\npins = [{pins}]\n"
        )
    };
    scene(&format!(
        "[simulation]\nintegrator = \"{integrator}\"\ndt = {}\n{}{}{SPRINGS}\
         [[seam]]\na = {{ cloth = 0, edge = \"left\" }}\nb = {{ cloth = 1, edge = \"left\" }}\n\
         [[seam]]\na = {{ cloth = 0, edge = \"right\" }}\nb = {{ cloth = 1, edge = \"right\" }}\n{extra}",
        dt(integrator),
        panel(-apart / 2.0, "\"top-left\", \"top-right\""),
        panel(apart / 2.0, "")
    ))
}

/// How far apart the tube's panels are laid out \[m\]: its seams start
/// open, and close.
const TUBE_APART: f64 = 0.02;

/// How far apart the tube's panels are laid out with self-collision \[m\]:
/// more than its thickness (the rest spacing, 3.125 cm), as a scene must
/// start: panels laid closer are thrown apart in the first step.
const TUBE_APART_CONTACT: f64 = 0.04;

/// The bound on a seam at rest \[m\]: closed to within a
/// millimetre (measured 0.02–0.2 mm: the seam's own springs, as stiff as
/// the fabric's, carry the panel's weight below them over 17 springs).
const SEAM_GAP: f64 = 1e-3;

/// How far a seam may stand open with self-collision, in thicknesses: a
/// tenth, so that the seam is a line rather than a slit as wide as the
/// fabric is thick. The contact holds the two panels a thickness apart
/// across the fold the seam makes, and that pulls on the seam's springs
/// (measured 1.5–1.7 mm at the tube's 3.1 cm; with the seam's two sides
/// not excluded from contact, 33 mm: the seam held a thickness open).
const SEAM_GAP_CONTACT_THICKNESSES: f64 = 0.1;

/// Simulated time of the tube's hanging \[s\]: its seams close within a
/// few tenths of a second and its swing settles.
const TUBE_SECONDS: f64 = 2.0;

/// The tube's seams close, with self-collision too: a seam's two sides
/// (and their neighbours across it) are excluded from contact, so the
/// contact that holds the panels a thickness apart does not hold the seam
/// open (without the exclusion of seam partners: a seam a thickness open).
#[test]
fn a_tube_sewn_from_two_panels_closes_its_seams() {
    for (integrator, self_collision) in [
        Integrator::Implicit,
        Integrator::SemiImplicit,
        Integrator::Explicit,
    ]
    .into_iter()
    .flat_map(|i| [(i, false), (i, true)])
    {
        let s = if self_collision {
            tube_with_self_collision(integrator, TUBE_APART_CONTACT)
        } else {
            tube(integrator, TUBE_APART)
        };
        let integrator = format!("{integrator}, self-collision {self_collision}");
        assert_eq!(s.seams.len(), 2 * 17);
        let model = s.model().expect("model");
        let steps = (TUBE_SECONDS / s.params.dt).round() as u64;
        let solver = run_checked_f64(&model, &s.params, steps);
        let x = &solver.state().x;
        let gap = widest_seam(&s.seams, x);
        let bound = match wgcloth::self_collision::thickness(&model, &s.params) {
            Ok(Some(t)) => SEAM_GAP.max(SEAM_GAP_CONTACT_THICKNESSES * t),
            _ => SEAM_GAP,
        };
        assert!(
            gap <= bound,
            "{integrator}: a seam {gap} m open, above {bound}"
        );
        // The second panel, held by the seams alone, hangs from them: its
        // top corners where the first panel's pins hold theirs.
        let top = x[153..]
            .iter()
            .map(|p| p.y)
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            top >= 1.0 - SEAM_GAP,
            "{integrator}: the sewn panel's top at {top} m, below its seams"
        );
    }
}

/// Steps of the GPU worlds against their mirror.
const GPU_STEPS: u32 = 40;

/// The stack (two cloths, self-collision, a ball) and the tube (seams,
/// self-collision) on the GPU: the `f32` mirror's state under the agreement policy on
/// both step paths, every integrator; and a batch of both worlds steps
/// each as a lone solver does.
#[test]
fn the_gpu_steps_a_world_as_its_mirror() {
    use wgcloth::gpu::{GpuBatch, GpuSolver, StepPath};
    let worlds: Vec<(String, Scene)> = [
        Integrator::Implicit,
        Integrator::SemiImplicit,
        Integrator::Explicit,
    ]
    .into_iter()
    .flat_map(|i| {
        [
            (format!("stack, {i}"), stack(i, true)),
            (
                format!("tube, {i}"),
                tube_with_self_collision(i, TUBE_APART_CONTACT),
            ),
        ]
    })
    .map(|(what, mut s)| {
        // The GPU's fix-up is Jacobi's: the mirror's must be too.
        s.params.fixup.method = FixupMethod::Jacobi;
        (what, s)
    })
    .collect();
    for (what, s) in &worlds {
        let model = s.model().expect("model");
        assert_both_paths_agree(what, &model, &s.params, GPU_STEPS);
    }
    let ctx = gpu_common::gpu();
    let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    let members: Vec<_> = worlds
        .iter()
        .map(|(_, s)| {
            let model = s.model().expect("model");
            let id = batch.add(&model, &s.params).expect("added");
            (id, model)
        })
        .collect();
    batch.step(GPU_STEPS).expect("batch run");
    for ((what, s), (id, model)) in worlds.iter().zip(&members) {
        let mut lone = GpuSolver::with_step_path(
            ctx.kernels(),
            &ctx.queue,
            model,
            &s.params,
            StepPath::Workgroup,
        )
        .expect("lone solver");
        lone.step(GPU_STEPS).expect("lone run");
        let (n, p) = differing(
            &batch.read_state(*id).expect("batch read-back").x,
            &lone.read_state().expect("lone read-back").x,
        );
        assert_eq!(
            n, 0,
            "{what}: {n} positions differ from the lone solver's, the first {p:?}"
        );
    }
}

#[test]
fn bad_worlds_are_refused_naming_the_keys() {
    let two = format!("{}{}", hanging(9, -1.0, ""), hanging(13, 1.0, ""));
    for (extra, says) in [
        (
            "[[seam]]\na = { cloth = 0, edge = \"left\" }\nb = { cloth = 1, edge = \"right\" }\n",
            "`seam[0].a` has 9 particles, `seam[0].b` 13",
        ),
        (
            "[[seam]]\na = { cloth = 2, edge = \"left\" }\nb = { cloth = 1, edge = \"right\" }\n",
            "seam[0].a.cloth",
        ),
        (
            "[[seam]]\na = { cloth = 0, edge = \"middle\" }\nb = { cloth = 1, edge = \"left\" }\n",
            "seam[0].a.edge",
        ),
        (
            "[[seam]]\na = { cloth = 0, vertices = [1, 81] }\nb = { cloth = 1, vertices = [0, 1] }\n",
            "seam[0].a.vertices[1]",
        ),
        (
            "[[seam]]\na = { cloth = 0, edge = \"left\", vertices = [0] }\nb = { cloth = 1, edge = \"left\" }\n",
            "exactly one of `edge`, `vertices` and `box`",
        ),
        ("[[render_mesh]]\nfile = \"x.obj\"\ncloth = 2\n", "`render_mesh[0].cloth` = 2"),
    ] {
        let e = refusal(&format!("{two}{extra}"));
        assert!(e.contains("world.toml") && e.contains(says), "{extra}: {e}");
    }
    // Keys of one cloth of the two, named by its place.
    let first = || hanging(9, -1.0, "");
    let second = |extra: &str| hanging(13, 1.0, extra);
    for (text, says) in [
        (
            first() + &second("").replace("\"top-right\"]", "\"top-right\", 500]"),
            "cloth[1].pins[2]",
        ),
        (
            first() + &second("[cloth.springs.stretch]\nmax_stretch = 1.1\n"),
            "cloth[1].springs.stretch.max_stretch",
        ),
        (
            first() + &second("[cloth.material]\ndensity = 0.2\n"),
            "`cloth[1].mass` conflicts with `[cloth[1].material]`",
        ),
        (
            first() + &second("[cloth.springs.shear]\nstiffness = -1.0\n"),
            "cloth[1].springs.shear.stiffness",
        ),
        (
            hanging(9, -1.0, "color = [1.0, 0.5, 2.0]\n") + &second(""),
            "cloth[0].color[2]",
        ),
    ] {
        let e = refusal(&text);
        assert!(e.contains(says), "{e}");
    }
}

/// Frames a second of the skirt's animation: `wgcloth render`'s default.
const SKIRT_FPS: f64 = 30.0;

/// Simulated time the skirt's character stands still \[s\]: its first two
/// keys (the `cape`'s path).
const SKIRT_STANDING: f64 = 0.6;

/// The built-in `skirt` on the CPU in `f64`, its character playing its
/// keys frame by frame: no blow-up (the divergence rule each step); its
/// seams closed to within `SEAM_GAP` by the end of the standing, and to
/// within `SKIRT_RUNNING_GAP` while it jogs and turns (the waistband's
/// pairs, pinned on both sides, move as one).
#[test]
fn the_skirt_keeps_its_seams_on_the_running_character() {
    let scene = Scene::builtin("skirt").expect("built in");
    let model = scene.model().expect("model");
    let animation = scene.animation(&model).expect("a character");
    let mut s = CpuSolver::<f64>::new(&model, &scene.params).expect("solver");
    let rule = common::divergence_rule(&model, &scene.params, &s);
    let frame = 1.0 / SKIRT_FPS;
    let steps = (frame / scene.params.dt).round() as u64;
    let frames = (scene.duration * SKIRT_FPS).round() as u64;
    let (mut standing, mut running) = (f64::NAN, 0.0f64);
    for f in 0..frames {
        let t = f as f64 * frame;
        animation.apply(&mut s, t, frame).expect("a pose");
        for _ in 0..steps {
            if let Err(e) = s.step().and_then(|_| s.check_divergence(&rule)) {
                panic!("frame {f}: {e}");
            }
        }
        let x = &s.state().x;
        let gap = widest_seam(&scene.seams, x);
        if t + frame <= SKIRT_STANDING + 1e-9 {
            standing = gap;
        } else {
            running = running.max(gap);
        }
    }
    assert!(standing <= SEAM_GAP, "standing: a seam {standing} m open");
    assert!(
        running <= SKIRT_RUNNING_GAP,
        "running: a seam {running} m open"
    );
}

/// How far a seam of the running skirt may open \[m\]: a tenth of the
/// panels' row spacing (5 cm from waist to hem in 10 rows), so that the
/// seam stays a line rather than a slit (measured 1.1 mm as the character
/// turns; seams a tenth as stiff as the fabric open 9 mm).
const SKIRT_RUNNING_GAP: f64 = 5e-3;

/// The fix-up holds a seam: the seams of a tube whose panels rest
/// together, made soft (1 N/m, where the panel's weight opens them by
/// centimetres), stay within
/// `SEAM_FIXUP_LIMIT` at the end of every explicit and semi-implicit step
/// (the fix-up runs last), up to the rounding of the positions it moves;
/// and open past it without the fix-up.
#[test]
fn the_fixup_holds_a_soft_seam_within_its_limit() {
    use wgcloth::model::SEAM_FIXUP_LIMIT;
    for integrator in [Integrator::Explicit, Integrator::SemiImplicit] {
        let mut s = tube(integrator, 0.0);
        for seam in &mut s.seams {
            seam.stiffness = Some(1.0);
        }
        let model = s.model().expect("model");
        let gap = |params: &wgcloth::Params| {
            let steps = (TUBE_SECONDS / params.dt).round() as u64;
            let mut solver = CpuSolver::<f64>::new(&model, params).expect("solver");
            let mut widest = 0.0f64;
            for _ in 0..steps {
                solver.step().expect("finite");
                widest = widest.max(widest_seam(&s.seams, &solver.state().x));
            }
            widest
        };
        let held = gap(&s.params);
        assert!(
            held <= SEAM_FIXUP_LIMIT + FIXUP_ROUNDING,
            "{integrator}: a soft seam {held} m open under the fix-up"
        );
        let mut free = s.params.clone();
        free.fixup.iterations = 0;
        let open = gap(&free);
        assert!(
            open > 10.0 * SEAM_FIXUP_LIMIT,
            "{integrator}: without the fix-up the soft seam should open (it opened {open} m)"
        );
    }
}

/// How far past its limit a corrected seam may end \[m\]: the fix-up puts
/// its ends on the limit up to the rounding of their coordinates (about
/// 1 m here: 2.2e-16 m an ulp), a few ulps (measured 1.1e-16 m).
const FIXUP_ROUNDING: f64 = 1e-15;
