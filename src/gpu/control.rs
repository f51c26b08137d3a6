//! Changing a [`GpuSolver`]'s scene between steps: gravity, wind, ground,
//! spheres and capsules (moving ones too), pins, pinned positions and pin
//! targets, and the kernel variants. Nothing is
//! rebuilt but what the change invalidates.

use super::grid::GridBlock;
use super::kernels::Features;
use super::layout::{section, torque_bits, GpuParams};
use super::semi_filter::SemiFilter;
use super::solver::{
    check_collider_counts, compiled_features, gpu_capsules, gpu_mesh_colliders, gpu_spheres,
    scene_features, GpuSolver, NO_GROUND, NO_WIND,
};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::{Capsule, Ground, Params, PinTarget, Sphere, Wind};
use crate::sdf::{MeshCollider, MeshPose};
use glam::{DVec3, Vec3};

/// What pinning or releasing a particle changes besides its own model
/// and parameters (see [`pin`]).
pub(super) struct Pinning {
    /// The particle's new inverse mass \[1/kg\] (0: pinned).
    pub inverse_mass: f32,
    /// The dense semi-implicit filter rebuilt for the new pins, where the
    /// cloth has one.
    pub filter: Option<SemiFilter>,
}

/// Pins (`true`) or releases particle `p` in `model` and the uniform block
/// `params` (torque compensation, dense filter size) under the parameters
/// `host`: what else to write, `None` when it already was. Shared by a
/// solver and a batch, which write it to their buffers.
pub(super) fn pin(
    model: &mut Model,
    host: &Params,
    params: &mut GpuParams,
    p: usize,
    pinned: bool,
) -> Result<Option<Pinning>> {
    if model.pinned[p] == pinned {
        return Ok(None);
    }
    model.pinned[p] = pinned;
    let inverse_mass = if pinned {
        0.0
    } else {
        (1.0 / model.mass[p]) as f32
    };
    params.torque_compensation =
        torque_bits(host.semi_implicit.torque_compensation, model.pinned_count());
    let filter = if params.filter_count > 0 {
        // The device holds the dense filter for every particle free.
        let filter = SemiFilter::new(model, host, true)?;
        params.filter_count = filter.count;
        Some(filter)
    } else {
        None
    };
    Ok(Some(Pinning {
        inverse_mass,
        filter,
    }))
}

/// The goals of pinned particles moving to `targets` over `frame_seconds`
/// \[s\] of steps of `dt` from `steps_recorded` (see
/// [`GpuSolver::set_pin_targets`]): `(particle, goal)` as the `work`
/// section `PIN_TARGET` holds it. An error changes nothing.
pub(super) fn pin_goals(
    targets: &[PinTarget],
    frame_seconds: f64,
    dt: f64,
    pinned: &[bool],
    steps_recorded: u64,
) -> Result<Vec<(usize, [f32; 4])>> {
    let steps = crate::params::frame_steps(frame_seconds, dt)?;
    crate::params::check_pin_targets(targets, |p| pinned[p], pinned.len())?;
    let end = (steps_recorded as u32).wrapping_add(steps);
    Ok(targets
        .iter()
        .map(|t| {
            let mut goal = t.position.extend(0.0).to_array();
            goal[3] = f32::from_bits(end);
            (t.particle, goal)
        })
        .collect())
}

/// The uniform block's part of the setters that change parameters only:
/// each edits the block given the steps recorded so far. Shared by a
/// solver and a batch.
pub(super) mod entry {
    use super::*;

    /// Gravity [m/s²].
    pub fn gravity(g: DVec3) -> impl FnOnce(&mut GpuParams, u64) {
        move |p, _| p.gravity = g.as_vec3().to_array()
    }

    /// The wind (`None`: none).
    pub fn wind(wind: Option<Wind>) -> impl FnOnce(&mut GpuParams, u64) {
        move |p, _| {
            let w = wind.unwrap_or(NO_WIND);
            p.wind_velocity = w.velocity.as_vec3().to_array();
            p.wind_drag = w.drag as f32;
            p.wind_lift = w.lift as f32;
        }
    }

