//! Stability regions: for each integrator, which (stretch stiffness, time
//! step) pairs keep a hanging cloth bounded.
//!
//! The cloth is the `hanging` scene's 1 m × 1 m patch pinned at its two top
//! corners, without the floor, at a realistic areal mass (0.2 kg/m² by
//! default), with shear = stretch / 4 and bend = stretch / 50 and the
//! scene's damping and fix-up (10 Gauss–Seidel passes to 110 % of the rest
//! length). It starts at rest, horizontal, and falls.
//!
//! A run is **stable** when, at every check (every [`CHECK_EVERY`] steps and
//! at the end), it has not diverged by the rule every command uses,
//! [`Divergence`], held to a strain of [`MAX_STRAIN`]:
//! - every position and velocity is finite;
//! - its total energy (kinetic + gravitational + elastic) stays below
//!   `E₀ + ENERGY_MARGIN · M·|g|·L` — gravity is in the total, so a
//!   physical run never gains energy; the margin, a fraction of the work
//!   gravity does dropping the whole cloth (mass `M`) by its side `L`,
//!   leaves room for symplectic Euler's bounded energy oscillation (the
//!   cloth starts at rest and unstretched, without wind, so the rule's
//!   other terms are zero);
//! - its largest stretch strain stays below [`MAX_STRAIN`].

use super::gpu_runs::{gpu_runs, GpuGrouping, Job};
use super::{GpuHandles, Points, Runner};
use crate::diagnostics::{Crossed, Divergence};
use crate::error::{Error, Result};
use crate::evidence::Backend;
use crate::model::Model;
use crate::params::{Integrator, SpringKind};
use crate::scene::Scene;

pub use crate::diagnostics::{CHECK_EVERY, ENERGY_MARGIN};

/// Largest stretch strain `(l − L) / L` of a stable run: a spring at twice
/// its rest length is no cloth any more. Stricter than a run's
/// [`DIVERGED_STRAIN`](crate::diagnostics::DIVERGED_STRAIN): the map marks
/// soft cloths that sag that far as "overstretched", which a run accepts.
pub const MAX_STRAIN: f64 = 1.0;

/// Ratio of shear stiffness to stretch stiffness in the sweep.
pub const SHEAR_RATIO: f64 = 0.25;

/// Ratio of bend stiffness to stretch stiffness in the sweep.
pub const BEND_RATIO: f64 = 0.02;

/// What [`stability`] sweeps.
#[derive(Clone, Debug, PartialEq)]
pub struct StabilityOptions {
    /// Particles per side.
    pub resolution: usize,
    /// Areal mass [kg/m²] (the cloth is 1 m², so also its mass \[kg\]).
    pub areal_mass: f64,
    /// Stretch stiffnesses [N/m].
    pub stiffnesses: Vec<f64>,
    /// Time steps \[s\].
    pub dts: Vec<f64>,
    /// Simulated time of each run \[s\].
    pub duration: f64,
    /// Cap on the steps of one run: the smallest time steps cover only
    /// `max_steps · dt` (< `duration`) so the sweep ends in minutes.
    pub max_steps: u64,
    /// Integrators swept.
    pub integrators: Vec<Integrator>,
}

impl Default for StabilityOptions {
    /// 17 × 17 particles, 0.2 kg, stiffness 10 … 10⁷ N/m (×10), dt 10⁻⁴ …
    /// 1/30 s (six steps, about ×3.2), 1 s, at most 2000 steps.
    fn default() -> Self {
        StabilityOptions {
            resolution: 17,
            areal_mass: 0.2,
            stiffnesses: (1..=7).map(|e| 10f64.powi(e)).collect(),
            dts: vec![1e-4, 3.2e-4, 1e-3, 3.2e-3, 1e-2, 1.0 / 30.0],
            duration: 1.0,
            max_steps: 2000,
            integrators: Integrator::ALL.to_vec(),
        }
    }
}

impl StabilityOptions {
    /// A sweep of seconds: 9 × 9 particles, 0.5 s, at most 500 steps.
    pub fn quick() -> Self {
        StabilityOptions {
            resolution: 9,
            duration: 0.5,
            max_steps: 500,
            ..StabilityOptions::default()
        }
    }
}

/// Why a run was judged as it was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Bounded to the end.
    Stable,
    /// A position or velocity became non-finite at this time \[s\].
    NonFinite(f64),
    /// Total energy exceeded the bound at this time \[s\].
    EnergyGrew(f64),
    /// A stretch spring passed [`MAX_STRAIN`] at this time \[s\].
    Overstretched(f64),
    /// The solver refused the parameters (e.g. a semi-implicit filter that
    /// is not positive definite).
    Refused,
}

