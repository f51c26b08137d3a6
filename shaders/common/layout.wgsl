// What every wgcloth kernel shares: the structs (Pod twins in
// src/gpu/layout.rs), bindings 1–10 of the one bind group, the scene
// features, and the accessors that place a cloth in the buffers. Binding
// 0, the parameters `params`, is declared by the file that includes this
// one: common/bindings.wgsl (a uniform block: the multi-dispatch kernels)
// or common/cloth_bindings.wgsl (a workgroup's copy of its cloth's entry
// in a table: the workgroup kernels).

// The shared numbers (workgroup sizes, buffer sections, partial slots,
// status words), generated from src/kernel_config.rs where each is
// documented: W_* (`work` sections), S_* (`spring_work` sections), P_* and
// C_* (`partials` slots and CG scalars), STATUS_* (`status` words),
// FILTER_* (filter kinds), INTEGRATOR_* (params.integrator), MAX_SPHERES,
// MAX_CAPSULES, and the overrides WORKGROUP and SUM_GROUP (set per
// pipeline by src/gpu/kernels.rs).
#include "generated/config.wgsl"

// Scene features; a pipeline variant with a feature off has its code
// removed by the compiler (constant-folded branch).
override HAS_WIND: bool = true;
override HAS_GROUND: bool = true;
// Some sphere or capsule collider.
override HAS_SPHERES: bool = true;
// Some particle can be constrained in CG (pins or colliders).
override HAS_FILTER: bool = true;
// Some spring has damping.
override HAS_DAMPING: bool = true;
// The springs are in grid layout (src/gpu/grid.rs) and the kernels find
// them by row and column instead of through the adjacency lists.
override GRID: bool = false;
// The CG matrix is the semi-implicit constant one: every spring block is
// a I with a = dt² k of its kind (params.kind_a), so the grid kernels need
// not load it.
override CONSTANT_BLOCKS: bool = false;
// The implicit CG adds the coarse levels (common/coarse.wgsl) to its
// preconditioner.
override COARSE: bool = false;

// Twin: layout::GpuSphere.
struct Sphere {
    // Centre when set [m]; it moves at `velocity` [m/s] from there.
    center: vec3<f32>,
    radius: f32,
    velocity: vec3<f32>,
    friction: f32,
}

// Twin: layout::GpuCapsule. The segment a–b when set [m], moving at
// `velocity` [m/s].
struct Capsule {
    a: vec3<f32>,
    radius: f32,
    b: vec3<f32>,
    friction: f32,
    velocity: vec3<f32>,
    _pad0: f32,
}

// Twin: layout::GpuParams.
struct Params {
    gravity: vec3<f32>,
    dt: f32,
    wind_velocity: vec3<f32>,
    wind_drag: f32,
    wind_lift: f32,
    ground_height: f32,
    ground_friction: f32,
    fixup_omega: f32,
    particle_count: u32,
    spring_count: u32,
    triangle_count: u32,
    sphere_count: u32,
    // Offsets into `topo` (u32 words).
    spring_adj_entries: u32,
    tri_adj_offsets: u32,
    tri_adj_entries: u32,
    triangles: u32,
    cg_tolerance_sq: f32,
    // Number of workgroups of a per-particle dispatch (= reduction partials).
    partial_count: u32,
    // Free particles in the dense filter.
    filter_count: u32,
    torque_compensation: u32,
    // The cloth's place in the shared buffers, as element indices into
    // each (all zero for a lone cloth; a batch gives each cloth its own):
    // its first particle (x, v, vertex_normals), spring, spring adjacency
    // offset in `topo`, `work` and `spring_work` entry, reduction partial,
    // status word and dense filter word.
    particle_base: u32,
    spring_base: u32,
    topo_base: u32,
    work_base: u32,
    spring_work_base: u32,
    partial_base: u32,
    status_base: u32,
    dense_base: u32,
    // The cloth's integrator (INTEGRATOR_*): a batch runs each workgroup
    // kernel over every cloth, and each steps only its own.
    integrator: u32,
    // Fix-up passes per step (0: no constrained spring kind).
    fixup_iterations: u32,
    // Most CG iterations per step (the workgroup kernels' loop; the
    // multi-dispatch path records its budget instead).
    cg_max_iterations: u32,
    _pad0: u32,
    // Grid layout (src/gpu/grid.rs): columns, rows, a bit per spring kind
    // present; rest length per direction; stiffness and damping per kind.
    grid: vec4<u32>,
    grid_rest_a: vec4<f32>,
    grid_rest_b: vec4<f32>,
    // Fix-up length limit per grid direction (0: none).
    grid_max_a: vec4<f32>,
    grid_max_b: vec4<f32>,
    kind_k: vec4<f32>,
    kind_kd: vec4<f32>,
    // Semi-implicit CG: the constant block a = dt² k of each spring kind.
    kind_a: vec4<f32>,
    // The implicit CG's coarse levels (common/coarse.wgsl): columns, rows,
    // level-1 aggregates, level-2 aggregates.
    coarse: vec4<u32>,
    // Moving colliders: capsules in use, the step counts at which the
    // spheres and the capsules were set, unused.
    motion: vec4<u32>,
    spheres: array<Sphere, MAX_SPHERES>,
    capsules: array<Capsule, MAX_CAPSULES>,
}

