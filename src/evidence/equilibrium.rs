//! The static equilibrium of a cloth: the shape it rests in under its
//! springs, its linear bending and gravity, found by damped Newton steps
//! on the forces, each a banded direct solve.
//!
//! Settling by time steps reaches the same state (a backward-Euler step at
//! rest changes nothing), but a resolution study of a near-inextensible,
//! bending-dominated plate needs thousands of implicit steps whose CG —
//! ill-conditioned by the membrane's stiffness and by the bending operator,
//! which grows as `h⁻⁴` with the mesh spacing `h` — stops at its cap:
//! minutes at 33², hours at 65². A direct solve costs the band's
//! `3n · (3w)²` for a particle bandwidth `w` (about two grid rows with
//! bending): seconds at 65².
//!
//! Each step solves `(K + μ M) Δx = f(x)` (Levenberg–Marquardt with the
//! mass matrix: `μ = 1/dt²` is a backward-Euler step from rest of `dt`,
//! `μ = 0` a Newton step); after an accepted step Newton is trusted more
//! (`μ` ÷ 10), after a refused one the step is retried with more damping
//! (`μ` × 10), as where `K + μ M` is not positive definite. The stiffness
//! `K = −∂f/∂x` is the exact one, assembled from the springs' blocks and
//! the bending operator.
//! Each step is accepted where it lowers the potential energy or the
//! residual: the energy while the membrane's stiff forces swamp the
//! residual, the residual near the solution, where energy differences
//! drown in rounding. Pinned particles stay where they are; contacts, wind
//! and the stretch limit are not modelled (a scene with any is refused).

use super::Points;
use crate::band::{cholesky_in_place, solve_in_place};
use crate::cpu::forces::{spring_forces, spring_frame, total_force};
use crate::cpu::System;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::Params;
use crate::real::Vec3;

/// The largest force left on a free particle at equilibrium, as a
/// fraction of its weight. The forces of the stiff stretch springs cancel
/// to about `k · 10⁻¹⁶ m` in `f64` (10⁻¹³ N for the plate of
/// [`super::cantilever::plate_drop`] at 65², a few 10⁻⁸ of a particle's
/// weight); 10⁻⁶ of the weight, well above that, moves the plate's drop by
/// about a millionth of itself, far below the differences between
/// resolutions.
pub const EQUILIBRIUM_TOLERANCE: f64 = 1e-6;

/// Newton steps before giving up (the plate converges in 20 to 40).
pub const MAX_EQUILIBRIUM_STEPS: u32 = 200;

/// The first step's damping `μ` [1/s²]: a backward-Euler step of 0.02 s
/// from rest, safe from the flat start where Newton's linearisation of a
/// large sag overshoots.
const FIRST_DAMPING: f64 = 1.0 / (0.02 * 0.02);

/// Below this `μ` \[1/s²\] a step is a pure Newton step (`μ = 0`).
const NEWTON_DAMPING: f64 = FIRST_DAMPING * 1e-8;

/// Above this `μ` \[1/s²\] no step lowers the residual: the iteration
/// has failed (steps of nanoseconds).
const MAX_DAMPING: f64 = FIRST_DAMPING * 1e12;

/// The equilibrium [`equilibrium`] found.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    /// Every particle's rest position \[m\].
    pub positions: Points,
    /// Newton steps taken.
    pub steps: u32,
    /// Whether every free particle's force fell below
    /// [`EQUILIBRIUM_TOLERANCE`] of its weight.
    pub converged: bool,
}

