// Vertex normals for rendering: the normalised sum of the incident
// triangles' area-weighted normals. Twin: cpu::skin::normals.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

@compute @workgroup_size(WORKGROUP)
fn normals(@builtin(global_invocation_id) gid: vec3<u32>) {
    // A batch runs this pass per cloth, with the cloth's bases.
    if (gid.x >= params.particle_count) {
        return;
    }
    let p = params.particle_base + gid.x;
    var n = vec3<f32>(0.0);
    let tb = tri_adj(p);
    let te = tri_adj(p + 1u);
    for (var k = tb; k < te; k++) {
        let base = params.triangles + 3u * topo(params.tri_adj_entries + k);
        let a = x[topo(base)].xyz;
        let b = x[topo(base + 1u)].xyz;
        let c = x[topo(base + 2u)].xyz;
        n += cross3(b - a, c - a);
    }
    vertex_normals[p] = vec4<f32>(normalize_or(n, vec3<f32>(0.0, 1.0, 0.0)), 0.0);
}
