//! A batch of cloths stepped together: [`GpuBatch`].
//!
//! Every cloth the workgroup kernels can step (see [`StepPath`]) lives in
//! the batch's shared buffers at offsets of its own (`table.rs`; where in
//! each buffer: `ranges.rs`), with an entry in the cloth table the kernels
//! read: one dispatch per integrator present steps all of them, a
//! workgroup per cloth. Any other cloth (beyond the per-workgroup limit, or
//! an integrator without a workgroup kernel) is held as a [`GpuSolver`] of
//! its own on the same kernel library and recorded into the same encoder,
//! so a batch takes any cloth.

mod control;
pub(crate) mod ranges;
mod table;
mod table_cloth;

use std::ops::Range;

use super::errors::{block_on, guarded_async, guarded_on_web};
use super::kernels::GpuKernels;
use super::solver::{GpuSolver, GpuState};
use crate::diagnostics::{Divergence, Motion};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::Params;
use crate::stats::StepStats;
use table::Table;
use table_cloth::TableCloth;

/// A cloth of a [`GpuBatch`], from [`GpuBatch::add`]. Its index is its slot
/// in the batch; a removed cloth's id stays invalid when its slot is
/// reused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ClothId {
    slot: u32,
    generation: u32,
}

impl ClothId {
    /// The cloth's slot: its workgroup in the batch's dispatches, and the
    /// number an error names.
    pub fn index(self) -> u32 {
        self.slot
    }
}

/// Which buffers and which part of them draw one cloth of a batch
/// ([`GpuBatch::draw_range`]): `draw_indexed(indices, base_vertex, 0..1)`
/// with `positions` (and `normals`) as vertex buffers and `index_buffer`
/// as the index buffer.
#[derive(Clone, Debug)]
pub struct DrawRange<'a> {
    /// Positions (`vec4<f32>`, xyz in m), stride 16.
    pub positions: &'a wgpu::Buffer,
    /// Vertex normals (`vec4<f32>`), valid after
    /// [`GpuBatch::encode_normals`].
    pub normals: &'a wgpu::Buffer,
    /// Triangle indices (`u32`), relative to `base_vertex`.
    pub index_buffer: &'a wgpu::Buffer,
    /// The cloth's indices in `index_buffer`.
    pub indices: Range<u32>,
    /// The cloth's first vertex in `positions`.
    pub base_vertex: i32,
}

/// A cloth of the batch.
#[derive(Debug)]
enum Member {
    /// In the shared buffers, stepped by the workgroup kernels.
    Table(Box<TableCloth>),
    /// Held as a solver of its own (the workgroup kernels cannot step it).
    Solo(Box<GpuSolver>),
}

/// A slot of the batch: its cloth, `None` once removed (free for a later
/// add), and how many cloths it has held (so an old id is refused).
#[derive(Debug)]
struct Slot {
    generation: u32,
    member: Option<Member>,
    /// The moving bodies of its cloth, for [`GpuBatch::check_divergence`].
    motion: Motion,
}

/// Many cloths on a wgpu device the host owns, stepped together.
///
/// Each cloth is made from its own [`Model`] and [`Params`] (sizes,
/// meshes, integrators and parameters may all differ) and gets a
/// [`ClothId`]. Stepping records every cloth's steps into one encoder
/// ([`GpuBatch::encode_steps`]) or records and submits them
/// ([`GpuBatch::step`]); [`GpuBatch::check`] reads every cloth's status
/// and names the first cloth whose state stopped being finite. Adding and
/// removing cloths between steps keeps the others' state and compiles no
/// pipeline the batch already has.
#[derive(Debug)]
pub struct GpuBatch {
    kernels: GpuKernels,
    queue: wgpu::Queue,
    slots: Vec<Slot>,
    /// The shared buffers of the table cloths.
    table: Table,
    /// Dispatches recorded by the last `encode_steps`, and its steps.
    recorded: (u32, u32),
}

