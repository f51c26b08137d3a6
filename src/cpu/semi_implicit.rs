//! Desbrun's semi-implicit split with torque compensation and fix-up.
//!
//! Each spring force `−k (l − L) n` is split into a linear part `−k d` and
//! the rest. The linear parts form the constant Laplacian `H`; the step
//! treats it implicitly and everything else explicitly:
//!
//! `(M − dt² H) Δv = dt (f(x, v) + dt K v)`, i.e. `Δv = W dt (f + dt K v)`
//!
//! with the constant filter `W` (see [`super::filter`]). Spring damping is
//! part of `f`, i.e. explicit. `K` is the stiffness of the velocity term:
//!
//! 1. **Torque compensation, per spring.** The linear part treats every
//!    spring as zero-rest-length, and such a spring resists being turned
//!    with its whole stiffness: with `K = H` the filter damps every spring's
//!    rotation by `dt k`, far more than the mass can carry at cloth steps,
//!    and the cloth moves as a board. The neglected non-linear part
//!    `k L n` cancels exactly that (its Jacobian `k (L/l)(I − n nᵀ)` is a
//!    rotation term), so with the compensation on `K` is each spring's own
//!    Jacobian, `k (c I + (1 − c) n nᵀ)` with `c = max(0, 1 − L/l)`
//!    ([`spring_kv`], the implicit integrator's): a spring resists across
//!    itself only with the stiffness its tension gives it. It is local, so
//!    it applies to pinned cloths too. A spring touching a collider keeps
//!    `K = H` (see `jacobian_v`). Off, `K = H`.
//! 2. **Torque compensation, global.** For a cloth without pins the
//!    angular impulse of `Δv` about the centre of mass minus that of the
//!    external forces (`dt Σ r × f_ext`) is cancelled by a rigid rotation
//!    `Δv_p −= ω × r_p`, `ω = I⁻¹ ΔL` (`I` the inertia tensor), so a free
//!    cloth keeps its angular momentum. Linear momentum is untouched
//!    (`Σ m ω × r = 0`). Pins exert real torque, so it does not apply to a
//!    pinned cloth.
//! 3. `v ← v + Δv`, `x* ← x + dt v`, fix-up, `v ← (x* − x)/dt` if the fix-up
//!    moved anything (as in the explicit scheme).
//!
//! For a single linear spring along its axis with one end pinned the step is
//! exactly backward Euler.
//!
//! A step is the GPU's sequence of kernels: `spring_forces`
//! ([`forces::spring_forces`]; on a grid the GPU computes the forces in
//! `semi_rhs`), [`rhs`], `filter_dense`
//! ([`DenseFilter::apply`](super::filter::DenseFilter::apply)), the three
//! torque passes ([`super::torque`]), [`integrate`], the fix-up passes and
//! `finish_step` (as in the explicit step). Beyond the dense filter's
//! size the GPU solves the filter by CG on the device ([`cg_prepare`] and
//! the CG kernels) while the CPU applies the exact banded factor.

use super::collide::{contact, CONTACT_SLOP};
use super::forces::{
    self, bending_diagonal, bending_product, external_forces, spring_frame, total_force,
    wind_forces,
};
use super::implicit::{spring_kv, transverse, warm_start, Filter};
use super::mat3::Sym3;
use super::{fixup_and_finish, predict, torque, State, StepStats, System, Workspace};
use crate::real::{Real, Vec3};

/// Whether a particle at `x` touches a collider (within the implicit
/// integrator's [`CONTACT_SLOP`]), the colliders where they are at the
/// particle clock `clock`.
fn touching<R: Real>(sys: &System<R>, x: Vec3<R>, clock: u32) -> bool {
    contact(sys, x, R::from_f64(CONTACT_SLOP), clock).is_some()
}

/// The velocity term of the filter's right-hand side for particle `p`,
/// `Σ ±K_s (v_i − v_j)` over its springs in adjacency order, `K_s` each
/// spring's stiffness as the filter's linear part sees it. Compensated
/// (`rotation_free`), a spring resists across itself only with the share
/// `max(0, 1 − L/l)` that its tension gives it, as the real spring does:
/// the implicit integrator's Jacobian ([`spring_kv`]). Uncompensated, `K_s`
/// is the linear part's `k I`, which resists every rotation of the spring
/// as if it had zero rest length. A spring with an end on a collider keeps
/// `k I` either way: the constant filter cannot hold a contact as the
/// implicit integrator's CG does, and without that resistance a cloth
/// landing on a collider at a large step diverges at contact (`touching`:
/// per particle, as [`touching`] says at the step's start).
fn jacobian_v<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    v: &[Vec3<R>],
    p: usize,
    rotation_free: bool,
    touching: &[bool],
) -> Vec3<R> {
    let mut acc = Vec3::ZERO;
    for &e in sys.spring_adj.of(p) {
        let sp = &sys.springs[(e >> 1) as usize];
        let (i, j) = (sp.i as usize, sp.j as usize);
        let (dir, l) = spring_frame(x[i], x[j]);
        let c = if rotation_free && !touching[i] && !touching[j] {
            transverse(sp.rest, l)
        } else {
            R::ONE
        };
        let term = spring_kv(sp.k, c, dir, v[i] - v[j]);
        if e & 1 == 0 {
            acc += term;
        } else {
            acc -= term;
        }
    }
    acc
}

