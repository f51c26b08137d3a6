//! The two ways a [`GpuSolver`](super::GpuSolver) steps a cloth, and the
//! automatic choice between them.
//!
//! A cloth of at most [`WORKGROUP_STEP_MAX_PARTICLES`] particles can be
//! stepped by one workgroup ([`StepPath::Workgroup`]:
//! `shaders/cloth_*.wgsl`), its phases separated by workgroup barriers
//! instead of dispatches, so a step is one dispatch; any cloth can take the
//! multi-dispatch plan ([`StepPath::MultiDispatch`], see [`super::plan`]).
//! Both give the same bits. Where both can, the choice is the one the
//! cost model in `path_cost.rs` estimates faster: a dispatch's latency against
//! the parallelism each path can use.

use super::grid::{GridBlock, GridLayout};
use super::kernel::Kernel;
use super::layout::{torque_bits, TORQUE_GLOBAL};
use super::path_cost::{AdapterCost, Work, CG_ITERATIONS_ESTIMATE, DENSE_FILTER_ENTRIES_PER_ITEM};
use super::plan::{Plan, PlanInputs};
use crate::aggregation::Aggregation;
use crate::error::{Error, Result};
use crate::kernel_config::{SUM_GROUP, WORKGROUP_STEP_MAX_PARTICLES, WORKGROUP_STEP_SHARED_BYTES};
use crate::model::Model;
use crate::params::{Integrator, Params};

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

/// Whether the workgroup path can step the cloth (a batch puts such
/// cloths in its shared buffers).
pub(super) fn workgroup_steps(i: &PathInputs<'_>) -> bool {
    workgroup_refusal(i).is_ok()
}

/// The path of a cloth: `forced`, or chosen — the multi-dispatch path where
/// the workgroup path cannot step the cloth, else the faster by `cost`'s
/// estimate of a step of `work` (a lone cloth). Forcing the workgroup path
/// where it cannot is the error that says why (naming the limit).
pub(super) fn choose(
    i: &PathInputs<'_>,
    forced: Option<StepPath>,
    work: &Work,
    cost: &AdapterCost,
) -> Result<PathChoice> {
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
        (None, Ok(())) => {
            let (path, reason) = cheaper(work, cost);
            choice(path, reason)
        }
        (None, Err(r)) => choice(StepPath::MultiDispatch, r.reason),
    }
}

/// The path `cost` estimates faster for a lone cloth's step of `work`, and
/// the estimates in a sentence: `est. X µs vs Y µs per step: …`.
fn cheaper(work: &Work, cost: &AdapterCost) -> (StepPath, String) {
    let wg = cost.workgroup_us(work, 1);
    let md = cost.multi_dispatch_us(work, 1);
    let spread = work
        .particles
        .div_ceil(u64::from(crate::kernel_config::WORKGROUP))
        .clamp(1, u64::from(cost.units.max(1)));
    let (units, d, items) = (cost.units, work.dispatches, work.items);
    let wg_says = format!("1 dispatch, {d} phases, {items} items on 1 of {units} units");
    let md_says = format!("{d} dispatches, {items} items over {spread} of {units} units");
    let (path, [(us, says), (other_us, other)]) = if md < wg {
        (StepPath::MultiDispatch, [(md, md_says), (wg, wg_says)])
    } else {
        (StepPath::Workgroup, [(wg, wg_says), (md, md_says)])
    };
    let reason = format!(
        "est. {} vs {} per step: {says}, against {other}; {}",
        micros(us),
        micros(other_us),
        cost.class
    );
    (path, reason)
}

/// A time estimate in µs to 2 significant figures (it is no more exact).
fn micros(us: f64) -> String {
    let e = us.max(1e-3).log10().floor() as i32;
    let step = 10f64.powi(e - 1);
    let decimals = (1 - e).max(0) as usize;
    format!("{:.decimals$} µs", (us / step).round() * step)
}

