//! Measured evidence for `docs/integrators.md`: accuracy against a converged
//! reference trajectory ([`mod@accuracy`]), stability regions over stiffness
//! and time step ([`mod@stability`]) and a clamped strip against the heavy
//! elastica ([`mod@cantilever`], [`mod@elastica`]).
//!
//! Pure functions over a [`Scene`](crate::Scene): no files, no printing, no
//! device creation (the GPU is borrowed, like everywhere in the library), so
//! the `wgcloth bench` subcommands and the tests share them.

pub mod accuracy;
pub mod cantilever;
pub mod elastica;
pub mod equilibrium;
mod gpu_runs;
pub mod sheet;
pub mod stability;

pub use accuracy::{
    accuracy, accuracy_with, AccuracyOptions, AccuracyReport, AccuracyRow, Backend,
};
pub use cantilever::{cantilever, CantileverOptions, CantileverReport, CantileverRow};
pub use gpu_runs::GpuGrouping;
pub use stability::{
    stability, stability_gpu, StabilityCell, StabilityOptions, StabilityReport, Verdict,
};

use crate::cpu::CpuSolver;
use crate::error::Error;
use crate::model::Model;
use crate::params::Params;
use crate::real::{Real, Vec3};
use crate::Result;

/// One vector per particle, in `f64` (\[m\] or [m/s]): the form the
/// diagnostics take, so a state is widened once.
type Points = Vec<Vec3<f64>>;

/// A borrowed GPU device and queue (the host owns them).
#[derive(Clone, Copy, Debug)]
pub struct GpuHandles<'a> {
    /// The device the solver's buffers and pipelines live on.
    pub device: &'a wgpu::Device,
    /// The queue its steps are submitted to.
    pub queue: &'a wgpu::Queue,
}

/// A CPU solver in either precision, seen through what the benches need
/// (the GPU's runs go through [`gpu_runs`], stepped together).
enum Runner {
    F64(Box<CpuSolver<f64>>),
    F32(Box<CpuSolver<f32>>),
}

impl Runner {
    /// The CPU solver of `backend` (the GPU is none).
    fn new(backend: Backend, model: &Model, params: &Params) -> Result<Runner> {
        Ok(match backend {
            Backend::CpuF64 => Runner::F64(Box::new(CpuSolver::new(model, params)?)),
            Backend::CpuF32 => Runner::F32(Box::new(CpuSolver::new(model, params)?)),
            Backend::Gpu => {
                return Err(Error::Gpu(
                    "the GPU's runs are batched (evidence::gpu_runs), not run one by one".into(),
                ))
            }
        })
    }

    /// Advances `n` steps; an error when the state stops being finite.
    fn advance(&mut self, n: u64) -> Result<()> {
        match self {
            Runner::F64(s) => s.step_n(n).map(drop),
            Runner::F32(s) => s.step_n(n).map(drop),
        }
    }

    /// Positions \[m\] and velocities [m/s] in `f64` (a read-back on the GPU).
    fn state(&self) -> Result<(Points, Points)> {
        fn conv<R: Real>(s: &CpuSolver<R>) -> (Points, Points) {
            (
                s.state()
                    .x
                    .iter()
                    .map(|p| Vec3::from_f64(p.to_f64()))
                    .collect(),
                s.state()
                    .v
                    .iter()
                    .map(|p| Vec3::from_f64(p.to_f64()))
                    .collect(),
            )
        }
        Ok(match self {
            Runner::F64(s) => conv(s),
            Runner::F32(s) => conv(s),
        })
    }
}
