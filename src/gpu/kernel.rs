//! The typed identity of every compute kernel: [`Kernel`] (one per
//! `shaders/NAME.wgsl`, whose entry point is `NAME`), its [`Variant`]s
//! (values of the kernel's own `override` constants), how a dispatch of it
//! is launched ([`Launch`]), and a step's entries ([`Dispatch`]).

use crate::kernel_config::work;

/// One compute kernel: the file `shaders/NAME.wgsl` and its entry point
/// `NAME` ([`Kernel::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kernel {
    /// Per spring: the spring force on each end (general layout).
    SpringForces,
    /// Per particle: explicit integration (and, fused, the step end).
    ExplicitIntegrate,
    /// Per particle: copies the state into the snapshot before an odd
    /// number of single-pass explicit steps.
    ExplicitSeed,
    /// Per particle: one Jacobi pass of the length fix-up.
    FixupJacobi,
    /// Per particle: the step end (velocity from the fix-up, collisions,
    /// the finite check).
    FinishStep,
    /// Per particle: vertex normals (rendering only).
    Normals,
    /// Per render vertex: its position and normal on the cloth (rendering
    /// only; see [`crate::render_mesh`]).
    Skin,
    /// Per spring: the implicit linearisation (spring blocks).
    ImplicitSprings,
    /// Per particle: the implicit system, its right-hand side and filter.
    ImplicitPrepare,
    /// Per aggregate: the coarse levels' diagonal blocks.
    CoarseSetup,
    /// Per particle: CG's initial residual, the partial sums of δ0 and
    /// ρ, the first iteration's slot.
    CgInit,
    /// Per particle: the convergence test and β from the partials, then
    /// c = s + β c, q = A c and cᵀq's partial sums.
    CgApply,
    /// Per particle (per slot of the level-2-major order of the level-1
    /// aggregates with coarse levels): α from the partials, then the CG
    /// update of Δv, r and s and ρ's partial sums.
    CgUpdate,
    /// Per particle: the implicit step's end (with self-collision, its
    /// stages before and after it: [`Variant::ImplicitPredict`],
    /// [`Variant::ImplicitProject`]).
    ImplicitFinish,
    /// Per particle: self-collision's cells and bucket counts.
    SelfCollisionCount,
    /// One workgroup: self-collision's bucket runs (a prefix sum).
    SelfCollisionScan,
    /// Per particle: self-collision's scatter into the bucket runs.
    SelfCollisionScatter,
    /// Per particle: self-collision's runs in index order.
    SelfCollisionRank,
    /// Per particle: one Jacobi pass of self-collision's response.
    SelfCollisionRespond,
    /// Per particle: the semi-implicit right-hand side.
    SemiRhs,
    /// Per free particle: the dense semi-implicit filter's product.
    FilterDense,
    /// Torque compensation: the centre of mass.
    TorqueCentre,
    /// Torque compensation: the moments.
    TorqueMoments,
    /// Torque compensation: the correction.
    TorqueApply,
    /// Per particle: the semi-implicit integration.
    SemiIntegrate,
    /// Per particle: the semi-implicit filter's CG system.
    SemiCgPrepare,
    /// Per cloth, one workgroup each: a whole explicit step (the
    /// workgroup path, see [`StepPath`](super::StepPath)).
    ClothExplicit,
    /// Per cloth, one workgroup each: a whole implicit step, CG included
    /// (the workgroup path).
    ClothImplicit,
    /// Per cloth, one workgroup each: a whole semi-implicit step with the
    /// dense filter.
    ClothSemiImplicit,
}

/// `(kernel, name, WGSL source before composition)`, in [`Kernel::ALL`]
/// order.
macro_rules! kernels {
    ($($kernel:ident = $name:literal),* $(,)?) => {
        impl Kernel {
            /// Every kernel.
            pub const ALL: [Kernel; [$($name),*].len()] = [$(Kernel::$kernel),*];

            /// The file stem and entry point.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Kernel::$kernel => $name,)*
                }
            }

            /// The kernel's WGSL before `#include`s are resolved, embedded
            /// at compile time.
            pub const fn source(self) -> &'static str {
                match self {
                    $(Kernel::$kernel => include_str!(concat!("../../shaders/", $name, ".wgsl")),)*
                }
            }
        }
    };
}

