//! The two SVG charts of `wgcloth bench`, written by hand.
//!
//! Why not `plotters`: a log–log scatter and a grid of coloured cells are a
//! few dozen SVG elements; SVG text needs no font (the viewer lays it out),
//! whereas plotters measures text with a font backend, and its lean
//! `svg_backend`-only build would add a dependency tree for what
//! `format!` does here.

use std::fmt::Write as _;

use wgcloth::evidence::cantilever::{BendingModel, DrapeRow};
use wgcloth::evidence::{elastica, AccuracyReport, Backend, CantileverReport, StabilityReport};
use wgcloth::Integrator;

/// Chart size [px].
const WIDTH: f64 = 720.0;
/// Chart size [px].
const HEIGHT: f64 = 480.0;
/// Space for the axes' labels [px].
const MARGIN: f64 = 70.0;

/// A colour per integrator, a marker per backend.
fn colour(i: Integrator) -> &'static str {
    match i {
        Integrator::Explicit => "#1f77b4",
        Integrator::Implicit => "#d62728",
        Integrator::SemiImplicit => "#2ca02c",
    }
}

fn marker(out: &mut String, b: Backend, x: f64, y: f64, fill: &str) {
    // `write!` into a `String` cannot fail.
    let _ = match b {
        Backend::CpuF64 => writeln!(
            out,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" fill="{fill}"/>"#
        ),
        Backend::CpuF32 => writeln!(
            out,
            r#"<rect x="{:.1}" y="{:.1}" width="8" height="8" fill="{fill}"/>"#,
            x - 4.0,
            y - 4.0
        ),
        Backend::Gpu => writeln!(
            out,
            r#"<path d="M{x:.1} {:.1} L{:.1} {:.1} L{:.1} {:.1} Z" fill="{fill}"/>"#,
            y - 5.0,
            x + 5.0,
            y + 4.0,
            x - 5.0,
            y + 4.0
        ),
    };
}

/// Decades `[floor(log10 lo), ceil(log10 hi)]` covering `values`.
fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (0, 1);
    }
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (a, b.max(a + 1))
}

/// The pixel coordinate of a value on a log axis spanning the decades
/// `e0..=e1` from pixel `from` to pixel `to`.
fn log_scale((e0, e1): (i32, i32), from: f64, to: f64) -> impl Fn(f64) -> f64 {
    move |v| from + (v.log10() - f64::from(e0)) / f64::from(e1 - e0) * (to - from)
}

/// Error (RMS, log) against wall time per simulated second (log), one
/// colour per integrator, one marker per backend; the Pareto front joined
/// by a black line.
pub fn accuracy_svg(report: &AccuracyReport) -> String {
    let stable: Vec<_> = report.rows.iter().filter(|r| r.stable).collect();
    let (x0, x1) = decades(stable.iter().map(|r| r.wall_per_sim_second));
    let (y0, y1) = decades(stable.iter().map(|r| r.rms_error));
    let px = log_scale((x0, x1), MARGIN, WIDTH - MARGIN);
    let py = log_scale((y0, y1), HEIGHT - MARGIN, MARGIN);
    let mut s = header(&format!(
        "{}: RMS position error vs cost ({} particles, reference dt = {:.3e} s)",
        report.scene, report.particles, report.reference_dt
    ));
    axes(
        &mut s,
        (x0, x1),
        (y0, y1),
        "wall time per simulated second [s]",
        "RMS error [m]",
    );
    let mut front: Vec<_> = report
        .pareto_front()
        .into_iter()
        .map(|i| &report.rows[i])
        .collect();
    front.sort_by(|a, b| a.wall_per_sim_second.total_cmp(&b.wall_per_sim_second));
    let pts: Vec<String> = front
        .iter()
        .map(|r| format!("{:.1},{:.1}", px(r.wall_per_sim_second), py(r.rms_error)))
        .collect();
    let _ = writeln!(
        s,
        r#"<polyline points="{}" fill="none" stroke="black" stroke-dasharray="4 3"/>"#,
        pts.join(" ")
    );
    for r in &stable {
        marker(
            &mut s,
            r.backend,
            px(r.wall_per_sim_second),
            py(r.rms_error),
            colour(r.integrator),
        );
    }
    // Legend.
    let mut y = MARGIN;
    for i in Integrator::ALL {
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{y:.0}" fill="{}">{i}</text>"#,
            WIDTH - MARGIN - 150.0,
            colour(i)
        );
        y += 16.0;
    }
    for b in Backend::ALL {
        marker(&mut s, b, WIDTH - MARGIN - 145.0, y - 4.0, "#555");
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{y:.0}">{}</text>"#,
            WIDTH - MARGIN - 135.0,
            b.as_str()
        );
        y += 16.0;
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.0}" y="{y:.0}">- - Pareto front</text>"#,
        WIDTH - MARGIN - 150.0
    );
    s.push_str("</svg>\n");
    s
}

