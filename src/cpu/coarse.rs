//! The implicit CG's coarse levels on a grid cloth: an additive two-level
//! aggregation preconditioner on top of the block-Jacobi one.
//!
//! Block Jacobi removes the error of each particle against its neighbours
//! quickly and the smooth error (a whole region moving together) slowly:
//! CG needs more iterations the stiffer the springs are against the mass.
//! Grouping the particles into square *aggregates* of
//! [`LEVEL_SIDES`](crate::aggregation::LEVEL_SIDES)
//! particles a side gives each level one unknown 3-vector per aggregate
//! (the aggregate moving rigidly), and the preconditioner becomes
//!
//! `M⁻¹ r = S P r + Σ_l S Π_l θ_l D_l⁻¹ Π_lᵀ r`,
//!
//! where `Π_l` copies an aggregate's vector to each of its particles and
//! `D_l` is the 3×3 diagonal block of the Galerkin matrix `Π_lᵀ A Π_l` of
//! each aggregate: its particles' mass plus the blocks `B_s` of the springs
//! that cross its border (springs inside it move rigidly with it and drop
//! out), and `D_l⁻¹` is weighted by `θ = 1 − 3 Σm / Σ tr(A_ii)` over the
//! aggregate's particles. Block Jacobi already handles the rigid motion of
//! an aggregate whose springs are weak against its mass (`A ≈ M`): there
//! an unweighted coarse term corrects the same error twice and *adds*
//! iterations at small steps. `θ` is the share of the diagonal that the
//! springs contribute, near 0 there and near 1 where the springs dominate,
//! so the weighted term costs no iterations at small steps and keeps its
//! gains at large ones (`tests/cpu_agreement.rs` checks both). Each
//! term is symmetric positive semi-definite and the first is definite on
//! the filtered subspace, so `M⁻¹` is a valid CG preconditioner; the
//! filter `S` keeps the corrections off constrained directions.
//!
//! Two levels about halve the iterations on a large, stiff cloth (level 1
//! alone most of that; see `docs/integrators.md`). An
//! exact solve on the 16-particle level instead of its diagonal gains only
//! a few more iterations, and a third level (64) none, so the levels stop
//! at two, each corrected through its diagonal block.
//!
//! Everything is summed in a fixed order that the GPU reproduces (twins:
//! [`Coarse::setup`] of `coarse_setup.wgsl`; [`Coarse::level1`],
//! [`Coarse::level2`] and [`Coarse::partials`] of the per-slot
//! `cg_update.wgsl`; [`Coarse::prolong`] of the correction `cg_apply` adds
//! to each `s` it loads): an aggregate's particles in row-major order; a
//! level-2 aggregate's residual as the pairwise sum of its level-1
//! aggregates' in slot order; ρ and the coarse terms of `rᵀM⁻¹r` through a
//! workgroup's tree of slots; `s` gets the block-Jacobi term, then level
//! 1's, then level 2's.

use super::cg::pairwise;
use super::implicit::Filter;
use super::mat3::Sym3;
pub use crate::aggregation::Aggregation;
use crate::aggregation::SLOTS_PER_LEVEL2;
use crate::kernel_config::CG_BLOCK;
use crate::real::{Real, Vec3};