kernels! {
    SpringForces = "spring_forces",
    ExplicitIntegrate = "explicit_integrate",
    ExplicitSeed = "explicit_seed",
    FixupJacobi = "fixup_jacobi",
    FinishStep = "finish_step",
    Normals = "normals",
    Skin = "skin",
    ImplicitSprings = "implicit_springs",
    ImplicitPrepare = "implicit_prepare",
    CoarseSetup = "coarse_setup",
    CgInit = "cg_init",
    CgApply = "cg_apply",
    CgUpdate = "cg_update",
    ImplicitFinish = "implicit_finish",
    SelfCollisionCount = "self_collision_count",
    SelfCollisionScan = "self_collision_scan",
    SelfCollisionScatter = "self_collision_scatter",
    SelfCollisionRank = "self_collision_rank",
    SelfCollisionRespond = "self_collision_respond",
    SemiRhs = "semi_rhs",
    FilterDense = "filter_dense",
    TorqueCentre = "torque_centre",
    TorqueMoments = "torque_moments",
    TorqueApply = "torque_apply",
    SemiIntegrate = "semi_integrate",
    SemiCgPrepare = "semi_cg_prepare",
    ClothExplicit = "cloth_explicit",
    ClothImplicit = "cloth_implicit",
    ClothSemiImplicit = "cloth_semi_implicit",
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The buffers a kernel that writes indirect dispatch arguments binds as
/// its group 1 (see `apply_args` in `shaders/common/cg.wgsl`): a kernel
/// may not bind the buffer it is dispatched from, so cg_apply and
/// cg_update each bind only the other's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ArgsGroup {
    /// cg_init: `apply_args`, `update_args`.
    Start,
    /// cg_apply: `update_args`.
    Apply,
    /// cg_update: `apply_args`.
    Update,
}

impl ArgsGroup {
    /// Every group, in the order the solver stores them.
    pub const ALL: [ArgsGroup; 3] = [ArgsGroup::Start, ArgsGroup::Apply, ArgsGroup::Update];

    /// Its index in [`ArgsGroup::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The group-1 bindings: 0 `apply_args`, 1 `update_args`.
    pub const fn bindings(self) -> &'static [u32] {
        match self {
            ArgsGroup::Start => &[0, 1],
            ArgsGroup::Apply => &[1],
            ArgsGroup::Update => &[0],
        }
    }
}

impl Kernel {
    /// Whether the kernel steps whole cloths, one workgroup each, from the
    /// cloth table (binding 0 a storage array of parameters: see
    /// `shaders/common/cloth_bindings.wgsl`).
    pub const fn steps_cloths(self) -> bool {
        matches!(
            self,
            Kernel::ClothExplicit | Kernel::ClothImplicit | Kernel::ClothSemiImplicit
        )
    }

    /// Whether the kernel binds a group of its own instead of the cloth's
    /// (`common/layout.wgsl`), and so declares none of its scene-feature
    /// overrides: `skin`, which reads a cloth as it is drawn.
    pub const fn has_own_bindings(self) -> bool {
        matches!(self, Kernel::Skin)
    }

    /// The group 1 of a kernel that writes indirect dispatch arguments.
    pub const fn args_group(self) -> Option<ArgsGroup> {
        match self {
            Kernel::CgInit => Some(ArgsGroup::Start),
            Kernel::CgApply => Some(ArgsGroup::Apply),
            Kernel::CgUpdate => Some(ArgsGroup::Update),
            _ => None,
        }
    }

    /// Invocations per workgroup of a direct or slot launch: the CG
    /// kernels' [`CG_GROUP`](crate::kernel_config::CG_GROUP) (the block of
    /// their reductions), else [`WORKGROUP`](crate::kernel_config::WORKGROUP).
    /// The workgroup kernels are launched a workgroup per cloth.
    pub const fn workgroup_size(self) -> u32 {
        match self {
            Kernel::CgInit | Kernel::CgApply | Kernel::CgUpdate => crate::kernel_config::CG_GROUP,
            _ => crate::kernel_config::WORKGROUP,
        }
    }

    /// Whether the kernel's grid gather takes the solver's block shape
    /// ([`GridBlock`](super::GridBlock)). The CG kernels gather one
    /// particle per invocation: each workgroup's partial sums then cover
    /// the particles of one of the CPU mirror's reduction blocks whatever
    /// the shape.
    pub const fn takes_grid_block(self) -> bool {
        !matches!(self, Kernel::CgInit | Kernel::CgApply)
    }
}

/// Which fix-up pass of a step a `fixup_jacobi` pipeline runs, after the
/// first: pass `k` is phase `k mod 6` (which section it reads, by parity,
/// and which of three rotating flags it sets).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FixupPhase(u8);

impl FixupPhase {
    /// The phase of pass `k ≥ 1`.
    pub const fn of_pass(k: u32) -> FixupPhase {
        FixupPhase((k % 6) as u8)
    }

    /// `k mod 6` of the passes of this phase.
    pub const fn index(self) -> u32 {
        self.0 as u32
    }
}