/// One panel per integrator: stiffness (rows) × dt (columns), green for
/// stable cells, red for unstable ones.
pub fn stability_svg(report: &StabilityReport) -> String {
    let o = &report.options;
    let (cols, rows) = (o.dts.len().max(1) as f64, o.stiffnesses.len().max(1) as f64);
    let panel_w = (WIDTH - MARGIN) / 3.0;
    let cell_w = (panel_w - 20.0) / cols;
    let cell_h = (HEIGHT - 2.0 * MARGIN) / rows;
    let mut s = header("Stable (green) and unstable (red) runs: stretch stiffness × dt");
    for (p, integrator) in o.integrators.iter().enumerate() {
        let left = MARGIN + p as f64 * panel_w;
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{:.0}">{integrator}</text>"#,
            left,
            MARGIN - 10.0
        );
        for (r, &k) in o.stiffnesses.iter().enumerate() {
            let y = HEIGHT - MARGIN - (r as f64 + 1.0) * cell_h;
            if p == 0 {
                let _ = writeln!(
                    s,
                    r#"<text x="{:.0}" y="{:.0}" text-anchor="end" font-size="11">{k:.0e}</text>"#,
                    left - 4.0,
                    y + cell_h / 2.0 + 4.0
                );
            }
            for (c, &dt) in o.dts.iter().enumerate() {
                let x = left + c as f64 * cell_w;
                let fill = match report.cell(*integrator, k, dt) {
                    Some(cell) if cell.verdict.is_stable() => "#8fd18f",
                    Some(_) => "#e58a8a",
                    None => "#ddd",
                };
                let _ = writeln!(
                    s,
                    r#"<rect x="{x:.1}" y="{y:.1}" width="{:.1}" height="{:.1}" fill="{fill}" stroke="white"/>"#,
                    cell_w, cell_h
                );
                if r == 0 {
                    let _ = writeln!(
                        s,
                        r#"<text x="{:.1}" y="{:.0}" font-size="9" text-anchor="middle">{dt:.1e}</text>"#,
                        x + cell_w / 2.0,
                        HEIGHT - MARGIN + 14.0
                    );
                }
            }
        }
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.0}" y="{:.0}" text-anchor="middle">dt [s]</text>"#,
        WIDTH / 2.0,
        HEIGHT - MARGIN + 40.0
    );
    let _ = writeln!(
        s,
        r#"<text x="14" y="{:.0}" transform="rotate(-90 14 {:.0})" text-anchor="middle">stretch stiffness [N/m]</text>"#,
        HEIGHT / 2.0,
        HEIGHT / 2.0
    );
    s.push_str("</svg>\n");
    s
}

/// Points of the elastica's curve per decade of Γ.
const CURVE_POINTS_PER_DECADE: i32 = 20;

/// Colours of the strips' resolutions, in report order.
const RESOLUTION_COLOURS: [&str; 6] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

