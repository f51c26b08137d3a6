//! The step plan: the typed list of dispatches a step records, built from
//! the solver's counts and the scene's features.
//!
//! Only what the scene uses is recorded: no fix-up passes without a
//! constrained spring kind or with zero iterations; no torque passes for a
//! pinned cloth; no per-spring pass on a grid (see [`super::grid`]: the
//! kernels compute each spring's force, or its implicit linearisation,
//! where they gather it); without fix-up an explicit step on a grid is one
//! pass (a single-pass step, below), and the general kernels fuse
//! integration and step end after their spring pass when there is no wind
//! or linear bending either; wind, ground, spheres, pins and damping are compiled out of the
//! kernels when absent (see [`super::kernels`]); CG records the budget of
//! iterations (see [`super::budget`]) and stops on the device, after which
//! its per-particle passes are dispatched with zero workgroups. The
//! fix-up, too, stops on the device once a pass moves nothing.
//!
//! On the workgroup path ([`StepPath::Workgroup`]) a step is one dispatch
//! of the integrator's workgroup kernel ([`Launch::Cloths`]), which runs
//! all of the above inside one workgroup, barriers between its phases.
//!
//! A single-pass explicit step reads every particle's neighbours, so it
//! cannot update the state in place: consecutive steps alternate between
//! the x, v buffers and a snapshot in `work`
//! ([`Variant::ToSnapshot`], [`Variant::FromSnapshot`]), two stores per
//! particle and step. An odd number of steps starts with `explicit_seed`
//! (a copy into the snapshot), so the last step always writes x and v.

use super::kernel::{Dispatch, FixupPhase, Kernel, Launch, RespondPass, Variant};
use super::kernels::Features;
use super::path::StepPath;
use crate::aggregation::SLOTS_PER_LEVEL2;
use crate::kernel_config::{SUM_GROUP, WORKGROUP};
use crate::params::Integrator;

/// What the plan depends on besides the features.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PlanInputs {
    /// The integrator.
    pub integrator: Integrator,
    /// The features the kernels are specialised for.
    pub features: Features,
    /// Particles.
    pub particles: u32,
    /// Spring slots on the device.
    pub spring_slots: u32,
    /// Invocations of the kernels that gather from neighbours: grid blocks
    /// on a grid, else particles.
    pub gather: u32,
    /// The coarse levels' level-1 and level-2 aggregates (zero without).
    pub aggregates: [u32; 2],
    /// Free particles of the dense semi-implicit filter (0: CG filter).
    pub filter_count: u32,
    /// The semi-implicit torque compensation applies.
    pub torque: bool,
    /// Fix-up passes per step.
    pub fixup_iterations: u32,
    /// Self-collision passes per step (0: none).
    pub self_collision_passes: u32,
    /// How a step is recorded.
    pub path: StepPath,
}

/// One part of a step: a dispatch, or the CG iterations, which repeat
/// their dispatches once per iteration of the budget.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Part<T> {
    /// Recorded once.
    Once(T),
    /// Recorded once per CG iteration, in order; each launches from the
    /// iteration's slot.
    CgIterations(Vec<T>),
}

/// The plan of a step, over entries `T` (a [`Dispatch`], or one with its
/// pipeline).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Plan<T> {
    /// Recorded before the first of an odd number of single-pass steps.
    pub seed: Option<T>,
    /// A step whose state is in x and v (`[0]`) or in the snapshot
    /// (`[1]`); the same unless the steps are single-pass.
    pub steps: [Vec<Part<T>>; 2],
    /// Single-pass steps: each moves the state between x, v and the
    /// snapshot.
    pub alternates: bool,
}

