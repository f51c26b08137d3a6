//! The GPU profiler (`wgcloth run --profile`): it lists every kernel the
//! step plan records, its times add up, its bytes follow the traffic
//! table, it changes no result, an adapter without timestamps is said to
//! have none, and the host's time to record a step is reported. On
//! lavapipe in CI.

mod cli_common;

use std::collections::BTreeSet;
use std::sync::OnceLock;

use cli_common::{assert_status, stdout, wgcloth};
use wgcloth::gpu::{GpuContext, GpuSolver, Kernel, Profile, Profiler, StepPath, Timestamps};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params, Scene};

/// A device with the timestamp features the adapter has, as
/// `wgcloth run --profile` opens it. A machine without an adapter fails.
fn gpu() -> &'static GpuContext {
    static CONTEXT: OnceLock<GpuContext> = OnceLock::new();
    CONTEXT.get_or_init(
        || match GpuContext::with_features(None, Timestamps::FEATURES) {
            Ok(c) => c,
            Err(e) => panic!("GPU tests need an adapter: {e}"),
        },
    )
}

/// The best timing the test device allows.
fn best() -> Timestamps {
    Timestamps::best(gpu().device.features())
}

/// A built-in scene's model and parameters, with `integrator`.
fn scene(name: &str, integrator: Integrator) -> (Model, Params) {
    let mut scene = Scene::resolve(name).unwrap_or_else(|e| panic!("scene {name}: {e}"));
    scene.params.integrator = integrator;
    let model = scene
        .model()
        .unwrap_or_else(|e| panic!("model {name}: {e}"));
    (model, scene.params)
}

fn solver(model: &Model, params: &Params) -> GpuSolver {
    let ctx = gpu();
    GpuSolver::new(&ctx.device, &ctx.queue, model, params).expect("GPU solver")
}

/// A solver on the multi-dispatch path, whose passes the byte counts
/// below name one by one.
fn multi_dispatch(model: &Model, params: &Params) -> GpuSolver {
    let ctx = gpu();
    GpuSolver::with_step_path(
        ctx.kernels(),
        &ctx.queue,
        model,
        params,
        StepPath::MultiDispatch,
    )
    .expect("GPU solver")
}

/// The distinct kernels of the solver's step plan, in order of first
/// dispatch, with their dispatches per step.
fn plan_kernels(g: &GpuSolver) -> Vec<(Kernel, u32)> {
    let mut out: Vec<(Kernel, u32)> = Vec::new();
    for d in g.tuning().step_plan() {
        match out.iter_mut().find(|(k, _)| *k == d.kernel) {
            Some(e) => e.1 += 1,
            None => out.push((d.kernel, 1)),
        }
    }
    out
}

#[test]
fn every_kernel_has_its_traffic() {
    for kernel in Kernel::ALL {
        let terms = kernel.traffic();
        assert!(!terms.is_empty(), "{kernel} has no traffic row");
        assert!(
            terms.iter().any(|t| t.read + t.written > 0),
            "{kernel} moves no bytes"
        );
        let units: BTreeSet<_> = terms.iter().map(|t| format!("{:?}", t.unit)).collect();
        assert_eq!(units.len(), terms.len(), "{kernel} counts a unit twice");
    }
}

#[test]
fn the_profile_lists_the_step_plan_and_its_times_add_up() {
    for name in ["hanging", "flag"] {
        for integrator in Integrator::ALL {
            let (model, params) = scene(name, integrator);
            let mut g = solver(&model, &params);
            let mut profiler = Profiler::new(best());
            // Two batches, the second after the CG budget has adapted.
            for n in [3, 4] {
                g.step_profiled(n, &mut profiler).expect("profiled steps");
            }
            let profile = g.profile(&profiler);
            let rows: Vec<(Kernel, u32)> = profile
                .rows
                .iter()
                .map(|r| (r.kernel, r.dispatches))
                .collect();
            assert_eq!(rows, plan_kernels(&g), "{name}, {integrator:?}");
            assert_eq!(profile.steps, 7, "{name}, {integrator:?}");
            if best() == Timestamps::None {
                continue;
            }
            let mut sum = 0.0;
            for r in &profile.rows {
                let t = r.micros.expect("a time per kernel with timestamps");
                assert!(t >= 0.0, "{name}, {integrator:?}: {} took {t} µs", r.kernel);
                sum += t;
            }
            let total = profile.total_micros().expect("a total with timestamps");
            assert_eq!(
                total, sum,
                "{name}, {integrator:?}: the total is the rows' sum"
            );
            assert!(total > 0.0, "{name}, {integrator:?}: a step took no time");
        }
    }
}

