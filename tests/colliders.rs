//! Capsule colliders and colliders that move, on every integrator and
//! both backends: no particle ends a step inside a capsule, a moving
//! sphere carries a resting cloth by friction (and a frictionless one
//! slides), the GPU equals the `f32` mirror bit for bit, and bad capsule
//! keys are refused naming the file, the key and what is allowed.

mod gpu_common;

use gpu_common::agreement;

use std::path::Path;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::gpu::GpuSolver;
use wgcloth::model::ClothSpec;
use wgcloth::params::{Capsule, Integrator, Sphere};
use wgcloth::{Model, Params, Real, Scene, Vector};

/// Collision projection in `f64` puts a particle on the surface up to the
/// rounding of `x − n d` (~1e-16 m near 1 m); 1e-12 m separates "on the
/// surface" from "inside" with room to spare.
const F64_TOL: f64 = 1e-12;
/// The same in `f32`: a position near 1 m rounds to ~6e-8 m, and the
/// distance is recomputed here from rounded values; 1e-6 m is about
/// sixteen such roundings.
const F32_TOL: f64 = 1e-6;

/// The capsule the cloth falls across: horizontal along x, 0.1 m thick.
const CAPSULE: Capsule = Capsule {
    a: DVec3::new(-0.8, 0.6, 0.0),
    b: DVec3::new(0.8, 0.6, 0.0),
    radius: 0.1,
    friction: 0.5,
    velocity: DVec3::ZERO,
};

/// Distance \[m\] from `x` to the segment of `c` (shifted by `t` seconds of
/// its velocity), in `f64`.
fn segment_distance(c: &Capsule, t: f64, x: DVec3) -> f64 {
    let (a, b) = (c.a + c.velocity * t, c.b + c.velocity * t);
    let d = b - a;
    let s = ((x - a).dot(d) / d.dot(d)).clamp(0.0, 1.0);
    (x - (a + d * s)).length()
}

/// The collider tests' parameters: dt 1 ms for explicit, 1/240 s
/// otherwise; the Jacobi fix-up (the GPU's).
fn collider_params(integrator: Integrator) -> Params {
    let mut params = Params {
        integrator,
        dt: if integrator == Integrator::Explicit {
            1e-3
        } else {
            1.0 / 240.0
        },
        ..Params::default()
    };
    params.fixup.method = wgcloth::params::FixupMethod::Jacobi;
    params
}

/// A horizontal 12 × 12 cloth, 0.8 m square, centred above the capsule.
fn dropped(integrator: Integrator) -> (Model, Params) {
    let mut params = collider_params(integrator);
    params.capsules = vec![CAPSULE];
    let spec = ClothSpec {
        nx: 12,
        ny: 12,
        size: [0.8, 0.8],
        origin: DVec3::new(-0.4, 0.8, -0.4),
        pins: vec![],
        ..ClothSpec::default()
    };
    let model = Model::new(&spec, &params.springs).expect("valid grid");
    (model, params)
}

/// Asserts no particle of `x` is closer than the capsule's radius less
/// `tol` to its segment; returns how many touch it (within 1e-4 m).
fn check_outside<V: Vector>(what: &str, step: usize, x: &[V], tol: f64) -> usize {
    let mut touching = 0;
    for (p, x) in x.iter().enumerate() {
        let d = segment_distance(&CAPSULE, 0.0, DVec3::from_array(x.to_f64()));
        assert!(
            d >= CAPSULE.radius - tol,
            "{what}: step {step} particle {p} inside the capsule by {:e} m",
            CAPSULE.radius - d
        );
        touching += usize::from(d < CAPSULE.radius + 1e-4);
    }
    touching
}

/// Steps the cloth falls across the capsule and settles (0.5 s).
const DROP_STEPS: f64 = 0.5;