/// The coarse levels' per-step state.
#[derive(Clone, Debug)]
pub struct Coarse<R> {
    /// How the grid is aggregated.
    pub agg: Aggregation,
    /// Each particle's aggregate at both levels (`Aggregation::of`).
    pub of: Vec<[u32; 2]>,
    /// Per particle and level: its mass times `I` plus the blocks of its
    /// springs whose other end lies in another aggregate of that level
    /// (filled by `implicit::prepare`; the GPU's `W_LEVEL1_D` … `W_LEVEL2_O`).
    pub contrib: Vec<[Sym3<R>; 2]>,
    /// Per particle: the trace of its block-Jacobi block (of `A`'s
    /// diagonal block) \[kg\], for the weight θ (the GPU's w of
    /// `W_LEVEL1_O`).
    pub trace: Vec<R>,
    /// `θ D⁻¹` of each aggregate, both levels (zero where `D` is not
    /// invertible, which drops that aggregate's correction; the GPU's
    /// `W_COARSE_INV_D`, `W_COARSE_INV_O`).
    pub inv: Vec<Sym3<R>>,
    /// `Πᵀr` of each level-1 aggregate (the GPU's xyz of `W_COARSE_Z`).
    pub r1: Vec<Vec3<R>>,
    /// `(Πᵀr)·D⁻¹Πᵀr` of each level-1 aggregate (the GPU's w of
    /// `W_COARSE_Z`).
    pub term1: Vec<R>,
    /// The correction `z = D⁻¹ Πᵀr` of each level-2 aggregate (the GPU's
    /// xyz of `W_COARSE_Z` past the level-1 aggregates).
    pub z2: Vec<Vec3<R>>,
    /// The term `(Πᵀr)·D⁻¹Πᵀr` of each level-2 aggregate (the GPU's w of
    /// `W_COARSE_Z` there).
    pub term2: Vec<R>,
    /// ρ's partial sums, one per workgroup of the per-slot update (the
    /// GPU's `P_RS`).
    pub rho_partials: Vec<R>,
    /// The partial sums of δ's coarse terms (the GPU's `P_DC`).
    pub dc_partials: Vec<R>,
}

impl<R: Real> Coarse<R> {
    /// Coarse levels for `agg`.
    pub fn new(agg: Aggregation) -> Self {
        Coarse {
            of: (0..agg.particle_count())
                .map(|p| [agg.of(0, p) as u32, agg.of(1, p) as u32])
                .collect(),
            contrib: vec![[Sym3::default(); 2]; agg.particle_count()],
            trace: vec![R::ZERO; agg.particle_count()],
            inv: vec![Sym3::default(); agg.total()],
            r1: vec![Vec3::ZERO; agg.count(0)],
            term1: vec![R::ZERO; agg.count(0)],
            z2: vec![Vec3::ZERO; agg.count(1)],
            term2: vec![R::ZERO; agg.count(1)],
            rho_partials: vec![R::ZERO; agg.slots().div_ceil(CG_BLOCK)],
            dc_partials: vec![R::ZERO; agg.slots().div_ceil(CG_BLOCK)],
            agg,
        }
    }

    /// Twin of `shaders/coarse_setup.wgsl`: sums each aggregate's `D` from
    /// the particles' contributions and stores `θ D⁻¹` (see the module
    /// docs for the weight θ). Reads `contrib`, `trace` and `mass`, the
    /// particles' masses \[kg\]; writes `inv`.
    pub fn setup(&mut self, mass: &[R]) {
        for level in 0..2 {
            let offset = if level == 0 { 0 } else { self.agg.count(0) };
            for a in 0..self.agg.count(level) {
                let mut d = Sym3::default();
                let (mut sm, mut st) = (R::ZERO, R::ZERO);
                for p in self.agg.particles(level, a) {
                    sm += mass[p];
                    st += self.trace[p];
                    for (e, c) in d.m.iter_mut().zip(self.contrib[p][level].m) {
                        *e += c;
                    }
                }
                let mut inv = d.inverse().unwrap_or_default();
                let theta = if st > R::ZERO {
                    R::ONE - R::from_f64(3.0) * sm / st
                } else {
                    R::ZERO
                };
                for e in inv.m.iter_mut() {
                    *e *= theta;
                }
                self.inv[offset + a] = inv;
            }
        }
    }

