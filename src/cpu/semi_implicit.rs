//! Desbrun's semi-implicit split with torque compensation and fix-up.
//!
//! Each spring force `−k (l − L) n` is split into a linear part `−k d` and
//! the rest. The linear parts form the constant Laplacian `H`; the step
//! treats it implicitly and everything else explicitly:
//!
//! `(M − dt² H) Δv = dt (f(x, v) + dt H v)`, i.e. `Δv = W dt (f + dt H v)`
//!
//! with the constant filter `W` (see [`super::filter`]). Spring damping is
//! part of `f`, i.e. explicit. Then:
//!
//! 1. **Torque compensation.** The linear model resists rigid rotation
//!    (a rotating spring's `d` changes though its length does not), so the
//!    filtered response of a free cloth carries a spurious angular impulse.
//!    We remove it: with `r_p` measured from the centre of mass, the
//!    angular impulse of `Δv` minus that of the external forces
//!    (`dt Σ r × f_ext`) is cancelled by a rigid rotation
//!    `Δv_p −= ω × r_p`, `ω = I⁻¹ ΔL` (`I` the inertia tensor). Linear
//!    momentum is untouched (`Σ m ω × r = 0`). It is applied only to a cloth
//!    without pins: pins hold the rotational modes themselves and exert real
//!    torque, which the filter — with the pins constrained inside it —
//!    already treats implicitly.
//! 2. `v ← v + Δv`, `x* ← x + dt v`, fix-up, `v ← (x* − x)/dt` if the fix-up
//!    moved anything (as in the explicit scheme).
//!
//! For a single linear spring along its axis with one end pinned the step is
//! exactly backward Euler.

use super::forces::external_forces;
use super::implicit::block_sum;
use super::mat3::Sym3;
use super::{finish_with_fixup, State, StepStats, System, Workspace};
use crate::real::{Real, Vec3};

/// One semi-implicit step. `w.filter` must be built for the current system.
pub fn step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    let n = st.x.len();
    let dt = sys.dt;
    w.compute_forces(sys, st);
    // per_spring ← k (v_i − v_j); (H v)_p = −Σ ± per_spring.
    for (s, sp) in sys.springs.iter().enumerate() {
        w.per_spring[s] = (st.v[sp.i as usize] - st.v[sp.j as usize]) * sp.k;
    }
    for p in 0..n {
        let hv = -super::forces::gather_signed(&sys.spring_adj, &w.per_spring, p);
        w.rhs[p] = (w.force[p] + hv * dt) * dt;
        w.dv[p] = Vec3::ZERO;
    }
    if let Some(filter) = &w.constant_filter {
        filter.apply(&w.rhs, &mut w.dv, &mut w.scratch);
    }
    if sys.torque_compensation && sys.pinned_count == 0 {
        external_forces(sys, &st.x, &st.v, &mut w.per_triangle, &mut w.force);
        compensate_torque(sys, &st.x, &w.force, &mut w.dv);
    }
    for p in 0..n {
        if sys.inv_mass[p] > R::ZERO {
            st.v[p] += w.dv[p];
        }
    }
    finish_with_fixup(sys, st, w)
}

/// Removes from `dv` the angular impulse (about the centre of mass) that
/// is not accounted for by the external forces `f_ext`.
///
/// Every sum is a [`block_sum`], the GPU's reduction order.
fn compensate_torque<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    f_ext: &[Vec3<R>],
    dv: &mut [Vec3<R>],
) {
    let n = x.len();
    let m = &sys.mass;
    let total = block_sum(n, |p| m[p]);
    let weighted = |k: usize| block_sum(n, |p| (x[p] * m[p]).get(k));
    let centre = Vec3::new(weighted(0), weighted(1), weighted(2)) / total;
    let r = |p: usize| x[p] - centre;
    let moment = |p: usize| r(p).cross(dv[p] * m[p] - f_ext[p] * sys.dt);
    let excess = Vec3::new(
        block_sum(n, |p| moment(p).x),
        block_sum(n, |p| moment(p).y),
        block_sum(n, |p| moment(p).z),
    );
    // Inertia Σ m (|r|² I − r rᵀ), one tree sum per stored entry.
    let term = |p: usize, k: usize| {
        let mut t = Sym3::default();
        t.add_iso_aniso(m[p] * r(p).length_squared(), -m[p], r(p));
        t.m[k]
    };
    let inertia = Sym3 {
        m: std::array::from_fn(|k| block_sum(n, |p| term(p, k))),
    };
    // A cloth collapsed onto a line or point has a singular inertia tensor:
    // it has no well-defined rotation to remove, so leave it.
    let Some(inv) = inertia.inverse() else {
        return;
    };
    let omega = inv.mul(excess);
    for p in 0..x.len() {
        dv[p] -= omega.cross(x[p] - centre);
    }
}
