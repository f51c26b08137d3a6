//! The implicit step's modified preconditioned CG (see [`super::implicit`]
//! for the method), one function per GPU kernel, called in the order the
//! GPU records them ([`solve`]): [`init`], with coarse levels
//! [`update`]`(first)`, then per iteration [`apply`] and [`update`].
//!
//! Two kernels an iteration, and no one-workgroup kernel: each kernel
//! writes one partial sum per workgroup of the dot-product terms it
//! produces ([`block_partials`]), and every workgroup of the next kernel
//! adds all the partials itself, in one fixed order ([`sum_partials`]) —
//! they read the same bits, so they all find the same α, β and stop
//! without talking to each other. [`apply`] finds β and the convergence
//! test from the partials [`update`] (or [`init`]) left, [`update`] finds
//! α from [`apply`]'s. The particle kernels also leave their terms in the
//! spare `w` of a vector they write; here they go to the workspace's term
//! arrays (`delta0_terms`, `rho_terms`, `cq_terms`). The scalars the GPU
//! keeps in `partials` and its status words are [`Scalars`].

use std::ops::Add;

use super::forces::bending_product;
use super::implicit::{Filter, SpringBlock};
use super::{System, Workspace};
use crate::kernel_config::CG_BLOCK;
use crate::real::{Real, Vec3};

/// The CG scalars between kernels: the GPU's scalar slots of `partials`
/// (`C_DELTA0`, `C_DELTA`, `C_ALPHA`, `C_BETA`, `C_DELTA_PREV`) and its
/// status words `STATUS_CG_ITERATIONS` and `STATUS_CG_STOPPED`. `rho` is
/// the CPU's alone (the GPU tests it where it sums it), for the step's
/// residual.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scalars<R> {
    /// `(Sb)ᵀP⁻¹(Sb)`, the filtered right-hand side's norm.
    pub delta0: R,
    /// `rᵀM⁻¹r` of the current residual (ρ without coarse levels).
    pub delta: R,
    /// The step along the direction.
    pub alpha: R,
    /// The direction update's weight (0 in the first iteration).
    pub beta: R,
    /// δ of the last completed iteration's start, for the next β.
    pub delta_prev: R,
    /// `rᵀP⁻¹r` with the block-Jacobi `P`, which decides convergence.
    pub rho: R,
    /// Iterations completed.
    pub iterations: u32,
    /// CG has converged or broken down.
    pub stopped: bool,
}

/// The sum of `values` (a power of two of them) as a pairwise tree of
/// neighbours: `v[i] += v[i + w]` for `w = 1, 2, 4, …` at every `i` that
/// is a multiple of `2w`; the result is `v[0]`. The GPU's workgroups sum
/// in this order (`tree_reduce` in `shaders/common/cg.wgsl`), and a
/// subgroup's xor butterfly reaches the same bits in every lane.
pub fn pairwise<T: Copy + Add<Output = T>>(values: &mut [T]) -> T {
    let n = values.len();
    debug_assert!(n.is_power_of_two());
    let mut w = 1;
    while w < n {
        for i in (0..n).step_by(2 * w) {
            values[i] = values[i] + values[i + w];
        }
        w *= 2;
    }
    values[0]
}

/// Each block's sum of `terms(p)` over `n` particles, block by block:
/// `out(block, sum)`, a block being [`CG_BLOCK`] particles (one
/// workgroup's) summed as a [`pairwise`] tree, zeros past the last
/// particle (twin: `tree_reduce` in the CG kernels, and
/// `write_block_partials` on the workgroup path).
pub fn block_partials<R: Real>(
    n: usize,
    mut terms: impl FnMut(usize) -> R,
    mut out: impl FnMut(usize, R),
) {
    let mut lanes = [R::ZERO; CG_BLOCK];
    for (b, start) in (0..n).step_by(CG_BLOCK).enumerate() {
        for (k, lane) in lanes.iter_mut().enumerate() {
            let p = start + k;
            *lane = if p < n { terms(p) } else { R::ZERO };
        }
        out(b, pairwise(&mut lanes));
    }
}

/// The total of `partials` as every workgroup of a CG kernel adds them
/// (twin: `sum_partials_tree` in `shaders/common/cg.wgsl`): lane `l` of
/// [`CG_BLOCK`] adds partials `l`, `l + 256`, … in sequence from
/// zero, then the lanes' sums go through a [`pairwise`] tree. Coalesced
/// loads, and a handful of additions per lane at any size.
pub fn sum_partials<R: Real>(partials: &[R]) -> R {
    let mut lanes = [R::ZERO; CG_BLOCK];
    for (k, &v) in partials.iter().enumerate() {
        lanes[k % CG_BLOCK] += v;
    }
    pairwise(&mut lanes)
}

/// `Σ terms(p)` over `n` particles in the GPU's order: [`block_partials`],
/// then [`sum_partials`].
pub fn block_sum<R: Real>(n: usize, terms: impl FnMut(usize) -> R) -> R {
    let mut partials = Vec::with_capacity(n.div_ceil(CG_BLOCK));
    block_partials(n, terms, |_, sum| partials.push(sum));
    sum_partials(&partials)
}

