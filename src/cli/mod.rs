//! Command-line parsing, dispatch and exit statuses.
//!
//! The options and exit statuses are a stable contract (documented in
//! `docs/cli.md`): scripts run parameter sweeps through them.

/// `print!` that hands a failed write back (`?`) instead of panicking: a
/// reader that stopped reading (`wgcloth scenes | head -1`) ends the
/// command quietly with [`EXIT_CLOSED_PIPE`] (see [`stdout_closed`]).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::say(format_args!($($arg)*))
    };
}

/// `println!` as [`out!`] writes.
macro_rules! outln {
    () => {
        $crate::cli::say(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::say(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprintln!` that never panics: a note to a closed stderr is lost, and
/// the exit status still tells the outcome.
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::cli::tell(format_args!($($arg)*), true)
    };
}

/// `eprint!` as [`note!`] writes.
macro_rules! note_part {
    ($($arg:tt)*) => {
        $crate::cli::tell(format_args!($($arg)*), false)
    };
}

mod backend;
mod batch;
mod bench;
mod chart;
mod interrupt;
mod output;
mod profile;
mod render;
mod run;
mod scenes;
mod summary;

use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use wgcloth::gpu::Timestamps;
use wgcloth::params::format_number;
use wgcloth::Integrator;

/// Frames per second of `render` (and of a character's poses in `run`)
/// unless `--fps` says otherwise or a step is longer than a frame (then
/// one step a frame).
const DEFAULT_FPS: f64 = 30.0;

/// Exit status of a run that succeeded.
const EXIT_OK: u8 = 0;
/// An output file could not be created or written, or another failure that
/// is neither the input's fault nor the simulation's.
const EXIT_FAILURE: u8 = 1;
/// The command line, the scene or a parameter was rejected, or the scene
/// or image needs more memory than the host or device has; nothing ran.
/// (clap uses the same status for its own usage errors.)
const EXIT_INVALID: u8 = 2;
/// The simulation blew up: it became non-finite or crossed a bound of the
/// divergence rule (`wgcloth::diagnostics::Divergence`); no output file was
/// written.
const EXIT_BLEW_UP: u8 = 3;
/// `--backend gpu` found no GPU adapter (or none matching `--adapter`), or
/// could not open one; nothing ran.
const EXIT_NO_ADAPTER: u8 = 4;
/// Ctrl-C or SIGTERM stopped `run` or `render` (128 + SIGINT, the shell's
/// convention): no partial file was left, no output of `run` was written.
const EXIT_INTERRUPTED: u8 = 130;
/// Standard output was a pipe its reader had closed (`| head -1`): the
/// command stopped quietly at its first line that could not be written,
/// with the status a tool killed by SIGPIPE reports (128 + 13), so that
/// `set -o pipefail` still sees an output that was not all read. Files
/// already committed are kept whole; none is left half written.
const EXIT_CLOSED_PIPE: u8 = 141;

#[derive(Parser, Debug)]
#[command(
    name = "wgcloth",
    version,
    about = "Mass-spring cloth simulator: explicit, implicit and semi-implicit integrators \
             on a CPU reference solver and a wgpu GPU solver",
    propagate_version = true
)]
struct Cli {
    /// With no command, `wgcloth` renders the `hanging` scene to
    /// `./out/hanging` (as `wgcloth render hanging --overwrite`).
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate a scene and print a summary of the final state.
    Run(RunArgs),
    /// List the built-in scenes.
    Scenes,
    /// Simulate a scene on the GPU and write each frame as a PNG.
    Render(RenderArgs),
    /// Measure accuracy against cost, or stability regions; write a CSV and
    /// an SVG chart and print a table.
    #[command(subcommand)]
    Bench(BenchCommand),
}

/// The measurements of `wgcloth bench`.
#[derive(Subcommand, Debug)]
enum BenchCommand {
    /// Error against a converged reference vs wall time, for every
    /// integrator, backend and a range of time steps (`accuracy.csv`,
    /// `accuracy.svg`).
    Accuracy(BenchAccuracyArgs),
    /// Stable or not over stretch stiffness × time step, per integrator
    /// (`stability.csv`, `stability.svg`).
    Stability(BenchStabilityArgs),
    /// Tip drop of clamped strips settled under their own weight against
    /// the heavy elastica, over Γ = ρ g L³ / B from 10⁻² to 10².
    Cantilever(BenchCantileverArgs),
    /// ASTM D1388's cantilever test on a simulated strip of a material:
    /// the overhang at which its tip meets the 41.5° line, the bending
    /// length and the rigidity it implies against the material's.
    Overhang(BenchOverhangArgs),
    /// Resolution independence of the linear bending model: the same
    /// material plate, clamped and sagging, as grids and irregular meshes
    /// of several resolutions at rest; the differences between
    /// resolutions and the order they fall at.
    Drape(BenchDrapeArgs),
}

/// The options of `wgcloth bench drape`.
#[derive(Args, Debug)]
struct BenchDrapeArgs {
    /// Rows of particles across the plate, comma-separated (each 3 to
    /// 257; `2ᵏ + 1` rows halve the spacing each time, which the order
    /// assumes). 65 takes minutes.
    #[arg(
        long,
        value_name = "N,N,…",
        value_delimiter = ',',
        default_values_t = [9, 17, 33],
        value_parser = parse_plate_rows,
        allow_hyphen_values = true
    )]
    sizes: Vec<usize>,

    /// Write the table as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,

    /// Write an SVG chart of the differences against the spacing to FILE.
    #[arg(long, value_name = "FILE.svg")]
    chart: Option<PathBuf>,
}

/// The options of `wgcloth bench overhang`.
#[derive(Args, Debug)]
struct BenchOverhangArgs {
    /// The material's areal density [kg/m²] (the default: a cotton
    /// shirting's ~0.12 kg/m²).
    // Negative numbers reach the library's check, which says what is
    // allowed under the option's name.
    #[arg(
        long,
        value_name = "KG_PER_M2",
        default_value_t = 0.12,
        value_parser = parse_number,
        allow_negative_numbers = true
    )]
    density: f64,

    /// The material's bending stiffness per unit width [N·m].
    #[arg(
        long,
        value_name = "N_M",
        default_value_t = 5e-6,
        value_parser = parse_number,
        allow_negative_numbers = true
    )]
    bending: f64,

    /// Cells along the strip's overhang (2 to 256).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 16,
        value_parser = parse_segments,
        allow_negative_numbers = true
    )]
    segments: usize,
}

/// The options of `wgcloth bench accuracy`.
#[derive(Args, Debug)]
struct BenchAccuracyArgs {
    /// A scene file (`*.toml`) or the name of a built-in scene.
    #[arg(value_name = "SCENE.toml | name", default_value = "hanging")]
    scene: String,

    /// The folder the CSV and SVG go to; created if missing.
    #[arg(long, value_name = "DIR", default_value = "out/bench")]
    out: PathBuf,

    /// A run of seconds: 9 × 9 particles, 5 samples, reference at dt / 64.
    #[arg(long)]
    quick: bool,

    /// Leave out the GPU rows even when an adapter is available.
    #[arg(long)]
    no_gpu: bool,

    /// Use the first GPU adapter whose name contains NAME
    /// (case-insensitive).
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
}

/// The options of `wgcloth bench stability`.
#[derive(Args, Debug)]
struct BenchStabilityArgs {
    /// The folder the CSV and SVG go to; created if missing.
    #[arg(long, value_name = "DIR", default_value = "out/bench")]
    out: PathBuf,

    /// A sweep of seconds: 9 × 9 particles, 0.5 s, at most 500 steps.
    #[arg(long)]
    quick: bool,

    /// Which solver sweeps the map: the CPU reference in f64, or the GPU
    /// in f32, the runs of one time step stepped together as one batch of
    /// cloths.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,

    /// With `--backend gpu`: use the first GPU adapter whose name contains
    /// NAME (case-insensitive).
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
}

/// The options of `wgcloth bench cantilever`.
#[derive(Args, Debug)]
struct BenchCantileverArgs {
    /// A run of seconds: 8 segments, one Γ a decade.
    #[arg(long)]
    quick: bool,

    /// Write the table as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,

    /// Write an SVG chart of both curves to FILE.
    #[arg(long, value_name = "FILE.svg")]
    chart: Option<PathBuf>,
}

/// The options of `wgcloth render`.
#[derive(Args, Debug)]
struct RenderArgs {
    /// A scene file (`*.toml`) or the name of a built-in scene.
    #[arg(value_name = "SCENE.toml | name")]
    scene: String,

    /// Frames to write (N ≥ 1); frame k shows the cloth at t = k / FPS.
    /// Default: enough to cover `--seconds`, else the scene's
    /// `[simulation] duration`.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "seconds",
        value_parser = parse_frames,
        allow_negative_numbers = true
    )]
    frames: Option<u32>,

    /// Simulated time to render [s]: frames up to the first at or after
    /// T (frame 0 is the start). Default: the scene's `[simulation]
    /// duration`.
    #[arg(
        long,
        value_name = "T",
        value_parser = parse_seconds,
        allow_hyphen_values = true
    )]
    seconds: Option<f64>,

    /// Frames per second of simulated time: each frame advances
    /// ceil((1/F) / dt) steps (F ≤ 1/dt: a frame is at least a step).
    /// Default: 30, or 1/dt if less.
    #[arg(
        long,
        value_name = "F",
        value_parser = render::parse_fps,
        allow_hyphen_values = true
    )]
    fps: Option<f64>,

    /// Image size in pixels.
    // Hyphen values reach the parser, so `-640x480` is told what is allowed
    // rather than taken for an unknown option.
    #[arg(
        long,
        value_name = "WxH",
        default_value = "640x480",
        value_parser = render::parse_size,
        allow_hyphen_values = true
    )]
    size: (u32, u32),

    /// The folder the frames go to (`frame_00000.png`, …); created if
    /// missing. Default: `out/<scene>` (the scene's name, or its file's
    /// stem).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,

    /// Remove the `frame_*.png` files already in DIR first (without it,
    /// such files are refused rather than mixed with the new frames).
    #[arg(long)]
    overwrite: bool,

    /// Colour the cloth (still lit) by stretch strain instead of red/orange:
    /// per triangle, its largest (l − L) / L, blue at ≤ 0, green, red at
    /// and above `max_stretch − 1` of the stretch springs (10 % without).
    #[arg(long)]
    strain: bool,

    /// Time integrator, overriding the scene's `[simulation] integrator`.
    #[arg(long, value_enum)]
    integrator: Option<IntegratorArg>,

    /// Use the first GPU adapter whose name contains NAME
    /// (case-insensitive). Default: `WGPU_ADAPTER_NAME`, else the system's
    /// high-performance adapter.
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,

    /// How a step is recorded, as `wgcloth run --step-path` (the results
    /// are the same bits).
    #[arg(long, value_enum, default_value_t = StepPathArg::Auto)]
    step_path: StepPathArg,
}

