//! `wgcloth bench accuracy`, `stability` and `cantilever`: run the
//! measurements of [`wgcloth::evidence`], write a CSV and an SVG chart, and
//! print a short table.

use std::fmt::Write as _;
use std::fs;
use std::io::Write as _;
use std::path::Path;

use anyhow::Context as _;
use wgcloth::atomic_file::{commit_all, AtomicFile};
use wgcloth::evidence::{
    self, cantilever::BendingModel, AccuracyOptions, AccuracyReport, CantileverOptions,
    CantileverReport, GpuGrouping, GpuHandles, StabilityOptions, StabilityReport,
};
use wgcloth::gpu::GpuContext;
use wgcloth::Scene;

use super::{
    chart, BenchAccuracyArgs, BenchCantileverArgs, BenchDrapeArgs, BenchOverhangArgs,
    BenchStabilityArgs, UsageError,
};

/// Stiffness range [N/m] the article reached with its semi-implicit
/// integrator (see `docs/integrators.md`): 10⁵.
const ARTICLE_STIFFNESS: f64 = 1e5;
/// Stiffness range Desbrun et al. claimed: 10⁶.
const DESBRUN_STIFFNESS: f64 = 1e6;

/// Refuses an `--out` that cannot be a folder: the path itself, or the
/// nearest of its ancestors that exists, is something other than a folder
/// (a file, a FIFO…). Checked before a sweep runs, so that minutes of
/// measuring are not lost to the destination.
fn check_out_dir(dir: &Path) -> Result<(), UsageError> {
    let Some((existing, meta)) = dir
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find_map(|a| fs::metadata(a).ok().map(|m| (a, m)))
    else {
        return Ok(());
    };
    if meta.is_dir() {
        return Ok(());
    }
    let what = if existing == dir {
        "is".to_string()
    } else {
        format!("is inside {}, which is", existing.display())
    };
    Err(UsageError(format!(
        "--out {}: {what} a file, not a folder; --out names the folder the CSV and SVG \
         are written into (created if missing): choose a folder",
        dir.display()
    )))
}

/// Writes each `(name, text)` into `dir` (created if missing), all or
/// none ([`commit_all`]), then says which files were written.
fn write_files(dir: &Path, files: &[(&str, String)]) -> anyhow::Result<()> {
    check_out_dir(dir)?;
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut outputs = Vec::new();
    for (name, text) in files {
        outputs.push((Some(AtomicFile::create(&dir.join(name))?), text.as_str()));
    }
    write_outputs(outputs)
}

/// Writes each text into its file, where one was asked for, all or none
/// ([`commit_all`]), then says which files were written.
fn write_outputs<'a>(
    outputs: impl IntoIterator<Item = (Option<AtomicFile>, &'a str)>,
) -> anyhow::Result<()> {
    let mut written = Vec::new();
    for (file, text) in outputs {
        if let Some(mut f) = file {
            f.write_with(|out| out.write_all(text.as_bytes()))?;
            written.push(f);
        }
    }
    let paths: Vec<String> = written
        .iter()
        .map(|f| f.path().display().to_string())
        .collect();
    commit_all(written)?;
    say_written(&paths)
}

/// `wrote PATH`, a line each.
fn say_written(paths: &[String]) -> anyhow::Result<()> {
    for p in paths {
        outln!("wrote {p}")?;
    }
    Ok(())
}

/// `wgcloth bench accuracy`.
pub fn accuracy(args: &BenchAccuracyArgs) -> anyhow::Result<()> {
    let scene = Scene::resolve(&args.scene)?;
    check_out_dir(&args.out)?;
    let options = if args.quick {
        AccuracyOptions::quick()
    } else {
        AccuracyOptions::default()
    };
    // No adapter is not an error here: the GPU rows are left out, and said so.
    let context = if args.no_gpu {
        None
    } else {
        match GpuContext::new(args.adapter.as_deref()) {
            Ok(c) => Some(c),
            Err(e) => {
                note!("note: no GPU rows ({e})");
                None
            }
        }
    };
    let gpu = context.as_ref().map(|c| GpuHandles {
        device: &c.device,
        queue: &c.queue,
    });
    if let Some(c) = &context {
        outln!("GPU adapter: {}", c.adapter.get_info().name)?;
    }
    let report = evidence::accuracy(&scene, &options, gpu)?;
    write_files(
        &args.out,
        &[
            ("accuracy.csv", accuracy_csv(&report)),
            ("accuracy.svg", chart::accuracy_svg(&report)),
        ],
    )?;
    out!("{}", accuracy_table(&report))
}

