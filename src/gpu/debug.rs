//! Running a step kernel by kernel and reading or writing any buffer a
//! kernel binds: for the tests that run each kernel alone against its CPU
//! twin (`tests/kernel_twins.rs`). Not part of the embedding API.

use std::ops::Range;

use super::errors::guarded;
use super::kernel::Dispatch;
use super::readback;
use super::solver::GpuSolver;
use crate::error::{Error, Result};
use crate::kernel_config::{partials, WORKGROUP};

/// A buffer a kernel binds, named as in `shaders/common/bindings.wgsl`
/// (group 0) and `shaders/common/cg.wgsl` (group 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DebugBuffer {
    /// `params`: the uniform block ([`super::layout::GpuParams`]).
    Params,
    /// `springs` ([`super::layout::GpuSpring`] per slot).
    Springs,
    /// `topo`: adjacency and triangles.
    Topo,
    /// `x`: positions and inverse masses.
    X,
    /// `v`: velocities and masses.
    V,
    /// `work`: the per-particle sections ([`crate::kernel_config::work`]).
    Work,
    /// `spring_work`: the per-spring sections
    /// ([`crate::kernel_config::spring_work`]).
    SpringWork,
    /// `partials`: reduction partials and CG scalars
    /// ([`crate::kernel_config::partials`]).
    Partials,
    /// `status` ([`crate::kernel_config::status`]).
    Status,
    /// `vertex_normals`.
    VertexNormals,
    /// `dense`: the dense semi-implicit filter.
    Dense,
    /// `cg_args`: the per-particle CG kernels' indirect arguments.
    CgArgs,
    /// `alpha_slots`: cg_alpha's indirect arguments.
    AlphaSlots,
    /// `beta_slots`: cg_beta's indirect arguments.
    BetaSlots,
}

impl DebugBuffer {
    /// Every buffer.
    pub const ALL: [DebugBuffer; 14] = [
        DebugBuffer::Params,
        DebugBuffer::Springs,
        DebugBuffer::Topo,
        DebugBuffer::X,
        DebugBuffer::V,
        DebugBuffer::Work,
        DebugBuffer::SpringWork,
        DebugBuffer::Partials,
        DebugBuffer::Status,
        DebugBuffer::VertexNormals,
        DebugBuffer::Dense,
        DebugBuffer::CgArgs,
        DebugBuffer::AlphaSlots,
        DebugBuffer::BetaSlots,
    ];
}

/// Where a solver's sections lie in its buffers, in `u32` words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DebugLayout {
    /// Words per section of `work` (four per particle).
    pub work_section_words: usize,
    /// Words per section of `spring_work` (four per spring slot).
    pub spring_section_words: usize,
    /// Words (`f32`) per slot of `partials`: one per reduction block of
    /// [`WORKGROUP`] particles.
    pub partial_slot_words: usize,
}

impl DebugLayout {
    /// The words of `work` section `section` (see
    /// [`crate::kernel_config::work`]) within the whole buffer's `words`.
    pub fn work_section<'a>(&self, words: &'a [u32], section: u32) -> &'a [u32] {
        let start = section as usize * self.work_section_words;
        &words[start..start + self.work_section_words]
    }

    /// The words of `spring_work` section `section`.
    pub fn spring_section<'a>(&self, words: &'a [u32], section: u32) -> &'a [u32] {
        let start = section as usize * self.spring_section_words;
        &words[start..start + self.spring_section_words]
    }

    /// The words of `partials` slot `slot`.
    pub fn partial_slot<'a>(&self, words: &'a [u32], slot: u32) -> &'a [u32] {
        let start = slot as usize * self.partial_slot_words;
        &words[start..start + self.partial_slot_words]
    }

    /// The index in `partials` of CG scalar `k` (see
    /// [`crate::kernel_config::partials::DELTA0`] and after).
    pub fn cg_scalar(&self, k: u32) -> usize {
        partials::SLOTS as usize * self.partial_slot_words + k as usize
    }
}

