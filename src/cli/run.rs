//! `wgcloth run`: resolve the scene, apply the command-line overrides,
//! validate, simulate, write the outputs, print the summary.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use wgcloth::cpu::skin;
use wgcloth::diagnostics::{self, CHECK_EVERY};
use wgcloth::params::format_number;
use wgcloth::render_mesh::Embedding;
use wgcloth::{Model, Params, Real, Scene};

use super::backend::{Cpu, Gpu, Solver};
use super::batch::GpuCopies;
use super::interrupt;
use super::output::{commit_all, distinct_outputs, write_positions, AtomicFile, Trace};
use super::profile;
use super::summary::{Outcome, Summary};
use super::{Backend, Precision, RunArgs, StepPathArg, UsageError};
use wgcloth::gpu::Timestamps;
use wgcloth::scene::animation::Animation;

/// Most steps one run may take: far beyond any useful run, and small enough
/// that the count is exact in an `f64` (the `--seconds` conversion).
pub(super) const MAX_STEPS: u64 = 1_000_000_000_000;

/// A quotient `T / dt` within this relative distance of a whole number
/// counts as that number, so a duration that is a whole number of steps
/// does not gain one from rounding (1 s / 0.01 s is 100 steps, not 101);
/// `--fps` holds a frame of one step to it too.
pub(super) const WHOLE_STEPS_TOLERANCE: f64 = 1e-9;

/// Runs `wgcloth run`.
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    interrupt::install();
    let precision = precision_for_backend(args)?;
    let mut scene = Scene::resolve_until(&args.scene, &interrupt::requested)?;
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
    distinct_outputs(&[
        ("--positions-out", args.positions_out.as_deref()),
        ("--render-mesh-out", args.render_mesh_out.as_deref()),
        ("--trace-out", args.trace_out.as_deref()),
    ])?;
    if args.render_mesh_out.is_some() && scene.render_meshes.is_empty() {
        return Err(UsageError(format!(
            "--render-mesh-out writes a scene's render meshes; `{}` has none (`[cloth] \
             render_mesh` or `[[render_mesh]]` in the scene file)",
            scene.name
        ))
        .into());
    }
    let model = scene.model()?;
    // Embedded before any step: a vertex far from the cloth is refused now.
    let embeddings = match &args.render_mesh_out {
        Some(_) => scene.embeddings(&model)?,
        None => Vec::new(),
    };
    let animation = scene.animation(&model);
    let character = match (&animation, args.fps) {
        (None, None) => None,
        (None, Some(_)) => {
            return Err(UsageError(format!(
                "--fps only applies to a scene with a [character] (it sets how often the \
                 character's pose is updated); `{}` has none",
                scene.name
            ))
            .into())
        }
        (Some(animation), fps) => Some(Character::new(animation, fps, scene.params.dt)?),
    };
    let (model, params) = (&model, &scene.params);
    let run = Run {
        character,
        model,
        params,
        steps,
        positions: args.positions_out.as_deref(),
        render_meshes: args.render_mesh_out.as_deref(),
        embeddings: &embeddings,
        trace: args.trace_out.as_deref(),
        trace_every: args.trace_every,
    };
    let outcome = match (args.backend, precision, args.batch) {
        (Backend::Cpu, Precision::F64, _) => run.simulate(Cpu::<f64>::new(model, params)?)?,
        (Backend::Cpu, Precision::F32, _) => run.simulate(Cpu::<f32>::new(model, params)?)?,
        (Backend::Gpu, _, Some(copies)) => run.simulate(GpuCopies::new(
            args.adapter.as_deref(),
            model,
            params,
            copies,
        )?)?,
        (Backend::Gpu, _, None) => {
            let profile = args.profile.then(|| {
                args.profile_timestamps
                    .map_or(Timestamps::InsidePasses, Timestamps::from)
            });
            run.simulate(Gpu::new(
                args.adapter.as_deref(),
                model,
                params,
                profile,
                args.step_path.forced(),
            )?)?
        }
    };
    let summary = Summary {
        scene: &scene.name,
        integrator: scene.params.integrator,
        model,
        dt: scene.params.dt,
        wall: started.elapsed(),
        outcome,
    };
    out!("{summary}")?;
    if args.verbose {
        if let Some(path) = &summary.outcome.step_path {
            outln!("step path: {path}")?;
            if model.grid.is_some() && !model.own_constants.is_empty() {
                outln!(
                    "spring layout: general (the [material] gives each spring constants of its \
                     own; the grid kernels read one stiffness per kind)"
                )?;
            }
        }
        print_passes(&summary.outcome.passes, summary.outcome.backend)?;
        if let Some((per, budget, hits)) = summary.outcome.cg_recording {
            let total: u32 = summary.outcome.passes.iter().map(|p| p.1).sum();
            let outside = total.saturating_sub(per * budget);
            outln!(
                "dispatches per CG iteration: {per} ({budget} iterations recorded per step, \
                 {outside} dispatches outside them)"
            )?;
            outln!("CG budget hits        {hits} (checks that found a step cut short by the budget; its steps were run again with a larger one)")?;
        }
    }
    if let Some(profile) = &summary.outcome.profile {
        out!("{}", profile::Table(profile))?;
    }
    Ok(())
}

