//! What the linear bending model costs: a step of a `[material]` cloth
//! with `bending` against the same cloth without it, beside what the chord
//! bend springs add to a spring-table cloth, on the CPU reference in `f32`
//! and on the GPU solver, as ratios measured in one run.
//!
//! `cargo bench --bench bending_step` prints, for a 1 m² horizontal sheet
//! pinned at two corners at 33², 65² and 129² (explicit at 1/10 000 s at 33²
//! and `∝ h²` finer, implicit and semi-implicit at 1/60 s), the median wall time of single
//! `f32` steps of four cloths timed in turn, sample by sample, so that a
//! load on the machine hits all four: a material without and with a
//! bending stiffness (5 µN·m, a shirting's), and a spring table without and
//! with bend springs. The ratios are what each bending term adds to its
//! step. Then the same four cloths on the GPU solver of the default
//! adapter (`GpuContext::new(None)`; `WGPU_ADAPTER_NAME` picks another),
//! on the step path it chooses, each sample [`GPU_STEPS`] steps recorded
//! into one encoder, submitted and waited for, the four timed in turn.
//! No file inputs: `cargo bench --bench bending_step` on any machine with
//! an adapter. `WGCLOTH_BENCH_QUICK=1` shortens the run;
//! `WGCLOTH_BENCH_SIZES=33,65` picks sizes.

mod common;

use std::path::Path;
use std::time::Instant;

use wgcloth::cpu::CpuSolver;
use wgcloth::{GpuContext, GpuSolver, Model, Params, Scene};

/// The explicit step at 33² \[s\], `∝ h²` finer: stable for the four
/// cloths (at 1/2000 s the material's membrane blows up within 20 steps,
/// and a blown-up cloth times differently).
const EXPLICIT_DT_33: f64 = 1e-4;

/// GPU steps per sample: one submit and wait per sample, so that the
/// launch and the wait are spread over a few steps as a frame's are.
const GPU_STEPS: u64 = 10;

/// The integrators of each size's rows.
const INTEGRATORS: [&str; 3] = ["explicit", "implicit", "semi-implicit"];

/// The four cloths of a row: material without and with bending, springs
/// without and with bend springs.
fn cloths(n: usize, integrator: &str) -> Vec<(Model, Params)> {
    let dt = if integrator == "explicit" {
        // The membrane's stiffest vibration sets the explicit step: ω ∝ 1/h.
        EXPLICIT_DT_33 * (32.0 / (n - 1) as f64).powi(2)
    } else {
        1.0 / 60.0
    };
    let head = format!(
        "[simulation]\nintegrator = \"{integrator}\"\ndt = {dt}\n\
         [cloth]\nresolution = [{n}, {n}]\nsize = [1.0, 1.0]\n"
    );
    [
        "[material]\ndensity = 0.12\nstretch = 500.0\nshear = 100.0\n".to_string(),
        "[material]\ndensity = 0.12\nstretch = 500.0\nshear = 100.0\nbending = 5e-6\n".to_string(),
        "[springs.bend]\nstiffness = 0.0\n".to_string(),
        String::new(),
    ]
    .iter()
    .map(|tail| {
        let scene = Scene::from_toml(&format!("{head}{tail}"), Path::new("bench.toml"))
            .unwrap_or_else(|e| panic!("{e}"));
        let model = scene.model().unwrap_or_else(|e| panic!("{e}"));
        (model, scene.params)
    })
    .collect()
}

/// Medians of `samples` samples of each of `runs`, timed in turn sample
/// by sample (a load on the machine hits all of them alike); each call of
/// `run(k)` times one sample of run `k` \[s\].
fn medians_in_turn(runs: usize, samples: usize, mut run: impl FnMut(usize) -> f64) -> Vec<f64> {
    let mut times = vec![Vec::new(); runs];
    for _ in 0..samples {
        for (k, t) in times.iter_mut().enumerate() {
            t.push(run(k));
        }
    }
    times
        .into_iter()
        .map(|mut t| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        })
        .collect()
}

/// The table's header, naming what a row's times are.
fn header(what: &str) {
    println!("{what}, median seconds per step; ratio = with / without (one run)");
    println!(
        "{:>5} {:<14} {:>11} {:>11} {:>7} {:>11} {:>11} {:>7}",
        "n", "integrator", "material", "+ bending", "ratio", "springs", "+ bend", "ratio"
    );
}

/// A row: the four cloths' medians `m` and the two ratios, then `note`.
fn row(n: usize, integrator: &str, m: &[f64], note: &str) {
    println!(
        "{n:>5} {integrator:<14} {:>11.3e} {:>11.3e} {:>7.2} {:>11.3e} {:>11.3e} {:>7.2} {note}",
        m[0],
        m[1],
        m[1] / m[0],
        m[2],
        m[3],
        m[3] / m[2]
    );
}

fn main() {
    let samples = if common::quick() { 15 } else { 101 };
    let sizes = common::sizes(&[33, 65, 129]);
    header("CPU f32");
    for &n in &sizes {
        for integrator in INTEGRATORS {
            let mut solvers: Vec<CpuSolver<f32>> = cloths(n, integrator)
                .iter()
                .map(|(m, p)| {
                    let mut s = CpuSolver::new(m, p).unwrap_or_else(|e| panic!("{e}"));
                    s.step_n(5).unwrap_or_else(|e| panic!("{e}"));
                    s
                })
                .collect();
            let m = medians_in_turn(solvers.len(), samples, |k| {
                let start = Instant::now();
                solvers[k].step().unwrap_or_else(|e| panic!("{e}"));
                start.elapsed().as_secs_f64()
            });
            row(n, integrator, &m, "");
        }
    }
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("the GPU rows need an adapter: {e}"));
    header(&format!("GPU ({})", ctx.describe()));
    let gpu_samples = if common::quick() { 7 } else { 31 };
    for &n in &sizes {
        for integrator in INTEGRATORS {
            let mut solvers: Vec<GpuSolver> = cloths(n, integrator)
                .iter()
                .map(|(m, p)| {
                    let mut g = GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, m, p)
                        .unwrap_or_else(|e| panic!("{e}"));
                    g.step(5).unwrap_or_else(|e| panic!("{e}"));
                    g
                })
                .collect();
            let m = medians_in_turn(solvers.len(), gpu_samples, |k| {
                let t = common::submit_and_wait(&ctx, &mut solvers[k], GPU_STEPS);
                t.as_secs_f64() / GPU_STEPS as f64
            });
            for g in &mut solvers {
                // The steps timed stayed finite (a blown-up cloth times
                // differently); check reads the status words back.
                g.check().unwrap_or_else(|e| panic!("{e}"));
            }
            let paths: Vec<String> = solvers
                .iter()
                .map(|g| g.tuning().step_path().to_string())
                .collect();
            row(n, integrator, &m, &format!("({})", paths.join(", ")));
        }
    }
}
