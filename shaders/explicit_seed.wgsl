// Copies x and v into the `work` sections SNAP and SNAP + 1, where
// single-pass explicit steps (explicit_integrate with SNAP_IN) alternate
// the state with x and v: recorded before an odd number of such steps, so
// that the last one writes x and v.
#include "common/bindings.wgsl"

override SNAP: u32 = 4u;

@compute @workgroup_size(WORKGROUP)
fn explicit_seed(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    work[wi(SNAP, p)] = x[p];
    work[wi(SNAP + 1u, p)] = v[p];
}