/// The accuracy CSV: `#` comment lines, then
/// `integrator,backend,dt,fixup_iterations,cg_tolerance,stable,wall_per_sim_second,rms_error,max_error,pareto`.
pub fn accuracy_csv(r: &AccuracyReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# scene {}, {} particles, reference: CPU f64 explicit at dt_ref = {} s",
        r.scene, r.particles, r.reference_dt
    );
    let times: Vec<String> = r.sample_times.iter().map(|t| format!("{t}")).collect();
    let _ = writeln!(s, "# sample times [s]: {}", times.join(" "));
    for (fix, change) in &r.reference_change {
        let _ = writeln!(s, "# reference convergence (fix-up {fix}): max |x(dt_ref) - x(dt_ref/2)| = {change:.3e} m, smallest RMS error against it {:.3e} m", r.smallest_error_with_fixup(*fix));
    }
    let _ = writeln!(
        s,
        "# smallest RMS error measured: {:.3e} m",
        r.smallest_error()
    );
    let _ = writeln!(s, "integrator,backend,dt,fixup_iterations,cg_tolerance,stable,wall_per_sim_second,rms_error,max_error,pareto");
    let front = r.pareto_front();
    for (i, row) in r.rows.iter().enumerate() {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            row.integrator,
            row.backend.as_str(),
            row.dt,
            row.fixup_iterations,
            row.cg_tolerance.map(|t| t.to_string()).unwrap_or_default(),
            row.stable,
            row.wall_per_sim_second,
            row.rms_error,
            row.max_error,
            front.contains(&i)
        );
    }
    s
}

fn accuracy_table(r: &AccuracyReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "reference: dt_ref = {:.3e} s, converged to {:.2e} m (smallest RMS error measured {:.2e} m)",
        r.reference_dt,
        r.worst_reference_change(),
        r.smallest_error()
    );
    let _ = writeln!(
        s,
        "{:<14} {:<8} {:>8} {:>5} {:>7} {:>12} {:>10} {:>10}",
        "integrator", "backend", "dt [s]", "fixup", "cg tol", "wall [s/s]", "rms [m]", "max [m]"
    );
    let front = r.pareto_front();
    for (i, row) in r.rows.iter().enumerate() {
        let tol = row
            .cg_tolerance
            .map(|t| format!("{t:.0e}"))
            .unwrap_or_default();
        let _ = write!(
            s,
            "{:<14} {:<8} {:>8.4} {:>5} {:>7}",
            row.integrator.as_str(),
            row.backend.as_str(),
            row.dt,
            row.fixup_iterations,
            tol
        );
        let _ = if row.stable {
            writeln!(
                s,
                " {:>12.3e} {:>10.2e} {:>10.2e}{}",
                row.wall_per_sim_second,
                row.rms_error,
                row.max_error,
                if front.contains(&i) { "  pareto" } else { "" }
            )
        } else {
            writeln!(s, "  unstable")
        };
    }
    s
}

/// `wgcloth bench stability`.
pub fn stability(args: &BenchStabilityArgs) -> anyhow::Result<()> {
    check_out_dir(&args.out)?;
    let options = if args.quick {
        StabilityOptions::quick()
    } else {
        StabilityOptions::default()
    };
    let report = match args.backend {
        super::Backend::Cpu => {
            if args.adapter.is_some() {
                return Err(super::UsageError(
                    "--adapter only applies to --backend gpu".to_string(),
                )
                .into());
            }
            evidence::stability(&options)?
        }
        super::Backend::Gpu => {
            let context = GpuContext::new(args.adapter.as_deref())?;
            outln!("GPU adapter: {}", context.describe())?;
            let gpu = GpuHandles {
                device: &context.device,
                queue: &context.queue,
            };
            evidence::stability_gpu(&options, gpu, GpuGrouping::Batches)?
        }
    };
    write_files(
        &args.out,
        &[
            ("stability.csv", stability_csv(&report)),
            ("stability.svg", chart::stability_svg(&report)),
        ],
    )?;
    out!("{}", stability_table(&report))
}

