// What every wgcloth kernel shares: the structs (Pod twins in
// src/gpu/layout.rs), bindings 1–6 of group 0, the scene
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
#include "common/vector.wgsl"

// Scene features; a pipeline variant with a feature off has its code
// removed by the compiler (constant-folded branch).
override HAS_WIND: bool = true;
override HAS_GROUND: bool = true;
// Some sphere or capsule collider.
override HAS_SPHERES: bool = true;
// Some mesh collider (a cloth with one has HAS_SPHERES too).
override HAS_MESH_COLLIDERS: bool = true;
// Some particle can be constrained in CG (pins or colliders).
override HAS_FILTER: bool = true;
// Some spring has damping.
override HAS_DAMPING: bool = true;
// The linear bending model (common/bending.wgsl).
override HAS_BENDING: bool = true;
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

// Whether a feature's code runs for this cloth: compiled in and present in
// its scene (params.features, FEATURE_* bits). A specialised pipeline folds
// an absent feature away; the workgroup kernels, compiled with every
// feature, skip it by a uniform branch.
fn has_wind() -> bool {
    return HAS_WIND && (params.features & FEATURE_WIND) != 0u;
}
fn has_ground() -> bool {
    return HAS_GROUND && (params.features & FEATURE_GROUND) != 0u;
}
fn has_spheres() -> bool {
    return HAS_SPHERES && (params.features & FEATURE_SPHERES) != 0u;
}
fn has_mesh_colliders() -> bool {
    return HAS_MESH_COLLIDERS && (params.features & FEATURE_MESH_COLLIDERS) != 0u;
}
fn has_filter() -> bool {
    return HAS_FILTER && (params.features & FEATURE_FILTER) != 0u;
}
fn has_damping() -> bool {
    return HAS_DAMPING && (params.features & FEATURE_DAMPING) != 0u;
}
fn has_bending() -> bool {
    return HAS_BENDING && (params.features & FEATURE_BENDING) != 0u;
}
// Self-collision has no HAS_ constant: only the workgroup kernels ask
// (the multi-dispatch path records its kernels or not), so a kernel's code
// is the same with it or without, and a driver's shader cache serves both.
fn has_self_collision() -> bool {
    return (params.features & FEATURE_SELF_COLLISION) != 0u;
}

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

