// Shared by the torque-compensation kernels and the semi-implicit
// workgroup kernel (twin: cpu::torque): each particle's terms of the sums,
// the centre of mass from the partial sums, and the rotation ω to remove.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

var<workgroup> shared_vec: vec4<f32>;
var<workgroup> shared_omega: vec4<f32>;

const T_MASS: u32 = 0u;      // Σ m
const T_MX: u32 = 1u;        // Σ m x (3 slots)
const T_EXCESS: u32 = 4u;    // Σ r × (m Δv − dt f_ext) (3 slots)
const T_INERTIA: u32 = 7u;   // Σ m (|r|² I − r rᵀ) (6 slots)
// The sums of torque_centre (T_MASS, T_MX) and of torque_moments
// (T_EXCESS, T_INERTIA).
const T_CENTRE_SUMS: u32 = 4u;
const T_MOMENT_SUMS: u32 = 9u;

// Bit of params.torque_compensation: the global passes (twin:
// gpu::layout::TORQUE_GLOBAL).
const TORQUE_GLOBAL: u32 = 2u;

fn torque_slot(k: u32) -> u32 {
    return P_TORQUE + k;
}

// Particle p's terms of torque_centre's sums: m, m x.
fn centre_terms(p: u32) -> array<f32, T_CENTRE_SUMS> {
    let m = v[p].w;
    let mx = x[p].xyz * m;
    return array<f32, T_CENTRE_SUMS>(m, mx.x, mx.y, mx.z);
}

// Particle p's terms of torque_moments' sums about `centre`: the angular
// impulse not explained by external forces, r × (m Δv − dt f_ext), then
// the inertia tensor's m (|r|² I − r rᵀ) (xx, yy, zz, xy, xz, yz).
fn moment_terms(p: u32, centre: vec3<f32>) -> array<f32, T_MOMENT_SUMS> {
    let m = v[p].w;
    let r = x[p].xyz - centre;
    let moment = cross3(r, work[wi(W_DV, p)].xyz * m - external_force(p) * params.dt);
    // Twin: Sym3::add_iso_aniso(m |r|², −m, r) on a zero matrix.
    let a = m * dot3(r, r);
    let b = -m;
    return array<f32, T_MOMENT_SUMS>(
        moment.x,
        moment.y,
        moment.z,
        a + b * r.x * r.x,
        a + b * r.y * r.y,
        a + b * r.z * r.z,
        b * r.x * r.y,
        b * r.x * r.z,
        b * r.y * r.z,
    );
}

// The centre of mass, computed by invocation 0 and shared.
fn centre_of_mass(lid: u32) -> vec3<f32> {
    if (lid == 0u) {
        let total = sum_partials(torque_slot(T_MASS));
        let c = vec3<f32>(
            sum_partials(torque_slot(T_MX)),
            sum_partials(torque_slot(T_MX + 1u)),
            sum_partials(torque_slot(T_MX + 2u)),
        ) / total;
        shared_vec = vec4<f32>(c, 0.0);
    }
    return workgroupUniformLoad(&shared_vec).xyz;
}

// ω = I⁻¹ ΔL from the partial sums (w: 1), or zero (w: 0) where the
// inertia tensor is singular (twin: inverse() is None), which leaves Δv
// as it is; computed by invocation 0 and shared.
fn torque_omega(lid: u32) -> vec4<f32> {
    if (lid == 0u) {
        let e = vec3<f32>(
            sum_partials(torque_slot(T_EXCESS)),
            sum_partials(torque_slot(T_EXCESS + 1u)),
            sum_partials(torque_slot(T_EXCESS + 2u)),
        );
        let inertia = Sym3(
            vec3<f32>(
                sum_partials(torque_slot(T_INERTIA)),
                sum_partials(torque_slot(T_INERTIA + 1u)),
                sum_partials(torque_slot(T_INERTIA + 2u)),
            ),
            vec3<f32>(
                sum_partials(torque_slot(T_INERTIA + 3u)),
                sum_partials(torque_slot(T_INERTIA + 4u)),
                sum_partials(torque_slot(T_INERTIA + 5u)),
            ),
        );
        var omega = vec4<f32>(0.0);
        let inv = sym3_inverse(inertia);
        if (inv.ok) {
            omega = vec4<f32>(sym3_mul(inv.m, e), 1.0);
        }
        shared_omega = omega;
    }
    return workgroupUniformLoad(&shared_omega);
}

// Particle p's Δv less the rotation `omega` about `centre`.
fn remove_rotation(p: u32, omega: vec3<f32>, centre: vec3<f32>) {
    let dv = work[wi(W_DV, p)].xyz - cross3(omega, x[p].xyz - centre);
    work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
}
