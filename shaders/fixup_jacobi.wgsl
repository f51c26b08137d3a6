// One Jacobi pass of Provot's fix-up: every particle gathers the
// corrections of its over-stretched springs from the snapshot in section
// SRC and writes its moved position to section DST. Twin:
// cpu::fixup::jacobi (one pass).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/fixup.wgsl"
#include "common/no_spring_data.wgsl"
#include "generated/grid_block.wgsl"

override SRC: u32 = 0u;
override DST: u32 = 1u;
// Pass k's flag slot is k mod 3 (FLAG); FIRST marks pass 0.
override FLAG: u32 = 0u;
override FIRST: bool = true;

// The grid gather (generated/grid_block.wgsl): each particle's SRC
// position and inverse mass; the sum (xyz: Σ ±c, w: count) of the
// corrections of its springs over their limits.
struct BlockData {
    x: vec3<f32>,
    w: f32,
}

alias BlockAcc = vec4<f32>;

fn block_load(pt: GridPoint) -> BlockData {
    return BlockData(work[wi(SRC, pt.index)].xyz, x[pt.index].w);
}

fn block_start(p: u32, own: BlockData) -> vec4<f32> {
    return vec4<f32>(0.0);
}

// `acc` plus spring `inc`'s correction, if it is over its limit: the
// correction as both ends compute it (twin: cpu::fixup::correction).
// Branch-free: a spring under its limit adds −0.
fn block_term(acc: vec4<f32>, own: BlockData, other: BlockData, inc: Incident, sd: u32) -> vec4<f32> {
    // x_i + x_j in either order is the same sum.
    let w = own.w + other.w;
    let d = select(own.x, other.x, inc.at_j) - select(other.x, own.x, inc.at_j);
    let l = len3(d);
    let over = inc.ok && inc.max_len > 0.0 && l > inc.max_len * SLACK && w > 0.0;
    let c = d * ((l - inc.max_len) / (l * w));
    // End i moves by −w c, end j by +w c.
    return acc + select(vec4<f32>(-0.0), vec4<f32>(select(-c, c, inc.at_j), 1.0), over);
}

fn block_end(p: u32, own: BlockData, acc: vec4<f32>) {
    if (fixup_move(p, own.x, own.w, acc.xyz, u32(acc.w), DST)) {
        fixup_moved(FLAG);
    }
}

@compute @workgroup_size(WORKGROUP)
fn fixup_jacobi(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    // Stop once a pass moved nothing (twin: the CPU's `break`): its result,
    // in SRC, is final. Pass k reads pass k−1's flag and clears pass k+1's,
    // which no invocation of this dispatch reads.
    if (atomicLoad(&status[sw(STATUS_FIXUP_STOPPED)]) != 0u) {
        return;
    }
    if (!FIRST && atomicLoad(&status[sw(STATUS_FIXUP_FLAG + (FLAG + 2u) % 3u)]) == 0u) {
        if (p == 0u) {
            atomicStore(&status[sw(STATUS_FIXUP_STOPPED)], 1u);
        }
        return;
    }
    if (p == 0u) {
        atomicStore(&status[sw(STATUS_FIXUP_FLAG + (FLAG + 1u) % 3u)], 0u);
        atomicStore(&status[sw(STATUS_FIXUP_RESULT)], DST);
        atomicAdd(&status[sw(STATUS_FIXUP_PASSES)], 1u);
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    if (fixup_particle(p, SRC, DST)) {
        fixup_moved(FLAG);
    }
}
