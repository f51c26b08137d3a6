//! Baraff–Witkin linearised backward Euler, solved by a matrix-free
//! modified preconditioned conjugate gradient (MPCG) with constraint
//! filtering.
//!
//! One step solves `(M − dt D − dt² K) Δv = dt (f0 + dt K v0)`, then
//! `v1 = v0 + Δv`, `x1 = x0 + dt v1`. Per spring the system matrix
//! contributes `B = a I + b n nᵀ` acting on `p_i − p_j` (with sign), where
//! - `a = dt² k max(0, 1 − L/l)` — the transverse stiffness; the `max`
//!   drops it for a compressed spring, which keeps `A` positive definite (a
//!   compressed spring's true transverse stiffness is negative: cloth
//!   buckles instead of exploding), and
//! - `b = dt² k − a + dt kd ≥ 0` — the longitudinal stiffness plus damping.
//!
//! With `m = √b n`, `B = a I + m mᵀ`: `A p = M p + Σ ±B_s (p_i − p_j)` is
//! evaluated from four numbers per spring, never as an assembled matrix. The preconditioner `P⁻¹` is the inverse
//! of `A`'s 3×3 diagonal blocks; on a grid cloth the coarse levels of
//! [`super::coarse`] add aggregate corrections to it (`M⁻¹`). The filter `S_p` is `0` for a pinned
//! particle and for a contact static friction holds, `I − n nᵀ` for one
//! resting on a collider (the constrained component of `Δv` is prescribed
//! by `z_p`, which cancels an inward normal velocity, or a held contact's
//! whole velocity relative to the collider; friction: `contact_friction`); CG applies it to the residual and search direction so
//! constrained directions never move.
//!
//! Convergence: stop when `rᵀP⁻¹r ≤ tol² · (Sb)ᵀP⁻¹(Sb)`, i.e. the
//! block-Jacobi preconditioned residual norm relative to the filtered
//! right-hand side — with or without coarse levels, so they change how
//! fast CG gets there, not where "there" is.
//! CG starts from the last two steps' `Δv` extrapolated, `2 Δv₁ − Δv₂`
//! (filtered) — a warm start that cuts iterations for smooth motion
//! without changing the answer beyond the tolerance.
//!
//! A step is the GPU's sequence of kernels, each a function here or in
//! [`super::cg`]: [`springs`], [`prepare`], with coarse levels
//! [`Coarse::setup`](super::coarse::Coarse::setup), [`cg::solve`], [`finish`].
//! On a grid the GPU has no `implicit_springs` pass: its gathering kernels
//! linearise each spring where they use it, with the same arithmetic.

use super::cg::{self, apply_a_unfiltered};
use super::collide::{collide, contact, CONTACT_SLOP};
use super::forces::{
    bending_diagonal, bending_product, gather_signed, spring_force, spring_frame, total_force,
    wind_forces,
};
use super::mat3::Sym3;
use super::motion::{self, pin_velocity};
use super::self_collision;
use super::{State, StepStats, System, Workspace};
use crate::real::{Real, Vec3};

/// Per-particle constraint: what `S_p` keeps free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter<R> {
    /// Unconstrained: `S = I`.
    Free,
    /// Pinned: `S = 0`.
    Fixed,
    /// On a surface with this normal and friction coefficient:
    /// `S = I − n nᵀ`.
    Plane(Vec3<R>, R),
    /// On a surface (normal, friction coefficient) that static friction
    /// held at the end of the last step: `S = 0`, `Δv` takes the particle
    /// to the collider's velocity, so the solve moves its neighbours
    /// knowing it stays (see `contact_friction`).
    Held(Vec3<R>, R),
}

impl<R: Real> Filter<R> {
    /// Applies `S` to a vector.
    #[inline]
    pub fn apply(self, v: Vec3<R>) -> Vec3<R> {
        match self {
            Filter::Free => v,
            Filter::Fixed | Filter::Held(..) => Vec3::ZERO,
            Filter::Plane(n, _) => v - n * v.dot(n),
        }
    }
}

/// Per-spring linearisation at the start of the step, `B = a I + m mᵀ`
/// with `m = √b n` (`b ≥ 0`, see the module docs): four numbers, one
/// `vec4` on the GPU, where CG's inner loop is bound by loads.
#[derive(Clone, Copy, Debug, Default)]
pub struct SpringBlock<R> {
    /// `√b n` [√kg].
    pub m: Vec3<R>,
    /// Isotropic coefficient `a` \[kg\].
    pub a: R,
    /// The spring's ends, copied here so CG's inner loop streams one array.
    pub ends: [u32; 2],
}

