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

/// The most grid cloths whose coarse levels one solver keeps (a world of
/// more takes none): the GPU holds a [`Piece`] of each in its parameters
/// (`params.coarse_pieces`), two `vec4` a piece.
pub const MAX_PIECES: usize = 8;

/// One grid cloth of an aggregation: its `nx × ny` particles, row-major
/// from `first`, cut into its own aggregates (none spans two cloths).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    /// Columns of particles.
    pub nx: usize,
    /// Rows of particles.
    pub ny: usize,
    /// Its first particle.
    pub first: usize,
    /// Its first level-1 aggregate, among level 1's.
    pub level1: usize,
    /// Its first level-2 aggregate, among level 2's.
    pub level2: usize,
}

impl Piece {
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

    /// Its first aggregate of `level`, among that level's.
    fn start(&self, level: usize) -> usize {
        if level == 0 {
            self.level1
        } else {
            self.level2
        }
    }
}

/// How the grid cloths of a model are cut into aggregates: each cloth (a
/// [`Piece`]) into its own, the last row and column of aggregates of each
/// maybe partial. Aggregates are numbered level by level, cloth by cloth,
/// row-major within a cloth.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Aggregation {
    pieces: Vec<Piece>,
    counts: [usize; 2],
}

impl Aggregation {
    /// The aggregation of a grid of `(nx, ny)` particles, or `None` without
    /// a grid or where the aggregates outnumber the particles (a grid
    /// thinner than two particles: the GPU keeps the aggregates in
    /// per-particle storage).
    pub fn for_grid(grid: Option<(usize, usize)>) -> Option<Self> {
        Self::for_grids(&[grid?])
    }

    /// The aggregation of the grid cloths `grids` (`(nx, ny)` each, their
    /// particles one after the other), or `None` where one is thinner than
    /// two particles, there are more than [`MAX_PIECES`] or none, or the
    /// aggregates outnumber the particles.
    pub fn for_grids(grids: &[(usize, usize)]) -> Option<Self> {
        if grids.is_empty() || grids.len() > MAX_PIECES {
            return None;
        }
        let mut pieces = Vec::with_capacity(grids.len());
        let (mut first, mut counts) = (0, [0, 0]);
        for &(nx, ny) in grids {
            if nx < 2 || ny < 2 {
                return None;
            }
            let piece = Piece {
                nx,
                ny,
                first,
                level1: counts[0],
                level2: counts[1],
            };
            counts = [0, 1].map(|l| counts[l] + piece.count(l));
            first += nx * ny;
            pieces.push(piece);
        }
        (counts[0] + counts[1] <= first).then_some(Aggregation { pieces, counts })
    }

    /// The aggregation of `model`'s CG under `params`: a cloth, or a world
    /// of cloths, that are all grids ([`Model::cloth_grids`]), with
    /// [`crate::params::ImplicitParams::coarse_levels`], implicit (both
    /// backends) or semi-implicit (the GPU's CG-solved filter; the CPU
    /// factors the filter instead).
    pub fn for_scene(model: &Model, params: &Params) -> Option<Self> {
        // The coarse levels aggregate the springs' blocks; a cloth of the
        // linear bending model has a wider operator they do not carry.
        if params.integrator == Integrator::Explicit
            || !params.implicit.coarse_levels
            || model.bending.is_some()
            || model.cloth_grids.len() != model.cloth_starts.len()
        {
            return None;
        }
        let grids: Option<Vec<(usize, usize)>> = model
            .cloth_grids
            .iter()
            .map(|g| g.map(|[nx, ny]| (nx, ny)))
            .collect();
        let agg = Self::for_grids(&grids?)?;
        let covered = agg
            .pieces
            .iter()
            .zip(&model.cloth_starts)
            .all(|(p, &start)| p.first == start as usize);
        (covered && agg.particle_count() == model.particle_count()).then_some(agg)
    }

    /// The cloths, in order.
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Particles of every piece.
    pub fn particle_count(&self) -> usize {
        self.pieces.last().map_or(0, |p| p.first + p.nx * p.ny)
    }

    /// Aggregates at `level`.
    pub fn count(&self, level: usize) -> usize {
        self.counts[level]
    }

    /// Aggregates of both levels: level 1's, then level 2's.
    pub fn total(&self) -> usize {
        self.count(0) + self.count(1)
    }

    /// The piece holding particle `p`.
    fn piece_of(&self, p: usize) -> &Piece {
        let k = self.pieces.partition_point(|piece| piece.first <= p);
        &self.pieces[k.saturating_sub(1)]
    }

    /// The piece holding aggregate `a` of `level` (its index among that
    /// level's).
    fn piece_of_aggregate(&self, level: usize, a: usize) -> &Piece {
        let k = self.pieces.partition_point(|piece| piece.start(level) <= a);
        &self.pieces[k.saturating_sub(1)]
    }

