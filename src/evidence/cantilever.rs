//! The cantilever: strips of the project's cloth bending under their own
//! weight, against the heavy elastica ([`mod@super::elastica`]).
//!
//! A strip is a grid cloth of `segments + 2` columns along `+x` and
//! [`ROWS`] rows, horizontal, clamped by pinning its first two columns (the
//! clamp is the second, at `x = 0`, and the first holds the strip level
//! there). Its free length is [`LENGTH`], each row weighs [`LINE_MASS`] per
//! metre. Stretch and shear springs are [`STRETCH_OVER_BEND`] and
//! [`SHEAR_OVER_BEND`] times stiffer than the bend springs, so the strip is
//! inextensible next to its bending; the bend springs alone resist bending.
//!
//! # What `B` is
//!
//! A bend spring joins particles two apart along a row. When the joint
//! between them turns by `θ` its chord shortens from `2h` to
//! `2h cos(θ/2)`, by `h θ² / 4`: second order. Its energy is
//! `k h² θ⁴ / 32` and its moment `k h² θ³ / 8`, so with curvature
//! `κ = θ / h` a row bends by the **cubic** law `M = C κ³`,
//! `C = k h⁵ / 8`, not the elastica's `M = B κ`: the cloth has no linear
//! bending stiffness. Its small-deflection tip drop is, for many segments,
//! `δ = (3/8) L^{8/3} (λ g / 2C)^{1/3}` (integrate `κ = (M / C)^{1/3}` with
//! `M = λ g (L − x)² / 2`, `λ` the mass per length of a row), and
//! [`chord_law_drop`] for the discrete strip: it grows as the cube root of
//! the load, where the elastica's grows linearly, and a linear `B` fitted
//! at one load is wrong by a factor `(load ratio)^{2/3}` at another, at
//! every resolution.
//!
//! To place the cloth on the elastica's `Γ` axis anyway, `B` is calibrated
//! once per resolution in the small-deflection limit: the bend stiffness
//! `k_cal` is tuned until the strip's tip drops as far as the elastica's at
//! [`CALIBRATION_GAMMA`], and `B` is then taken to scale with `k` as a
//! linear stiffness would. `Γ` is varied through the bend stiffness,
//! `k(Γ) = k_cal Γ_cal / Γ`, at fixed length, mass and gravity.
//!
//! # Settling
//!
//! The strip starts level and at rest and is stepped with the implicit
//! integrator (CPU, `f64`) at [`SETTLE_DT`]: backward Euler damps every
//! mode and its rest state is exact equilibrium whatever the step (with
//! `v = 0` and zero net force a step changes nothing), so large steps
//! reach rest fastest. A strip is at rest when no particle moves faster
//! than [`REST_SPEED`]; a run that does not get there within
//! [`MAX_STEPS`] is reported as not settled.

use super::{elastica, sheet, Points, Runner};
use crate::error::{Error, Result};
use crate::evidence::Backend;
use crate::material::{Material, WarpWeft};
use crate::model::{ClothSpec, Model, Orientation, Pin};
use crate::params::{format_number, format_short, Integrator, Params, SpringKind};
use glam::DVec3;

/// Free length of every strip \[m\].
pub const LENGTH: f64 = 1.0;

/// Rows across the strip: two, so that it has a width and its cells can
/// be held square by shear springs.
pub const ROWS: usize = 2;

/// Width of the strip \[m\] (the spacing of its rows).
pub const WIDTH: f64 = 0.05;

/// Mass per metre of each row [kg/m]. Only `Γ` matters to the shape, and
/// the chord law needs a bend stiffness `∝ λ N⁵ / Γ³` (module docs): this
/// light a strip keeps every stiffness of the default sweep within the
/// parameters' `1e9 N/m`.
pub const LINE_MASS: f64 = 1e-7;

/// Stretch stiffness over bend stiffness: the stretch springs carry the
/// bend springs' compression at a strain `θ² / 400`, `θ` the turning
/// angle of one joint, and give the bend springs 1 % of extra compliance
/// in series.
pub const STRETCH_OVER_BEND: f64 = 100.0;

/// Shear stiffness over bend stiffness (holds the cells square).
pub const SHEAR_OVER_BEND: f64 = 100.0;

/// Time step of the settling runs \[s\] (see the module docs).
pub const SETTLE_DT: f64 = 0.02;

/// Relative CG tolerance of the settling steps: the stiff stretch springs
/// (`k dt² / m` near `1e11` at `Γ = 10⁻²`) keep a looser solve's error
/// moving the strip faster than [`REST_SPEED`].
pub const CG_TOLERANCE: f64 = 1e-10;

/// Most CG iterations of a settling step: several times the 108 unknowns
/// of the finest default strip (36 particles).
pub const CG_MAX_ITERATIONS: u32 = 1000;

/// Speed under which every particle counts as at rest [m/s]. At this
/// speed the settled drops of 4, 8 and 16 segments agree to 0.5 % and
/// follow the chord law to 1 %: what motion is left is below what the
/// bench resolves.
pub const REST_SPEED: f64 = 1e-6;

/// Steps between two checks for rest.
pub const CHECK_EVERY: u64 = 25;

/// Most steps of one settling run (200 s of simulated time).
pub const MAX_STEPS: u64 = 10_000;