/// Twin of `shaders/semi_rhs.wgsl`: each particle's total force from the
/// spring pass and the filter's right-hand side `dt (f + dt K v)` (`K v`
/// from `jacobian_v`, per-spring compensated when the torque
/// compensation is on); `Δv` zeroed where `zero_dv` (the dense filter;
/// the GPU's CG filter keeps it as its warm start: the `keep` variant).
/// Reads `x`, `v`, `per_spring`; writes `touching` (compensated), `force`, `per_triangle` (wind),
/// `rhs` (`W_RHS`, w 0) and `dv`.
pub fn rhs<R: Real>(sys: &System<R>, st: &State<R>, w: &mut Workspace<R>, zero_dv: bool) {
    let dt = sys.dt;
    wind_forces(sys, &st.x, &st.v, &mut w.per_triangle);
    if sys.torque_compensation {
        // Once per particle, not once per spring end as the kernel does
        // (the same answers: a pure function of the particle's position).
        for (t, &x) in w.touching.iter_mut().zip(&st.x) {
            *t = touching(sys, x, w.clock);
        }
    }
    for p in 0..st.x.len() {
        w.force[p] = total_force(sys, &w.per_spring, &w.per_triangle, &st.x, &st.v, p);
        let kv = jacobian_v(sys, &st.x, &st.v, p, sys.torque_compensation, &w.touching)
            - bending_product(sys, &st.v, p);
        w.rhs[p] = (w.force[p] + kv * dt) * dt;
        if zero_dv {
            w.dv[p] = Vec3::ZERO;
        }
    }
}

/// Twin of `shaders/semi_integrate.wgsl`: `v += Δv` for free particles,
/// then the prediction `x* = x + dt v` (`predict`). Reads `x`, `v`,
/// `dv`; writes `x_old`, and `x*`, `v*` into `st` (the GPU's `W_X_PRED`,
/// `W_V_NEW`).
pub fn integrate<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    for p in 0..st.x.len() {
        if sys.inv_mass[p] > R::ZERO {
            st.v[p] += w.dv[p];
        }
    }
    predict(sys, st, w);
}

/// Twin of `shaders/semi_cg_prepare.wgsl`, which sets up the GPU's CG
/// solve of the filter's matrix `A = M − dt² H` (beyond the dense filter's
/// size): `w.blocks` hold `A`'s constant spring blocks (`a = dt² k`, `m =
/// 0`, the GPU's `S_BLOCK`), pins are fixed filters, the preconditioner is
/// Jacobi's, `Δv` is warm-started, and δ0's terms are left as in
/// [`super::implicit::prepare`]; CG's count and stop are reset. Reads
/// `blocks`, `rhs`, `dv`, `dv_prev`; writes `filter`, `z` (zero),
/// `precond`, `dv`, `dv_prev`, `delta0_terms`, `cg`. The CPU's own step
/// applies the exact banded factor instead and never calls this.
pub fn cg_prepare<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    w.cg.iterations = 0;
    w.cg.stopped = false;
    for p in 0..sys.mass.len() {
        w.filter[p] = if sys.inv_mass[p] <= R::ZERO {
            Filter::Fixed
        } else {
            Filter::Free
        };
        let mut diag = sys.mass[p];
        for &e in sys.spring_adj.of(p) {
            diag += w.blocks[(e >> 1) as usize].a;
        }
        if let Some(b) = &sys.bending {
            diag += bending_diagonal(b, p) * b.scale;
        }
        w.z[p] = Vec3::ZERO;
        w.precond[p] = Sym3::scaled_identity(R::ONE / diag);
        w.dv[p] = w.filter[p].apply(warm_start(w, p));
        let sb = w.filter[p].apply(w.rhs[p]);
        w.delta0_terms[p] = sb.dot(w.precond[p].mul(sb));
    }
}

/// One semi-implicit step: the GPU's kernels in its order. `w.constant_filter`
/// must be built for the current system.
pub fn step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    forces::spring_forces(sys, &st.x, &st.v, &mut w.per_spring);
    rhs(sys, st, w, true);
    if let Some(filter) = &w.constant_filter {
        filter.apply(&w.rhs, &mut w.dv, &mut w.scratch);
    }
    if sys.torque_compensation && sys.pinned_count == 0 {
        external_forces(sys, &st.x, &st.v, &mut w.per_triangle, &mut w.force);
        torque::centre(sys, &st.x, &mut w.torque);
        torque::moments(sys, &st.x, &w.dv, &w.force, &mut w.torque);
        torque::apply(&st.x, &w.torque, &mut w.dv);
    }
    integrate(sys, st, w);
    fixup_and_finish(sys, st, w)
}