/// A kernel's specialisation beyond the scene's features: values of its
/// own `override` constants. Each variant but [`Variant::Plain`] belongs to
/// one kernel ([`Variant::kernel`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Variant {
    /// The kernel's own constants at their defaults.
    Plain,
    /// `explicit_integrate` with the step end fused after it (explicit
    /// steps without fix-up or wind, general layout).
    Fused,
    /// `explicit_integrate` as a whole single-pass step, from the state
    /// buffers into the snapshot (see [`work::SNAPSHOT`]).
    ToSnapshot,
    /// `explicit_integrate` as a whole single-pass step, from the snapshot
    /// into the state buffers.
    FromSnapshot,
    /// `fixup_jacobi`'s first pass of a step: reads the predicted
    /// positions, finds no previous pass.
    FixupFirst,
    /// `fixup_jacobi`'s later passes.
    Fixup(FixupPhase),
    /// `cg_update` preconditioning the initial residual (coarse levels).
    CgFirst,
    /// `semi_rhs` keeping Δv for the CG's warm start.
    KeepDv,
    /// `implicit_finish` storing the prediction for self-collision.
    ImplicitPredict,
    /// `implicit_finish` ending the step after self-collision.
    ImplicitProject,
    /// A `self_collision_respond` pass.
    Respond(RespondPass),
}

/// Which pass of a step a `self_collision_respond` pipeline runs: its
/// sections (the first reads `SC_A`, then `SC_B` and `SC_C` alternate,
/// see `sc_pass_src` in `shaders/common/self_collision.wgsl`) and whether
/// it is the last (which caps and writes where the step's end reads).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RespondPass {
    /// 0 the first pass, 1 an odd one, 2 an even one after the first.
    phase: u8,
    last: bool,
}

impl RespondPass {
    /// Pass `k` of `passes`.
    pub const fn of(k: u32, passes: u32) -> RespondPass {
        let phase = if k == 0 { 0 } else { 2 - (k % 2) as u8 };
        RespondPass {
            phase,
            last: k + 1 == passes,
        }
    }
}

/// `STATE_BUFFERS` in the kernels: read or write x and v.
const STATE_BUFFERS: f64 = u32::MAX as f64;

impl Variant {
    /// The kernel the variant belongs to; `None` for [`Variant::Plain`],
    /// which every kernel has.
    pub const fn kernel(self) -> Option<Kernel> {
        match self {
            Variant::Plain => None,
            Variant::Fused | Variant::ToSnapshot | Variant::FromSnapshot => {
                Some(Kernel::ExplicitIntegrate)
            }
            Variant::FixupFirst | Variant::Fixup(_) => Some(Kernel::FixupJacobi),
            Variant::CgFirst => Some(Kernel::CgUpdate),
            Variant::KeepDv => Some(Kernel::SemiRhs),
            Variant::ImplicitPredict | Variant::ImplicitProject => Some(Kernel::ImplicitFinish),
            Variant::Respond(_) => Some(Kernel::SelfCollisionRespond),
        }
    }

    /// Whether `kernel` has this variant.
    pub fn is_of(self, kernel: Kernel) -> bool {
        self.kernel().is_none_or(|k| k == kernel)
    }

    /// The `override` constants of `kernel`'s pipeline of this variant
    /// (beyond the workgroup sizes and scene features every kernel takes).
    pub(crate) fn constants(self, kernel: Kernel) -> Vec<(&'static str, f64)> {
        let section = |s: u32| f64::from(s);
        let (pred, alt) = (section(work::X_PRED), section(work::X_ALT));
        match (kernel, self) {
            (Kernel::ExplicitSeed, _) => vec![("SNAP", section(work::SNAPSHOT))],
            (Kernel::FixupJacobi, Variant::FixupFirst) => {
                vec![("SRC", pred), ("DST", alt), ("FLAG", 0.0), ("FIRST", 1.0)]
            }
            (Kernel::FixupJacobi, Variant::Fixup(phase)) => {
                let k = phase.index();
                let (src, dst) = if k % 2 == 1 { (alt, pred) } else { (pred, alt) };
                vec![
                    ("SRC", src),
                    ("DST", dst),
                    ("FLAG", f64::from(k % 3)),
                    ("FIRST", 0.0),
                ]
            }
            (Kernel::ExplicitIntegrate, Variant::Fused) => vec![("FUSED", 1.0)],
            (Kernel::ExplicitIntegrate, Variant::ToSnapshot) => vec![
                ("FUSED", 1.0),
                ("SNAP_IN", STATE_BUFFERS),
                ("SNAP_OUT", section(work::SNAPSHOT)),
            ],
            (Kernel::ExplicitIntegrate, Variant::FromSnapshot) => vec![
                ("FUSED", 1.0),
                ("SNAP_IN", section(work::SNAPSHOT)),
                ("SNAP_OUT", STATE_BUFFERS),
            ],
            (Kernel::CgUpdate, Variant::CgFirst) => vec![("FIRST", 1.0)],
            (Kernel::SemiRhs, Variant::KeepDv) => vec![("ZERO_DV", 0.0)],
            (Kernel::ImplicitFinish, Variant::ImplicitPredict) => vec![("STAGE", 1.0)],
            (Kernel::ImplicitFinish, Variant::ImplicitProject) => vec![("STAGE", 2.0)],
            (Kernel::SelfCollisionRespond, Variant::Respond(pass)) => vec![
                ("PASS", f64::from(pass.phase)),
                ("LAST", f64::from(u8::from(pass.last))),
            ],
            _ => Vec::new(),
        }
    }
}