impl RenderArgs {
    /// The job `wgcloth` with no arguments runs.
    fn default_job() -> RenderArgs {
        RenderArgs {
            scene: "hanging".to_string(),
            frames: None,
            seconds: None,
            fps: None,
            size: (640, 480),
            out: None,
            overwrite: true,
            strain: false,
            integrator: None,
            adapter: None,
            step_path: StepPathArg::Auto,
        }
    }
}

/// The options of `wgcloth run`.
#[derive(Args, Debug)]
struct RunArgs {
    /// A scene file (`*.toml`) or the name of a built-in scene
    /// (`wgcloth scenes` lists them).
    #[arg(value_name = "SCENE.toml | name")]
    scene: String,

    /// Time integrator, overriding the scene's `[simulation] integrator`.
    #[arg(long, value_enum)]
    integrator: Option<IntegratorArg>,

    /// Which solver runs the simulation.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,

    /// With `--backend gpu`: use the first GPU adapter whose name contains
    /// NAME (case-insensitive). Default: the adapter named by the
    /// `WGPU_ADAPTER_NAME` environment variable, else the system's
    /// high-performance adapter.
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,

    /// Number of steps to run (0 ≤ N ≤ 1e12, the cap `--seconds` has too).
    /// Default: the scene's `[simulation] duration`, converted like
    /// `--seconds`.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "seconds",
        value_parser = parse_steps,
        allow_negative_numbers = true
    )]
    steps: Option<u64>,

    /// Simulated time to run [s]: `ceil(T / dt)` steps, so the run covers at
    /// least T (a quotient within 1e-9 of a whole number counts as that
    /// number: 1 s at dt = 0.01 s is 100 steps).
    #[arg(
        long,
        value_name = "T",
        value_parser = parse_seconds,
        allow_hyphen_values = true
    )]
    seconds: Option<f64>,

    /// Time step in seconds, overriding the scene's `[simulation] dt` (0 < DT ≤ 1).
    #[arg(long, value_name = "DT", value_parser = parse_dt, allow_hyphen_values = true)]
    dt: Option<f64>,

    /// With a scene's `[character]`: its pose is set every
    /// ceil((1/F) / dt) steps, as `wgcloth render --fps F` sets it each
    /// frame, so both commands move the cloth alike (F ≤ 1/dt; default 30,
    /// render's, or 1/dt if less). Refused for a scene without a character.
    #[arg(
        long,
        value_name = "F",
        value_parser = render::parse_fps,
        allow_hyphen_values = true
    )]
    fps: Option<f64>,

    /// Write the final positions (metres) to FILE: one line `x y z` per particle,
    /// in particle order, every number exact as an f64.
    #[arg(long, value_name = "FILE")]
    positions_out: Option<PathBuf>,

    /// Write the final positions (metres) of the scene's render meshes'
    /// vertices to FILE: one line `x y z` per vertex, each mesh in the
    /// order of its file, the meshes in the scene's order (`[cloth]
    /// render_mesh` first). Refused for a scene without one.
    #[arg(long, value_name = "FILE")]
    render_mesh_out: Option<PathBuf>,

    /// Write a CSV trace to FILE: header `step,time,particle,x,y,z,vx,vy,vz`,
    /// one row per particle at step 0, every K-th step and the last step.
    #[arg(long, value_name = "FILE.csv")]
    trace_out: Option<PathBuf>,

    /// Trace every K-th step (K ≥ 1); the last step is traced whatever K.
    #[arg(
        long,
        value_name = "K",
        default_value_t = 1,
        requires = "trace_out",
        value_parser = parse_trace_every,
        allow_negative_numbers = true
    )]
    trace_every: u64,

    /// Arithmetic of the CPU solver: f64 (the reference) or f32 (what the
    /// GPU computes). Default: f64 on the CPU; the GPU computes in f32 only
    /// and refuses `--precision f64`.
    #[arg(long, value_enum)]
    precision: Option<Precision>,

    /// Also print the passes each step records (kernel, dispatches per
    /// step, invocations each) and a line `dispatches per step: N`, so that
    /// what the scene does not need is seen to be skipped (GPU backend).
    #[arg(long, short)]
    verbose: bool,

    /// With `--backend gpu`: time every dispatch of the run with timestamp
    /// queries and print, per kernel, the median GPU time per step, its
    /// share, the bytes it reads and writes per step and the bandwidth
    /// achieved (slower: each batch's timestamps are read back).
    #[arg(long)]
    profile: bool,

    /// Limits how `--profile` times kernels, to test what a lesser adapter
    /// prints (default: the best the adapter has).
    #[arg(long, value_enum, requires = "profile", hide = true)]
    profile_timestamps: Option<TimestampsArg>,

    /// With `--backend gpu`: step N copies of the scene's cloth together in
    /// one batch (1 ≤ N ≤ 65535). The outputs and the summary's state are
    /// copy 0's, the same as `--batch 1`'s; the summary adds cloth-steps
    /// per second and the batch's dispatches per step.
    #[arg(long, value_name = "N", value_parser = parse_copies, allow_negative_numbers = true)]
    batch: Option<u32>,

    /// With `--backend gpu`: how a step is recorded — the solver's own
    /// choice (`auto`), one workgroup per cloth (`workgroup`: refused for a
    /// cloth it cannot step, naming the limit) or a dispatch per phase
    /// (`multi-dispatch`: what `--profile` breaks down kernel by kernel).
    /// The results are the same bits.
    #[arg(long, value_enum, default_value_t = StepPathArg::Auto)]
    step_path: StepPathArg,
}

