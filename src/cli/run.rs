//! `wgcloth run`: resolve the scene, apply the command-line overrides,
//! validate, simulate, write the outputs, print the summary.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use wgcloth::cpu::{CpuSolver, StepStats};
use wgcloth::{diagnostics, Integrator, Model, Params, Real, Scene};

use super::output::{write_positions, AtomicFile, Trace};
use super::summary::{CgSummary, FixupSummary, Outcome, Summary};
use super::{Backend, Precision, RunArgs, UsageError};

/// Most steps one run may take: far beyond any useful run, and small enough
/// that the count is exact in an `f64` (the `--seconds` conversion).
const MAX_STEPS: u64 = 1_000_000_000_000;

/// A quotient `T / dt` within this relative distance of a whole number
/// counts as that number, so a duration that is a whole number of steps
/// does not gain one from rounding (1 s / 0.01 s is 100 steps, not 101).
const WHOLE_STEPS_TOLERANCE: f64 = 1e-9;

/// Runs `wgcloth run`.
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    let mut scene = Scene::resolve(&args.scene)?;
    if let Some(integrator) = args.integrator {
        scene.params.integrator = integrator.into();
    }
    if let Some(dt) = args.dt {
        scene.params.dt = dt;
    }
    scene
        .params
        .validate()
        .context("the command-line options make the scene invalid")?;
    let steps = match (args.steps, args.seconds) {
        (Some(n), _) => n,
        (None, Some(t)) => steps_for(t, scene.params.dt, "--seconds")?,
        (None, None) => steps_for(scene.duration, scene.params.dt, "the scene's duration")?,
    };
    if let (Some(a), Some(b)) = (&args.positions_out, &args.trace_out) {
        if a == b {
            return Err(UsageError(format!(
                "--positions-out and --trace-out are the same file ({})",
                a.display()
            ))
            .into());
        }
    }
    let model = scene.model()?;
    let outputs = Outputs {
        positions: args.positions_out.as_deref(),
        trace: args.trace_out.as_deref(),
        trace_every: args.trace_every,
    };
    let outcome = match (args.backend, args.precision) {
        (Backend::Cpu, Precision::F64) => simulate::<f64>(&model, &scene.params, steps, &outputs)?,
        (Backend::Cpu, Precision::F32) => simulate::<f32>(&model, &scene.params, steps, &outputs)?,
    };
    let summary = Summary {
        scene: &scene.name,
        integrator: scene.params.integrator,
        backend: args.backend.as_str(),
        precision: args.precision.as_str(),
        model: &model,
        dt: scene.params.dt,
        wall: started.elapsed(),
        outcome,
    };
    print!("{summary}");
    Ok(())
}

/// The step count that covers `seconds` at `dt`: `ceil(seconds / dt)`, up to
/// [`WHOLE_STEPS_TOLERANCE`]. `what` names the source in the error.
fn steps_for(seconds: f64, dt: f64, what: &str) -> Result<u64, UsageError> {
    let q = seconds / dt;
    let nearest = q.round();
    let n = if (q - nearest).abs() <= WHOLE_STEPS_TOLERANCE * nearest.max(1.0) {
        nearest
    } else {
        q.ceil()
    };
    if n.is_nan() || n > MAX_STEPS as f64 {
        return Err(UsageError(format!(
            "{what}: {seconds} s at dt = {dt} s is {q:e} steps; at most {MAX_STEPS:e} are allowed"
        )));
    }
    Ok(n as u64)
}

/// Where the run writes its files.
struct Outputs<'a> {
    positions: Option<&'a Path>,
    trace: Option<&'a Path>,
    trace_every: u64,
}

