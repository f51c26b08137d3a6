//! Fault rows: physics that must not add energy. Self-collision friction
//! at any coefficient, a turntable carrying a cloth, a body turning about
//! an axis it is not round about, and bending at the explicit
//! integrator's limit: each either runs with its energy under the run's
//! own bound or is refused before it runs (status, message, nothing
//! written), never a blow-up.

use std::fmt::Write as _;

use wgcloth::cpu::CpuSolver;
use wgcloth::diagnostics::{self, Divergence};
use wgcloth::real::Real;
use wgcloth::Scene;

use crate::cli_common::{assert_status, stderr, TempDir, BIN, EXIT_INVALID};
use crate::refusal_faults;

/// Steps between the energy checks of the library rows: the CLI's own
/// check interval's order, fine enough to see a climb long before it
/// doubles.
const CHECK_STEPS: u64 = 12;

/// What a run of `scene` for `steps` steps on the CPU did: its energy at
/// the start, its largest at a check and its last \[J\], and the solver;
/// or where its state stopped being finite or its energy passed the
/// divergence rule's bound (the CLI's blow-up).
struct Ran<R: Real> {
    start: f64,
    largest: f64,
    last: f64,
    solver: CpuSolver<R>,
}

fn energies<R: Real>(scene: &Scene, steps: u64) -> Result<Ran<R>, String> {
    let model = scene.model().expect("the scene builds");
    let mut solver = CpuSolver::<R>::new(&model, &scene.params).expect("valid parameters");
    let rule = Divergence::new(
        &model,
        &scene.params,
        0.0,
        &solver.positions(),
        &solver.velocities(),
    );
    let start = rule.initial_energy();
    let (mut largest, mut last) = (start, start);
    let mut done = 0;
    while done < steps {
        let n = CHECK_STEPS.min(steps - done);
        solver
            .step_n(n)
            .map_err(|e| format!("not finite after {done} steps: {e}"))?;
        done += n;
        let time = done as f64 * scene.params.dt;
        let (x, v) = (solver.positions(), solver.velocities());
        if let Some(crossed) = rule.crossed(time, &x, &v) {
            return Err(format!(
                "blew up at step {done} (t = {time} s): {crossed:?}"
            ));
        }
        last = diagnostics::energy(&model, &scene.params, &x, &v).total();
        largest = largest.max(last);
    }
    Ok(Ran {
        start,
        largest,
        last,
        solver,
    })
}

