//! The human-readable block `wgcloth run` prints on stdout after a run.

use std::fmt::{self, Display, Formatter};
use std::time::Duration;

use wgcloth::diagnostics::Energy;
use wgcloth::params::{format_number, SpringKind};
use wgcloth::{Integrator, Model};

/// Width of the label column.
const LABEL_WIDTH: usize = 22;

/// Significant digits of measured quantities (energies, times): more would
/// be noise for a summary; exact values go to the output files.
const DIGITS: usize = 6;

/// Everything the summary shows.
pub struct Summary<'a> {
    /// Scene name.
    pub scene: &'a str,
    /// Integrator that ran.
    pub integrator: Integrator,
    /// The cloth (particle and spring counts).
    pub model: &'a Model,
    /// Time step \[s\].
    pub dt: f64,
    /// Wall-clock time of the whole command, set-up and output included.
    pub wall: Duration,
    /// What the run measured.
    pub outcome: Outcome,
}

/// What a finished run measured.
pub struct Outcome {
    /// The passes of one step (see `Solver::passes`), as last recorded.
    pub passes: Vec<(&'static str, u32, u32)>,
    /// Dispatches per CG iteration, the iterations a step records and the
    /// budget's hits (see
    /// `Solver::cg_recording`).
    pub cg_recording: Option<(u32, u32, u64)>,
    /// How the GPU records a step, and why (see `Solver::step_path`).
    pub step_path: Option<String>,
    /// Each kernel's GPU time and bytes per step (`--profile`).
    pub profile: Option<wgcloth::gpu::Profile>,
    /// Backend name (`"cpu"`, `"gpu"`).
    pub backend: &'static str,
    /// `"f64"` or `"f32"`.
    pub precision: &'static str,
    /// The adapter the GPU backend ran on (`None` on the CPU).
    pub device: Option<String>,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time \[s\].
    pub time: f64,
    /// Wall-clock time spent stepping only: on the GPU, submitting the steps
    /// and waiting for the status read-back after each batch.
    pub stepping: Duration,
    /// Largest stretch-spring strain `(l − L) / L` at the end; `−∞` when
    /// there are no stretch springs.
    pub max_strain: f64,
    /// Energy at the end \[J\].
    pub energy: Energy,
    /// What the solver counted.
    pub stats: SolverStats,
    /// `--batch`: the batch the cloth was stepped in.
    pub batch: Option<BatchSummary>,
}

/// A run of `--batch N` copies of the cloth in one batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchSummary {
    /// Cloths stepped together (the run's own counted).
    pub cloths: u64,
    /// Compute dispatches per step of the whole batch.
    pub dispatches_per_step: f64,
}

/// What a solver counted over a run, per integrator.
pub struct SolverStats {
    /// Conjugate-gradient statistics (implicit only).
    pub cg: Option<CgSummary>,
    /// Fix-up statistics (explicit and semi-implicit).
    pub fixup: Option<FixupSummary>,
    /// `"dense"` / `"banded"` (semi-implicit on the CPU only).
    pub filter: Option<&'static str>,
}

/// CG iterations over a run.
pub struct CgSummary {
    /// Most iterations in one step.
    pub max: u32,
    /// The iteration cap (`[implicit] max_iterations`).
    pub cap: u32,
    /// The relative tolerance (`[implicit] tolerance`).
    pub tolerance: f64,
    /// What else the solver knows.
    pub detail: CgDetail,
}

/// The CG statistics beyond the maximum, which depend on the backend.
pub enum CgDetail {
    /// The CPU sees every step.
    PerStep {
        /// Mean iterations per step (`None` for a run of zero steps).
        mean: Option<f64>,
        /// Steps that stopped at the cap instead of the tolerance.
        capped_steps: u64,
        /// Largest final relative residual of any step.
        max_residual: f64,
    },
    /// The GPU reports the last step's iterations only (`None` for a run of
    /// zero steps).
    Last(Option<u32>),
}

/// The fix-up over a run.
pub enum FixupSummary {
    /// The CPU counts the passes that moved something.
    Counted {
        /// Mean passes per step (`None` for a run of zero steps).
        mean: Option<f64>,
        /// Most passes in one step.
        max: u32,
    },
    /// The GPU always uses Jacobi, whatever the scene's `[fixup] method`,
    /// and stops on the device once a pass moves nothing; it reports the
    /// passes of the last step.
    GpuJacobi {
        /// `[fixup] iterations`: the most passes per step.
        iterations: u32,
        /// Passes run in the last step (`None` before any step).
        last: Option<u32>,
    },
}

