//! Baraff–Witkin linearised backward Euler, solved by a matrix-free
//! modified preconditioned conjugate gradient (MPCG) with constraint
//! filtering.
//!
//! One step solves `(M − dt D − dt² K) Δv = dt (f0 + dt K v0)`, then
//! `v1 = v0 + Δv`, `x1 = x0 + dt v1`. Per spring the system matrix
//! contributes `B = a I + b n nᵀ` acting on `p_i − p_j` (with sign), where
//! - `a = dt² k max(0, 1 − L/l)` — the transverse stiffness; the `max`
//!   drops it for a compressed spring, which keeps `A` positive definite (a
//!   compressed spring's true transverse stiffness is negative: cloth
//!   buckles instead of exploding), and
//! - `b = dt² k − a + dt kd ≥ 0` — the longitudinal stiffness plus damping.
//!
//! With `m = √b n`, `B = a I + m mᵀ`: `A p = M p + Σ ±B_s (p_i − p_j)` is
//! evaluated from four numbers per spring, never as an assembled matrix. The preconditioner `P⁻¹` is the inverse
//! of `A`'s 3×3 diagonal blocks; on a grid cloth the coarse levels of
//! [`super::coarse`] add aggregate corrections to it (`M⁻¹`). The filter `S_p` is `0` for a pinned
//! particle and `I − n nᵀ` for one resting on a collider (the constrained
//! component of `Δv` is prescribed by `z_p`, which cancels an inward normal
//! velocity); CG applies it to the residual and search direction so
//! constrained directions never move.
//!
//! Convergence: stop when `rᵀP⁻¹r ≤ tol² · (Sb)ᵀP⁻¹(Sb)`, i.e. the
//! block-Jacobi preconditioned residual norm relative to the filtered
//! right-hand side — with or without coarse levels, so they change how
//! fast CG gets there, not where "there" is.
//! CG starts from the last two steps' `Δv` extrapolated, `2 Δv₁ − Δv₂`
//! (filtered) — a warm start that cuts iterations for smooth motion
//! without changing the answer beyond the tolerance.

use super::collide::{collide, contact, CONTACT_SLOP};
use super::forces::{gather_signed, spring_frame};
use super::mat3::Sym3;
use super::{State, StepStats, System, Workspace, REDUCTION_BLOCK};
use crate::real::{Real, Vec3};

/// Per-particle constraint: what `S_p` keeps free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter<R> {
    /// Unconstrained: `S = I`.
    Free,
    /// Pinned: `S = 0`.
    Fixed,
    /// On a surface with this normal and friction coefficient:
    /// `S = I − n nᵀ`.
    Plane(Vec3<R>, R),
}

impl<R: Real> Filter<R> {
    /// Applies `S` to a vector.
    #[inline]
    pub fn apply(self, v: Vec3<R>) -> Vec3<R> {
        match self {
            Filter::Free => v,
            Filter::Fixed => Vec3::ZERO,
            Filter::Plane(n, _) => v - n * v.dot(n),
        }
    }
}

/// Per-spring linearisation at the start of the step, `B = a I + m mᵀ`
/// with `m = √b n` (`b ≥ 0`, see the module docs): four numbers, one
/// `vec4` on the GPU, where CG's inner loop is bound by loads.
#[derive(Clone, Copy, Debug, Default)]
pub struct SpringBlock<R> {
    /// `√b n` [√kg].
    pub m: Vec3<R>,
    /// Isotropic coefficient `a` \[kg\].
    pub a: R,
    /// The spring's ends, copied here so CG's inner loop streams one array.
    pub ends: [u32; 2],
}

impl<R: Real> SpringBlock<R> {
    /// `B d = a d + m (m·d)`.
    #[inline]
    pub fn apply(&self, d: Vec3<R>) -> Vec3<R> {
        d * self.a + self.m * self.m.dot(d)
    }
}

/// `out = S (A p)` over all particles.
///
/// Unlike the force evaluation, this product *scatters* over the springs in
/// one pass (each spring adds to both ends): it is CG's inner loop, and one
/// pass halves its memory traffic against a spring pass plus a gather. It
/// still sums as the GPU's gather (`apply_a` in `shaders/common/cg.wgsl`)
/// does, bit for bit: each particle starts from `m p` and receives its
/// springs' terms in ascending spring index, the order of its adjacency
/// list, which the GPU walks.
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

/// Coulomb friction at the contacts the filter constrained.
///
/// The filter removed the contacts' normal motion before anything could
/// measure it, so friction is computed from the constraint impulse instead:
/// the part of `A Δv − b` along the normal is the momentum the surface had to
/// supply [N·s]. The tangential velocity then loses at most `μ` times that
/// impulse divided by the mass — the same law the collision pass applies to
/// a removed normal velocity.
fn contact_friction<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    apply_a_unfiltered(sys, &w.blocks, &w.dv, &mut w.q);
    for p in 0..st.v.len() {
        let Filter::Plane(normal, mu) = w.filter[p] else {
            continue;
        };
        let impulse = (w.q[p] - w.rhs[p]).dot(normal);
        if impulse <= R::ZERO {
            continue;
        }
        let v = st.v[p];
        let tangential = v - normal * v.dot(normal);
        let speed = tangential.length();
        let loss = mu * impulse / sys.mass[p];
        let kept = if speed > loss && speed > R::TINY {
            (speed - loss) / speed
        } else {
            R::ZERO
        };
        st.v[p] = normal * v.dot(normal) + tangential * kept;
    }
}