/// `Γ` at which `B` is calibrated: small deflection (tip drop 1.25 % of
/// the length). Calibrating at `10⁻²` would need a spring 1000 times
/// stiffer (the chord law's `Γ⁻³`), past the parameters' `1e9 N/m` at 16
/// segments.
pub const CALIBRATION_GAMMA: f64 = 0.1;

/// Rounds of the calibration of `k_cal` (each scales `k` by the cube of the
/// drop's ratio to the target, the chord law's exponent; three bring it
/// within 1e-4 (relative) of the target in the runs measured).
pub const CALIBRATION_ROUNDS: u32 = 3;

/// What [`cantilever`] measures.
#[derive(Clone, Debug, PartialEq)]
pub struct CantileverOptions {
    /// Resolutions: segments along the free length (each ≥ 2).
    pub segments: Vec<usize>,
    /// `Γ = ρ g L³ / B` values, within `(0,` [`elastica::MAX_GAMMA`]`]`.
    pub gammas: Vec<f64>,
    /// Integrators run at each point (calibration uses the first).
    pub integrators: Vec<Integrator>,
    /// Resolutions of the material strips (`[material]` with the linear
    /// bending model): segments along the free length, each ≥ 2; none:
    /// only the chord springs are measured.
    pub material_segments: Vec<usize>,
}

impl Default for CantileverOptions {
    /// Γ from 10⁻² to 10² at five points a decade, 4, 8 and 16 segments,
    /// implicit.
    fn default() -> Self {
        CantileverOptions {
            segments: vec![4, 8, 16],
            gammas: (-10..=10).map(|e| 10f64.powf(f64::from(e) / 5.0)).collect(),
            integrators: vec![Integrator::Implicit],
            material_segments: vec![8, 16, 32],
        }
    }
}

impl CantileverOptions {
    /// A run of seconds: 8 segments, one point a decade.
    pub fn quick() -> Self {
        CantileverOptions {
            segments: vec![8],
            gammas: (-2..=2).map(|e| 10f64.powi(e)).collect(),
            material_segments: vec![8],
            ..CantileverOptions::default()
        }
    }
}

/// What resists bending in a strip.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BendingModel {
    /// The article's chord bend springs, `B` calibrated once per
    /// resolution (module docs).
    Chord,
    /// `[material]` with the linear bending model ([`crate::bending`]): `B`
    /// is the input, nothing calibrated.
    Material,
}

impl BendingModel {
    /// Its name in the bench's output.
    pub fn as_str(self) -> &'static str {
        match self {
            BendingModel::Chord => "chord",
            BendingModel::Material => "material",
        }
    }
}

/// One settled strip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CantileverRow {
    /// What resists bending.
    pub model: BendingModel,
    /// Segments along the free length.
    pub segments: usize,
    /// The integrator.
    pub integrator: Integrator,
    /// `Γ` (dimensionless).
    pub gamma: f64,
    /// Bend springs' stiffness of the run [N/m] (chord), or the material's
    /// bending stiffness `B` \[N·m\] (material).
    pub bend_stiffness: f64,
    /// The elastica's tip drop over length.
    pub reference: f64,
    /// The strip's tip drop over length (mean over its rows).
    pub simulated: f64,
    /// The elastica's tip reach over length (`x` of the tip).
    pub reference_reach: f64,
    /// The strip's tip reach over length (mean over its rows).
    pub reach: f64,
    /// `(simulated − reference) / reference`.
    pub deviation: f64,
    /// Steps the run took.
    pub steps: u64,
    /// `false`: not at rest after [`MAX_STEPS`] (the drop is where it was).
    pub settled: bool,
}

/// Result of [`cantilever`].
#[derive(Clone, Debug, PartialEq)]
pub struct CantileverReport {
    /// Per resolution: `(segments, k_cal [N/m])`.
    pub calibrations: Vec<(usize, f64)>,
    /// The measurements, per resolution, integrator and `Γ`.
    pub rows: Vec<CantileverRow>,
}

impl CantileverRow {
    /// The strip's tip drop over its reach, `H / W` (the master curve's
    /// ordinate).
    pub fn h_over_w(&self) -> f64 {
        self.simulated / self.reach
    }

    /// The elastica's `H / W`.
    pub fn reference_h_over_w(&self) -> f64 {
        self.reference / self.reference_reach
    }

    /// `H / W`'s relative deviation from the elastica's.
    pub fn h_over_w_deviation(&self) -> f64 {
        self.h_over_w() / self.reference_h_over_w() - 1.0
    }
}

impl CantileverReport {
    /// The largest `|deviation|` of the tip drop over the chord strips of
    /// `segments` (NaN when none).
    pub fn worst_deviation(&self, segments: usize) -> f64 {
        self.worst(BendingModel::Chord, segments, |r| r.deviation)
    }

    /// The largest `|deviation|` of `H / W` over the material strips of
    /// `segments` (NaN when none).
    pub fn worst_material_deviation(&self, segments: usize) -> f64 {
        self.worst(
            BendingModel::Material,
            segments,
            CantileverRow::h_over_w_deviation,
        )
    }

    fn worst(
        &self,
        model: BendingModel,
        segments: usize,
        f: impl Fn(&CantileverRow) -> f64,
    ) -> f64 {
        self.rows
            .iter()
            .filter(|r| r.segments == segments && r.model == model)
            .map(|r| f(r).abs())
            .fold(f64::NAN, f64::max)
    }
}

