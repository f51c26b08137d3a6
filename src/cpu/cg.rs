//! The implicit step's modified preconditioned CG (see [`super::implicit`]
//! for the method), one function per GPU kernel, called in the order the
//! GPU records them ([`solve`]): [`init`], with coarse levels
//! [`update`]`(first)`, [`start`], [`prolong`], then per iteration
//! [`apply`], [`alpha`], [`update`], [`beta`], [`prolong`].
//!
//! The particle kernels leave their dot-product terms in the spare `w` of a
//! vector they write; here they go to the workspace's term arrays
//! (`delta0_terms`, `rho_terms`, `cq_terms`), and the scalar kernels sum
//! them with [`block_sum`], the GPU's order. The scalars the GPU keeps in
//! `partials` and its status words are [`Scalars`].

use super::forces::bending_product;
use super::implicit::{Filter, SpringBlock};
use super::{System, Workspace, REDUCTION_BLOCK};
use crate::real::{Real, Vec3};

/// The CG scalars between kernels: the GPU's scalar slots of `partials`
/// (`C_DELTA0`, `C_DELTA`, `C_ALPHA`, `C_BETA`) and its status words
/// `STATUS_CG_ITERATIONS` and `STATUS_CG_STOPPED`. `rho` is the CPU's
/// alone (the GPU tests it where it sums it), for the step's residual.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scalars<R> {
    /// `(Sb)ᵀP⁻¹(Sb)`, the filtered right-hand side's norm.
    pub delta0: R,
    /// `rᵀM⁻¹r` of the current residual (ρ without coarse levels).
    pub delta: R,
    /// The step along the direction.
    pub alpha: R,
    /// The direction update's weight (0 before the first iteration).
    pub beta: R,
    /// `rᵀP⁻¹r` with the block-Jacobi `P`, which decides convergence.
    pub rho: R,
    /// Iterations completed.
    pub iterations: u32,
    /// CG has converged or broken down.
    pub stopped: bool,
}

/// `Σ terms(p)` over `n` particles in the GPU's reduction order: a running
/// sum inside each block of [`REDUCTION_BLOCK`] particles, then the block
/// sums in sequence (twin: `sum_w` and `reduce_to_partial` then
/// `sum_partials` in `shaders/common/cg.wgsl`). Summing in the GPU's order
/// lets the `f32` mirror reproduce the GPU's iterates bit for bit. A
/// running sum rather than a tree because on the GPU a tree needs a
/// workgroup barrier per level, which on a CPU adapter costs more than the
/// additions it saves.
pub fn block_sum<R: Real>(n: usize, terms: impl FnMut(usize) -> R) -> R {
    let mut total = R::ZERO;
    block_partials(n, terms, |_, block| total += block);
    total
}

/// Each block's running sum of `terms(p)` over `n` particles, block by
/// block: `out(block, sum)` (the GPU's `reduce_to_partial`).
pub fn block_partials<R: Real>(
    n: usize,
    mut terms: impl FnMut(usize) -> R,
    mut out: impl FnMut(usize, R),
) {
    for (b, start) in (0..n).step_by(REDUCTION_BLOCK).enumerate() {
        let mut block = R::ZERO;
        for p in start..(start + REDUCTION_BLOCK).min(n) {
            block += terms(p);
        }
        out(b, block);
    }
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
/// `filter`, `precond`, `dv`, `rhs`; writes `r`, `s`, `c`, `q`,
/// `rho_terms` (the GPU's w of `W_R`; `W_S`'s w is the filter kind).
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
}

/// Twin of `shaders/cg_start.wgsl`: δ0 and ρ summed from their terms, δ =
/// ρ plus the coarse levels' terms ([`super::coarse::Coarse::level2`], whose
/// corrections [`prolong`] adds), β = 0, and whether CG is done before its
/// first iteration. Reads `delta0_terms`, `rho_terms` (and the coarse
/// levels' `r1`, `term1`, `inv`); writes `cg` (and `z2`, `term2`).
pub fn start<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    let n = w.r.len();
    let delta0 = block_sum(n, |p| w.delta0_terms[p]);
    let rho = block_sum(n, |p| w.rho_terms[p]);
    w.cg.delta0 = delta0;
    w.cg.delta = coarse_delta(w, rho);
    w.cg.beta = R::ZERO;
    w.cg.rho = rho;
    let running = rho > tolerance_sq(sys) * delta0;
    w.cg.stopped = !running;
}