/// `--step-path`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum StepPathArg {
    /// The solver's automatic choice.
    Auto,
    /// One workgroup per cloth.
    Workgroup,
    /// A dispatch per phase of the step.
    MultiDispatch,
}

impl StepPathArg {
    /// The path forced, `None` for the automatic choice.
    fn forced(self) -> Option<wgcloth::gpu::StepPath> {
        match self {
            StepPathArg::Auto => None,
            StepPathArg::Workgroup => Some(wgcloth::gpu::StepPath::Workgroup),
            StepPathArg::MultiDispatch => Some(wgcloth::gpu::StepPath::MultiDispatch),
        }
    }
}

/// `--profile-timestamps`: the profiler's timing, best first.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum TimestampsArg {
    /// Timestamps between dispatches inside one compute pass.
    InsidePasses,
    /// A compute pass per dispatch, timestamps at its start and end.
    PassBoundaries,
    /// No timestamps, as on an adapter without timestamp queries.
    None,
}

impl From<TimestampsArg> for Timestamps {
    fn from(t: TimestampsArg) -> Self {
        match t {
            TimestampsArg::InsidePasses => Timestamps::InsidePasses,
            TimestampsArg::PassBoundaries => Timestamps::PassBoundaries,
            TimestampsArg::None => Timestamps::None,
        }
    }
}