/// `--verbose`: the passes of one step, then `dispatches per step: N`.
fn print_passes(passes: &[(&str, u32, u32)], backend: &str) -> anyhow::Result<()> {
    if passes.is_empty() {
        outln!("passes per step       none: the {backend} backend dispatches no GPU work")?;
    }
    for (k, (kernel, count, items)) in passes.iter().enumerate() {
        let head = if k == 0 { "passes per step" } else { "" };
        outln!("{head:<21} {kernel:<20} {count:>4} × {items} invocations")?;
    }
    let total: u32 = passes.iter().map(|p| p.1).sum();
    outln!("dispatches per step: {total}")
}

/// The solver's precision: `--precision` on the CPU (default f64); f32 on
/// the GPU, which refuses an explicit `--precision f64` rather than run
/// something other than what was asked for. Also refuses `--adapter` and
/// `--profile` with the CPU backend, where they would mean nothing, and
/// `--batch` and `--step-path` there too (and `--batch` with `--profile`
/// or `--step-path`).
fn precision_for_backend(args: &RunArgs) -> Result<Precision, UsageError> {
    match (args.backend, args.precision) {
        (Backend::Cpu, _) if args.adapter.is_some() => Err(UsageError(
            "--adapter only applies to --backend gpu".to_string(),
        )),
        (Backend::Cpu, _) if args.profile => Err(UsageError(
            "--profile only applies to --backend gpu: it times GPU kernels".to_string(),
        )),
        (Backend::Cpu, _) if args.batch.is_some() => Err(UsageError(
            "--batch only applies to --backend gpu: it steps copies of the cloth in one GPU batch"
                .to_string(),
        )),
        (Backend::Cpu, _) if args.step_path != StepPathArg::Auto => Err(UsageError(
            "--step-path only applies to --backend gpu: it chooses how GPU steps are recorded"
                .to_string(),
        )),
        (Backend::Gpu, _) if args.batch.is_some() && args.step_path != StepPathArg::Auto => {
            Err(UsageError(
                "--step-path applies to one cloth: a batch steps each cloth on the path it can \
                 share (leave out --batch or --step-path)"
                    .to_string(),
            ))
        }
        (Backend::Gpu, _) if args.batch.is_some() && args.profile => Err(UsageError(
            "--profile times one cloth's kernels: leave out --batch to profile".to_string(),
        )),
        (Backend::Cpu, p) => Ok(p.unwrap_or(Precision::F64)),
        (Backend::Gpu, None | Some(Precision::F32)) => Ok(Precision::F32),
        (Backend::Gpu, Some(Precision::F64)) => Err(UsageError(
            "--precision f64 is not available with --backend gpu: the GPU computes in f32 \
             (leave --precision out; `--backend cpu --precision f64` is the reference)"
                .to_string(),
        )),
    }
}

/// The step count that covers `seconds` at `dt`: `ceil(seconds / dt)`, up to
/// [`WHOLE_STEPS_TOLERANCE`]. `what` names the source in the error.
fn steps_for(seconds: f64, dt: f64, what: &str) -> Result<u64, UsageError> {
    let q = seconds / dt;
    let n = whole_ceil(q);
    if n.is_nan() || n > MAX_STEPS as f64 {
        return Err(UsageError(format!(
            "{what}: {} s at dt = {} s is {q:e} steps; at most {MAX_STEPS:e} are allowed",
            format_number(seconds),
            format_number(dt)
        )));
    }
    Ok(n as u64)
}

/// A scene's character as `run` plays it: posed every `steps` steps, as
/// `render` poses it before each frame's steps (the same
/// [`wgcloth::render::steps_per_frame`] for the same frames per second),
/// so both commands move the cloth alike.
struct Character<'a> {
    animation: &'a Animation,
    /// Steps between two poses.
    steps: u64,
    /// Their simulated time \[s\].
    seconds: f64,
}

impl<'a> Character<'a> {
    /// Poses `fps` (`render`'s default without it) times a second of
    /// simulated time at time step `dt` \[s\]; an `fps` `render` would
    /// refuse is refused.
    fn new(animation: &'a Animation, fps: Option<f64>, dt: f64) -> Result<Self, UsageError> {
        let steps = super::render::frame_steps(fps, dt)?;
        Ok(Character {
            animation,
            steps: u64::from(steps),
            seconds: f64::from(steps) * dt,
        })
    }
}