    /// Sphere colliders, moving from the steps recorded so far.
    pub fn spheres(spheres: &[Sphere]) -> impl FnOnce(&mut GpuParams, u64) + '_ {
        move |p, steps| {
            p.spheres = gpu_spheres(spheres);
            p.sphere_count = spheres.len() as u32;
            p.motion[1] = steps as u32;
        }
    }

    /// Mesh colliders moved to `colliders` (their grids stay), moving from
    /// the steps recorded so far.
    pub fn mesh_colliders(colliders: &[MeshCollider]) -> impl FnOnce(&mut GpuParams, u64) + '_ {
        move |p, steps| {
            let grids = p.meshes.map(|m| m.grid);
            p.meshes = gpu_mesh_colliders(colliders, &grids);
            p.mesh[1] = steps as u32;
        }
    }

    /// Capsule colliders, moving from the steps recorded so far.
    pub fn capsules(capsules: &[Capsule]) -> impl FnOnce(&mut GpuParams, u64) + '_ {
        move |p, steps| {
            p.capsules = gpu_capsules(capsules);
            p.motion[0] = capsules.len() as u32;
            p.motion[2] = steps as u32;
        }
    }
}

impl GpuSolver {
    /// Changes gravity [m/s²] from the next recorded step on.
    pub fn set_gravity(&mut self, gravity: DVec3) -> Result<()> {
        let mut p = self.host_params.clone();
        p.gravity = gravity;
        p.validate()?;
        self.host_params = p;
        entry::gravity(gravity)(&mut self.params, self.steps_recorded);
        self.upload_params();
        Ok(())
    }

    /// Changes the wind (`None`: no wind) from the next recorded step on.
    /// Turning wind on or off switches to the matching kernel variants
    /// (compiled once, then cached).
    pub fn set_wind(&mut self, wind: Option<Wind>) -> Result<()> {
        let mut p = self.host_params.clone();
        p.wind = wind;
        p.validate()?;
        self.host_params = p;
        entry::wind(wind)(&mut self.params, self.steps_recorded);
        self.update_features()
    }

    /// Changes the ground plane (`None`: no ground).
    pub fn set_ground(&mut self, ground: Option<Ground>) -> Result<()> {
        let mut p = self.host_params.clone();
        p.ground = ground;
        p.validate()?;
        self.host_params = p;
        let g = ground.unwrap_or(NO_GROUND);
        self.params.ground_height = g.height as f32;
        self.params.ground_friction = g.friction as f32;
        self.update_features()
    }

    /// Replaces the sphere colliders (at most [`MAX_SPHERES`](super::layout::MAX_SPHERES)); each moves
    /// at its velocity from its `center` from the next recorded step on. A
    /// game moving a ball calls this every frame with the ball's position
    /// and velocity; the steps of one submit see it move (the kernels
    /// compute its position from the steps since this call).
    pub fn set_spheres(&mut self, spheres: &[Sphere]) -> Result<()> {
        check_collider_counts(spheres.len(), 0, 0)?;
        let mut p = self.host_params.clone();
        p.spheres = spheres.to_vec();
        p.validate()?;
        self.host_params = p;
        entry::spheres(spheres)(&mut self.params, self.steps_recorded);
        self.motion.set_spheres(self.time(), spheres);
        self.update_features()
    }

    /// Replaces the capsule colliders (at most [`MAX_CAPSULES`](super::layout::MAX_CAPSULES)), as
    /// [`GpuSolver::set_spheres`] the spheres.
    pub fn set_capsules(&mut self, capsules: &[Capsule]) -> Result<()> {
        check_collider_counts(0, capsules.len(), 0)?;
        let mut p = self.host_params.clone();
        p.capsules = capsules.to_vec();
        p.validate()?;
        self.host_params = p;
        entry::capsules(capsules)(&mut self.params, self.steps_recorded);
        self.motion.set_capsules(self.time(), capsules);
        self.update_features()
    }

