//! The table `wgcloth run --profile` prints after the summary: per kernel
//! of the step plan, dispatches, median GPU time, share of the step, bytes
//! read and written and the bandwidth achieved, all per step; then the
//! step's totals, and the host's time to record a step (which the GPU's
//! timestamps do not see).

use std::fmt::{self, Display, Formatter};

use wgcloth::gpu::{Profile, RecordingCost, Timestamps};

/// Width of the kernel column (the longest kernel name, `semi_cg_prepare`
/// and `implicit_prepare`, fits with room).
const KERNEL_WIDTH: usize = 20;

/// A [`Profile`] as a table.
pub struct Table<'a>(pub &'a Profile);

impl Display for Table<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let p = self.0;
        writeln!(
            f,
            "profile               {} steps; timestamps {}",
            p.steps,
            p.timestamps.describe()
        )?;
        writeln!(
            f,
            "{:<KERNEL_WIDTH$} {:>10} {:>10} {:>7} {:>14} {:>14} {:>8}",
            "kernel", "dispatches", "µs/step", "share", "read B/step", "written B/step", "GB/s"
        )?;
        let total = p.total_micros();
        for r in &p.rows {
            let share = match (r.micros, total) {
                (Some(t), Some(all)) if all > 0.0 => format!("{:.1} %", 100.0 * t / all),
                _ => "—".to_string(),
            };
            row(
                f,
                r.kernel.name(),
                r.dispatches,
                r.micros,
                &share,
                (r.read, r.written),
                r.bandwidth(),
            )?;
        }
        let share = if total.is_some() { "100 %" } else { "—" };
        row(
            f,
            "total",
            p.dispatches(),
            total,
            share,
            p.bytes(),
            p.bandwidth(),
        )?;
        if p.timestamps == Timestamps::None {
            writeln!(
                f,
                "no GPU times: the adapter has no timestamp queries; bytes and dispatches only"
            )?;
        }
        recording(f, p.recording)
    }
}

/// `recording (CPU)   X µs/step over N dispatches (Y µs each)` (`1
/// dispatch` in the singular): the host time to record a step and the
/// dispatches it recorded; `—` before any step.
fn recording(f: &mut Formatter<'_>, cost: Option<RecordingCost>) -> fmt::Result {
    let label = "recording (CPU)";
    let Some(cost) = cost else {
        return writeln!(f, "{label:<21} — (no steps profiled)");
    };
    let d = cost.dispatches_per_step;
    // A whole count as one; an odd batch of single-pass explicit steps
    // records one seed dispatch more, a fraction per step.
    let dispatches = if d == 1.0 {
        "1 dispatch".to_string()
    } else if d.fract() == 0.0 {
        format!("{d:.0} dispatches")
    } else {
        format!("{d:.2} dispatches")
    };
    let each = cost
        .micros_per_dispatch()
        .map_or("—".to_string(), |t| format!("{t:.3}"));
    writeln!(
        f,
        "{label:<21} {:.2} µs/step over {dispatches} ({each} µs each)",
        cost.micros_per_step
    )
}

/// One line of the table; `—` where there is no time.
fn row(
    f: &mut Formatter<'_>,
    name: &str,
    dispatches: u32,
    micros: Option<f64>,
    share: &str,
    (read, written): (u64, u64),
    bandwidth: Option<f64>,
) -> fmt::Result {
    let time = micros.map_or("—".to_string(), |t| format!("{t:.1}"));
    let rate = bandwidth.map_or("—".to_string(), |b| format!("{b:.2}"));
    writeln!(
        f,
        "{name:<KERNEL_WIDTH$} {dispatches:>10} {time:>10} {share:>7} {read:>14} {written:>14} {rate:>8}"
    )
}