/// The stability CSV: `#` comment lines, then
/// `integrator,stiffness,dt,simulated,stable,reason`.
pub fn stability_csv(r: &StabilityReport) -> String {
    let o = &r.options;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {0} x {0} cloth, {1} kg/m^2, shear = stretch x {2}, bend = stretch x {3}, up to {4} s or {5} steps",
        o.resolution,
        o.areal_mass,
        evidence::stability::SHEAR_RATIO,
        evidence::stability::BEND_RATIO,
        o.duration,
        o.max_steps
    );
    let _ = writeln!(s, "integrator,stiffness,dt,simulated,stable,reason");
    for c in &r.cells {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{}",
            c.integrator,
            c.stiffness,
            c.dt,
            c.simulated,
            c.verdict.is_stable(),
            c.verdict.reason()
        );
    }
    s
}

fn stability_table(r: &StabilityReport) -> String {
    let o = &r.options;
    let mut s = String::from("largest stable dt [s] (every smaller swept dt stable too)\n");
    let _ = write!(s, "{:>12}", "k [N/m]");
    for i in &o.integrators {
        let _ = write!(s, " {:>14}", i.as_str());
    }
    s.push('\n');
    for &k in &o.stiffnesses {
        let _ = write!(s, "{k:>12.0e}");
        for &i in &o.integrators {
            let cell = r
                .largest_stable_dt(i, k)
                .map(|dt| format!("{dt:.1e}"))
                .unwrap_or_else(|| "none".into());
            let _ = write!(s, " {cell:>14}");
        }
        s.push('\n');
    }
    for &i in &o.integrators {
        let stable: Vec<f64> = o
            .stiffnesses
            .iter()
            .copied()
            .filter(|&k| r.largest_stable_dt(i, k).is_some())
            .collect();
        let range = match (stable.first(), stable.last()) {
            (Some(lo), Some(hi)) => hi / lo,
            _ => 0.0,
        };
        let _ = writeln!(
            s,
            "{i}: stable at some swept dt over a stiffness range of {range:.0e} \
             (the article reached {ARTICLE_STIFFNESS:.0e}, Desbrun claimed {DESBRUN_STIFFNESS:.0e})"
        );
    }
    s
}

/// `wgcloth bench cantilever`.
pub fn cantilever(args: &BenchCantileverArgs) -> anyhow::Result<()> {
    let options = if args.quick {
        CantileverOptions::quick()
    } else {
        CantileverOptions::default()
    };
    let (csv, svg) = csv_and_chart(args.csv.as_deref(), args.chart.as_deref())?;
    let report = evidence::cantilever(&options)?;
    write_outputs([
        (csv, cantilever_csv(&report).as_str()),
        (svg, chart::cantilever_svg(&report).as_str()),
    ])?;
    out!("{}", cantilever_table(&report))
}

/// The `--csv` and `--chart` files, opened before a sweep runs so that
/// minutes of measuring are not lost to a destination; one file for both
/// is refused (the chart would replace the table).
fn csv_and_chart(
    csv: Option<&Path>,
    chart: Option<&Path>,
) -> anyhow::Result<(Option<AtomicFile>, Option<AtomicFile>)> {
    super::output::distinct_outputs(&[("--csv", csv), ("--chart", chart)])?;
    Ok((
        csv.map(AtomicFile::create).transpose()?,
        chart.map(AtomicFile::create).transpose()?,
    ))
}

/// `wgcloth bench drape`.
pub fn drape(args: &BenchDrapeArgs) -> anyhow::Result<()> {
    let (csv, svg) = csv_and_chart(args.csv.as_deref(), args.chart.as_deref())?;
    let rows = evidence::cantilever::drape(&args.sizes).map_err(as_option)?;
    write_outputs([
        (csv, drape_csv(&rows).as_str()),
        (svg, chart::drape_svg(&rows).as_str()),
    ])?;
    out!("{}", drape_table(&rows))
}