/// The integrators, as the CLI spells them (the scene-file spelling).
#[derive(Clone, Copy, Debug, ValueEnum)]
enum IntegratorArg {
    /// Symplectic Euler with Provot's fix-up.
    Explicit,
    /// Baraff–Witkin backward Euler, filtered PCG.
    Implicit,
    /// Desbrun's constant filter with fix-up.
    SemiImplicit,
}

impl From<IntegratorArg> for Integrator {
    fn from(i: IntegratorArg) -> Self {
        match i {
            IntegratorArg::Explicit => Integrator::Explicit,
            IntegratorArg::Implicit => Integrator::Implicit,
            IntegratorArg::SemiImplicit => Integrator::SemiImplicit,
        }
    }
}

/// Solver backends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// The CPU reference solver, in f64 or f32.
    Cpu,
    /// The wgpu compute-shader solver, in f32.
    Gpu,
}

/// Scalar type of the solver.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Precision {
    /// Double precision: the ground truth.
    F64,
    /// Single precision: the GPU's arithmetic.
    F32,
}

/// `--seconds`: a finite, non-negative number of seconds.
fn parse_seconds(s: &str) -> Result<f64, String> {
    let allowed = "must be a finite number ≥ 0 of seconds";
    let t: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{allowed}, got `{s}`"))?;
    if t.is_finite() && t >= 0.0 {
        Ok(t)
    } else {
        Err(format!("{allowed}, got {}", format_number(t)))
    }
}

