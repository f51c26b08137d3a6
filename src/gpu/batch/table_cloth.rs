//! A cloth of a batch in the shared buffers (see `table.rs`): what the
//! host keeps of it (its table entry as uploaded, its model and
//! parameters, its ranges), its status and state read back, its normals
//! and draw range, and its setters.

use glam::Vec3;

use super::ranges::{Extents, Region};
use super::table::{self, Table};
use super::DrawRange;
use crate::budget::{self, Counts};
use crate::error::{Error, Result};
use crate::gpu::build::cloth_arrays;
use crate::gpu::control::{pin, pin_goals};
use crate::gpu::grid::GridBlock;
use crate::gpu::guarded;
use crate::gpu::kernels::{Features, GpuKernels};
use crate::gpu::layout::{section, status, GpuParams};
use crate::gpu::path::{self, PathInputs, StepPath};
use crate::gpu::semi_filter::SemiFilter;
use crate::gpu::solver::{check_collider_counts, decode_status, scene_features, GpuState};
use crate::kernel_config::WORKGROUP;
use crate::model::Model;
use crate::params::{Integrator, Params, PinTarget};
use crate::stats::StepStats;

/// The path of this cloth in a batch: the workgroup path wherever it can
/// step the cloth — sharing the batch's one dispatch is the point of a
/// batch, whatever a lone solver's cost model would choose — else a solver
/// of its own on the multi-dispatch path.
pub(super) fn path(kernels: &GpuKernels, model: &Model, params: &Params) -> Result<StepPath> {
    params.validate()?;
    crate::self_collision::thickness(model, params)?;
    crate::self_collision::check_gpu(params)?;
    let counts = Counts::of_model(model);
    let dense = dense_filter(model, params);
    let limits = kernels.device().limits();
    let inputs = PathInputs {
        integrator: params.integrator,
        particles: counts.particles,
        dense,
        limits: &limits,
    };
    Ok(if path::workgroup_steps(&inputs) {
        StepPath::Workgroup
    } else {
        StepPath::MultiDispatch
    })
}

/// Whether the cloth is semi-implicit with the dense filter.
fn dense_filter(model: &Model, params: &Params) -> bool {
    params.integrator == Integrator::SemiImplicit
        && params
            .semi_implicit
            .filter
            .is_dense(Counts::of_model(model).free as usize)
}

/// The integrators present among `cloths`, and the union of their
/// features: one pipeline per integrator steps them all (a feature a cloth
/// lacks is inert by its parameters: zero wind, no collider, …).
pub(super) fn union<'a>(
    cloths: impl Iterator<Item = &'a TableCloth>,
) -> (Vec<Integrator>, Option<Features>) {
    let mut present = Vec::new();
    let mut all: Option<Features> = None;
    for c in cloths {
        if !present.contains(&c.integrator) {
            present.push(c.integrator);
        }
        all = Some(all.map_or(c.features, |a| table::either(a, c.features)));
    }
    present.sort_by_key(|i| Integrator::ALL.iter().position(|j| j == i));
    (present, all)
}

/// A cloth in the shared buffers.
#[derive(Debug)]
pub(super) struct TableCloth {
    integrator: Integrator,
    /// Its table entry as uploaded (bases included).
    params: GpuParams,
    /// Its ranges in the shared buffers: starts and lengths.
    starts: Extents,
    lens: Extents,
    /// The model with its current pins (a dense filter is rebuilt from it).
    model: Model,
    /// The parameters with the current colliders, wind and gravity.
    host_params: Params,
    features: Features,
    /// Its table entry as a uniform block, for its vertex-normal pass.
    normals_params: wgpu::Buffer,
    pub(super) steps_recorded: u64,
}