fn invalid(key: &str, allowed: &str, got: impl std::fmt::Debug) -> Error {
    Error::InvalidParameter {
        key: key.to_string(),
        allowed: allowed.to_string(),
        got: format!("{got:?}"),
    }
}

/// Segment length \[m\].
fn spacing(segments: usize) -> f64 {
    LENGTH / segments as f64
}

/// The chord law's small-deflection tip drop over length of a strip of
/// `segments` whose bend springs have stiffness `k` [N/m] under gravity
/// `gravity` [m/s²], summed joint by joint as the discrete strip carries
/// it: joint `i` (at `x = i h`) bears the moment `λ g h² n (n + 1) / 2` of
/// the `n = N − i` particles beyond it, turns by `θ = (8 M / (k h²))^{1/3}`,
/// and lowers the tip by `θ n h`. Its limit for many segments is
/// `(3/8) L^{8/3} (λ g / 2C)^{1/3}` (module docs).
pub fn chord_law_drop(segments: usize, k: f64, gravity: f64) -> f64 {
    let h = spacing(segments);
    (1..=segments)
        .map(|n| {
            let n = n as f64;
            let moment = LINE_MASS * gravity * h * h * n * (n + 1.0) / 2.0;
            (8.0 * moment / (k * h * h)).cbrt() * n * h
        })
        .sum::<f64>()
        / LENGTH
}

/// The strip's model and parameters at bend stiffness `k`.
fn strip(segments: usize, k: f64, integrator: Integrator) -> Result<(Model, Params)> {
    let h = spacing(segments);
    let nx = segments + 2;
    let spec = ClothSpec {
        nx,
        ny: ROWS,
        size: [(nx - 1) as f64 * h, WIDTH],
        origin: DVec3::new(-h, 0.0, 0.0),
        orientation: Orientation::Horizontal,
        mass: LINE_MASS * h * (nx * ROWS) as f64,
        pins: (0..ROWS)
            .flat_map(|r| [Pin::Index(r * nx), Pin::Index(r * nx + 1)])
            .collect(),
    };
    let mut params = Params {
        integrator,
        dt: SETTLE_DT,
        ..Params::default()
    };
    for (kind, ratio) in [
        (SpringKind::Stretch, STRETCH_OVER_BEND),
        (SpringKind::Shear, SHEAR_OVER_BEND),
        (SpringKind::Bend, 1.0),
    ] {
        let s = &mut params.springs[kind.index()];
        s.stiffness = k * ratio;
        s.damping = 0.0;
        s.max_stretch = None;
    }
    params.fixup.iterations = 0;
    params.implicit.tolerance = CG_TOLERANCE;
    params.implicit.max_iterations = CG_MAX_ITERATIONS;
    Ok((Model::new(&spec, &params.springs)?, params))
}

/// Areal density of the material strips \[kg/m²\]: light, so that every
/// `B = ρ g L³ / Γ` of the sweep stays within `[material] bending`'s range.
pub const MATERIAL_DENSITY: f64 = 1e-3;

/// Stretch stiffness of the material strips over their greatest tension
/// per unit width (`ρ g L` at the clamp): the strip stretches by at most
/// `1/`this, far below what the bench resolves.
pub const MATERIAL_STRETCH_OVER_TENSION: f64 = 1e5;

/// Which way a strip is cut from a woven fabric.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cut {
    /// Along the warp: the grid's rows run along the strip.
    Warp,
    /// Along the weft: the grid's columns run along the strip.
    Weft,
}

/// A strip ready to settle: its model and parameters, the
/// particles at its free end and the unit direction from the clamp along
/// it.
struct Strip {
    model: Model,
    params: Params,
    tips: Vec<usize>,
    along: DVec3,
}

/// The material strip of free length `length` \[m\]: a [`Material`] of
/// `density` \[kg/m²\] and `bending` \[N·m\], stretch stiff enough to be
/// inextensible, shear a tenth of that and no damping, on a grid of
/// `segments` square cells along the free length and `rows` particles
/// across, cut from the fabric as `cut` says and clamped where a user
/// clamps it (every particle at `x ≤ 0` pinned: its first two columns, or
/// along the weft at `z ≤ 0`, its first two rows).
fn material_strip(
    segments: usize,
    rows: usize,
    length: f64,
    (density, bending): (f64, WarpWeft),
    cut: Cut,
    integrator: Integrator,
) -> Result<Strip> {
    let gravity = -Params::default().gravity.y;
    // Clamped as a user clamps it: every particle at x ≤ 0 is pinned (the
    // columns sit at (c − 1) h, the clamp is the second, at 0, and the tip
    // at L); the bending operator treats that column as a clamp
    // (`bending::CLAMP_WEIGHT`).
    let h = length / segments as f64;
    let long = segments + 2;
    let weft = cut == Cut::Weft;
    let (nx, ny) = if weft { (rows, long) } else { (long, rows) };
    let at = |along: usize, across: usize| {
        if weft {
            across + along * nx
        } else {
            along + across * nx
        }
    };
    let spec = ClothSpec {
        nx,
        ny,
        size: [(nx - 1) as f64 * h, (ny - 1) as f64 * h],
        origin: if weft {
            DVec3::new(0.0, 0.0, -h)
        } else {
            DVec3::new(-h, 0.0, 0.0)
        },
        orientation: Orientation::Horizontal,
        mass: 1.0,
        pins: (0..rows)
            .flat_map(|r| [Pin::Index(at(0, r)), Pin::Index(at(1, r))])
            .collect(),
    };
    let stretch = MATERIAL_STRETCH_OVER_TENSION * density * gravity * length;
    let material = Material {
        density,
        stretch: stretch.into(),
        shear: 0.1 * stretch,
        bending,
        damping: 0.0,
    };
    material.validate()?;
    let mut params = Params {
        integrator,
        dt: SETTLE_DT,
        springs: material.spring_params(),
        ..Params::default()
    };
    params.fixup.iterations = 0;
    params.implicit.tolerance = CG_TOLERANCE;
    params.implicit.max_iterations = CG_MAX_ITERATIONS;
    let mut model = Model::new(&spec, &params.springs)?;
    let cells = model.grid_cells();
    let warp = model.grid_warp();
    material.apply(&mut model, cells.iter().map(|c| (&c[..], warp)))?;
    Ok(Strip {
        model,
        params,
        tips: (0..rows).map(|r| at(long - 1, r)).collect(),
        along: if weft { DVec3::Z } else { DVec3::X },
    })
}