    /// Index, among both levels' aggregates, of the level-`level` aggregate
    /// of particle `p`.
    pub fn of(&self, level: usize, p: usize) -> usize {
        let piece = self.piece_of(p);
        let side = LEVEL_SIDES[level];
        let local = p - piece.first;
        let (row, col) = ((local / piece.nx) / side, (local % piece.nx) / side);
        let offset = if level == 0 { 0 } else { self.count(0) };
        offset + piece.start(level) + row * piece.across(level) + col
    }

    /// Slots of the level-2-major order of the level-1 aggregates:
    /// [`SLOTS_PER_LEVEL2`] per level-2 aggregate.
    pub fn slots(&self) -> usize {
        self.count(1) * SLOTS_PER_LEVEL2
    }

    /// The level-1 aggregate (its index among level 1's) at slot `slot` of
    /// the level-2-major order: slot `16 b + 4 i + j` holds the level-1
    /// aggregate `i` rows and `j` columns into level-2 aggregate `b`, or
    /// none where its cloth's edge cuts level-2 aggregate `b` short or past
    /// the last level-2 aggregate. CG's
    /// per-aggregate update runs an invocation per slot, so the level-1
    /// aggregates of one level-2 aggregate share a workgroup, which sums
    /// their residuals itself (twin: `level1_of_slot` in
    /// `shaders/common/coarse_layout.wgsl`).
    pub fn slot_aggregate(&self, slot: usize) -> Option<usize> {
        let b = slot / SLOTS_PER_LEVEL2;
        let k = slot % SLOTS_PER_LEVEL2;
        if b >= self.count(1) {
            return None;
        }
        let piece = self.piece_of_aggregate(1, b);
        let local = b - piece.level2;
        let row = (local / piece.across(1)) * RATIO + k / RATIO;
        let col = (local % piece.across(1)) * RATIO + k % RATIO;
        (row < piece.down(0) && col < piece.across(0))
            .then(|| piece.level1 + row * piece.across(0) + col)
    }

    /// Particles of aggregate `a` of `level` (its index among that
    /// level's), row-major.
    pub fn particles(&self, level: usize, a: usize) -> impl Iterator<Item = usize> + '_ {
        let piece = *self.piece_of_aggregate(level, a);
        let local = a - piece.start(level);
        let (row, col) = (local / piece.across(level), local % piece.across(level));
        let side = LEVEL_SIDES[level];
        let rows = row * side..((row + 1) * side).min(piece.ny);
        let cols = col * side..((col + 1) * side).min(piece.nx);
        rows.flat_map(move |r| cols.clone().map(move |c| piece.first + r * piece.nx + c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every particle in one aggregate of each level, which `of` names;
    /// every level-1 aggregate in one slot, within its level-2
    /// aggregate's run.
    fn assert_covers(agg: &Aggregation) {
        let n = agg.particle_count();
        for level in 0..2 {
            let mut seen = vec![0; n];
            for a in 0..agg.count(level) {
                let offset = if level == 0 { 0 } else { agg.count(0) };
                for p in agg.particles(level, a) {
                    seen[p] += 1;
                    assert_eq!(agg.of(level, p), offset + a);
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "level {level}");
        }
        let mut seen = vec![0; agg.count(0)];
        for slot in 0..agg.slots() {
            if let Some(a) = agg.slot_aggregate(slot) {
                seen[a] += 1;
                let p = agg.particles(0, a).next();
                let level2 = p.map(|p| agg.of(1, p) - agg.count(0));
                assert_eq!(level2, Some(slot / SLOTS_PER_LEVEL2), "slot {slot}");
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }

    #[test]
    fn aggregates_cover_the_grid_once_per_level() {
        let agg = Aggregation::for_grid(Some((37, 21))).expect("a grid");
        assert_covers(&agg);
        assert_eq!(agg.count(0), 10 * 6);
        assert_eq!(agg.count(1), 3 * 2);
    }

    #[test]
    fn a_world_s_grids_are_aggregated_each_on_its_own() {
        let agg = Aggregation::for_grids(&[(37, 21), (9, 17), (33, 33)]).expect("grids");
        assert_covers(&agg);
        assert_eq!(agg.count(0), 10 * 6 + 3 * 5 + 9 * 9);
        assert_eq!(agg.count(1), 3 * 2 + 2 + 3 * 3);
        // No aggregate holds particles of two cloths.
        let cloth = |p: usize| [0, 777, 930].partition_point(|&s| s <= p);
        for level in 0..2 {
            for a in 0..agg.count(level) {
                let mut of = agg.particles(level, a).map(cloth);
                let first = of.next();
                assert!(of.all(|c| Some(c) == first), "level {level}, aggregate {a}");
            }
        }
    }

    #[test]
    fn no_aggregation_without_a_grid_or_on_a_line() {
        assert_eq!(Aggregation::for_grid(None), None);
        assert_eq!(Aggregation::for_grid(Some((1, 50))), None);
        assert_eq!(Aggregation::for_grids(&[(9, 9), (1, 50)]), None);
        assert_eq!(Aggregation::for_grids(&[(9, 9); MAX_PIECES + 1]), None);
    }
}
