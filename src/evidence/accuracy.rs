//! Accuracy against a converged reference: error against cost for every
//! integrator, backend and time step.
//!
//! The reference is the CPU `f64` explicit (symplectic Euler) solver at
//! `dt_ref = dt / reference_divisor`; it is run again at `dt_ref / 2` and the
//! largest difference between the two ([`AccuracyReport::reference_change`])
//! bounds how far it is from the exact trajectory. Every run samples its
//! positions at the same times `t_k = k · sample_every · dt` (`dt` the
//! scene's step), which are whole steps of every time step measured (each
//! multiple must divide `sample_every`), so nothing is interpolated.
//!
//! Provot's fix-up changes the physics (it is a constraint, not an error of
//! the integrator), so each fix-up setting is compared with a reference run
//! at that same setting; the implicit integrator has no fix-up and is
//! compared with the reference without.

use std::time::Instant;

use super::gpu_runs::{gpu_runs, GpuGrouping, Job};
use super::{GpuHandles, Points, Runner};
use crate::diagnostics::max_stretch_strain;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::{Integrator, Params};
use crate::scene::Scene;

/// Which solver and arithmetic a row measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Backend {
    /// CPU reference solver in double precision.
    CpuF64,
    /// CPU solver in single precision (the GPU's arithmetic).
    CpuF32,
    /// wgpu compute solver (single precision).
    Gpu,
}

impl Backend {
    /// All backends, in table order.
    pub const ALL: [Backend; 3] = [Backend::CpuF64, Backend::CpuF32, Backend::Gpu];

    /// The CSV / chart spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Backend::CpuF64 => "cpu-f64",
            Backend::CpuF32 => "cpu-f32",
            Backend::Gpu => "gpu",
        }
    }
}

/// Strain past which a run counts as unstable rather than inaccurate: a
/// spring stretched to twice its rest length is no cloth any more (the
/// same rule as [`mod@super::stability`]).
pub const UNSTABLE_STRAIN: f64 = 1.0;

/// What [`accuracy`] measures.
#[derive(Clone, Debug, PartialEq)]
pub struct AccuracyOptions {
    /// Particles per side of the cloth (the scene's resolution is replaced;
    /// its size and mass are kept). `None` keeps the scene's.
    pub resolution: Option<usize>,
    /// Time between samples, in steps of the scene's `dt`.
    pub sample_every: u32,
    /// Number of samples (the run covers `samples · sample_every · dt`).
    pub samples: u32,
    /// The time steps measured, as multiples of the scene's `dt`; each must
    /// divide `sample_every`.
    pub dt_multiples: Vec<u32>,
    /// `dt_ref = dt / reference_divisor`.
    pub reference_divisor: u32,
    /// Fix-up iteration counts of the explicit and semi-implicit runs.
    pub fixup_iterations: Vec<u32>,
    /// CG tolerances of the implicit runs (relative, dimensionless).
    pub cg_tolerances: Vec<f64>,
    /// Integrators measured.
    pub integrators: Vec<Integrator>,
    /// Backends measured (`Gpu` only when a device is passed).
    pub backends: Vec<Backend>,
}

impl Default for AccuracyOptions {
    /// 17 × 17 particles, 10 samples 80 steps apart (0.8 s at the
    /// `hanging` scene's 1 ms), dt × {1, 2, 4, 8, 16}, reference at dt / 128
    /// (at dt / 64 the fix-up reference was within 8× of the smallest
    /// fix-up error; halving it again keeps it over 10× below).
    fn default() -> Self {
        AccuracyOptions {
            resolution: Some(17),
            sample_every: 80,
            samples: 10,
            dt_multiples: vec![1, 2, 4, 8, 16],
            reference_divisor: 128,
            fixup_iterations: vec![0, 10],
            cg_tolerances: vec![1e-2, 1e-4],
            integrators: Integrator::ALL.to_vec(),
            backends: Backend::ALL.to_vec(),
        }
    }
}

impl AccuracyOptions {
    /// A run of a few seconds: 9 × 9 particles, 5 samples, reference at
    /// dt / 64. A smoke run, not for numbers: its fix-up reference moves by
    /// 2.9e-4 m when halved, a third of the smallest fix-up error (1e-3 m).
    /// (At dt / 16 it moved by 6e-4 m.)
    pub fn quick() -> Self {
        AccuracyOptions {
            resolution: Some(9),
            samples: 5,
            reference_divisor: 64,
            ..AccuracyOptions::default()
        }
    }
}