/// A settled strip: tip drop and reach over length, steps, at rest.
fn settle(segments: usize, k: f64, integrator: Integrator) -> Result<Settled> {
    let (model, params) = strip(segments, k, integrator)?;
    let nx = segments + 2;
    let strip = Strip {
        model,
        params,
        tips: (0..ROWS).map(|r| r * nx + nx - 1).collect(),
        along: DVec3::X,
    };
    settle_strip(&strip, LENGTH)
}

/// A settled material strip of `rows` rows at `Γ` ([`LENGTH`] long, of
/// [`MATERIAL_DENSITY`]).
pub fn settle_material(
    segments: usize,
    rows: usize,
    gamma: f64,
    integrator: Integrator,
) -> Result<Settled> {
    let material = (MATERIAL_DENSITY, bending_at(gamma, LENGTH).into());
    let strip = material_strip(segments, rows, LENGTH, material, Cut::Warp, integrator)?;
    settle_strip(&strip, LENGTH)
}

/// How much stiffer in bending the fabric of [`settle_woven`]'s strips is
/// along its warp than along its weft: a plain-woven cotton's order
/// (`docs/materials.md`).
pub const WOVEN_ANISOTROPY: f64 = 4.0;

/// A settled strip of [`MATERIAL_ROWS`] rows, [`LENGTH`] long, of
/// [`MATERIAL_DENSITY`], cut as `cut` from a fabric [`WOVEN_ANISOTROPY`]
/// times stiffer in bending along its warp than its weft, whose stiffness
/// along the cut gives `Γ = ρ g L³ / B = gamma`.
pub fn settle_woven(
    segments: usize,
    gamma: f64,
    cut: Cut,
    integrator: Integrator,
) -> Result<Settled> {
    let along = bending_at(gamma, LENGTH);
    let bending = match cut {
        Cut::Warp => WarpWeft {
            warp: along,
            weft: along / WOVEN_ANISOTROPY,
        },
        Cut::Weft => WarpWeft {
            warp: along * WOVEN_ANISOTROPY,
            weft: along,
        },
    };
    let material = (MATERIAL_DENSITY, bending);
    let strip = material_strip(segments, MATERIAL_ROWS, LENGTH, material, cut, integrator)?;
    settle_strip(&strip, LENGTH)
}

/// The bending stiffness \[N·m\] that gives a length `length` \[m\] of a
/// material of [`MATERIAL_DENSITY`] `Γ = ρ g L³ / B = gamma`.
fn bending_at(gamma: f64, length: f64) -> f64 {
    let gravity = -Params::default().gravity.y;
    MATERIAL_DENSITY * gravity * length.powi(3) / gamma
}

/// Rows of the material strips: three, so that the middle row's
/// particles are inside the cloth.
pub const MATERIAL_ROWS: usize = 3;

/// A strip at rest (or after [`MAX_STEPS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    /// Tip drop below the clamp over length (mean over the rows).
    pub drop: f64,
    /// Tip reach beyond the clamp over length (mean over the rows).
    pub reach: f64,
    /// Steps taken.
    pub steps: u64,
    /// `false`: not at rest after [`MAX_STEPS`].
    pub settled: bool,
}

/// Steps a strip of free length `length` \[m\] until it is at rest.
fn settle_strip(strip: &Strip, length: f64) -> Result<Settled> {
    let (x, steps, settled) = rest_positions(&strip.model, &strip.params)?;
    let count = strip.tips.len() as f64;
    let mean = |f: &dyn Fn(DVec3) -> f64| {
        strip
            .tips
            .iter()
            .map(|&t| f(DVec3::new(x[t].x, x[t].y, x[t].z)))
            .sum::<f64>()
            / (count * length)
    };
    Ok(Settled {
        drop: mean(&|p| -p.y),
        reach: mean(&|p| p.dot(strip.along)),
        steps,
        settled,
    })
}

/// Steps `model` on the CPU in `f64`, [`CHECK_EVERY`] steps at a time,
/// until no particle moves faster than [`REST_SPEED`] or [`MAX_STEPS`]
/// have passed: the positions then, the steps taken and whether it came to
/// rest.
fn rest_positions(model: &Model, params: &Params) -> Result<(Points, u64, bool)> {
    let mut runner = Runner::new(Backend::CpuF64, model, params)?;
    let mut steps = 0;
    loop {
        runner.advance(CHECK_EVERY)?;
        steps += CHECK_EVERY;
        let (x, v) = runner.state()?;
        let at_rest = v.iter().all(|v| v.length() < REST_SPEED);
        if at_rest || steps >= MAX_STEPS {
            return Ok((x, steps, at_rest));
        }
    }
}

