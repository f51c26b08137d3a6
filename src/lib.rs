//! # wgcloth
//!
//! Mass-spring cloth with three integrators — explicit (symplectic Euler +
//! Provot fix-up), implicit (Baraff–Witkin with filtered PCG) and
//! semi-implicit (Desbrun's constant filter) — on a CPU reference solver that
//! runs in `f64` (ground truth) or `f32` (the GPU's arithmetic).
//!
//! The pieces, each its own module:
//! - [`model`]: topology, rest lengths, masses, pins, adjacency (built once);
//! - [`params`]: every other parameter, validated in one place;
//! - [`scene`]: TOML scene files and the built-in scenes;
//! - [`cpu`]: the reference solver and its state;
//! - [`diagnostics`]: energy and strain, shared by every backend;
//! - [`budget`]: the memory a scene needs, checked before it is allocated;
//! - `evidence` (feature `cli`, on by default): the accuracy and stability
//!   sweeps behind `wgcloth bench`.
//!
//! The types an embedder holds are at the crate root: [`Scene`], [`Model`],
//! [`Params`], the solvers [`CpuSolver`] (its steps report [`StepStats`])
//! and [`GpuSolver`] (its checks report [`GpuStatus`]), [`GpuContext`] to
//! open a device, and [`Error`]; [`render`] draws the GPU solver's cloth.
//!
//! Units are SI throughout (m, kg, s, N), y is up.
#![deny(missing_docs)]

// The coarse levels' aggregates, shared by the CPU and GPU solvers.
pub(crate) mod aggregation;
pub mod atomic_file;
pub mod budget;
pub mod cpu;
pub mod diagnostics;
mod error;
// The `wgcloth bench` harness: used by the binary (`src/cli`) and
// `tests/evidence.rs`; not part of the embedding API.
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod evidence;
pub mod gpu;
// The numbers the kernels and the CPU reference share (workgroup size,
// buffer sections, status words); reached by the twin tests.
#[doc(hidden)]
pub mod kernel_config;
pub mod mesh;
pub mod model;
pub mod params;
mod real;
pub mod render;
pub mod scene;

pub use cpu::{CpuSolver, StepStats};
pub use error::{Error, Result};
pub use gpu::{GpuContext, GpuSolver, GpuStatus};
pub use model::{ClothSpec, Model};
pub use params::{Integrator, Params};
pub use real::{Real, Vec3};
pub use scene::Scene;

/// The Rust examples of `README.md` and `docs/embedding.md`, compiled (and
/// the CPU one run) by `cargo test --doc` so they stay true to the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
#[doc = include_str!("../docs/embedding.md")]
pub struct DocExamples;
