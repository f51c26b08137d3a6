//! The agreement policy every GPU test compares under: how closely the
//! device must reproduce the `f32` CPU mirror on this adapter.
//!
//! - **Bits** where the adapter rounds every operation as the mirror does
//!   (no fused multiply-add, correctly rounded `/` and `sqrt`, subnormals
//!   kept): lavapipe and SwiftShader. Every word is compared exactly, and
//!   long runs are compared after every step count without re-seeding.
//! - **Bounded** elsewhere (a hardware GPU may fuse `a·b + c`, which WGSL
//!   allows, and rounds `/` and `sqrt` within 2.5 ulp, which Vulkan
//!   allows): each word within the bounds below, whose derivations stand
//!   beside them; long runs re-seeded, so that rounding never compounds
//!   (before each step the mirror takes the device's state, one step runs
//!   on each, and the step is compared).
//!
//! The policy is the probe's verdict (a tiny kernel measures the four
//! properties), or what `WGCLOTH_AGREEMENT=bits|bounded` forces (so the
//! bounded tier runs on lavapipe in CI too); it is printed once per test
//! binary.

use std::sync::OnceLock;

use wgcloth::cpu::twins::System;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::Vec3;
use wgcloth::gpu::GpuSolver;
use wgcloth::real::Real;

use super::gpu;

/// How the GPU must agree with the mirror on this adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Policy {
    /// Every word equal.
    Bits,
    /// Every word within a [`Bound`]; long runs re-seeded each step.
    Bounded,
}

/// What the probe kernel measured of the adapter's arithmetic.
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    /// `a·b + c` rounds once (the compiler fused it).
    pub fuses: bool,
    /// Every sampled quotient is the correctly rounded one.
    pub division_exact: bool,
    /// Every sampled square root is the correctly rounded one.
    pub sqrt_exact: bool,
    /// A subnormal product came back as zero.
    pub flushes_subnormals: bool,
}

impl Probe {
    /// Whether the adapter rounds every operation as the mirror does.
    pub fn rounds_like_the_mirror(&self) -> bool {
        !self.fuses && self.division_exact && self.sqrt_exact && !self.flushes_subnormals
    }
}

/// The environment variable that forces a policy.
pub const POLICY_VAR: &str = "WGCLOTH_AGREEMENT";

/// The policy of this test binary: forced by [`POLICY_VAR`], else the
/// probe's verdict. Printed once.
pub fn policy() -> Policy {
    static POLICY: OnceLock<Policy> = OnceLock::new();
    *POLICY.get_or_init(|| {
        let probe = probe();
        let forced = std::env::var(POLICY_VAR).ok().filter(|v| !v.is_empty());
        let policy = match forced.as_deref() {
            Some("bits") => Policy::Bits,
            Some("bounded") => Policy::Bounded,
            None => {
                if probe.rounds_like_the_mirror() {
                    Policy::Bits
                } else {
                    Policy::Bounded
                }
            }
            Some(other) => panic!("{POLICY_VAR}={other}: expected bits or bounded"),
        };
        eprintln!(
            "agreement: {policy:?}{} on {} (probe: {probe:?})",
            if forced.is_some() { ", forced" } else { "" },
            gpu().describe()
        );
        policy
    })
}

/// Samples of `/` and `sqrt` the probe checks.
const PROBE_SAMPLES: usize = 1024;
/// Inputs before the samples (see `probe.wgsl`).
const PROBE_HEAD: usize = 5;

/// The probe's inputs: the fusing triple, the subnormal and one, then
/// numerator–denominator pairs and radicands spread over many binades
/// (a fixed linear congruential sequence, so every run probes the same).
fn probe_inputs() -> Vec<f32> {
    // a = b = 1 + 2⁻¹²: a·b = 1 + 2⁻¹¹ + 2⁻²⁴ exactly, which rounds (a tie,
    // to even) to 1 + 2⁻¹¹; with c = −(1 + 2⁻¹¹) the unfused sum is 0 and
    // the fused one 2⁻²⁴.
    let a = 1.0 + f32::powi(2.0, -12);
    let c = -(1.0 + f32::powi(2.0, -11));
    let subnormal = f32::from_bits(0x0040_0000); // 2⁻¹²⁷
    let mut out = vec![a, a, c, subnormal, 1.0];
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        // A mantissa in [1, 2) and an exponent in [−20, 20).
        let mantissa = 1.0 + (state >> 40) as f32 / (1u64 << 24) as f32;
        mantissa * f32::powi(2.0, ((state >> 32) % 40) as i32 - 20)
    };
    for _ in 0..2 * PROBE_SAMPLES {
        out.push(next());
    }
    for _ in 0..PROBE_SAMPLES {
        out.push(next());
    }
    out
}

/// Runs the probe kernel once per test binary.
pub fn probe() -> Probe {
    static PROBE: OnceLock<Probe> = OnceLock::new();
    *PROBE.get_or_init(|| {
        let inputs = probe_inputs();
        let out = run_probe(&inputs);
        let pairs = &inputs[PROBE_HEAD..PROBE_HEAD + 2 * PROBE_SAMPLES];
        let radicands = &inputs[PROBE_HEAD + 2 * PROBE_SAMPLES..];
        Probe {
            fuses: out[0] != inputs[0] * inputs[1] + inputs[2],
            division_exact: (0..PROBE_SAMPLES)
                .all(|k| out[2 + k].to_bits() == (pairs[2 * k] / pairs[2 * k + 1]).to_bits()),
            sqrt_exact: (0..PROBE_SAMPLES)
                .all(|k| out[2 + PROBE_SAMPLES + k].to_bits() == radicands[k].sqrt().to_bits()),
            flushes_subnormals: out[1] == 0.0,
        }
    })
}

