// Torque compensation, pass 3: Δv −= ω × r with ω = I⁻¹ ΔL.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/torque.wgsl"

var<workgroup> shared_omega: vec4<f32>;

@compute @workgroup_size(WORKGROUP)
fn torque_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    let centre = centre_of_mass(lid.x);
    if (lid.x == 0u) {
        let e = vec3<f32>(
            sum_partials(torque_slot(T_EXCESS)),
            sum_partials(torque_slot(T_EXCESS + 1u)),
            sum_partials(torque_slot(T_EXCESS + 2u)),
        );
        let xx = sum_partials(torque_slot(T_INERTIA));
        let yy = sum_partials(torque_slot(T_INERTIA + 1u));
        let zz = sum_partials(torque_slot(T_INERTIA + 2u));
        let xy = sum_partials(torque_slot(T_INERTIA + 3u));
        let xz = sum_partials(torque_slot(T_INERTIA + 4u));
        let yz = sum_partials(torque_slot(T_INERTIA + 5u));
        // Twin: Sym3::inverse; a singular tensor leaves Δv as it is.
        let c_xx = yy * zz - yz * yz;
        let c_xy = xz * yz - xy * zz;
        let c_xz = xy * yz - xz * yy;
        let det = xx * c_xx + xy * c_xy + xz * c_xz;
        let scale = max(max(abs(xx), abs(yy)), abs(zz));
        let floor = TINY * scale * scale * scale;
        var omega = vec4<f32>(0.0);
        if (finite1(det) && det > floor) {
            let inv = 1.0 / det;
            let ixx = c_xx * inv;
            let iyy = (xx * zz - xz * xz) * inv;
            let izz = (xx * yy - xy * xy) * inv;
            let ixy = c_xy * inv;
            let ixz = c_xz * inv;
            let iyz = (xy * xz - xx * yz) * inv;
            omega = vec4<f32>(
                ixx * e.x + ixy * e.y + ixz * e.z,
                ixy * e.x + iyy * e.y + iyz * e.z,
                ixz * e.x + iyz * e.y + izz * e.z,
                1.0,
            );
        }
        shared_omega = omega;
    }
    let omega = workgroupUniformLoad(&shared_omega);
    let p = gid.x;
    if (p < params.particle_count && omega.w != 0.0) {
        let dv = work[wi(W_DV, p)].xyz - cross3(omega.xyz, x[p].xyz - centre);
        work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
    }
}
