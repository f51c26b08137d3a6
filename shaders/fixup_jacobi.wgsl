// One Jacobi pass of Provot's fix-up: every particle gathers the
// corrections of its over-stretched springs from the snapshot in section
// SRC and writes its moved position to section DST. Twin:
// cpu::fixup::jacobi (one pass).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

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

// `acc` (xyz: Σ ±c, w: count) plus grid spring `t`'s correction at
// particle p, if it is over its limit: the correction as both ends compute
// it (twin: cpu::fixup::correction), from the SRC positions and inverse
// masses `xp`, `wp` of p and those of its neighbour. Branch-free: a
// spring under its limit adds −0.
fn grid_fixup_term(
    acc: vec4<f32>,
    p: u32,
    rc: vec2<i32>,
    xp: vec3<f32>,
    wp: f32,
    t: vec4<i32>,
) -> vec4<f32> {
    let inc = grid_incident(p, rc, t);
    let xo = work[wi(SRC, inc.other)].xyz;
    // x_i + x_j in either order is the same sum.
    let w = wp + x[inc.other].w;
    let d = select(xp, xo, inc.at_j) - select(xo, xp, inc.at_j);
    let l = len3(d);
    let over = inc.ok && inc.max_len > 0.0 && l > inc.max_len * SLACK && w > 0.0;
    let c = d * ((l - inc.max_len) / (l * w));
    // End i moves by −w c, end j by +w c.
    return acc + select(vec4<f32>(-0.0), vec4<f32>(select(-c, c, inc.at_j), 1.0), over);
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
    if (p >= params.particle_count) {
        return;
    }
    var xp = work[wi(SRC, p)].xyz;
    let w = x[p].w;
    var sum = vec3<f32>(0.0);
    var count = 0u;
    var begin = 0u;
    var end = 0u;
    if (!GRID) {
        begin = topo[p];
        end = topo[p + 1u];
    } else {
        // The same springs in the same order, two loads each.
        let rc = grid_row_col(p);
        var acc = vec4<f32>(0.0);
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(-1, 0, 1, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(0, -1, 0, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(0, 1, 0, 0));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(1, 0, 1, 0));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(-1, -1, 2, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(-1, 1, 3, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(1, -1, 3, 0));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(1, 1, 2, 0));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(-2, 0, 5, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(0, -2, 4, 1));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(0, 2, 4, 0));
        acc = grid_fixup_term(acc, p, rc, xp, w, vec4<i32>(2, 0, 5, 0));
        sum = acc.xyz;
        count = u32(acc.w);
    }
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
    if (count > 0u) {
        atomicStore(&status[STATUS_FIXUP_MOVED], 1u);
        atomicStore(&status[STATUS_FIXUP_FLAG + FLAG], 1u);
        if (w > 0.0) {
            xp += sum * (w * params.fixup_omega / f32(count));
        }
    }
    work[wi(DST, p)] = vec4<f32>(xp, 0.0);
}
