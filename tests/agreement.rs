//! The agreement policy's own proofs (`tests/gpu_common/agreement.rs`):
//! the probe's verdict, bounds that fail on real bugs, and bounds that
//! admit what hardware does.
//!
//! - **Red proofs.** Kernels changed as a bug would change them (a spring
//!   term dropped, a neighbour's index shifted, `dt` 1 % high, a
//!   damping coefficient 10⁻³ off, a term of the implicit CG's product
//!   dropped) must fail the bounded tier against the mirror (the implicit
//!   one its `f64` residual) without the increments' drift; `dt` one ulp
//!   high must fail it by the drift where the adapter rounds as the mirror
//!   does, the only adapters whose comparisons check the drift.
//!   They run the bounded tier whatever the policy, so they prove the
//!   bounds on every adapter.
//! - **Admission.** A CPU mirror that fuses every product into the sum it
//!   feeds (`gpu_common::fused`: what a hardware GPU may do to any `a·b + c`)
//!   must pass the bounded tier against the unfused mirror, for every
//!   integrator.

#[path = "gpu_common/fused.rs"]
mod fused;
mod gpu_common;

use fused::{to_glam, Fused};
use gpu_common::agreement::{self, Policy, States, Stepper};
use gpu_common::{busy_params, corners, gpu, grid, without_grid};
use wgcloth::cpu::CpuSolver;
use wgcloth::gpu::{GpuKernels, GpuSolver, Kernel, SourcePatch, StepPath};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

/// Columns and rows of the proofs' cloth (the kernel twins' size: three
/// reduction blocks, the last partial).
const NX: usize = 12;
const NY: usize = 11;

/// Re-seeded steps each proof compares: enough for the busy scene's cloth
/// to swing in the wind and reach its sphere.
const STEPS: u32 = 30;

/// The busy scene for `integrator` on the general kernels.
fn scene(integrator: Integrator) -> (Model, Params) {
    let p = busy_params(integrator);
    (without_grid(&grid(NX, NY, corners(), &p)), p)
}

#[test]
fn the_policy_follows_the_probe_or_the_override() {
    let probe = agreement::probe();
    let policy = agreement::policy();
    match std::env::var(agreement::POLICY_VAR).ok().as_deref() {
        Some("bits") => assert_eq!(policy, Policy::Bits),
        Some("bounded") => assert_eq!(policy, Policy::Bounded),
        _ => assert_eq!(
            policy == Policy::Bits,
            probe.rounds_like_the_mirror(),
            "{probe:?}"
        ),
    }
    // The probe's own check: a CPU division and square root are correctly
    // rounded, so the inputs it compares against are the right answers.
    assert_eq!((1.0f32 / 3.0).to_bits(), 0x3eaa_aaab);
    assert_eq!(2.0f32.sqrt().to_bits(), 0x3fb5_04f3);
}

/// A kernel changed as a bug would change it: the patch and what it
/// models.
struct Mutation {
    what: &'static str,
    integrator: Integrator,
    /// The springs' damping [N·s/m] where the scene's would hide the
    /// mutation: the default 0.05 makes damping forces a thousandth of
    /// the elastic terms' magnitudes, so a 10⁻³ error in them is below
    /// the rounding of the forces' sum any adapter may differ by.
    damping: Option<f64>,
    kernel: Kernel,
    find: &'static str,
    replace: &'static str,
    /// Caught by the increments' drift alone, at this allowance (`None`:
    /// caught without the drift, on every adapter); tried only where this
    /// adapter's comparisons check the drift (`agreement::checked_drift`).
    drift: Option<f64>,
}

/// The mutations every bounded comparison must catch.
const MUTATIONS: &[Mutation] = &[
    Mutation {
        what: "each particle's first spring dropped from its gather",
        integrator: Integrator::Explicit,
        damping: None,
        kernel: Kernel::ExplicitIntegrate,
        find: "for (var k = begin; k < end; k++) {\n        let e = topo(params.spring_adj_entries + k);",
        replace: "for (var k = begin + 1u; k < end; k++) {\n        let e = topo(params.spring_adj_entries + k);",
        drift: None,
    },
    Mutation {
        what: "a neighbour's index shifted by one in the gather",
        integrator: Integrator::Explicit,
        damping: None,
        kernel: Kernel::ExplicitIntegrate,
        find: "let e = topo(params.spring_adj_entries + k);",
        replace: "let e = topo(params.spring_adj_entries + min(k + 1u, end - 1u));",
        drift: None,
    },
    Mutation {
        what: "dt one ulp high (2⁻²³ relative) in the integration",
        integrator: Integrator::Explicit,
        damping: None,
        kernel: Kernel::ExplicitIntegrate,
        find: "params.dt",
        replace: "(params.dt * 1.00000012)",
        drift: Some(agreement::DRIFT_SYSTEMATIC),
    },
    Mutation {
        what: "dt 1 % high in the integration",
        integrator: Integrator::Explicit,
        damping: None,
        kernel: Kernel::ExplicitIntegrate,
        find: "params.dt",
        replace: "(params.dt * 1.01)",
        drift: None,
    },
    Mutation {
        what: "the damping coefficient 10⁻³ high",
        integrator: Integrator::Explicit,
        damping: Some(1.0),
        kernel: Kernel::SpringForces,
        find: "kd * rate",
        replace: "(kd * 1.001) * rate",
        drift: None,
    },
    Mutation {
        what: "each spring's m mᵀ part dropped from the implicit CG's product",
        integrator: Integrator::Implicit,
        damping: None,
        kernel: Kernel::CgApply,
        find: "let y = d * blk.w + blk.xyz * dot3(blk.xyz, d);",
        replace: "let y = d * blk.w;",
        drift: None,
    },
];

