//! A finite blow-up on every backend: a cloth whose state stays finite but
//! whose energy or strain has run away is a blow-up (exit status 3, the
//! step and the bound in the message, no output written), reported at the
//! same step by the CPU in `f64` and `f32` and by the GPU where their
//! arithmetic allows; a soft cloth and a flag fed by wind are not.

use std::path::{Path, PathBuf};
use std::process::Output;

use wgcloth::cpu::CpuSolver;
use wgcloth::diagnostics::{self, Divergence, CHECK_EVERY, DIVERGED_STRAIN, ENERGY_MARGIN};
use wgcloth::{Integrator, Scene};

use crate::cli_common::{
    assert_status, names_in, stderr, stdout, wgcloth, TempDir, EXIT_BLEW_UP, LAVAPIPE,
};

/// The `hanging` scene at `resolution`² particles and `dt` \[s\], with the
/// GPU's Jacobi fix-up so that the CPU's `f32` mirror performs the GPU's
/// arithmetic. The explicit integrator's limit is `ω_max·dt < 2`; at
/// dt = 0.01 s it is 5 (17²) to 11 (33²) and the fix-up, holding every
/// spring under 110 %, keeps the state finite while energy pours in.
fn hanging(resolution: usize, dt: f64) -> String {
    format!(
        r#"
[simulation]
integrator = "explicit"
dt = {dt}
gravity = [0.0, -9.81, 0.0]
duration = 2.0

[cloth]
resolution = [{resolution}, {resolution}]
size = [1.0, 1.0]
origin = [-0.5, 1.0, -0.5]
orientation = "horizontal"
mass = 0.3
pins = ["top-left", "top-right"]

[springs.stretch]
stiffness = 30.0
damping = 0.02
max_stretch = 1.1

[springs.shear]
stiffness = 10.0
damping = 0.01

[springs.bend]
stiffness = 2.0
damping = 0.002

[fixup]
iterations = 10
method = "jacobi"

[ground]
height = 0.0
friction = 0.5
"#
    )
}

/// Explicit integration far beyond its limit (ω·dt ≈ 10⁴: k = 10⁹ N/m,
/// m ≈ 0.03 kg, dt = 0.1 s): the state grows by ~10⁸ a step, past `f32`'s
/// range within a check interval and, in `f64`, to 10⁸¹ m by step 20.
const STIFF: &str = r#"
[simulation]
integrator = "explicit"
dt = 0.1
duration = 2.0

[cloth]
resolution = [3, 3]
pins = ["top-left"]

[springs.stretch]
stiffness = 1e9

[fixup]
method = "jacobi"
"#;

/// Steps of the [`STIFF`] rows: `f64` stays finite that long.
const STIFF_STEPS: u64 = 20;

/// The `hanging` scene made very soft (stretch 0.3 N/m, 100× softer than
/// the scene), implicit, without fix-up or floor: it sags far past 100 %
/// (the stability map's "overstretched") under its own weight, and does so
/// physically: its energy never exceeds the start's.
const SOFT: &str = r#"
[simulation]
integrator = "implicit"
dt = 0.004
duration = 4.0

[cloth]
resolution = [17, 17]
mass = 0.3
pins = ["top-left", "top-right"]

[springs.stretch]
stiffness = 0.3
damping = 0.02

[springs.shear]
stiffness = 10.0
damping = 0.01

[springs.bend]
stiffness = 2.0
damping = 0.002

[fixup]
iterations = 0
"#;

/// The three ways to run the same arithmetic: the `f64` reference, its
/// `f32` mirror and the GPU (lavapipe).
const BACKENDS: [&[&str]; 3] = [
    &["--backend", "cpu", "--precision", "f64"],
    &["--backend", "cpu", "--precision", "f32"],
    &["--backend", "gpu", "--adapter", LAVAPIPE],
];

/// Runs `wgcloth run SCENE --positions-out positions.txt` and `extra` in
/// `dir`.
fn run(dir: &TempDir, scene: &Path, extra: &[&str]) -> (Output, PathBuf) {
    let positions = dir.join("positions.txt");
    let mut args: Vec<&str> = vec![
        "run",
        scene.to_str().expect("a UTF-8 temp path"),
        "--positions-out",
        positions.to_str().expect("a UTF-8 temp path"),
    ];
    args.extend(extra);
    (wgcloth(&args), positions)
}