/// `kernel`'s row of `profile`: dispatches, bytes read and written.
fn row_of(profile: &Profile, kernel: Kernel) -> (u32, u64, u64) {
    let r = profile.rows.iter().find(|r| r.kernel == kernel);
    let r = r.unwrap_or_else(|| panic!("no {kernel} row"));
    (r.dispatches, r.read, r.written)
}

#[test]
fn bytes_of_a_grid_step_match_the_hand_count() {
    // `hanging`, explicit: a 33 × 33 grid cloth (no springs buffer read) with
    // 10 fix-up passes.
    let (model, params) = scene("hanging", Integrator::Explicit);
    let n = model.particle_count() as u64;
    assert_eq!(n, 33 * 33);
    let g = multi_dispatch(&model, &params);
    let profile = g.profile(&Profiler::new(Timestamps::None));
    let row = |k: Kernel| row_of(&profile, k);
    // finish_step reads x, v, the fix-up's result, the new v and the
    // particle clock (5 vec4 of 16 bytes) and writes x, v and the clock.
    assert_eq!(row(Kernel::FinishStep), (1, n * 5 * 16, n * 3 * 16));
    // Each fix-up pass reads the source positions and writes the
    // destination (16 bytes each); a grid has no springs buffer or
    // adjacency to read.
    let passes = u64::from(params.fixup.iterations);
    assert_eq!(passes, 10);
    assert_eq!(
        row(Kernel::FixupJacobi),
        (10, passes * n * 16, passes * n * 16)
    );
    let (read, written) = profile.bytes();
    let rows: u64 = profile.rows.iter().map(|r| r.read + r.written).sum();
    assert_eq!(read + written, rows);
}

#[test]
fn bytes_of_a_mesh_step_match_the_hand_count() {
    // `banner`, semi-implicit: a glTF mesh, so the general layout (a
    // springs buffer and an adjacency list), with 10 fix-up passes.
    let (model, params) = scene("banner", Integrator::SemiImplicit);
    let (n, s) = (model.particle_count() as u64, model.springs.len() as u64);
    let g = multi_dispatch(&model, &params);
    let profile = g.profile(&Profiler::new(Timestamps::None));
    let row = |k: Kernel| row_of(&profile, k);
    // spring_forces reads each particle's x and v (16 bytes each) and each
    // spring (32 bytes), and writes each spring's force (16).
    assert_eq!(row(Kernel::SpringForces), (1, n * 2 * 16 + s * 32, s * 16));
    // A fix-up pass reads the source positions (16), each particle's
    // adjacency offset (4), each spring (32) and its two adjacency entries
    // (2 × 4), and writes the destination positions (16).
    let passes = u64::from(params.fixup.iterations);
    assert!(passes > 0, "banner has no fix-up");
    assert_eq!(
        row(Kernel::FixupJacobi),
        (
            passes as u32,
            passes * (n * (16 + 4) + s * (32 + 2 * 4)),
            passes * n * 16
        )
    );
}