impl GpuSolver {
    /// The buffer `buffer`.
    fn debug_buffer(&self, buffer: DebugBuffer) -> &wgpu::Buffer {
        match buffer {
            DebugBuffer::Params => &self.params_buffer,
            DebugBuffer::Springs => &self.springs_buffer,
            DebugBuffer::Topo => &self.topo,
            DebugBuffer::X => &self.x,
            DebugBuffer::V => &self.v,
            DebugBuffer::Work => &self.work,
            DebugBuffer::SpringWork => &self.spring_work,
            DebugBuffer::Partials => &self.partials,
            DebugBuffer::Status => &self.status,
            DebugBuffer::VertexNormals => &self.normals,
            DebugBuffer::Dense => &self.dense,
            DebugBuffer::CgArgs => &self.cg_args,
            DebugBuffer::AlphaSlots => &self.alpha_slots,
            DebugBuffer::BetaSlots => &self.beta_slots,
        }
    }

    /// The dispatches of the next step, in the order
    /// [`GpuSolver::encode_steps`]`(…, 1)` records them (single-pass
    /// explicit: `explicit_seed` first; CG: the current budget of
    /// iterations).
    #[doc(hidden)]
    pub fn debug_plan(&self) -> Vec<Dispatch> {
        self.prepared.steps.dispatches(Some(1), self.cg_budget)
    }

    /// Records and submits dispatches `range` of [`GpuSolver::debug_plan`].
    /// Running `0..len` in pieces equals one `step(1)` bit for bit; the
    /// step count advances when a range reaches the plan's end. Reads
    /// nothing back and checks nothing ([`GpuSolver::check`] does).
    #[doc(hidden)]
    pub fn debug_run(&mut self, range: Range<usize>) -> Result<()> {
        let mut entries = Vec::new();
        self.prepared.steps.for_each(1, self.cg_budget, |e, k| {
            entries.push((e, k));
        });
        if range.start > range.end || range.end > entries.len() {
            return Err(Error::InvalidParameter {
                key: "dispatch range".into(),
                allowed: format!("a range within 0..{}", entries.len()),
                got: format!("{range:?}"),
            });
        }
        let device = self.device.clone();
        guarded(&device, "running dispatches", None, || {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.debug_run"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wgcloth.debug_run"),
                    timestamp_writes: None,
                });
                pass.set_bind_group(0, &self.bind_group, &[]);
                for &((d, p), k) in &entries[range.clone()] {
                    self.dispatch(&mut pass, d, p, k);
                }
            }
            self.queue.submit([encoder.finish()]);
            Ok(())
        })?;
        if range.end == entries.len() && range.start < range.end {
            self.steps_recorded += 1;
        }
        Ok(())
    }

    /// The words of `buffer` (blocking).
    #[doc(hidden)]
    pub fn debug_read(&self, buffer: DebugBuffer) -> Result<Vec<u32>> {
        let b = self.debug_buffer(buffer);
        let bytes = readback::read_buffers(&self.device, &self.queue, &[(b, 0, b.size())])?;
        Ok(bytemuck::cast_slice::<u8, u32>(&bytes[0]).to_vec())
    }

    /// Writes `words` into `buffer` from its start (takes effect before
    /// the next submitted work). More words than the buffer holds is an
    /// error.
    #[doc(hidden)]
    pub fn debug_write(&self, buffer: DebugBuffer, words: &[u32]) -> Result<()> {
        let b = self.debug_buffer(buffer);
        let capacity = b.size() / 4;
        if words.len() as u64 > capacity {
            return Err(Error::InvalidParameter {
                key: format!("{buffer:?} words"),
                allowed: format!("at most {capacity}"),
                got: words.len().to_string(),
            });
        }
        guarded(&self.device, "writing a buffer", None, || {
            self.queue.write_buffer(b, 0, bytemuck::cast_slice(words));
            Ok(())
        })
    }

    /// Where the sections of `work`, `spring_work` and `partials` lie.
    #[doc(hidden)]
    pub fn debug_layout(&self) -> DebugLayout {
        DebugLayout {
            work_section_words: 4 * self.particles as usize,
            spring_section_words: 4 * self.spring_slots as usize,
            partial_slot_words: self.particles.div_ceil(WORKGROUP) as usize,
        }
    }
}