/// Measures the strips of `options` against the elastica (module docs).
pub fn cantilever(options: &CantileverOptions) -> Result<CantileverReport> {
    if let Some(s) = options
        .segments
        .iter()
        .chain(&options.material_segments)
        .find(|&&s| s < 2)
    {
        return Err(invalid("bench.cantilever.segments", "≥ 2", s));
    }
    if let Some(g) = options
        .gammas
        .iter()
        .find(|&&g| !(g > 0.0 && g <= elastica::MAX_GAMMA))
    {
        return Err(invalid(
            "bench.cantilever.gammas",
            &format!("0 < Γ ≤ {}", elastica::MAX_GAMMA),
            g,
        ));
    }
    let (Some(&first), false) = (options.integrators.first(), options.gammas.is_empty()) else {
        return Err(invalid(
            "bench.cantilever",
            "at least one integrator and one Γ",
            options,
        ));
    };
    let gravity = -Params::default().gravity.y;
    let target = elastica::tip(CALIBRATION_GAMMA)?.drop;
    let mut report = CantileverReport {
        calibrations: Vec::new(),
        rows: Vec::new(),
    };
    for &segments in &options.segments {
        // The chord law's own prediction as the first guess.
        let mut k = k_for_drop(segments, target, gravity);
        for _ in 0..CALIBRATION_ROUNDS {
            k *= (settle(segments, k, first)?.drop / target).powi(3);
        }
        report.calibrations.push((segments, k));
        for &integrator in &options.integrators {
            for &gamma in &options.gammas {
                let bend = k * CALIBRATION_GAMMA / gamma;
                let run = settle(segments, bend, integrator)?;
                report.rows.push(row(
                    BendingModel::Chord,
                    segments,
                    integrator,
                    gamma,
                    bend,
                    run,
                )?);
            }
        }
    }
    let gravity_density = MATERIAL_DENSITY * gravity * LENGTH.powi(3);
    for &segments in &options.material_segments {
        for &integrator in &options.integrators {
            for &gamma in &options.gammas {
                let run = settle_material(segments, MATERIAL_ROWS, gamma, integrator)?;
                let bending = gravity_density / gamma;
                report.rows.push(row(
                    BendingModel::Material,
                    segments,
                    integrator,
                    gamma,
                    bending,
                    run,
                )?);
            }
        }
    }
    Ok(report)
}

/// A row of the report from a settled run.
fn row(
    model: BendingModel,
    segments: usize,
    integrator: Integrator,
    gamma: f64,
    bend_stiffness: f64,
    run: Settled,
) -> Result<CantileverRow> {
    let tip = elastica::tip(gamma)?;
    Ok(CantileverRow {
        model,
        segments,
        integrator,
        gamma,
        bend_stiffness,
        reference: tip.drop,
        simulated: run.drop,
        reference_reach: tip.reach,
        reach: run.reach,
        deviation: (run.drop - tip.drop) / tip.drop,
        steps: run.steps,
        settled: run.settled,
    })
}

/// The bend stiffness [N/m] at which [`chord_law_drop`] is `drop`.
fn k_for_drop(segments: usize, drop: f64, gravity: f64) -> f64 {
    // δ ∝ k^(-1/3): scale from the drop at 1 N/m.
    (chord_law_drop(segments, 1.0, gravity) / drop).powi(3)
}

/// ASTM D1388's angle \[degrees\]: a strip slid over a table edge until
/// its tip meets the line this far below the horizontal overhangs by
/// twice its bending length.
pub const OVERHANG_ANGLE_DEGREES: f64 = 41.5;

/// Halvings of the overhang's bisection (on `ln Γ` over `[ln 1, ln 100]`):
/// 24 leave the overhang within `1e-7` (relative) of the crossing, far
/// below the resolution's error.
pub const OVERHANG_BISECTIONS: u32 = 24;

/// The strip lengths [`overhang`] may settle: its segments of the
/// overhang. Two are the fewest with a bend between the clamp and the
/// tip; 256 settle for about a minute each, beyond any use of the test.
pub const OVERHANG_SEGMENTS: std::ops::RangeInclusive<usize> = 2..=256;

/// The `Γ` range [`overhang`] bisects over.
const OVERHANG_GAMMAS: [f64; 2] = [1.0, 100.0];

/// The overhang \[m\] of a strip of the material at `gamma = ρ g O³ / B`.
fn overhang_length(gamma: f64, density: f64, bending: f64) -> f64 {
    let gravity = -Params::default().gravity.y;
    (gamma * bending / (density * gravity)).cbrt()
}