/// How a dispatch finds its workgroup count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Launch {
    /// ⌈items / [`Kernel::workgroup_size`]⌉ workgroups.
    Direct,
    /// Indirectly from CG iteration `k`'s slot of `apply_args` (its
    /// workgroups while the iteration is due, else 0; see
    /// `shaders/common/cg.wgsl`).
    ApplySlot(u32),
    /// Indirectly from CG iteration `k`'s slot of `update_args`.
    UpdateSlot(u32),
    /// One workgroup per cloth of the cloth table, `n` cloths (the
    /// workgroup kernels, [`Kernel::steps_cloths`]).
    Cloths(u32),
}

/// Which buffer of indirect arguments a [`Launch`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ArgsBuffer {
    /// `apply_args`.
    Apply,
    /// `update_args`.
    Update,
}

impl Launch {
    /// The buffer and byte offset of an indirect launch's arguments;
    /// `None` for a direct one.
    pub(crate) fn args(self) -> Option<(ArgsBuffer, u64)> {
        let at = |k: u32| u64::from(k) * 12;
        match self {
            Launch::Direct | Launch::Cloths(_) => None,
            Launch::ApplySlot(k) => Some((ArgsBuffer::Apply, at(k))),
            Launch::UpdateSlot(k) => Some((ArgsBuffer::Update, at(k))),
        }
    }
}

/// Slots in `apply_args` and `update_args` for at most
/// `cg_max_iterations` recorded CG iterations: one per iteration and one
/// more (the one the last recorded iteration enables).
pub(crate) const fn arg_slots(cg_max_iterations: u32) -> u32 {
    cg_max_iterations + 1
}

/// `u32` words of `apply_args` and of `update_args` with `slots` slots,
/// three words each.
pub(crate) const fn args_words(slots: u32) -> u32 {
    3 * slots
}

/// One entry of a step's plan: a kernel variant over `items` invocations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dispatch {
    /// The kernel.
    pub kernel: Kernel,
    /// Its variant.
    pub variant: Variant,
    /// Invocations (particles, springs, grid blocks, slots of aggregates;
    /// a workgroup kernel: one workgroup's worth).
    pub items: u32,
    /// How its workgroup count is found.
    pub launch: Launch,
}

impl Dispatch {
    /// `kernel`'s plain variant over `items`, launched directly.
    pub const fn direct(kernel: Kernel, items: u32) -> Dispatch {
        Dispatch {
            kernel,
            variant: Variant::Plain,
            items,
            launch: Launch::Direct,
        }
    }

    /// The same dispatch of `variant`.
    pub const fn of(self, variant: Variant) -> Dispatch {
        Dispatch { variant, ..self }
    }

    /// The same dispatch launched by `launch`.
    pub const fn launched(self, launch: Launch) -> Dispatch {
        Dispatch { launch, ..self }
    }

    /// The pipeline it runs: kernel and variant.
    pub const fn pipeline(&self) -> (Kernel, Variant) {
        (self.kernel, self.variant)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kernel_has_its_own_name_and_file() {
        for (k, kernel) in Kernel::ALL.iter().enumerate() {
            assert!(
                Kernel::ALL[..k].iter().all(|o| o.name() != kernel.name()),
                "{kernel} named twice"
            );
            let entry = format!("fn {}(", kernel.name());
            assert!(
                kernel.source().contains(&entry),
                "shaders/{kernel}.wgsl has no entry point `{}`",
                kernel.name()
            );
        }
    }

    #[test]
    fn fixup_passes_alternate_sections_and_rotate_flags() {
        let get = |pass: u32, name: &str| {
            let v = if pass == 0 {
                Variant::FixupFirst
            } else {
                Variant::Fixup(FixupPhase::of_pass(pass))
            };
            v.constants(Kernel::FixupJacobi)
                .iter()
                .find(|c| c.0 == name)
                .map(|c| c.1)
        };
        for pass in 0..13 {
            // Each pass reads what the previous one wrote.
            if pass > 0 {
                assert_eq!(get(pass, "SRC"), get(pass - 1, "DST"), "pass {pass}");
            }
            assert_eq!(get(pass, "FLAG"), Some(f64::from(pass % 3)), "pass {pass}");
            assert_ne!(get(pass, "SRC"), get(pass, "DST"), "pass {pass}");
        }
    }
}
