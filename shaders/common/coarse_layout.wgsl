// Where the implicit CG's coarse levels live on a grid cloth (twin:
// crate::aggregation): square aggregates of LEVEL1_SIDE and LEVEL2_SIDE
// particles a side. params.coarse = (columns, rows, level-1 aggregates,
// level-2 aggregates); every aggregate lives at its index among both
// levels (level 1's first) in the W_COARSE_* sections. The numerics are in
// common/coarse.wgsl; the CG kernels' common code reads a particle's
// level-2 correction from here.

#include "common/bindings.wgsl"

// Twin: cpu::coarse::LEVEL_SIDES.
const LEVEL1_SIDE: u32 = 4u;
const LEVEL2_SIDE: u32 = 16u;
// Level-1 aggregates per level-2 aggregate side.
const LEVEL_RATIO: u32 = 4u;

// Aggregate a's entry of `work` section `section` (the coarse levels keep
// one entry per aggregate of both levels, level 1's first, where the
// particles keep one per particle).
fn wa(section: u32, a: u32) -> u32 {
    return wi(section, params.particle_base + a);
}

// Aggregates per row of a level whose aggregates have `side` particles a
// side (twin: Aggregation::across).
fn coarse_across(side: u32) -> u32 {
    return (params.coarse.x + side - 1u) / side;
}

// Aggregates per column (twin: Aggregation::down).
fn coarse_down(side: u32) -> u32 {
    return (params.coarse.y + side - 1u) / side;
}

// Index, among both levels', of the aggregate in aggregate row and column
// `at` of the level whose aggregates have `side` particles a side.
fn coarse_index(side: u32, at: vec2<u32>) -> u32 {
    let offset = select(0u, params.coarse.z, side == LEVEL2_SIDE);
    return offset + at.x * coarse_across(side) + at.y;
}

// Index of particle p's aggregate of side `side`, among both levels'
// (twin: Aggregation::of).
fn coarse_of(side: u32, p: u32) -> u32 {
    let row = local(p) / params.coarse.x;
    let col = local(p) % params.coarse.x;
    return coarse_index(side, vec2<u32>(row / side, col / side));
}

// Particle k (0 ≤ k < LEVEL1_SIDE², row-major) of level-1 aggregate a,
// or NO_PARTICLE where the grid's edge cuts the aggregate. Loops over k
// with this fixed trip count are unrolled by the compilers.
const NO_PARTICLE: u32 = 0xffffffffu;

fn level1_particle(a: u32, k: u32) -> u32 {
    let nx = params.coarse.x;
    let across = coarse_across(LEVEL1_SIDE);
    let row = (a / across) * LEVEL1_SIDE + k / LEVEL1_SIDE;
    let col = (a % across) * LEVEL1_SIDE + k % LEVEL1_SIDE;
    if (row >= params.coarse.y || col >= nx) {
        return NO_PARTICLE;
    }
    return params.particle_base + row * nx + col;
}

// Level-2 aggregate k's correction z (W_COARSE_Z's xyz past level 1),
// for particle p's.
fn level2_z(p: u32) -> vec3<f32> {
    return work[wa(W_COARSE_Z, coarse_of(LEVEL2_SIDE, p))].xyz;
}

// The level-1 aggregate at slot `slot` of the level-2-major order, or
// NO_PARTICLE (twin: Aggregation::slot_aggregate): slot 16 b + 4 i + j is
// the level-1 aggregate i rows and j columns into level-2 aggregate b.
fn level1_of_slot(slot: u32) -> u32 {
    let b = slot / (LEVEL_RATIO * LEVEL_RATIO);
    let k = slot % (LEVEL_RATIO * LEVEL_RATIO);
    let across2 = coarse_across(LEVEL2_SIDE);
    let row = (b / across2) * LEVEL_RATIO + k / LEVEL_RATIO;
    let col = (b % across2) * LEVEL_RATIO + k % LEVEL_RATIO;
    if (b >= params.coarse.w || row >= coarse_down(LEVEL1_SIDE) || col >= coarse_across(LEVEL1_SIDE)) {
        return NO_PARTICLE;
    }
    return row * coarse_across(LEVEL1_SIDE) + col;
}
