//! Moving bodies are not a blow-up: a ball rolling into a falling cloth,
//! a bar sweeping through a hanging one and a running character carrying
//! a cape put energy into the cloth, which the divergence rule bounds
//! ([`Divergence::motion_work`]) on every integrator, on the CPU and the
//! GPU, as the solvers move the bodies — while the same scenes made far
//! too stiff for their step still blow up, and are caught near the step
//! the rule without moving bodies would catch them.

use std::path::Path;

use wgcloth::cpu::CpuSolver;
use wgcloth::diagnostics::{self, Divergence, Motion, CHECK_EVERY};
use wgcloth::glam::DVec3;
use wgcloth::params::{Capsule, PinTarget};
use wgcloth::scene::animation::Animated;
use wgcloth::{Error, GpuSolver, Integrator, Model, Scene};

use crate::cli_common::{assert_status, stderr, wgcloth, TempDir, EXIT_BLEW_UP, LAVAPIPE};
use crate::gpu_common::gpu;

/// A 9 × 9 cloth (1 m, 0.3 kg) let fall from 0.2 m, implicit at 1 ms,
/// for `duration` \[s\], with the scene's other tables `bodies`.
fn falling(duration: f64, bodies: &str) -> String {
    format!(
        r#"
[simulation]
integrator = "implicit"
dt = 0.001
gravity = [0.0, -9.81, 0.0]
duration = {duration}

[cloth]
resolution = [9, 9]
size = [1.0, 1.0]
origin = [-0.5, 0.2, -0.5]
orientation = "horizontal"
mass = 0.3
pins = []
{bodies}"#
    )
}

/// The issue's ball: the [`falling`] cloth onto a ground of friction 1, a
/// 0.25 m ball of friction 1 rolling at 2 m/s into its edge. It lifts the
/// edge onto its top and carries it: before the rule counted moving
/// bodies this exited 3 at step 470 (2.19 J against the bound's 2.06 J).
fn ball() -> String {
    falling(
        1.0,
        r#"
[ground]
height = 0.0
friction = 1.0

[[sphere]]
center = [-0.7, 0.25, 0.0]
radius = 0.25
friction = 1.0
velocity = [2.0, 0.0, 0.0]
"#,
    )
}

/// A bar (a capsule of 5 cm radius, 2 m long) sweeping up and sideways
/// at 3 m/s under the [`falling`] cloth: it catches the cloth, which
/// drapes over it, and lifts it a metre.
fn bar() -> String {
    falling(
        0.5,
        r#"
[[capsule]]
a = [-0.3, -0.3, -1.0]
b = [-0.3, -0.3, 1.0]
radius = 0.05
friction = 1.0
velocity = [1.0, 2.8284271247, 0.0]
"#,
    )
}

/// A 9 × 9 cape pinned along its top edge to a character that stands,
/// sprints at 10 m/s, turns towards +x at about 7 m/s and stops dead: the
/// pins drag the cape along, the body knocks it, the stop flings it on.
const RUNNER: &str = r#"
[simulation]
integrator = "implicit"
dt = 0.001
gravity = [0.0, -9.81, 0.0]
duration = 1.0

[cloth]
resolution = [9, 9]
size = [0.56, 0.95]
origin = [-0.28, 1.42, -0.2]
orientation = "vertical"
mass = 0.25
pins = [{ box = [[-1.0, 1.41, -1.0], [1.0, 1.43, 1.0]] }]

[springs.stretch]
stiffness = 800.0
damping = 0.2

[springs.shear]
stiffness = 150.0
damping = 0.05

[springs.bend]
stiffness = 2.0
damping = 0.001

[ground]
height = 0.0
friction = 0.6

[character]

[[character.capsule]]
a = [0.0, 0.85, 0.0]
b = [0.0, 1.3, 0.0]
radius = 0.17
friction = 0.8

[[character.key]]
time = 0.0
position = [0.0, 0.0, 0.0]
yaw = 0.0

[[character.key]]
time = 0.2
position = [0.0, 0.0, 0.0]
yaw = 0.0

[[character.key]]
time = 0.5
position = [0.0, 0.0, 3.0]
yaw = 0.0

[[character.key]]
time = 0.8
position = [2.0, 0.0, 3.5]
yaw = 90.0
"#;