#[test]
fn self_collision_friction_at_any_coefficient_takes_energy_out_of_the_heap() {
    // 2 s of the heap: it has slumped and folded onto itself (its layers
    // in contact for over a second) by then.
    const SECONDS: f64 = 2.0;
    let mut failures = Vec::new();
    for friction in [0.0, 1.0, 3.0, 10.0] {
        let mut scene = Scene::builtin("heap").expect("the built-in heap");
        let c = scene
            .params
            .self_collision
            .as_mut()
            .expect("heap self-collides");
        c.friction = friction;
        let steps = (SECONDS / scene.params.dt).round() as u64;
        match energies::<f64>(&scene, steps) {
            Ok(r) if r.last < r.start => println!(
                "friction {friction}: {:.4} J at the start, at most {:.4} J, {:.4} J at {SECONDS} s",
                r.start, r.largest, r.last
            ),
            Ok(r) => failures.push(format!(
                "friction {friction}: {:.4} J at the start, {:.4} J at {SECONDS} s (at most {:.4} J)",
                r.start, r.last, r.largest
            )),
            Err(e) => failures.push(format!("friction {friction}: {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Sides of the turntable's prism: round enough that its facets' corners
/// move along their normals by `sin(π/64)` ≈ 5 % of the rim speed.
const TURNTABLE_SIDES: usize = 64;

/// A prism of [`TURNTABLE_SIDES`] sides about y, radius `radius` \[m\],
/// from y = 0 to `height` \[m\], as OBJ text (faces wound outward).
fn prism(radius: f64, height: f64) -> String {
    let mut obj = String::from("v 0 0 0\n");
    let _ = writeln!(obj, "v 0 {height} 0");
    for k in 0..TURNTABLE_SIDES {
        let a = std::f64::consts::TAU * k as f64 / TURNTABLE_SIDES as f64;
        let (x, z) = (radius * a.cos(), radius * a.sin());
        let _ = writeln!(obj, "v {x} 0 {z}\nv {x} {height} {z}");
    }
    for k in 0..TURNTABLE_SIDES {
        let (b0, b1) = (3 + 2 * k, 3 + 2 * ((k + 1) % TURNTABLE_SIDES));
        let (t0, t1) = (b0 + 1, b1 + 1);
        let _ = writeln!(obj, "f {b0} {t0} {t1} {b1}\nf 2 {t1} {t0}\nf 1 {b0} {b1}");
    }
    obj
}

/// The turntable's angular speed \[rad/s\] and its rim's radius \[m\]:
/// the rim moves at 2.1 m/s.
const SPIN: f64 = 3.0;
const RIM: f64 = 0.7;

/// A 0.8 m cloth dropped onto a turntable turning at [`SPIN`] rad/s,
/// friction 1, implicit at `dt`: the cloth lies within the rim.
fn turntable_scene(dt: f64) -> String {
    format!(
        r#"
[simulation]
integrator = "implicit"
dt = {dt}

[cloth]
resolution = [17, 17]
size = [0.8, 0.8]
origin = [-0.4, 0.9, -0.4]
orientation = "horizontal"
mass = 0.1
pins = []

[springs.stretch]
stiffness = 500.0
damping = 0.1

[springs.shear]
stiffness = 100.0
damping = 0.02

[[collider]]
mesh = "turntable.obj"
angular_velocity = [0.0, {SPIN}, 0.0]
friction = 1.0
thickness = 0.012
"#
    )
}

/// How much faster than the surface under it a carried particle may be:
/// the step's straight move along `ω × r` leaves the circle by
/// `r (1/cos(ω dt) − 1)`, under 1e-3 r at the rows' steps; a whole
/// percent is far from a drive that pumps the cloth up.
const CARRIED_MARGIN: f64 = 0.01;

#[test]
fn a_turntable_carries_its_cloth_at_the_speed_of_the_surface_under_it() {
    let dir = TempDir::new("energy-turntable");
    dir.write("turntable.obj", &prism(RIM, 0.76));
    for dt in [1.0 / 120.0, 1.0 / 480.0] {
        let path = dir.write("scene.toml", &turntable_scene(dt));
        let scene = Scene::load(&path).expect("the turntable loads");
        let steps = (2.0 / dt).round() as u64;
        let ran = energies::<f64>(&scene, steps).unwrap_or_else(|e| panic!("dt {dt}: {e}"));
        let (x, v) = (ran.solver.positions(), ran.solver.velocities());
        let mut worst = (0.0f64, 0);
        for (p, (x, v)) in x.iter().zip(&v).enumerate() {
            let r = x.x.hypot(x.z);
            let over = v.x.hypot(v.z) - SPIN * r * (1.0 + CARRIED_MARGIN);
            if over > worst.0 {
                worst = (over, p);
            }
        }
        let fastest = v.iter().map(|v| v.x.hypot(v.z)).fold(0.0, f64::max);
        assert!(
            worst.0 <= 0.0 && fastest > 0.5 * SPIN * RIM,
            "dt {dt}: particle {} faster than the surface under it by {} m/s; fastest \
             {fastest} m/s (the rim: {} m/s)",
            worst.1,
            worst.0,
            SPIN * RIM
        );
    }
}

#[test]
fn a_body_turning_about_an_axis_it_is_not_round_about_is_refused() {
    // The built-in table turning at 3 rad/s under its cloth: its long
    // sides would slide along themselves at up to 1.8 m/s while the table
    // stays put, winding the cloth round it (a blow-up at any dt).
    let dir = TempDir::new("energy-turning-table");
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/table.obj"),
        dir.join("table.obj"),
    )
    .expect("copy the table");
    let table = include_str!("../../scenes/table.toml").replace(
        "friction = 0.6",
        "friction = 1.0\nangular_velocity = [0.0, 3.0, 0.0]",
    );
    dir.write("scene.toml", &table);
    let before = dir.files();
    let out = std::process::Command::new(BIN)
        .current_dir(&dir.0)
        .args(["run", "scene.toml", "--positions-out", "positions.txt"])
        .output()
        .expect("run the wgcloth binary");
    let wrong = refusal_faults(
        &out,
        &[
            "scene file scene.toml",
            "`collider[0].angular_velocity`",
            "round about",
            "at most 20 %",
            "got [0, 3, 0]",
        ],
        &["blew up"],
        &before,
        &dir.files(),
    );
    assert!(wrong.is_empty(), "{}\n{}", wrong.join("; "), stderr(&out));
    // The same table without the turning runs.
    dir.write("scene.toml", include_str!("../../scenes/table.toml"));
    let out = std::process::Command::new(BIN)
        .current_dir(&dir.0)
        .args(["run", "scene.toml", "--steps", "2"])
        .output()
        .expect("run the wgcloth binary");
    assert_status(&out, 0);
}

/// An explicit cloth of 0.1 m cells at dt = 1 ms with the default
/// material's damping, of bending `bending` \[N·m\].
fn bending_scene(bending: &str) -> String {
    format!(
        "[simulation]\nintegrator = \"explicit\"\ndt = 0.001\n\
         [cloth]\nresolution = [11, 11]\nsize = [1.0, 1.0]\n\
         [material]\nbending = {bending}\n"
    )
}

/// `wgcloth run scene.toml` of `bending` for 1 s in a fresh directory.
fn run_bending(bending: &str) -> (std::process::Output, TempDir) {
    let dir = TempDir::new(&format!("energy-bending-{bending}"));
    dir.write("scene.toml", &bending_scene(bending));
    let out = std::process::Command::new(BIN)
        .current_dir(&dir.0)
        .args(["run", "scene.toml", "--seconds", "1"])
        .args(["--positions-out", "positions.txt"])
        .output()
        .expect("run the wgcloth binary");
    (out, dir)
}

#[test]
fn the_explicit_bending_limit_admits_what_runs_and_refuses_what_blows_up() {
    // 0.7 N·m blew up at step 60 where the limit once said 1.
    let (out, dir) = run_bending("0.7");
    let wrong = refusal_faults(
        &out,
        &[
            "`material.bending`",
            "at most",
            "explicit integrator",
            "dt = 0.001 s",
        ],
        &["blew up"],
        &["scene.toml".to_string()],
        &dir.files(),
    );
    assert!(wrong.is_empty(), "{}", wrong.join("; "));
    let err = stderr(&out);
    let limit: f64 = err
        .split("at most ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no limit in {err}"));
    // Just below the limit it runs a second (1000 steps) without a
    // blow-up; just above it is refused.
    let (out, dir) = run_bending(&limit.to_string());
    assert_status(&out, 0);
    assert!(dir.join("positions.txt").is_file());
    let (out, _dir) = run_bending(&(limit * 1.02).to_string());
    assert_status(&out, EXIT_INVALID);
    assert!(
        stderr(&out).contains("`material.bending`"),
        "{}",
        stderr(&out)
    );
}
