//! Guards the measured accuracy and stability of the integrators
//! (`docs/integrators.md`) against regressions: a small
//! version of `wgcloth bench accuracy` and `wgcloth bench stability`, on
//! the CPU; and on the GPU, that a sweep's runs batched give what they
//! give alone.
//!
//! Each bound is a value measured on the commit that introduced this test,
//! times a safety factor; the measured value is in the comment. A change
//! that makes an integrator less accurate, or unstable where it was stable,
//! fails here; a change that makes it better should lower the bound.

use wgcloth::evidence::{self, AccuracyOptions, Backend, StabilityOptions};
use wgcloth::{Integrator, Scene};

/// Room for harmless changes (summation order, a CG iteration more or
/// less) without hiding a real loss of accuracy: errors here scale like
/// `dt`, so halving the accuracy is the smallest regression that matters.
const SAFETY_FACTOR: f64 = 1.5;

/// RMS position error [m] of the explicit integrator (no fix-up), 9 × 9
/// `hanging`, dt = 4 ms, 3 samples 80 ms apart, against the dt / 16
/// reference. Measured: 2.959e-3 m.
const EXPLICIT_RMS_MEASURED: f64 = 2.959e-3;
/// Same for the implicit integrator at CG tolerance 1e-4. Measured:
/// 2.993e-3 m.
const IMPLICIT_RMS_MEASURED: f64 = 2.993e-3;
/// Same for the semi-implicit integrator (no fix-up), with its per-spring
/// torque compensation. Measured: 3.357e-3 m.
const SEMI_IMPLICIT_RMS_MEASURED: f64 = 3.357e-3;

/// How far below the smallest measured error the reference's own change
/// (run again at half its step) must stay: 4× keeps the reference's error
/// out of the first digit of every bound above. Measured: 3.8e-5 m against
/// 2.96e-3 m (78×).
const REFERENCE_MARGIN: f64 = 4.0;

/// Time steps of the accuracy check, in steps of the scene's 1 ms.
const DT_MULTIPLE: u32 = 4;

fn accuracy_options() -> AccuracyOptions {
    AccuracyOptions {
        resolution: Some(9),
        sample_every: 80,
        samples: 3,
        dt_multiples: vec![DT_MULTIPLE],
        reference_divisor: 16,
        fixup_iterations: vec![0],
        cg_tolerances: vec![1e-4],
        integrators: Integrator::ALL.to_vec(),
        backends: vec![Backend::CpuF64],
    }
}

#[test]
fn each_integrator_stays_within_its_recorded_error() {
    let scene = Scene::builtin("hanging").expect("built-in scene");
    let report = evidence::accuracy(&scene, &accuracy_options(), None).expect("accuracy");
    for (integrator, measured) in [
        (Integrator::Explicit, EXPLICIT_RMS_MEASURED),
        (Integrator::Implicit, IMPLICIT_RMS_MEASURED),
        (Integrator::SemiImplicit, SEMI_IMPLICIT_RMS_MEASURED),
    ] {
        let row = report
            .rows
            .iter()
            .find(|r| r.integrator == integrator)
            .expect("one row per integrator");
        eprintln!(
            "{integrator}: rms {:e} m, max {:e} m",
            row.rms_error, row.max_error
        );
        assert!(row.stable, "{integrator} blew up at dt = {} s", row.dt);
        let bound = measured * SAFETY_FACTOR;
        assert!(
            row.rms_error <= bound,
            "{integrator}: RMS error {:e} m > bound {bound:e} m (max error {:e} m)",
            row.rms_error,
            row.max_error
        );
    }
    // The reference must be far more accurate than what it judges.
    eprintln!(
        "reference change {:e} m, smallest error {:e} m",
        report.worst_reference_change(),
        report.smallest_error()
    );
    assert!(
        report.worst_reference_change() < report.smallest_error() / REFERENCE_MARGIN,
        "reference not converged: {:e} m vs smallest error {:e} m",
        report.worst_reference_change(),
        report.smallest_error()
    );
}

