//! The GPU profiler behind `wgcloth run --profile`: each kernel's GPU time
//! per step from timestamp queries, and the bytes it moves per step (from
//! [`super::traffic`]), so that its bandwidth can be read against the
//! device's.
//!
//! [`GpuSolver::step_profiled`] records the same dispatches in the same
//! order as [`GpuSolver::step`] and checks the device at the same points,
//! so results are bit-identical; only the recording differs. Where the
//! device has `TIMESTAMP_QUERY_INSIDE_PASSES`, one compute pass holds the
//! dispatches with a timestamp between each two; otherwise each dispatch
//! gets a compute pass of its own with timestamps at its start and end
//! (which adds the passes' own cost to each kernel); without timestamp
//! queries the steps run unprofiled and only bytes and dispatch counts are
//! reported.
//!
//! Each profiled submit also times, on the host, the recording of its steps
//! as [`GpuSolver::step`] records them (`encode_steps` into an encoder of its
//! own and `finish`), then drops that recording unsubmitted: wgpu validates
//! and tracks every dispatch on the CPU, a cost the GPU's timestamps do not
//! see and that falls with the dispatches per step.

use std::time::Instant;

use super::errors::guarded;
use super::kernel::{Dispatch, Kernel};
use super::readback;
use super::solver::{Entry, GpuSolver};
use super::traffic::UnitCounts;
use crate::error::{Error, Result};
use crate::stats::StepStats;

/// Most dispatches timed in one submission: one more than this many
/// timestamps fit a query set (two per dispatch at pass boundaries).
const CHUNK: usize = (wgpu::QUERY_SET_MAX_QUERIES / 2 - 1) as usize;

/// How kernels are timed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Timestamps {
    /// No timestamp queries: no times.
    None,
    /// One compute pass per dispatch, timestamps at its start and end.
    PassBoundaries,
    /// One compute pass, a timestamp between each two dispatches.
    InsidePasses,
}

impl Timestamps {
    /// The device features profiling uses where the adapter has them.
    pub const FEATURES: wgpu::Features =
        wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES);

    /// The best timing a device with `features` allows.
    pub fn best(features: wgpu::Features) -> Timestamps {
        if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
            Timestamps::None
        } else if features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES) {
            Timestamps::InsidePasses
        } else {
            Timestamps::PassBoundaries
        }
    }

    /// How the times were taken, for reports.
    pub fn describe(self) -> &'static str {
        match self {
            Timestamps::None => "none (the device has no timestamp queries)",
            Timestamps::PassBoundaries => {
                "at pass boundaries (a compute pass per dispatch; each time \
                 includes its pass's own cost)"
            }
            Timestamps::InsidePasses => "inside the step's compute pass",
        }
    }
}

/// Most steps whose times a [`Profiler`] keeps: beyond, it keeps an evenly
/// spaced sample, so a long run's memory stays bounded (64 KiB per kernel)
/// and the median is still over steps from the whole run.
const KEPT_STEPS: usize = 8192;

/// The GPU times gathered over profiled steps.
#[derive(Clone, Debug)]
pub struct Profiler {
    timestamps: Timestamps,
    /// Per kernel: its GPU time in each kept step \[ns\].
    samples: Vec<(Kernel, Vec<f64>)>,
    /// Steps kept: every `stride`-th profiled step.
    kept: usize,
    stride: u64,
    /// Steps profiled.
    steps: u64,
    /// Per kept submit: its host recording cost.
    recording: Vec<RecordingCost>,
    /// Submits kept: every `recording_stride`-th timed one.
    recording_stride: u64,
    /// Submits whose recording was timed.
    submits: u64,
}

impl Profiler {
    /// A profiler timing by `timestamps`, which the device must allow
    /// (see [`Timestamps::best`]; a lesser one may be asked for).
    pub fn new(timestamps: Timestamps) -> Profiler {
        Profiler {
            timestamps,
            samples: Vec::new(),
            kept: 0,
            stride: 1,
            steps: 0,
            recording: Vec::new(),
            recording_stride: 1,
            submits: 0,
        }
    }

    /// How kernels are timed.
    pub fn timestamps(&self) -> Timestamps {
        self.timestamps
    }