#[test]
fn a_profiled_run_equals_an_unprofiled_one_bit_for_bit() {
    let mut timings = vec![Timestamps::None];
    if best() >= Timestamps::PassBoundaries {
        timings.push(Timestamps::PassBoundaries);
    }
    if best() == Timestamps::InsidePasses {
        timings.push(Timestamps::InsidePasses);
    }
    for integrator in Integrator::ALL {
        // `flag` runs at dt = 5 ms, beyond the explicit integrator's reach.
        let name = if integrator == Integrator::Explicit {
            "hanging"
        } else {
            "flag"
        };
        let (model, params) = scene(name, integrator);
        let mut plain = solver(&model, &params);
        // Odd batches: single-pass steps start with the seed.
        let batches = [3, 10, 7];
        for n in batches {
            plain.step(n).expect("steps");
        }
        let expected = plain.read_state().expect("read-back");
        for &timing in &timings {
            let mut g = solver(&model, &params);
            let mut profiler = Profiler::new(timing);
            for n in batches {
                g.step_profiled(n, &mut profiler).expect("profiled steps");
            }
            let got = g.read_state().expect("read-back");
            let bits = |v: &[wgcloth::glam::Vec3]| -> Vec<[u32; 3]> {
                v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
            };
            let differ = bits(&got.x)
                .iter()
                .zip(bits(&expected.x))
                .position(|(a, b)| *a != b);
            assert_eq!(
                differ, None,
                "{integrator:?}, {timing:?}: first particle that differs"
            );
            assert_eq!(
                bits(&got.v),
                bits(&expected.v),
                "{integrator:?}, {timing:?}"
            );
            assert_eq!(g.steps_recorded(), plain.steps_recorded());
        }
    }
}