// Twin: layout::GpuSpring.
struct Spring {
    i: u32,
    j: u32,
    rest: f32,
    k: f32,
    kd: f32,
    // Largest allowed length [m]; 0 = not constrained.
    max_len: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(1) var<storage, read> springs: array<Spring>;
// Spring adjacency offsets (N + 1) at params.topo_base, then its entries
// (spring << 1 | end), then each entry's other particle; triangle adjacency
// offsets and entries; triangles (see spring_adj, tri_adj).
@group(0) @binding(2) var<storage, read> topo: array<u32>;
// Positions [m]; w = inverse mass (0 = pinned). Also the vertex buffer.
@group(0) @binding(3) var<storage, read_write> x: array<vec4<f32>>;
// Velocities [m/s]; w = mass [kg].
@group(0) @binding(4) var<storage, read_write> v: array<vec4<f32>>;
// Per-particle scratch (see wi).
@group(0) @binding(5) var<storage, read_write> work: array<vec4<f32>>;
// Per-spring scratch (see si).
@group(0) @binding(6) var<storage, read_write> spring_work: array<vec4<f32>>;
// Reduction partials (see pi; a block is 64 particles: one workgroup of
// a per-particle dispatch).
@group(0) @binding(7) var<storage, read_write> partials: array<f32>;
// Status words (see STATUS_*, sw).
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
// Vertex normals; w unused.
@group(0) @binding(9) var<storage, read_write> vertex_normals: array<vec4<f32>>;
// Dense semi-implicit filter, row-major over filter positions, then the
// filter order (particle of each position, as f32 bits), from
// params.dense_base.
@group(0) @binding(10) var<storage, read> dense: array<f32>;

// A length below which a spring or triangle has no direction. Twin:
// Real::TINY for f32.
const TINY: f32 = 1e-9;

// Particle p's index within its cloth (particles are global indices in
// x, v, vertex_normals and the springs' ends).
fn local(p: u32) -> u32 {
    return p - params.particle_base;
}

// Particle p's entry of `work` section `section`.
fn wi(section: u32, p: u32) -> u32 {
    return params.work_base + section * params.particle_count + local(p);
}

// Spring s's entry of `spring_work` section `section`.
fn si(section: u32, s: u32) -> u32 {
    return params.spring_work_base + section * params.spring_count + (s - params.spring_base);
}

// Reduction block `block`'s partial of slot `slot` (blocks of WORKGROUP
// particles, counted from the cloth's first).
fn pi(slot: u32, block: u32) -> u32 {
    return params.partial_base + slot * params.partial_count + block;
}

// The cloth's status word `word` (STATUS_*).
fn sw(word: u32) -> u32 {
    return params.status_base + word;
}

// Where particle p's spring adjacency entries start, relative to
// params.spring_adj_entries (its row ends where particle p + 1's starts).
fn spring_adj(p: u32) -> u32 {
    return topo[params.topo_base + local(p)];
}

// Where particle p's triangle adjacency entries start, relative to
// params.tri_adj_entries.
fn tri_adj(p: u32) -> u32 {
    return topo[params.tri_adj_offsets + local(p)];
}

// Where the other-particle column of the spring adjacency starts.
fn spring_adj_others() -> u32 {
    return params.spring_adj_entries + topo[params.topo_base + params.particle_count];
}
