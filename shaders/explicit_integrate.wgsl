// Symplectic Euler: v* = v + dt w f, x* = x + dt v* (pinned: x* = x,
// v* = 0). Twin: cpu::explicit::integrate.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/fixup.wgsl"
#include "common/step.wgsl"
#include "common/no_spring_data.wgsl"
#include "generated/grid_block.wgsl"

// Without fix-up, end the step here (twin: finish_step): collide and store.
// Either this kernel then reads no other particle's state (the general
// kernels without wind: the spring pass has gathered it), and updates it
// in place, or it reads the state, wind triangles included, from one
// place and writes it to another (below).
override FUSED: bool = false;
// Single-pass grid steps (see GpuSolver::step_plan) alternate between the
// state buffers x, v and the `work` sections SNAPSHOT (x) and SNAPSHOT + 1
// (v): read from SNAP_IN, write to SNAP_OUT (STATE_BUFFERS: x and v) —
// no invocation reads what another writes.
override SNAP_IN: u32 = 0xffffffffu;
override SNAP_OUT: u32 = 0xffffffffu;

@compute @workgroup_size(WORKGROUP)
fn explicit_integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[sw(STATUS_STEP)], 1u);
        reset_fixup();
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    let own = block_load(lone_point(p));
    integrate_particle(p, own.x, own.v, total_force(p, own.x, own.v, SNAP_IN));
}

// The grid gather (generated/grid_block.wgsl): each particle's state, and
// the sum of its spring forces.
struct BlockData {
    x: vec4<f32>,
    v: vec4<f32>,
}

alias BlockAcc = vec3<f32>;

fn block_load(pt: GridPoint) -> BlockData {
    let i = pt.index;
    if (SNAP_IN == STATE_BUFFERS) {
        return BlockData(x[i], v[i]);
    }
    return BlockData(work[wi(SNAP_IN, i)], work[wi(SNAP_IN + 1u, i)]);
}

fn block_start(p: u32, own: BlockData) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn block_term(sum: vec3<f32>, own: BlockData, other: BlockData, inc: Incident, sd: u32) -> vec3<f32> {
    return sum + grid_spring_force(inc, own.x.xyz, own.v.xyz, other.x.xyz, other.v.xyz);
}

fn block_end(p: u32, own: BlockData, sum: vec3<f32>) {
    integrate_particle(p, own.x, own.v, force_with_springs(p, sum, own.v.w, SNAP_IN));
}

// The rest of particle p's step from its state `x0`, `v0` and the total
// force `f` on it [N].
fn integrate_particle(p: u32, x0: vec4<f32>, v0: vec4<f32>, f: vec3<f32>) {
    let w = x0.w;
    let pred = predict(x0, v0, f);
    var xn = pred[0];
    var vn = pred[1];
    if (FUSED) {
        let clock = particle_clock(p);
        if (w > 0.0) {
            let r = collide_particle(x0.xyz, xn, vn, clock);
            xn = r[0];
            vn = r[1];
        } else {
            let r = pin_step(p, clock, xn);
            xn = r[0];
            vn = r[1];
        }
        advance_clock(p, clock, vec3<f32>(0.0));
        // A state that is not finite is not stored: the last finite one
        // is (see store_state).
        let ok = finite_or_reported(p, xn, vn);
        let x_out = select(x0, vec4<f32>(unsigned_zero3(xn), w), ok);
        let v_out = select(v0, vec4<f32>(unsigned_zero3(vn), v0.w), ok);
        if (SNAP_OUT == STATE_BUFFERS) {
            x[p] = x_out;
            v[p] = v_out;
        } else {
            work[wi(SNAP_OUT, p)] = x_out;
            work[wi(SNAP_OUT + 1u, p)] = v_out;
        }
        return;
    }
    store_prediction(p, xn, vn);
}