impl TableCloth {
    /// Puts a cloth into `table` at slot `slot` (the table then holds at
    /// least `slots` entries).
    pub(super) fn add(
        table: &mut Table,
        slot: u32,
        slots: u64,
        model: &Model,
        params: &Params,
    ) -> Result<TableCloth> {
        check_collider_counts(
            params.spheres.len(),
            params.capsules.len(),
            params.mesh_colliders.len(),
        )?;
        let device = table.device().clone();
        // The arrays built on the host (the device's bytes are the shared
        // buffers', checked when they grow).
        let counts = Counts::of_model(model);
        let dense = dense_filter(model, params);
        let bandwidth = if dense {
            budget::filter_bandwidth(model)
        } else {
            0
        };
        let need = budget::gpu_bytes(counts, model.springs.len() as u64, params, dense, bandwidth);
        budget::check_host(need.host, || {
            format!("a cloth of {} particles for the batch", counts.particles)
        })?;
        let filter = match params.integrator {
            // The shared buffers refuse a dense filter they cannot hold,
            // naming the limit, when they grow.
            Integrator::SemiImplicit => Some(SemiFilter::new(model, params, true)?),
            _ => None,
        };
        // The workgroup kernels read the adjacency lists: general layout.
        let mut arrays = cloth_arrays(model, params, filter, None, GridBlock::ONE)?;
        let model = model.try_clone()?;
        let lens = table::extents(&arrays, model.triangles.len());
        let starts = table.reserve(&lens, slots)?;
        table::place(&mut arrays, &starts);
        let words = match arrays.model_words() {
            Ok(w) => w,
            Err(e) => {
                table.free(slot, &starts, &lens);
                return Err(e);
            }
        };
        let uploaded = guarded(&device, "adding a cloth to the batch", None, || {
            table.upload(slot, &arrays, &words, &model.triangles, &starts);
            Ok(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wgcloth.batch.normals_params"),
                size: std::mem::size_of::<GpuParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }))
        });
        let normals_params = match uploaded {
            Ok(b) => b,
            Err(e) => {
                table.free(slot, &starts, &lens);
                return Err(e);
            }
        };
        let features = scene_features(&model, params, None);
        let cloth = TableCloth {
            integrator: params.integrator,
            params: arrays.params,
            starts,
            lens,
            model,
            host_params: params.clone(),
            features,
            normals_params,
            steps_recorded: 0,
        };
        cloth.upload_params(table, slot);
        Ok(cloth)
    }

    /// Takes the cloth out of `table` (slot `slot`).
    pub(super) fn remove(self, table: &mut Table, slot: u32) {
        table.free(slot, &self.starts, &self.lens);
    }

    /// Its first particle in the shared buffers.
    fn base(&self) -> u64 {
        self.starts[Region::Particles.index()]
    }

    fn particles(&self) -> u64 {
        u64::from(self.params.particle_count)
    }

    /// Its statistics from all the batch's status words.
    pub(super) fn decode(&self, words: &[u32]) -> Result<StepStats> {
        let at = self.params.status_base as usize;
        let mine = words.get(at..at + status::COUNT).ok_or_else(|| {
            Error::Gpu(format!(
                "the status words of a cloth at {at} were not read back"
            ))
        })?;
        self.decode_words(mine)
    }

    /// Starts its window of [`StepStats::cg_max_iterations`] afresh: the
    /// next check reports the steps after this one (as a lone solver's).
    pub(super) fn restart_cg_window(&self, table: &Table) {
        let word = u64::from(self.params.status_base) + status::CG_MAX_ITERATIONS as u64;
        table
            .queue()
            .write_buffer(table.buffer(Region::Status), word * 4, &[0; 4]);
    }

    /// Its statistics from its own status words.
    fn decode_words(&self, words: &[u32]) -> Result<StepStats> {
        // No CG budget on the workgroup path: never hit (as a lone solver
        // on that path reports).
        decode_status(words, self.steps_recorded, self.host_params.dt, Some(0))
    }

    /// Reads its positions and velocities back.
    pub(super) async fn read_state(&self, table: &Table) -> Result<GpuState> {
        let (p, n) = (self.base(), self.particles());
        let s = u64::from(self.params.status_base);
        let parts = table
            .read(&[
                (table.buffer(Region::Particles), Region::Particles, p, n),
                (table.velocities(), Region::Particles, p, n),
                (
                    table.buffer(Region::Status),
                    Region::Status,
                    s,
                    status::COUNT as u64,
                ),
            ])
            .await?;
        // Copied out of the bytes: a read-back need not be aligned for u32.
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&parts[2]);
        self.decode_words(&words)?;
        Ok(GpuState::from_bytes(&parts[0], &parts[1]))
    }

    /// Records its vertex-normal pass.
    pub(super) fn encode_normals(&self, table: &Table, encoder: &mut wgpu::CommandEncoder) {
        let Some(pipeline) = table.normals_pipeline() else {
            return;
        };
        let group = table.uniform_group(&self.normals_params);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.batch.normals"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &group, &[]);
        pass.set_pipeline(pipeline);
        pass.dispatch_workgroups(self.params.particle_count.div_ceil(WORKGROUP), 1, 1);
    }

    /// Where it is drawn from.
    pub(super) fn draw_range<'a>(&self, table: &'a Table) -> DrawRange<'a> {
        let first = self.starts[Region::Indices.index()] as u32;
        DrawRange {
            positions: table.buffer(Region::Particles),
            normals: table.normals(),
            index_buffer: table.buffer(Region::Indices),
            indices: first..first + self.lens[Region::Indices.index()] as u32,
            base_vertex: self.base() as i32,
        }
    }

    /// Uploads its table entry (and the normals pass's copy).
    fn upload_params(&self, table: &Table, slot: u32) {
        table.write_entry(slot, &self.params);
        table
            .queue()
            .write_buffer(&self.normals_params, 0, bytemuck::bytes_of(&self.params));
    }

    /// Changes its parameters to `p` (validated first: an error changes
    /// nothing) and its table entry by `f`; the union of features may
    /// change (the batch then takes its pipelines).
    pub(super) fn change(
        &mut self,
        table: &Table,
        slot: u32,
        p: Params,
        f: impl FnOnce(&mut GpuParams, u64),
    ) -> Result<()> {
        p.validate()?;
        self.host_params = p;
        f(&mut self.params, self.steps_recorded);
        self.features = scene_features(&self.model, &self.host_params, None);
        self.params.features = self.features.bits();
        self.upload_params(table, slot);
        Ok(())
    }

    /// A copy of its parameters, to change and pass to [`TableCloth::change`].
    pub(super) fn host_params(&self) -> Params {
        self.host_params.clone()
    }

    fn check_particle(&self, p: usize) -> Result<()> {
        if (p as u64) < self.particles() {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                key: "particle".into(),
                allowed: format!("an index below {}", self.params.particle_count),
                got: p.to_string(),
            })
        }
    }

    /// Moves particle `p` (counted within the cloth) to `position`.
    pub(super) fn set_position(&self, table: &Table, p: usize, position: Vec3) -> Result<()> {
        self.check_particle(p)?;
        table.queue().write_buffer(
            table.buffer(Region::Particles),
            (self.base() + p as u64) * 16,
            bytemuck::cast_slice(&position.to_array()),
        );
        Ok(())
    }

    /// Writes particle `p`'s pin goal.
    fn write_pin_goal(&self, table: &Table, p: usize, goal: [f32; 4]) {
        let at = u64::from(self.params.work_base)
            + u64::from(section::PIN_TARGET) * self.particles()
            + p as u64;
        table.queue().write_buffer(
            table.buffer(Region::Work),
            at * 16,
            bytemuck::cast_slice(&goal),
        );
    }

    /// Pins or releases particle `p`, as [`GpuSolver::set_pinned`](crate::gpu::GpuSolver::set_pinned).
    pub(super) fn set_pinned(
        &mut self,
        table: &Table,
        slot: u32,
        p: usize,
        pinned: bool,
    ) -> Result<()> {
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
        let at = (self.base() + p as u64) * 16;
        let q = table.queue();
        q.write_buffer(
            table.buffer(Region::Particles),
            at + 12,
            bytemuck::bytes_of(&change.inverse_mass),
        );
        if pinned {
            q.write_buffer(table.velocities(), at, bytemuck::cast_slice(&[0f32; 3]));
        }
        // A new pin stands still until it is given a target.
        self.write_pin_goal(table, p, [0.0; 4]);
        if let Some(mut filter) = change.filter {
            table::shift_order(&mut filter.words, filter.count, self.base() as u32);
            q.write_buffer(
                table.buffer(Region::Model),
                u64::from(self.params.dense_base) * 4,
                bytemuck::cast_slice(&filter.words),
            );
        }
        self.features = scene_features(&self.model, &self.host_params, None);
        self.params.features = self.features.bits();
        self.upload_params(table, slot);
        Ok(())
    }

    /// Sets pin targets, as [`GpuSolver::set_pin_targets`](crate::gpu::GpuSolver::set_pin_targets).
    pub(super) fn set_pin_targets(
        &self,
        table: &Table,
        targets: &[PinTarget],
        frame_seconds: f64,
    ) -> Result<()> {
        let goals = pin_goals(
            targets,
            frame_seconds,
            self.host_params.dt,
            &self.model.pinned,
            self.steps_recorded,
        )?;
        for (p, goal) in goals {
            self.write_pin_goal(table, p, goal);
        }
        Ok(())
    }
}