    /// Adds one step's times: `(kernel, ns)` per dispatch.
    fn add_step(&mut self, dispatches: impl Iterator<Item = (Kernel, f64)>) {
        let keep = self.steps.is_multiple_of(self.stride);
        self.steps += 1;
        if !keep {
            return;
        }
        let column = self.kept;
        for (kernel, ns) in dispatches {
            let at = match self.samples.iter().position(|s| s.0 == kernel) {
                Some(at) => at,
                None => {
                    self.samples.push((kernel, Vec::new()));
                    self.samples.len() - 1
                }
            };
            let times = &mut self.samples[at].1;
            // A kernel first seen in a later step took no time before it.
            if times.len() <= column {
                times.resize(column + 1, 0.0);
            }
            times[column] += ns;
        }
        self.kept += 1;
        if self.kept == KEPT_STEPS {
            // Keep every other step from here on, and of those kept.
            for (_, times) in &mut self.samples {
                keep_every_other(times);
            }
            self.kept = KEPT_STEPS / 2;
            self.stride *= 2;
        }
    }

    /// Adds one submit's host recording cost, keeping an evenly spaced
    /// sample of at most [`KEPT_STEPS`] submits as [`Profiler::add_step`]
    /// does of steps.
    fn add_recording(&mut self, cost: RecordingCost) {
        let keep = self.submits.is_multiple_of(self.recording_stride);
        self.submits += 1;
        if !keep {
            return;
        }
        self.recording.push(cost);
        if self.recording.len() == KEPT_STEPS {
            keep_every_other(&mut self.recording);
            self.recording_stride *= 2;
        }
    }

    /// The kept submit of median recording time per step (the mean of the
    /// two middle ones for an even count); `None` before any.
    fn median_recording(&self) -> Option<RecordingCost> {
        let mut costs = self.recording.clone();
        median(
            &mut costs,
            |c| c.micros_per_step,
            |a, b| RecordingCost {
                micros_per_step: 0.5 * (a.micros_per_step + b.micros_per_step),
                dispatches_per_step: 0.5 * (a.dispatches_per_step + b.dispatches_per_step),
            },
        )
    }

    /// `kernel`'s median GPU time per kept step \[µs\] (`None` without
    /// times or steps).
    fn median_us(&self, kernel: Kernel) -> Option<f64> {
        if self.timestamps == Timestamps::None || self.kept == 0 {
            return None;
        }
        let mut times = self
            .samples
            .iter()
            .find(|s| s.0 == kernel)
            .map_or_else(Vec::new, |s| s.1.clone());
        times.resize(self.kept, 0.0);
        let median = median(&mut times, |t| *t, |a, b| 0.5 * (a + b))?;
        Some(median / 1000.0)
    }
}

/// Drops every second entry of `v` (keeps the first, third, …): halves an
/// evenly spaced sample and keeps it evenly spaced.
fn keep_every_other<T>(v: &mut Vec<T>) {
    let mut k = 0;
    v.retain(|_| {
        k += 1;
        k % 2 == 1
    });
}

/// The median of `values` ordered by `key`: the middle one, or the `mean`
/// of the two middle ones for an even count; `None` for none. Sorts
/// `values`.
fn median<T: Copy>(
    values: &mut [T],
    key: impl Fn(&T) -> f64,
    mean: impl Fn(T, T) -> T,
) -> Option<T> {
    values.sort_by(|a, b| key(a).total_cmp(&key(b)));
    let mid = values.len() / 2;
    match values.len() {
        0 => None,
        len if len % 2 == 1 => Some(values[mid]),
        _ => Some(mean(values[mid - 1], values[mid])),
    }
}

/// The host's cost of recording steps: [`GpuSolver::encode_steps`] into an
/// encoder of its own plus [`wgpu::CommandEncoder::finish`], with no submit
/// and no wait. wgpu validates and tracks each dispatch on the CPU, so it
/// grows with the dispatches per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordingCost {
    /// Host time to record one step \[µs\].
    pub micros_per_step: f64,
    /// Dispatches recorded per step (an odd number of single-pass explicit
    /// steps adds the one `explicit_seed` dispatch to their count).
    pub dispatches_per_step: f64,
}

impl RecordingCost {
    /// Host time to record one dispatch \[µs\]; `None` without dispatches.
    pub fn micros_per_dispatch(&self) -> Option<f64> {
        (self.dispatches_per_step > 0.0).then(|| self.micros_per_step / self.dispatches_per_step)
    }
}