/// `--dt`: a number; its range is `Params::validate`'s, which says it with
/// the scene's other parameters.
fn parse_dt(s: &str) -> Result<f64, String> {
    s.trim()
        .parse()
        .map_err(|_| "must be a number of seconds, 0 < DT ≤ 1".to_string())
}

/// A whole number in `range`; else "must be {allowed}", for a negative
/// number or a fraction as for a number out of range.
fn parse_whole(s: &str, range: RangeInclusive<u64>, allowed: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if range.contains(&n) => Ok(n),
        _ => Err(format!("must be {allowed}")),
    }
}

/// A number whose range the library checks under the option's name
/// (`bench overhang`'s `--density`, `--bending`).
fn parse_number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("must be a number, got `{s}`"))
}

/// `bench overhang --segments`: [`OVERHANG_SEGMENTS`].
///
/// [`OVERHANG_SEGMENTS`]: wgcloth::evidence::cantilever::OVERHANG_SEGMENTS
fn parse_segments(s: &str) -> Result<usize, String> {
    parse_count(
        s,
        wgcloth::evidence::cantilever::OVERHANG_SEGMENTS,
        "a whole number of cells along the strip,",
    )
}

/// One of `bench drape --sizes`: [`PLATE_ROWS`].
///
/// [`PLATE_ROWS`]: wgcloth::evidence::cantilever::PLATE_ROWS
fn parse_plate_rows(s: &str) -> Result<usize, String> {
    parse_count(
        s,
        wgcloth::evidence::cantilever::PLATE_ROWS,
        "a comma-separated list of whole numbers of rows, each",
    )
}

