//! The GPU solver: WGSL compute kernels on storage buffers, recorded into
//! the host's command encoder.
//!
//! - [`GpuSolver`] borrows the host's device and queue, records steps into
//!   the host's encoder and exposes its position, normal and index buffers
//!   for drawing;
//! - [`layout`] holds the Pod twins of the WGSL structs;
//! - [`shaders`] composes the kernels (one per file in `shaders/`);
//! - [`context`] opens an adapter and device for tools and tests (the solver
//!   itself never does).

mod build;
pub mod context;
mod control;
mod divergence;
mod errors;
pub mod grid;
pub mod layout;
pub mod pipelines;
pub mod readback;
mod semi_filter;
pub mod shaders;
mod solver;
mod tuning;

pub use context::GpuContext;
pub(crate) use errors::guarded;
pub use grid::GridBlock;
pub use semi_filter::{FILTER_CG_MAX_ITERATIONS, FILTER_CG_TOLERANCE};
pub use solver::{GpuSolver, GpuState, GpuStatus, SINGLE_PASS, WORKGROUP};
pub use tuning::{GpuTuning, GpuTuningMut};