/// Builds the solver, opens the outputs, steps, and writes the outputs.
fn simulate<R: Real>(
    model: &Model,
    params: &Params,
    steps: u64,
    outputs: &Outputs<'_>,
) -> wgcloth::Result<Outcome> {
    let mut solver = CpuSolver::<R>::new(model, params)?;
    // Opened before stepping so a bad path fails before a long run, not
    // after it; dropped uncommitted on any error below, which removes them.
    let positions = outputs.positions.map(AtomicFile::create).transpose()?;
    let mut trace = outputs
        .trace
        .map(|path| Trace::create(path, outputs.trace_every))
        .transpose()?;
    if let Some(trace) = &mut trace {
        trace.step(0, 0.0, solver.positions(), solver.velocities())?;
    }

    let mut totals = Totals::new(params.implicit.max_iterations);
    for _ in 0..steps {
        let t0 = Instant::now();
        let stats = solver.step()?;
        totals.stepping += t0.elapsed();
        totals.add(&stats);
        if let Some(trace) = &mut trace {
            trace.step(
                solver.steps(),
                solver.time(),
                solver.positions(),
                solver.velocities(),
            )?;
        }
    }

    let (x, v) = (solver.positions(), solver.velocities());
    if let Some(mut file) = positions {
        file.write_with(|out| write_positions(out, x))?;
        file.commit()?;
    }
    if let Some(trace) = trace {
        trace.finish(solver.steps(), solver.time(), x, v)?;
    }
    Ok(Outcome {
        steps: solver.steps(),
        time: solver.time(),
        stepping: totals.stepping,
        max_strain: diagnostics::max_stretch_strain(model, x),
        energy: diagnostics::energy(model, params, x, v),
        cg: totals.cg(params),
        fixup: totals.fixup(params.integrator),
        filter: solver.filter_name(),
    })
}

/// Per-step statistics summed over the run.
struct Totals {
    steps: u64,
    stepping: Duration,
    cg_iterations: u64,
    cg_max: u32,
    /// The implicit solver's CG iteration cap.
    cg_cap: u32,
    /// Steps whose CG stopped at the cap rather than at the tolerance.
    cg_capped: u64,
    cg_max_residual: f64,
    fixup_passes: u64,
    fixup_max: u32,
}

impl Totals {
    fn new(cg_cap: u32) -> Self {
        Totals {
            steps: 0,
            stepping: Duration::ZERO,
            cg_iterations: 0,
            cg_max: 0,
            cg_cap,
            cg_capped: 0,
            cg_max_residual: 0.0,
            fixup_passes: 0,
            fixup_max: 0,
        }
    }

    fn add(&mut self, s: &StepStats) {
        self.steps += 1;
        self.cg_iterations += u64::from(s.cg_iterations);
        self.cg_max = self.cg_max.max(s.cg_iterations);
        self.cg_capped += u64::from(s.cg_iterations >= self.cg_cap);
        self.cg_max_residual = self.cg_max_residual.max(s.cg_residual);
        self.fixup_passes += u64::from(s.fixup_passes);
        self.fixup_max = self.fixup_max.max(s.fixup_passes);
    }

    fn mean(&self, total: u64) -> Option<f64> {
        (self.steps > 0).then(|| total as f64 / self.steps as f64)
    }

    fn cg(&self, params: &Params) -> Option<CgSummary> {
        (params.integrator == Integrator::Implicit).then(|| CgSummary {
            mean: self.mean(self.cg_iterations),
            max: self.cg_max,
            cap: self.cg_cap,
            capped_steps: self.cg_capped,
            max_residual: self.cg_max_residual,
            tolerance: params.implicit.tolerance,
        })
    }

    fn fixup(&self, integrator: Integrator) -> Option<FixupSummary> {
        (integrator != Integrator::Implicit).then(|| FixupSummary {
            mean: self.mean(self.fixup_passes),
            max: self.fixup_max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_to_steps_rounds_up_but_not_for_rounding_noise() {
        assert_eq!(steps_for(1.0, 0.01, "t").ok(), Some(100));
        assert_eq!(steps_for(4.0, 1.0 / 600.0, "t").ok(), Some(2400));
        assert_eq!(steps_for(0.3, 0.1, "t").ok(), Some(3));
        assert_eq!(steps_for(1.05, 0.1, "t").ok(), Some(11));
        assert_eq!(steps_for(0.0, 0.1, "t").ok(), Some(0));
        assert_eq!(steps_for(0.01, 0.1, "t").ok(), Some(1));
        assert!(steps_for(1e6, 1e-9, "t").is_err());
    }
}