/// A step of `model` under `params` on the multi-dispatch path, as the cost
/// model sees it, from its plan with [`CG_ITERATIONS_ESTIMATE`] CG
/// iterations: the dispatches of the plan the solver would record (`grid`:
/// its grid layout there; `block`: the grid kernels' block shape), the
/// items of the plan in general layout (a grid kernel's invocation takes a
/// block of particles; a dense filter row counts its entries,
/// [`DENSE_FILTER_ENTRIES_PER_ITEM`] to an item). `dense`: the
/// semi-implicit filter is the dense one.
pub(super) fn work(
    model: &Model,
    params: &Params,
    dense: bool,
    grid: Option<&GridLayout>,
    block: GridBlock,
) -> Work {
    let n = model.particle_count() as u32;
    let pinned = model.pinned_count();
    let cg = CG_ITERATIONS_ESTIMATE.min(params.implicit.max_iterations);
    let count = |grid: Option<&GridLayout>| {
        let gather = match (grid, &model.grid) {
            (Some(_), Some(g)) => block.count(g.nx as u32, g.ny as u32),
            _ => n,
        };
        let plan = Plan::new(&PlanInputs {
            integrator: params.integrator,
            features: super::solver::scene_features(model, params, grid.map(|_| block)),
            particles: n,
            spring_slots: grid.map_or(model.springs.len(), GridLayout::slots) as u32,
            gather,
            aggregates: Aggregation::for_scene(model, params)
                .map_or([0, 0], |a| [a.count(0) as u32, a.count(1) as u32]),
            filter_count: if dense { n - pinned as u32 } else { 0 },
            torque: torque_bits(params.semi_implicit.torque_compensation, pinned) & TORQUE_GLOBAL
                != 0,
            fixup_iterations: super::build::fixup_iterations(params),
            self_collision_passes: params.self_collision.as_ref().map_or(0, |c| c.iterations),
            path: StepPath::MultiDispatch,
        });
        let (mut dispatches, mut items) = (0, 0);
        plan.for_each_in_step(0, cg, |d, _| {
            dispatches += 1;
            items += match d.kernel {
                // A row of the dense filter is a dot product over every
                // free particle, not one item's work.
                Kernel::FilterDense => {
                    u64::from(d.items) * u64::from(d.items) / DENSE_FILTER_ENTRIES_PER_ITEM
                }
                _ => u64::from(d.items),
            };
        });
        (dispatches, items)
    };
    let (dispatches, _) = count(grid);
    let (_, items) = count(None);
    Work {
        particles: n.into(),
        dispatches,
        items,
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

    /// A small cloth's step: a few dispatches, little work (a workgroup
    /// path favourite wherever dispatches cost more than the work).
    const TINY: Work = Work {
        particles: 16,
        dispatches: 13,
        items: 300,
    };

    /// `hanging`'s step on the multi-dispatch path, as `--verbose` reports
    /// it (33 × 33 particles, 10 fix-up passes).
    const HANGING: Work = Work {
        particles: 1089,
        dispatches: 13,
        items: 19_000,
    };

    fn cost(class: wgpu::DeviceType) -> AdapterCost {
        AdapterCost::of(class, 2)
    }

    fn auto(i: &PathInputs<'_>, work: &Work, class: wgpu::DeviceType) -> Option<StepPath> {
        choose(i, None, work, &cost(class)).map(|c| c.path).ok()
    }

    #[test]
    fn the_workgroup_path_ends_at_its_limit_and_the_devices() {
        let limits = wgpu::Limits::default();
        let max = u64::from(WORKGROUP_STEP_MAX_PARTICLES);
        let gpu = wgpu::DeviceType::DiscreteGpu;
        assert!(workgroup_steps(&inputs(Integrator::Explicit, max, &limits)));
        let over = inputs(Integrator::Explicit, max + 1, &limits);
        assert!(!workgroup_steps(&over));
        // Past the limit the estimate is not asked: even a step the cost
        // model would give the workgroup path goes to multi-dispatch.
        assert_eq!(auto(&over, &TINY, gpu), Some(StepPath::MultiDispatch));
        let reason = choose(&over, None, &TINY, &cost(gpu)).map(|c| c.reason);
        assert!(
            reason
                .as_deref()
                .is_ok_and(|r| r.contains("WORKGROUP_STEP_MAX_PARTICLES")),
            "{reason:?}"
        );
        let small = wgpu::Limits {
            max_compute_invocations_per_workgroup: SUM_GROUP - 1,
            ..wgpu::Limits::default()
        };
        let refused = inputs(Integrator::Explicit, 16, &small);
        assert_eq!(auto(&refused, &TINY, gpu), Some(StepPath::MultiDispatch));
        let forced = choose(&refused, Some(StepPath::Workgroup), &TINY, &cost(gpu));
        let message = forced.map(|c| c.path).err().map(|e| e.to_string());
        assert!(
            message
                .as_deref()
                .is_some_and(|m| m.contains("max_compute_invocations_per_workgroup")),
            "{message:?}"
        );
    }

    #[test]
    fn a_lone_cloth_takes_the_path_its_adapter_class_steps_faster() {
        let limits = wgpu::Limits::default();
        let small = inputs(Integrator::Explicit, TINY.particles, &limits);
        let hanging = inputs(Integrator::Explicit, HANGING.particles, &limits);
        // Two cores: one workgroup leaves one idle and pays a switch per
        // barrier.
        let cpu = wgpu::DeviceType::Cpu;
        assert_eq!(auto(&hanging, &HANGING, cpu), Some(StepPath::MultiDispatch));
        // A GPU: thirteen launches cost more than a tiny cloth's work.
        let gpu = wgpu::DeviceType::DiscreteGpu;
        assert_eq!(auto(&small, &TINY, gpu), Some(StepPath::Workgroup));
        let chosen = choose(&hanging, None, &HANGING, &cost(cpu));
        let reason = chosen.map(|c| c.reason).unwrap_or_default();
        assert!(
            reason.starts_with("est. ") && reason.contains(" µs vs ") && reason.contains("CPU"),
            "{reason}"
        );
        // Forcing either path where both can step the cloth is obeyed.
        for path in [StepPath::Workgroup, StepPath::MultiDispatch] {
            let forced = choose(&hanging, Some(path), &HANGING, &cost(cpu));
            assert_eq!(forced.map(|c| c.path).ok(), Some(path));
        }
    }

    #[test]
    fn estimates_print_to_two_significant_figures() {
        assert_eq!(micros(1349.0), "1300 µs");
        assert_eq!(micros(43.2), "43 µs");
        assert_eq!(micros(4.66), "4.7 µs");
        assert_eq!(micros(0.123), "0.12 µs");
    }
}