#[test]
fn no_particle_ends_a_step_inside_a_capsule_on_any_backend() {
    for integrator in Integrator::ALL {
        let (model, params) = dropped(integrator);
        let steps = (DROP_STEPS / params.dt).round() as usize;
        let mut f64s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
        let mut g = exact_gpu(&model, &params);
        let mut touched = 0;
        let bound = agreement::step_bound(&params);
        for step in 0..steps {
            let before = agreement::before_step(&g, &mut f32s);
            f64s.step().expect("stable");
            f32s.step().expect("stable");
            g.step(1).expect("GPU step");
            touched += check_outside("f64", step, &f64s.positions(), F64_TOL);
            check_outside("f32", step, &f32s.positions(), F32_TOL);
            let gs = g.read_state().expect("read-back");
            check_outside("GPU", step, &gs.x, F32_TOL);
            let what = format!("{integrator}: GPU vs f32, step {step}");
            agreement::check_after_step(&what, &before, &(gs.x, gs.v), &f32s, &bound)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        assert!(
            touched > 0,
            "{integrator}: the cloth never reached the capsule"
        );
    }
}

/// The sphere's speed sideways [m/s]; in 1 s it moves 0.5 m.
const SPHERE_SPEED: f64 = 0.5;
/// The rule: friction 1 carries the cloth at least half the
/// sphere's displacement in 1 s.
const CARRIED_FRACTION: f64 = 0.5;
/// "Much less" without friction: a frictionless cloth may be carried along
/// +x at most a quarter of what friction 1 carries it (the sphere sliding
/// out from under it pushes it along the contact normal, which on the
/// sphere's trailing side points backwards, so it is not carried at all).
const FRICTIONLESS_FRACTION: f64 = 0.25;

/// A 10 × 10 cloth, 0.4 m square, resting on top of a 0.5 m sphere that
/// moves along +x.
fn on_a_sphere(integrator: Integrator, friction: f64) -> (Model, Params) {
    let mut params = collider_params(integrator);
    params.spheres = vec![Sphere {
        center: DVec3::new(0.0, 0.5, 0.0),
        radius: 0.5,
        friction,
        velocity: DVec3::new(SPHERE_SPEED, 0.0, 0.0),
    }];
    let spec = ClothSpec {
        nx: 10,
        ny: 10,
        size: [0.4, 0.4],
        origin: DVec3::new(-0.2, 1.0, -0.2),
        pins: vec![],
        ..ClothSpec::default()
    };
    (Model::new(&spec, &params.springs).expect("valid"), params)
}

fn mean_x<V: Vector>(x: &[V]) -> f64 {
    x.iter().map(|p| p.to_f64()[0]).sum::<f64>() / x.len() as f64
}

#[test]
fn a_moving_sphere_carries_a_resting_cloth_by_friction_and_not_without() {
    for integrator in Integrator::ALL {
        let carried = |friction: f64| {
            let (model, params) = on_a_sphere(integrator, friction);
            let steps = (1.0 / params.dt).round() as u32;
            let mut f64s = CpuSolver::<f64>::new(&model, &params).expect("valid");
            let start = mean_x(&f64s.positions());
            f64s.step_n(u64::from(steps)).expect("stable");
            let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
            let mut g = exact_gpu(&model, &params);
            let what = format!("{integrator} μ {friction}");
            let bound = agreement::step_bound(&params);
            agreement::assert_steps(&what, &mut g, &mut f32s, steps, &bound);
            mean_x(&f64s.positions()) - start
        };
        let sphere = SPHERE_SPEED * 1.0;
        let (with, without) = (carried(1.0), carried(0.0));
        eprintln!("{integrator}: carried {with:.3} m with friction 1, {without:.3} m without");
        assert!(
            with >= CARRIED_FRACTION * sphere,
            "{integrator}: friction 1 carried the cloth {with:.3} m of the sphere's {sphere} m"
        );
        assert!(
            without < FRICTIONLESS_FRACTION * with,
            "{integrator}: without friction the cloth still moved {without:.3} m ({with:.3} m with)"
        );
    }
}

/// Frames of the per-frame test and steps per frame.
const FRAMES: u32 = 12;
const FRAME_STEPS: u32 = 10;

/// A host moving a sphere and a capsule itself, frame by frame (position
/// and velocity each frame, changing direction), drives the GPU and the
/// `f32` mirror alike: every step under the agreement policy (bit for
/// bit on lavapipe).
#[test]
fn colliders_set_every_frame_move_the_same_on_both_backends() {
    for integrator in Integrator::ALL {
        let (model, params) = on_a_sphere(integrator, 1.0);
        let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
        let mut g = exact_gpu(&model, &params);
        let bound = agreement::step_bound(&params);
        let frame = params.dt * f64::from(FRAME_STEPS);
        let mut centre = params.spheres[0].center;
        for k in 0..FRAMES {
            let angle = f64::from(k) * 0.3;
            let velocity = DVec3::new(angle.cos(), 0.0, angle.sin()) * 0.4;
            let sphere = Sphere {
                center: centre,
                velocity,
                ..params.spheres[0]
            };
            let capsule = Capsule {
                a: centre + DVec3::new(-0.3, -0.3, 0.0),
                b: centre + DVec3::new(0.3, -0.3, 0.0),
                velocity,
                ..CAPSULE
            };
            f32s.set_spheres(&[sphere]).expect("valid sphere");
            f32s.set_capsules(&[capsule]).expect("valid capsule");
            g.set_spheres(&[sphere]).expect("valid sphere");
            g.set_capsules(&[capsule]).expect("valid capsule");
            for step in 0..FRAME_STEPS {
                let before = agreement::before_step(&g, &mut f32s);
                g.step(1).expect("GPU step");
                f32s.step().expect("stable");
                let what = format!("{integrator}, frame step {step}");
                let after = agreement::Stepper::state(&g);
                agreement::check_after_step(&what, &before, &after, &f32s, &bound)
                    .unwrap_or_else(|e| panic!("{e}"));
            }
            centre += velocity * frame;
        }
        let gs = g.read_state().expect("read-back");
        let moved = mean_x(&gs.x) - mean_x(&model.rest_positions);
        assert!(
            moved.abs() > 1e-3,
            "{integrator}: the moving colliders moved the cloth"
        );
    }
}

#[test]
fn more_capsules_than_the_gpu_holds_are_refused_before_anything_runs() {
    let ctx = gpu();
    let (model, mut params) = dropped(Integrator::Implicit);
    let max = wgcloth::kernel_config::MAX_CAPSULES;
    params.capsules = vec![CAPSULE; max + 1];
    let Err(e) = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params) else {
        panic!("{} capsules were taken", max + 1);
    };
    let msg = e.to_string();
    assert!(
        msg.contains("capsule") && msg.contains(&format!("at most {max}")),
        "{msg}"
    );
    params.capsules = vec![CAPSULE];
    let mut g = exact_gpu(&model, &params);
    let e = g
        .set_capsules(&vec![CAPSULE; max + 1])
        .expect_err("refused");
    assert!(e.to_string().contains(&format!("at most {max}")), "{e}");
    // The f32 mirror takes any number.
    let mut c = CpuSolver::<f32>::new(&model, &params).expect("valid");
    c.set_capsules(&vec![CAPSULE; max + 1])
        .expect("any number on the CPU");
}

