//! The table `wgcloth run --profile` prints after the summary: per kernel
//! of the step plan, dispatches, median GPU time, share of the step, bytes
//! read and written and the bandwidth achieved, all per step; then the
//! step's totals.

use std::fmt::{self, Display, Formatter};

use wgcloth::gpu::{Profile, Timestamps};

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
        Ok(())
    }
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