impl Verdict {
    /// `true` for [`Verdict::Stable`].
    pub fn is_stable(self) -> bool {
        self == Verdict::Stable
    }

    /// A short reason for tables and CSV.
    pub fn reason(self) -> String {
        match self {
            Verdict::Stable => "stable".into(),
            Verdict::NonFinite(t) => format!("non-finite at {t:.3} s"),
            Verdict::EnergyGrew(t) => format!("energy grew at {t:.3} s"),
            Verdict::Overstretched(t) => format!("strain > 100 % at {t:.3} s"),
            Verdict::Refused => "refused".into(),
        }
    }
}

/// One (integrator, stiffness, dt) run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StabilityCell {
    /// The integrator.
    pub integrator: Integrator,
    /// Stretch stiffness [N/m].
    pub stiffness: f64,
    /// Time step \[s\].
    pub dt: f64,
    /// Simulated time covered \[s\] (`min(duration, max_steps · dt)`).
    pub simulated: f64,
    /// The outcome.
    pub verdict: Verdict,
}

/// Result of [`stability`].
#[derive(Clone, Debug, PartialEq)]
pub struct StabilityReport {
    /// What was swept.
    pub options: StabilityOptions,
    /// One cell per integrator × stiffness × dt, in that nesting order.
    pub cells: Vec<StabilityCell>,
}

impl StabilityReport {
    /// The cell of one run, if swept.
    pub fn cell(&self, integrator: Integrator, stiffness: f64, dt: f64) -> Option<&StabilityCell> {
        self.cells
            .iter()
            .find(|c| c.integrator == integrator && c.stiffness == stiffness && c.dt == dt)
    }

    /// Largest swept dt \[s\] at `stiffness` such that it and every smaller
    /// swept dt are stable; `None` when even the smallest is not.
    pub fn largest_stable_dt(&self, integrator: Integrator, stiffness: f64) -> Option<f64> {
        let mut dts = self.options.dts.clone();
        dts.sort_by(f64::total_cmp);
        let mut best = None;
        for dt in dts {
            match self.cell(integrator, stiffness, dt) {
                Some(c) if c.verdict.is_stable() => best = Some(dt),
                _ => break,
            }
        }
        best
    }
}

/// The hanging scene set up for one cell of the sweep.
fn cell_scene(
    options: &StabilityOptions,
    integrator: Integrator,
    k: f64,
    dt: f64,
) -> Result<Scene> {
    let mut scene = Scene::builtin("hanging")?;
    scene.cloths[0].spec.nx = options.resolution;
    scene.cloths[0].spec.ny = options.resolution;
    scene.cloths[0].spec.mass =
        options.areal_mass * scene.cloths[0].spec.size[0] * scene.cloths[0].spec.size[1];
    let p = &mut scene.params;
    p.integrator = integrator;
    p.dt = dt;
    p.ground = None;
    p.springs[SpringKind::Stretch.index()].stiffness = k;
    p.springs[SpringKind::Shear.index()].stiffness = k * SHEAR_RATIO;
    p.springs[SpringKind::Bend.index()].stiffness = k * BEND_RATIO;
    Ok(scene)
}

/// Runs one cell on the CPU in `f64`.
fn run_cell(
    options: &StabilityOptions,
    integrator: Integrator,
    k: f64,
    dt: f64,
) -> Result<StabilityCell> {
    let scene = cell_scene(options, integrator, k, dt)?;
    let model: Model = scene.model()?;
    let params = &scene.params;
    let steps = steps_of(options, dt);
    let mut cell = StabilityCell {
        integrator,
        stiffness: k,
        dt,
        simulated: steps as f64 * dt,
        verdict: Verdict::Stable,
    };
    let mut runner = match Runner::new(Backend::CpuF64, &model, params) {
        Ok(r) => r,
        Err(Error::InvalidParameter { .. }) => {
            cell.verdict = Verdict::Refused;
            return Ok(cell);
        }
        Err(e) => return Err(e),
    };
    let (x0, v0) = runner.state()?;
    let rule = Divergence::new(&model, params, 0.0, &x0, &v0).with_max_strain(MAX_STRAIN);
    let mut done = 0;
    while done < steps {
        let n = CHECK_EVERY.min(steps - done);
        let stepped = runner.advance(n);
        done += n;
        let t = done as f64 * dt;
        let checked = stepped.and_then(|()| {
            let (x, v) = runner.state()?;
            rule.check(done, t, &x, &v)
        });
        if let Some(verdict) = verdict(checked, t)? {
            cell.verdict = verdict;
            return Ok(cell);
        }
    }
    Ok(cell)
}

