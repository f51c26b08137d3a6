//! The semi-implicit filter as the GPU applies it, built on the host.

use crate::budget::try_with_capacity;
use crate::cpu::filter::{DenseFilter, FilterSystem};
use crate::error::Result;
use crate::model::Model;
use crate::params::Params;

/// The semi-implicit filter as the GPU applies it: `Wᵀ` followed by the
/// filter order (`u32` bits), built on the host by the CPU reference's own
/// filter code in `f32`.
///
/// A cloth with more free particles than the dense crossover gets no
/// matrix: its filter is solved by CG on the device instead.
#[derive(Debug)]
pub(super) struct SemiFilter {
    /// Free particles in the dense filter (0: solved by CG instead).
    pub(super) count: u32,
    /// `Wᵀ` then the order, as uploaded (empty: solved by CG).
    pub(super) words: Vec<f32>,
}

/// Relative tolerance of the semi-implicit filter's CG solve: a hundred
/// f32 epsilons, about where single-precision CG stops making progress.
pub const FILTER_CG_TOLERANCE: f64 = 1e-5;

/// Iteration cap of the semi-implicit filter's CG solve. The matrix is
/// constant and the solve warm-started, so after the first steps it needs
/// far fewer; the recorded budget adapts (see [`GpuSolver::check`](super::GpuSolver::check)).
pub const FILTER_CG_MAX_ITERATIONS: u32 = 1000;

impl SemiFilter {
    /// The filter of `model` under `params`, built in `f32` on the host;
    /// solved by CG where `params` chooses it, or where the device cannot
    /// hold the dense one (`fits` false).
    pub(super) fn new(model: &Model, params: &Params, fits: bool) -> Result<SemiFilter> {
        let sys = crate::cpu::System::<f32>::new(model, params);
        let grid = model.grid.as_ref().map(|g| (g.nx, g.ny));
        let fs = FilterSystem::new(&sys, grid);
        if !(fits && params.semi_implicit.filter.is_dense(fs.len())) {
            return Ok(SemiFilter {
                count: 0,
                words: Vec::new(),
            });
        }
        let w = DenseFilter::<f32>::new(&fs)?;
        let n = fs.len();
        let m = w.matrix();
        let mut words = try_with_capacity(n * n + n, "the semi-implicit dense filter's upload")?;
        for q in 0..n {
            for k in 0..n {
                words.push(m[k * n + q]);
            }
        }
        words.extend(w.order().iter().map(|&p| f32::from_bits(p)));
        Ok(SemiFilter {
            count: n as u32,
            words,
        })
    }
}
