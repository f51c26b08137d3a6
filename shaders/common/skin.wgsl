// One render vertex skinned on the cloth (src/render_mesh.rs gives the
// formulas; twin: cpu::skin::skin_vertex): its place on a cloth triangle,
// offset along the interpolated vertex normal, and its own normal turned
// with the frame of that place. Reads the cloth's positions `x` and the
// normals pass's `vertex_normals`.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// A render vertex's place (twin: render_mesh::Embedded, whose `uv` is u
// and v here: a vec2 would be aligned to 8 bytes).
struct Embedded {
    triangle: u32,
    u: f32,
    v: f32,
    offset: f32,
    normal: vec3<f32>,
    pad: u32,
}

struct Skinned {
    position: vec3<f32>,
    normal: vec3<f32>,
}

// n / |n|, or `fallback` where |n| is at most TINY (twin:
// cpu::skin::normalize_or).
fn normalize_or(n: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l = len3(n);
    if (l > TINY) {
        return n / l;
    }
    return fallback;
}

fn skin_vertex(e: Embedded) -> Skinned {
    let corner = params.triangles + 3u * e.triangle;
    let a = topo(corner);
    let b = topo(corner + 1u);
    let c = topo(corner + 2u);
    let u = e.u;
    let v = e.v;
    let w = 1.0 - u - v;
    let base = x[a].xyz * w + x[b].xyz * u + x[c].xyz * v;
    let n = normalize_or(
        vertex_normals[a].xyz * w + vertex_normals[b].xyz * u + vertex_normals[c].xyz * v,
        vec3<f32>(0.0, 1.0, 0.0),
    );
    let position = base + n * e.offset;
    let edge = x[b].xyz - x[a].xyz;
    let t = normalize_or(edge - n * dot3(n, edge), vec3<f32>(1.0, 0.0, 0.0));
    let bt = cross3(n, t);
    let normal = normalize_or(t * e.normal.x + bt * e.normal.y + n * e.normal.z, n);
    return Skinned(position, normal);
}