/// The capsule of the [`RUNNER`]'s body.
const BODY: &str = r#"
[[character.capsule]]
a = [0.0, 0.85, 0.0]
b = [0.0, 1.3, 0.0]
radius = 0.17
friction = 0.8
"#;

/// The scenes, by name: the runner also without its body, the cape
/// carried by its pins alone (so that the pins' record, not the body's,
/// is what lets it pass).
fn scenes() -> [(&'static str, String); 4] {
    assert!(RUNNER.contains(BODY), "the runner's body as BODY spells it");
    [
        ("ball", ball()),
        ("bar", bar()),
        ("runner", RUNNER.into()),
        ("carried", RUNNER.replace(BODY, "")),
    ]
}

/// Far too stiff for 1 ms: stretch springs of 10⁶ N/m on particles of
/// 3–4 g give `ω·dt ≈ 30` for the explicit integrator (stable below 2).
const TOO_STIFF: f64 = 1e6;

/// The most steps after the rule without moving bodies would catch a
/// blow-up that the rule with them may take: one check interval more (the
/// motion term, a few joules to tens of joules, is passed a few steps after
/// the static bound by an energy that grows geometrically).
const CATCH_DELAY: u64 = CHECK_EVERY;

/// One frame of the drivers: the character's poses are applied every
/// check interval.
const FRAME_STEPS: u32 = CHECK_EVERY as u32;

/// `scene` with `integrator` and, with `stiffness`, stretch springs that
/// stiff.
fn scene(text: &str, integrator: Integrator, stiffness: Option<f64>) -> Scene {
    let mut scene = Scene::from_toml(text, Path::new("test.toml")).expect("a valid test scene");
    scene.params.integrator = integrator;
    if let Some(k) = stiffness {
        scene.params.springs[0].stiffness = k;
    }
    scene
}

/// What the drivers need of both solvers.
trait Driven: Animated {
    /// Runs `n` steps (an error: a non-finite state).
    fn advance(&mut self, n: u32) -> wgcloth::Result<()>;
    /// The solver's own check; the state it judged, in `f64`.
    fn judge(&self, rule: &Divergence) -> wgcloth::Result<(Vec<DVec3>, Vec<DVec3>)>;
    /// The solver's record of its moving bodies.
    fn bodies(&self) -> &Motion;
    /// Simulated time \[s\].
    fn now(&self) -> f64;
}

impl Driven for CpuSolver<f64> {
    fn advance(&mut self, n: u32) -> wgcloth::Result<()> {
        self.step_n(n.into()).map(|_| ())
    }
    fn judge(&self, rule: &Divergence) -> wgcloth::Result<(Vec<DVec3>, Vec<DVec3>)> {
        self.check_divergence(rule)?;
        Ok((self.positions(), self.velocities()))
    }
    fn bodies(&self) -> &Motion {
        self.motion()
    }
    fn now(&self) -> f64 {
        self.time()
    }
}

impl Driven for GpuSolver {
    fn advance(&mut self, n: u32) -> wgcloth::Result<()> {
        self.step(n).map(|_| ())
    }
    fn judge(&self, rule: &Divergence) -> wgcloth::Result<(Vec<DVec3>, Vec<DVec3>)> {
        let s = self.check_divergence(rule)?;
        let f64s = |v: Vec<wgcloth::glam::Vec3>| v.into_iter().map(|p| p.as_dvec3()).collect();
        Ok((f64s(s.x), f64s(s.v)))
    }
    fn bodies(&self) -> &Motion {
        self.motion()
    }
    fn now(&self) -> f64 {
        self.time()
    }
}

/// How a driven run ended.
#[derive(Debug)]
struct Ran {
    /// `Ok`, or the blow-up the solver's check reported.
    result: wgcloth::Result<()>,
    /// A check at which the state's energy was past the bound without the
    /// motion term (the term was needed), if any: (step, total \[J\],
    /// bound without the term \[J\]).
    needed: Option<(u64, f64, f64)>,
    /// The first check the rule without moving bodies would have failed.
    static_fail: Option<u64>,
}

/// Drives `solver` through `scene` to its end as a game would: the
/// character (if any) applied every frame, the solver's own divergence
/// check after each.
fn drive(solver: &mut impl Driven, scene: &Scene, model: &Model) -> Ran {
    let params = &scene.params;
    let x0: Vec<DVec3> = model.rest_positions.clone();
    let v0 = vec![DVec3::ZERO; x0.len()];
    let rule = Divergence::new(model, params, 0.0, &x0, &v0);
    let still = Motion::new(model, &{
        let mut p = params.clone();
        p.spheres.iter_mut().for_each(|s| s.velocity = DVec3::ZERO);
        p.capsules.iter_mut().for_each(|c| c.velocity = DVec3::ZERO);
        p
    });
    let animation = scene.animation(model);
    let frame = f64::from(FRAME_STEPS) * params.dt;
    let frames = (scene.duration / frame).round() as u64;
    let mut ran = Ran {
        result: Ok(()),
        needed: None,
        static_fail: None,
    };
    for k in 0..frames {
        let step = (k + 1) * CHECK_EVERY;
        let stepped = animation
            .as_ref()
            .map_or(Ok(()), |a| a.apply(solver, solver.now(), frame))
            .and_then(|()| solver.advance(FRAME_STEPS));
        let judged = stepped.and_then(|()| solver.judge(&rule));
        let (x, v) = match judged {
            Ok(s) => s,
            Err(e) => {
                ran.result = Err(e);
                return ran;
            }
        };
        let time = solver.now();
        let total = diagnostics::energy(model, params, &x, &v).total();
        let without =
            rule.energy_limit_with(time, solver.bodies()) - rule.motion_work(time, solver.bodies());
        if total > without && ran.needed.is_none() {
            ran.needed = Some((step, total, without));
        }
        if rule.crossed_with(time, &x, &v, &still).is_some() && ran.static_fail.is_none() {
            ran.static_fail = Some(step);
        }
    }
    ran
}

/// Runs `scene` on the CPU (`f64`) and the GPU (lavapipe).
fn both(scene: &Scene) -> [(&'static str, Ran); 2] {
    let model = scene.model().expect("the test scene builds");
    let mut cpu = CpuSolver::<f64>::new(&model, &scene.params).expect("valid parameters");
    let mut gpu = GpuSolver::with_kernels(gpu().kernels(), &gpu().queue, &model, &scene.params)
        .expect("a GPU solver");
    [
        ("cpu", drive(&mut cpu, scene, &model)),
        ("gpu", drive(&mut gpu, scene, &model)),
    ]
}

#[test]
fn a_ball_a_bar_and_a_runner_moving_a_cloth_are_no_blow_up_on_any_integrator_or_backend() {
    for (name, text) in scenes() {
        let mut needed = Vec::new();
        for integrator in Integrator::ALL {
            for (backend, ran) in both(&scene(&text, integrator, None)) {
                let row = format!("{name}, {integrator}, {backend}");
                eprintln!("{row}: {ran:?}");
                if let Err(e) = &ran.result {
                    panic!("{row}: a physical run was called a blow-up: {e}");
                }
                needed.extend(ran.needed.map(|n| (row, n)));
            }
        }
        // The motion term is what let the scene pass: without it the rule
        // would have stopped it.
        assert!(
            !needed.is_empty(),
            "{name}: no run went past the bound without moving bodies"
        );
    }
}

#[test]
fn the_same_scenes_far_too_stiff_still_blow_up_near_the_step_the_rule_without_motion_says() {
    for (name, text) in scenes() {
        let scene = scene(&text, Integrator::Explicit, Some(TOO_STIFF));
        for (backend, ran) in both(&scene) {
            let row = format!("{name} at {TOO_STIFF} N/m, {backend}");
            eprintln!("{row}: {ran:?}");
            let step = match &ran.result {
                Err(Error::Diverged { step, .. } | Error::NonFinite { step, .. }) => *step,
                other => panic!("{row}: expected a blow-up, got {other:?}"),
            };
            // Every check before passed the rule without moving bodies too
            // (`static_fail` is `None`), or the blow-up is caught within
            // CATCH_DELAY of the first check that rule failed.
            if let Some(first) = ran.static_fail {
                assert!(
                    step <= first + CATCH_DELAY,
                    "{row}: caught at step {step}, {} steps after the rule without motion",
                    step - first
                );
            }
            // The f64 reference is caught while still finite.
            if backend == "cpu" {
                assert!(
                    matches!(ran.result, Err(Error::Diverged { .. })),
                    "{row}: {:?}",
                    ran.result
                );
            }
        }
    }
}

#[test]
fn pins_count_their_speed_and_rise_and_colliders_only_while_they_move() {
    let scene = scene(RUNNER, Integrator::Implicit, None);
    let model = scene.model().expect("builds");
    let mut cpu = CpuSolver::<f64>::new(&model, &scene.params).expect("valid");
    let x0 = model.rest_positions.clone();
    let v0 = vec![DVec3::ZERO; x0.len()];
    let rule = Divergence::new(&model, &scene.params, 0.0, &x0, &v0);
    assert_eq!(
        rule.motion_work(0.0, cpu.motion()),
        0.0,
        "nothing moves yet"
    );
    // The character's body, at rest, goes: nothing moved.
    cpu.set_capsules(&[]).expect("valid");
    assert_eq!(cpu.motion().reach(0.0).top, f64::NEG_INFINITY);
    // Every pin 0.1 m up over 10 ms: 10 m/s and a 0.1 m rise.
    let targets: Vec<PinTarget> = (0..model.particle_count())
        .filter(|&p| model.pinned[p])
        .map(|p| PinTarget {
            particle: p,
            position: (x0[p] + DVec3::new(0.0, 0.1, 0.0)).as_vec3(),
        })
        .collect();
    cpu.set_pin_targets(&targets, 0.01).expect("valid targets");
    let reach = cpu.motion().reach(0.0);
    assert!((reach.speed - 10.0).abs() < 1e-4, "{reach:?}");
    assert!((reach.rise - 0.1).abs() < 1e-6, "{reach:?}");
    // A capsule with a velocity counts its speed; one at rest nothing.
    let still = Capsule {
        a: DVec3::new(0.0, 3.0, 0.0),
        b: DVec3::new(0.0, 3.0, 0.0),
        radius: 0.1,
        friction: 0.0,
        velocity: DVec3::ZERO,
    };
    cpu.set_capsules(&[still]).expect("valid");
    assert_eq!(cpu.motion().reach(0.0).top, f64::NEG_INFINITY);
    // The same capsule set 1 m higher has jumped: its top counts, at no
    // speed (no time passed).
    let jumped = Capsule {
        a: still.a + DVec3::Y,
        b: still.b + DVec3::Y,
        ..still
    };
    cpu.set_capsules(&[jumped]).expect("valid");
    assert!((cpu.motion().reach(0.0).top - 4.1).abs() < 1e-12);
    assert!((cpu.motion().reach(0.0).speed - 10.0).abs() < 1e-4);
    cpu.set_capsules(&[Capsule {
        velocity: DVec3::new(0.0, 0.0, 20.0),
        ..still
    }])
    .expect("valid");
    let reach = cpu.motion().reach(0.0);
    assert_eq!(reach.speed, 20.0);
    // Back at 3.1 m, moving 20 m/s along z: 0.1 s later still at 3.1 m.
    assert!(
        (cpu.motion().reach(0.1).top - 4.1).abs() < 1e-12,
        "the jump's top is kept"
    );
    // The bound: the free cloth carried at 20 m/s, and lifted from its
    // lowest particle to the highest top (4.1 m).
    let w = rule.motion_work(0.0, cpu.motion());
    let free: f64 = (0..model.particle_count())
        .filter(|&p| !model.pinned[p])
        .map(|p| model.mass[p])
        .sum();
    let lowest = x0.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let least = 0.5 * free * 400.0 + 0.25 * 9.81 * (4.1 - lowest);
    assert!(w > least, "{w} J against at least {least} J");
}

#[test]
fn the_cli_runs_the_ball_and_the_bar_on_the_gpu_and_stops_them_too_stiff() {
    for (name, text) in [("ball", ball()), ("bar", bar())] {
        let dir = TempDir::new(&format!("moving-{name}"));
        let fine = dir.write("scene.toml", &text);
        let stiff = dir.write(
            "stiff.toml",
            &format!(
                "{}\n[springs.stretch]\nstiffness = {TOO_STIFF:e}\n",
                text.replace("\"implicit\"", "\"explicit\"")
            ),
        );
        for (path, status) in [(fine, 0), (stiff, EXIT_BLEW_UP)] {
            let path = path.to_str().expect("a UTF-8 temp path");
            let out = wgcloth(&["run", path, "--backend", "gpu", "--adapter", LAVAPIPE]);
            assert_status(&out, status);
            if status == EXIT_BLEW_UP {
                let err = stderr(&out);
                assert!(err.contains("blew up at step"), "{name}: {err}");
            }
        }
    }
}
