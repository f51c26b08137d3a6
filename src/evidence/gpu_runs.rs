//! The GPU runs of a sweep, stepped together: every cloth of a group in
//! one [`GpuBatch`] on one kernel library, so a sweep's grid of small
//! cloths costs a few dispatches per step instead of a few per cloth.
//!
//! Each cloth of a batch steps exactly as it would alone (the batch's
//! contract, tested in `tests/batch.rs`), and the batch submits and checks
//! at the steps a lone run does ([`GPU_BATCH`] steps per submit), so the
//! states sampled are the lone runs' bit for bit; only the wall time is
//! shared.

use std::time::Instant;

use super::{GpuHandles, Points};
use crate::error::{Error, Result};
use crate::gpu::{ClothId, GpuBatch, GpuKernels};
use crate::model::Model;
use crate::params::Params;
use crate::real::Vec3;

/// Most steps one GPU submission records (as in `wgcloth run`): bounds the
/// command buffer.
pub(super) const GPU_BATCH: u32 = 256;

/// How a sweep's GPU runs are grouped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuGrouping {
    /// The runs that share their sample steps in one batch (the default).
    Batches,
    /// Each run alone (a batch of one): what the batches are checked
    /// against, and a sweep's cost per cloth alone.
    Alone,
}

/// One run of a group: its cloth.
pub(super) struct Job<'a> {
    pub model: &'a Model,
    pub params: &'a Params,
}

/// What a run reports after each of its intervals.
pub(super) struct Sample {
    /// The run (its index in the jobs).
    pub job: usize,
    /// Steps done.
    pub steps: u64,
    /// Its share of the wall time of the interval \[s\]: the batch's time
    /// over the runs it stepped.
    pub wall: f64,
    /// Positions \[m\] and velocities [m/s], or why there are none (the
    /// state stopped being finite).
    pub state: Result<(Points, Points)>,
}

/// Steps `jobs` on the GPU, grouped by `grouping`, through `intervals`
/// (steps each); after each interval calls `visit` for every run still
/// going, which returns whether the run goes on (a run whose state stopped
/// being finite stops anyway). A run the GPU solver refuses is reported by
/// `refused` and not run.
pub(super) fn gpu_runs(
    gpu: GpuHandles<'_>,
    jobs: &[Job<'_>],
    grouping: GpuGrouping,
    intervals: &[u64],
    mut refused: impl FnMut(usize, Error) -> Result<()>,
    mut visit: impl FnMut(Sample) -> Result<bool>,
) -> Result<()> {
    let kernels = GpuKernels::new(gpu.device);
    let groups: Vec<Vec<usize>> = match grouping {
        GpuGrouping::Batches => vec![(0..jobs.len()).collect()],
        GpuGrouping::Alone => (0..jobs.len()).map(|j| vec![j]).collect(),
    };
    for group in groups {
        let mut batch = GpuBatch::with_kernels(&kernels, gpu.queue);
        let mut live: Vec<(usize, ClothId)> = Vec::new();
        for j in group {
            match batch.add(jobs[j].model, jobs[j].params) {
                Ok(id) => live.push((j, id)),
                Err(e) => refused(j, e)?,
            }
        }
        let mut done = 0;
        for &steps in intervals {
            if live.is_empty() {
                break;
            }
            let start = Instant::now();
            let mut blown = advance(&mut batch, steps)?;
            done += steps;
            let mut states = Vec::with_capacity(live.len());
            for &(j, id) in &live {
                let state = match blown.iter().position(|(c, _)| *c == id) {
                    Some(k) => Err(blown.swap_remove(k).1),
                    None => batch.read_state(id).map(|s| {
                        let widen = |v: &[glam::Vec3]| -> Points {
                            v.iter().map(|p| Vec3::from_f64(p.as_dvec3())).collect()
                        };
                        (widen(&s.x), widen(&s.v))
                    }),
                };
                states.push((j, id, state));
            }
            let wall = start.elapsed().as_secs_f64() / live.len() as f64;
            live.clear();
            for (job, id, state) in states {
                let finite = state.is_ok();
                let go_on = visit(Sample {
                    job,
                    steps: done,
                    wall,
                    state,
                })?;
                if finite && go_on {
                    live.push((job, id));
                } else if finite {
                    batch.remove(id)?;
                }
            }
        }
    }
    Ok(())
}

/// Steps every cloth of `batch` `steps` steps, [`GPU_BATCH`] per submit
/// with a check after each, as a lone run does; returns the cloths whose
/// state stopped being finite (removed from the batch) with the error.
fn advance(batch: &mut GpuBatch, steps: u64) -> Result<Vec<(ClothId, Error)>> {
    let mut blown = Vec::new();
    let mut left = steps;
    while left > 0 && batch.cloth_count() > 0 {
        let n = left.min(u64::from(GPU_BATCH));
        // `n ≤ GPU_BATCH`, a u32.
        let mut checked = batch.step(n as u32).map(drop);
        // Every cloth took the steps; the check names the first that blew
        // up. Set it aside and check the others again.
        while let Err(e) = checked {
            match e {
                Error::InBatch { cloth, source } if matches!(*source, Error::NonFinite { .. }) => {
                    let Some(id) = batch.cloths().into_iter().find(|id| id.index() == cloth) else {
                        return Err(Error::InBatch { cloth, source });
                    };
                    batch.remove(id)?;
                    blown.push((id, *source));
                    checked = batch.check().map(drop);
                }
                e => return Err(e),
            }
        }
        left -= n;
    }
    Ok(blown)
}
