//! Handing a running cloth to a new solver (an integrator switch): shared
//! by the viewer and the web page (`web/src/cloth.rs`).

use wgcloth::gpu::GpuState;
use wgcloth::GpuSolver;

/// Gives `solver` the positions and velocities of `state`, read back from
/// the solver it replaces; the particles `pinned` marks (the scene's pins)
/// keep standing still.
pub fn hand_over(solver: &mut GpuSolver, state: GpuState, pinned: &[bool]) -> wgcloth::Result<()> {
    let particles = state.x.into_iter().zip(state.v).zip(pinned);
    for (i, ((x, v), &pinned)) in particles.enumerate() {
        solver.set_position(i, x)?;
        if !pinned {
            solver.set_velocity(i, v)?;
        }
    }
    Ok(())
}