/// One kernel's row of a [`Profile`].
#[derive(Clone, Debug, PartialEq)]
pub struct ProfileRow {
    /// The kernel.
    pub kernel: Kernel,
    /// Its dispatches per step.
    pub dispatches: u32,
    /// Median GPU time per step over the profiled steps (an evenly spaced
    /// sample of them beyond 8 192) \[µs\]; `None`
    /// without timestamps.
    pub micros: Option<f64>,
    /// Bytes read per step (see [`Kernel::traffic`]).
    pub read: u64,
    /// Bytes written per step.
    pub written: u64,
}

impl ProfileRow {
    /// Achieved bandwidth, bytes moved over GPU time \[GB/s\].
    pub fn bandwidth(&self) -> Option<f64> {
        bandwidth(self.read + self.written, self.micros?)
    }
}

/// (Bytes over µs) in GB/s; `None` for no time.
fn bandwidth(bytes: u64, micros: f64) -> Option<f64> {
    (micros > 0.0).then(|| bytes as f64 / (micros * 1000.0))
}

/// Each kernel of the step plan: dispatches, GPU time and bytes per step.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// How the times were taken.
    pub timestamps: Timestamps,
    /// Steps profiled (the times are medians over them).
    pub steps: u64,
    /// One row per kernel of the step plan, in order of first dispatch.
    pub rows: Vec<ProfileRow>,
    /// The host's cost of recording a step, from the profiled submit of
    /// median recording time per step (the mean of the two middle ones for
    /// an even count; over an evenly spaced sample of the submits beyond
    /// 8 192); `None` before any profiled step.
    pub recording: Option<RecordingCost>,
}

impl Profile {
    /// GPU time per step, the sum of the rows \[µs\]; `None` without times.
    pub fn total_micros(&self) -> Option<f64> {
        self.rows.iter().map(|r| r.micros).sum()
    }

    /// Dispatches per step.
    pub fn dispatches(&self) -> u32 {
        self.rows.iter().map(|r| r.dispatches).sum()
    }

    /// Bytes read and written per step.
    pub fn bytes(&self) -> (u64, u64) {
        let read = self.rows.iter().map(|r| r.read).sum();
        (read, self.rows.iter().map(|r| r.written).sum())
    }

    /// Achieved bandwidth of the whole step \[GB/s\].
    pub fn bandwidth(&self) -> Option<f64> {
        let (read, written) = self.bytes();
        bandwidth(read + written, self.total_micros()?)
    }
}

/// `plan` grouped by kernel, in order of first appearance: `(kernel,
/// dispatches, invocations of the first)`.
pub(super) fn per_kernel(plan: &[Dispatch]) -> Vec<(Kernel, u32, u32)> {
    let mut out: Vec<(Kernel, u32, u32)> = Vec::new();
    for d in plan {
        match out.iter_mut().find(|(k, _, _)| *k == d.kernel) {
            Some(entry) => entry.1 += 1,
            None => out.push((d.kernel, 1, d.items)),
        }
    }
    out
}

impl GpuSolver {
    /// [`GpuSolver::step`] with each dispatch timed into `profiler`: the
    /// same dispatches in the same order, so the same results bit for bit.
    /// Submits a chunk of dispatches at a time and reads its timestamps
    /// back, so it is slower than `step`. `explicit_seed`, which an odd
    /// number of single-pass steps records once, is not part of a step and
    /// is not timed into one. A timing the device lacks the features for
    /// is an [`Error::InvalidParameter`].
    #[doc(hidden)]
    pub fn step_profiled(&mut self, n: u32, profiler: &mut Profiler) -> Result<StepStats> {
        let best = Timestamps::best(self.device.features());
        if profiler.timestamps > best {
            return Err(Error::InvalidParameter {
                key: "profiler timestamps".into(),
                allowed: format!(
                    "{best:?} or less: the device lacks the features of more \
                     (open it with Timestamps::FEATURES)"
                ),
                got: format!("{:?}", profiler.timestamps),
            });
        }
        // Timed before the steps, so with the CG budget they record. A
        // browser has no clock for `Instant` (and cannot run profiled steps,
        // which wait on the device).
        if n > 0 && !cfg!(target_arch = "wasm32") {
            profiler.add_recording(self.time_recording(n)?);
        }
        if profiler.timestamps == Timestamps::None {
            profiler.steps += u64::from(n);
            return self.step(n);
        }
        let mut entries: Vec<(&Entry, u32)> = Vec::new();
        self.prepared
            .steps
            .for_each(n, self.cg.current(), |e, k| entries.push((e, k)));
        let plan = &self.prepared.steps;
        let seeded = usize::from(plan.alternates && n % 2 == 1 && plan.seed.is_some());
        self.recorded.set((0, n));
        let mut ns = Vec::with_capacity(entries.len());
        for chunk in entries.chunks(CHUNK) {
            ns.extend(self.record_timed(chunk, profiler.timestamps)?);
        }
        if n > 0 {
            let per_step = (entries.len() - seeded) / n as usize;
            let timed = entries.iter().zip(&ns).skip(seeded);
            let steps: Vec<_> = timed.map(|((e, _), t)| (e.0.kernel, *t)).collect();
            for step in steps.chunks(per_step.max(1)) {
                profiler.add_step(step.iter().copied());
            }
        }
        self.steps_recorded += u64::from(n);
        self.check()
    }