/// A blow-up as a user sees it: exit status 3, `blew up at step N` and
/// the advice on stderr, and no file written beside the scene. Returns the
/// step and the message.
#[track_caller]
fn blow_up(dir: &TempDir, scene: &Path, extra: &[&str]) -> (u64, String) {
    let (out, _) = run(dir, scene, extra);
    assert_status(&out, EXIT_BLEW_UP);
    let err = stderr(&out);
    assert!(
        err.contains("try a smaller dt, softer springs or another integrator"),
        "{extra:?}: {err}"
    );
    let scene_name = scene.file_name().map(|n| n.to_string_lossy().into_owned());
    assert_eq!(
        dir.files(),
        Vec::from_iter(scene_name),
        "{extra:?}: files left"
    );
    let at = err
        .find("blew up at step ")
        .unwrap_or_else(|| panic!("{extra:?}: {err}"));
    let step: String = err[at + "blew up at step ".len()..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    (step.parse().expect("a step number"), err)
}

/// The `f64` reference of `scene` stepped `steps` times without the
/// divergence rule: it must stay finite (it is a *finite* blow-up).
/// Returns its largest position coordinate \[m\] and largest strain.
fn stays_finite(scene: &Path, steps: u64) -> (f64, f64) {
    let scene = Scene::load(scene).expect("the test scene loads");
    let model = scene.model().expect("the test scene builds");
    let mut solver = CpuSolver::<f64>::new(&model, &scene.params).expect("valid parameters");
    if let Err(e) = solver.step_n(steps) {
        panic!("the f64 reference should stay finite for {steps} steps: {e}");
    }
    let far = solver
        .positions()
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .fold(0.0, |m: f64, c| m.max(c.abs()));
    (
        far,
        diagnostics::max_stretch_strain(&model, &solver.positions()),
    )
}

#[test]
fn a_finite_blow_up_is_reported_at_the_same_step_on_every_backend() {
    // 17²: every backend stays finite for the whole 2 s without the rule
    // (the f64 reference ends at 6.6 J from a 2.9 J start); 33²: f32 and
    // the GPU overflow at step 35, f64 reaches 10²⁷⁹ J. Either way the
    // energy bound catches all three at the same check.
    for resolution in [17, 33] {
        let dir = TempDir::new(&format!("finite-blow-up-{resolution}"));
        let scene = dir.write("scene.toml", &hanging(resolution, 0.01));
        let (_, strain) = stays_finite(&scene, 200);
        if resolution == 17 {
            // Not the strain bound's case: the fix-up holds the lengths.
            assert!(strain < 1.0, "{strain}");
        }
        let reports: Vec<(u64, String)> =
            BACKENDS.iter().map(|b| blow_up(&dir, &scene, b)).collect();
        for (backend, (step, err)) in BACKENDS.iter().zip(&reports) {
            assert!(err.contains("energy bound"), "{backend:?}: {err}");
            assert_eq!(
                step % CHECK_EVERY,
                0,
                "{backend:?}: not a check step: {err}"
            );
            assert_eq!(*step, reports[0].0, "{backend:?} against f64: {err}");
        }
    }
}

#[test]
fn a_stiff_blow_up_is_caught_finite_in_f64_and_at_its_overflow_in_f32() {
    let dir = TempDir::new("stiff-blow-up");
    let scene = dir.write("stiff.toml", STIFF);
    // What `run` wrote and called a success before the rule: 10⁸¹ m.
    let (far, _) = stays_finite(&scene, STIFF_STEPS);
    assert!(far > 1e80, "{far} m");
    let steps = STIFF_STEPS.to_string();
    let with_steps = |b: &[&'static str]| -> Vec<&str> {
        let mut args = vec!["--steps", steps.as_str()];
        args.extend(b);
        args
    };
    // f64: the first check; f32 and the GPU overflow before it, at the
    // step the device's status word records.
    let (step, err) = blow_up(&dir, &scene, &with_steps(BACKENDS[0]));
    assert_eq!(step, CHECK_EVERY, "{err}");
    assert!(err.contains("energy bound"), "{err}");
    let (f32_step, f32_err) = blow_up(&dir, &scene, &with_steps(BACKENDS[1]));
    let (gpu_step, gpu_err) = blow_up(&dir, &scene, &with_steps(BACKENDS[2]));
    assert!(f32_step < CHECK_EVERY, "{f32_err}");
    assert!(f32_err.contains("is not finite"), "{f32_err}");
    assert!(gpu_err.contains("is not finite"), "{gpu_err}");
    assert_eq!(gpu_step, f32_step, "{gpu_err}");
}

/// A cloth of a `--batch` that blows up is a blow-up (status 3), caught
/// at the step a lone cloth's is, the message naming the cloth.
#[test]
fn a_blow_up_in_a_batch_exits_as_a_lone_cloths_does() {
    let dir = TempDir::new("batch-blow-up");
    let scene = dir.write("stiff.toml", STIFF);
    let steps = STIFF_STEPS.to_string();
    let lone = [
        "--steps",
        steps.as_str(),
        "--backend",
        "gpu",
        "--adapter",
        LAVAPIPE,
    ];
    let (lone_step, _) = blow_up(&dir, &scene, &lone);
    let mut batch = lone.to_vec();
    batch.extend(["--batch", "2"]);
    let (step, err) = blow_up(&dir, &scene, &batch);
    assert!(err.contains("cloth 0 of the batch"), "{err}");
    assert_eq!(step, lone_step, "{err}");
}

/// The value after `label` on the summary line that starts with it.
fn summary_value(out: &Output, label: &str) -> f64 {
    let text = stdout(out);
    text.lines()
        .find_map(|l| l.trim_start().strip_prefix(label))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no `{label}` in the summary:\n{text}"))
}

#[test]
fn a_soft_cloth_that_sags_past_100_percent_is_no_blow_up() {
    for backend in [BACKENDS[0], BACKENDS[2]] {
        let dir = TempDir::new("soft-cloth");
        let scene = dir.write("soft.toml", SOFT);
        let (out, positions) = run(&dir, &scene, backend);
        assert_status(&out, 0);
        let strain = summary_value(&out, "max strain");
        assert!(
            strain > 100.0 && strain < DIVERGED_STRAIN * 100.0,
            "{backend:?}: {strain} %"
        );
        let lines = std::fs::read_to_string(&positions).expect("positions written");
        assert_eq!(lines.lines().count(), 17 * 17, "{backend:?}");
    }
}

#[test]
fn a_flag_fed_by_wind_is_no_blow_up_on_any_integrator() {
    // The scene's dt (5 ms) is beyond the explicit integrator's limit
    // (ω_max·dt ≈ 3.7 > 2), which the rule reports; at 1 ms it is 0.75.
    for (integrator, dt) in [
        (Integrator::Explicit, Some("0.001")),
        (Integrator::Implicit, None),
        (Integrator::SemiImplicit, None),
    ] {
        let dir = TempDir::new(&format!("flag-{integrator}"));
        let mut args = vec!["--integrator", integrator.as_str()];
        if let Some(dt) = dt {
            args.extend(["--dt", dt]);
        }
        let (out, positions) = run(&dir, Path::new("flag"), &args);
        assert_status(&out, 0);
        assert!(positions.exists(), "{integrator}: no positions");
        // The wind fed it: without the wind's allowance the explicit
        // flag's final energy would have been called a blow-up.
        if integrator == Integrator::Explicit {
            let calm = windless_limit();
            let total = summary_value(&out, "total");
            assert!(total > calm, "{total} J ≤ {calm} J: the wind fed nothing");
        }
    }
}

/// The energy bound of the `flag` scene at rest without its wind \[J\].
fn windless_limit() -> f64 {
    let mut scene = Scene::builtin("flag").expect("built-in scene");
    scene.params.wind = None;
    let model = scene.model().expect("the flag builds");
    let solver = CpuSolver::<f64>::new(&model, &scene.params).expect("valid");
    let rule = Divergence::new(
        &model,
        &scene.params,
        0.0,
        &solver.positions(),
        &solver.velocities(),
    );
    let limit = rule.energy_limit(0.0);
    // The margin is the stated fraction of the drop of the whole cloth.
    assert!(limit > rule.initial_energy() + ENERGY_MARGIN * 0.25 * 9.81);
    limit
}

#[test]
fn render_stops_at_a_finite_blow_up_before_writing_its_frames() {
    let dir = TempDir::new("render-finite-blow-up");
    let scene = dir.write("scene.toml", &hanging(17, 0.01));
    let out = dir.join("frames");
    let frames = 30;
    let args = [
        "render",
        scene.to_str().expect("a UTF-8 temp path"),
        "--out",
        out.to_str().expect("a UTF-8 temp path"),
        "--size",
        "32x24",
        "--frames",
        &frames.to_string(),
        "--adapter",
        LAVAPIPE,
    ];
    let run = wgcloth(&args);
    assert_status(&run, EXIT_BLEW_UP);
    let err = stderr(&run);
    assert!(
        err.contains("blew up at step ") && err.contains("energy bound"),
        "{err}"
    );
    // Only frames from before the last good check stay, numbered from 0
    // without a gap.
    let written = names_in(&out);
    assert!(written.len() < frames, "{written:?}");
    let expected: Vec<String> = (0..written.len() as u32)
        .map(wgcloth::render::frame_name)
        .collect();
    assert_eq!(written, expected);
}