/// Tip drop over length (log) against Γ (log): the elastica as a black
/// line, each resolution's strips as dots joined by a line of its colour.
pub fn cantilever_svg(report: &CantileverReport) -> String {
    let (x0, x1) = decades(report.rows.iter().map(|r| r.gamma));
    let (y0, y1) = decades(report.rows.iter().flat_map(|r| [r.reference, r.simulated]));
    let px = log_scale((x0, x1), MARGIN, WIDTH - MARGIN);
    let py = log_scale((y0, y1), HEIGHT - MARGIN, MARGIN);
    let mut s = header("Cantilever: tip drop of clamped strips against the heavy elastica");
    axes(
        &mut s,
        (x0, x1),
        (y0, y1),
        "Γ = ρ g L³ / B",
        "tip drop / length",
    );
    let curve: Vec<String> = (x0 * CURVE_POINTS_PER_DECADE..=x1 * CURVE_POINTS_PER_DECADE)
        .filter_map(|e| {
            let gamma = 10f64.powf(f64::from(e) / f64::from(CURVE_POINTS_PER_DECADE));
            let drop = elastica::tip(gamma).ok()?.drop;
            (drop > 10f64.powi(y0)).then(|| format!("{:.1},{:.1}", px(gamma), py(drop)))
        })
        .collect();
    let _ = writeln!(
        s,
        r#"<polyline points="{}" fill="none" stroke="black" stroke-width="2"/>"#,
        curve.join(" ")
    );
    let mut y = MARGIN + 10.0;
    let _ = writeln!(
        s,
        r#"<text x="{:.0}" y="{y:.0}">— heavy elastica</text>"#,
        MARGIN + 10.0
    );
    let mut series: Vec<(BendingModel, usize)> = Vec::new();
    for r in &report.rows {
        if !series.contains(&(r.model, r.segments)) {
            series.push((r.model, r.segments));
        }
    }
    for (k, &(model, segments)) in series.iter().enumerate() {
        let fill = RESOLUTION_COLOURS[k % RESOLUTION_COLOURS.len()];
        let mut rows: Vec<_> = report
            .rows
            .iter()
            .filter(|r| r.segments == segments && r.model == model)
            .collect();
        rows.sort_by(|a, b| a.gamma.total_cmp(&b.gamma));
        let pts: Vec<String> = rows
            .iter()
            .map(|r| format!("{:.1},{:.1}", px(r.gamma), py(r.simulated)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{fill}"/>"#,
            pts.join(" ")
        );
        for r in &rows {
            let (x, y) = (px(r.gamma), py(r.simulated));
            let _ = match model {
                BendingModel::Chord => writeln!(
                    s,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" fill="{fill}"/>"#
                ),
                BendingModel::Material => writeln!(
                    s,
                    r#"<rect x="{:.1}" y="{:.1}" width="8" height="8" fill="none" stroke="{fill}" stroke-width="2"/>"#,
                    x - 4.0,
                    y - 4.0
                ),
            };
        }
        y += 16.0;
        let label = match model {
            BendingModel::Chord => format!(
                "● chord bend springs, {segments} segments (B calibrated at Γ = {})",
                wgcloth::evidence::cantilever::CALIBRATION_GAMMA
            ),
            BendingModel::Material => {
                format!("□ [material] linear bending, {segments} segments (B as given)")
            }
        };
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{y:.0}" fill="{fill}">{label}</text>"#,
            MARGIN + 10.0
        );
    }
    s.push_str("</svg>\n");
    s
}

