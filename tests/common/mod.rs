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

/// A 0.5 m sheet of 12² lying flat, pinned at its top corners: released,
/// it swings down and never comes near itself.
pub fn swinging_sheet() -> Model {
    let spec = ClothSpec {
        nx: 12,
        ny: 12,
        size: [0.5, 0.5],
        origin: DVec3::new(-0.25, 1.0, 0.0),
        orientation: Orientation::Horizontal,
        mass: 0.1,
        pins: vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)],
    };
    Model::new(&spec, &Params::default().springs).expect("model")
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

/// The mesh edges: each triangle side once.
pub fn edges(model: &Model) -> Vec<[u32; 2]> {
    let mut e: Vec<[u32; 2]> = model
        .triangles
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

/// Whether segment `a`–`b` passes through triangle `t`: its ends lie
/// strictly on opposite sides of the triangle's plane and the point where
/// it meets the plane lies inside the triangle (a segment touching the
/// plane, or in it, does not pass through).
pub fn crosses(a: DVec3, b: DVec3, t: [DVec3; 3]) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let (da, db) = (n.dot(a - t[0]), n.dot(b - t[0]));
    if da * db >= 0.0 {
        return false;
    }
    let hit = a + (b - a) * (da / (da - db));
    (0..3).all(|k| {
        let (p, q) = (t[k], t[(k + 1) % 3]);
        n.dot((q - p).cross(hit - p)) >= 0.0
    })
}

/// The edge–triangle crossings at `x`: each mesh edge (of `edges`) that
/// passes through a triangle of `model` it does not share a corner with,
/// as its edge and the triangle.
pub fn crossing_pairs(model: &Model, edges: &[[u32; 2]], x: &[DVec3]) -> Vec<([u32; 2], [u32; 3])> {
    let boxes: Vec<(DVec3, DVec3)> = model
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| x[i as usize]);
            (a.min(b).min(c), a.max(b).max(c))
        })
        .collect();
    let mut out = Vec::new();
    for e in edges {
        let (a, b) = (x[e[0] as usize], x[e[1] as usize]);
        let (lo, hi) = (a.min(b), a.max(b));
        for (t, (tlo, thi)) in model.triangles.iter().zip(&boxes) {
            if t.contains(&e[0]) || t.contains(&e[1]) {
                continue;
            }
            if lo.cmpgt(*thi).any() || hi.cmplt(*tlo).any() {
                continue;
            }
            if crosses(a, b, t.map(|i| x[i as usize])) {
                out.push((*e, *t));
            }
        }
    }
    out
}

/// The divergence rule for `solver` (of `model` under `params`) from its
/// state now, at time 0.
pub fn divergence_rule<R: Real>(
    model: &Model,
    params: &Params,
    solver: &CpuSolver<R>,
) -> wgcloth::diagnostics::Divergence {
    wgcloth::diagnostics::Divergence::new(
        model,
        params,
        0.0,
        &solver.positions(),
        &solver.velocities(),
    )
}