impl Plan<Dispatch> {
    /// The plan of `inputs`.
    pub fn new(inputs: &PlanInputs) -> Plan<Dispatch> {
        if let Some(kernel) = workgroup_kernel(inputs) {
            let step = Dispatch::direct(kernel, SUM_GROUP).launched(Launch::Cloths(1));
            return Plan {
                seed: None,
                steps: [vec![Part::Once(step)], vec![Part::Once(step)]],
                alternates: false,
            };
        }
        if single_pass_explicit(inputs) {
            let step = Dispatch::direct(Kernel::ExplicitIntegrate, inputs.gather);
            return Plan {
                seed: Some(Dispatch::direct(Kernel::ExplicitSeed, inputs.particles)),
                steps: [
                    vec![Part::Once(step.of(Variant::ToSnapshot))],
                    vec![Part::Once(step.of(Variant::FromSnapshot))],
                ],
                alternates: true,
            };
        }
        let step = step(inputs);
        Plan {
            seed: None,
            steps: [step.clone(), step],
            alternates: false,
        }
    }
}

impl<T> Plan<T> {
    /// The same plan with each entry mapped by `f`, or `f`'s first error.
    pub fn try_map<U, E>(&self, mut f: impl FnMut(&T) -> Result<U, E>) -> Result<Plan<U>, E> {
        let mut part = |p: &Part<T>| -> Result<Part<U>, E> {
            Ok(match p {
                Part::Once(t) => Part::Once(f(t)?),
                Part::CgIterations(ts) => {
                    Part::CgIterations(ts.iter().map(&mut f).collect::<Result<_, _>>()?)
                }
            })
        };
        let steps = [
            self.steps[0]
                .iter()
                .map(&mut part)
                .collect::<Result<_, _>>()?,
            self.steps[1]
                .iter()
                .map(&mut part)
                .collect::<Result<_, _>>()?,
        ];
        Ok(Plan {
            seed: self.seed.as_ref().map(&mut f).transpose()?,
            steps,
            alternates: self.alternates,
        })
    }

    /// Visits the entries of `steps` steps in recording order, with the
    /// CG iterations repeated `cg_budget` times; `f` gets each entry and
    /// the CG iteration it belongs to (0 outside the iterations).
    pub fn for_each<'a>(&'a self, steps: u32, cg_budget: u32, mut f: impl FnMut(&'a T, u32)) {
        let mut in_snapshot = false;
        if self.alternates && steps % 2 == 1 {
            if let Some(seed) = &self.seed {
                f(seed, 0);
                in_snapshot = true;
            }
        }
        for _ in 0..steps {
            self.for_each_in_step(usize::from(in_snapshot), cg_budget, &mut f);
            in_snapshot ^= self.alternates;
        }
    }

    /// Visits the entries of step `which` (`0`: its state is in x and v;
    /// `1`: in the snapshot) as [`Plan::for_each`] does.
    pub fn for_each_in_step<'a>(
        &'a self,
        which: usize,
        cg_budget: u32,
        mut f: impl FnMut(&'a T, u32),
    ) {
        for part in &self.steps[which] {
            match part {
                Part::Once(t) => f(t, 0),
                Part::CgIterations(ts) => {
                    for iteration in 0..cg_budget {
                        for t in ts {
                            f(t, iteration);
                        }
                    }
                }
            }
        }
    }

    /// Entries recorded per CG iteration of a step (0: no CG).
    pub fn per_cg_iteration(&self) -> u32 {
        self.steps[0]
            .iter()
            .map(|p| match p {
                Part::CgIterations(ts) => ts.len() as u32,
                Part::Once(_) => 0,
            })
            .sum()
    }

    /// Every entry of the plan, once each (for compiling its pipelines).
    pub fn entries(&self) -> impl Iterator<Item = &T> {
        let parts = self.steps.iter().flatten().flat_map(|p| match p {
            Part::Once(t) => std::slice::from_ref(t),
            Part::CgIterations(ts) => ts.as_slice(),
        });
        self.seed.iter().chain(parts)
    }
}

