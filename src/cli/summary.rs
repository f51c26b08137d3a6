//! The human-readable block `wgcloth run` prints on stdout after a run.

use std::fmt::{self, Display, Formatter};
use std::time::Duration;

use wgcloth::diagnostics::Energy;
use wgcloth::params::SpringKind;
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
    /// Backend name.
    pub backend: &'static str,
    /// `"f64"` or `"f32"`.
    pub precision: &'static str,
    /// The cloth (particle and spring counts).
    pub model: &'a Model,
    /// Time step [s].
    pub dt: f64,
    /// Wall-clock time of the whole command, set-up and output included.
    pub wall: Duration,
    /// What the run measured.
    pub outcome: Outcome,
}

/// What a finished run measured.
pub struct Outcome {
    /// Steps taken.
    pub steps: u64,
    /// Simulated time [s].
    pub time: f64,
    /// Wall-clock time spent inside the solver's `step` only.
    pub stepping: Duration,
    /// Largest stretch-spring strain `(l − L) / L` at the end; `−∞` when
    /// there are no stretch springs.
    pub max_strain: f64,
    /// Energy at the end [J].
    pub energy: Energy,
    /// Conjugate-gradient statistics (implicit only).
    pub cg: Option<CgSummary>,
    /// Fix-up statistics (explicit and semi-implicit).
    pub fixup: Option<FixupSummary>,
    /// `"dense"` / `"banded"` (semi-implicit only).
    pub filter: Option<&'static str>,
}

/// CG iterations over a run.
pub struct CgSummary {
    /// Mean iterations per step (`None` for a run of zero steps).
    pub mean: Option<f64>,
    /// Most iterations in one step.
    pub max: u32,
    /// The iteration cap (`[implicit] max_iterations`).
    pub cap: u32,
    /// Steps that stopped at the cap instead of the tolerance.
    pub capped_steps: u64,
    /// Largest final relative residual of any step.
    pub max_residual: f64,
    /// The relative tolerance (`[implicit] tolerance`).
    pub tolerance: f64,
}

/// Fix-up passes that moved something, over a run.
pub struct FixupSummary {
    /// Mean passes per step (`None` for a run of zero steps).
    pub mean: Option<f64>,
    /// Most passes in one step.
    pub max: u32,
}

impl Display for Summary<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let o = &self.outcome;
        let m = self.model;
        let row = |f: &mut Formatter<'_>, label: &str, value: &dyn Display| {
            writeln!(f, "{label:<LABEL_WIDTH$}{value}")
        };
        row(f, "scene", &self.scene)?;
        row(f, "integrator", &self.integrator)?;
        row(
            f,
            "backend",
            &format!("{} ({})", self.backend, self.precision),
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
        row(f, "steps", &format!("{} (dt = {} s)", o.steps, self.dt))?;
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
        let rate = if rate.is_finite() {
            format!("{rate:.0} (stepping only)")
        } else {
            "n/a".to_string()
        };
        row(f, "steps per second", &rate)?;
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
        if let Some(cg) = &o.cg {
            row(
                f,
                "CG iterations",
                &format!(
                    "mean {}, max {} per step (cap {}, reached in {} steps)",
                    mean(cg.mean),
                    cg.max,
                    cg.cap,
                    cg.capped_steps
                ),
            )?;
            row(
                f,
                "CG residual",
                &format!(
                    "max {:.3e} (relative; tolerance {:e})",
                    cg.max_residual, cg.tolerance
                ),
            )?;
        }
        if let Some(filter) = o.filter {
            row(f, "filter", &filter)?;
        }
        if let Some(fixup) = &o.fixup {
            row(
                f,
                "fix-up passes",
                &format!("mean {}, max {} per step", mean(fixup.mean), fixup.max),
            )?;
        }
        Ok(())
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
    use super::sig;

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
