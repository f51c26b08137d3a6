//! How a grid cloth is cut into the square aggregates of the implicit
//! CG's coarse levels: shared by the CPU reference (`cpu::coarse`) and the
//! GPU solver (`gpu`), which sizes its buffers and dispatches from it and
//! whose WGSL twin is `shaders/common/coarse.wgsl`. The numerics live in
//! `cpu::coarse`; this module only describes the shape.

use crate::model::Model;
use crate::params::{Integrator, Params};

/// Particles per aggregate side, level by level. Level 2's side is a
/// multiple of level 1's, so each level-2 aggregate is a whole number of
/// level-1 aggregates (at most 4 × 4).
pub const LEVEL_SIDES: [usize; 2] = [4, 16];

/// Level-1 aggregates per level-2 aggregate side.
pub const RATIO: usize = LEVEL_SIDES[1] / LEVEL_SIDES[0];

/// Slots of a level-2 aggregate in the level-2-major order of the level-1
/// aggregates ([`Aggregation::slot_aggregate`]).
pub const SLOTS_PER_LEVEL2: usize = RATIO * RATIO;

/// How an `nx × ny` grid is cut into aggregates (the last row and column
/// of aggregates may be partial).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Aggregation {
    /// Columns of particles.
    pub nx: usize,
    /// Rows of particles.
    pub ny: usize,
}

impl Aggregation {
    /// The aggregation of a grid of `(nx, ny)` particles, or `None` without
    /// a grid or where the aggregates outnumber the particles (a grid
    /// thinner than two particles: the GPU keeps the aggregates in
    /// per-particle storage).
    pub fn for_grid(grid: Option<(usize, usize)>) -> Option<Self> {
        let (nx, ny) = grid?;
        let agg = Aggregation { nx, ny };
        (nx >= 2 && ny >= 2 && agg.total() <= nx * ny).then_some(agg)
    }

    /// The aggregation of `model`'s CG under `params`: a grid cloth with
    /// [`crate::params::ImplicitParams::coarse_levels`], implicit (both
    /// backends) or semi-implicit (the GPU's CG-solved filter; the CPU
    /// factors the filter instead).
    pub fn for_scene(model: &Model, params: &Params) -> Option<Self> {
        // The coarse levels aggregate the springs' blocks; a cloth of the
        // linear bending model has a wider operator they do not carry.
        if params.integrator == Integrator::Explicit
            || !params.implicit.coarse_levels
            || model.bending.is_some()
        {
            return None;
        }
        Self::for_grid(model.grid.as_ref().map(|g| (g.nx, g.ny)))
    }

    /// Aggregates per row at `level`.
    pub fn across(&self, level: usize) -> usize {
        self.nx.div_ceil(LEVEL_SIDES[level])
    }

    /// Aggregates per column at `level`.
    pub fn down(&self, level: usize) -> usize {
        self.ny.div_ceil(LEVEL_SIDES[level])
    }

    /// Aggregates at `level`.
    pub fn count(&self, level: usize) -> usize {
        self.across(level) * self.down(level)
    }

    /// Aggregates of both levels: level 1's, then level 2's.
    pub fn total(&self) -> usize {
        self.count(0) + self.count(1)
    }

    /// Index, among both levels' aggregates, of aggregate `(row, col)` of
    /// `level`.
    pub fn index(&self, level: usize, row: usize, col: usize) -> usize {
        let offset = if level == 0 { 0 } else { self.count(0) };
        offset + row * self.across(level) + col
    }

    /// Index, among both levels' aggregates, of the level-`level` aggregate
    /// of particle `p`.
    pub fn of(&self, level: usize, p: usize) -> usize {
        let side = LEVEL_SIDES[level];
        self.index(level, (p / self.nx) / side, (p % self.nx) / side)
    }

    /// Slots of the level-2-major order of the level-1 aggregates:
    /// [`SLOTS_PER_LEVEL2`] per level-2 aggregate.
    pub fn slots(&self) -> usize {
        self.count(1) * SLOTS_PER_LEVEL2
    }

    /// The level-1 aggregate (its index among level 1's) at slot `slot` of
    /// the level-2-major order: slot `16 b + 4 i + j` holds the level-1
    /// aggregate `i` rows and `j` columns into level-2 aggregate `b`, or
    /// none where the grid's edge cuts level-2 aggregate `b` short or past
    /// the last level-2 aggregate. CG's
    /// per-aggregate update runs an invocation per slot, so the level-1
    /// aggregates of one level-2 aggregate share a workgroup, which sums
    /// their residuals itself (twin: `level1_of_slot` in
    /// `shaders/common/coarse.wgsl`).
    pub fn slot_aggregate(&self, slot: usize) -> Option<usize> {
        let b = slot / SLOTS_PER_LEVEL2;
        let k = slot % SLOTS_PER_LEVEL2;
        if b >= self.count(1) {
            return None;
        }
        let row = (b / self.across(1)) * RATIO + k / RATIO;
        let col = (b % self.across(1)) * RATIO + k % RATIO;
        (row < self.down(0) && col < self.across(0)).then(|| self.index(0, row, col))
    }

    /// Particles of aggregate `(row, col)` of `level`, row-major.
    pub fn particles(
        &self,
        level: usize,
        row: usize,
        col: usize,
    ) -> impl Iterator<Item = usize> + '_ {
        let side = LEVEL_SIDES[level];
        let rows = row * side..((row + 1) * side).min(self.ny);
        let cols = col * side..((col + 1) * side).min(self.nx);
        rows.flat_map(move |r| cols.clone().map(move |c| r * self.nx + c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aggregates_cover_the_grid_once_per_level() {
        let agg = Aggregation::for_grid(Some((37, 21))).expect("a grid");
        for level in 0..2 {
            let mut seen = vec![0; agg.nx * agg.ny];
            for row in 0..agg.down(level) {
                for col in 0..agg.across(level) {
                    for p in agg.particles(level, row, col) {
                        seen[p] += 1;
                        assert_eq!(agg.of(level, p), agg.index(level, row, col));
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "level {level}");
        }
        assert_eq!(agg.count(0), 10 * 6);
        // The level-2-major slots hold every level-1 aggregate once, each in
        // its level-2 aggregate's run of slots.
        let mut seen = vec![0; agg.count(0)];
        for slot in 0..agg.slots() {
            if let Some(a) = agg.slot_aggregate(slot) {
                seen[a] += 1;
                let p = agg
                    .particles(0, a / agg.across(0), a % agg.across(0))
                    .next();
                let level2 = p.map(|p| agg.of(1, p) - agg.count(0));
                assert_eq!(level2, Some(slot / SLOTS_PER_LEVEL2), "slot {slot}");
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        assert_eq!(agg.count(1), 3 * 2);
    }

    #[test]
    fn no_aggregation_without_a_grid_or_on_a_line() {
        assert_eq!(Aggregation::for_grid(None), None);
        assert_eq!(Aggregation::for_grid(Some((1, 50))), None);
    }
}
