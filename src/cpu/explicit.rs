//! Symplectic Euler with Provot deformation constraints.
//!
//! `v ← v + dt w f`, `x* ← x + dt v`, then the fix-up on `x*`, then (only
//! when the fix-up moved something) `v ← (x* − x) / dt`, and `x ← x*`.
//! Skipping the velocity rebuild when nothing moved keeps the scheme
//! bit-for-bit symplectic Euler without constraints (no `(x + dt v − x)/dt`
//! rounding), which is what the closed-form tests check.
//!
//! A step is the GPU's sequence of kernels: `spring_forces`
//! ([`forces::spring_forces`]), [`integrate`], the fix-up passes
//! (`fixup_jacobi`, [`super::fixup::jacobi`]), `finish_step`
//! ([`super::finish_step`]). On a grid the GPU computes the spring forces
//! inside `explicit_integrate`, and without fix-up it fuses the whole step
//! into that one kernel (the `FUSED` variants: [`integrate`] then
//! [`super::finish_step`]), alternating the state with a snapshot that
//! [`seed`] starts.

use super::forces::{self, total_force, wind_forces};
use super::{fixup_and_finish, predict, State, StepStats, System, Workspace};
use crate::real::Real;

/// Twin of `shaders/explicit_integrate.wgsl`: each particle's total force
/// from the spring pass, `v* = v + dt w f`, `x* = x + dt v*` (pinned:
/// `x* = x`, `v* = 0`; see `predict`). Reads `x`, `v`, `per_spring`;
/// writes `force`, `per_triangle` (wind), `x_old` (the GPU keeps it in
/// `x`), and `x*`, `v*` into `st` (the GPU's `W_X_PRED`, `W_V_NEW`).
pub fn integrate<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    wind_forces(sys, &st.x, &st.v, &mut w.per_triangle);
    // Every force from the step's start before any velocity changes: the
    // bending force reads the neighbours' velocities.
    for p in 0..st.x.len() {
        w.force[p] = total_force(sys, &w.per_spring, &w.per_triangle, &st.x, &st.v, p);
    }
    for p in 0..st.x.len() {
        st.v[p] += w.force[p] * (sys.dt * sys.inv_mass[p]);
    }
    predict(sys, st, w);
}

/// Twin of `shaders/explicit_seed.wgsl`: the snapshot that single-pass
/// GPU steps alternate the state with, a copy of it (`x` and `v`; on the
/// GPU their w, inverse mass and mass, come along). The CPU steps in
/// place and never needs one.
pub fn seed<R: Real>(st: &State<R>, snapshot: &mut State<R>) {
    snapshot.x.clone_from(&st.x);
    snapshot.v.clone_from(&st.v);
}

/// One explicit step: the GPU's kernels in its order.
pub fn step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    forces::spring_forces(sys, &st.x, &st.v, &mut w.per_spring);
    integrate(sys, st, w);
    fixup_and_finish(sys, st, w)
}
