//! Moving pins and the particle clock.
//!
//! Every particle counts the steps it has finished (its clock: the GPU
//! keeps one per particle in the `work` section `CLOCK`, so no kernel
//! reads a count that another invocation of its own dispatch is changing;
//! the CPU keeps the one count they all share). The moving colliders'
//! time comes from it (`collide::collider_time`), and so do the
//! moving pins':
//!
//! A pinned particle has a target `(position, end)` (the GPU's `work`
//! section `PIN_TARGET`): during the steps whose end clock is at most
//! `end` it moves at the velocity that reaches `position` at `end`,
//! `(position − x) / ((end − clock) dt)`, recomputed from where it is each
//! step (constant up to rounding), and the step ending at `end` puts it
//! on `position` itself, so the target is hit exactly at the frame's end
//! whatever the rounding on the way. Outside that window the pin stands
//! still (velocity zero). A pinned particle's velocity is the one it moved
//! at, which the forces, the damping and the implicit step's right-hand
//! side see.

use super::{System, Workspace};
use crate::real::{Real, Vec3};

pub use crate::kernel_config::MAX_FRAME_STEPS;

/// A pinned particle's target: where it is to be \[m\] at the end of the
/// step that brings its clock to `end`. `end = 0` at the start: still.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PinGoal<R> {
    /// Target position \[m\].
    pub position: Vec3<R>,
    /// The clock value at which it is there.
    pub end: u32,
}

/// The velocity [m/s] of a pinned particle at `x` during the step that
/// starts at clock `clock` (twin: `pin_velocity` in
/// `shaders/common/physics.wgsl`): towards its goal, or zero outside the
/// goal's window.
pub fn pin_velocity<R: Real>(
    sys: &System<R>,
    goal: &PinGoal<R>,
    clock: u32,
    x: Vec3<R>,
) -> Vec3<R> {
    let remaining = goal.end.wrapping_sub(clock);
    if remaining.wrapping_sub(1) < MAX_FRAME_STEPS {
        (goal.position - x) / (R::from_f64(f64::from(remaining)) * sys.dt)
    } else {
        Vec3::ZERO
    }
}

/// A pinned particle's position and velocity at the end of the step that
/// starts at clock `clock` from `x` (twin: `pin_step`): `x + dt v`, or the
/// goal itself on its last step.
pub fn pin_step<R: Real>(
    sys: &System<R>,
    goal: &PinGoal<R>,
    clock: u32,
    x: Vec3<R>,
) -> (Vec3<R>, Vec3<R>) {
    let v = pin_velocity(sys, goal, clock, x);
    if goal.end.wrapping_sub(clock) == 1 {
        (goal.position, v)
    } else {
        (x + v * sys.dt, v)
    }
}

/// Moves every pinned particle one step (after the free ones' update),
/// then advances the clock: the end of every step.
pub(crate) fn move_pins<R: Real>(
    sys: &System<R>,
    x: &mut [Vec3<R>],
    v: &mut [Vec3<R>],
    w: &Workspace<R>,
) {
    if sys.pinned_count == 0 {
        return;
    }
    for p in 0..x.len() {
        if sys.inv_mass[p] <= R::ZERO {
            (x[p], v[p]) = pin_step(sys, &w.pin_goal[p], w.clock, x[p]);
        }
    }
}