/// A whole number in the library's `range`, refused as "must be {what}
/// {start} ≤ N ≤ {end}".
fn parse_count(s: &str, range: RangeInclusive<usize>, what: &str) -> Result<usize, String> {
    let (start, end) = (*range.start(), *range.end());
    let allowed = format!("{what} {start} ≤ N ≤ {end}");
    let n = parse_whole(s, start as u64..=end as u64, &allowed)?;
    usize::try_from(n).map_err(|_| format!("must be {allowed}"))
}

/// `--steps`: at most [`run::MAX_STEPS`], the cap `--seconds` and the
/// scene's duration are held to.
fn parse_steps(s: &str) -> Result<u64, String> {
    parse_whole(
        s,
        0..=run::MAX_STEPS,
        &format!(
            "a whole number of steps, 0 ≤ N ≤ {:e} (the cap --seconds has too)",
            run::MAX_STEPS
        ),
    )
}

/// `--trace-every`: every K-th step, K ≥ 1.
fn parse_trace_every(s: &str) -> Result<u64, String> {
    parse_whole(s, 1..=u64::MAX, "a whole number of steps ≥ 1")
}

/// `--batch`: at least one copy, at most [`batch::MAX_COPIES`].
fn parse_copies(s: &str) -> Result<u32, String> {
    let allowed = format!(
        "a whole number of copies, 1 ≤ N ≤ {} (a workgroup per cloth in one dispatch)",
        batch::MAX_COPIES
    );
    let n = parse_whole(s, 1..=batch::MAX_COPIES, &allowed)?;
    u32::try_from(n).map_err(|_| format!("must be {allowed}"))
}

/// `--frames`: at least one frame (none would write nothing and still
/// succeed).
fn parse_frames(s: &str) -> Result<u32, String> {
    let max = u32::MAX;
    let allowed = format!("a whole number of frames, 1 ≤ N ≤ {max} (0 frames would write nothing)");
    let n = parse_whole(s, 1..=u64::from(max), &allowed)?;
    u32::try_from(n).map_err(|_| format!("must be {allowed}"))
}

/// A command-line value that clap's parser could not judge alone (it needs
/// the scene, e.g. the step count `--seconds` implies). Exit status
/// [`EXIT_INVALID`].
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct UsageError(String);

/// Standard output could not take a line because its reader is gone (a
/// closed pipe): the command ends quietly with [`EXIT_CLOSED_PIPE`].
#[derive(Debug, thiserror::Error)]
#[error("standard output was closed by its reader")]
struct StdoutClosed;

/// Writes to standard output (what [`out!`] and [`outln!`] expand to). A
/// closed pipe is [`StdoutClosed`]; any other failure (a full disk behind
/// a redirection) an error naming standard output.
fn say(args: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    match stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("writing to standard output")),
    }
}

/// Writes to standard error (what [`note!`] and [`note_part!`] expand to),
/// then a newline if `line`; a failure is ignored.
fn tell(args: std::fmt::Arguments<'_>, line: bool) {
    use std::io::Write as _;
    let mut stderr = std::io::stderr().lock();
    let _ = stderr.write_fmt(args);
    if line {
        let _ = stderr.write_all(b"\n");
    }
    let _ = stderr.flush();
}

/// Parses the command line, runs it and maps the outcome to an exit status.
pub fn main() -> ExitCode {
    // Usage errors exit with status 2 here, `--help` and `--version` with 0.
    let cli = Cli::parse();
    let outcome = match cli.command {
        Some(Command::Run(args)) => run::run(&args),
        Some(Command::Scenes) => scenes::list(),
        Some(Command::Render(args)) => render::render(&args),
        Some(Command::Bench(BenchCommand::Accuracy(args))) => bench::accuracy(&args),
        Some(Command::Bench(BenchCommand::Stability(args))) => bench::stability(&args),
        Some(Command::Bench(BenchCommand::Cantilever(args))) => bench::cantilever(&args),
        Some(Command::Bench(BenchCommand::Overhang(args))) => bench::overhang(&args),
        Some(Command::Bench(BenchCommand::Drape(args))) => bench::drape(&args),
        None => render::render(&RenderArgs::default_job()),
    };
    match outcome {
        Ok(()) => ExitCode::from(EXIT_OK),
        Err(err) if err.chain().any(|c| c.is::<StdoutClosed>()) => ExitCode::from(EXIT_CLOSED_PIPE),
        Err(err) => {
            note!("error: {err:#}");
            ExitCode::from(exit_status(&err))
        }
    }
}

