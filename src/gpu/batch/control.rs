//! Changing one cloth of a [`GpuBatch`] between steps: what a game needs
//! of [`GpuSolver`]'s setters (see `src/gpu/control.rs`), per cloth. An
//! error names the cloth; the other cloths are never touched.

use glam::{DVec3, Vec3};

use super::table::Table;
use super::table_cloth::TableCloth;
use super::{in_cloth, ClothId, GpuBatch, Member};
use crate::diagnostics::Motion;
use crate::error::Result;
use crate::gpu::control::entry;
use crate::gpu::GpuSolver;
use crate::params::{Capsule, PinTarget, Sphere, Wind};
use crate::sdf::MeshPose;

impl GpuBatch {
    /// Changes cloth `id`: by `solo` on its own solver, by `table` in the
    /// shared buffers (then the batch takes the pipelines of its features'
    /// union); an error names the cloth.
    fn change(
        &mut self,
        id: ClothId,
        solo: impl FnOnce(&mut GpuSolver) -> Result<()>,
        table: impl FnOnce(&mut TableCloth, &Table) -> Result<()>,
    ) -> Result<()> {
        self.member(id)?;
        let changed = match &mut self.slots[id.slot as usize].member {
            Some(Member::Solo(solver)) => return solo(solver).map_err(|e| in_cloth(id, e)),
            Some(Member::Table(cloth)) => table(cloth, &self.table),
            None => Ok(()),
        };
        changed
            .and_then(|()| self.prepare())
            .map_err(|e| in_cloth(id, e))
    }

    /// Changes the parameters of cloth `id` by `edit` and its table entry
    /// by `entry` (or calls `solo` on its own solver).
    fn change_params(
        &mut self,
        id: ClothId,
        solo: impl FnOnce(&mut GpuSolver) -> Result<()>,
        edit: impl FnOnce(&mut crate::params::Params),
        entry: impl FnOnce(&mut crate::gpu::layout::GpuParams, u64),
    ) -> Result<()> {
        let slot = id.slot;
        self.change(id, solo, |c, t| {
            let mut p = c.host_params();
            edit(&mut p);
            c.change(t, slot, p, entry)
        })
    }

    /// [`GpuSolver::set_gravity`] for cloth `id`.
    pub fn set_gravity(&mut self, id: ClothId, gravity: DVec3) -> Result<()> {
        self.change_params(
            id,
            |s| s.set_gravity(gravity),
            |p| p.gravity = gravity,
            entry::gravity(gravity),
        )
    }

    /// [`GpuSolver::set_wind`] for cloth `id` (turning wind on compiles the
    /// batch's wind variants once).
    pub fn set_wind(&mut self, id: ClothId, wind: Option<Wind>) -> Result<()> {
        self.change_params(
            id,
            |s| s.set_wind(wind),
            |p| p.wind = wind,
            entry::wind(wind),
        )
    }

    /// Tells cloth `id`'s record of moving bodies ([`GpuBatch::motion`])
    /// a change made at its current time.
    fn moved(&mut self, id: ClothId, tell: impl FnOnce(&mut Motion, f64)) -> Result<()> {
        let time = self.time(id)?;
        tell(&mut self.slots[id.slot as usize].motion, time);
        Ok(())
    }

    /// [`GpuSolver::set_spheres`] for cloth `id`.
    pub fn set_spheres(&mut self, id: ClothId, spheres: &[Sphere]) -> Result<()> {
        crate::gpu::solver::check_collider_counts(spheres.len(), 0, 0)?;
        self.change_params(
            id,
            |s| s.set_spheres(spheres),
            |p| p.spheres = spheres.to_vec(),
            entry::spheres(spheres),
        )?;
        self.moved(id, |m, t| m.set_spheres(t, spheres))
    }

    /// [`GpuSolver::set_capsules`] for cloth `id`.
    pub fn set_capsules(&mut self, id: ClothId, capsules: &[Capsule]) -> Result<()> {
        crate::gpu::solver::check_collider_counts(0, capsules.len(), 0)?;
        self.change_params(
            id,
            |s| s.set_capsules(capsules),
            |p| p.capsules = capsules.to_vec(),
            entry::capsules(capsules),
        )?;
        self.moved(id, |m, t| m.set_capsules(t, capsules))
    }

    /// [`GpuSolver::set_mesh_colliders`] for cloth `id`.
    pub fn set_mesh_colliders(&mut self, id: ClothId, poses: &[MeshPose]) -> Result<()> {
        let slot = id.slot;
        let moved = std::cell::RefCell::new(Vec::new());
        self.change(
            id,
            |s| {
                s.set_mesh_colliders(poses)?;
                *moved.borrow_mut() = s.host_params.mesh_colliders.clone();
                Ok(())
            },
            |c, t| {
                let mut p = c.host_params();
                let now = crate::sdf::posed(&p.mesh_colliders, poses)?;
                p.mesh_colliders = now.clone();
                *moved.borrow_mut() = now.clone();
                c.change(t, slot, p, entry::mesh_colliders(&now))
            },
        )?;
        let moved = moved.into_inner();
        self.moved(id, |m, t| m.set_mesh_colliders(t, &moved))
    }

    /// [`GpuSolver::set_position`] for particle `p` of cloth `id` (`p`
    /// counted within the cloth).
    pub fn set_position(&mut self, id: ClothId, p: usize, position: Vec3) -> Result<()> {
        self.change(
            id,
            |s| s.set_position(p, position),
            |c, t| c.set_position(t, p, position),
        )?;
        self.moved(id, |m, t| m.place(p, position.as_dvec3(), t))
    }

    /// [`GpuSolver::set_pinned`] for particle `p` of cloth `id`.
    pub fn set_pinned(&mut self, id: ClothId, p: usize, pinned: bool) -> Result<()> {
        let slot = id.slot;
        self.change(
            id,
            |s| s.set_pinned(p, pinned),
            |c, t| c.set_pinned(t, slot, p, pinned),
        )?;
        // Where a new pin is would need a read-back: its first target
        // places it for the divergence rule.
        self.moved(id, |m, t| {
            if pinned {
                m.pin(p, None, t);
            } else {
                m.release(p);
            }
        })
    }

    /// [`GpuSolver::set_pin_targets`] for cloth `id` (particles counted
    /// within the cloth).
    pub fn set_pin_targets(
        &mut self,
        id: ClothId,
        targets: &[PinTarget],
        frame_seconds: f64,
    ) -> Result<()> {
        self.change(
            id,
            |s| s.set_pin_targets(targets, frame_seconds),
            |c, t| c.set_pin_targets(t, targets, frame_seconds),
        )?;
        let dt = self.dt(id)?;
        let duration = f64::from(crate::params::frame_steps(frame_seconds, dt)?) * dt;
        self.moved(id, |m, t| m.set_pin_targets(t, targets, duration))
    }
}