/// The static equilibrium of `model` under `params`' gravity, springs and
/// bending, from its rest positions (module docs).
pub fn equilibrium(model: &Model, params: &Params) -> Result<Equilibrium> {
    let sys = System::<f64>::new(model, params);
    if sys.ground.is_some()
        || !sys.spheres.is_empty()
        || !sys.capsules.is_empty()
        || !sys.mesh_colliders.is_empty()
        || sys.self_collision.is_some()
        || sys.wind.is_some()
        || sys.max_len.iter().any(|&m| m > 0.0)
    {
        return Err(Error::InvalidParameter {
            key: "evidence.equilibrium".into(),
            allowed: "a scene without contacts, wind or stretch limits".into(),
            got: "a ground, a collider, self-collision, wind or max_stretch".into(),
        });
    }
    let n = model.particle_count();
    let w = particle_bandwidth(&sys);
    let bw = 3 * w + 2;
    let mut forces = Forces::new(&sys);
    let mut x: Points = model.rest_positions.iter().map(|&p| p.into()).collect();
    let mut f = forces.of(&sys, &x).to_vec();
    let weight = sys.gravity.length();
    let mut mu = FIRST_DAMPING;
    for step in 0..MAX_EQUILIBRIUM_STEPS {
        let converged = (0..n).all(|p| {
            sys.inv_mass[p] <= 0.0 || f[p].length() <= EQUILIBRIUM_TOLERANCE * sys.mass[p] * weight
        });
        if converged {
            return Ok(Equilibrium {
                positions: x,
                steps: step,
                converged: true,
            });
        }
        let stiffness = stiffness(&sys, &x, bw)?;
        let (residual, energy) = (residual_of(&sys, &f), potential(model, params, &x));
        loop {
            if let Some(dx) = damped_step(&sys, &stiffness, bw, mu, &f)? {
                let trial: Points = x.iter().zip(&dx).map(|(&a, &d)| a + d).collect();
                let f_trial = forces.of(&sys, &trial);
                if residual_of(&sys, f_trial) < residual
                    || potential(model, params, &trial) < energy
                {
                    f.copy_from_slice(f_trial);
                    x = trial;
                    mu = if mu * 0.1 < NEWTON_DAMPING {
                        0.0
                    } else {
                        mu * 0.1
                    };
                    break;
                }
            }
            mu = (mu * 10.0).max(NEWTON_DAMPING);
            if mu > MAX_DAMPING {
                return Ok(Equilibrium {
                    positions: x,
                    steps: step,
                    converged: false,
                });
            }
        }
    }
    Ok(Equilibrium {
        positions: x,
        steps: MAX_EQUILIBRIUM_STEPS,
        converged: false,
    })
}

/// The largest index distance between two particles that act on each
/// other: a spring or a bending entry (wind, which couples a triangle's
/// corners, is refused).
fn particle_bandwidth(sys: &System<f64>) -> usize {
    let gap = |a: u32, b: u32| a.abs_diff(b) as usize;
    let springs = sys.springs.iter().map(|s| gap(s.i, s.j));
    let bending = sys.bending.iter().flat_map(|b| {
        (0..sys.mass.len()).flat_map(move |p| b.row(p).0.iter().map(move |&c| gap(p as u32, c)))
    });
    springs.chain(bending).max().unwrap_or(0)
}

/// The force on each particle at rest (`v = 0`) and the scratch it needs
/// (no wind: no per-triangle shares).
struct Forces {
    still: Points,
    per_spring: Points,
    out: Points,
}

impl Forces {
    fn new(sys: &System<f64>) -> Forces {
        let n = sys.mass.len();
        Forces {
            still: vec![Vec3::ZERO; n],
            per_spring: vec![Vec3::ZERO; sys.springs.len()],
            out: vec![Vec3::ZERO; n],
        }
    }

    /// Every particle's total force \[N\] at positions `x`, at rest.
    fn of(&mut self, sys: &System<f64>, x: &[Vec3<f64>]) -> &[Vec3<f64>] {
        spring_forces(sys, x, &self.still, &mut self.per_spring);
        for (p, out) in self.out.iter_mut().enumerate() {
            *out = total_force(sys, &self.per_spring, &[], x, &self.still, p);
        }
        &self.out
    }
}

/// The potential energy at `x` \[J\]: the springs', the bending's and
/// gravity's.
fn potential(model: &Model, params: &Params, x: &[Vec3<f64>]) -> f64 {
    let e = crate::diagnostics::energy(model, params, x, x);
    let bending = model.bending.as_ref().map_or(0.0, |b| {
        let x: Vec<glam::DVec3> = x.iter().map(|p| p.to_f64().into()).collect();
        b.energy(&x)
    });
    e.gravitational + e.elastic + bending
}