/// `ceil(q)`, but a `q` within [`WHOLE_STEPS_TOLERANCE`] of a whole number
/// is that number (1 s / 0.01 s is 100 steps, not 101).
pub(super) fn whole_ceil(q: f64) -> f64 {
    let nearest = q.round();
    if (q - nearest).abs() <= WHOLE_STEPS_TOLERANCE * nearest.max(1.0) {
        nearest
    } else {
        q.ceil()
    }
}

/// One run: what to simulate and where its files go.
struct Run<'a> {
    /// The scene's character, if it has one.
    character: Option<Character<'a>>,
    model: &'a Model,
    params: &'a Params,
    steps: u64,
    positions: Option<&'a Path>,
    /// `--render-mesh-out`, and the scene's render meshes embedded.
    render_meshes: Option<&'a Path>,
    embeddings: &'a [Embedding],
    trace: Option<&'a Path>,
    trace_every: u64,
}

impl Run<'_> {
    /// Opens the outputs, steps `solver`, writes the outputs and measures
    /// the final state.
    fn simulate<S: Solver>(&self, mut solver: S) -> wgcloth::Result<Outcome> {
        // Opened before stepping so a bad path fails before a long run, not
        // after it; dropped uncommitted on any error or interruption below,
        // which removes them.
        let positions = self.positions.map(AtomicFile::create).transpose()?;
        let render_meshes = self.render_meshes.map(AtomicFile::create).transpose()?;
        let mut trace = self
            .trace
            .map(|path| Trace::create(path, self.trace_every))
            .transpose()?;

        let rule = solver.divergence_rule(self.model, self.params)?;
        let mut stepping = Duration::ZERO;
        loop {
            let done = solver.steps();
            // One read of the state (a read-back on the GPU) serves both the
            // divergence check and the trace when they fall on one step.
            let check = done.is_multiple_of(CHECK_EVERY) || done == self.steps;
            let traced = trace.as_ref().is_some_and(|t| t.wants(done));
            if check || traced {
                let time = solver.time();
                let motion = solver.motion()?;
                let s = solver.state()?;
                if check {
                    rule.check_with(done, time, &s.x, &s.v, &motion)?;
                }
                if let Some(trace) = trace.as_mut().filter(|_| traced) {
                    trace.step(done, time, &s.x, &s.v)?;
                }
            }
            if done == self.steps {
                break;
            }
            // Up to the next divergence check, so that every backend checks
            // at the same steps, and to the next traced step, so that the
            // state is at hand then.
            let mut n = (self.steps - done).min(CHECK_EVERY - done % CHECK_EVERY);
            if trace.is_some() {
                n = n.min(self.trace_every - done % self.trace_every);
            }
            // Up to the character's next pose, set at the start of each of
            // its frames as `render` sets it.
            if let Some(c) = &self.character {
                if done.is_multiple_of(c.steps) {
                    let frame = (done / c.steps) as f64;
                    solver.animate(c.animation, frame * c.seconds, c.seconds)?;
                }
                n = n.min(c.steps - done % c.steps);
            }
            interrupt::check()?;
            let t0 = Instant::now();
            solver.advance(n)?;
            stepping += t0.elapsed();
        }

        let (steps, time, device) = (solver.steps(), solver.time(), solver.device());
        let passes = solver.passes();
        let cg_recording = solver.cg_recording();
        let step_path = solver.step_path();
        let profile = solver.profile();
        let stats = solver.stats(self.params);
        let batch = solver.batch();
        let s = solver.state()?;
        let mut outputs = Vec::new();
        if let Some(mut file) = positions {
            file.write_with(|out| write_positions(out, &s.x))?;
            outputs.push(file);
        }
        if let Some(mut file) = render_meshes {
            // The skinning's CPU twin on the final positions: on a GPU
            // that rounds like it, the bits its `skin` pass writes.
            file.write_with(|out| {
                self.embeddings
                    .iter()
                    .try_for_each(|e| write_positions(out, &skin::skin(self.model, &s.x, e).0))
            })?;
            outputs.push(file);
        }
        if let Some(trace) = trace {
            outputs.push(trace.finish(steps, time, &s.x, &s.v)?);
        }
        commit_all(outputs)?;
        Ok(Outcome {
            passes,
            cg_recording,
            step_path,
            profile,
            backend: S::BACKEND,
            precision: S::Real::NAME,
            device,
            steps,
            time,
            stepping,
            max_strain: diagnostics::max_stretch_strain(self.model, &s.x),
            energy: diagnostics::energy(self.model, self.params, &s.x, &s.v),
            stats,
            batch,
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