/// Refuses what [`overhang`] cannot measure, under the names of its
/// arguments (`density`, `bending`, `segments`; a command line names its
/// options so): segments outside [`OVERHANG_SEGMENTS`], a density or
/// bending the material refuses or of zero bending (no overhang to find),
/// and a pair whose strips (their length `(Γ B / (ρ g))^⅓` over the
/// bisection's `Γ`) the solvers cannot hold.
pub fn check_overhang(density: f64, bending: f64, segments: usize) -> Result<()> {
    if !OVERHANG_SEGMENTS.contains(&segments) {
        return Err(invalid(
            "segments",
            &format!(
                "{} ≤ segments ≤ {} (cells along the strip's overhang)",
                OVERHANG_SEGMENTS.start(),
                OVERHANG_SEGMENTS.end()
            ),
            segments,
        ));
    }
    crate::params::check("density", density, density > 0.0, "> 0 (kg/m²)")?;
    crate::params::check(
        "bending",
        bending,
        bending > 0.0 && bending <= crate::material::MAX_BENDING,
        "0 < bending ≤ 1 (N·m per unit width; without bending a strip has no overhang)",
    )?;
    let [short, long] = OVERHANG_GAMMAS.map(|g| overhang_length(g, density, bending));
    for length in [short, long] {
        material_strip(
            segments,
            MATERIAL_ROWS,
            length,
            (density, bending.into()),
            Cut::Warp,
            Integrator::Implicit,
        )
        .map_err(|_| Error::InvalidParameter {
            key: "density".to_string(),
            allowed: format!(
                "a density that, with bending {} N·m, gives strips the solvers can hold: the \
                 test settles overhangs (Γ B / (ρ g))^⅓ for Γ from 1 to 100, here {} to {} m, \
                 and in f32 a cloth stays within ±1e18 m, its cells at least 1e-18 m and its \
                 particles' masses normal numbers",
                format_number(bending),
                format_short(short),
                format_short(long)
            ),
            got: format_number(density),
        })?;
    }
    Ok(())
}

/// What [`overhang`] measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overhang {
    /// Segments of the strip.
    pub segments: usize,
    /// The material's areal density \[kg/m²\].
    pub density: f64,
    /// The material's bending stiffness, the input \[N·m\].
    pub bending: f64,
    /// The overhang `O` at which the tip meets the 41.5° line \[m\].
    pub length: f64,
    /// The bending length `c = O / 2` \[m\].
    pub bending_length: f64,
    /// The rigidity the test implies, `ρ g c³` \[N·m\].
    pub implied: f64,
    /// `implied / bending − 1`.
    pub deviation: f64,
    /// The heavy elastica's `Γ` at the crossing (exactly `8.00` for a
    /// perfect strip).
    pub gamma: f64,
    /// Strips settled.
    pub runs: u32,
}

/// ASTM D1388's cantilever test, done on a simulated strip of `segments`
/// cells of the material (`density` \[kg/m²\], `bending` \[N·m\]): the
/// overhang `O` at which the settled tip's chord makes
/// [`OVERHANG_ANGLE_DEGREES`] with the horizontal (bisected), the bending
/// length `c = O/2` and the rigidity `B = ρ g c³` it implies. Exact for the
/// elastica: its tip–chord angle reaches 41.5° at `Γ = ρ g O³ / B = 8.00`.
pub fn overhang(density: f64, bending: f64, segments: usize) -> Result<Overhang> {
    check_overhang(density, bending, segments)?;
    let gravity = -Params::default().gravity.y;
    let target = OVERHANG_ANGLE_DEGREES.to_radians().tan();
    let length_at = |ln_gamma: f64| overhang_length(ln_gamma.exp(), density, bending);
    let tan_at = |length: f64| -> Result<f64> {
        let strip = material_strip(
            segments,
            MATERIAL_ROWS,
            length,
            (density, bending.into()),
            Cut::Warp,
            Integrator::Implicit,
        )?;
        let run = settle_strip(&strip, length)?;
        Ok(run.drop / run.reach)
    };
    let (mut lo, mut hi) = (OVERHANG_GAMMAS[0].ln(), OVERHANG_GAMMAS[1].ln());
    for _ in 0..OVERHANG_BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if tan_at(length_at(mid))? < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let ln_gamma = 0.5 * (lo + hi);
    let length = length_at(ln_gamma);
    let bending_length = length / 2.0;
    let implied = density * gravity * bending_length.powi(3);
    Ok(Overhang {
        segments,
        density,
        bending,
        length,
        bending_length,
        implied,
        deviation: implied / bending - 1.0,
        gamma: ln_gamma.exp(),
        runs: OVERHANG_BISECTIONS,
    })
}

/// Where the clamped plate of [`plate_drop`] is held: every particle with
/// `x ≤` this \[m\] is pinned (the plate lies on a table up to there). A
/// column of every grid of `2ᵏ + 1` particles a side lies on it, the
/// clamp the bending operator weights as one (`bending::CLAMP_WEIGHT`);
/// the irregular meshes' clamp follows their vertices.
pub const PLATE_CLAMP: f64 = 0.125;

/// `Γ = ρ g L³ / B` of the clamped plate over its overhang `L = 1 −`
/// [`PLATE_CLAMP`]: a large, smooth sag, no folds for the resolutions to
/// disagree on.
pub const PLATE_GAMMA: f64 = 5.0;

/// How the unit square of [`plate_drop`] is discretised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlateMesh {
    /// A grid of `n × n` particles (the Hessian bending operator).
    Grid(usize),
    /// The irregular triangle mesh of [`sheet::irregular_sheet`] with this
    /// many rows (Bergou's operator).
    Irregular(usize),
}