/// `Σ |f_p|² / m_p` over the free particles \[N²/kg\].
fn residual_of(sys: &System<f64>, f: &[Vec3<f64>]) -> f64 {
    f.iter()
        .zip(&sys.inv_mass)
        .map(|(f, &inv)| f.length_squared() * inv)
        .sum()
}

/// The stiffness `K = −∂f/∂x` over the free particles' coordinates in
/// band storage of half-bandwidth `bw` (pinned rows and columns empty,
/// a pinned particle's springs still stiffening its free neighbours):
/// each spring's block `k (c I + (1 − c) n nᵀ)` with `c = 1 − L/l`
/// (negative under compression: unlike the implicit integrator's filtered
/// blocks, `K` may be indefinite, and the damping then grows until
/// `K + μ M` is not), and the bending operator `Q ⊗ I₃`.
fn stiffness(sys: &System<f64>, x: &Points, bw: usize) -> Result<Vec<f64>> {
    let n = x.len();
    let mut band = crate::budget::try_vec(
        (3 * n).saturating_mul(bw + 1),
        0.0f64,
        "the equilibrium's stiffness band",
    )?;
    let free = |p: usize| sys.inv_mass[p] > 0.0;
    // Adds `block` (row particle p, column particle q) where it falls in
    // the stored lower triangle.
    let mut add = |p: usize, q: usize, block: &dyn Fn(usize, usize) -> f64| {
        if !(free(p) && free(q)) {
            return;
        }
        for e in 0..3 {
            for d in 0..3 {
                let (i, j) = (3 * p + e, 3 * q + d);
                if j <= i {
                    band[i * (bw + 1) + (j + bw - i)] += block(e, d);
                }
            }
        }
    };
    for s in &sys.springs {
        let (i, j) = (s.i as usize, s.j as usize);
        let (dir, l) = spring_frame(x[i], x[j]);
        let c = if l > 0.0 { 1.0 - s.rest / l } else { 0.0 };
        let k = |e: usize, d: usize| {
            let across = if e == d { c } else { 0.0 };
            s.k * (across + (1.0 - c) * dir.get(e) * dir.get(d))
        };
        add(i, i, &k);
        add(j, j, &k);
        add(i, j, &|e, d| -k(e, d));
        add(j, i, &|e, d| -k(e, d));
    }
    if let Some(b) = &sys.bending {
        let iso = |value: f64| move |e: usize, d: usize| if e == d { value } else { 0.0 };
        for p in 0..n {
            let (columns, coefficients) = b.row(p);
            for (&q, &qpq) in columns.iter().zip(coefficients) {
                add(p, q as usize, &iso(qpq));
                add(p, p, &iso(-qpq));
            }
        }
    }
    Ok(band)
}

/// `Δx` solving `(K + μ M) Δx = f` on the free coordinates (zero on the
/// pinned), or `None` where that matrix is not positive definite.
fn damped_step(
    sys: &System<f64>,
    stiffness: &[f64],
    bw: usize,
    mu: f64,
    f: &[Vec3<f64>],
) -> Result<Option<Points>> {
    let n = f.len();
    let mut a = crate::budget::try_vec(stiffness.len(), 0.0f64, "the equilibrium's factor")?;
    a.copy_from_slice(stiffness);
    let mut rhs = vec![0.0f64; 3 * n];
    for (p, force) in f.iter().enumerate() {
        for d in 0..3 {
            let i = 3 * p + d;
            let diagonal = &mut a[i * (bw + 1) + bw];
            if sys.inv_mass[p] > 0.0 {
                *diagonal += mu * sys.mass[p];
                rhs[i] = force.get(d);
            } else {
                *diagonal = 1.0;
            }
        }
    }
    if !cholesky_in_place(3 * n, bw, &mut a) {
        return Ok(None);
    }
    solve_in_place(bw, &a, &mut rhs);
    Ok(Some(
        rhs.chunks_exact(3)
            .map(|c| Vec3::from_f64([c[0], c[1], c[2]]))
            .collect(),
    ))
}
