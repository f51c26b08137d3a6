// The grid gather's hooks (generated/grid_block.wgsl) for the CG product
// (A a)_p, summed as apply_a sums it, of the vector in `work` section
// APPLY_SEC. The including kernel defines APPLY_SEC,
// `apply_value(point, stored)`, the vector's value at a stencil point from
// what the section stores there, and `apply_end(p, a_p, (A a)_p
// unfiltered)`, where a_p is the value with the stored w. Each stencil
// particle's a and (for the implicit matrix) position are loaded once;
// each spring's block is computed once, from its ends' positions (see
// grid_spring_block).

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

struct BlockData {
    a: vec4<f32>,
    x: vec3<f32>,
}

alias BlockAcc = vec3<f32>;

fn block_load(pt: GridPoint) -> BlockData {
    let i = pt.index;
    var xi = vec3<f32>(0.0);
    if (!CONSTANT_BLOCKS) {
        xi = x[i].xyz;
    }
    let stored = work[wi(APPLY_SEC, i)];
    return BlockData(vec4<f32>(apply_value(pt, stored), stored.w), xi);
}

fn block_start(p: u32, own: BlockData) -> vec3<f32> {
    return own.a.xyz * v[p].w;
}

alias SpringData = vec4<f32>;

fn spring_load(inc: Incident, first: BlockData, second: BlockData) -> vec4<f32> {
    return grid_spring_block(inc, first.x, second.x);
}

fn block_term(acc: vec3<f32>, own: BlockData, other: BlockData, inc: Incident, blk: vec4<f32>) -> vec3<f32> {
    return grid_apply_with(acc, inc, own.a.xyz, other.a.xyz, blk);
}

fn block_end(p: u32, own: BlockData, acc: vec3<f32>) {
    // The bending operator's neighbours are not the stencil's: its part
    // reads the section itself (the coarse correction of apply_value is
    // never on with it).
    apply_end(p, own.a, add_bending_product(acc, APPLY_SEC, p));
}