impl<R: Real> SpringBlock<R> {
    /// `B d = a d + m (m·d)`.
    #[inline]
    pub fn apply(&self, d: Vec3<R>) -> Vec3<R> {
        d * self.a + self.m * self.m.dot(d)
    }
}

/// The velocity [m/s] of the collider a particle at `x` touches at the
/// start of the step (twin: `contact_velocity` in
/// `shaders/common/physics.wgsl`): the filter's contact, found again.
fn contact_velocity<R: Real>(sys: &System<R>, x: Vec3<R>, clock: u32) -> Vec3<R> {
    contact(sys, x, R::from_f64(CONTACT_SLOP), clock).map_or(Vec3::ZERO, |c| c.velocity)
}

/// Coulomb friction at the contacts the filter constrained, relative to
/// the collider's velocity: what the next step applies (`w.held`,
/// `w.friction`).
///
/// Friction acts inside the solve, never on its answer: changing a
/// contact's velocity after the solve moved its neighbours as if it slid
/// would stretch its springs by what it would have slid, and a steep
/// drape's contacts stopped that way every step pump energy in until it
/// blows up. The filter removed the contacts' normal motion before
/// anything could measure it, so the normal force comes from the
/// constraint impulse `r = A Δv − b` [N·s], the momentum the surface had
/// to supply; friction may then supply up to `μ r·n` the next step:
/// - a held contact ([`Filter::Held`]) stays held while `r` lies in the
///   friction cone (`|r − n (r·n)| ≤ μ r·n`); out of it, it slides next
///   step with `μ r·n` along `r`'s tangential part (what the surface
///   resisted with);
/// - a sliding contact that `μ r·n` can stop (its tangential momentum
///   relative to the collider is no more) is held next step; one it cannot
///   stop slides with `μ r·n` against its tangential velocity, an impulse
///   the next [`prepare`] adds to the right-hand side;
/// - a contact the surface did not push (`r·n ≤ 0`) is free of friction.
///
/// Twin: the friction of `implicit_predict_item` in
/// `shaders/common/implicit.wgsl`.
fn contact_friction<R: Real>(sys: &System<R>, st: &State<R>, w: &mut Workspace<R>) {
    apply_a_unfiltered(sys, &w.blocks, &w.dv, &mut w.q);
    for p in 0..st.v.len() {
        let (held, friction) = match w.filter[p] {
            Filter::Plane(normal, mu) | Filter::Held(normal, mu) => {
                let r = w.q[p] - w.rhs[p];
                let pushed = r.dot(normal);
                let budget = mu * pushed;
                if pushed <= R::ZERO || budget <= R::ZERO {
                    (false, Vec3::ZERO)
                } else if let Filter::Held(..) = w.filter[p] {
                    let resisted = r - normal * pushed;
                    let needed = resisted.length();
                    if needed <= budget {
                        (true, Vec3::ZERO)
                    } else {
                        (false, resisted * (budget / needed))
                    }
                } else {
                    let vc = contact_velocity(sys, st.x[p], w.clock);
                    let rel = st.v[p] - vc;
                    let tangential = rel - normal * rel.dot(normal);
                    let speed = tangential.length();
                    if speed * sys.mass[p] <= budget {
                        (true, Vec3::ZERO)
                    } else {
                        (false, tangential * (-budget / speed))
                    }
                }
            }
            Filter::Free | Filter::Fixed => (false, Vec3::ZERO),
        };
        w.held[p] = held;
        w.friction[p] = friction;
    }
}

/// The share `c = max(0, 1 − L/l)` of a spring's stiffness that acts
/// across it, at length `l` \[m\] and rest length `rest` \[m\]: zero for a
/// compressed spring (its true transverse stiffness is negative) and for a
/// degenerate one (twin: `spring_transverse` in `shaders/common/cg.wgsl`).
#[inline]
pub fn transverse<R: Real>(rest: R, l: R) -> R {
    if l > R::TINY {
        (R::ONE - rest / l).max(R::ZERO)
    } else {
        R::ZERO
    }
}