/// `out = S (A p)` over all particles (twin: `apply_a` in
/// `shaders/common/cg.wgsl`, then the filter).
///
/// Unlike the force evaluation, this product *scatters* over the springs in
/// one pass (each spring adds to both ends): it is CG's inner loop, and one
/// pass halves its memory traffic against a spring pass plus a gather. It
/// still sums as the GPU's gather does, bit for bit: each particle starts
/// from `m p` and receives its springs' terms in ascending spring index,
/// the order of its adjacency list, which the GPU walks.
pub fn apply_a<R: Real>(
    sys: &System<R>,
    blocks: &[SpringBlock<R>],
    filter: &[Filter<R>],
    p: &[Vec3<R>],
    out: &mut [Vec3<R>],
) {
    apply_a_unfiltered(sys, blocks, p, out);
    for (o, f) in out.iter_mut().zip(filter) {
        *o = f.apply(*o);
    }
}

/// `out = A p` without the constraint filter.
pub fn apply_a_unfiltered<R: Real>(
    sys: &System<R>,
    blocks: &[SpringBlock<R>],
    p: &[Vec3<R>],
    out: &mut [Vec3<R>],
) {
    for ((o, &m), &pp) in out.iter_mut().zip(&sys.mass).zip(p) {
        *o = pp * m;
    }
    for blk in blocks {
        let (i, j) = (blk.ends[0] as usize, blk.ends[1] as usize);
        let y = blk.apply(p[i] - p[j]);
        out[i] += y;
        out[j] -= y;
    }
    // The linear bending operator's part, (dt² + dt β) Q p, after each
    // particle's springs.
    if let Some(b) = &sys.bending {
        for (k, o) in out.iter_mut().enumerate() {
            *o += bending_product(sys, p, k) * b.scale;
        }
    }
}

/// The convergence threshold `tol²` in precision `R`.
fn tolerance_sq<R: Real>(sys: &System<R>) -> R {
    R::from_f64(sys.cg_tolerance * sys.cg_tolerance)
}

/// Twin of `shaders/cg_init.wgsl`: `r = S b − S A Δv` with ρ's term
/// `r·s`, `s = S P r`, and a zero previous direction and product (the
/// first iteration has β = 0). With coarse levels `s` and ρ's terms are
/// left to [`update`]`(first)` (the GPU's ρ term there: 0). Reads `blocks`,
/// `filter`, `precond`, `dv`, `rhs`, `delta0_terms`; writes `r`, `s`, `c`,
/// `q`, `rho_terms` (the GPU's w of `W_R`; `W_S`'s w is the filter kind)
/// and resets `cg`. The GPU's partials of δ0 and ρ are the block sums of
/// `delta0_terms` and `rho_terms` ([`block_partials`]).
pub fn init<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    apply_a(sys, &w.blocks, &w.filter, &w.dv, &mut w.q);
    let coarse = w.coarse.is_some();
    for p in 0..w.r.len() {
        w.r[p] = w.filter[p].apply(w.rhs[p]) - w.q[p];
        if coarse {
            w.rho_terms[p] = R::ZERO;
        } else {
            w.s[p] = w.filter[p].apply(w.precond[p].mul(w.r[p]));
            w.rho_terms[p] = w.r[p].dot(w.s[p]);
        }
        w.c[p] = Vec3::ZERO;
        w.q[p] = Vec3::ZERO;
    }
    w.cg.iterations = 0;
    w.cg.stopped = false;
}

/// ρ = rᵀP⁻¹r and δ = rᵀM⁻¹r of the current residual as [`apply`] sums
/// them: ρ from the block sums of `rho_terms`, or with coarse levels from
/// their per-slot partials, plus the coarse terms (twin: `cg_sums` in
/// `shaders/common/cg.wgsl`).
pub fn residual_sums<R: Real>(w: &Workspace<R>) -> (R, R) {
    match &w.coarse {
        Some(coarse) => {
            let rho = sum_partials(&coarse.rho_partials);
            (rho, rho + sum_partials(&coarse.dc_partials))
        }
        None => {
            let rho = block_sum(w.rho_terms.len(), |p| w.rho_terms[p]);
            (rho, rho)
        }
    }
}