/// `out = A p` without the constraint filter.
fn apply_a_unfiltered<R: Real>(
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
}

/// `Σ terms(p)` over `n` particles in the GPU's reduction order: a running
/// sum inside each block of [`REDUCTION_BLOCK`] particles, then the block
/// sums in sequence. Summing in the GPU's order lets the `f32` mirror
/// reproduce the GPU's CG iterates bit for bit. A running sum rather than a
/// tree because on the GPU a tree needs a workgroup barrier per level, which
/// on a CPU adapter costs more than the additions it saves.
pub fn block_sum<R: Real>(n: usize, mut terms: impl FnMut(usize) -> R) -> R {
    let mut total = R::ZERO;
    for start in (0..n).step_by(REDUCTION_BLOCK) {
        let mut block = R::ZERO;
        for p in start..(start + REDUCTION_BLOCK).min(n) {
            block += terms(p);
        }
        total += block;
    }
    total
}

/// Sum of `a[p]·b[p]` in the GPU's order.
#[inline]
fn dot<R: Real>(a: &[Vec3<R>], b: &[Vec3<R>]) -> R {
    block_sum(a.len(), |p| a[p].dot(b[p]))
}

/// Particle p's block-Jacobi term: `w.t = P r` (ρ's term before the
/// filter: r is filtered already) and `w.s = S P r`.
#[inline]
fn precondition_at<R: Real>(w: &mut Workspace<R>, p: usize) {
    let s = w.precond[p].mul(w.r[p]);
    w.t[p] = s;
    w.s[p] = w.filter[p].apply(s);
}

/// δ = rᵀM⁻¹r from ρ = rᵀP⁻¹r once every particle's block-Jacobi term is
/// in `w.s`: with coarse levels, their corrections added to `w.s` and
/// their terms to ρ; without, ρ. (On the GPU: the end of cg_update,
/// cg_beta's sums, and level 2's corrections added by cg_apply to each s
/// it loads — by a cg_prolong pass off the grid kernels.)
fn coarse_terms<R: Real>(w: &mut Workspace<R>, rho: R) -> R {
    match &mut w.coarse {
        Some(coarse) => {
            coarse.level1(&w.r, &w.filter, &mut w.s);
            rho + coarse.level2(&w.filter, &mut w.s)
        }
        None => rho,
    }
}