#[test]
fn a_degenerate_capsule_is_a_sphere() {
    // The same cloth on a capsule with a == b and on a sphere there ends
    // bit for bit where it does: both are a ball around one point.
    let (model, mut params) = on_a_sphere(Integrator::Explicit, 0.5);
    let sphere = params.spheres[0];
    params.spheres.clear();
    params.capsules = vec![Capsule {
        a: sphere.center,
        b: sphere.center,
        radius: sphere.radius,
        friction: sphere.friction,
        velocity: sphere.velocity,
    }];
    let mut on_capsule = CpuSolver::<f32>::new(&model, &params).expect("valid");
    params.capsules.clear();
    params.spheres = vec![sphere];
    let mut on_sphere = CpuSolver::<f32>::new(&model, &params).expect("valid");
    on_capsule.step_n(300).expect("stable");
    on_sphere.step_n(300).expect("stable");
    for (p, (c, s)) in on_capsule
        .positions()
        .iter()
        .zip(on_sphere.positions())
        .enumerate()
    {
        assert_eq!(
            c.to_array().map(f32::to_bits),
            s.to_array().map(f32::to_bits),
            "capsule a == b vs sphere: particle {p}"
        );
    }
}

/// A scene file's text with one capsule whose keys are `keys`.
fn capsule_scene(keys: &str) -> String {
    format!("[[capsule]]\n{keys}\n")
}