/// The verdict of a check at time `t` \[s\] that found `checked`: `None`
/// while the run is stable; an error that is no verdict is the sweep's.
fn verdict(checked: Result<()>, t: f64) -> Result<Option<Verdict>> {
    Ok(Some(match checked {
        Ok(()) => return Ok(None),
        Err(Error::NonFinite { time, .. }) => Verdict::NonFinite(time),
        Err(Error::Diverged {
            crossed: Crossed::Energy { .. },
            ..
        }) => Verdict::EnergyGrew(t),
        Err(Error::Diverged {
            crossed: Crossed::Strain { .. },
            ..
        }) => Verdict::Overstretched(t),
        Err(e) => return Err(e),
    }))
}

/// The steps of a run at `dt`: `duration`, at most `max_steps`.
fn steps_of(options: &StabilityOptions, dt: f64) -> u64 {
    ((options.duration / dt).ceil() as u64).min(options.max_steps)
}

/// Sweeps every integrator × stiffness × dt of `options` (CPU, `f64`; see
/// the module docs for the stability rule).
pub fn stability(options: &StabilityOptions) -> Result<StabilityReport> {
    let mut cells = Vec::new();
    for &integrator in &options.integrators {
        for &k in &options.stiffnesses {
            for &dt in &options.dts {
                cells.push(run_cell(options, integrator, k, dt)?);
            }
        }
    }
    Ok(StabilityReport {
        options: options.clone(),
        cells,
    })
}

/// [`stability`] on the GPU (`f32`), the runs of one time step (which take
/// the same steps) stepped together as one batch of cloths with
/// [`GpuGrouping::Batches`], each alone with [`GpuGrouping::Alone`]: the
/// same verdicts either way. Each run is checked as on the CPU, from the
/// rest state rounded to `f32` (where the GPU starts).
pub fn stability_gpu(
    options: &StabilityOptions,
    gpu: GpuHandles<'_>,
    grouping: GpuGrouping,
) -> Result<StabilityReport> {
    let mut cells = Vec::new();
    for &integrator in &options.integrators {
        for &k in &options.stiffnesses {
            for &dt in &options.dts {
                cells.push(StabilityCell {
                    integrator,
                    stiffness: k,
                    dt,
                    simulated: steps_of(options, dt) as f64 * dt,
                    verdict: Verdict::Stable,
                });
            }
        }
    }
    let mut dts = options.dts.clone();
    dts.sort_by(f64::total_cmp);
    dts.dedup();
    for dt in dts {
        let mine: Vec<usize> = (0..cells.len()).filter(|&c| cells[c].dt == dt).collect();
        let mut scenes = Vec::with_capacity(mine.len());
        for &c in &mine {
            let scene = cell_scene(options, cells[c].integrator, cells[c].stiffness, dt)?;
            let model = scene.model()?;
            scenes.push((scene.params, model));
        }
        let jobs: Vec<Job<'_>> = scenes
            .iter()
            .map(|(params, model)| Job { model, params })
            .collect();
        let rules: Vec<Divergence> = scenes
            .iter()
            .map(|(params, model)| {
                let (x0, v0) = gpu_rest_state(model);
                Divergence::new(model, params, 0.0, &x0, &v0).with_max_strain(MAX_STRAIN)
            })
            .collect();
        let steps = steps_of(options, dt);
        let intervals: Vec<u64> = (0..steps.div_ceil(CHECK_EVERY))
            .map(|k| CHECK_EVERY.min(steps - k * CHECK_EVERY))
            .collect();
        let mut verdicts: Vec<Verdict> = vec![Verdict::Stable; mine.len()];
        let mut refused = Vec::new();
        gpu_runs(
            gpu,
            &jobs,
            grouping,
            &intervals,
            |j, e| match e {
                Error::InvalidParameter { .. } => {
                    refused.push(j);
                    Ok(())
                }
                e => Err(e),
            },
            |s| {
                let t = s.steps as f64 * dt;
                let checked = s
                    .state
                    .and_then(|(x, v)| rules[s.job].check(s.steps, t, &x, &v));
                Ok(match verdict(checked, t)? {
                    None => true,
                    Some(v) => {
                        verdicts[s.job] = v;
                        false
                    }
                })
            },
        )?;
        for j in refused {
            verdicts[j] = Verdict::Refused;
        }
        for (c, v) in mine.into_iter().zip(verdicts) {
            cells[c].verdict = v;
        }
    }
    Ok(StabilityReport {
        options: options.clone(),
        cells,
    })
}

/// A cloth's rest state as the GPU starts from it: positions rounded to
/// `f32`, at rest.
fn gpu_rest_state(model: &Model) -> (Points, Points) {
    let x = model
        .rest_positions
        .iter()
        .map(|p| crate::real::Vec3::from_f64(p.as_vec3().as_dvec3()))
        .collect();
    let v = vec![crate::real::Vec3::from_f64([0.0; 3]); model.particle_count()];
    (x, v)
}