    /// Level 1 of the coarse terms, per level-1 aggregate: `Πᵀr`, its
    /// correction `z = D⁻¹ Πᵀr` added to `s` as `S z` (after the block
    /// Jacobi term already there), and the term `(Πᵀr)·z` of `rᵀM⁻¹r`.
    /// The GPU does this in its per-slot `cg_update` (`cg_update_slot`).
    pub fn level1(&mut self, r: &[Vec3<R>], filter: &[Filter<R>], s: &mut [Vec3<R>]) {
        let agg = &self.agg;
        for a in 0..agg.count(0) {
            let mut r1 = Vec3::ZERO;
            for p in agg.particles(0, a) {
                r1 += r[p];
            }
            let z = self.inv[a].mul(r1);
            self.r1[a] = r1;
            self.term1[a] = r1.dot(z);
            for p in agg.particles(0, a) {
                s[p] += filter[p].apply(z);
            }
        }
    }

    /// Level 2, after [`Coarse::level1`]: each level-2 aggregate's `Πᵀr`,
    /// the [`pairwise`] sum of its level-1 aggregates' in slot order
    /// ([`Aggregation::slot_aggregate`]; zeros for the slots the grid's
    /// edge leaves empty), its correction `z = D⁻¹Πᵀr` into `z2` and its
    /// term `(Πᵀr)·z` of `rᵀM⁻¹r` into `term2`. On the GPU the workgroup
    /// of the per-slot `cg_update` that holds the level-2 aggregate's slots
    /// sums them in its reduction tree (`cg_update_slot`).
    /// [`Coarse::prolong`] adds the corrections to `s`.
    pub fn level2(&mut self) {
        let agg = &self.agg;
        for b in 0..agg.count(1) {
            let mut r1 = [Vec3::ZERO; SLOTS_PER_LEVEL2];
            for (k, r) in r1.iter_mut().enumerate() {
                if let Some(a) = agg.slot_aggregate(b * SLOTS_PER_LEVEL2 + k) {
                    *r = self.r1[a];
                }
            }
            let r2 = pairwise(&mut r1);
            let z = self.inv[agg.count(0) + b].mul(r2);
            self.z2[b] = z;
            self.term2[b] = r2.dot(z);
        }
    }

    /// The partial sums of ρ and of δ's coarse terms, one per workgroup of
    /// the per-slot `cg_update` (4 level-2 aggregates' slots), after
    /// [`Coarse::level2`]: slot by slot, ρ's terms `rho_terms` of the
    /// slot's particles added in row-major sequence, and the slot's coarse
    /// terms — its level-1 term, plus its level-2 aggregate's in the
    /// aggregate's first slot — each through a [`pairwise`] tree of the
    /// workgroup's slots (twin: `cg_update_slot`'s reductions). Writes
    /// `rho_partials` and `dc_partials`.
    pub fn partials(&mut self, rho_terms: &[R]) {
        let agg = &self.agg;
        let mut rho = [R::ZERO; CG_BLOCK];
        let mut dc = [R::ZERO; CG_BLOCK];
        for (g, start) in (0..agg.slots()).step_by(CG_BLOCK).enumerate() {
            for k in 0..CG_BLOCK {
                let slot = start + k;
                (rho[k], dc[k]) = (R::ZERO, R::ZERO);
                let Some(a) = agg.slot_aggregate(slot) else {
                    continue;
                };
                for p in agg.particles(0, a) {
                    rho[k] += rho_terms[p];
                }
                dc[k] = self.term1[a];
                if slot % SLOTS_PER_LEVEL2 == 0 {
                    dc[k] += self.term2[slot / SLOTS_PER_LEVEL2];
                }
            }
            self.rho_partials[g] = pairwise(&mut rho);
            self.dc_partials[g] = pairwise(&mut dc);
        }
    }

    /// Adds each level-2 aggregate's correction `S z` to its particles'
    /// `s` (after the block-Jacobi and level-1 terms already there): twin
    /// of the correction `cg_apply` adds to each `s` it loads
    /// (`near_correction` on a grid, `coarse_source` elsewhere).
    pub fn prolong(&self, filter: &[Filter<R>], s: &mut [Vec3<R>]) {
        let agg = &self.agg;
        for b in 0..agg.count(1) {
            let z = self.z2[b];
            for p in agg.particles(1, b) {
                s[p] += filter[p].apply(z);
            }
        }
    }
}
