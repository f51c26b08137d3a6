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

/// A buffer a kernel binds, or a part of one, named as in
/// `shaders/common/layout.wgsl` (group 0) and `shaders/common/cg.wgsl`
/// (group 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DebugBuffer {
    /// `params`: the uniform block ([`super::layout::GpuParams`]).
    Params,
    /// The spring records of `model` ([`super::layout::GpuSpring`] per
    /// slot).
    Springs,
    /// The topology words of `model`: adjacency and triangles.
    Topo,
    /// `x`: positions and inverse masses.
    X,
    /// `v`: velocities and masses.
    V,
    /// The per-particle sections of `work`
    /// ([`crate::kernel_config::work`]).
    Work,
    /// The per-spring sections of `work`
    /// ([`crate::kernel_config::spring_work`]).
    SpringWork,
    /// The reduction partials and CG scalars of `work`
    /// ([`crate::kernel_config::partials`]), a `vec4` (four words) each.
    Partials,
    /// `status` ([`crate::kernel_config::status`]).
    Status,
    /// `vertex_normals`.
    VertexNormals,
    /// The dense semi-implicit filter's words of `model` (to the end of
    /// the buffer).
    Dense,
    /// `apply_args`: the slots of cg_apply ([`DebugLayout::arg_slots`],
    /// three words a slot).
    ApplyArgs,
    /// `update_args`: the slots of cg_update.
    UpdateArgs,
}

impl DebugBuffer {
    /// Every buffer.
    pub const ALL: [DebugBuffer; 13] = [
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
        DebugBuffer::ApplyArgs,
        DebugBuffer::UpdateArgs,
    ];
}

/// Where a solver's sections lie in its buffers, in `u32` words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DebugLayout {
    /// Words per section of `work` (four per particle).
    pub work_section_words: usize,
    /// Words per section of `spring_work` (four per spring slot).
    pub spring_section_words: usize,
    /// Entries (`vec4`s) per slot of `partials`: one per reduction block
    /// of [`WORKGROUP`] particles.
    pub partial_slot_words: usize,
    /// Slots in `apply_args` and in `update_args`.
    pub arg_slots: usize,
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

    /// Component `c` (0 for `x`) of each entry of `partials` slot `slot`,
    /// within the words of [`DebugBuffer::Partials`].
    pub fn partial_slot(&self, words: &[u32], slot: u32, c: usize) -> Vec<u32> {
        let start = slot as usize * self.partial_slot_words;
        (start..start + self.partial_slot_words)
            .map(|e| words[4 * e + c])
            .collect()
    }

    /// The index, within the words of [`DebugBuffer::Partials`], of CG
    /// scalar `k` (see [`crate::kernel_config::partials::DELTA0`] and
    /// after).
    pub fn cg_scalar(&self, k: u32) -> usize {
        4 * (partials::SLOTS as usize * self.partial_slot_words + k as usize)
    }

    /// The workgroup count (the first word) of slot `k` within the words
    /// of [`DebugBuffer::ApplyArgs`] or [`DebugBuffer::UpdateArgs`].
    pub fn arg_slot(&self, words: &[u32], k: usize) -> u32 {
        words[3 * k]
    }
}

/// Where a [`DebugBuffer`] lies: its buffer, first byte, bytes (`None`: to
/// the end), and whether it is read-only (the partials, which run into the
/// CG scalars and the buffer's end).
type View<'a> = (&'a wgpu::Buffer, u64, Option<u64>, bool);

impl GpuSolver {
    /// The dispatches of the next step, in the order
    /// [`GpuSolver::encode_steps`]`(…, 1)` records them (single-pass
    /// explicit: `explicit_seed` first; CG: the current budget of
    /// iterations).
    #[doc(hidden)]
    pub fn debug_plan(&self) -> Vec<Dispatch> {
        self.prepared.steps.dispatches(Some(1), self.cg.current())
    }