/// `K_s u = −k (c u + (1 − c) n (n·u))` \[N/s\]: the spring's
/// Jacobian (stiffness `k` \[N/m\], transverse share `c` from
/// [`transverse`], direction `n`) applied to `u = v_i − v_j` \[m/s\]
/// (twin: `spring_kv` in `shaders/common/cg.wgsl`).
#[inline]
pub fn spring_kv<R: Real>(k: R, c: R, n: Vec3<R>, u: Vec3<R>) -> Vec3<R> {
    let k_long = k * (R::ONE - c);
    -(u * (k * c) + n * (k_long * n.dot(u)))
}

/// Twin of `shaders/implicit_springs.wgsl`: every spring linearised at
/// the start of the step. Reads `x`, `v`; writes `blocks` (the GPU's
/// `S_BLOCK`: xyz `m`, w `a`), `kv`, `K_s (v_i − v_j)` on end `i` (`S_KV`),
/// and `per_spring`, the spring's force on end `i` (`S_FORCE`).
pub fn springs<R: Real>(sys: &System<R>, st: &State<R>, w: &mut Workspace<R>) {
    let dt = sys.dt;
    let dt2 = dt * dt;
    for (s, sp) in sys.springs.iter().enumerate() {
        let (i, j) = (sp.i as usize, sp.j as usize);
        let (dir, l) = spring_frame(st.x[i], st.x[j]);
        let transverse = transverse(sp.rest, l);
        let a = dt2 * sp.k * transverse;
        let b = dt2 * sp.k - a + dt * sp.kd;
        w.blocks[s] = SpringBlock {
            m: dir * b.max(R::ZERO).sqrt(),
            a,
            ends: [sp.i, sp.j],
        };
        w.kv[s] = spring_kv(sp.k, transverse, dir, st.v[i] - st.v[j]);
        w.per_spring[s] = spring_force(sys, s, &st.x, &st.v);
    }
}

/// Twin of `shaders/implicit_prepare.wgsl`, per particle: the total force,
/// the constraint filter and `z`, the right-hand side, the block-diagonal
/// preconditioner, with coarse levels the particle's contributions to its
/// aggregates' `D`, the warm-started `Δv` and δ0's term; CG's count and
/// stop are reset. Reads `x`, `v`, `per_spring`, `kv`, `blocks`, `dv`,
/// `dv_prev`; writes `force`, `per_triangle` (wind), `filter` and `z` (the
/// GPU's `W_FILTER` and `W_Z`, whose w is the filter kind), `rhs`,
/// `delta0_terms` (`W_RHS`'s w), `precond` (`W_PRE_DIAG`, `W_PRE_OFF`),
/// `dv` (`W_DV`, w the filter kind), `dv_prev`, the coarse levels'
/// `contrib` and `trace`, and `cg`.
pub fn prepare<R: Real>(sys: &System<R>, st: &State<R>, w: &mut Workspace<R>) {
    let dt = sys.dt;
    wind_forces(sys, &st.x, &st.v, &mut w.per_triangle);
    w.cg.iterations = 0;
    w.cg.stopped = false;
    for p in 0..st.x.len() {
        w.force[p] = total_force(sys, &w.per_spring, &w.per_triangle, &st.x, &st.v, p);
        // The filter and z, the prescribed Δv in constrained directions: a
        // pin's change to its prescribed velocity (Baraff–Witkin's moving
        // constraints), a held contact's velocity relative to its collider,
        // a sliding contact's approach speed relative to it.
        (w.filter[p], w.z[p]) = if sys.inv_mass[p] <= R::ZERO {
            let pin = pin_velocity(sys, &w.pin_goal[p], w.clock, st.x[p]);
            (Filter::Fixed, pin - st.v[p])
        } else {
            match contact(sys, st.x[p], R::from_f64(CONTACT_SLOP), w.clock) {
                // Static friction held it at the end of the last step.
                Some(c) if w.held[p] => (Filter::Held(c.normal, c.friction), c.velocity - st.v[p]),
                // Constrain only a particle pushed or moving into the surface:
                // one pulled away is free to lift off this step.
                Some(c)
                    if w.force[p].dot(c.normal) < R::ZERO
                        || (st.v[p] - c.velocity).dot(c.normal) < R::ZERO =>
                {
                    let approach = (st.v[p] - c.velocity).dot(c.normal);
                    (
                        Filter::Plane(c.normal, c.friction),
                        c.normal * (-approach.min(R::ZERO)),
                    )
                }
                _ => (Filter::Free, Vec3::ZERO),
            }
        };
        let kv = gather_signed(&sys.spring_adj, &w.kv, p) - bending_product(sys, &st.v, p);
        w.rhs[p] = (w.force[p] + kv * dt) * dt;
        // A sliding contact's friction from the last step's normal force.
        if let Filter::Plane(..) = w.filter[p] {
            w.rhs[p] += w.friction[p];
        }
        let mut diag = Sym3::scaled_identity(sys.mass[p]);
        if let Some(b) = &sys.bending {
            diag.add_iso_aniso(bending_diagonal(b, p) * b.scale, R::ZERO, Vec3::ZERO);
        }
        let mut levels = [diag; 2];
        for &e in sys.spring_adj.of(p) {
            let blk = &w.blocks[(e >> 1) as usize];
            diag.add_iso_aniso(blk.a, R::ONE, blk.m);
            if let Some(coarse) = &w.coarse {
                let other = blk.ends[(e & 1 == 0) as usize] as usize;
                for (level, d) in levels.iter_mut().enumerate() {
                    if coarse.of[other][level] != coarse.of[p][level] {
                        d.add_iso_aniso(blk.a, R::ONE, blk.m);
                    }
                }
            }
        }
        if let Some(coarse) = &mut w.coarse {
            coarse.contrib[p] = levels;
            coarse.trace[p] = diag.m[0] + diag.m[1] + diag.m[2];
        }
        // A's diagonal block is m I plus positive semi-definite terms, so it
        // is invertible; the fallback only guards a pathological input.
        w.precond[p] = diag
            .inverse()
            .unwrap_or(Sym3::scaled_identity(R::ONE / sys.mass[p]));
        w.dv[p] = w.filter[p].apply(warm_start(w, p)) + w.z[p];
        let sb = w.filter[p].apply(w.rhs[p]);
        w.delta0_terms[p] = sb.dot(w.precond[p].mul(sb));
    }
}

