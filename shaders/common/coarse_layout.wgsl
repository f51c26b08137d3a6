// Where the implicit CG's coarse levels live on a grid cloth, or a world
// of grid cloths (twin: crate::aggregation): square aggregates of
// LEVEL1_SIDE and LEVEL2_SIDE particles a side, each cloth (a piece) cut
// into its own. params.coarse = (the first cloth's columns and rows, for
// the grid kernels of a lone grid; level-1 aggregates; level-2
// aggregates), params.coarse_world.x the pieces, params.coarse_pieces two
// vec4 a piece (coarse_piece); every aggregate lives at its index among
// both levels (level 1's first, cloth by cloth) in the W_COARSE_*
// sections. The numerics are in common/coarse.wgsl; the CG kernels'
// common code reads a particle's level-2 correction from here.

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

// A grid cloth of the coarse levels (twin: aggregation::Piece): columns,
// rows, its first particle (within the cloth's range), its first level-1
// aggregate among level 1's and first level-2 aggregate among level 2's.
struct CoarsePiece {
    nx: u32,
    ny: u32,
    first: u32,
    level1: u32,
    level2: u32,
}

fn coarse_piece(k: u32) -> CoarsePiece {
    let a = params.coarse_pieces[2u * k];
    return CoarsePiece(a.x, a.y, a.z, a.w, params.coarse_pieces[2u * k + 1u].x);
}

// The last piece whose start (component `c` of its first vec4: 2 its
// first particle, 3 its first level-1 aggregate; 4 the second vec4's x,
// its first level-2 aggregate) is at most `at`: the piece holding `at`.
fn coarse_piece_at(c: u32, at: u32) -> CoarsePiece {
    var k = 0u;
    for (var j = 1u; j < params.coarse_world.x; j++) {
        var start = params.coarse_pieces[2u * j + 1u].x;
        if (c < 4u) {
            start = params.coarse_pieces[2u * j][c];
        }
        if (start <= at) {
            k = j;
        }
    }
    return coarse_piece(k);
}

// Aggregates per row of piece `pc` at the level whose aggregates have
// `side` particles a side (twin: Piece::across).
fn piece_across(pc: CoarsePiece, side: u32) -> u32 {
    return (pc.nx + side - 1u) / side;
}

// Aggregates per column (twin: Piece::down).
fn piece_down(pc: CoarsePiece, side: u32) -> u32 {
    return (pc.ny + side - 1u) / side;
}

// Aggregates per row of a lone grid cloth (the grid kernels').
fn coarse_across(side: u32) -> u32 {
    return (params.coarse.x + side - 1u) / side;
}

// Index, among both levels', of the aggregate in aggregate row and column
// `at` of a lone grid cloth's level whose aggregates have `side`
// particles a side (the grid kernels').
fn coarse_index(side: u32, at: vec2<u32>) -> u32 {
    let offset = select(0u, params.coarse.z, side == LEVEL2_SIDE);
    return offset + at.x * coarse_across(side) + at.y;
}

// Index of particle p's aggregate of side `side`, among both levels'
// (twin: Aggregation::of).
fn coarse_of(side: u32, p: u32) -> u32 {
    let l = local(p);
    let pc = coarse_piece_at(2u, l);
    let q = l - pc.first;
    let row = (q / pc.nx) / side;
    let col = (q % pc.nx) / side;
    let offset = select(pc.level1, params.coarse.z + pc.level2, side == LEVEL2_SIDE);
    return offset + row * piece_across(pc, side) + col;
}

// Particle k (0 ≤ k < LEVEL1_SIDE², row-major) of level-1 aggregate a,
// or NO_PARTICLE where the grid's edge cuts the aggregate. Loops over k
// with this fixed trip count are unrolled by the compilers.
const NO_PARTICLE: u32 = 0xffffffffu;

fn level1_particle(a: u32, k: u32) -> u32 {
    let pc = coarse_piece_at(3u, a);
    let across = piece_across(pc, LEVEL1_SIDE);
    let row = ((a - pc.level1) / across) * LEVEL1_SIDE + k / LEVEL1_SIDE;
    let col = ((a - pc.level1) % across) * LEVEL1_SIDE + k % LEVEL1_SIDE;
    if (row >= pc.ny || col >= pc.nx) {
        return NO_PARTICLE;
    }
    return params.particle_base + pc.first + row * pc.nx + col;
}

// Level-2 aggregate k's correction z (W_COARSE_Z's xyz past level 1),
// for particle p's.
fn level2_z(p: u32) -> vec3<f32> {
    return work[wa(W_COARSE_Z, coarse_of(LEVEL2_SIDE, p))].xyz;
}

// The level-1 aggregate at slot `slot` of the level-2-major order, or
// NO_PARTICLE (twin: Aggregation::slot_aggregate): slot 16 b + 4 i + j is
// the level-1 aggregate i rows and j columns into level-2 aggregate b
// (of its cloth).
fn level1_of_slot(slot: u32) -> u32 {
    let b = slot / (LEVEL_RATIO * LEVEL_RATIO);
    let k = slot % (LEVEL_RATIO * LEVEL_RATIO);
    if (b >= params.coarse.w) {
        return NO_PARTICLE;
    }
    let pc = coarse_piece_at(4u, b);
    let across2 = piece_across(pc, LEVEL2_SIDE);
    let row = ((b - pc.level2) / across2) * LEVEL_RATIO + k / LEVEL_RATIO;
    let col = ((b - pc.level2) % across2) * LEVEL_RATIO + k % LEVEL_RATIO;
    if (row >= piece_down(pc, LEVEL1_SIDE) || col >= piece_across(pc, LEVEL1_SIDE)) {
        return NO_PARTICLE;
    }
    return pc.level1 + row * piece_across(pc, LEVEL1_SIDE) + col;
}
