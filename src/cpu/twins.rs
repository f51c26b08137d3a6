//! The CPU twins of the GPU kernels, for `tests/kernel_twins.rs`, which
//! runs each kernel alone on the device and its twin here on the same
//! inputs; not part of the embedding API.
//!
//! Each `shaders/NAME.wgsl` has a function carrying its name (its doc
//! comment says what it reads and writes, and where the GPU keeps
//! something else in a `w`):
//!
//! | kernel | twin |
//! | --- | --- |
//! | `spring_forces` | [`forces::spring_forces`] |
//! | `explicit_integrate` | [`explicit::integrate`] |
//! | `explicit_seed` | [`explicit::seed`] |
//! | `fixup_jacobi` | [`fixup::jacobi`] (one pass per dispatch) |
//! | `finish_step` | [`finish_step`] |
//! | `implicit_springs` | [`implicit::springs`] |
//! | `implicit_prepare` | [`implicit::prepare`] |
//! | `coarse_setup` | [`Coarse::setup`] |
//! | `cg_init` | [`cg::init`] |
//! | `cg_apply` | [`cg::apply`] (with coarse levels [`cg::prolong`] inside it) |
//! | `cg_update` | [`cg::update`] |
//! | `implicit_finish` | [`implicit::finish`] |
//! | `semi_rhs` | [`semi_implicit::rhs`] |
//! | `filter_dense` | [`DenseFilter::apply`] |
//! | `torque_centre` | [`torque::centre`] |
//! | `torque_moments` | [`torque::moments`] |
//! | `torque_apply` | [`torque::apply`] |
//! | `semi_integrate` | [`semi_implicit::integrate`] |
//! | `semi_cg_prepare` | [`semi_implicit::cg_prepare`] |
//!
//! `normals` (vertex normals for rendering) has none: the CPU solver
//! never renders, and stepping never reads normals.

pub use super::coarse::Coarse;
pub use super::filter::{ConstantFilter, DenseFilter};
pub use super::implicit::{Filter, SpringBlock};
pub use super::mat3::Sym3;
pub use super::{finish_step, fixup, CpuSolver, State, System, Workspace};
use crate::real::Real;

/// The spring pass.
pub mod forces {
    pub use crate::cpu::forces::{external_forces, spring_forces};
}

/// The explicit step's twins.
pub mod explicit {
    pub use crate::cpu::explicit::{integrate, seed};
}

/// The implicit step's twins, but CG's.
pub mod implicit {
    pub use crate::cpu::implicit::{finish, prepare, springs};
}

/// The CG kernels' twins and their scalars.
pub mod cg {
    pub use crate::cpu::cg::{
        apply, block_partials, block_sum, init, pairwise, prolong, residual_sums, sum_partials,
        update, Scalars,
    };
}

/// The semi-implicit step's twins, but the torque passes'.
pub mod semi_implicit {
    pub use crate::cpu::semi_implicit::{cg_prepare, integrate, rhs};
}

/// Self-collision's twins: `build` (of `self_collision_count`, `_scan`,
/// `_scatter` and `_rank` together), `bucket`, `pass` (of
/// `self_collision_respond`).
pub mod self_collision {
    pub use crate::cpu::self_collision::{bucket, build, pass, Grid};
    pub use crate::self_collision::SelfCollisionR;
}

/// The torque compensation's twins.
pub mod torque {
    pub use crate::cpu::torque::{apply, centre, centre_of_mass, moments, SLOTS};
}

/// A solver's system, state and workspace, for a test to load a kernel's
/// inputs into and run its twin on.
pub fn parts<R: Real>(solver: &mut CpuSolver<R>) -> (&System<R>, &mut State<R>, &mut Workspace<R>) {
    (&solver.sys, &mut solver.state, &mut solver.work)
}