/// One measured configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct AccuracyRow {
    /// The integrator.
    pub integrator: Integrator,
    /// The backend.
    pub backend: Backend,
    /// Time step \[s\].
    pub dt: f64,
    /// Fix-up iterations (explicit, semi-implicit; 0 for implicit).
    pub fixup_iterations: u32,
    /// CG tolerance (implicit; `None` otherwise).
    pub cg_tolerance: Option<f64>,
    /// `false`: the run blew up or stretched a spring past
    /// [`UNSTABLE_STRAIN`]; the time and error fields are then NaN.
    pub stable: bool,
    /// Wall time per simulated second [s/s] (solver set-up excluded).
    pub wall_per_sim_second: f64,
    /// RMS over all particles and samples of the distance to the
    /// reference \[m\].
    pub rms_error: f64,
    /// Largest such distance \[m\].
    pub max_error: f64,
}

/// Result of [`accuracy`].
#[derive(Clone, Debug, PartialEq)]
pub struct AccuracyReport {
    /// The scene's name.
    pub scene: String,
    /// Particles in the measured cloth.
    pub particles: usize,
    /// The reference step \[s\].
    pub reference_dt: f64,
    /// Sample times \[s\].
    pub sample_times: Vec<f64>,
    /// Per fix-up setting: largest distance \[m\] between the reference and a
    /// run at half its step — how far from converged the reference is.
    pub reference_change: Vec<(u32, f64)>,
    /// The measurements.
    pub rows: Vec<AccuracyRow>,
}

impl AccuracyReport {
    /// The largest [`AccuracyReport::reference_change`] \[m\].
    pub fn worst_reference_change(&self) -> f64 {
        self.reference_change
            .iter()
            .map(|r| r.1)
            .fold(0.0, f64::max)
    }

    /// The smallest RMS error of a stable row \[m\] (NaN when none).
    pub fn smallest_error(&self) -> f64 {
        self.smallest_error_where(|_| true)
    }

    /// The smallest RMS error \[m\] of the stable rows compared with the
    /// reference of `fixup_iterations` fix-up passes (NaN when none).
    pub fn smallest_error_with_fixup(&self, fixup_iterations: u32) -> f64 {
        self.smallest_error_where(|r| r.fixup_iterations == fixup_iterations)
    }

    fn smallest_error_where(&self, keep: impl Fn(&AccuracyRow) -> bool) -> f64 {
        self.rows
            .iter()
            .filter(|r| r.stable && keep(r))
            .map(|r| r.rms_error)
            .fold(f64::NAN, f64::min)
    }

    /// Indices of the stable rows on the Pareto front of (wall time, RMS
    /// error): no other stable row is both faster and more accurate.
    pub fn pareto_front(&self) -> Vec<usize> {
        let stable: Vec<usize> = (0..self.rows.len())
            .filter(|&i| self.rows[i].stable)
            .collect();
        stable
            .iter()
            .copied()
            .filter(|&i| {
                let a = &self.rows[i];
                !stable.iter().any(|&j| {
                    let b = &self.rows[j];
                    j != i
                        && b.wall_per_sim_second <= a.wall_per_sim_second
                        && b.rms_error <= a.rms_error
                        && (b.wall_per_sim_second < a.wall_per_sim_second
                            || b.rms_error < a.rms_error)
                })
            })
            .collect()
    }
}

fn invalid(key: &str, allowed: &str, got: impl std::fmt::Display) -> Error {
    Error::InvalidParameter {
        key: key.to_string(),
        allowed: allowed.to_string(),
        got: got.to_string(),
    }
}

/// The scene's model at `options.resolution`.
fn model_of(scene: &Scene, resolution: Option<usize>) -> Result<Model> {
    let mut scene = scene.clone();
    if let Some(n) = resolution {
        scene.cloths[0].spec.nx = n;
        scene.cloths[0].spec.ny = n;
    }
    scene.model()
}

/// Positions sampled at the sample times, and whether the run stayed
/// stable; plus the wall time of the stepping \[s\].
struct Trajectory {
    samples: Vec<Points>,
    stable: bool,
    wall: f64,
}