impl GpuBatch {
    /// An empty batch on the host's `device` and `queue`, compiling its
    /// pipelines into a kernel library of its own.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> GpuBatch {
        GpuBatch::with_kernels(&GpuKernels::new(device), queue)
    }

    /// An empty batch on the device of `kernels`, taking its pipelines from
    /// that library (shared with the solvers and batches built with it).
    pub fn with_kernels(kernels: &GpuKernels, queue: &wgpu::Queue) -> GpuBatch {
        GpuBatch {
            kernels: kernels.clone(),
            queue: queue.clone(),
            slots: Vec::new(),
            table: Table::new(kernels, queue),
            recorded: (0, 0),
        }
    }

    /// Adds a cloth, refusing (before allocating anything) what
    /// [`GpuSolver::new`] refuses: invalid parameters, a cloth beyond the
    /// device's limits or the host's memory. The other cloths are not
    /// touched. Its slot is the first free one.
    ///
    /// A cloth the workgroup kernels can step (see
    /// [`StepPath`](super::StepPath)) goes into the shared buffers (which
    /// grow, copied on the device, when it does not fit where a removed
    /// cloth was); any other is held as a [`GpuSolver`] of its own,
    /// recorded into the same encoder. The shared buffers hold at most the
    /// device's `max_compute_workgroups_per_dimension` slots (65 535 on
    /// every WebGPU device): a cloth for a slot beyond is refused, naming
    /// the limit.
    ///
    /// Native only: in a browser it is an error saying to await
    /// [`GpuBatch::add_async`].
    pub fn add(&mut self, model: &Model, params: &Params) -> Result<ClothId> {
        block_on("GpuBatch::add_async", self.add_async(model, params))
    }

    /// [`GpuBatch::add`] as a future, for a browser's event loop: the
    /// device's verdict on the new cloth's buffers and pipelines is
    /// awaited.
    pub async fn add_async(&mut self, model: &Model, params: &Params) -> Result<ClothId> {
        crate::material::check_explicit_bending(model, params)?;
        let free = self.slots.iter().position(|s| s.member.is_none());
        let slot = free.unwrap_or(self.slots.len());
        let slot32 = u32::try_from(slot).map_err(|_| Error::InvalidParameter {
            key: "batch".into(),
            allowed: format!("at most {} cloths", u32::MAX),
            got: slot.to_string(),
        })?;
        let path = table_cloth::path(&self.kernels, model, params)?;
        if path == super::StepPath::Workgroup {
            // The table's cloths are one workgroup each of one dispatch.
            let limits = self.kernels.device().limits();
            super::solver::limit(
                "max_compute_workgroups_per_dimension",
                "the cloths of a batch stepped in one dispatch (a workgroup each)",
                limits.max_compute_workgroups_per_dimension.into(),
                u64::from(slot32) + 1,
            )?;
        }
        let device = self.kernels.device().clone();
        let member = match path {
            super::StepPath::Workgroup => Member::Table(Box::new(
                guarded_on_web(&device, "adding a cloth to the batch", None, || {
                    TableCloth::add(
                        &mut self.table,
                        slot32,
                        (self.slots.len().max(slot + 1)) as u64,
                        model,
                        params,
                    )
                })
                .await?,
            )),
            super::StepPath::MultiDispatch => Member::Solo(Box::new(
                GpuSolver::with_kernels_async(&self.kernels, &self.queue, model, params).await?,
            )),
        };
        let motion = Motion::new(model, params);
        if slot == self.slots.len() {
            self.slots.push(Slot {
                generation: 0,
                member: None,
                motion: motion.clone(),
            });
        }
        let s = &mut self.slots[slot];
        s.generation = s.generation.wrapping_add(1);
        s.member = Some(member);
        s.motion = motion;
        let prepared = guarded_on_web(&device, "compiling the batch's kernels", None, || {
            self.prepare()
        })
        .await;
        if let Err(e) = prepared {
            // Not added: its pipelines could not be built.
            if let Some(Member::Table(c)) = self.slots[slot].member.take() {
                c.remove(&mut self.table, slot32);
            }
            return Err(e);
        }
        Ok(ClothId {
            slot: slot32,
            generation: self.slots[slot].generation,
        })
    }

    /// Removes a cloth; its slot and ranges of the shared buffers are
    /// reused by a later add. An id that is not in the batch is an error.
    pub fn remove(&mut self, id: ClothId) -> Result<()> {
        self.member(id)?;
        if let Some(Member::Table(c)) = self.slots[id.slot as usize].member.take() {
            c.remove(&mut self.table, id.slot);
        }
        self.prepare()
    }

    /// Takes the workgroup kernels' pipelines for the integrators and the
    /// union of the features of the table cloths (compiling only those the
    /// library lacks).
    fn prepare(&mut self) -> Result<()> {
        let cloths = self.slots.iter().filter_map(|s| match &s.member {
            Some(Member::Table(c)) => Some(c.as_ref()),
            _ => None,
        });
        let (present, features) = table_cloth::union(cloths);
        self.table.prepare(&present, features)
    }

    /// The cloth of `id`, or an error naming it.
    fn member(&self, id: ClothId) -> Result<&Member> {
        match self.slots.get(id.slot as usize) {
            Some(Slot {
                generation,
                member: Some(m),
                ..
            }) if *generation == id.generation => Ok(m),
            _ => Err(self.unknown(id)),
        }
    }

    /// The error for an id that is not in the batch.
    fn unknown(&self, id: ClothId) -> Error {
        Error::InvalidParameter {
            key: "cloth".into(),
            allowed: format!("a cloth of this batch ({} now)", self.cloth_count()),
            got: format!("cloth {} (removed, or of another batch)", id.slot),
        }
    }

    /// The cloths in the batch, in slot order.
    pub fn cloths(&self) -> Vec<ClothId> {
        self.slots
            .iter()
            .zip(0u32..)
            .filter(|(s, _)| s.member.is_some())
            .map(|(s, slot)| ClothId {
                slot,
                generation: s.generation,
            })
            .collect()
    }

    /// Cloths in the batch.
    pub fn cloth_count(&self) -> usize {
        self.cloths().len()
    }

    /// The table entries a dispatch covers: up to the last slot that holds
    /// a cloth in the shared buffers (the table holds at least those; the
    /// kernels skip the zeroed entries of other slots).
    fn table_span(&self) -> u32 {
        self.slots
            .iter()
            .rposition(|s| matches!(s.member, Some(Member::Table(_))))
            .map_or(0, |k| k as u32 + 1)
    }

    /// Records `n` steps of every cloth into `encoder` without submitting.
    pub fn encode_steps(&mut self, encoder: &mut wgpu::CommandEncoder, n: u32) {
        let span = self.table_span();
        let mut dispatches = f64::from(self.table.encode_steps(encoder, n, span));
        for s in &mut self.slots {
            match &mut s.member {
                Some(Member::Table(c)) => c.steps_recorded += u64::from(n),
                Some(Member::Solo(solver)) => {
                    solver.encode_steps(encoder, n);
                    dispatches += solver.dispatches_per_step() * f64::from(n);
                }
                None => {}
            }
        }
        // Each solver records whole dispatches per step.
        self.recorded = (dispatches.round() as u32, n);
    }

    /// Records and submits `n` steps of every cloth in one encoder, then
    /// [`GpuBatch::check`]s them. Native only (see
    /// [`GpuBatch::step_async`]).
    pub fn step(&mut self, n: u32) -> Result<Vec<(ClothId, StepStats)>> {
        block_on("GpuBatch::step_async", self.step_async(n))
    }

    /// [`GpuBatch::step`] as a future, for a browser's event loop.
    pub async fn step_async(&mut self, n: u32) -> Result<Vec<(ClothId, StepStats)>> {
        let device = self.kernels.device().clone();
        guarded_async(&device, "stepping the batch", None, || {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.batch.step"),
            });
            self.encode_steps(&mut encoder, n);
            self.queue.submit([encoder.finish()]);
            Ok(())
        })
        .await?;
        self.check_async().await
    }

    /// Reads every cloth's status (see [`GpuSolver::check`]; one
    /// read-back for all the table cloths): their statistics, in slot
    /// order, or an error naming the first cloth whose state stopped being
    /// finite, and the step. Native only (see [`GpuBatch::check_async`]).
    pub fn check(&mut self) -> Result<Vec<(ClothId, StepStats)>> {
        block_on("GpuBatch::check_async", self.check_async())
    }

    /// [`GpuBatch::check`] as a future, for a browser's event loop.
    pub async fn check_async(&mut self) -> Result<Vec<(ClothId, StepStats)>> {
        let words = self.table.read_status().await?;
        let ids = self.cloths();
        let mut out = Vec::with_capacity(ids.len());
        for id in ids {
            self.member(id)?;
            let stats = match &mut self.slots[id.slot as usize].member {
                None => continue,
                Some(Member::Table(c)) => {
                    let stats = c.decode(&words);
                    if stats.as_ref().is_ok_and(|s| s.cg_max_iterations > 0) {
                        c.restart_cg_window(&self.table);
                    }
                    stats
                }
                Some(Member::Solo(solver)) => solver.check_async().await,
            };
            out.push((id, stats.map_err(|e| in_cloth(id, e))?));
        }
        Ok(out)
    }

    /// Reads one cloth's positions and velocities back (blocking); fails
    /// if its state stopped being finite. Native only (see
    /// [`GpuBatch::read_state_async`]).
    pub fn read_state(&self, id: ClothId) -> Result<GpuState> {
        block_on("GpuBatch::read_state_async", self.read_state_async(id))
    }

    /// [`GpuBatch::read_state`] as a future, for a browser's event loop.
    pub async fn read_state_async(&self, id: ClothId) -> Result<GpuState> {
        match self.member(id)? {
            Member::Table(c) => c.read_state(&self.table).await,
            Member::Solo(solver) => solver.read_state_async().await,
        }
        .map_err(|e| in_cloth(id, e))
    }

    /// Records the vertex-normal pass of every cloth (for rendering).
    pub fn encode_normals(&self, encoder: &mut wgpu::CommandEncoder) {
        for s in &self.slots {
            match &s.member {
                Some(Member::Table(c)) => c.encode_normals(&self.table, encoder),
                Some(Member::Solo(solver)) => solver.encode_normals(encoder),
                None => {}
            }
        }
    }

    /// The buffers and ranges that draw cloth `id` (see [`DrawRange`]).
    pub fn draw_range(&self, id: ClothId) -> Result<DrawRange<'_>> {
        match self.member(id)? {
            Member::Table(c) => Ok(c.draw_range(&self.table)),
            Member::Solo(solver) => Ok(solver.draw_range()),
        }
    }

    /// The kernel library the batch's pipelines come from.
    pub(in crate::gpu) fn kernels(&self) -> &GpuKernels {
        &self.kernels
    }

    /// The queue the batch submits to.
    pub(in crate::gpu) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// The path that steps cloth `id`: [`StepPath::Workgroup`](super::StepPath::Workgroup)
    /// for a cloth in the shared buffers, else the multi-dispatch path of
    /// its own solver.
    pub fn step_path(&self, id: ClothId) -> Result<super::StepPath> {
        Ok(match self.member(id)? {
            Member::Table(_) => super::StepPath::Workgroup,
            Member::Solo(_) => super::StepPath::MultiDispatch,
        })
    }

    /// The shared position buffer of the cloths on the workgroup path
    /// (`vec4<f32>`: xyz in m, w = inverse mass; a vertex buffer of
    /// stride 16); [`GpuBatch::draw_range`] says where each cloth is, and
    /// which buffers hold a cloth on the multi-dispatch path.
    pub fn positions_buffer(&self) -> &wgpu::Buffer {
        self.table.buffer(ranges::Region::Particles)
    }

    /// The shared vertex normals, parallel to
    /// [`GpuBatch::positions_buffer`], valid after
    /// [`GpuBatch::encode_normals`].
    pub fn normals_buffer(&self) -> &wgpu::Buffer {
        self.table.normals()
    }

    /// The shared triangle indices (`u32`), each cloth's relative to its
    /// first vertex ([`DrawRange::base_vertex`]).
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        self.table.buffer(ranges::Region::Indices)
    }

    /// Compute dispatches per step of the whole batch in the last
    /// [`GpuBatch::encode_steps`] call.
    pub fn dispatches_per_step(&self) -> f64 {
        let (d, s) = self.recorded;
        if s == 0 {
            0.0
        } else {
            f64::from(d) / f64::from(s)
        }
    }

    /// The passes of one step of the whole batch, by kernel in order of
    /// first appearance: `(kernel, dispatches per step, invocations per
    /// dispatch)`, the dispatches of cloths that share a kernel and size
    /// added up (what `wgcloth run --batch N --verbose` prints).
    pub fn describe_step(&self) -> Vec<(&'static str, u32, u32)> {
        let mut out = self.table.describe_step(self.table_span());
        for s in &self.slots {
            let passes = match &s.member {
                Some(Member::Solo(solver)) => solver.describe_step(),
                Some(Member::Table(_)) | None => continue,
            };
            for (kernel, count, items) in passes {
                match out.iter_mut().find(|p| p.0 == kernel && p.2 == items) {
                    Some(p) => p.1 += count,
                    None => out.push((kernel, count, items)),
                }
            }
        }
        out
    }

    /// Steps recorded so far by cloth `id` (cloths added later have fewer).
    pub fn steps_recorded(&self, id: ClothId) -> Result<u64> {
        match self.member(id)? {
            Member::Table(c) => Ok(c.steps_recorded),
            Member::Solo(solver) => Ok(solver.steps_recorded()),
        }
    }

    /// The time step of cloth `id` \[s\].
    pub fn dt(&self, id: ClothId) -> Result<f64> {
        match self.member(id)? {
            Member::Table(c) => Ok(c.host_params().dt),
            Member::Solo(solver) => Ok(solver.dt()),
        }
    }

    /// Simulated time of cloth `id`'s recorded steps, `steps × dt` \[s\].
    pub fn time(&self, id: ClothId) -> Result<f64> {
        Ok(self.steps_recorded(id)? as f64 * self.dt(id)?)
    }

    /// The moving bodies (colliders, pins) of cloth `id` as the batch's
    /// setters have moved them since it was added.
    pub fn motion(&self, id: ClothId) -> Result<&Motion> {
        self.member(id)?;
        Ok(&self.slots[id.slot as usize].motion)
    }

    /// Reads cloth `id`'s state back (blocking) and applies `rule` to it at
    /// its last recorded step, bounding the work of its bodies as the
    /// batch moved them ([`GpuBatch::motion`]), as
    /// [`GpuSolver::check_divergence`] does for a solver; returns the state
    /// it judged. An error names the cloth. The rule for a cloth is
    /// [`Divergence::new`] from its model, its parameters and
    /// [`GpuBatch::read_state`].
    pub fn check_divergence(&self, id: ClothId, rule: &Divergence) -> Result<GpuState> {
        block_on(
            "GpuBatch::check_divergence_async",
            self.check_divergence_async(id, rule),
        )
    }

    /// [`GpuBatch::check_divergence`] as a future, for a browser's event
    /// loop.
    pub async fn check_divergence_async(&self, id: ClothId, rule: &Divergence) -> Result<GpuState> {
        let state = self.read_state_async(id).await?;
        rule.check_with(
            self.steps_recorded(id)?,
            self.time(id)?,
            &state.x,
            &state.v,
            self.motion(id)?,
        )
        .map_err(|e| in_cloth(id, e))?;
        Ok(state)
    }
}

/// `e`, said of cloth `id`.
fn in_cloth(id: ClothId, e: Error) -> Error {
    Error::InBatch {
        cloth: id.slot,
        source: Box::new(e),
    }
}
