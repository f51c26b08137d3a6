//! Setting a particle's velocity: with [`GpuSolver::set_position`], what
//! moving a running cloth into another solver takes (a host switching
//! integrators keeps the motion; see `examples/viewer`).

use super::solver::GpuSolver;
use crate::error::{Error, Result};
use glam::Vec3;

impl GpuSolver {
    /// Sets particle `p`'s velocity \[m/s\] from the next recorded step
    /// on. A pinned particle does not move by velocity: only zero is
    /// accepted for it. A velocity that is not finite, or an index beyond
    /// the cloth, is an [`Error::InvalidParameter`].
    pub fn set_velocity(&mut self, p: usize, velocity: Vec3) -> Result<()> {
        self.check_particle(p)?;
        let pinned = self.model.pinned[p];
        if !velocity.is_finite() || (pinned && velocity != Vec3::ZERO) {
            return Err(Error::InvalidParameter {
                key: format!("velocity of particle {p}"),
                allowed: if pinned {
                    "zero: the particle is pinned".into()
                } else {
                    "a finite vector (m/s)".into()
                },
                got: format!("{velocity}"),
            });
        }
        self.queue.write_buffer(
            &self.buffers.v,
            (p * 16) as u64,
            bytemuck::cast_slice(&velocity.to_array()),
        );
        Ok(())
    }
}
