//! The two ways a [`GpuSolver`](super::GpuSolver) steps a cloth, and the
//! automatic choice between them.
//!
//! A small cloth is stepped by one workgroup ([`StepPath::Workgroup`]:
//! `shaders/cloth_*.wgsl`), its phases separated by workgroup barriers
//! instead of dispatches, so a step is one dispatch; any other takes the
//! multi-dispatch plan ([`StepPath::MultiDispatch`], see
//! [`super::plan`]). Both give the same bits.

use crate::error::{Error, Result};
use crate::kernel_config::{SUM_GROUP, WORKGROUP_STEP_MAX_PARTICLES, WORKGROUP_STEP_SHARED_BYTES};
use crate::params::Integrator;

/// How a step is recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StepPath {
    /// One workgroup per cloth: the whole step in one dispatch.
    Workgroup,
    /// A dispatch per phase of the step (and per fix-up pass and CG
    /// iteration), each over the cloth's particles or springs.
    MultiDispatch,
}

impl std::fmt::Display for StepPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StepPath::Workgroup => "one workgroup per cloth",
            StepPath::MultiDispatch => "multi-dispatch",
        })
    }
}

/// What the choice depends on.
#[derive(Clone, Copy, Debug)]
pub(super) struct PathInputs<'a> {
    /// The integrator.
    pub integrator: Integrator,
    /// Particles.
    pub particles: u64,
    /// The semi-implicit filter is the dense one.
    pub dense: bool,
    /// The device's limits.
    pub limits: &'a wgpu::Limits,
}

/// The path a solver takes and why (what `wgcloth run --verbose` prints).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct PathChoice {
    /// The path.
    pub path: StepPath,
    /// Why, in a sentence.
    pub reason: String,
}

/// Why the workgroup path cannot step a cloth: a sentence (what
/// `--verbose` prints when the solver chooses the multi-dispatch path) and
/// the error that forcing the workgroup path returns.
struct Refusal {
    reason: String,
    error: Error,
}

impl From<Error> for Refusal {
    fn from(error: Error) -> Refusal {
        Refusal {
            reason: error.to_string(),
            error,
        }
    }
}

/// A refusal of the workgroup path, `reason` saying why and `allowed` what
/// the error names as allowed.
fn refusal(reason: String, allowed: String, got: String) -> Refusal {
    Refusal {
        error: Error::InvalidParameter {
            key: "step path".into(),
            allowed,
            got,
        },
        reason,
    }
}

/// Why the workgroup path cannot step this cloth; `Ok` where it can.
fn workgroup_refusal(i: &PathInputs<'_>) -> std::result::Result<(), Refusal> {
    let no_kernel = |why: &str| {
        Err(refusal(
            why.to_string(),
            format!("the multi-dispatch path ({why})"),
            StepPath::Workgroup.to_string(),
        ))
    };
    // One arm per integrator: which of its cloths a workgroup kernel steps.
    match i.integrator {
        Integrator::Explicit => {}
        Integrator::SemiImplicit if i.dense => {}
        Integrator::SemiImplicit => {
            return no_kernel(
                "the semi-implicit filter beyond the dense filter's size is solved by CG, \
                 which has no workgroup kernel",
            )
        }
        Integrator::Implicit => {}
    }
    if i.particles > u64::from(WORKGROUP_STEP_MAX_PARTICLES) {
        return Err(refusal(
            format!(
                "{} particles, more than the workgroup path's {WORKGROUP_STEP_MAX_PARTICLES} \
                 (WORKGROUP_STEP_MAX_PARTICLES)",
                i.particles
            ),
            format!(
                "the workgroup path for at most {WORKGROUP_STEP_MAX_PARTICLES} particles \
                 (WORKGROUP_STEP_MAX_PARTICLES)"
            ),
            format!("{} particles", i.particles),
        ));
    }
    let what = "the workgroup path";
    let l = i.limits;
    super::solver::limit(
        "max_compute_invocations_per_workgroup",
        what,
        l.max_compute_invocations_per_workgroup.into(),
        SUM_GROUP.into(),
    )?;
    super::solver::limit(
        "max_compute_workgroup_size_x",
        what,
        l.max_compute_workgroup_size_x.into(),
        SUM_GROUP.into(),
    )?;
    super::solver::limit(
        "max_compute_workgroup_storage_size",
        what,
        l.max_compute_workgroup_storage_size.into(),
        WORKGROUP_STEP_SHARED_BYTES.into(),
    )?;
    Ok(())
}

/// The path of a cloth: `forced`, or chosen — the workgroup path wherever
/// it can step the cloth. Forcing the workgroup path where it cannot is
/// the error that says why (naming the limit).
pub(super) fn choose(i: &PathInputs<'_>, forced: Option<StepPath>) -> Result<PathChoice> {
    let refused = workgroup_refusal(i);
    let choice = |path, reason: String| Ok(PathChoice { path, reason });
    match (forced, refused) {
        (Some(StepPath::MultiDispatch), _) => {
            choice(StepPath::MultiDispatch, "chosen by the host".into())
        }
        (Some(StepPath::Workgroup), Err(r)) => Err(r.error),
        (Some(StepPath::Workgroup), Ok(())) => {
            choice(StepPath::Workgroup, "chosen by the host".into())
        }
        (None, Ok(())) => choice(
            StepPath::Workgroup,
            format!(
                "{} particles, at most {WORKGROUP_STEP_MAX_PARTICLES}: one workgroup steps \
                 the cloth",
                i.particles
            ),
        ),
        (None, Err(r)) => choice(StepPath::MultiDispatch, r.reason),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(integrator: Integrator, particles: u64, limits: &wgpu::Limits) -> PathInputs<'_> {
        PathInputs {
            integrator,
            particles,
            dense: true,
            limits,
        }
    }

    #[test]
    fn the_workgroup_path_ends_at_its_limit_and_the_devices() {
        let limits = wgpu::Limits::default();
        let max = u64::from(WORKGROUP_STEP_MAX_PARTICLES);
        let at = choose(&inputs(Integrator::Explicit, max, &limits), None);
        assert_eq!(at.map(|c| c.path).ok(), Some(StepPath::Workgroup));
        let over = choose(&inputs(Integrator::Explicit, max + 1, &limits), None);
        assert_eq!(over.map(|c| c.path).ok(), Some(StepPath::MultiDispatch));
        let small = wgpu::Limits {
            max_compute_invocations_per_workgroup: SUM_GROUP - 1,
            ..wgpu::Limits::default()
        };
        let refused = choose(&inputs(Integrator::Explicit, 16, &small), None);
        assert_eq!(refused.map(|c| c.path).ok(), Some(StepPath::MultiDispatch));
        let forced = choose(
            &inputs(Integrator::Explicit, 16, &small),
            Some(StepPath::Workgroup),
        );
        let message = forced.map(|c| c.path).err().map(|e| e.to_string());
        assert!(
            message
                .as_deref()
                .is_some_and(|m| m.contains("max_compute_invocations_per_workgroup")),
            "{message:?}"
        );
    }
}