/// (stretch stiffness [N/m], dt [s]) points each integrator must stay
/// stable at (9 × 9 cloth of 0.2 kg, 0.5 s or 500 steps), from
/// `wgcloth bench stability --quick`: for the explicit integrator its
/// largest stable dt at each stiffness it survives; for the other two, the
/// sweep's corners they were stable at (every cell from 10² N/m up was).
const STABLE_POINTS: [(Integrator, &[(f64, f64)]); 3] = [
    (
        Integrator::Explicit,
        &[
            (1e1, 1.0 / 30.0),
            (1e2, 3.2e-3),
            (1e3, 1e-3),
            (1e4, 3.2e-4),
            (1e5, 1e-4),
        ],
    ),
    (
        Integrator::Implicit,
        &[
            (1e2, 1.0 / 30.0),
            (1e5, 1.0 / 30.0),
            (1e7, 1.0 / 30.0),
            (1e7, 1e-3),
        ],
    ),
    (
        Integrator::SemiImplicit,
        &[
            (1e1, 1.0 / 30.0),
            (1e5, 1.0 / 30.0),
            (1e7, 1.0 / 30.0),
            (1e7, 1e-3),
        ],
    ),
];

#[test]
fn each_integrator_is_stable_where_it_was() {
    for (integrator, points) in STABLE_POINTS {
        for &(k, dt) in points {
            let options = StabilityOptions {
                stiffnesses: vec![k],
                dts: vec![dt],
                integrators: vec![integrator],
                ..StabilityOptions::quick()
            };
            let report = evidence::stability(&options).expect("sweep");
            let cell = report.cells[0];
            assert!(
                cell.verdict.is_stable(),
                "{integrator} at k = {k} N/m, dt = {dt} s: {}",
                cell.verdict.reason()
            );
        }
    }
}

/// A small sweep on the GPU: its runs stepped together as batches give
/// the verdicts and errors they give alone.
mod gpu_batches {
    use wgcloth::evidence::{
        self, AccuracyOptions, Backend, GpuGrouping, GpuHandles, StabilityOptions,
    };
    use wgcloth::gpu::GpuContext;
    use wgcloth::{Integrator, Scene};

    fn gpu() -> GpuContext {
        GpuContext::new(None).unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
    }

    #[test]
    fn a_batched_stability_map_is_the_map_run_alone() {
        let ctx = gpu();
        let handles = GpuHandles {
            device: &ctx.device,
            queue: &ctx.queue,
        };
        // Stiff and large steps blow up, soft and small ones do not: both
        // outcomes inside one batch.
        let options = StabilityOptions {
            resolution: 5,
            stiffnesses: vec![1e2, 1e6],
            dts: vec![1e-3, 1e-2],
            duration: 0.1,
            max_steps: 60,
            ..StabilityOptions::quick()
        };
        let batched = evidence::stability_gpu(&options, handles, GpuGrouping::Batches)
            .expect("batched sweep");
        let alone =
            evidence::stability_gpu(&options, handles, GpuGrouping::Alone).expect("lone sweep");
        assert_eq!(batched.cells, alone.cells);
        let stable = batched
            .cells
            .iter()
            .filter(|c| c.verdict.is_stable())
            .count();
        assert!(
            stable > 0 && stable < batched.cells.len(),
            "the sweep should hold stable and unstable runs: {:?}",
            batched.cells
        );
    }

    #[test]
    fn batched_accuracy_rows_are_the_rows_run_alone() {
        let ctx = gpu();
        let handles = GpuHandles {
            device: &ctx.device,
            queue: &ctx.queue,
        };
        let scene = Scene::builtin("hanging").expect("built-in scene");
        let options = AccuracyOptions {
            resolution: Some(5),
            sample_every: 8,
            samples: 2,
            dt_multiples: vec![1, 8],
            reference_divisor: 4,
            fixup_iterations: vec![10],
            cg_tolerances: vec![1e-4],
            integrators: Integrator::ALL.to_vec(),
            backends: vec![Backend::Gpu],
        };
        let run =
            |g| evidence::accuracy_with(&scene, &options, Some(handles), g).expect("accuracy");
        let (batched, alone) = (run(GpuGrouping::Batches), run(GpuGrouping::Alone));
        assert_eq!(batched.rows.len(), alone.rows.len());
        assert!(!batched.rows.is_empty());
        for (b, a) in batched.rows.iter().zip(&alone.rows) {
            let key = |r: &evidence::AccuracyRow| {
                (r.integrator, r.dt.to_bits(), r.fixup_iterations, r.stable)
            };
            assert_eq!(key(b), key(a));
            assert_eq!(
                (b.rms_error.to_bits(), b.max_error.to_bits()),
                (a.rms_error.to_bits(), a.max_error.to_bits()),
                "{b:?} batched, {a:?} alone"
            );
        }
    }
}
