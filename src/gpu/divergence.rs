//! The divergence rule ([`Divergence`]) applied to a GPU solver's state:
//! the device catches a non-finite state at the exact step by itself (see
//! [`GpuSolver::check`]); the finite bounds need the state on the host.

use super::errors::block_on;
use super::solver::{GpuSolver, GpuState};
use crate::diagnostics::{Divergence, Motion};
use crate::error::Result;

impl GpuSolver {
    /// The divergence rule for this solver's model and current parameters,
    /// starting from its current state (one read-back). Native only (see
    /// [`GpuSolver::divergence_rule_async`]).
    pub fn divergence_rule(&self) -> Result<Divergence> {
        block_on(
            "GpuSolver::divergence_rule_async",
            self.divergence_rule_async(),
        )
    }

    /// [`GpuSolver::divergence_rule`] as a future, for a browser's event
    /// loop.
    pub async fn divergence_rule_async(&self) -> Result<Divergence> {
        let state = self.read_state_async().await?;
        Ok(Divergence::new(
            &self.model,
            &self.host_params,
            self.time(),
            &state.x,
            &state.v,
        ))
    }

    /// Reads the state back (blocking) and applies `rule` to it at the last
    /// recorded step, bounding the work of the bodies as this solver moved
    /// them ([`GpuSolver::motion`]): [`crate::Error::NonFinite`] with the
    /// exact step the device recorded, or [`crate::Error::Diverged`]. An
    /// embedder calls this every [`crate::diagnostics::CHECK_EVERY`] steps
    /// and at its last step; it returns the state it judged. Native only
    /// (see [`GpuSolver::check_divergence_async`]).
    pub fn check_divergence(&self, rule: &Divergence) -> Result<GpuState> {
        block_on(
            "GpuSolver::check_divergence_async",
            self.check_divergence_async(rule),
        )
    }

    /// [`GpuSolver::check_divergence`] as a future, for a browser's event
    /// loop.
    pub async fn check_divergence_async(&self, rule: &Divergence) -> Result<GpuState> {
        let state = self.read_state_async().await?;
        rule.check_with(
            self.steps_recorded,
            self.time(),
            &state.x,
            &state.v,
            &self.motion,
        )?;
        Ok(state)
    }

    /// The moving bodies (colliders, pins) as this solver has moved them
    /// since it started, told by every setter that moves one.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// Simulated time of the recorded steps, `steps × dt` \[s\] (as the
    /// device's blow-up report counts it).
    pub fn time(&self) -> f64 {
        self.steps_recorded as f64 * self.dt
    }
}