    /// Records and submits dispatches `range` of [`GpuSolver::debug_plan`].
    /// Running `0..len` in pieces equals one `step(1)` bit for bit; the
    /// step count advances when a range reaches the plan's end. Reads
    /// nothing back and checks nothing ([`GpuSolver::check`] does).
    #[doc(hidden)]
    pub fn debug_run(&mut self, range: Range<usize>) -> Result<()> {
        let mut entries = Vec::new();
        self.prepared.steps.for_each(1, self.cg.current(), |e, k| {
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
                pass.set_bind_group(0, &self.buffers.bind_group, &[]);
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

    /// Where `buffer` lies in the solver's buffers.
    fn view(&self, buffer: DebugBuffer) -> View<'_> {
        let b = &self.buffers;
        let p = &self.params;
        let vec4 = |k: u32| u64::from(k) * 16;
        let word = |k: u32| u64::from(k) * 4;
        let spring_bytes = u64::from(self.spring_slots) * 32;
        match buffer {
            DebugBuffer::Params => (&b.params, 0, None, false),
            DebugBuffer::Springs => (&b.model, vec4(p.spring_base), Some(spring_bytes), false),
            DebugBuffer::Topo => {
                let len = word(p.dense_base) - word(p.topo_base);
                (&b.model, word(p.topo_base), Some(len), false)
            }
            DebugBuffer::Dense => (&b.model, word(p.dense_base), None, false),
            DebugBuffer::X => (&b.x, 0, None, false),
            DebugBuffer::V => (&b.v, 0, None, false),
            DebugBuffer::Work => {
                let len = vec4(p.spring_work_base) - vec4(p.work_base);
                (&b.work, vec4(p.work_base), Some(len), false)
            }
            DebugBuffer::SpringWork => {
                let len = vec4(p.partial_base) - vec4(p.spring_work_base);
                (&b.work, vec4(p.spring_work_base), Some(len), false)
            }
            DebugBuffer::Partials => (&b.work, vec4(p.partial_base), None, true),
            DebugBuffer::Status => (&b.status, 0, None, false),
            DebugBuffer::VertexNormals => (&b.normals, 0, None, false),
            DebugBuffer::ApplyArgs => (&b.apply_args, 0, None, false),
            DebugBuffer::UpdateArgs => (&b.update_args, 0, None, false),
        }
    }

    /// The words of `buffer` (blocking).
    #[doc(hidden)]
    pub fn debug_read(&self, buffer: DebugBuffer) -> Result<Vec<u32>> {
        let (b, start, len, _) = self.view(buffer);
        let len = len.unwrap_or(b.size() - start);
        let bytes = readback::read_buffers(&self.device, &self.queue, &[(b, start, len)])?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[0]);
        Ok(words)
    }

    /// Writes `words` into `buffer` from its start (takes effect before
    /// the next submitted work). More words than the buffer holds, or a
    /// write to the partials, is an error.
    #[doc(hidden)]
    pub fn debug_write(&self, buffer: DebugBuffer, words: &[u32]) -> Result<()> {
        let (b, start, len, read_only) = self.view(buffer);
        let capacity = if read_only {
            0
        } else {
            len.unwrap_or(b.size() - start) / 4
        };
        if words.len() as u64 > capacity {
            return Err(Error::InvalidParameter {
                key: format!("{buffer:?} words"),
                allowed: format!("at most {capacity}"),
                got: words.len().to_string(),
            });
        }
        guarded(&self.device, "writing a buffer", None, || {
            self.queue
                .write_buffer(b, start, bytemuck::cast_slice(words));
            Ok(())
        })
    }

    /// Where the sections of `work`, `spring_work` and `partials` lie.
    #[doc(hidden)]
    pub fn debug_layout(&self) -> DebugLayout {
        DebugLayout {
            work_section_words: 4 * self.params.particle_count as usize,
            spring_section_words: 4 * self.spring_slots as usize,
            partial_slot_words: self.params.particle_count.div_ceil(WORKGROUP) as usize,
            arg_slots: self.buffers.arg_slots as usize,
        }
    }
}
