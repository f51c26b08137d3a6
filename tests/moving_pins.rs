//! Pins that move: a pin target is reached exactly at each frame's end on
//! every integrator and backend (the GPU equal to the `f32` mirror bit for
//! bit), a cloth swung by its pins on a circle keeps its energy bounded,
//! bad targets are refused, and a released pin keeps its velocity.

mod gpu_common;

use gpu_common::agreement;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::diagnostics;
use wgcloth::glam::{DVec3, Vec3};
use wgcloth::model::{ClothSpec, Corner, Orientation, Pin};
use wgcloth::params::{FixupMethod, Integrator};
use wgcloth::{Model, Params, PinTarget};

/// Radius of the pins' circle \[m\].
const RADIUS: f64 = 0.1;
/// Angular speed of the pins [rad/s]: one turn a second, 0.63 m/s.
const OMEGA: f64 = std::f64::consts::TAU;
/// Frames per second of the host driving the pins.
const FPS: f64 = 60.0;

/// A vertical 12 × 12 cloth, 0.5 m square, hanging from its top corners.
fn hanging(integrator: Integrator) -> (Model, Params) {
    let mut params = Params {
        integrator,
        // Ten steps a frame for explicit, two for the others.
        dt: if integrator == Integrator::Explicit {
            1.0 / 600.0
        } else {
            1.0 / 120.0
        },
        ..Params::default()
    };
    params.fixup.method = FixupMethod::Jacobi;
    let spec = ClothSpec {
        nx: 12,
        ny: 12,
        size: [0.5, 0.5],
        origin: DVec3::new(-0.25, 1.0, 0.0),
        orientation: Orientation::Vertical,
        pins: vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)],
        ..ClothSpec::default()
    };
    (Model::new(&spec, &params.springs).expect("valid"), params)
}

/// Where the pins are at time `t` \[s\]: each pinned particle's rest
/// position moved along a horizontal circle through it.
fn targets(model: &Model, t: f64) -> Vec<PinTarget> {
    let offset = DVec3::new((OMEGA * t).cos() - 1.0, 0.0, (OMEGA * t).sin()) * RADIUS;
    (0..model.particle_count())
        .filter(|&p| model.pinned[p])
        .map(|p| PinTarget {
            particle: p,
            position: (model.rest_positions[p] + offset).as_vec3(),
        })
        .collect()
}

/// The solvers a frame drives alike.
trait Driven {
    fn frame(&mut self, targets: &[PinTarget], steps: u32);
    fn x(&mut self) -> Vec<DVec3>;
}

impl Driven for CpuSolver<f64> {
    fn frame(&mut self, targets: &[PinTarget], steps: u32) {
        self.set_pin_targets(targets, f64::from(steps) * self.system().dt)
            .expect("valid targets");
        self.step_n(u64::from(steps)).expect("stable");
    }
    fn x(&mut self) -> Vec<DVec3> {
        self.positions()
    }
}

impl Driven for CpuSolver<f32> {
    fn frame(&mut self, targets: &[PinTarget], steps: u32) {
        let dt = f64::from(self.system().dt);
        self.set_pin_targets(targets, f64::from(steps) * dt)
            .expect("valid targets");
        self.step_n(u64::from(steps)).expect("stable");
    }
    fn x(&mut self) -> Vec<DVec3> {
        self.positions().iter().map(|p| p.as_dvec3()).collect()
    }
}

#[test]
fn pin_targets_are_reached_exactly_at_each_frame_end() {
    for integrator in Integrator::ALL {
        let (model, params) = hanging(integrator);
        let steps = (1.0 / (FPS * params.dt)).round() as u32;
        let frame = f64::from(steps) * params.dt;
        let mut f64s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
        let mut g = exact_gpu(&model, &params);
        let bound = agreement::step_bound(&params);
        for k in 1..=30 {
            let goal = targets(&model, f64::from(k) * frame);
            f64s.frame(&goal, steps);
            f32s.set_pin_targets(&goal, frame).expect("valid targets");
            g.set_pin_targets(&goal, frame).expect("valid targets");
            // Step by step, the GPU against the mirror under the agreement
            // policy.
            for step in 0..steps {
                let before = agreement::before_step(&g, &mut f32s);
                g.step(1).expect("GPU step");
                f32s.step().expect("stable");
                let what = format!("{integrator}: frame {k} step {step}");
                let after = agreement::Stepper::state(&g);
                agreement::check_after_step(&what, &before, &after, &f32s, &bound)
                    .unwrap_or_else(|e| panic!("{e}"));
            }
            let gx = g.read_state().expect("read-back").x;
            let (x64, x32) = (f64s.x(), f32s.x());
            for t in &goal {
                let p = t.particle;
                // Exact: f64 holds the f32 target exactly, and the last
                // step of a frame lands on it rather than adding dt v.
                assert_eq!(
                    x64[p],
                    t.position.as_dvec3(),
                    "{integrator} f64: frame {k} pin {p}"
                );
                assert_eq!(
                    x32[p],
                    t.position.as_dvec3(),
                    "{integrator} f32: frame {k} pin {p}"
                );
                assert_eq!(
                    gx[p].to_array().map(f32::to_bits),
                    t.position.to_array().map(f32::to_bits),
                    "{integrator} GPU: frame {k} pin {p}"
                );
            }
        }
    }
}

/// Seconds of swinging in the energy test: four turns.
const SWING_SECONDS: f64 = 4.0;

