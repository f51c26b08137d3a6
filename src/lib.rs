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
//! [`Params`], the solvers [`CpuSolver`] and [`GpuSolver`] (both report
//! [`StepStats`]), [`GpuContext`] to open a device, and [`Error`]; [`render`]
//! draws the GPU solver's cloth.
//!
//! Vectors cross the API as [`glam`]'s (re-exported, the version Bevy uses):
//! `DVec3` where the value is `f64` (parameters, rest positions, the `f64`
//! CPU solver's state), `Vec3` where it is `f32` (the GPU's state, the `f32`
//! CPU solver's, the camera). Units are SI throughout (m, kg, s, N), y is up.
#![deny(missing_docs)]

// The coarse levels' aggregates, shared by the CPU and GPU solvers.
pub(crate) mod aggregation;
pub mod atomic_file;
// Banded Cholesky, shared by the semi-implicit filter and the evidence.
mod band;
pub mod bending;
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
pub mod material;
pub mod mesh;
pub mod model;
pub mod params;
// The scalar and the generic vector the CPU internals compute with;
// reached by the tests that compare them bit for bit.
#[doc(hidden)]
pub mod real;
pub mod render;
pub mod render_mesh;
pub mod scene;
pub mod sdf;
pub mod self_collision;
mod stats;
pub mod world;

pub use cpu::CpuSolver;
pub use error::{Error, Result};
pub use glam;
pub use gpu::{GpuContext, GpuSolver};
pub use model::{ClothSpec, Model};
pub use params::{Integrator, Params, PinTarget};
pub use real::{Real, Vector};
pub use scene::Scene;
pub use stats::StepStats;

/// The Rust examples of `README.md` and `docs/embedding.md`, compiled (and
/// the CPU one run) by `cargo test --doc` so they stay true to the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
#[doc = include_str!("../docs/embedding.md")]
pub struct DocExamples;