impl<P> Plan<(Dispatch, P)> {
    /// The dispatches of `steps` steps as [`Plan::for_each`] visits them
    /// (`None`: one step of a long run, reading x and v, without the
    /// seed), each CG iteration's launching from its own slots.
    pub fn dispatches(&self, steps: Option<u32>, cg_budget: u32) -> Vec<Dispatch> {
        let mut out = Vec::new();
        let push = |(d, _): &(Dispatch, P), k| out.push(in_iteration(*d, k));
        match steps {
            Some(n) => self.for_each(n, cg_budget, push),
            None => self.for_each_in_step(0, cg_budget, push),
        }
        out
    }
}

/// A dispatch of the CG iterations in iteration `k`: the plan's slot
/// launches count from their iteration, so each launches from its own.
pub(super) fn in_iteration(d: Dispatch, k: u32) -> Dispatch {
    match d.launch {
        Launch::ApplySlot(j) => d.launched(Launch::ApplySlot(j + k)),
        Launch::UpdateSlot(j) => d.launched(Launch::UpdateSlot(j + k)),
        Launch::Direct | Launch::Cloths(_) => d,
    }
}

/// The workgroup kernel of a step on the workgroup path: one per
/// integrator.
fn workgroup_kernel(i: &PlanInputs) -> Option<Kernel> {
    if i.path != StepPath::Workgroup {
        return None;
    }
    match i.integrator {
        Integrator::Explicit => Some(Kernel::ClothExplicit),
        Integrator::Implicit => Some(Kernel::ClothImplicit),
        Integrator::SemiImplicit => Some(Kernel::ClothSemiImplicit),
    }
}

/// Explicit steps on a grid without fix-up integrate and finish in one
/// kernel.
fn single_pass_explicit(i: &PlanInputs) -> bool {
    i.integrator == Integrator::Explicit
        && i.fixup_iterations == 0
        && i.features.grid
        && !i.features.self_collision
}

/// Self-collision (see `shaders/common/self_collision.wgsl`): the grid's
/// build, then its passes, the last capping the step's displacement.
fn self_collision(i: &PlanInputs, plan: &mut Vec<Part<Dispatch>>) {
    if !i.features.self_collision {
        return;
    }
    let n = i.particles;
    let once = |k: Kernel, items: u32| Part::Once(Dispatch::direct(k, items));
    plan.extend([
        once(Kernel::SelfCollisionCount, n),
        once(Kernel::SelfCollisionScan, WORKGROUP),
        once(Kernel::SelfCollisionScatter, n),
        once(Kernel::SelfCollisionRank, n),
    ]);
    let passes = i.self_collision_passes;
    for k in 0..passes {
        let pass = Variant::Respond(RespondPass::of(k, passes));
        plan.push(Part::Once(
            Dispatch::direct(Kernel::SelfCollisionRespond, n).of(pass),
        ));
    }
}

