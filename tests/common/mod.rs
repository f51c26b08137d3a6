//! Builders shared by the CPU physics tests.
#![allow(dead_code, reason = "each test binary uses a different subset")]

use wgcloth::cpu::{CpuSolver, State};
use wgcloth::glam::DVec3;
use wgcloth::model::{ClothSpec, Corner, Model, Orientation, Pin, Spring};
use wgcloth::params::{Integrator, Params, SpringKind, SpringParams};
use wgcloth::real::Vec3;
use wgcloth::{Real, Vector};

/// A small horizontal cloth.
pub fn cloth(nx: usize, ny: usize, pins: Vec<Pin>) -> ClothSpec {
    ClothSpec {
        nx,
        ny,
        size: [0.5, 0.5],
        origin: DVec3::new(-0.25, 1.0, -0.25),
        orientation: Orientation::Horizontal,
        mass: 0.1,
        pins,
    }
}

/// The four corners.
pub fn four_corners() -> Vec<Pin> {
    vec![
        Pin::Corner(Corner::TopLeft),
        Pin::Corner(Corner::TopRight),
        Pin::Corner(Corner::BottomLeft),
        Pin::Corner(Corner::BottomRight),
    ]
}

/// Parameters with fix-up off and a tight CG tolerance, for tests that
/// compare against exact discrete solutions.
pub fn exact_params(integrator: Integrator, dt: f64) -> Params {
    let mut p = Params {
        integrator,
        dt,
        ..Params::default()
    };
    p.fixup.iterations = 0;
    p.implicit.tolerance = 1e-12;
    p.implicit.max_iterations = 10_000;
    p
}

/// Two particles on one stretch spring along y: particle 0 pinned at the
/// origin, particle 1 hanging `rest + displacement` below it. Gravity off,
/// no damping, no fix-up.
pub fn single_spring(
    integrator: Integrator,
    k: f64,
    mass: f64,
    rest: f64,
    displacement: f64,
    dt: f64,
) -> (Model, Params) {
    let model = Model::from_parts(
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, -(rest + displacement), 0.0),
        ],
        vec![mass, mass],
        vec![true, false],
        vec![Spring {
            i: 0,
            j: 1,
            rest,
            kind: SpringKind::Stretch,
        }],
        vec![],
    )
    .expect("valid single spring");
    let mut params = exact_params(integrator, dt);
    params.gravity = DVec3::ZERO;
    params.springs = [
        SpringParams {
            stiffness: k,
            damping: 0.0,
            max_stretch: None,
        },
        SpringParams::NONE,
        SpringParams::NONE,
    ];
    (model, params)
}

/// Runs `steps` steps and returns the solver (panics on blow-up with the
/// solver's message: the tests that call this expect stability).
pub fn run<R: Real>(model: &Model, params: &Params, steps: u64) -> CpuSolver<R> {
    let mut s = CpuSolver::<R>::new(model, params).expect("valid parameters");
    if let Err(e) = s.step_n(steps) {
        panic!("{} run failed: {e}", params.integrator);
    }
    s
}

/// Largest distance between two position sets, with the particle.
pub fn max_distance<A: Vector, B: Vector>(a: &[A], b: &[B]) -> (f64, usize) {
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(p, (&x, &y))| {
            let (x, y) = (Vector::to_f64(x), Vector::to_f64(y));
            let d = ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt();
            (d, p)
        })
        .fold((0.0, 0), |m, c| if c.0 > m.0 { c } else { m })
}

/// Root-mean-square distance between two position sets.
pub fn rms_distance(a: &[Vec3<f64>], b: &[Vec3<f64>]) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum();
    (sum / a.len() as f64).sqrt()
}

#[allow(unused_imports, reason = "each test binary uses a different subset")]
pub use wgcloth::evidence::sheet::noise;

/// How many positions' bits differ between `a` and `b`, and the first
/// that does.
pub fn differing(a: &[wgcloth::glam::Vec3], b: &[wgcloth::glam::Vec3]) -> (usize, Option<usize>) {
    let bits = |v: &wgcloth::glam::Vec3| v.to_array().map(f32::to_bits);
    let differ: Vec<usize> = (0..a.len())
        .filter(|&p| bits(&a[p]) != bits(&b[p]))
        .collect();
    (differ.len(), differ.first().copied())
}

/// The model's rest state: rest positions, zero velocities.
pub fn rest_state(model: &Model) -> State<f64> {
    State {
        x: model
            .rest_positions
            .iter()
            .map(|&p| Vec3::from_f64(p))
            .collect(),
        v: vec![Vec3::ZERO; model.particle_count()],
    }
}

#[allow(unused_imports, reason = "each test binary uses a different subset")]
pub use wgcloth::evidence::sheet::irregular_sheet;
