//! Changing a [`GpuSolver`]'s scene between steps: gravity, wind, ground,
//! spheres, pins, pinned positions and the kernel variants. Nothing is
//! rebuilt but what the change invalidates.

use super::grid::GridBlock;
use super::kernels::Features;
use super::layout::{torque_bits, MAX_SPHERES};
use super::semi_filter::SemiFilter;
use super::solver::{gpu_spheres, scene_features, GpuSolver, NO_GROUND, NO_WIND};
use crate::error::{Error, Result};
use crate::params::{Ground, Sphere, Wind};
use glam::{DVec3, Vec3};

impl GpuSolver {
    /// Changes gravity [m/s²] from the next recorded step on.
    pub fn set_gravity(&mut self, gravity: DVec3) -> Result<()> {
        let mut p = self.host_params.clone();
        p.gravity = gravity;
        p.validate()?;
        self.host_params = p;
        self.params.gravity = gravity.as_vec3().to_array();
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
        let w = wind.unwrap_or(NO_WIND);
        self.params.wind_velocity = w.velocity.as_vec3().to_array();
        self.params.wind_drag = w.drag as f32;
        self.params.wind_lift = w.lift as f32;
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

    /// Replaces the sphere colliders (at most [`MAX_SPHERES`]); a game
    /// moving a ball calls this every frame.
    pub fn set_spheres(&mut self, spheres: &[Sphere]) -> Result<()> {
        if spheres.len() > MAX_SPHERES {
            return Err(Error::InvalidParameter {
                key: "sphere".into(),
                allowed: format!("at most {MAX_SPHERES} spheres on the GPU backend"),
                got: spheres.len().to_string(),
            });
        }
        let mut p = self.host_params.clone();
        p.spheres = spheres.to_vec();
        p.validate()?;
        self.host_params = p;
        self.params.spheres = gpu_spheres(spheres);
        self.params.sphere_count = spheres.len() as u32;
        self.update_features()
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
        Ok(())
    }

    /// Pins (`true`) or releases (`false`) particle `p`. A newly pinned
    /// particle stops. A semi-implicit solver with the dense filter rebuilds
    /// its filter on the host (the pins are constrained inside it).
    pub fn set_pinned(&mut self, p: usize, pinned: bool) -> Result<()> {
        self.check_particle(p)?;
        if self.model.pinned[p] == pinned {
            return Ok(());
        }
        self.model.pinned[p] = pinned;
        let inverse_mass = if pinned {
            0.0
        } else {
            (1.0 / self.model.mass[p]) as f32
        };
        let base = (p * 16) as u64;
        self.queue.write_buffer(
            &self.buffers.x,
            base + 12,
            bytemuck::bytes_of(&inverse_mass),
        );
        if pinned {
            self.queue
                .write_buffer(&self.buffers.v, base, bytemuck::cast_slice(&[0f32; 3]));
        }
        self.params.torque_compensation = torque_bits(
            self.host_params.semi_implicit.torque_compensation,
            self.model.pinned_count(),
        );
        if self.params.filter_count > 0 {
            let filter = SemiFilter::new(&self.model, &self.host_params)?;
            self.params.filter_count = filter.count;
            self.queue
                .write_buffer(&self.buffers.dense, 0, bytemuck::cast_slice(&filter.words));
        }
        self.update_features()
    }

    fn check_particle(&self, p: usize) -> Result<()> {
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
    /// gather kernels handles (see [`GridBlock`]; the default suits the
    /// adapter: [`GridBlock::for_adapter`]). Results are the same for every
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
        let features = if self.specialised {
            scene_features(
                &self.model,
                &self.host_params,
                self.grid.then_some(self.block),
            )
        } else {
            Features {
                wind: true,
                ground: true,
                spheres: true,
                filter: true,
                damping: true,
                grid: false,
                block: GridBlock::ONE,
                // The coarse levels change the iterates (the CPU mirror
                // follows the scene's choice), not which code is compiled
                // in.
                coarse: self.features.coarse,
                constant_blocks: self.features.constant_blocks,
            }
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