/// The documented exit status for an error.
fn exit_status(err: &anyhow::Error) -> u8 {
    for cause in err.chain() {
        if cause.is::<UsageError>() {
            return EXIT_INVALID;
        }
        if let Some(e) = cause.downcast_ref::<wgcloth::Error>() {
            return library_status(e);
        }
    }
    EXIT_FAILURE
}

/// The documented exit status for a library error.
fn library_status(e: &wgcloth::Error) -> u8 {
    match e {
        // A cloth of a batch fails as a lone cloth would.
        wgcloth::Error::InBatch { source, .. } => library_status(source),
        wgcloth::Error::NonFinite { .. } | wgcloth::Error::Diverged { .. } => EXIT_BLEW_UP,
        wgcloth::Error::NoAdapter { .. } | wgcloth::Error::DeviceUnavailable { .. } => {
            EXIT_NO_ADAPTER
        }
        wgcloth::Error::Interrupted => EXIT_INTERRUPTED,
        // A cloth or image too big for the device or the host's memory is
        // the input's fault.
        wgcloth::Error::InvalidParameter { .. }
        | wgcloth::Error::Scene { .. }
        | wgcloth::Error::Mesh { .. }
        | wgcloth::Error::UnknownScene { .. }
        | wgcloth::Error::DeviceLimit { .. }
        | wgcloth::Error::NotAFile { .. }
        | wgcloth::Error::OutOfMemory { .. } => EXIT_INVALID,
        _ => EXIT_FAILURE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn clap_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn integrator_spellings_match_the_library() {
        for arg in IntegratorArg::value_variants() {
            let name = arg.to_possible_value().expect("no skipped variants");
            assert_eq!(name.get_name(), Integrator::from(*arg).as_str());
        }
    }

    #[test]
    fn message_does_not_repeat_a_cause_its_parent_already_shows() {
        let io = wgcloth::Error::Io {
            path: "out.txt".into(),
            source: std::io::Error::other("disk full"),
        };
        let err = anyhow::Error::new(io).context("writing the trace");
        assert_eq!(format!("{err:#}"), "writing the trace: out.txt: disk full");
    }

    #[test]
    fn counts_say_what_is_allowed() {
        assert_eq!(parse_steps("0"), Ok(0));
        assert_eq!(parse_steps(&run::MAX_STEPS.to_string()), Ok(run::MAX_STEPS));
        for bad in ["-5", "1.5", "abc", "", "1000000000001"] {
            let e = parse_steps(bad).expect_err(bad);
            assert!(
                e.contains("whole number of steps") && e.contains("1e12"),
                "{bad}: {e}"
            );
        }
        assert_eq!(parse_trace_every("1"), Ok(1));
        for bad in ["0", "-1"] {
            let e = parse_trace_every(bad).expect_err(bad);
            assert!(e.contains("≥ 1"), "{bad}: {e}");
        }
        assert_eq!(parse_frames("1"), Ok(1));
        assert_eq!(parse_frames(&u32::MAX.to_string()), Ok(u32::MAX));
        for bad in ["0", "-1", "4294967296"] {
            let e = parse_frames(bad).expect_err(bad);
            assert!(e.contains("1 ≤ N"), "{bad}: {e}");
        }
    }

    #[test]
    fn seconds_must_be_finite_and_non_negative() {
        assert_eq!(parse_seconds("1.5"), Ok(1.5));
        assert_eq!(parse_seconds("0"), Ok(0.0));
        for bad in ["-1", "inf", "NaN", "abc"] {
            assert!(parse_seconds(bad).is_err(), "{bad} accepted");
        }
        assert_eq!(
            parse_seconds("-1e-300"),
            Err("must be a finite number ≥ 0 of seconds, got -1e-300".to_string())
        );
    }
}