/// The same material discretised as `mesh`: a unit-square plate of
/// [`MATERIAL_DENSITY`], horizontal, clamped where `x ≤` [`PLATE_CLAMP`]
/// and sagging under its own weight at [`PLATE_GAMMA`], at its static
/// equilibrium ([`super::equilibrium`]). Returns the mean drop of its free
/// edge (`x = 1`, every particle within 1 mm of it) over the overhang, and
/// whether the equilibrium converged.
pub fn plate_drop(mesh: PlateMesh) -> Result<(f64, bool)> {
    scene_drop(&plate_scene(mesh)?)
}

/// [`plate_drop`]'s measure of a plate's scene.
fn scene_drop(scene: &crate::scene::Scene) -> Result<(f64, bool)> {
    let model = scene.model()?;
    let edge: Vec<usize> = (0..model.particle_count())
        .filter(|&p| model.rest_positions[p].x > 1.0 - 1e-3)
        .collect();
    let rest = super::equilibrium::equilibrium(&model, &scene.params)?;
    let drop = edge.iter().map(|&p| -rest.positions[p].y).sum::<f64>() / edge.len() as f64;
    Ok((drop / (1.0 - PLATE_CLAMP), rest.converged))
}

/// The scene of [`plate_drop`]'s plate discretised as `mesh` (the
/// implicit integrator at [`SETTLE_DT`], for a host that lets it settle
/// by steps).
pub fn plate_scene(mesh: PlateMesh) -> Result<crate::scene::Scene> {
    woven_plate_scene(mesh, plate_bending().into(), 0.0)
}

/// The bending stiffness \[N·m\] of [`plate_drop`]'s plate: its overhang
/// `1 −` [`PLATE_CLAMP`] at [`PLATE_GAMMA`].
pub fn plate_bending() -> f64 {
    bending_at(PLATE_GAMMA, 1.0 - PLATE_CLAMP)
}

/// The scene file of a horizontal unit-square sheet of `n × n` particles
/// (`x` and `z` from 0 to 1 at `y = 0`) of [`MATERIAL_DENSITY`] and
/// `bending`, every particle in the box `table` (two corners \[m\])
/// pinned, its stretch [`MATERIAL_STRETCH_OVER_TENSION`] times the tension
/// per unit width of a length `hanging` \[m\] of it under gravity, its
/// shear a tenth of that, undamped, for the implicit integrator at
/// [`SETTLE_DT`] without a fix-up.
fn sheet_scene(n: usize, table: [[f64; 3]; 2], hanging: f64, bending: WarpWeft) -> String {
    let gravity = -Params::default().gravity.y;
    let stretch = MATERIAL_STRETCH_OVER_TENSION * MATERIAL_DENSITY * gravity * hanging;
    let [[x0, y0, z0], [x1, y1, z1]] = table;
    format!(
        "[simulation]\nintegrator = \"implicit\"\ndt = {SETTLE_DT}\n\
         [implicit]\ntolerance = {CG_TOLERANCE}\nmax_iterations = {CG_MAX_ITERATIONS}\n\
         [fixup]\niterations = 0\n\
         [cloth]\nresolution = [{n}, {n}]\nsize = [1.0, 1.0]\norigin = [0.0, 0.0, 0.0]\n\
         pins = [{{ box = [[{x0:?}, {y0:?}, {z0:?}], [{x1:?}, {y1:?}, {z1:?}]] }}]\n\
         [material]\ndensity = {MATERIAL_DENSITY}\nstretch = {stretch}\nshear = {}\n\
         bending = {bending}\ndamping = 0.0\n",
        0.1 * stretch
    )
}

/// The clamped plate of [`plate_drop`] of a fabric of `bending`, its warp
/// at `warp_degrees` to the overhang (`x`) in the plate's plane: the
/// fraction of the overhang its free edge drops at rest, and whether the
/// equilibrium converged. A grid's warp runs along its rows, so on a grid
/// `warp_degrees` is 0 or 90 (its weft along the overhang: the bending
/// swapped); the irregular mesh carries texture coordinates turned by it.
pub fn woven_plate_drop(
    mesh: PlateMesh,
    bending: WarpWeft,
    warp_degrees: f64,
) -> Result<(f64, bool)> {
    scene_drop(&woven_plate_scene(mesh, bending, warp_degrees)?)
}

/// The scene of [`woven_plate_drop`].
fn woven_plate_scene(
    mesh: PlateMesh,
    bending: WarpWeft,
    warp_degrees: f64,
) -> Result<crate::scene::Scene> {
    use crate::mesh::{Mesh, MeshCloth};
    use crate::scene::Scene;
    let n = match mesh {
        PlateMesh::Grid(n) | PlateMesh::Irregular(n) => n,
    };
    let bending = match (mesh, warp_degrees) {
        (PlateMesh::Irregular(_), _) | (PlateMesh::Grid(_), 0.0) => bending,
        (PlateMesh::Grid(_), 90.0) => WarpWeft {
            warp: bending.weft,
            weft: bending.warp,
        },
        (PlateMesh::Grid(_), _) => {
            return Err(invalid(
                "warp_degrees",
                "0 or 90 on a grid, whose warp runs along its rows",
                warp_degrees,
            ))
        }
    };
    let table = [[-1.0, -1.0, -1.0], [PLATE_CLAMP + 1e-9, 1.0, 2.0]];
    let text = sheet_scene(n, table, 1.0 - PLATE_CLAMP, bending);
    let mut scene = Scene::from_toml(&text, std::path::Path::new("plate.toml"))?;
    if let PlateMesh::Irregular(rows) = mesh {
        // The sheet lies in the xy-plane hanging from y = 0; turn it into
        // the xz-plane, z from 0 to 1, u along the warp, v along the weft.
        let (sin, cos) = warp_degrees.to_radians().sin_cos();
        let flat = sheet::textured_irregular_sheet(1.0, rows, |[x, y]| {
            let z = -y;
            ([x, 0.0, z], [x * cos + z * sin, z * cos - x * sin])
        });
        let path = std::path::Path::new("plate.obj");
        let parsed = Mesh::parse(flat.as_bytes(), path, None, &|_| {
            Err("no external files".to_string())
        })?;
        scene.cloths[0].mesh = Some(MeshCloth {
            path: path.to_path_buf(),
            mesh_name: None,
            scale: 1.0,
            mesh: parsed,
        });
    }
    Ok(scene)
}