/// Dispatches `probe.wgsl` over `inputs` and reads its outputs back.
fn run_probe(inputs: &[f32]) -> Vec<f32> {
    use wgpu::util::DeviceExt;
    let ctx = gpu();
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("agreement.probe"),
        source: wgpu::ShaderSource::Wgsl(include_str!("probe.wgsl").into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("agreement.probe"),
        layout: None,
        module: &module,
        entry_point: Some("probe"),
        compilation_options: Default::default(),
        cache: None,
    });
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("agreement.inputs"),
        contents: bytemuck::cast_slice(inputs),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let bytes = ((2 + 2 * PROBE_SAMPLES) * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("agreement.outputs"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("agreement.readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("agreement.probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(PROBE_SAMPLES.div_ceil(64) as u32, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, bytes);
    ctx.queue.submit([encoder.finish()]);
    let slice = readback.slice(..);
    let (tx, rx) = flume::bounded(1);
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .unwrap_or_else(|e| panic!("the probe did not finish: {e}"));
    rx.recv()
        .unwrap_or_else(|e| panic!("the probe's read-back: {e}"))
        .unwrap_or_else(|e| panic!("the probe's read-back: {e}"));
    let view = slice
        .get_mapped_range()
        .unwrap_or_else(|e| panic!("the probe's read-back: {e}"));
    bytemuck::cast_slice(&view).to_vec()
}

/// The unit roundoff of `f32`, 2⁻²⁴: one correctly rounded operation's
/// largest relative error.
pub const U: f64 = 1.0 / 16_777_216.0;

/// How far one word of the device's output may be from the mirror's under
/// the bounded policy, and how far the words may be on average.
///
/// For word `k` with mirror value `c` and device value `g`, over words
/// whose largest mirror magnitude is `S` (the scale of the quantity: a
/// buffer section, or one state array):
///
/// `|g − c| ≤ ulps · ulp(m) + rel · U · S`, `m = max(|g|, |c|, S · FLOOR)`
///
/// and `sqrt(mean((g − c)² / unit²)) ≤ rms_ulps`, `unit = ulp(m) + rel ·
/// U · S / max(ulps, 1)` (the word's bound over its ulps). The first is the
/// worst case a legal adapter can reach; the second says that such worst
/// cases are rare, so a systematic error of a few ulps in every word (a
/// coefficient off by 10⁻³, a damping term misplaced) fails it while the
/// scattered ulps of fused products pass.
#[derive(Clone, Copy, Debug)]
pub struct Bound {
    /// Ulps of the word's own magnitude.
    pub ulps: f64,
    /// Multiples of [`U`] times the scale `S`.
    pub rel: f64,
    /// The root mean square of the differences, in each word's unit (its
    /// ulp, plus its share of the scale term where `rel` admits one).
    pub rms_ulps: f64,
    /// The systematic relative drift of re-seeded steps' increments
    /// admitted besides their scatter (see [`Drift`]); `None`: not checked.
    pub drift: Option<f64>,
}

/// Words below this share of their scale are measured in ulps of
/// `S · FLOOR`: their rounding comes from terms of the scale's size that
/// cancelled (a net force of opposing springs), not from their own.
pub const FLOOR: f64 = 1.0 / 1024.0;

/// One kernel's output words against its twin's, from the same input
/// words. `ulps`: the final rounding (½ ulp) plus a division or square
/// root on the word's path, which Vulkan lets differ by 2.5 ulp, rounded
/// up to 4. `rel`: each product the device may fuse rounds once less, a
/// difference of at most `U` times the product, which is at most the
/// scale of the quantity (a spring's force beside the net force, a
/// neighbour's velocity beside the particle's); the longest chains in the
/// kernels (a 3 × 3 block product summed over eight neighbours, then the
/// filter and the preconditioner) hold fewer than 64 such products. `rms`,
/// in units of a quarter of each word's bound (an ulp plus 16 `U S`):
/// scattered differences of a unit in half the words give 0.7; 2 admits
/// twice that everywhere, while an error of half the bound in every word
/// fails.
pub const KERNEL: Bound = Bound {
    ulps: 4.0,
    rel: 64.0,
    rms_ulps: 2.0,
    drift: Some(DRIFT_SYSTEMATIC),
};

/// One step's state (positions, velocities) against the mirror's step from
/// the same state, each word in its unit (`U` times the magnitudes summed
/// into it, see [`check_step_state`]; `rel` is not used there). `ulps`:
/// each operation the device may round otherwise (a product fused, a
/// quotient or square root within 2.5 ulp) moves a word by at most a unit,
/// and no word of a step sits at the end of more than 64 such operations
/// whose terms reach its full magnitude (a spring's length and force, its
/// gather over twelve springs, the integration, a dozen fix-up passes of
/// a few each). `rms_ulps`: those operations' differences are
/// independent, so they add in quadrature: √64 = 8 units where every one
/// of them differs by a unit (measured: 4.6 over a small cloth's fix-up
/// on an NVIDIA H200, whose quotients and roots are not correctly
/// rounded), while an error of more than 8 units in every word fails.
pub const STEP: Bound = Bound {
    ulps: 64.0,
    rel: 0.0,
    rms_ulps: 8.0,
    drift: Some(DRIFT_SYSTEMATIC),
};

/// The condition number of the implicit step's preconditioned system on
/// the tests' cloths, bounded above: with the block-diagonal
/// preconditioner its eigenvalues lie in [1, 1 + 2 Σ dt² k / m] (Gershgorin
/// on the scaled rows), and the stiffest test cloth (500 N/m stretch, 100
/// shear, 5 bend at 1/120 s, 1/221 kg particles, four springs of each
/// kind) gives 1 + 2 · 4 · (7.7 + 1.5 + 0.1) ≈ 75.
pub const CG_CONDITION: f64 = 100.0;

/// One implicit step against the mirror's from the same state, CG run to
/// relative `tolerance` on both: two answers that each leave a residual
/// below `tolerance` of the right-hand side differ by at most twice that
/// times the condition number, relative to the answer, which is at most
/// a velocity's magnitude (`|v| + dt F / m`, the unit's; so `ulps` adds
/// `2 · tolerance · CG_CONDITION / U` units). The
/// scatter is then the tolerance's, not rounding's, and the two answers'
/// last iterations need not lean either way: neither the root mean square
/// nor the drift is checked.
pub fn implicit_step(tolerance: f64) -> Bound {
    Bound {
        ulps: STEP.ulps + 2.0 * tolerance * CG_CONDITION / U,
        rms_ulps: f64::INFINITY,
        drift: None,
        ..STEP
    }
}

/// CG iterations a step of the device may take more or fewer than the
/// mirror's from the same state, under the bounded policy: CG's residual
/// falls by a roughly constant factor per iteration, so rounding that
/// moves it by a few ulps moves the crossing of the tolerance by at most
/// one iteration, unless two crossings are that close, which a second
/// allows.
pub const CG_ITERATION_MARGIN: u32 = 2;

/// [`CG_ITERATION_MARGIN`] under the bounded policy, 0 under bits.
pub fn cg_iteration_margin() -> u32 {
    match policy() {
        Policy::Bits => 0,
        Policy::Bounded => CG_ITERATION_MARGIN,
    }
}

/// Steps by which the device's blow-up may come before or after the
/// mirror's under the bounded policy: a state growing by a factor per
/// step reaches infinity a step earlier or later only if rounding moved
/// it across that step's threshold, which a relative change of a few
/// ulps does for at most one step.
pub const BLOW_UP_MARGIN: u64 = 1;

/// Panics unless the device's blow-up at `step` is the mirror's at
/// `mirror_step`: the same step under bits, within [`BLOW_UP_MARGIN`]
/// under bounds.
pub fn assert_blow_up_step(what: &str, step: u64, mirror_step: u64) {
    let margin = match policy() {
        Policy::Bits => 0,
        Policy::Bounded => BLOW_UP_MARGIN,
    };
    assert!(
        step.abs_diff(mirror_step) <= margin,
        "{what}: the GPU blew up at step {step}, the mirror at {mirror_step} (margin {margin})"
    );
}

/// The bound of one step under `params`' integrator: [`implicit_step`] at
/// its CG tolerance, else [`STEP`].
pub fn step_bound(params: &wgcloth::Params) -> Bound {
    step_bound_of(params.integrator, params.implicit.tolerance)
}

/// [`step_bound`] of `integrator` at CG `tolerance`.
pub fn step_bound_of(integrator: wgcloth::params::Integrator, tolerance: f64) -> Bound {
    use wgcloth::params::Integrator;
    match integrator {
        Integrator::Implicit => implicit_step(tolerance),
        Integrator::SemiImplicit | Integrator::Explicit => STEP,
    }
}

/// Checks `gpu` against `cpu` word by word under `bound`; the error names
/// the worst word and both values.
pub fn check_values(what: &str, gpu: &[f32], cpu: &[f32], bound: &Bound) -> Result<(), String> {
    check_values_with(what, gpu, cpu, largest(cpu), bound, |_| 0.0)
}

/// [`check_values`] with the scale `S` given and word `k`'s spacing at
/// least `floor(k)`: a word computed from others divided by a small
/// number (a velocity `Δx / dt`) is as exact as those others, measured in
/// their spacing so divided.
pub fn check_values_with(
    what: &str,
    gpu: &[f32],
    cpu: &[f32],
    scale: f64,
    bound: &Bound,
    floor: impl Fn(usize) -> f64,
) -> Result<(), String> {
    if gpu.len() != cpu.len() {
        return Err(format!(
            "{what}: {} words, the mirror {}",
            gpu.len(),
            cpu.len()
        ));
    }
    let mut sum_sq = 0.0;
    let mut worst: Option<(f64, usize, f64)> = None;
    for (k, (&g, &c)) in gpu.iter().zip(cpu).enumerate() {
        if !g.is_finite() || !c.is_finite() {
            if g.to_bits() != c.to_bits() && !(g.is_nan() && c.is_nan()) {
                return Err(format!("{what}: word {k}: GPU {g:e}, mirror {c:e}"));
            }
            continue;
        }
        let (g64, c64) = (f64::from(g), f64::from(c));
        let m = g64.abs().max(c64.abs()).max(scale * FLOOR);
        let ulp = ulp_of(m).max(floor(k));
        let diff = (g64 - c64).abs();
        let allowed = bound.ulps * ulp + bound.rel * U * scale;
        if diff > allowed {
            return Err(format!(
                "{what}: word {k}: GPU {g:e}, mirror {c:e}, {:.1} units ({ulp:e}) apart, over the bound ({allowed:e})",
                diff / ulp
            ));
        }
        // The root mean square's unit is the word's bound over its ulps:
        // an ulp where the bound is in ulps alone, more where it admits
        // the scale's share too (a word that its terms' cancellation
        // left small is measured as its bound measures it).
        let unit = ulp + bound.rel * U * scale / bound.ulps.max(1.0);
        let ulps = diff / unit;
        sum_sq += ulps * ulps;
        if worst.is_none_or(|(w, _, _)| ulps > w) {
            worst = Some((ulps, k, unit));
        }
    }
    let rms = (sum_sq / gpu.len().max(1) as f64).sqrt();
    if rms > bound.rms_ulps {
        let (w, k, unit) = worst.unwrap_or((0.0, 0, 0.0));
        return Err(format!(
            "{what}: the words differ by {rms:.2} units (root mean square) over {} words, above {} (worst: word {k}, {w:.1} units of {unit:e}: GPU {:e}, mirror {:e})",
            gpu.len(),
            bound.rms_ulps,
            gpu[k],
            cpu[k]
        ));
    }
    // The words' own drift: a value scaled by 1 + ε in every word (a
    // coefficient one ulp off) is below every single word's bound.
    if let Some(systematic) = checked_drift(bound) {
        let mut drift = Drift::default();
        drift.add(&vec![0.0; cpu.len()], gpu, cpu);
        drift.check(what, systematic)?;
    }
    Ok(())
}

/// The largest finite magnitude of `words`.
fn largest(words: &[f32]) -> f64 {
    words
        .iter()
        .filter(|c| c.is_finite())
        .fold(0.0f64, |m, c| m.max(f64::from(c.abs())))
}

/// The magnitudes summed into each particle's step \[N\]: its weight, and
/// over its springs the elastic terms `k · max(rest, length)` (a length's
/// last place is that much force: the net force of a stretched spring is
/// what is left of two such terms), the damping terms `kd · |Δv|`, and
/// the linear bending terms `|Q_pj| · (|Δx| + β |Δv|)`. Wind and contact
/// are left to the words' own last place and the bound's chain.
pub fn force_magnitudes(sys: &System<f32>, before: &States) -> Vec<f64> {
    let (x, v) = (&before.0, &before.1);
    let g = f64::from(sys.gravity.length());
    let mut out: Vec<f64> = sys.mass.iter().map(|&m| f64::from(m) * g).collect();
    for s in &sys.springs {
        let (i, j) = (s.i as usize, s.j as usize);
        let length = f64::from((x[i] - x[j]).length());
        let term = f64::from(s.k) * length.max(f64::from(s.rest))
            + f64::from(s.kd) * f64::from((v[i] - v[j]).length());
        out[i] += term;
        out[j] += term;
    }
    if let Some(b) = &sys.bending {
        for (p, o) in out.iter_mut().enumerate() {
            let (cols, q) = b.row(p);
            for (&j, &q) in cols.iter().zip(q) {
                let j = j as usize;
                *o += f64::from(q.abs())
                    * f64::from((x[j] - x[p]).length() + b.damping * (v[j] - v[p]).length());
            }
        }
    }
    out
}

/// Checks one step's state against the mirror's, both stepped from
/// `before`. Word `k` of particle `p` is measured in its unit: the larger
/// of its own last place and `U` times the magnitudes summed into it —
/// for a velocity `|v| + dt · F_p / m_p` with `F_p` the particle's
/// [`force_magnitudes`], for a position `|x| + dt ·` that velocity
/// magnitude. Where the step set velocities from positions
/// (`from_positions = Some(dt)`: the fix-up moved, or self-collision
/// projected, so `v = Δx / dt`), a velocity's unit is at least its
/// position's divided by `dt`: a rounding of the position, which no
/// bound can avoid, is that much velocity.
pub fn check_step_state(
    what: &str,
    sys: &System<f32>,
    before: &States,
    gpu: &States,
    cpu: &States,
    from_positions: Option<f64>,
    bound: &Bound,
) -> Result<(), String> {
    let dt = f64::from(sys.dt);
    let forces = force_magnitudes(sys, before);
    let v_mag: Vec<f64> = forces
        .iter()
        .zip(&sys.mass)
        .zip(&before.1)
        .map(|((&f, &m), v)| f64::from(v.length()) + dt * f / f64::from(m).max(f64::MIN_POSITIVE))
        .collect();
    let x_mag: Vec<f64> = v_mag
        .iter()
        .zip(&before.0)
        .map(|(&v, x)| f64::from(x.length()) + dt * v)
        .collect();
    let (gx, cx) = (flat(&gpu.0), flat(&cpu.0));
    let x_unit = |k: usize| U * x_mag[k / 3];
    check_values_with(&format!("{what}: x"), &gx, &cx, 0.0, bound, x_unit)?;
    let (gv, cv) = (flat(&gpu.1), flat(&cpu.1));
    let v_unit = |k: usize| {
        let own = U * v_mag[k / 3];
        match from_positions {
            Some(dt) => {
                let m = f64::from(gx[k].abs().max(cx[k].abs()));
                own.max((ulp_of(m) + x_unit(k)) / dt)
            }
            None => own,
        }
    };
    check_values_with(&format!("{what}: v"), &gv, &cv, 0.0, bound, v_unit)
}

/// The spacing of `f32` values at magnitude `m` (`m` ≥ 0), as `f64`; the
/// smallest normal's spacing below it.
pub fn ulp_of(m: f64) -> f64 {
    let f = (m as f32).max(f32::MIN_POSITIVE);
    f64::from(f32::from_bits(f.to_bits() + 1)) - f64::from(f)
}

/// Compares words of the device with the twin's under the policy: equal
/// bits, or within `bound` (read as `f32`s); `what` names them.
pub fn check_words(what: &str, gpu: &[u32], cpu: &[u32], bound: &Bound) -> Result<(), String> {
    match policy() {
        Policy::Bits => check_bits(what, gpu, cpu),
        Policy::Bounded => check_values(
            what,
            bytemuck::cast_slice(gpu),
            bytemuck::cast_slice(cpu),
            bound,
        ),
    }
}

/// `Err` unless the words are equal, naming the first that differs.
pub fn check_bits(what: &str, gpu: &[u32], cpu: &[u32]) -> Result<(), String> {
    if gpu.len() != cpu.len() {
        return Err(format!(
            "{what}: {} words, the mirror {}",
            gpu.len(),
            cpu.len()
        ));
    }
    match (0..gpu.len()).find(|&k| gpu[k] != cpu[k]) {
        None => Ok(()),
        Some(k) => Err(format!(
            "{what}: {} words differ; first: word {k} (entry {}, component {}): GPU {:e} ({:#010x}), twin {:e} ({:#010x})",
            (0..gpu.len()).filter(|&k| gpu[k] != cpu[k]).count(),
            k / 4,
            k % 4,
            f32::from_bits(gpu[k]),
            gpu[k],
            f32::from_bits(cpu[k]),
            cpu[k],
        )),
    }
}

/// Vectors as their components, in order.
pub fn flat(v: &[Vec3]) -> Vec<f32> {
    v.iter().flat_map(|p| p.to_array()).collect()
}

/// A state: positions and velocities.
pub type States = (Vec<Vec3>, Vec<Vec3>);

/// `Err` unless a state's positions and velocities are the mirror's bits
/// (the bits policy's comparison of states; the bounded one compares a
/// step at a time, [`check_step_state`]).
pub fn check_state_bits(what: &str, gpu: &States, cpu: &States) -> Result<(), String> {
    let as_words = |v: &[Vec3]| -> Vec<u32> { flat(v).into_iter().map(f32::to_bits).collect() };
    check_bits(&format!("{what}: x"), &as_words(&gpu.0), &as_words(&cpu.0))?;
    check_bits(&format!("{what}: v"), &as_words(&gpu.1), &as_words(&cpu.1))
}

/// The relative scale of the device's increments against the mirror's,
/// accumulated over re-seeded steps: `s = Σ (g − c)·Δ / Σ Δ²`, where `Δ` is
/// the mirror's increment of a word over its step and `g − c` the
/// device's difference from the mirror after it. Rounding differences
/// (fused or not) are as often above as below, so `s` stays within a few
/// of its standard error `σ`, estimated from the scatter of the
/// differences themselves; an operation that scales a step (`dt` one ulp
/// high, a coefficient off) moves `s` by its relative error in every
/// word, which no single word shows.
#[derive(Clone, Debug, Default)]
pub struct Drift {
    /// Σ (g − c)·Δ.
    cross: f64,
    /// Σ Δ².
    norm: f64,
    /// Pairs `(g − c, Δ)`, for the scatter.
    samples: Vec<(f64, f64)>,
}

/// The standard errors by which [`Drift`]'s `s` may stand from zero: six,
/// a chance below 10⁻⁸ for unbiased rounding.
pub const DRIFT_SIGMAS: f64 = 6.0;
/// The systematic relative drift admitted besides: a quarter of `U`
/// (2⁻²⁶ ≈ 1.5e-8), for arithmetic that rounds as the mirror does but for
/// products fused into sums, whose differences lean neither way (the
/// fusing mirror of `tests/agreement.rs` stays within it; the drift is
/// checked only where the adapter rounds as the mirror does, see
/// [`checked_drift`]). A one-ulp change of `dt` moves `s` by 2⁻²⁴ at
/// least, four times this.
pub const DRIFT_SYSTEMATIC: f64 = U / 4.0;

impl Drift {
    /// Adds one step's words: before the step, the device's after it, the
    /// mirror's after it.
    pub fn add(&mut self, before: &[f32], gpu: &[f32], cpu: &[f32]) {
        for ((&b, &g), &c) in before.iter().zip(gpu).zip(cpu) {
            let delta = f64::from(c) - f64::from(b);
            let diff = f64::from(g) - f64::from(c);
            if delta != 0.0 && diff.is_finite() && delta.is_finite() {
                self.cross += diff * delta;
                self.norm += delta * delta;
                self.samples.push((diff, delta));
            }
        }
    }

    /// The scale `s` and its standard error `σ`.
    pub fn scale(&self) -> (f64, f64) {
        if self.norm == 0.0 {
            return (0.0, 0.0);
        }
        let s = self.cross / self.norm;
        let var: f64 = self
            .samples
            .iter()
            .map(|&(diff, delta)| {
                let r = diff - s * delta;
                r * r * delta * delta
            })
            .sum::<f64>()
            / (self.norm * self.norm);
        (s, var.sqrt())
    }

    /// `Err` when the increments drift beyond [`DRIFT_SIGMAS`] standard
    /// errors plus `systematic`.
    pub fn check(&self, what: &str, systematic: f64) -> Result<(), String> {
        let (s, sigma) = self.scale();
        let allowed = DRIFT_SIGMAS * sigma + systematic;
        if s.abs() > allowed {
            return Err(format!(
                "{what}: the device's words (or their changes over a step) are {s:e} (relative) larger than the mirror's over {} words, beyond {allowed:e} (σ = {sigma:e})",
                self.samples.len()
            ));
        }
        Ok(())
    }
}

/// Something stepped: the device's solver, or a mirror standing in for it
/// in a proof of the bounds.
pub trait Stepper {
    /// Steps `n` times.
    fn advance(&mut self, n: u32) -> Result<(), String>;
    /// The state.
    fn state(&self) -> States;
    /// After an implicit step: its `Δv` and each particle's filter kind
    /// (`kernel_config::filter_kind`), where the stepper keeps them.
    fn implicit_answer(&self) -> Option<(Vec<Vec3>, Vec<f32>)> {
        None
    }
}

impl<T: Stepper + ?Sized> Stepper for &mut T {
    fn advance(&mut self, n: u32) -> Result<(), String> {
        (**self).advance(n)
    }
    fn state(&self) -> States {
        (**self).state()
    }
    fn implicit_answer(&self) -> Option<(Vec<Vec3>, Vec<f32>)> {
        (**self).implicit_answer()
    }
}

impl Stepper for GpuSolver {
    fn advance(&mut self, n: u32) -> Result<(), String> {
        self.step(n)
            .map(|_| ())
            .map_err(|e| format!("GPU step: {e}"))
    }
    fn state(&self) -> States {
        let s = self
            .read_state()
            .unwrap_or_else(|e| panic!("GPU read-back: {e}"));
        (s.x, s.v)
    }
    fn implicit_answer(&self) -> Option<(Vec<Vec3>, Vec<f32>)> {
        use wgcloth::kernel_config::work;
        let words = self
            .debug_read(wgcloth::gpu::DebugBuffer::Work)
            .unwrap_or_else(|e| panic!("GPU read-back: {e}"));
        let n = self.particle_count() as usize;
        let entry = |sec: u32, p: usize| -> [f32; 4] {
            let at = (sec as usize * n + p) * 4;
            std::array::from_fn(|k| f32::from_bits(words[at + k]))
        };
        Some((
            (0..n)
                .map(|p| {
                    let e = entry(work::DV, p);
                    Vec3::new(e[0], e[1], e[2])
                })
                .collect(),
            (0..n).map(|p| entry(work::Z, p)[3]).collect(),
        ))
    }
}

/// How far above CG's tolerance the `f64` residual of the device's answer
/// may be: CG stops on its recursively updated `f32` residual, which
/// parts from the true residual by rounding of the order of `U` times the
/// condition number times the products summed (a block product of twelve
/// springs, four terms each: 64), relative to the right-hand side.
pub const RESIDUAL_GAP: f64 = 64.0 * U * CG_CONDITION;

/// Particles whose constraint the device decided otherwise than the `f64`
/// judge may be, per step: a contact taken or not, where the particle
/// lies within rounding of the contact's slop; each is left out of the
/// residual and counted. Two a step admits a particle on each side of a
/// surface; more is a real disagreement.
pub const FILTER_FLIPS: usize = 2;

/// The implicit step's own test: the device's `Δv` (`dv`, with its filter
/// kinds `kinds`) must satisfy the system that `judge` (an `f64` solver of
/// the same cloth, at the step's clock) assembles at the state `before`,
/// to CG's tolerance plus [`RESIDUAL_GAP`] — `‖S(b − A Δv)‖_P ≤ (tol +
/// gap) ‖S b‖_P` in the block-diagonal preconditioner's norm, CG's own
/// stopping test. Particles whose filter differs are left out and counted
/// (at most [`FILTER_FLIPS`]). `cap_reached`: CG stopped at its iteration
/// cap, where no tolerance is promised. The judge is then stepped once,
/// to the next step's clock.
pub fn check_implicit_residual(
    what: &str,
    judge: &mut CpuSolver<f64>,
    before: &States,
    dv: &[Vec3],
    kinds: &[f32],
    cap_reached: bool,
) -> Result<(), String> {
    use wgcloth::cpu::twins::{self as cpu, Filter};
    use wgcloth::kernel_config::filter_kind::{FIXED, FREE, HELD, PLANE};
    let wide = |v: &[Vec3]| -> Vec<wgcloth::real::Vec3<f64>> {
        v.iter()
            .map(|p| wgcloth::real::Vec3::new(p.x.into(), p.y.into(), p.z.into()))
            .collect()
    };
    judge
        .set_state(wgcloth::cpu::State {
            x: wide(&before.0),
            v: wide(&before.1),
        })
        .map_err(|e| format!("{what}: the f64 judge: {e}"))?;
    let tolerance = judge.system().cg_tolerance;
    let (sys, st, w) = cpu::parts(judge);
    // The contacts the device held by static friction: its decision at
    // the end of its last step, which the judge takes as it takes the
    // state.
    for (held, &kind) in w.held.iter_mut().zip(kinds) {
        *held = kind == HELD;
    }
    cpu::implicit::springs(sys, st, w);
    cpu::implicit::prepare(sys, st, w);
    w.dv = wide(dv);
    cpu::cg::init(sys, w);
    let (mut rho, mut delta0, mut flips) = (0.0, 0.0, 0usize);
    for (p, f) in w.filter.iter().enumerate() {
        let kind = match f {
            Filter::Free => FREE,
            Filter::Fixed => FIXED,
            Filter::Plane(..) => PLANE,
            Filter::Held(..) => HELD,
        };
        if kind != kinds[p] {
            flips += 1;
            continue;
        }
        let r = w.r[p];
        rho += r.dot(f.apply(w.precond[p].mul(r)));
        delta0 += w.delta0_terms[p];
    }
    judge
        .step()
        .map_err(|e| format!("{what}: the f64 judge's step: {e}"))?;
    if flips > FILTER_FLIPS {
        return Err(format!(
            "{what}: {flips} particles constrained otherwise than in f64, over {FILTER_FLIPS}"
        ));
    }
    let relative = if delta0 > 0.0 {
        (rho.max(0.0) / delta0).sqrt()
    } else {
        0.0
    };
    if !cap_reached && relative > tolerance + RESIDUAL_GAP {
        return Err(format!(
            "{what}: the device's Δv leaves a residual of {relative:e} of the right-hand side in f64, over the tolerance {tolerance:e} + {RESIDUAL_GAP:e}"
        ));
    }
    Ok(())
}

impl Stepper for CpuSolver<f32> {
    fn advance(&mut self, n: u32) -> Result<(), String> {
        self.step_n(u64::from(n))
            .map(|_| ())
            .map_err(|e| format!("CPU step: {e}"))
    }
    fn state(&self) -> States {
        (self.positions(), self.velocities())
    }
}

/// A cloth of a batch, stepped as the batch steps (every cloth of it).
pub struct BatchCloth {
    /// The batch.
    pub batch: wgcloth::gpu::GpuBatch,
    /// The cloth compared.
    pub id: wgcloth::gpu::ClothId,
}

impl Stepper for BatchCloth {
    fn advance(&mut self, n: u32) -> Result<(), String> {
        self.batch
            .step(n)
            .map(|_| ())
            .map_err(|e| format!("batch step: {e}"))
    }
    fn state(&self) -> States {
        let s = self
            .batch
            .read_state(self.id)
            .unwrap_or_else(|e| panic!("batch read-back: {e}"));
        (s.x, s.v)
    }
}

/// The mirror's state.
pub fn mirror_state(c: &CpuSolver<f32>) -> States {
    (c.positions(), c.velocities())
}

/// Sets the mirror to `state`.
pub fn reseed(c: &mut CpuSolver<f32>, state: &States) {
    c.set_positions_and_velocities(&state.0, &state.1)
        .unwrap_or_else(|e| panic!("re-seeding the mirror: {e}"));
}

/// Steps per submit in [`check_steps`]' bit-for-bit comparison (as
/// `wgcloth run` submits at most 10).
pub const SUBMIT_STEPS: u32 = 10;

/// Steps `device` and `mirror` `steps` times from the same state and checks
/// they agree under the policy: under bits both run on their own and
/// their states must be equal after the last step; under bounded the
/// mirror is re-seeded with the device's state before every step, each
/// step's states must lie within `bound`, and the increments must not
/// drift (see [`Drift`]).
pub fn check_steps(
    what: &str,
    device: &mut dyn Stepper,
    mirror: &mut CpuSolver<f32>,
    steps: u32,
    bound: &Bound,
) -> Result<(), String> {
    check_steps_judged(what, device, mirror, None, steps, bound)
}

/// [`check_steps`], each implicit step under the bounded policy also held
/// to its `f64` residual by `judge` (see [`check_reseeded_judged`]).
pub fn check_steps_judged(
    what: &str,
    device: &mut dyn Stepper,
    mirror: &mut CpuSolver<f32>,
    judge: Option<&mut CpuSolver<f64>>,
    steps: u32,
    bound: &Bound,
) -> Result<(), String> {
    match policy() {
        Policy::Bits => {
            // In submits of a few steps, as `wgcloth run` steps, so that
            // the GPU's checks between them adapt its CG budget.
            for chunk in (0..steps).step_by(SUBMIT_STEPS as usize) {
                device.advance(SUBMIT_STEPS.min(steps - chunk))?;
            }
            mirror.advance(steps)?;
            check_state_bits(
                &format!("{what}, after {steps} steps"),
                &device.state(),
                &mirror_state(mirror),
            )
        }
        Policy::Bounded => check_reseeded_judged(what, device, mirror, judge, steps, bound),
    }
}

/// The bounded tier of [`check_steps`], whatever the policy (the proofs of
/// the bounds run it on every adapter).
pub fn check_reseeded(
    what: &str,
    device: &mut dyn Stepper,
    mirror: &mut CpuSolver<f32>,
    steps: u32,
    bound: &Bound,
) -> Result<(), String> {
    check_reseeded_judged(what, device, mirror, None, steps, bound)
}

/// [`check_reseeded`], each implicit step's answer also held to its own
/// `f64` residual by `judge` (see [`check_implicit_residual`]), where the
/// device keeps its answer.
pub fn check_reseeded_judged(
    what: &str,
    device: &mut dyn Stepper,
    mirror: &mut CpuSolver<f32>,
    mut judge: Option<&mut CpuSolver<f64>>,
    steps: u32,
    bound: &Bound,
) -> Result<(), String> {
    let mut drift = Drift::default();
    for step in 1..=steps {
        let before = device.state();
        reseed(mirror, &before);
        device.advance(1)?;
        mirror.advance(1)?;
        let (g, c) = (device.state(), mirror_state(mirror));
        let at = format!("{what}, step {step} (re-seeded)");
        let implicit = mirror.integrator() == wgcloth::params::Integrator::Implicit;
        let answer = judge
            .as_deref_mut()
            .filter(|_| implicit)
            .and_then(|j| device.implicit_answer().map(|a| (j, a)));
        if let Some((judge, (dv, kinds))) = answer {
            let cap = mirror.system().cg_max_iterations;
            let cap_reached = mirror.last_stats().cg_iterations >= cap;
            check_implicit_residual(&at, judge, &before, &dv, &kinds, cap_reached)?;
        }
        let from_positions = velocities_from_positions(mirror);
        check_step_state(&at, mirror.system(), &before, &g, &c, from_positions, bound)?;
        drift.add(&flat(&before.0), &flat(&g.0), &flat(&c.0));
        drift.add(&flat(&before.1), &flat(&g.1), &flat(&c.1));
    }
    match checked_drift(bound) {
        Some(systematic) => drift.check(what, systematic),
        None => Ok(()),
    }
}

/// The drift `bound` checks on this adapter: none where the adapter
/// rounds otherwise than the mirror. [`Drift`]'s standard error assumes
/// the words' rounding differences are independent and unbiased, and
/// there they are neither:
/// - a cloth of identical particles repeats one product rounded
///   otherwise (fused) in every word, so a whole step's increments read
///   as scaled by up to an ulp with a standard error near zero (measured
///   on an NVIDIA H200: 1.17e-7, σ 1e-13);
/// - a square root or quotient that leans one way within its 2.5 ulp
///   leans every spring's length, and the fix-up's correction `l − L`,
///   where the spring is near its limit, cancels all but a hundredth of
///   it: the fix-up's increments read as scaled by 10⁻⁶ (measured on the
///   H200: 1.4e-6 over the `hanging` scene, 4.3e-6 over `curtain`).
///
/// Such an adapter's comparisons keep every word's bound and the root
/// mean square, which see `dt` 1 % off but not 10⁻³ (`tests/agreement.rs`:
/// a word's unit is the rounding of the forces summed into it, a
/// thousand times the net force on these cloths); where the adapter
/// rounds as the mirror does (the bounded tier forced on lavapipe) the
/// drift also sees `dt` one ulp off.
pub fn checked_drift(bound: &Bound) -> Option<f64> {
    bound.drift.filter(|_| probe().rounds_like_the_mirror())
}

/// `Some(dt)` where the mirror's last step set velocities from positions
/// (`v = Δx / dt`: its fix-up moved something, or self-collision may
/// have projected), else `None` (see [`check_step_state`]).
fn velocities_from_positions(mirror: &CpuSolver<f32>) -> Option<f64> {
    (mirror.last_stats().fixup_passes > 0 || mirror.system().self_collision.is_some())
        .then(|| mirror.system().dt.to_f64())
}

/// Before one step of `device` and `mirror` that [`check_after_step`]
/// compares: the device's state, which the mirror takes under the bounded
/// policy (under bits each runs on its own).
pub fn before_step(device: &dyn Stepper, mirror: &mut CpuSolver<f32>) -> States {
    let before = device.state();
    if policy() == Policy::Bounded {
        reseed(mirror, &before);
    }
    before
}

/// After one step of the device (now in state `gpu`) and the mirror from
/// `before`: equal bits, or within the step's `bound`.
pub fn check_after_step(
    what: &str,
    before: &States,
    gpu: &States,
    mirror: &CpuSolver<f32>,
    bound: &Bound,
) -> Result<(), String> {
    let cpu = mirror_state(mirror);
    match policy() {
        Policy::Bits => check_state_bits(what, gpu, &cpu),
        Policy::Bounded => check_step_state(
            what,
            mirror.system(),
            before,
            gpu,
            &cpu,
            velocities_from_positions(mirror),
            bound,
        ),
    }
}

/// [`check_steps`], panicking with its message.
pub fn assert_steps(
    what: &str,
    device: &mut dyn Stepper,
    mirror: &mut CpuSolver<f32>,
    steps: u32,
    bound: &Bound,
) {
    if let Err(e) = check_steps(what, device, mirror, steps, bound) {
        panic!("{e}");
    }
}