#[test]
fn bad_capsule_keys_are_refused_naming_the_file_the_key_and_what_is_allowed() {
    let ok = "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = 0.1";
    let scene = Scene::from_toml(&capsule_scene(ok), Path::new("capsule.toml")).expect("valid");
    assert_eq!(scene.params.capsules.len(), 1);
    assert_eq!(scene.params.capsules[0].velocity, DVec3::ZERO);
    let rows: [(&str, &[&str]); 7] = [
        (
            "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = 0",
            &["capsule[0].radius", "radius > 0"],
        ),
        (
            "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = -1",
            &["capsule[0].radius", "radius > 0"],
        ),
        (
            "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = nan",
            &["capsule[0].radius", "radius > 0"],
        ),
        (
            "a = [0, 1, 0]\nb = [1, inf, 0]\nradius = 0.1",
            &["capsule[0].b", "finite"],
        ),
        (
            "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = 0.1\nfriction = -0.5",
            &["capsule[0].friction", "friction ≥ 0"],
        ),
        ("a = [0, 1, 0]\nradius = 0.1", &["capsule[0]", "`b`"]),
        (
            "a = [0, 1, 0]\nb = [1, 1, 0]\nradius = 0.1\nvelocity = [1, 2]",
            &["capsule[0].velocity", "3"],
        ),
    ];
    for (keys, wanted) in rows {
        let e = Scene::from_toml(&capsule_scene(keys), Path::new("capsule.toml"))
            .err()
            .unwrap_or_else(|| panic!("refused: {keys}"));
        let msg = e.to_string();
        for w in wanted.iter().chain(&["capsule.toml"]) {
            assert!(msg.contains(w), "{keys:?}: message lacks {w:?}: {msg}");
        }
    }
}

#[test]
fn sphere_velocity_is_read_from_the_scene_file() {
    let text = "[[sphere]]\nradius = 0.5\nvelocity = [1, 0, -2]\n";
    let scene = Scene::from_toml(text, Path::new("s.toml")).expect("valid");
    assert_eq!(scene.params.spheres[0].velocity, DVec3::new(1.0, 0.0, -2.0));
    // A real number type is still what the f32 mirror converts.
    assert_eq!(f32::from_f64(scene.params.spheres[0].velocity.z), -2.0);
}

/// The built-in `drape` moved 0.2 m off the ball's centre: the longer
/// overhang pulls the cloth sideways over the ball, where friction 0.5
/// must hold it (the cloth reaches the ball at about step 27 and wraps
/// its side by step 40).
fn off_centre_drape() -> (Model, Params) {
    let mut scene = Scene::builtin("drape").expect("built in");
    scene.cloths[0].spec.origin = DVec3::new(-0.3, 0.6, -0.5);
    (scene.model().expect("valid"), scene.params)
}

/// Steps the off-centre drape runs in `f64`: 3 s at 1/120 s.
const DRAPE_STEPS: u64 = 360;
/// Steps the GPU runs against its mirror: past the ball's side.
const DRAPE_GPU_STEPS: u32 = 48;
/// The fastest particle of the drape at 3 s \[m/s\] is 0.022 here (the
/// hanging edge's last slow swing); a cloth sliding off the ball would
/// go at the ball's scale, √(2 g r) ≈ 2.6 m/s, so a tenth of a metre per
/// second separates resting from sliding with room either side.
const RESTING_SPEED: f64 = 0.1;

#[test]
fn a_cloth_dropped_off_centre_on_a_ball_comes_to_rest_held_by_static_friction() {
    let (model, params) = off_centre_drape();
    let f64s = run_checked_f64(&model, &params, DRAPE_STEPS);
    let v = f64s.velocities();
    let fastest = v.iter().map(|v| v.length()).fold(0.0, f64::max);
    let held = v.iter().filter(|v| **v == DVec3::ZERO).count();
    eprintln!("fastest {fastest:.4} m/s, {held} particles held");
    assert!(
        fastest < RESTING_SPEED,
        "after 3 s a particle still moves at {fastest} m/s"
    );
    // A held contact's Δv takes it exactly to the (resting) ball's
    // velocity, so its velocity is exactly zero.
    assert!(held > 0, "no contact is held by static friction");
    assert_both_paths_agree("off-centre drape", &model, &params, DRAPE_GPU_STEPS);
}