/// The parts of a step that is not single-pass.
fn step(i: &PlanInputs) -> Vec<Part<Dispatch>> {
    let (n, s, gather) = (i.particles, i.spring_slots, i.gather);
    let f = i.features;
    let once = |k: Kernel, items: u32| Part::Once(Dispatch::direct(k, items));
    let mut plan = Vec::new();
    match i.integrator {
        Integrator::Implicit => {
            // On a grid the gathering kernels linearise the springs they
            // use: no spring pass.
            if !f.grid {
                plan.push(once(Kernel::ImplicitSprings, s));
            }
            plan.push(once(Kernel::ImplicitPrepare, gather));
            if f.coarse {
                plan.push(once(Kernel::CoarseSetup, i.aggregates[0] + i.aggregates[1]));
            }
            cg(i, &mut plan);
            if f.self_collision {
                let finish = Dispatch::direct(Kernel::ImplicitFinish, n);
                plan.push(Part::Once(finish.of(Variant::ImplicitPredict)));
                self_collision(i, &mut plan);
                plan.push(Part::Once(finish.of(Variant::ImplicitProject)));
            } else {
                plan.push(once(Kernel::ImplicitFinish, n));
            }
            return plan;
        }
        Integrator::Explicit if f.grid => {
            plan.push(once(Kernel::ExplicitIntegrate, gather));
        }
        Integrator::Explicit => {
            plan.push(once(Kernel::SpringForces, s));
            // Wind and bending read the neighbours' state: not in place.
            if i.fixup_iterations == 0 && !f.wind && !f.bending && !f.self_collision {
                let fused = Dispatch::direct(Kernel::ExplicitIntegrate, n).of(Variant::Fused);
                plan.push(Part::Once(fused));
                return plan;
            }
            plan.push(once(Kernel::ExplicitIntegrate, n));
        }
        Integrator::SemiImplicit => {
            if !f.grid {
                plan.push(once(Kernel::SpringForces, s));
            }
            if i.filter_count > 0 {
                plan.push(once(Kernel::SemiRhs, n));
                plan.push(once(Kernel::FilterDense, i.filter_count));
            } else {
                let keep = Dispatch::direct(Kernel::SemiRhs, n).of(Variant::KeepDv);
                plan.push(Part::Once(keep));
                plan.push(once(Kernel::SemiCgPrepare, n));
                if f.coarse {
                    plan.push(once(Kernel::CoarseSetup, i.aggregates[0] + i.aggregates[1]));
                }
                cg(i, &mut plan);
            }
            if i.torque {
                plan.extend([
                    once(Kernel::TorqueCentre, n),
                    once(Kernel::TorqueMoments, n),
                    once(Kernel::TorqueApply, n),
                ]);
            }
            plan.push(once(Kernel::SemiIntegrate, n));
        }
    }
    for k in 0..i.fixup_iterations {
        let variant = if k == 0 {
            Variant::FixupFirst
        } else {
            Variant::Fixup(FixupPhase::of_pass(k))
        };
        plan.push(Part::Once(
            Dispatch::direct(Kernel::FixupJacobi, gather).of(variant),
        ));
    }
    self_collision(i, &mut plan);
    plan.push(once(Kernel::FinishStep, n));
    plan
}