    /// Sets where pinned particles are to be after `frame_seconds` \[s\] of
    /// simulated time: each moves at constant velocity over the frame's
    /// steps (the nearest whole number of steps, at least one) and lands
    /// exactly on its target at the last of them (see
    /// [`crate::cpu::motion`]); after that it stands still until the next
    /// call. A mouse drag is [`GpuSolver::set_pinned`]`(p, true)` then this
    /// every frame; `set_pinned(p, false)` lets go, keeping the velocity.
    /// An index out of range, an unpinned particle or a non-finite position
    /// is an error naming it, and then nothing is changed.
    pub fn set_pin_targets(&mut self, targets: &[PinTarget], frame_seconds: f64) -> Result<()> {
        let goals = pin_goals(
            targets,
            frame_seconds,
            self.host_params.dt,
            &self.model.pinned,
            self.steps_recorded,
        )?;
        for (p, goal) in goals {
            self.write_pin_goal(p, goal);
        }
        let duration = f64::from(crate::params::frame_steps(
            frame_seconds,
            self.host_params.dt,
        )?) * self.host_params.dt;
        self.motion.set_pin_targets(self.time(), targets, duration);
        Ok(())
    }

    /// The time step \[s\].
    pub fn dt(&self) -> f64 {
        self.host_params.dt
    }

    /// Moves the mesh colliders to `poses`, one per collider in the order
    /// the scene gives them (their meshes stay), from the next recorded
    /// step on, as [`GpuSolver::set_spheres`] the spheres.
    pub fn set_mesh_colliders(&mut self, poses: &[MeshPose]) -> Result<()> {
        let moved = crate::sdf::posed(&self.host_params.mesh_colliders, poses)?;
        entry::mesh_colliders(&moved)(&mut self.params, self.steps_recorded);
        self.motion.set_mesh_colliders(self.time(), &moved);
        self.host_params.mesh_colliders = moved;
        self.upload_params();
        Ok(())
    }

    /// The spheres and the capsules where they are after the steps
    /// recorded so far (positions moved by their velocities in `f64`;
    /// velocities as set): what a renderer draws
    /// ([`crate::render::Renderer::set_colliders`]).
    pub fn colliders(&self) -> (Vec<Sphere>, Vec<Capsule>) {
        let now = self.steps_recorded as u32;
        let since = |base: u32| f64::from(now.wrapping_sub(base)) * self.host_params.dt;
        let (ts, tc) = (since(self.params.motion[1]), since(self.params.motion[2]));
        let spheres = self.host_params.spheres.iter().map(|s| Sphere {
            center: s.center + s.velocity * ts,
            ..*s
        });
        let capsules = self.host_params.capsules.iter().map(|c| Capsule {
            a: c.a + c.velocity * tc,
            b: c.b + c.velocity * tc,
            ..*c
        });
        (spheres.collect(), capsules.collect())
    }

    /// Writes particle `p`'s pin goal (`work` section `PIN_TARGET`).
    fn write_pin_goal(&self, p: usize, goal: [f32; 4]) {
        let n = self.params.particle_count as u64;
        let offset =
            (u64::from(self.params.work_base) + u64::from(section::PIN_TARGET) * n + p as u64) * 16;
        self.queue
            .write_buffer(&self.buffers.work, offset, bytemuck::cast_slice(&goal));
    }

    /// Moves particle `p` to `position` \[m\] (for a pinned particle: a game
    /// dragging a corner). Its velocity is left as it is.
    pub fn set_position(&mut self, p: usize, position: Vec3) -> Result<()> {
        self.check_particle(p)?;
        self.queue.write_buffer(
            &self.buffers.x,
            (p * 16) as u64,
            bytemuck::cast_slice(&position.to_array()),
        );
        self.motion.place(p, position.as_dvec3(), self.time());
        Ok(())
    }