    /// Records `n` steps (`n` > 0) as [`GpuSolver::step`] does, into an
    /// encoder of their own, timing `encode_steps` and `finish` on the
    /// host, and drops the commands unsubmitted: the device and the count
    /// of recorded steps are as before.
    fn time_recording(&mut self, n: u32) -> Result<RecordingCost> {
        let device = self.device.clone();
        let steps_recorded = self.steps_recorded;
        let cost = guarded(&device, "timing the recording of steps", None, || {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.profile.recording"),
            });
            let start = Instant::now();
            self.encode_steps(&mut encoder, n);
            let commands = encoder.finish();
            let elapsed = start.elapsed();
            // Dropped, not submitted: only the recording was wanted.
            drop(commands);
            let (dispatches, _) = self.recorded.get();
            Ok(RecordingCost {
                micros_per_step: elapsed.as_secs_f64() * 1e6 / f64::from(n),
                dispatches_per_step: f64::from(dispatches) / f64::from(n),
            })
        });
        // The steps were never submitted: they did not happen.
        self.steps_recorded = steps_recorded;
        cost
    }

    /// Records, submits and times `entries` in one encoder: each entry's
    /// GPU time \[ns\].
    fn record_timed(&self, entries: &[(&Entry, u32)], timestamps: Timestamps) -> Result<Vec<f64>> {
        let inside = timestamps == Timestamps::InsidePasses;
        let count = if inside {
            entries.len() + 1
        } else {
            2 * entries.len()
        };
        // `count` ≤ QUERY_SET_MAX_QUERIES (CHUNK).
        let queries = count as u32;
        let device = self.device.clone();
        let resolved = guarded(&device, "profiling steps", None, || {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("wgcloth.profile"),
                ty: wgpu::QueryType::Timestamp,
                count: queries,
            });
            let resolved = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wgcloth.profile"),
                size: u64::from(queries) * u64::from(wgpu::QUERY_SIZE),
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.profile"),
            });
            if inside {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wgcloth.profile"),
                    timestamp_writes: None,
                });
                pass.set_bind_group(0, &self.buffers.bind_group, &[]);
                pass.write_timestamp(&set, 0);
                for (i, &((d, p), k)) in (1..).zip(entries) {
                    self.dispatch(&mut pass, d, p, k);
                    pass.write_timestamp(&set, i);
                }
            } else {
                for (i, &((d, p), k)) in (0..).zip(entries) {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("wgcloth.profile"),
                        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                            query_set: &set,
                            beginning_of_pass_write_index: Some(2 * i),
                            end_of_pass_write_index: Some(2 * i + 1),
                        }),
                    });
                    pass.set_bind_group(0, &self.buffers.bind_group, &[]);
                    self.dispatch(&mut pass, d, p, k);
                }
            }
            encoder.resolve_query_set(&set, 0..queries, &resolved, 0);
            self.queue.submit([encoder.finish()]);
            Ok(resolved)
        })?;
        let bytes =
            readback::read_buffers(&device, &self.queue, &[(&resolved, 0, resolved.size())])?;
        let ticks: &[u64] = bytemuck::cast_slice(&bytes[0]);
        let period = f64::from(self.queue.get_timestamp_period());
        // A device may report a later timestamp below an earlier one (a
        // clock that is not monotonic across passes): no time, not a
        // negative one.
        let span = |a: u64, b: u64| b.saturating_sub(a) as f64 * period;
        Ok(if inside {
            ticks.windows(2).map(|w| span(w[0], w[1])).collect()
        } else {
            ticks.chunks_exact(2).map(|w| span(w[0], w[1])).collect()
        })
    }

    /// Each kernel of the current step plan with its dispatches, bytes per
    /// step and the median GPU time `profiler` measured.
    #[doc(hidden)]
    pub fn profile(&self, profiler: &Profiler) -> Profile {
        let counts = self.unit_counts();
        let rows = per_kernel(&self.step_plan())
            .into_iter()
            .map(|(kernel, dispatches, _)| {
                let (read, written) = counts.bytes(kernel);
                ProfileRow {
                    kernel,
                    dispatches,
                    micros: profiler.median_us(kernel),
                    read: read * u64::from(dispatches),
                    written: written * u64::from(dispatches),
                }
            })
            .collect();
        Profile {
            timestamps: profiler.timestamps,
            steps: profiler.steps,
            rows,
            recording: profiler.median_recording(),
        }
    }

    /// How many items of each traffic unit the cloth has on the device.
    #[doc(hidden)]
    pub fn unit_counts(&self) -> UnitCounts {
        let coarse = self.params.coarse;
        UnitCounts {
            particles: self.params.particle_count.into(),
            springs: if self.grid {
                0
            } else {
                self.spring_slots.into()
            },
            adjacency_rows: if self.grid {
                0
            } else {
                self.params.particle_count.into()
            },
            aggregates: if self.features.coarse {
                u64::from(coarse[2]) + u64::from(coarse[3])
            } else {
                0
            },
            filter_rows: self.params.filter_count.into(),
            triangles: self.params.triangle_count.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_run_keeps_a_bounded_even_sample_with_the_runs_median() {
        let mut p = Profiler::new(Timestamps::InsidePasses);
        // Step i takes i µs: the median of the whole run is its middle.
        let steps = 3 * KEPT_STEPS as u64 + 5;
        for i in 0..steps {
            p.add_step([(Kernel::FinishStep, i as f64 * 1000.0)].into_iter());
        }
        assert_eq!(p.steps, steps);
        assert!(p.kept <= KEPT_STEPS, "kept {} steps", p.kept);
        assert!(p.samples.iter().all(|s| s.1.len() == p.kept));
        // An evenly spaced sample's median is within one stride of the
        // run's.
        let median = p.median_us(Kernel::FinishStep).unwrap_or(f64::NAN);
        let whole = (steps - 1) as f64 / 2.0;
        assert!(
            (median - whole).abs() <= p.stride as f64,
            "median {median} µs, the run's {whole} µs, stride {}",
            p.stride
        );
        // A kernel never dispatched took no time.
        assert_eq!(p.median_us(Kernel::CgUpdate), Some(0.0));
    }

    #[test]
    fn recording_costs_keep_a_bounded_sample_and_the_median_submit() {
        let cost = |us: f64, dispatches: f64| RecordingCost {
            micros_per_step: us,
            dispatches_per_step: dispatches,
        };
        let mut p = Profiler::new(Timestamps::None);
        assert_eq!(p.median_recording(), None);
        // An even count: the mean of the two middle submits, each its
        // time with its own dispatches.
        for (us, d) in [(9.0, 30.0), (1.0, 10.0), (3.0, 20.0), (5.0, 40.0)] {
            p.add_recording(cost(us, d));
        }
        assert_eq!(p.median_recording(), Some(cost(4.0, 30.0)));
        // Submit i takes i µs per step: the sample stays bounded and its
        // median is within one stride of the run's.
        let mut p = Profiler::new(Timestamps::None);
        let submits = 3 * KEPT_STEPS as u64 + 5;
        for i in 0..submits {
            p.add_recording(cost(i as f64, 1.0));
        }
        assert!(
            p.recording.len() <= KEPT_STEPS,
            "kept {}",
            p.recording.len()
        );
        let median = p.median_recording().map_or(f64::NAN, |c| c.micros_per_step);
        let whole = (submits - 1) as f64 / 2.0;
        assert!(
            (median - whole).abs() <= p.recording_stride as f64,
            "median {median} µs, the run's {whole} µs, stride {}",
            p.recording_stride
        );
    }
}