/// The CG solve: cg_init, with coarse levels the first cg_update, then
/// two dispatches per iteration, cg_apply and cg_update.
///
/// No one-workgroup kernel: each kernel writes a partial sum per
/// workgroup of the dot-product terms it produces, and every workgroup
/// of the next one adds all of them in the same fixed order, so they
/// agree on α, β and the stop without communicating (see
/// `shaders/common/cg.wgsl` and [`crate::cpu`]'s `cg`). cg_init and
/// cg_apply gather one particle per invocation on a grid too, so that a
/// workgroup's partials cover one reduction block; with coarse levels
/// cg_update takes a slot of the level-2-major order of the level-1
/// aggregates per invocation, and cg_apply adds the level-2 corrections to
/// each `s` it loads.
///
/// The per-iteration kernels are dispatched indirectly, each from its
/// iteration's slot: a dispatch whose invocations all return at once
/// still runs its workgroups (on a CPU adapter, the masked-off code too),
/// while an indirect dispatch of zero workgroups runs none.
fn cg(i: &PlanInputs, plan: &mut Vec<Part<Dispatch>>) {
    let n = i.particles;
    let update = if i.features.coarse {
        i.aggregates[1] * SLOTS_PER_LEVEL2 as u32
    } else {
        n
    };
    plan.push(Part::Once(Dispatch::direct(Kernel::CgInit, n)));
    if i.features.coarse {
        let first = Dispatch::direct(Kernel::CgUpdate, update).of(Variant::CgFirst);
        plan.push(Part::Once(first));
    }
    plan.push(Part::CgIterations(vec![
        Dispatch::direct(Kernel::CgApply, n).launched(Launch::ApplySlot(0)),
        Dispatch::direct(Kernel::CgUpdate, update).launched(Launch::UpdateSlot(0)),
    ]));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aggregation::Aggregation;

    /// A plain sheet of `side × side` particles pinned at two corners, on
    /// the multi-dispatch path: grid kernels, pins (a filter), damped
    /// springs, no collider, wind or fix-up; coarse levels for CG (the
    /// semi-implicit one the CG-solved filter).
    fn sheet(integrator: Integrator, side: u32) -> PlanInputs {
        let n = side * side;
        let agg = Aggregation::for_grid(Some((side as usize, side as usize)))
            .filter(|_| integrator != Integrator::Explicit);
        PlanInputs {
            integrator,
            features: Features {
                filter: true,
                damping: true,
                grid: true,
                coarse: agg.is_some(),
                constant_blocks: integrator == Integrator::SemiImplicit,
                ..Features::default()
            },
            particles: n,
            spring_slots: 6 * n,
            gather: n,
            aggregates: agg.map_or([0, 0], |a| [a.count(0) as u32, a.count(1) as u32]),
            filter_count: 0,
            torque: false,
            fixup_iterations: 0,
            self_collision_passes: 0,
            path: StepPath::MultiDispatch,
        }
    }

    /// The kernels of a step outside the CG iterations, and those of one
    /// iteration.
    fn shape(plan: &Plan<Dispatch>) -> (Vec<(Kernel, Variant)>, Vec<Kernel>) {
        let mut outside = Vec::new();
        let mut iteration = Vec::new();
        for part in &plan.steps[0] {
            match part {
                Part::Once(d) => outside.push(d.pipeline()),
                Part::CgIterations(ds) => iteration = ds.iter().map(|d| d.kernel).collect(),
            }
        }
        (outside, iteration)
    }

    /// The plan: at most eight dispatches outside the iterations
    /// for a plain pinned sheet and two per CG iteration, at every size;
    /// adding a dispatch to either fails here.
    #[test]
    fn a_plain_pinned_sheet_records_two_dispatches_per_cg_iteration() {
        for side in [15, 33, 65, 129, 257, 513] {
            let plan = Plan::new(&sheet(Integrator::Implicit, side));
            let (outside, iteration) = shape(&plan);
            assert_eq!(
                outside,
                [
                    (Kernel::ImplicitPrepare, Variant::Plain),
                    (Kernel::CoarseSetup, Variant::Plain),
                    (Kernel::CgInit, Variant::Plain),
                    (Kernel::CgUpdate, Variant::CgFirst),
                    (Kernel::ImplicitFinish, Variant::Plain),
                ],
                "implicit {side}²"
            );
            assert_eq!(iteration, [Kernel::CgApply, Kernel::CgUpdate], "{side}²");
            assert_eq!(plan.per_cg_iteration(), 2);
            let plan = Plan::new(&sheet(Integrator::SemiImplicit, side));
            let (outside, iteration) = shape(&plan);
            assert_eq!(
                outside,
                [
                    (Kernel::SemiRhs, Variant::KeepDv),
                    (Kernel::SemiCgPrepare, Variant::Plain),
                    (Kernel::CoarseSetup, Variant::Plain),
                    (Kernel::CgInit, Variant::Plain),
                    (Kernel::CgUpdate, Variant::CgFirst),
                    (Kernel::SemiIntegrate, Variant::Plain),
                    (Kernel::FinishStep, Variant::Plain),
                ],
                "semi-implicit {side}²"
            );
            assert_eq!(iteration, [Kernel::CgApply, Kernel::CgUpdate], "{side}²");
        }
    }

    /// The CG kernels gather one particle per invocation whatever the
    /// grid block (their partial sums cover CG blocks of particles), and
    /// a coarse cg_update takes one invocation per slot of the
    /// level-2-major order.
    #[test]
    fn the_cg_kernels_take_a_particle_or_a_slot_per_invocation() {
        let mut inputs = sheet(Integrator::Implicit, 37);
        inputs.gather = 100;
        let plan = Plan::new(&inputs);
        let mut seen = 0;
        plan.for_each_in_step(0, 1, |d, _| {
            let want = match d.kernel {
                Kernel::CgInit | Kernel::CgApply => 37 * 37,
                Kernel::CgUpdate => 9 * 16,
                _ => return,
            };
            seen += 1;
            assert_eq!(d.items, want, "{:?}", d.kernel);
        });
        assert_eq!(seen, 4);
    }
}