/// One implicit step.
pub fn step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) -> StepStats {
    let n = st.x.len();
    let dt = sys.dt;
    let dt2 = dt * dt;

    // Forces at the start of the step.
    w.compute_forces(sys, st);

    // Linearise every spring; `w.per_spring` gets K_s (v_i − v_j).
    for (s, sp) in sys.springs.iter().enumerate() {
        let (i, j) = (sp.i as usize, sp.j as usize);
        let (dir, l) = spring_frame(st.x[i], st.x[j]);
        let transverse = if l > R::TINY {
            (R::ONE - sp.rest / l).max(R::ZERO)
        } else {
            R::ZERO
        };
        let a = dt2 * sp.k * transverse;
        let b = dt2 * sp.k - a + dt * sp.kd;
        w.blocks[s] = SpringBlock {
            m: dir * b.max(R::ZERO).sqrt(),
            a,
            ends: [sp.i, sp.j],
        };
        // K_s u = −k (c u + (1 − c) n (n·u)), u = v_i − v_j.
        let u = st.v[i] - st.v[j];
        let k_long = sp.k * (R::ONE - transverse);
        w.per_spring[s] = -(u * (sp.k * transverse) + dir * (k_long * dir.dot(u)));
    }

    // Constraints, right-hand side and block-diagonal preconditioner.
    for p in 0..n {
        w.filter[p] = if sys.inv_mass[p] <= R::ZERO {
            Filter::Fixed
        } else {
            match contact(sys, st.x[p], R::from_f64(CONTACT_SLOP)) {
                // Constrain only a particle pushed or moving into the surface:
                // one pulled away is free to lift off this step.
                Some(c)
                    if w.force[p].dot(c.normal) < R::ZERO || st.v[p].dot(c.normal) < R::ZERO =>
                {
                    Filter::Plane(c.normal, c.friction)
                }
                _ => Filter::Free,
            }
        };
        // z: the prescribed Δv in constrained directions.
        w.z[p] = match w.filter[p] {
            Filter::Plane(nrm, _) => nrm * (-st.v[p].dot(nrm).min(R::ZERO)),
            Filter::Fixed => -st.v[p],
            Filter::Free => Vec3::ZERO,
        };
        let kv = gather_signed(&sys.spring_adj, &w.per_spring, p);
        w.rhs[p] = (w.force[p] + kv * dt) * dt;
        let mut diag = Sym3::scaled_identity(sys.mass[p]);
        let mut levels = [diag; 2];
        for &e in sys.spring_adj.of(p) {
            let blk = &w.blocks[(e >> 1) as usize];
            diag.add_iso_aniso(blk.a, R::ONE, blk.m);
            if let Some(coarse) = &w.coarse {
                let other = blk.ends[(e & 1 == 0) as usize] as usize;
                for (level, d) in levels.iter_mut().enumerate() {
                    if coarse.of[other][level] != coarse.of[p][level] {
                        d.add_iso_aniso(blk.a, R::ONE, blk.m);
                    }
                }
            }
        }
        if let Some(coarse) = &mut w.coarse {
            coarse.contrib[p] = levels;
            coarse.trace[p] = diag.m[0] + diag.m[1] + diag.m[2];
        }
        // A's diagonal block is m I plus positive semi-definite terms, so it
        // is invertible; the fallback only guards a pathological input.
        w.precond[p] = diag
            .inverse()
            .unwrap_or(Sym3::scaled_identity(R::ONE / sys.mass[p]));
    }

    if let Some(coarse) = &mut w.coarse {
        coarse.set_up(&sys.mass);
    }

    // MPCG, warm-started from the last two steps' Δv extrapolated
    // linearly (2 Δv₁ − Δv₂): on smooth motion a closer guess than the last
    // Δv alone, so fewer iterations, and CG corrects it either way.
    for p in 0..n {
        let guess = w.dv[p] * R::from_f64(2.0) - w.dv_prev[p];
        w.dv_prev[p] = w.dv[p];
        w.dv[p] = w.filter[p].apply(guess) + w.z[p];
    }
    let delta0 = block_sum(n, |p| {
        let sb = w.filter[p].apply(w.rhs[p]);
        sb.dot(w.precond[p].mul(sb))
    });
    apply_a(sys, &w.blocks, &w.filter, &w.dv, &mut w.q);
    for p in 0..n {
        w.r[p] = w.filter[p].apply(w.rhs[p]) - w.q[p];
        w.s[p] = w.filter[p].apply(w.precond[p].mul(w.r[p]));
        // The "previous" direction and its product, for β = 0.
        w.c[p] = Vec3::ZERO;
        w.q[p] = Vec3::ZERO;
    }
    // ρ = rᵀP⁻¹r with the block-Jacobi P alone decides convergence (the
    // coarse levels change the iterates, not what "converged" means); δ =
    // rᵀM⁻¹r with the coarse terms drives CG.
    let mut rho = dot(&w.r, &w.s);
    if w.coarse.is_some() {
        // The GPU preconditions r again, as each iteration does (its
        // cg_update.first).
        for p in 0..n {
            precondition_at(w, p);
        }
        rho = dot(&w.r, &w.t);
    }
    let mut delta = coarse_terms(w, rho);
    let mut beta = R::ZERO;
    let tol2 = R::from_f64(sys.cg_tolerance * sys.cg_tolerance);
    let mut iterations = 0;
    // Baraff and Witkin's modified PCG, with the direction update folded
    // into the matrix product: c = S P r + β c, so S A c = S A (S P r) +
    // β S A c_old — the product of the filtered preconditioned residual
    // plus the old product. On the GPU this saves the direction pass (its
    // neighbours' c would otherwise have to be complete before the
    // product). The same iterates in exact arithmetic.
    while rho > tol2 * delta0 && iterations < sys.cg_max_iterations {
        apply_a(sys, &w.blocks, &w.filter, &w.s, &mut w.t);
        for p in 0..n {
            w.c[p] = w.s[p] + w.c[p] * beta;
            w.q[p] = w.t[p] + w.q[p] * beta;
        }
        let cq = dot(&w.c, &w.q);
        // A is positive definite on the filtered subspace, so cq > 0 unless
        // c vanished to rounding: then the solve is as good as it gets.
        if !(cq.is_finite() && cq > R::ZERO) {
            break;
        }
        let alpha = delta / cq;
        let delta_old = delta;
        for p in 0..n {
            w.dv[p] += w.c[p] * alpha;
            w.r[p] -= w.q[p] * alpha;
            precondition_at(w, p);
        }
        rho = dot(&w.r, &w.t);
        delta = coarse_terms(w, rho);
        beta = delta / delta_old;
        iterations += 1;
    }
    let residual = if delta0 > R::ZERO {
        (rho / delta0).to_f64().max(0.0).sqrt()
    } else {
        0.0
    };

    for p in 0..n {
        st.v[p] += w.dv[p];
    }
    if w.filter.iter().any(|f| matches!(f, Filter::Plane(..))) {
        contact_friction(sys, st, w);
    }
    for p in 0..n {
        st.x[p] += st.v[p] * dt;
    }
    // Particles that were not touching at the start of the step can still
    // end it inside a collider.
    collide(sys, &mut st.x, &mut st.v);
    StepStats {
        cg_iterations: iterations,
        cg_residual: residual,
        ..StepStats::default()
    }
}