// Twin: layout::GpuMeshCollider. A mesh collider's pose: the world-to-body
// rotation (a unit quaternion x, y, z, w), its origin when set [m], moving
// at `velocity` [m/s] and spinning at `angular_velocity` [rad/s] about it;
// `grid`: the vec4 index in `model` of its distance grid (mesh_contact).
struct MeshCollider {
    rotation: vec4<f32>,
    position: vec3<f32>,
    friction: f32,
    velocity: vec3<f32>,
    thickness: f32,
    angular_velocity: vec3<f32>,
    grid: u32,
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
    // Word offsets into `model` (see topo).
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
    // The cloth's place in the shared buffers (a batch gives each cloth
    // its own): its first particle (x, v, vertex_normals); in `model`, its
    // first spring record (a vec4 index), its spring adjacency offsets and
    // dense filter (word indices, as topo_base's neighbours above); in
    // `work`, its per-particle sections, per-spring sections and first
    // partial (vec4 indices); its first status word. Springs are numbered
    // within their cloth.
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
    // The cloth's scene features (FEATURE_* bits; see has_wind()).
    features: u32,
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
    // The implicit CG's coarse levels (common/coarse_layout.wgsl): the
    // first cloth's columns and rows, level-1 aggregates, level-2
    // aggregates; the pieces (grid cloths), three unused; two vec4 a
    // piece (coarse_piece).
    coarse: vec4<u32>,
    coarse_world: vec4<u32>,
    coarse_pieces: array<vec4<u32>, COARSE_PIECE_WORDS>,
    // Moving colliders: capsules in use, the step counts at which the
    // spheres and the capsules were set, unused.
    motion: vec4<u32>,
    // Self-collision (common/self_collision.wgsl): thickness [m], Coulomb
    // friction, the cap on a step's displacement [m], the grid's inverse
    // cell size [1/m]; then its passes per step, its buckets (a power of
    // two), the cap's reference particle (within the cloth), and the vec4
    // index in `model` of its rest positions (in exclusion radii).
    self_collision: vec4<f32>,
    self_grid: vec4<u32>,
    spheres: array<Sphere, MAX_SPHERES>,
    capsules: array<Capsule, MAX_CAPSULES>,
    // Mesh colliders in use, the step count at which they were set, unused.
    mesh: vec4<u32>,
    meshes: array<MeshCollider, MAX_MESH_COLLIDERS>,
    // The linear bending model (common/bending.wgsl): its Rayleigh damping
    // β [s], the scale dt² + dt β [s²] of its operator in the CG matrices,
    // two unused; the word indices in `model` of its row offsets, columns
    // and coefficients, unused.
    bending: vec4<f32>,
    bending_rows: vec4<u32>,
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

// Group 0 binds seven buffers (six of them storage, plus `params`), so
// that with cg_init's two dispatch-argument buffers in group 1 no kernel
// binds more than the eight storage buffers per stage every WebGPU device
// grants (see docs/design.md, "Bindings"). Read-only model data shares one
// buffer, the scratch another.

// The cloth's model, read only, as u32 words (f32 as their bits): its
// spring records (two vec4 words each, see `spring`) from vec4
// params.spring_base; the spring adjacency offsets (N + 1) at word
// params.topo_base, then its entries (spring << 1 | end), then each
// entry's other particle; triangle adjacency offsets and entries;
// triangles (see spring_adj, tri_adj, topo); the linear bending
// operator's rows (see bending_row); the dense semi-implicit filter from
// word params.dense_base (see dense).
@group(0) @binding(1) var<storage, read> model: array<vec4<u32>>;
// Positions [m]; w = inverse mass (0 = pinned). Also the vertex buffer.
@group(0) @binding(2) var<storage, read_write> x: array<vec4<f32>>;
// Velocities [m/s]; w = mass [kg].
@group(0) @binding(3) var<storage, read_write> v: array<vec4<f32>>;
// Scratch: the per-particle sections from params.work_base (see wi), the
// per-spring sections from params.spring_work_base (see si), and the
// reduction partials and CG scalars from params.partial_base, one per
// vec4 in x (see pi, partial; a block is 64 particles: one workgroup of a
// per-particle dispatch).
@group(0) @binding(4) var<storage, read_write> work: array<vec4<f32>>;
// Status words (see STATUS_*, sw).
@group(0) @binding(5) var<storage, read_write> status: array<atomic<u32>>;
// Vertex normals; w unused.
@group(0) @binding(6) var<storage, read_write> vertex_normals: array<vec4<f32>>;

// Word `i` of `model`.
fn topo(i: u32) -> u32 {
    return model[i >> 2u][i & 3u];
}

// Word `i` of `model` as the f32 it holds (the dense filter).
fn dense(i: u32) -> f32 {
    return bitcast<f32>(topo(i));
}

// Spring s of the cloth (counted within it): two vec4 loads.
fn spring(s: u32) -> Spring {
    let at = params.spring_base + 2u * s;
    let a = model[at];
    let b = model[at + 1u];
    return Spring(
        a.x,
        a.y,
        bitcast<f32>(a.z),
        bitcast<f32>(a.w),
        bitcast<f32>(b.x),
        bitcast<f32>(b.y),
        b.z,
        b.w,
    );
}

// Particle p's index within its cloth (particles are global indices in
// x, v, vertex_normals and the springs' ends).
fn local(p: u32) -> u32 {
    return p - params.particle_base;
}

// Particle p's entry of `work` section `section`.
fn wi(section: u32, p: u32) -> u32 {
    return params.work_base + section * params.particle_count + local(p);
}

// Spring s's entry (in `work`) of the per-spring section `section`.
fn si(section: u32, s: u32) -> u32 {
    return params.spring_work_base + section * params.spring_count + s;
}

// Reduction block `block`'s partial of slot `slot` (blocks of WORKGROUP
// particles, counted from the cloth's first): an entry of `work`, read
// by `partial`, written by `set_partial`.
fn pi(slot: u32, block: u32) -> u32 {
    return params.partial_base + slot * params.partial_count + block;
}

// The partial or CG scalar at `work` entry `i` (see pi). One per vec4, so
// that two workgroups writing neighbouring partials never write one vec4.
fn partial(i: u32) -> f32 {
    return work[i].x;
}

fn set_partial(i: u32, value: f32) {
    work[i] = vec4<f32>(value, 0.0, 0.0, 0.0);
}

// The cloth's status word `word` (STATUS_*).
fn sw(word: u32) -> u32 {
    return params.status_base + word;
}

// Where particle p's spring adjacency entries start, relative to
// params.spring_adj_entries (its row ends where particle p + 1's starts).
fn spring_adj(p: u32) -> u32 {
    return topo(params.topo_base + local(p));
}

// Where particle p's triangle adjacency entries start, relative to
// params.tri_adj_entries.
fn tri_adj(p: u32) -> u32 {
    return topo(params.tri_adj_offsets + local(p));
}

// Where the other-particle column of the spring adjacency starts.
fn spring_adj_others() -> u32 {
    return params.spring_adj_entries + topo(params.topo_base + params.particle_count);
}

// Where a kernel reads the particles' state: the x and v buffers, or the
// pair of `work` sections that single-pass explicit steps alternate with
// them (explicit_integrate with SNAP_IN).
const STATE_BUFFERS: u32 = 0xffffffffu;

fn state_x(i: u32, sec: u32) -> vec3<f32> {
    if (sec == STATE_BUFFERS) {
        return x[i].xyz;
    }
    return work[wi(sec, i)].xyz;
}

fn state_v(i: u32, sec: u32) -> vec3<f32> {
    if (sec == STATE_BUFFERS) {
        return v[i].xyz;
    }
    return work[wi(sec + 1u, i)].xyz;
}

// `a` itself, through an xor with the uniform's opaque zero
// (`params.kind_k[3]`, as `unseen4` in common/cg.wgsl): a product passed
// through here is rounded before the sum it feeds, as the CPU rounds it,
// instead of being fused into a multiply-add.
fn unseen3(a: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a) ^ vec3<u32>(bitcast<u32>(params.kind_k[3])));
}

// `a` itself, as unseen3: a term that is a product, added to a running
// sum where it is computed, is rounded before the addition instead of
// being fused into a multiply-add.
fn unseen1(a: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(a) ^ bitcast<u32>(params.kind_k[3]));
}