/// Each mutation fails the bounded tier: the GPU stepping with the
/// changed kernel, re-seeded from the mirror's state each step, is caught
/// by a word's bound, the words' root mean square or the increments'
/// drift.
#[test]
fn the_bounded_tier_catches_each_mutation() {
    let ctx = gpu();
    for m in MUTATIONS {
        let (model, mut params) = scene(m.integrator);
        if let Some(kd) = m.damping {
            for s in &mut params.springs {
                s.damping = kd;
            }
        }
        let kernels = GpuKernels::with_patch(
            &ctx.device,
            SourcePatch {
                kernel: m.kernel,
                find: m.find.into(),
                replace: m.replace.into(),
            },
        );
        let mut g = GpuSolver::with_step_path(
            &kernels,
            &ctx.queue,
            &model,
            &params,
            StepPath::MultiDispatch,
        )
        .unwrap_or_else(|e| panic!("{}: {e}", m.what));
        let mut tuning = g.tuning_mut();
        tuning
            .set_specialised(false)
            .unwrap_or_else(|e| panic!("kernels: {e}"));
        tuning.set_adaptive_cg_budget(false);
        let mut c = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
        let mut bound = agreement::step_bound(&params);
        if m.drift.is_some() && agreement::checked_drift(&bound).is_none() {
            eprintln!("{}: this adapter's comparisons check no drift", m.what);
            continue;
        }
        bound.drift = m.drift;
        let verdict = agreement::check_reseeded(m.what, &mut g, &mut c, STEPS, &bound);
        match verdict {
            Err(e) => eprintln!("caught: {e}"),
            Ok(()) => panic!("{}: passed the bounded tier", m.what),
        }
    }
}

/// The same comparison without a mutation passes (so the red proofs fail
/// for their mutation, not for the scene).
#[test]
fn the_unchanged_kernels_pass_the_bounded_tier() {
    for integrator in [Integrator::Explicit, Integrator::Implicit] {
        let (model, params) = scene(integrator);
        let ctx = gpu();
        let mut g = GpuSolver::with_step_path(
            ctx.kernels(),
            &ctx.queue,
            &model,
            &params,
            StepPath::MultiDispatch,
        )
        .expect("GPU solver");
        let mut tuning = g.tuning_mut();
        tuning.set_specialised(false).expect("kernels");
        tuning.set_adaptive_cg_budget(false);
        let mut c = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
        agreement::check_reseeded(
            "unchanged",
            &mut g,
            &mut c,
            STEPS,
            &agreement::step_bound(&params),
        )
        .unwrap_or_else(|e| panic!("{integrator}: {e}"));
    }
}

impl Stepper for CpuSolver<Fused> {
    fn advance(&mut self, n: u32) -> Result<(), String> {
        self.step_n(u64::from(n))
            .map(|_| ())
            .map_err(|e| format!("fused mirror: {e}"))
    }
    fn state(&self) -> States {
        let st = self.state();
        (
            st.x.iter().copied().map(to_glam).collect(),
            st.v.iter().copied().map(to_glam).collect(),
        )
    }
}

/// The fusing mirror passes the bounded tier against the unfused one on
/// every integrator — and differs from it, so the tier is what admits it.
#[test]
fn a_mirror_that_fuses_passes_the_bounded_tier() {
    for integrator in [
        Integrator::Explicit,
        Integrator::SemiImplicit,
        Integrator::Implicit,
    ] {
        let (model, params) = scene(integrator);
        let mut fused = CpuSolver::<Fused>::new(&model, &params).expect("fused mirror");
        let mut plain = CpuSolver::<f32>::new(&model, &params).expect("mirror");
        agreement::check_reseeded(
            &format!("{integrator}, fused"),
            &mut fused,
            &mut plain,
            STEPS,
            &agreement::step_bound(&params),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let (f, p) = (Stepper::state(&fused), agreement::mirror_state(&plain));
        let differ = agreement::flat(&f.1)
            .iter()
            .zip(agreement::flat(&p.1))
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        eprintln!("{integrator}: the last step's velocities differ in {differ} words");
        assert!(differ > 0, "{integrator}: the fused mirror never differed");
    }
}