/// The clamped plate's differences between successive resolutions
/// (log) against the finer one's spacing (log), a series per
/// discretisation, with first- and second-order slopes for reference.
pub fn drape_svg(rows: &[DrapeRow]) -> String {
    let mut series: Vec<(&str, Vec<(f64, f64)>)> = Vec::new();
    for pair in rows.windows(2) {
        let name = super::bench::plate_mesh_name(pair[1].mesh);
        if name != super::bench::plate_mesh_name(pair[0].mesh) {
            continue;
        }
        let point = (pair[1].spacing, (pair[1].drop - pair[0].drop).abs());
        match series.iter_mut().find(|(n, _)| *n == name) {
            Some((_, points)) => points.push(point),
            None => series.push((name, vec![point])),
        }
    }
    let points = || series.iter().flat_map(|(_, p)| p.iter().copied());
    let (x0, x1) = decades(points().map(|(h, _)| h));
    let (y0, y1) = decades(points().map(|(_, d)| d));
    let px = log_scale((x0, x1), MARGIN, WIDTH - MARGIN);
    let py = log_scale((y0, y1), HEIGHT - MARGIN, MARGIN);
    let mut s =
        header("Clamped plate: change of the free edge's drop between successive resolutions");
    axes(
        &mut s,
        (x0, x1),
        (y0, y1),
        "spacing of the finer resolution [m]",
        "|difference of drop / overhang|",
    );
    // Reference slopes through the first point of the first series.
    if let Some(&(h, d)) = series.first().and_then(|(_, p)| p.first()) {
        for (order, dash) in [(1, "6 4"), (2, "2 3")] {
            // To the left edge, or to the bottom where the line leaves
            // through it.
            let bottom = h * (10f64.powi(y0) / d).powf(1.0 / f64::from(order));
            let h_end = 10f64.powi(x0).max(bottom);
            let d_end = d * (h_end / h).powi(order);
            let _ = writeln!(
                s,
                r##"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#888" stroke-dasharray="{dash}"/>"##,
                px(h),
                py(d),
                px(h_end),
                py(d_end)
            );
            let _ = writeln!(
                s,
                r##"<text x="{:.0}" y="{:.0}" fill="#888">order {order}</text>"##,
                px(h_end) + 4.0,
                py(d_end) - 6.0
            );
        }
    }
    let mut y = MARGIN + 10.0;
    for (k, (name, points)) in series.iter().enumerate() {
        let fill = RESOLUTION_COLOURS[k % RESOLUTION_COLOURS.len()];
        let pts: Vec<String> = points
            .iter()
            .map(|&(h, d)| format!("{:.1},{:.1}", px(h), py(d)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{fill}" stroke-width="2"/>"#,
            pts.join(" ")
        );
        for &(h, d) in points {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{fill}"/>"#,
                px(h),
                py(d)
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{y:.0}" fill="{fill}">● {name}</text>"#,
            WIDTH - MARGIN - 120.0
        );
        y += 16.0;
    }
    s.push_str("</svg>\n");
    s
}

fn header(title: &str) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{HEIGHT}\" \
         font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{:.0}\" y=\"24\" text-anchor=\"middle\" font-size=\"14\">{title}</text>\n",
        WIDTH / 2.0
    )
}

/// Log axes with a tick per decade.
fn axes(s: &mut String, (x0, x1): (i32, i32), (y0, y1): (i32, i32), xl: &str, yl: &str) {
    let (l, r, t, b) = (MARGIN, WIDTH - MARGIN, MARGIN, HEIGHT - MARGIN);
    let _ = writeln!(
        s,
        r#"<rect x="{l}" y="{t}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        r - l,
        b - t
    );
    for e in x0..=x1 {
        let x = l + f64::from(e - x0) / f64::from(x1 - x0) * (r - l);
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{t}" x2="{x:.1}" y2="{b}" stroke="#ddd"/>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{x:.1}" y="{:.0}" text-anchor="middle">1e{e}</text>"#,
            b + 16.0
        );
    }
    for e in y0..=y1 {
        let y = b - f64::from(e - y0) / f64::from(y1 - y0) * (b - t);
        let _ = writeln!(
            s,
            r##"<line x1="{l}" y1="{y:.1}" x2="{r}" y2="{y:.1}" stroke="#ddd"/>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.0}" y="{:.1}" text-anchor="end">1e{e}</text>"#,
            l - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.0}" y="{:.0}" text-anchor="middle">{xl}</text>"#,
        (l + r) / 2.0,
        b + 40.0
    );
    let _ = writeln!(
        s,
        r#"<text x="16" y="{:.0}" transform="rotate(-90 16 {:.0})" text-anchor="middle">{yl}</text>"#,
        (t + b) / 2.0,
        (t + b) / 2.0
    );
}