/// The most energy \[J\] the pins can give a cloth of mass `m` \[kg\] and
/// extent `d` \[m\] (its longest rest distance from a pin, stretched by
/// the fix-up's 10 %): every particle moving at most as fast as a rigid
/// rotation at the pins' angular speed about the circle's far side,
/// `ω (2R + d)`, and the cloth's centre of mass lifted at most `d`. A pin
/// that teleported or fed energy in would overshoot it within a turn.
fn energy_bound(m: f64, d: f64) -> f64 {
    let speed = OMEGA * (2.0 * RADIUS + d);
    m * (0.5 * speed * speed + 9.81 * d)
}

#[test]
fn a_cloth_swung_by_its_pins_keeps_its_energy_bounded() {
    for integrator in [Integrator::Implicit, Integrator::SemiImplicit] {
        let (model, params) = hanging(integrator);
        let steps = (1.0 / (FPS * params.dt)).round() as u32;
        let frame = f64::from(steps) * params.dt;
        let mut s = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let e0 = diagnostics::energy(&model, &params, &s.positions(), &s.velocities()).total();
        let mass: f64 = model.mass.iter().sum();
        let extent = 1.1 * 0.5 * 2f64.sqrt();
        let bound = energy_bound(mass, extent);
        let mut most: f64 = 0.0;
        let frames = (SWING_SECONDS / frame).round() as u32;
        for k in 1..=frames {
            s.frame(&targets(&model, f64::from(k) * frame), steps);
            let e = diagnostics::energy(&model, &params, &s.positions(), &s.velocities()).total();
            most = most.max(e - e0);
            assert!(
                e - e0 <= bound,
                "{integrator}: frame {k}: the cloth gained {:.3} J, above the bound {bound:.3} J",
                e - e0
            );
        }
        eprintln!("{integrator}: most energy gained {most:.3} J of {bound:.3} J");
        assert!(
            most > 1e-3,
            "{integrator}: the swinging pins moved the cloth"
        );
    }
}

#[test]
fn bad_pin_targets_are_refused_naming_the_particle_and_change_nothing() {
    let (model, params) = hanging(Integrator::Implicit);
    let mut c = CpuSolver::<f32>::new(&model, &params).expect("valid");
    let mut g = exact_gpu(&model, &params);
    let good = targets(&model, 0.25);
    let n = model.particle_count();
    let free = (0..n).find(|&p| !model.pinned[p]).expect("a free particle");
    let cases = [
        (
            PinTarget {
                particle: n,
                position: Vec3::ZERO,
            },
            format!("{n}"),
        ),
        (
            PinTarget {
                particle: free,
                position: Vec3::ZERO,
            },
            "pinned".to_string(),
        ),
        (
            PinTarget {
                particle: good[0].particle,
                position: Vec3::new(f32::NAN, 0.0, 0.0),
            },
            "finite".to_string(),
        ),
    ];
    for (bad, wanted) in cases {
        let list = [good[0], bad];
        for e in [
            c.set_pin_targets(&list, 0.1).err(),
            g.set_pin_targets(&list, 0.1).err(),
        ] {
            let msg = e.expect("refused").to_string();
            assert!(msg.contains(&wanted), "{bad:?}: {msg}");
        }
    }
    for seconds in [0.0, -1.0, f64::NAN] {
        assert!(c.set_pin_targets(&good, seconds).is_err());
        assert!(g.set_pin_targets(&good, seconds).is_err());
    }
    // Nothing was changed: the pins stay where they were.
    c.step_n(10).expect("stable");
    g.step(10).expect("GPU steps");
    let gx = g.read_state().expect("read-back").x;
    for t in &good {
        let rest = model.rest_positions[t.particle].as_vec3();
        assert_eq!(c.positions()[t.particle], rest);
        assert_eq!(gx[t.particle], rest);
    }
}

/// The released particle's velocity against the drag's: `(target − x) /
/// (steps left × dt)` in `f32` divides a 5 mm step rounded at ~6e-8 m, a
/// relative error near 1e-5; ten times that.
const RELEASE_TOL: f64 = 1e-4;

#[test]
fn a_released_pin_keeps_its_velocity() {
    for integrator in Integrator::ALL {
        let (model, params) = hanging(integrator);
        let mut c = CpuSolver::<f32>::new(&model, &params).expect("valid");
        let mut g = exact_gpu(&model, &params);
        let p = (0..model.particle_count())
            .find(|&p| !model.pinned[p])
            .expect("a free particle");
        // Grab a free particle and drag it 5 cm sideways in one frame.
        let frame = 10.0 * params.dt;
        let target = [PinTarget {
            particle: p,
            position: (model.rest_positions[p] + DVec3::new(0.05, 0.0, 0.0)).as_vec3(),
        }];
        c.set_pinned(p, true).expect("valid");
        g.set_pinned(p, true).expect("valid");
        c.set_pin_targets(&target, frame).expect("valid");
        g.set_pin_targets(&target, frame).expect("valid");
        c.step_n(10).expect("stable");
        g.step(10).expect("GPU steps");
        c.set_pinned(p, false).expect("valid");
        g.set_pinned(p, false).expect("valid");
        let speed = 0.05 / frame;
        let (cv, gv) = (c.velocities()[p], g.read_state().expect("read-back").v[p]);
        let close = |v: Vec3| (f64::from(v.x) - speed).abs() < RELEASE_TOL * speed;
        assert!(
            close(cv) && close(gv),
            "{integrator}: released at {cv} / {gv}, dragged at {speed} m/s"
        );
        assert_eq!(cv, gv, "{integrator}: GPU vs f32 mirror");
    }
}
