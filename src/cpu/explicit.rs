//! Symplectic Euler with Provot deformation constraints.
//!
//! `v ← v + dt w f`, `x* ← x + dt v`, then the fix-up on `x*`, then (only
//! when the fix-up moved something) `v ← (x* − x) / dt`, and `x ← x*`.
//! Skipping the velocity rebuild when nothing moved keeps the scheme
//! bit-for-bit symplectic Euler without constraints (no `(x + dt v − x)/dt`
//! rounding), which is what the closed-form tests check.

use super::{finish_with_fixup, State, StepStats, System, Workspace};

/// One explicit step.
pub fn step<R: crate::Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    w.compute_forces(sys, st);
    for p in 0..st.x.len() {
        st.v[p] += w.force[p] * (sys.dt * sys.inv_mass[p]);
    }
    finish_with_fixup(sys, st, w)
}