/// Half the side \[m\] of the square table a [`pedestal_drape`] sheet
/// rests on: a fifth of the sheet's side.
pub const PEDESTAL_HALF_SIDE: f64 = 0.1;

/// A unit-square sheet of `n × n` particles of [`MATERIAL_DENSITY`] and
/// `bending`, horizontal, held flat on a square table of half side
/// [`PEDESTAL_HALF_SIDE`] at its centre (every particle on it pinned) and
/// draping under its own weight to its static equilibrium: the mean drop
/// \[m\] of the midpoints of the two edges the warp runs to (`x = 0` and
/// `x = 1`) and of the two the weft runs to (`z = 0`, `z = 1`), and
/// whether the equilibrium converged.
pub fn pedestal_drape(n: usize, bending: WarpWeft) -> Result<([f64; 2], bool)> {
    use crate::scene::Scene;
    if !PLATE_ROWS.contains(&n) || n.is_multiple_of(2) {
        return Err(invalid(
            "n",
            &format!(
                "an odd number of rows from {} to {} (a particle at each edge's midpoint)",
                PLATE_ROWS.start(),
                PLATE_ROWS.end()
            ),
            n,
        ));
    }
    let (lo, hi) = (
        0.5 - PEDESTAL_HALF_SIDE - 1e-9,
        0.5 + PEDESTAL_HALF_SIDE + 1e-9,
    );
    let text = sheet_scene(n, [[lo, -1.0, lo], [hi, 1.0, hi]], 1.0, bending);
    let scene = Scene::from_toml(&text, std::path::Path::new("pedestal.toml"))?;
    let model = scene.model()?;
    let rest = super::equilibrium::equilibrium(&model, &scene.params)?;
    let mid = n / 2;
    let drop =
        |particles: [usize; 2]| particles.iter().map(|&p| -rest.positions[p].y).sum::<f64>() / 2.0;
    let warp = drop([mid * n, mid * n + n - 1]);
    let weft = drop([mid, (n - 1) * n + mid]);
    Ok(([warp, weft], rest.converged))
}

/// One discretisation of the clamped plate of [`plate_drop`] at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrapeRow {
    /// The discretisation.
    pub mesh: PlateMesh,
    /// Rows of particles across the unit square (`n`).
    pub rows: usize,
    /// Spacing between rows, `1 / (n − 1)` \[m\].
    pub spacing: f64,
    /// The free edge's mean drop over the overhang.
    pub drop: f64,
    /// Whether the equilibrium converged.
    pub converged: bool,
}

/// The rows a [`drape`] plate may have: 3 are the fewest with a bend,
/// 257 (`2⁸ + 1`) take about an hour.
pub const PLATE_ROWS: std::ops::RangeInclusive<usize> = 3..=257;

/// The clamped plate of [`plate_drop`] as a grid and as an irregular mesh
/// at each of `sizes` rows (grids first, each in the order given).
pub fn drape(sizes: &[usize]) -> Result<Vec<DrapeRow>> {
    if let Some(&n) = sizes.iter().find(|&&n| !PLATE_ROWS.contains(&n)) {
        return Err(invalid(
            "sizes",
            &format!("{} ≤ n ≤ {} rows", PLATE_ROWS.start(), PLATE_ROWS.end()),
            n,
        ));
    }
    let meshes = [
        PlateMesh::Grid as fn(usize) -> PlateMesh,
        PlateMesh::Irregular,
    ];
    let mut rows = Vec::new();
    for make in meshes {
        for &n in sizes {
            let (drop, converged) = plate_drop(make(n))?;
            rows.push(DrapeRow {
                mesh: make(n),
                rows: n,
                spacing: 1.0 / (n - 1) as f64,
                drop,
                converged,
            });
        }
    }
    Ok(rows)
}

/// The convergence order between three successive rows of one
/// discretisation whose spacings fall in a constant ratio `r` (as the
/// `2ᵏ + 1` rows of the defaults do, `r = 2`): `log(|d₁| / |d₂|) / log r`
/// for the differences `d₁ = drop(b) − drop(a)`, `d₂ = drop(c) − drop(b)`;
/// `None` where a difference is zero.
pub fn drape_order(a: &DrapeRow, b: &DrapeRow, c: &DrapeRow) -> Option<f64> {
    let (d1, d2) = ((b.drop - a.drop).abs(), (c.drop - b.drop).abs());
    (d1 > 0.0 && d2 > 0.0).then(|| (d1 / d2).ln() / (a.spacing / b.spacing).ln())
}