/// CG's start for particle `p`, unfiltered: the last two steps' `Δv`
/// extrapolated linearly (2 Δv₁ − Δv₂) — on smooth motion a closer guess
/// than the last `Δv` alone, so fewer iterations, and CG corrects it
/// either way; the last `Δv` becomes `dv_prev` (twin: `warm_start` in
/// `shaders/common/cg.wgsl`).
pub(crate) fn warm_start<R: Real>(w: &mut Workspace<R>, p: usize) -> Vec3<R> {
    let guess = w.dv[p] * R::from_f64(2.0) - w.dv_prev[p];
    w.dv_prev[p] = w.dv[p];
    guess
}

/// Twin of `shaders/implicit_finish.wgsl`: `v += Δv`, friction at the
/// filtered contacts (`contact_friction`), `x += dt v`, self-collision
/// (`self_collision::project`), collisions.
/// Reads `dv`, `filter`, `rhs`, `blocks`; writes `x`, `v` (and `q`,
/// scratch).
pub fn finish<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    for p in 0..st.x.len() {
        st.v[p] += w.dv[p];
    }
    if w.filter
        .iter()
        .any(|f| matches!(f, Filter::Plane(..) | Filter::Held(..)))
    {
        contact_friction(sys, st, w);
    } else {
        w.held.fill(false);
        w.friction.fill(Vec3::ZERO);
    }
    // The step's start, for self-collision and the colliders: before the
    // pins move, so that a moving pin's displacement counts in its
    // contacts' friction (the GPU reads it from x, which holds the step's
    // start until the step's end).
    w.x_old.copy_from_slice(&st.x);
    motion::move_pins(sys, &mut st.x, &mut st.v, w);
    for p in 0..st.x.len() {
        if sys.inv_mass[p] > R::ZERO {
            st.x[p] += st.v[p] * sys.dt;
        }
    }
    self_collision::project(sys, st, w);
    // Particles that were not touching at the start of the step can still
    // end it inside a collider.
    collide(sys, &w.x_old, &mut st.x, &mut st.v, w.clock);
    super::unsigned_zeros(st);
    w.clock = w.clock.wrapping_add(1);
}

/// One implicit step: the GPU's kernels in its order.
pub fn step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    springs(sys, st, w);
    prepare(sys, st, w);
    if let Some(coarse) = &mut w.coarse {
        coarse.setup(&sys.mass);
    }
    cg::solve(sys, w);
    finish(sys, st, w);
    let (rho, delta0) = (w.cg.rho, w.cg.delta0);
    let residual = if delta0 > R::ZERO {
        (rho / delta0).to_f64().max(0.0).sqrt()
    } else {
        0.0
    };
    StepStats {
        cg_iterations: w.cg.iterations,
        cg_residual: Some(residual),
        ..StepStats::default()
    }
}
