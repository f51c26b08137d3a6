//! Changing one cloth of a [`GpuBatch`] between steps: what a game needs
//! of [`GpuSolver`]'s setters (see `src/gpu/control.rs`), per cloth. An
//! error names the cloth; the other cloths are never touched.

use glam::{DVec3, Vec3};

use super::{in_cloth, ClothId, GpuBatch, Member};
use crate::error::Result;
use crate::gpu::GpuSolver;
use crate::params::{Capsule, PinTarget, Sphere, Wind};

impl GpuBatch {
    /// Applies `change` to cloth `id`'s solver, naming the cloth in an
    /// error.
    fn change(
        &mut self,
        id: ClothId,
        change: impl FnOnce(&mut GpuSolver) -> Result<()>,
    ) -> Result<()> {
        match self.member_mut(id)? {
            Member::Solo(solver) => change(solver).map_err(|e| in_cloth(id, e)),
        }
    }

    /// [`GpuSolver::set_gravity`] for cloth `id`.
    pub fn set_gravity(&mut self, id: ClothId, gravity: DVec3) -> Result<()> {
        self.change(id, |s| s.set_gravity(gravity))
    }

    /// [`GpuSolver::set_wind`] for cloth `id` (turning wind on compiles the
    /// batch's wind variants once).
    pub fn set_wind(&mut self, id: ClothId, wind: Option<Wind>) -> Result<()> {
        self.change(id, |s| s.set_wind(wind))
    }

    /// [`GpuSolver::set_spheres`] for cloth `id`.
    pub fn set_spheres(&mut self, id: ClothId, spheres: &[Sphere]) -> Result<()> {
        self.change(id, |s| s.set_spheres(spheres))
    }

    /// [`GpuSolver::set_capsules`] for cloth `id`.
    pub fn set_capsules(&mut self, id: ClothId, capsules: &[Capsule]) -> Result<()> {
        self.change(id, |s| s.set_capsules(capsules))
    }

    /// [`GpuSolver::set_position`] for particle `p` of cloth `id` (`p`
    /// counted within the cloth).
    pub fn set_position(&mut self, id: ClothId, p: usize, position: Vec3) -> Result<()> {
        self.change(id, |s| s.set_position(p, position))
    }

    /// [`GpuSolver::set_pinned`] for particle `p` of cloth `id`.
    pub fn set_pinned(&mut self, id: ClothId, p: usize, pinned: bool) -> Result<()> {
        self.change(id, |s| s.set_pinned(p, pinned))
    }

    /// [`GpuSolver::set_pin_targets`] for cloth `id` (particles counted
    /// within the cloth).
    pub fn set_pin_targets(
        &mut self,
        id: ClothId,
        targets: &[PinTarget],
        frame_seconds: f64,
    ) -> Result<()> {
        self.change(id, |s| s.set_pin_targets(targets, frame_seconds))
    }
}