/// The name of a plate's discretisation in the table and the CSV.
pub(super) fn plate_mesh_name(mesh: evidence::cantilever::PlateMesh) -> &'static str {
    match mesh {
        evidence::cantilever::PlateMesh::Grid(_) => "grid",
        evidence::cantilever::PlateMesh::Irregular(_) => "irregular",
    }
}

/// Each row with its difference from the previous resolution of its
/// discretisation and the order over the last three.
fn drape_lines(rows: &[evidence::cantilever::DrapeRow]) -> Vec<(usize, Option<f64>, Option<f64>)> {
    (0..rows.len())
        .map(|k| {
            let same = |j: usize| plate_mesh_name(rows[j].mesh) == plate_mesh_name(rows[k].mesh);
            let prev = (k >= 1 && same(k - 1)).then(|| k - 1);
            let difference = prev.map(|j| rows[k].drop - rows[j].drop);
            let order = match prev {
                Some(j) if j >= 1 && same(j - 1) => {
                    evidence::cantilever::drape_order(&rows[j - 1], &rows[j], &rows[k])
                }
                _ => None,
            };
            (k, difference, order)
        })
        .collect()
}

/// `wgcloth bench drape`'s table.
pub fn drape_table(rows: &[evidence::cantilever::DrapeRow]) -> String {
    let mut s = format!(
        "clamped plate (Γ = {} over the overhang), free edge's drop over the overhang at rest\n\
         {:<10} {:>5} {:>10} {:>10} {:>11} {:>6}\n",
        evidence::cantilever::PLATE_GAMMA,
        "mesh",
        "rows",
        "spacing",
        "drop",
        "difference",
        "order"
    );
    for (k, difference, order) in drape_lines(rows) {
        let r = &rows[k];
        let _ = writeln!(
            s,
            "{:<10} {:>5} {:>10.5} {:>10.6}{} {:>11} {:>6}",
            plate_mesh_name(r.mesh),
            r.rows,
            r.spacing,
            r.drop,
            if r.converged { " " } else { "*" },
            difference.map_or("-".into(), |d| format!("{d:+.6}")),
            order.map_or("-".into(), |o| format!("{o:.2}"))
        );
    }
    if rows.iter().any(|r| !r.converged) {
        s.push_str("* the equilibrium did not converge\n");
    }
    s
}

/// `wgcloth bench drape`'s CSV.
pub fn drape_csv(rows: &[evidence::cantilever::DrapeRow]) -> String {
    let mut s = String::from("mesh,rows,spacing_m,drop_over_overhang,converged,difference,order\n");
    for (k, difference, order) in drape_lines(rows) {
        let r = &rows[k];
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            plate_mesh_name(r.mesh),
            r.rows,
            r.spacing,
            r.drop,
            r.converged,
            difference.map_or(String::new(), |d| d.to_string()),
            order.map_or(String::new(), |o| o.to_string())
        );
    }
    s
}

/// A refusal of [`evidence::cantilever::overhang`]'s or `drape`'s
/// arguments under the option that gave it (`density` as `--density`);
/// any other error as it is.
fn as_option(e: wgcloth::Error) -> wgcloth::Error {
    match e {
        wgcloth::Error::InvalidParameter { key, allowed, got }
            if ["density", "bending", "segments", "sizes"].contains(&key.as_str()) =>
        {
            wgcloth::Error::InvalidParameter {
                key: format!("--{key}"),
                allowed,
                got,
            }
        }
        e => e,
    }
}

/// `wgcloth bench overhang`.
pub fn overhang(args: &BenchOverhangArgs) -> anyhow::Result<()> {
    let o = evidence::cantilever::overhang(args.density, args.bending, args.segments)
        .map_err(as_option)?;
    out!(
        "material: density {} kg/m², bending {:e} N·m; strip of {} segments, {} settled strips\n\
         overhang at 41.5°: O = {:.5} m, bending length c = O/2 = {:.5} m (elastica Γ there {:.4}; 8.00 exactly)\n\
         implied rigidity ρ g c³ = {:.6e} N·m, {:+.3} % from the input\n",
        o.density,
        o.bending,
        o.segments,
        o.runs,
        o.length,
        o.bending_length,
        o.gamma,
        o.implied,
        100.0 * o.deviation
    )
}