/// δ = rᵀM⁻¹r from ρ = rᵀP⁻¹r: ρ plus the coarse levels' terms, or ρ
/// without them (twin: `cg_delta` in `shaders/common/coarse.wgsl`).
fn coarse_delta<R: Real>(w: &mut Workspace<R>, rho: R) -> R {
    match &mut w.coarse {
        Some(coarse) => rho + coarse.level2(),
        None => rho,
    }
}

/// Twin of `shaders/cg_prolong.wgsl`: with coarse levels, `s += S z` of
/// each particle's level-2 aggregate ([`super::coarse::Coarse::prolong`]);
/// nothing without. On a grid the GPU has no such pass: `cg_apply` adds
/// the correction to each `s` it loads, so there `cg_apply` is the twin
/// of this followed by [`apply`].
pub fn prolong<R: Real>(w: &mut Workspace<R>) {
    if let Some(coarse) = &w.coarse {
        coarse.prolong(&w.filter, &mut w.s);
    }
}

/// Twin of `shaders/cg_apply.wgsl`: the direction `c = s + β c` and its
/// product `q = S A c = S A s + β q` (the direction update folded into
/// the product, see `solve`), and cᵀq's terms. Reads `blocks`,
/// `filter`, `s`, `c`, `q`, `cg.beta`; writes `c`, `q`, `cq_terms` (the
/// GPU's w of `W_Q`), and `t` (scratch: `S A s`).
pub fn apply<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    apply_a(sys, &w.blocks, &w.filter, &w.s, &mut w.t);
    let beta = w.cg.beta;
    for p in 0..w.c.len() {
        w.c[p] = w.s[p] + w.c[p] * beta;
        w.q[p] = w.t[p] + w.q[p] * beta;
        w.cq_terms[p] = w.c[p].dot(w.q[p]);
    }
}

/// Twin of `shaders/cg_alpha.wgsl`: α = δ / cᵀq. A cᵀq that is not
/// positive means `c` vanished to rounding (`A` is positive definite on
/// the filtered subspace): CG stops, the solve as good as it gets. Reads
/// `cq_terms`, `cg.delta`; writes `cg.alpha` or `cg.stopped`.
pub fn alpha<R: Real>(w: &mut Workspace<R>) {
    let cq = block_sum(w.cq_terms.len(), |p| w.cq_terms[p]);
    if !(cq.is_finite() && cq > R::ZERO) {
        w.cg.stopped = true;
        return;
    }
    w.cg.alpha = w.cg.delta / cq;
}

/// Twin of `shaders/cg_update.wgsl`: `Δv += α c`, `r −= α q` (not in the
/// `first` variant, which only preconditions the initial residual), `s =
/// S P r` with ρ's term `r·P r`; with coarse levels, level 1's correction
/// added to `s` ([`super::coarse::Coarse::level1`], which the GPU runs one
/// level-1 aggregate per invocation). Reads `c`, `q`, `precond`, `filter`,
/// `cg.alpha`; writes `dv`, `r`, `s`, `rho_terms` (the GPU's w of `W_R`)
/// and the level-1 sums (the GPU's level-1 `W_COARSE_Z`).
pub fn update<R: Real>(w: &mut Workspace<R>, first: bool) {
    let alpha = w.cg.alpha;
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
    }
}

/// Twin of `shaders/cg_beta.wgsl`: ρ summed from its terms, δ_new = ρ
/// plus the coarse terms, β = δ_new / δ, the iteration counted, and CG
/// stopped once ρ ≤ tol² δ0. Reads `rho_terms`, `cg` (and the level-1
/// sums); writes `cg` (and the level-2 `z2`, `term2`).
pub fn beta<R: Real>(sys: &System<R>, w: &mut Workspace<R>) {
    let rho = block_sum(w.rho_terms.len(), |p| w.rho_terms[p]);
    let delta = coarse_delta(w, rho);
    w.cg.beta = delta / w.cg.delta;
    w.cg.delta = delta;
    w.cg.rho = rho;
    w.cg.iterations += 1;
    let running = rho > tolerance_sq(sys) * w.cg.delta0;
    if !running {
        w.cg.stopped = true;
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
    start(sys, w);
    prolong(w);
    for _ in 0..sys.cg_max_iterations {
        if w.cg.stopped {
            break;
        }
        apply(sys, w);
        alpha(w);
        if w.cg.stopped {
            break;
        }
        update(w, false);
        beta(sys, w);
        prolong(w);
    }
}
