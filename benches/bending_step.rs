//! What the linear bending model costs: a step of a `[material]` cloth
//! with `bending` against the same cloth without it, beside what the chord
//! bend springs add to a spring-table cloth, on the CPU reference in `f32`,
//! as ratios measured in one run.
//!
//! `cargo bench --bench bending_step` prints, for a 1 m² horizontal sheet
//! pinned at two corners at 33², 65² and 129² (explicit at 1/2000 s at 33²
//! and `∝ h²` finer, implicit and semi-implicit at 1/60 s), the median wall time of single
//! `f32` steps of four cloths timed in turn, sample by sample, so that a
//! load on the machine hits all four: a material without and with a
//! bending stiffness (5 µN·m, a shirting's), and a spring table without and
//! with bend springs. The ratios are what each bending term adds to its
//! step. The GPU solvers do not run the linear bending model yet.
//! `WGCLOTH_BENCH_QUICK=1` shortens the run; `WGCLOTH_BENCH_SIZES=33,65`
//! picks sizes.

mod common;

use std::path::Path;
use std::time::Instant;

use wgcloth::cpu::CpuSolver;
use wgcloth::{Model, Params, Scene};

/// The four cloths of a row: material without and with bending, springs
/// without and with bend springs.
fn cloths(n: usize, integrator: &str) -> Vec<(Model, Params)> {
    let dt = if integrator == "explicit" {
        1.0 / 2000.0
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

fn main() {
    let samples = if common::quick() { 15 } else { 101 };
    println!("CPU f32, median seconds per step; ratio = with / without (one run)");
    println!(
        "{:>5} {:<14} {:>11} {:>11} {:>7} {:>11} {:>11} {:>7}",
        "n", "integrator", "material", "+ bending", "ratio", "springs", "+ bend", "ratio"
    );
    for n in common::sizes(&[33, 65, 129]) {
        for integrator in ["explicit", "implicit", "semi-implicit"] {
            let mut solvers: Vec<CpuSolver<f32>> = cloths(n, integrator)
                .iter()
                .map(|(m, p)| {
                    let mut s = CpuSolver::new(m, p).unwrap_or_else(|e| panic!("{e}"));
                    s.step_n(5).unwrap_or_else(|e| panic!("{e}"));
                    s
                })
                .collect();
            let mut times = vec![Vec::new(); solvers.len()];
            for _ in 0..samples {
                for (s, t) in solvers.iter_mut().zip(&mut times) {
                    let start = Instant::now();
                    s.step().unwrap_or_else(|e| panic!("{e}"));
                    t.push(start.elapsed().as_secs_f64());
                }
            }
            let m: Vec<f64> = times
                .into_iter()
                .map(|mut t| {
                    t.sort_by(f64::total_cmp);
                    t[t.len() / 2]
                })
                .collect();
            println!(
                "{n:>5} {integrator:<14} {:>11.3e} {:>11.3e} {:>7.2} {:>11.3e} {:>11.3e} {:>7.2}",
                m[0],
                m[1],
                m[1] / m[0],
                m[2],
                m[3],
                m[3] / m[2]
            );
        }
    }
}