/// The trajectory of a CPU run.
fn trajectory(
    backend: Backend,
    model: &Model,
    params: &Params,
    steps_per_sample: u64,
    samples: u32,
) -> Result<Trajectory> {
    let mut runner = Runner::new(backend, model, params)?;
    let mut t = Trajectory {
        samples: Vec::with_capacity(samples as usize),
        stable: true,
        wall: 0.0,
    };
    for _ in 0..samples {
        let start = Instant::now();
        let stepped = runner.advance(steps_per_sample);
        let state = runner.state();
        t.wall += start.elapsed().as_secs_f64();
        let state = stepped.and(state).map(|(x, _)| x);
        if !t.sample(model, state)? {
            break;
        }
    }
    Ok(t)
}

impl Trajectory {
    /// Adds a sample's positions, or marks the run unstable (its state
    /// stopped being finite, or a spring passed [`UNSTABLE_STRAIN`]);
    /// whether the run goes on. Any other error is the sweep's.
    fn sample(&mut self, model: &Model, state: Result<Points>) -> Result<bool> {
        let x = match state {
            Ok(x) => x,
            Err(Error::NonFinite { .. }) => {
                self.stable = false;
                return Ok(false);
            }
            Err(e) => return Err(e),
        };
        if max_stretch_strain(model, &x) > UNSTABLE_STRAIN {
            self.stable = false;
            return Ok(false);
        }
        self.samples.push(x);
        Ok(true)
    }
}

/// The trajectories of GPU runs of `model` under each of `params`, all
/// `steps_per_sample` apart, grouped by `grouping`.
fn gpu_trajectories(
    gpu: GpuHandles<'_>,
    grouping: GpuGrouping,
    model: &Model,
    params: &[Params],
    steps_per_sample: u64,
    samples: u32,
) -> Result<Vec<Trajectory>> {
    let jobs: Vec<Job<'_>> = params.iter().map(|params| Job { model, params }).collect();
    let mut out: Vec<Trajectory> = params
        .iter()
        .map(|_| Trajectory {
            samples: Vec::with_capacity(samples as usize),
            stable: true,
            wall: 0.0,
        })
        .collect();
    let intervals = vec![steps_per_sample; samples as usize];
    gpu_runs(
        gpu,
        &jobs,
        grouping,
        &intervals,
        |_, e| Err(e),
        |s| {
            let t = &mut out[s.job];
            t.wall += s.wall;
            t.sample(model, s.state.map(|(x, _)| x))
        },
    )?;
    Ok(out)
}

/// (RMS, max) distance \[m\] between two sampled trajectories.
fn errors(a: &[Points], b: &[Points]) -> (f64, f64) {
    let (mut sum, mut n, mut max) = (0.0, 0usize, 0.0f64);
    for (sa, sb) in a.iter().zip(b) {
        for (p, q) in sa.iter().zip(sb) {
            let d2 = (*p - *q).length_squared();
            sum += d2;
            n += 1;
            max = max.max(d2.sqrt());
        }
    }
    ((sum / n.max(1) as f64).sqrt(), max)
}

/// Measures error against cost for `scene` (see the module docs). `gpu`:
/// a device for the [`Backend::Gpu`] rows; without one they are skipped.
/// The GPU rows that share a time step run as one batch of cloths (their
/// positions are the lone runs' bit for bit; each row's wall time is its
/// share of the batch's).
pub fn accuracy(
    scene: &Scene,
    options: &AccuracyOptions,
    gpu: Option<GpuHandles<'_>>,
) -> Result<AccuracyReport> {
    accuracy_with(scene, options, gpu, GpuGrouping::Batches)
}

