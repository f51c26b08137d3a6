// CG scalars, once per solve (one workgroup, one invocation working):
// δ0 and δ from the partials in the CPU's order, and whether CG is done
// before its first iteration (twin: the loop condition of
// cpu::implicit::step).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(1)
fn cg_start() {
    let delta0 = sum_partials(P_D0);
    let delta = sum_partials(P_RS);
    partials[scalar_index(C_DELTA0)] = delta0;
    partials[scalar_index(C_DELTA)] = delta;
    if (!(delta > params.cg_tolerance_sq * delta0)) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
    }
}
