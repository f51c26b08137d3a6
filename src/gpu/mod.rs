//! The GPU solver: WGSL compute kernels on storage buffers, recorded into
//! the host's command encoder.
//!
//! - [`GpuSolver`] borrows the host's device and queue, records steps into
//!   the host's encoder and exposes its position, normal and index buffers
//!   for drawing;
//! - [`GpuBatch`] steps many cloths together, each drawable from the
//!   batch's buffers;
//! - [`GpuContext`] opens an adapter and device for tools and tests (the
//!   solver itself never does), and [`quiet_mesa`] settles the
//!   environment Mesa's drivers expect, for hosts on Linux;
//! - [`GpuSolver::tuning`] and [`GpuSolver::tuning_mut`] inspect and set
//!   the knobs benchmarks and tests use ([`GpuTuning`], [`GpuTuningMut`]).

mod batch;
mod buffers;
pub(crate) mod build;
mod cg_budget;
mod context;
mod control;
mod debug;
mod divergence;
mod errors;
mod grid;
mod host_env;
mod kernel;
mod kernels;
pub mod pipeline_cache;
// The kernels' buffer layouts, pipelines, read-back and WGSL sources:
// reached by `tests/shaders.rs` and `tests/gpu_behaviour.rs`; not part of
// the embedding API.
#[doc(hidden)]
pub mod layout;
mod path;
mod path_cost;
mod plan;
mod profile;
#[doc(hidden)]
pub mod readback;
mod render_mesh;
mod semi_filter;
#[doc(hidden)]
pub mod shaders;
mod solver;
mod traffic;
mod tuning;
mod velocity;

pub use batch::{ClothId, DrawRange, GpuBatch};
pub use context::{GpuContext, BACKEND_NAMES};
pub(crate) use errors::guarded;
pub use grid::GridBlock;
pub use host_env::quiet_mesa;
pub use path::StepPath;
pub use render_mesh::{GpuRenderMesh, SkinLayout};
pub use semi_filter::{FILTER_CG_MAX_ITERATIONS, FILTER_CG_TOLERANCE};
pub use solver::{GpuSolver, GpuState};
// The kernels' typed identity and the debug API that runs them one by one:
// reached by `tests/kernel_twins.rs` and `tests/gpu_skipping.rs`.
/// The workgroup size of every per-particle and per-spring kernel (see
/// [`crate::kernel_config::WORKGROUP`]).
pub use crate::kernel_config::WORKGROUP;
#[doc(hidden)]
pub use debug::{DebugBuffer, DebugLayout};
#[doc(hidden)]
pub use kernel::{ArgsGroup, Dispatch, FixupPhase, Kernel, Launch, Variant};
pub use kernels::GpuKernels;
#[doc(hidden)]
pub use kernels::SourcePatch;
// The profiler behind `wgcloth run --profile` and its traffic table.
#[doc(hidden)]
pub use kernels::{sum_group, Features};
#[doc(hidden)]
pub use profile::{Profile, ProfileRow, Profiler, RecordingCost, Timestamps};
#[doc(hidden)]
pub use traffic::{Term, Unit, UnitCounts};
pub use tuning::{GpuTuning, GpuTuningMut};