impl Display for Summary<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let o = &self.outcome;
        let m = self.model;
        row(f, "scene", &self.scene)?;
        row(f, "integrator", &self.integrator)?;
        let on = o.device.as_ref().map(|d| format!(" on {d}"));
        row(
            f,
            "backend",
            &format!("{} ({}){}", o.backend, o.precision, on.unwrap_or_default()),
        )?;
        row(
            f,
            "particles",
            &format!("{} ({} pinned)", m.particle_count(), m.pinned_count()),
        )?;
        let by_kind = SpringKind::ALL
            .map(|k| format!("{} {}", k.as_str(), m.kind_ranges[k.index()].len()))
            .join(", ");
        row(f, "springs", &format!("{} ({by_kind})", m.springs.len()))?;
        row(
            f,
            "steps",
            &format!("{} (dt = {})", o.steps, time_step(self.dt)),
        )?;
        row(f, "simulated time", &format!("{} s", sig(o.time)))?;
        row(
            f,
            "wall time",
            &format!(
                "{:.3} s ({:.3} s stepping)",
                self.wall.as_secs_f64(),
                o.stepping.as_secs_f64()
            ),
        )?;
        let rate = o.steps as f64 / o.stepping.as_secs_f64();
        let what = match o.device {
            Some(_) => "stepping and status read-backs only",
            None => "stepping only",
        };
        let rate = if rate.is_finite() {
            format!("{rate:.0} ({what})")
        } else {
            "n/a".to_string()
        };
        row(f, "steps per second", &rate)?;
        if let Some(b) = &o.batch {
            let rate = (b.cloths * o.steps) as f64 / o.stepping.as_secs_f64();
            let rate = if rate.is_finite() {
                format!("{rate:.0} cloth-steps per second ({what})")
            } else {
                "n/a".to_string()
            };
            row(
                f,
                "batch",
                &format!(
                    "{} cloth{}, dispatches per step: {}",
                    b.cloths,
                    if b.cloths == 1 { "" } else { "s" },
                    sig_dispatches(b.dispatches_per_step)
                ),
            )?;
            row(f, "batch rate", &rate)?;
        }
        let strain = if o.max_strain.is_finite() {
            format!("{:.3} % (stretch springs)", 100.0 * o.max_strain)
        } else {
            "n/a (no stretch springs)".to_string()
        };
        row(f, "max strain", &strain)?;
        let e = &o.energy;
        for (n, (name, value)) in [
            ("kinetic", e.kinetic),
            ("gravitational", e.gravitational),
            ("elastic", e.elastic),
            ("total", e.total()),
        ]
        .into_iter()
        .enumerate()
        {
            let label = if n == 0 { "energy [J]" } else { "" };
            row(f, label, &format!("{name:<14}{:>14}", sig(value)))?;
        }
        let stats = &o.stats;
        if let Some(cg) = &stats.cg {
            write_cg(f, cg)?;
        }
        if let Some(filter) = stats.filter {
            row(f, "filter", &filter)?;
        }
        match &stats.fixup {
            Some(FixupSummary::Counted { mean: m, max }) => row(
                f,
                "fix-up passes",
                &format!("mean {}, max {max} per step", mean(*m)),
            )?,
            Some(FixupSummary::GpuJacobi { iterations, last }) => row(
                f,
                "fix-up passes",
                &match last {
                    Some(n) => {
                        format!("last {n}, at most {iterations} per step, fix-up jacobi (GPU)")
                    }
                    None => format!("at most {iterations} per step, fix-up jacobi (GPU)"),
                },
            )?,
            None => {}
        }
        Ok(())
    }
}

/// One row of the summary: the label, padded, then the value.
fn row(f: &mut Formatter<'_>, label: &str, value: &dyn Display) -> fmt::Result {
    writeln!(f, "{label:<LABEL_WIDTH$}{value}")
}

/// The CG rows.
fn write_cg(f: &mut Formatter<'_>, cg: &CgSummary) -> fmt::Result {
    let CgSummary {
        max,
        cap,
        tolerance,
        ..
    } = cg;
    match cg.detail {
        CgDetail::PerStep {
            mean: m,
            capped_steps,
            max_residual,
        } => {
            row(
                f,
                "CG iterations",
                &format!(
                    "mean {}, max {max} per step (cap {cap}, reached in {capped_steps} steps)",
                    mean(m)
                ),
            )?;
            row(
                f,
                "CG residual",
                &format!("max {max_residual:.3e} (relative; tolerance {tolerance:e})"),
            )
        }
        CgDetail::Last(last) => row(
            f,
            "CG iterations",
            &format!(
                "last {}, max {max} per step (cap {cap}; tolerance {tolerance:e})",
                last.map_or_else(|| "n/a".to_string(), |n| n.to_string())
            ),
        ),
    }
}

