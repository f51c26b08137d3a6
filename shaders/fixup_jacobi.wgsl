// One Jacobi pass of Provot's fix-up: every particle gathers the
// corrections of its over-stretched springs from the snapshot in section
// SRC and writes its moved position to section DST. Twin:
// cpu::fixup::jacobi (one pass).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/no_spring_data.wgsl"
#include "generated/grid_block.wgsl"

override SRC: u32 = 0u;
override DST: u32 = 1u;
// Pass k's flag slot is k mod 3 (FLAG); FIRST marks pass 0.
override FLAG: u32 = 0u;
override FIRST: bool = true;

// Twin: cpu::fixup SLACK_ULPS × f32::EPSILON.
const SLACK: f32 = 1.0 + 1.1920929e-7 * 64.0;

// Twin: cpu::fixup::correction. Returns the correction c (end i moves by
// −w_i c, end j by +w_j c) and whether the spring is over its limit.
fn correction(s: u32) -> vec4<f32> {
    let sp = springs[s];
    if (sp.max_len <= 0.0) {
        return vec4<f32>(0.0);
    }
    let d = work[wi(SRC, sp.i)].xyz - work[wi(SRC, sp.j)].xyz;
    let l = len3(d);
    let w = x[sp.i].w + x[sp.j].w;
    if (l > sp.max_len * SLACK && w > 0.0) {
        return vec4<f32>(d * ((l - sp.max_len) / (l * w)), 1.0);
    }
    return vec4<f32>(0.0);
}

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
    move_particle(p, own.x, own.w, acc.xyz, u32(acc.w));
}

// Moves particle p (SRC position `xp`, inverse mass `w`) by the mean of
// its `count` corrections, whose sum is `sum`, into DST.
fn move_particle(p: u32, xp: vec3<f32>, w: f32, sum: vec3<f32>, count: u32) {
    var xn = xp;
    if (count > 0u) {
        atomicStore(&status[STATUS_FIXUP_MOVED], 1u);
        atomicStore(&status[STATUS_FIXUP_FLAG + FLAG], 1u);
        if (w > 0.0) {
            xn += sum * (w * params.fixup_omega / f32(count));
        }
    }
    work[wi(DST, p)] = vec4<f32>(xn, 0.0);
}

@compute @workgroup_size(WORKGROUP)
fn fixup_jacobi(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    // Stop once a pass moved nothing (twin: the CPU's `break`): its result,
    // in SRC, is final. Pass k reads pass k−1's flag and clears pass k+1's,
    // which no invocation of this dispatch reads.
    if (atomicLoad(&status[STATUS_FIXUP_STOPPED]) != 0u) {
        return;
    }
    if (!FIRST && atomicLoad(&status[STATUS_FIXUP_FLAG + (FLAG + 2u) % 3u]) == 0u) {
        if (p == 0u) {
            atomicStore(&status[STATUS_FIXUP_STOPPED], 1u);
        }
        return;
    }
    if (p == 0u) {
        atomicStore(&status[STATUS_FIXUP_FLAG + (FLAG + 1u) % 3u], 0u);
        atomicStore(&status[STATUS_FIXUP_RESULT], DST);
        atomicAdd(&status[STATUS_FIXUP_PASSES], 1u);
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    let own = block_load(lone_point(p));
    var sum = vec3<f32>(0.0);
    var count = 0u;
    let begin = topo[p];
    let end = topo[p + 1u];
    for (var k = begin; k < end; k++) {
        let e = topo[params.spring_adj_entries + k];
        let c = correction(e >> 1u);
        if (c.w == 0.0) {
            continue;
        }
        if ((e & 1u) == 0u) {
            sum -= c.xyz;
        } else {
            sum += c.xyz;
        }
        count += 1u;
    }
    move_particle(p, own.x, own.w, sum, count);
}