/// [`accuracy`] with the GPU rows grouped by `grouping`.
pub fn accuracy_with(
    scene: &Scene,
    options: &AccuracyOptions,
    gpu: Option<GpuHandles<'_>>,
    grouping: GpuGrouping,
) -> Result<AccuracyReport> {
    if options.sample_every == 0 || options.samples == 0 || options.reference_divisor == 0 {
        return Err(invalid(
            "bench.accuracy",
            "sample_every, samples and reference_divisor ≥ 1",
            format!("{options:?}"),
        ));
    }
    if let Some(&m) = options
        .dt_multiples
        .iter()
        .find(|&&m| m == 0 || !options.sample_every.is_multiple_of(m))
    {
        return Err(invalid(
            "bench.accuracy.dt_multiples",
            &format!("divisors of sample_every = {}", options.sample_every),
            m,
        ));
    }
    let model = model_of(scene, options.resolution)?;
    let dt = scene.params.dt;
    let dt_ref = dt / f64::from(options.reference_divisor);
    let every = u64::from(options.sample_every);

    // References per fix-up setting (implicit rows use the one with 0).
    let mut fixups = options.fixup_iterations.clone();
    if !fixups.contains(&0) {
        fixups.push(0);
    }
    let mut references = Vec::new();
    let mut reference_change = Vec::new();
    for &fix in &fixups {
        let run = |divisor: u64| -> Result<Vec<Points>> {
            let mut p = scene.params.clone();
            p.integrator = Integrator::Explicit;
            p.fixup.iterations = fix;
            p.dt = dt / divisor as f64;
            let t = trajectory(
                Backend::CpuF64,
                &model,
                &p,
                every * divisor,
                options.samples,
            )?;
            match t {
                t if t.stable => Ok(t.samples),
                _ => Err(invalid(
                    "bench.accuracy.reference_divisor",
                    "a reference step at which the explicit reference stays stable",
                    divisor,
                )),
            }
        };
        let div = u64::from(options.reference_divisor);
        let reference = run(div)?;
        let finer = run(2 * div)?;
        reference_change.push((fix, errors(&reference, &finer).1));
        references.push((fix, reference));
    }
    let reference_for = |fix: u32| references.iter().find(|r| r.0 == fix).map(|r| &r.1);

    // Every row's run, in table order; the GPU's are run afterwards, those
    // of one time step together.
    let mut runs: Vec<(AccuracyRow, Params, u64, Option<Trajectory>)> = Vec::new();
    for &integrator in &options.integrators {
        // (fix-up, CG tolerance) variants of this integrator.
        let variants: Vec<(u32, Option<f64>)> = match integrator {
            Integrator::Implicit => options
                .cg_tolerances
                .iter()
                .map(|&t| (0, Some(t)))
                .collect(),
            _ => options
                .fixup_iterations
                .iter()
                .map(|&f| (f, None))
                .collect(),
        };
        for &(fix, tol) in &variants {
            if reference_for(fix).is_none() {
                continue;
            }
            for &backend in &options.backends {
                if backend == Backend::Gpu && gpu.is_none() {
                    continue;
                }
                for &m in &options.dt_multiples {
                    let mut p = scene.params.clone();
                    p.integrator = integrator;
                    p.dt = dt * f64::from(m);
                    p.fixup.iterations = fix;
                    if let Some(t) = tol {
                        p.implicit.tolerance = t;
                    }
                    let steps = every / u64::from(m);
                    let t = match backend {
                        Backend::Gpu => None,
                        _ => Some(trajectory(backend, &model, &p, steps, options.samples)?),
                    };
                    let row = AccuracyRow {
                        integrator,
                        backend,
                        dt: p.dt,
                        fixup_iterations: fix,
                        cg_tolerance: tol,
                        stable: false,
                        wall_per_sim_second: f64::NAN,
                        rms_error: f64::NAN,
                        max_error: f64::NAN,
                    };
                    runs.push((row, p, steps, t));
                }
            }
        }
    }
    if let Some(gpu) = gpu {
        let mut step_counts: Vec<u64> = runs.iter().map(|r| r.2).collect();
        step_counts.sort_unstable();
        step_counts.dedup();
        for steps in step_counts {
            let mine: Vec<usize> = (0..runs.len())
                .filter(|&k| runs[k].0.backend == Backend::Gpu && runs[k].2 == steps)
                .collect();
            let params: Vec<Params> = mine.iter().map(|&k| runs[k].1.clone()).collect();
            let ts = gpu_trajectories(gpu, grouping, &model, &params, steps, options.samples)?;
            for (k, t) in mine.into_iter().zip(ts) {
                runs[k].3 = Some(t);
            }
        }
    }
    let mut rows = Vec::with_capacity(runs.len());
    for (mut row, p, steps, t) in runs {
        let (Some(t), Some(reference)) = (t, reference_for(row.fixup_iterations)) else {
            continue;
        };
        if t.stable {
            let duration = p.dt * (steps * u64::from(options.samples)) as f64;
            let (rms, max) = errors(&t.samples, reference);
            row.stable = true;
            row.wall_per_sim_second = t.wall / duration;
            row.rms_error = rms;
            row.max_error = max;
        }
        rows.push(row);
    }
    Ok(AccuracyReport {
        scene: scene.name.clone(),
        particles: model.particle_count(),
        reference_dt: dt_ref,
        sample_times: (1..=options.samples)
            .map(|k| f64::from(k) * f64::from(options.sample_every) * dt)
            .collect(),
        reference_change,
        rows,
    })
}