/// The cantilever CSV: `#` comment lines, then
/// `segments,integrator,gamma,bend_stiffness,reference,simulated,deviation,steps,settled,model,h_over_w,reference_h_over_w`.
pub fn cantilever_csv(r: &CantileverReport) -> String {
    use evidence::cantilever::{
        CALIBRATION_GAMMA, LENGTH, LINE_MASS, MATERIAL_DENSITY, MATERIAL_ROWS, ROWS,
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# chord: strips of {ROWS} rows, {LENGTH} m free length, {LINE_MASS} kg/m per row, implicit settling; tip drop over length; bend_stiffness in N/m"
    );
    let _ = writeln!(
        s,
        "# material: strips of {MATERIAL_ROWS} rows of square cells, {MATERIAL_DENSITY} kg/m², linear bending B = rho g L^3 / Gamma (bend_stiffness, N m); h_over_w = tip drop / tip reach"
    );
    for segments in material_resolutions(r) {
        let _ = writeln!(
            s,
            "# material, {segments} segments: largest |H/W deviation| {:.5}",
            r.worst_material_deviation(segments)
        );
    }
    for (segments, k) in &r.calibrations {
        let _ = writeln!(
            s,
            "# {segments} segments: B calibrated at Gamma = {CALIBRATION_GAMMA} with bend stiffness {k:.6e} N/m; largest |deviation| {:.3}",
            r.worst_deviation(*segments)
        );
    }
    let _ = writeln!(
        s,
        "segments,integrator,gamma,bend_stiffness,reference,simulated,deviation,steps,settled,model,h_over_w,reference_h_over_w"
    );
    for row in &r.rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            row.segments,
            row.integrator,
            row.gamma,
            row.bend_stiffness,
            row.reference,
            row.simulated,
            row.deviation,
            row.steps,
            row.settled,
            row.model.as_str(),
            row.h_over_w(),
            row.reference_h_over_w()
        );
    }
    s
}

/// The material strips' resolutions in the report, in order.
fn material_resolutions(r: &CantileverReport) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for row in r.rows.iter().filter(|r| r.model == BendingModel::Material) {
        if !out.contains(&row.segments) {
            out.push(row.segments);
        }
    }
    out
}

fn cantilever_table(r: &CantileverReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<9} {:>8} {:<14} {:>9} {:>11} {:>11} {:>10} {:>10} {:>10} {:>10}",
        "model",
        "segments",
        "integrator",
        "Γ",
        "elastica",
        "simulated",
        "deviation",
        "H/W ref",
        "H/W",
        "deviation"
    );
    for row in &r.rows {
        let _ = writeln!(
            s,
            "{:<9} {:>8} {:<14} {:>9.3e} {:>11.4e} {:>11.4e} {:>+9.2}% {:>10.4} {:>10.4} {:>+9.2}%{}",
            row.model.as_str(),
            row.segments,
            row.integrator.as_str(),
            row.gamma,
            row.reference,
            row.simulated,
            100.0 * row.deviation,
            row.reference_h_over_w(),
            row.h_over_w(),
            100.0 * row.h_over_w_deviation(),
            if row.settled { "" } else { "  not settled" }
        );
    }
    for (segments, _) in &r.calibrations {
        let _ = writeln!(
            s,
            "chord, {segments} segments: largest relative deviation {:.1} %",
            100.0 * r.worst_deviation(*segments)
        );
    }
    for segments in material_resolutions(r) {
        let _ = writeln!(
            s,
            "material, {segments} segments: largest relative deviation of H/W {:.2} %",
            100.0 * r.worst_material_deviation(segments)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgcloth::Integrator;

    #[test]
    fn csv_has_header_and_one_row_per_cell() {
        let options = StabilityOptions {
            resolution: 3,
            stiffnesses: vec![10.0],
            dts: vec![1e-2],
            duration: 0.05,
            integrators: vec![Integrator::Explicit],
            ..StabilityOptions::default()
        };
        let report = evidence::stability(&options).expect("sweep");
        let csv = stability_csv(&report);
        assert_eq!(csv.lines().filter(|l| !l.starts_with('#')).count(), 2);
    }
}