/// The kernel names in `--profile`'s table, between its header and total.
fn table_kernels(out: &str) -> Vec<String> {
    out.lines()
        .skip_while(|l| !l.starts_with("kernel "))
        .skip(1)
        .take_while(|l| !l.starts_with("total "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .collect()
}

/// `wgcloth run hanging --backend gpu --profile` with `extra` options; its
/// standard output.
fn run_profile(extra: &[&str]) -> String {
    let mut args = vec!["run", "hanging", "--backend", "gpu", "--profile"];
    args.extend(extra);
    let out = wgcloth(&args);
    assert_status(&out, 0);
    stdout(&out)
}

#[test]
fn the_cli_profile_lists_every_kernel_of_the_step_plan() {
    for integrator in Integrator::ALL {
        let spelled = match integrator {
            Integrator::Explicit => "explicit",
            Integrator::Implicit => "implicit",
            Integrator::SemiImplicit => "semi-implicit",
        };
        let text = run_profile(&["--steps", "4", "--integrator", spelled]);
        let (model, params) = scene("hanging", integrator);
        let expected: Vec<String> = plan_kernels(&solver(&model, &params))
            .iter()
            .map(|(k, _)| k.name().to_owned())
            .collect();
        assert_eq!(table_kernels(&text), expected, "{spelled}:\n{text}");
    }
}

#[test]
fn without_timestamps_the_profile_says_so_and_still_counts_bytes() {
    let text = run_profile(&["--profile-timestamps", "none", "--steps", "2"]);
    assert!(text.contains("no timestamp queries"), "{text}");
    let total = text.lines().find(|l| l.starts_with("total "));
    let total: Vec<&str> = total
        .unwrap_or_else(|| panic!("no total row in\n{text}"))
        .split_whitespace()
        .collect();
    // total, dispatches, time, share, read, written, bandwidth.
    assert_eq!(total[2], "—", "an invented time: {text}");
    assert_ne!(total[4], "0", "no bytes read: {text}");
}

/// `--profile`'s `recording (CPU)   X µs/step over N dispatches (Y µs
/// each)` line as (X, N, Y).
fn recording_line(out: &str) -> (f64, f64, f64) {
    let line = out.lines().find(|l| l.starts_with("recording (CPU) "));
    let line = line.unwrap_or_else(|| panic!("no recording line in\n{out}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let number = |at: usize, what: &str| -> f64 {
        let word = words.get(at).map(|w| w.trim_start_matches('('));
        match word.map(str::parse::<f64>) {
            Some(Ok(x)) => x,
            _ => panic!("no {what} in the recording line {line:?}"),
        }
    };
    let noun = words.get(6).copied();
    assert!(matches!(noun, Some("dispatch" | "dispatches")), "{line:?}");
    assert_eq!(
        (words.get(3), words.get(4), words.get(8)),
        (Some(&"µs/step"), Some(&"over"), Some(&"µs")),
        "{line:?}"
    );
    (
        number(2, "µs per step"),
        number(5, "dispatches"),
        number(7, "µs per dispatch"),
    )
}

/// How far the printed µs per dispatch may be from the printed µs per
/// step over the printed dispatches: half a unit of the last printed digit
/// of each (two decimals per step, divided by the dispatches; three per
/// dispatch).
fn printed_rounding(dispatches: f64) -> f64 {
    0.005 / dispatches + 0.0005
}

#[test]
fn the_cli_profile_reports_the_host_time_to_record_a_step() {
    // Explicit, an even number of steps: every recorded step has the
    // table's dispatches (no CG budget to adapt, no seed dispatch).
    for timing in ["inside-passes", "none"] {
        let text = run_profile(&[
            "--integrator",
            "explicit",
            "--steps",
            "4",
            "--profile-timestamps",
            timing,
        ]);
        let (per_step, dispatches, each) = recording_line(&text);
        assert!(
            per_step.is_finite() && per_step > 0.0,
            "{timing}: {per_step} µs per step:\n{text}"
        );
        let total = text.lines().find(|l| l.starts_with("total "));
        let total = total.unwrap_or_else(|| panic!("no total row in\n{text}"));
        let table: Option<f64> = total.split_whitespace().nth(1).and_then(|w| w.parse().ok());
        assert_eq!(Some(dispatches), table, "{timing}: dispatches:\n{text}");
        assert!(
            (each - per_step / dispatches).abs() <= printed_rounding(dispatches),
            "{timing}: {each} µs each is not {per_step} µs over {dispatches}:\n{text}"
        );
    }
}

#[test]
fn a_profile_has_the_recording_cost_of_its_steps_and_none_before() {
    // Explicit with fix-up passes on the multi-dispatch path, in even
    // batches: every submit records the step plan's dispatches per step
    // (no CG budget to adapt, no seed dispatch).
    let (model, params) = scene("hanging", Integrator::Explicit);
    for timing in [Timestamps::None, best()] {
        let mut g = multi_dispatch(&model, &params);
        let mut profiler = Profiler::new(timing);
        assert_eq!(g.profile(&profiler).recording, None, "{timing:?}");
        for n in [2, 4, 6] {
            g.step_profiled(n, &mut profiler).expect("profiled steps");
        }
        let cost = g.profile(&profiler).recording;
        let cost = cost.unwrap_or_else(|| panic!("{timing:?}: no recording cost"));
        assert!(
            cost.micros_per_step.is_finite() && cost.micros_per_step > 0.0,
            "{timing:?}: {cost:?}"
        );
        let planned = g.tuning().step_plan().len() as f64;
        assert!(planned > 1.0, "{timing:?}: {planned} dispatches per step");
        assert_eq!(cost.dispatches_per_step, planned, "{timing:?}");
        assert_eq!(
            cost.micros_per_dispatch(),
            Some(cost.micros_per_step / planned),
            "{timing:?}"
        );
        // Timing the recording records no step of its own.
        assert_eq!(g.steps_recorded(), 12, "{timing:?}");
    }
}

#[test]
fn profile_is_refused_on_the_cpu_backend() {
    let out = wgcloth(&["run", "hanging", "--profile", "--steps", "1"]);
    assert_status(&out, cli_common::EXIT_INVALID);
    assert!(cli_common::stderr(&out).contains("--profile"));
}

#[test]
fn a_timing_the_device_was_not_opened_for_is_refused() {
    // Opened without the timestamp features.
    let ctx = GpuContext::new(None).unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    assert_eq!(Timestamps::best(ctx.device.features()), Timestamps::None);
    let (model, params) = scene("hanging", Integrator::Explicit);
    let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params).expect("GPU solver");
    let mut profiler = Profiler::new(Timestamps::PassBoundaries);
    match g.step_profiled(1, &mut profiler) {
        Err(wgcloth::Error::InvalidParameter { key, .. }) => {
            assert_eq!(key, "profiler timestamps")
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert_eq!(g.steps_recorded(), 0, "a refused step ran");
}