/// A time step as people write it: `1/120 s` for a dt whose reciprocal
/// is a whole number and whose decimals run on (0.008333333333333333),
/// else the number itself (`0.001 s`).
pub(super) fn time_step(dt: f64) -> String {
    let plain = format_number(dt);
    let per = (1.0 / dt).round();
    // Within f64 rounding of 1/N: the scene wrote 1/N as decimals.
    let whole = (per * dt - 1.0).abs() <= 1e-12 && per >= 2.0;
    if plain.len() > 8 && whole {
        format!("1/{per:.0} s")
    } else {
        format!("{plain} s")
    }
}

/// Dispatches per step: whole when they are (every step recorded the
/// same), else with two decimals.
fn sig_dispatches(d: f64) -> String {
    if d.fract() == 0.0 {
        format!("{d:.0}")
    } else {
        format!("{d:.2}")
    }
}

/// A per-step mean, or `n/a` for a run of zero steps.
fn mean(m: Option<f64>) -> String {
    m.map_or_else(|| "n/a".to_string(), |m| format!("{m:.2}"))
}

/// `v` to [`DIGITS`] significant digits: fixed-point for magnitudes from
/// 1e-3 to 1e6, scientific otherwise.
fn sig(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() {
        format!("{v}")
    } else if (1e-3..1e6).contains(&a) {
        let int_digits = a.log10().floor() as i32 + 1;
        let decimals = (DIGITS as i32 - int_digits).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.prec$e}", prec = DIGITS - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgcloth::{ClothSpec, Params};

    #[test]
    fn time_steps_read_as_written() {
        assert_eq!(time_step(0.008333333333333333), "1/120 s");
        assert_eq!(time_step(0.004166666666666667), "1/240 s");
        assert_eq!(time_step(0.001), "0.001 s");
        assert_eq!(time_step(0.005), "0.005 s");
        // Long decimals that are no fraction 1/N stay a number.
        assert_eq!(time_step(0.0123456789), "0.0123456789 s");
    }

    #[test]
    fn gpu_rows_name_the_adapter_and_what_the_device_reports() {
        let params = Params {
            integrator: Integrator::Implicit,
            ..Params::default()
        };
        let model = Model::new(&ClothSpec::default(), &params.springs).expect("valid");
        let summary = Summary {
            scene: "test",
            integrator: params.integrator,
            model: &model,
            dt: params.dt,
            wall: Duration::from_secs(2),
            outcome: Outcome {
                passes: Vec::new(),
                cg_recording: None,
                step_path: None,
                profile: None,
                backend: "gpu",
                precision: "f32",
                device: Some("llvmpipe (Vulkan, Cpu)".into()),
                steps: 100,
                time: 100.0 * params.dt,
                stepping: Duration::from_secs(1),
                max_strain: 0.01,
                energy: Energy::default(),
                stats: SolverStats {
                    cg: Some(CgSummary {
                        max: 40,
                        cap: 200,
                        tolerance: 1e-4,
                        detail: CgDetail::Last(Some(12)),
                    }),
                    fixup: Some(FixupSummary::GpuJacobi {
                        iterations: 10,
                        last: Some(4),
                    }),
                    filter: None,
                },
                batch: None,
            },
        };
        let text = summary.to_string();
        for row in [
            "backend               gpu (f32) on llvmpipe (Vulkan, Cpu)\n",
            "steps per second      100 (stepping and status read-backs only)\n",
            "CG iterations         last 12, max 40 per step (cap 200; tolerance 1e-4)\n",
            "fix-up passes         last 4, at most 10 per step, fix-up jacobi (GPU)\n",
        ] {
            assert!(text.contains(row), "no `{row}` in\n{text}");
        }
        assert!(!text.contains("CG residual"), "{text}");
    }

    #[test]
    fn sig_keeps_six_significant_digits() {
        assert_eq!(sig(4.0), "4.00000");
        assert_eq!(sig(-0.912345678), "-0.912346");
        assert_eq!(sig(123456.7), "123457");
        assert_eq!(sig(0.0012345678), "0.00123457");
        assert_eq!(sig(1.5e-7), "1.50000e-7");
        assert_eq!(sig(0.0), "0");
    }
}
