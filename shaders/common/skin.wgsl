// One render vertex skinned on the cloth (src/render_mesh.rs gives the
// formulas; twin: cpu::skin::skin_vertex): its place on a cloth triangle,
// offset along the interpolated vertex normal, and its own normal turned
// with the frame of that place. The cloth is read as it is drawn — its
// position, normal and index buffers and where the cloth lies in them —
// so a lone solver's cloth and a batch's are skinned alike.

#include "generated/config.wgsl"
#include "common/vector.wgsl"

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

struct SkinParams {
    // Render vertices.
    count: u32,
    // f32 words from one vertex to the next.
    stride: u32,
    // The word of the position's x in a vertex.
    position: u32,
    // The word of the normal's x (NO_NORMAL: none written).
    normal: u32,
    // The cloth's first index in `cloth_indices`, and the vertex its
    // indices count from in `cloth_x` and `cloth_normals`.
    first_index: u32,
    base_vertex: i32,
    // The first render vertex's word in `skinned` (which is bound from a
    // storage-offset boundary below it in a host's buffer).
    base: u32,
}

const NO_NORMAL: u32 = 0xffffffffu;

@group(0) @binding(0) var<storage, read> embedded: array<Embedded>;
@group(0) @binding(1) var<storage, read_write> skinned: array<f32>;
@group(0) @binding(2) var<uniform> skin_params: SkinParams;
@group(0) @binding(3) var<storage, read> cloth_x: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> cloth_normals: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> cloth_indices: array<u32>;

struct Skinned {
    position: vec3<f32>,
    normal: vec3<f32>,
}

// Corner k of the cloth's triangle t, as a vertex of the cloth's buffers.
fn cloth_corner(t: u32, k: u32) -> u32 {
    let i = cloth_indices[skin_params.first_index + 3u * t + k];
    return u32(i32(i) + skin_params.base_vertex);
}

fn skin_vertex(e: Embedded) -> Skinned {
    let a = cloth_corner(e.triangle, 0u);
    let b = cloth_corner(e.triangle, 1u);
    let c = cloth_corner(e.triangle, 2u);
    let u = e.u;
    let v = e.v;
    let w = 1.0 - u - v;
    let base = cloth_x[a].xyz * w + cloth_x[b].xyz * u + cloth_x[c].xyz * v;
    let n = normalize_or(
        cloth_normals[a].xyz * w + cloth_normals[b].xyz * u + cloth_normals[c].xyz * v,
        vec3<f32>(0.0, 1.0, 0.0),
    );
    let position = base + n * e.offset;
    let edge = cloth_x[b].xyz - cloth_x[a].xyz;
    let t = normalize_or(edge - n * dot3(n, edge), vec3<f32>(1.0, 0.0, 0.0));
    let bt = cross3(n, t);
    let normal = normalize_or(t * e.normal.x + bt * e.normal.y + n * e.normal.z, n);
    return Skinned(position, normal);
}