    /// Pins (`true`) or releases (`false`) particle `p`. A newly pinned
    /// particle stops; a released one keeps its velocity (a flick). A semi-implicit solver with the dense filter rebuilds
    /// its filter on the host (the pins are constrained inside it).
    pub fn set_pinned(&mut self, p: usize, pinned: bool) -> Result<()> {
        self.check_particle(p)?;
        let Some(change) = pin(
            &mut self.model,
            &self.host_params,
            &mut self.params,
            p,
            pinned,
        )?
        else {
            return Ok(());
        };
        let base = (p * 16) as u64;
        self.queue.write_buffer(
            &self.buffers.x,
            base + 12,
            bytemuck::bytes_of(&change.inverse_mass),
        );
        if pinned {
            self.queue
                .write_buffer(&self.buffers.v, base, bytemuck::cast_slice(&[0f32; 3]));
        }
        // A new pin stands still until it is given a target.
        self.write_pin_goal(p, [0.0; 4]);
        // Where a new pin is would need a read-back: its first target
        // places it for the divergence rule.
        if pinned {
            self.motion.pin(p, None, self.time());
        } else {
            self.motion.release(p);
        }
        if let Some(filter) = change.filter {
            self.queue.write_buffer(
                &self.buffers.model,
                u64::from(self.params.dense_base) * 4,
                bytemuck::cast_slice(&filter.words),
            );
        }
        self.update_features()
    }

    pub(super) fn check_particle(&self, p: usize) -> Result<()> {
        if p < self.params.particle_count as usize {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                key: "particle".into(),
                allowed: format!("an index below {}", self.params.particle_count),
                got: p.to_string(),
            })
        }
    }

    /// With `false`, records the general kernels — every feature compiled
    /// in, absent ones made inert by their parameters (zero wind, no
    /// spheres, a ground out of reach, free filters, zero damping) — and no
    /// fused passes: for tests and benchmarks of what specialisation saves.
    /// With `true` (the default), the scene's own variants.
    pub(super) fn set_specialised(&mut self, on: bool) -> Result<()> {
        self.specialised = on;
        self.update_features()
    }

    /// Sets how many particles (columns × rows) each invocation of the grid
    /// gather kernels handles (see [`GridBlock`]; the default is
    /// [`GridBlock::ONE`]). Results are the same for every
    /// shape; speed is not. No effect on a cloth without grid layout.
    pub(super) fn set_grid_block(&mut self, block: GridBlock) -> Result<()> {
        if !block.is_valid() {
            return Err(Error::InvalidParameter {
                key: "grid block".into(),
                allowed: format!("1 to {} columns and rows", GridBlock::MAX),
                got: format!("{} × {}", block.cols, block.rows),
            });
        }
        self.block = block;
        self.params.grid[3] = block.count(self.params.grid[0], self.params.grid[1]);
        self.update_features()
    }

    /// The grid gather's block shape (see [`GpuTuningMut::set_grid_block`](super::GpuTuningMut::set_grid_block)).
    pub(super) fn grid_block(&self) -> GridBlock {
        self.block
    }

    /// Switches to the kernel variants of the current scene (compiling any
    /// not cached yet) and uploads the parameters.
    fn update_features(&mut self) -> Result<()> {
        let scene = scene_features(
            &self.model,
            &self.host_params,
            self.grid.then_some(self.block),
        );
        self.params.features = scene.bits();
        let features = if self.specialised {
            compiled_features(scene, self.path.path)
        } else {
            // The general kernels: every feature, the adjacency lists. The
            // coarse levels change the iterates (the CPU mirror follows the
            // scene's choice), not which code is compiled in, so they and
            // the constant blocks stay as they are.
            Features {
                grid: false,
                block: GridBlock::ONE,
                ..self.features
            }
            .with_every_scene_feature()
        };
        let previous = std::mem::replace(&mut self.features, features);
        if let Err(e) = self.prepare() {
            self.features = previous;
            return Err(e);
        }
        self.upload_params();
        Ok(())
    }

    fn upload_params(&self) {
        self.queue
            .write_buffer(&self.buffers.params, 0, bytemuck::bytes_of(&self.params));
    }
}