/// Twin of `shaders/cg_apply.wgsl`, CG iteration `cg.iterations`: ρ and δ
/// summed ([`residual_sums`]; in the first iteration δ0 too), CG stopped
/// once ρ ≤ tol² δ0; else β = δ / δ_prev (0 in the first iteration), the
/// direction `c = s + β c` and its product `q = S A c = S A s + β q` (the
/// direction update folded into the product, see `solve`), and cᵀq's
/// terms. With coarse levels `s` gets each level-2 aggregate's correction
/// first ([`prolong`], which the GPU adds to each `s` it loads). Reads
/// `blocks`, `filter`, `s`, `c`, `q`, `rho_terms` (or the coarse
/// partials), `delta0_terms` (first iteration), `cg`; writes `cg`, and
/// unless stopped `c`, `q`, `cq_terms` (the GPU's w of `W_Q`) and `t`
/// (scratch: `S A s`).
pub fn apply<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    let first = w.cg.iterations == 0;
    let (rho, delta) = residual_sums(w);
    if first {
        w.cg.delta0 = block_sum(w.delta0_terms.len(), |p| w.delta0_terms[p]);
    }
    w.cg.rho = rho;
    w.cg.delta = delta;
    w.cg.beta = if first {
        R::ZERO
    } else {
        delta / w.cg.delta_prev
    };
    // Not `<=`: a NaN ρ stops CG too, as on the GPU.
    let running = rho > tolerance_sq(sys) * w.cg.delta0;
    if !running {
        w.cg.stopped = true;
        return;
    }
    prolong(w);
    apply_a(sys, &w.blocks, &w.filter, &w.s, &mut w.t);
    let beta = w.cg.beta;
    for p in 0..w.c.len() {
        w.c[p] = w.s[p] + w.c[p] * beta;
        w.q[p] = w.t[p] + w.q[p] * beta;
        w.cq_terms[p] = w.c[p].dot(w.q[p]);
    }
}

/// With coarse levels, `s += S z` of each particle's level-2 aggregate
/// ([`super::coarse::Coarse::prolong`]); nothing without. The GPU adds the
/// correction to each `s` its `cg_apply` loads.
pub fn prolong<R: Real>(w: &mut Workspace<R>) {
    if let Some(coarse) = &w.coarse {
        coarse.prolong(&w.filter, &mut w.s);
    }
}

/// Twin of `shaders/cg_update.wgsl`: α = δ / cᵀq, cᵀq from the block sums
/// of `cq_terms` (not in the `first` variant, which only preconditions
/// the initial residual). A cᵀq that is not positive means `c` vanished to
/// rounding (`A` is positive definite on the filtered subspace): CG
/// stops, the solve as good as it gets. Else `Δv += α c`, `r −= α q`, `s =
/// S P r` with ρ's term `r·P r`; with coarse levels, both levels'
/// corrections and sums ([`super::coarse::Coarse::level1`],
/// [`level2`](super::coarse::Coarse::level2),
/// [`partials`](super::coarse::Coarse::partials), which the GPU runs one
/// slot of the level-2-major order per invocation); the iteration
/// counted. Reads `c`, `q`, `cq_terms`, `precond`, `filter`, `cg`;
/// writes `dv`, `r`, `s`, `rho_terms` (the GPU's w of `W_R`), the coarse
/// sums (the GPU's `W_COARSE_Z`) and `cg`.
pub fn update<R: Real>(w: &mut Workspace<R>, first: bool) {
    let mut alpha = R::ZERO;
    if !first {
        let cq = block_sum(w.cq_terms.len(), |p| w.cq_terms[p]);
        alpha = w.cg.delta / cq;
        w.cg.alpha = alpha;
        if !(cq.is_finite() && cq > R::ZERO) {
            w.cg.stopped = true;
            return;
        }
    }
    for p in 0..w.r.len() {
        if !first {
            w.dv[p] += w.c[p] * alpha;
            w.r[p] -= w.q[p] * alpha;
        }
        let pr = w.precond[p].mul(w.r[p]);
        w.rho_terms[p] = w.r[p].dot(pr);
        w.s[p] = w.filter[p].apply(pr);
    }
    if let Some(coarse) = &mut w.coarse {
        coarse.level1(&w.r, &w.filter, &mut w.s);
        coarse.level2();
        coarse.partials(&w.rho_terms);
    }
    if !first {
        w.cg.delta_prev = w.cg.delta;
        w.cg.iterations += 1;
    }
}

/// Baraff and Witkin's modified PCG from the set-up `implicit::prepare`
/// left (warm-started `dv`, `rhs`, `filter`, `precond`, `blocks`, the
/// coarse levels' `inv`): the kernels in the order the GPU records them,
/// at most `sys.cg_max_iterations` iterations.
///
/// The direction update is folded into the matrix product: c = S P r +
/// β c, so S A c = S A (S P r) + β S A c_old — the product of the
/// filtered preconditioned residual plus the old product. On the GPU this
/// saves the direction pass (its neighbours' c would otherwise have to be
/// complete before the product). The same iterates in exact arithmetic.
pub fn solve<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    init(sys, w);
    if w.coarse.is_some() {
        update(w, true);
    }
    for _ in 0..sys.cg_max_iterations {
        apply(sys, w);
        if w.cg.stopped {
            break;
        }
        update(w, false);
        if w.cg.stopped {
            break;
        }
    }
    // Cut short by the cap: the residual the step reports is the last
    // one's, which no apply summed (the GPU reports none).
    if !w.cg.stopped {
        w.cg.rho = residual_sums(w).0;
    }
}
