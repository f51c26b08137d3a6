// Shared declarations of every wgcloth kernel: the one bind group all
// pipelines use, its Pod twins (src/gpu/layout.rs), and the section layout
// of the scratch buffers. Included by each kernel file through
// `#include "common/bindings.wgsl"` (src/gpu/shaders.rs).

// Workgroup size of every per-particle and per-spring kernel.
override WORKGROUP: u32 = 64u;
// Workgroup size of the one-workgroup CG scalar kernels (cg_start,
// cg_alpha, cg_beta): 256, or what the device allows (src/gpu/pipelines.rs,
// sum_group).
override SUM_GROUP: u32 = 256u;
// Scene features; a pipeline variant with a feature off has its code
// removed by the compiler (constant-folded branch).
override HAS_WIND: bool = true;
override HAS_GROUND: bool = true;
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

const MAX_SPHERES: u32 = 16u;

// Twin: layout::GpuSphere.
struct Sphere {
    center: vec3<f32>,
    radius: f32,
    friction: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
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
    spheres: array<Sphere, 16>,
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

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> springs: array<Spring>;
// Spring adjacency offsets (N + 1) at 0, then its entries
// (spring << 1 | end), then each entry's other particle; triangle adjacency
// offsets and entries; triangles.
@group(0) @binding(2) var<storage, read> topo: array<u32>;
// Positions [m]; w = inverse mass (0 = pinned). Also the vertex buffer.
@group(0) @binding(3) var<storage, read_write> x: array<vec4<f32>>;
// Velocities [m/s]; w = mass [kg].
@group(0) @binding(4) var<storage, read_write> v: array<vec4<f32>>;
// Per-particle scratch, `SECTION * particle_count + p`.
@group(0) @binding(5) var<storage, read_write> work: array<vec4<f32>>;
// Per-spring scratch, `SECTION * spring_count + s`.
@group(0) @binding(6) var<storage, read_write> spring_work: array<vec4<f32>>;
// Reduction partials, `SLOT * partial_count + block` (a block is 64
// particles: one workgroup of a per-particle dispatch).
@group(0) @binding(7) var<storage, read_write> partials: array<f32>;
// Status words (see STATUS_*).
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
// Vertex normals; w unused.
@group(0) @binding(9) var<storage, read_write> vertex_normals: array<vec4<f32>>;
// Dense semi-implicit filter, row-major over filter positions, then the
// filter order (particle of each position, as f32 bits).
@group(0) @binding(10) var<storage, read> dense: array<f32>;

// `work` sections. Twin: layout::section.
const W_X_PRED: u32 = 0u;
const W_X_ALT: u32 = 1u;
const W_V_NEW: u32 = 2u;
const W_DV: u32 = 3u;
const W_R: u32 = 4u;
const W_C: u32 = 5u;
const W_Q: u32 = 6u;
const W_S: u32 = 7u;
const W_RHS: u32 = 8u;
const W_Z: u32 = 9u;
const W_FILTER: u32 = 10u;
const W_PRE_DIAG: u32 = 11u;
const W_PRE_OFF: u32 = 12u;
// Δv of the step before the last (CG warm start: 2 Δv − Δv_prev).
const W_DV_PREV: u32 = 13u;
// The w of the CG vectors: W_DV's and W_S's hold the particle's filter
// kind (W_DV's from the CG set-up, implicit_prepare or semi_cg_prepare,
// to the step's end; W_S's from cg_init and cg_update), for the kernels
// that load them anyway; W_R's, W_Q's and W_RHS's the particle's terms of
// ρ, cᵀq and δ0, summed by the one-workgroup kernels (see sum_w).

// The start-of-step positions of an implicit step on a grid with
// colliders, from which implicit_finish computes the spring blocks of its
// contact particles while x is being overwritten (the section of the
// explicit integrator's predicted positions, unused by the implicit one).
const W_X_START: u32 = W_X_PRED;
// The coarse levels (common/coarse.wgsl), indexed by aggregate: D⁻¹'s
// diagonal and off-diagonal, and the correction z = D⁻¹ Πᵀr (w: the
// coarse terms of δ, level-2 aggregates only).
const W_COARSE_INV_D: u32 = 14u;
const W_COARSE_INV_O: u32 = 15u;
const W_COARSE_Z: u32 = 16u;
// Each particle's contribution to its aggregates' D at levels 1 and 2
// (diagonal, off-diagonal; W_LEVEL1_O's w: the trace of the particle's
// block-Jacobi block), from implicit_prepare to coarse_setup: in CG
// sections that cg_init writes afterwards.
const W_LEVEL1_D: u32 = W_R;
const W_LEVEL1_O: u32 = W_C;
const W_LEVEL2_D: u32 = W_Q;
const W_LEVEL2_O: u32 = W_S;

// `spring_work` sections: the implicit block (m, a) with B = a I + m mᵀ;
// K_s u; the spring force on end i.
const S_BLOCK: u32 = 0u;
const S_KV: u32 = 1u;
const S_FORCE: u32 = 2u;

// `partials` slots (one value per block each), then the CG scalars.
const P_CQ: u32 = 0u;
const P_RS: u32 = 1u;
const P_D0: u32 = 2u;
const P_TORQUE: u32 = 3u; // 16 slots: torque-compensation sums
const P_SLOTS: u32 = 19u;

// `status` words. Twin: layout::status.
const STATUS_STEP: u32 = 0u;
const STATUS_BAD_STEP: u32 = 1u;
const STATUS_BAD_PARTICLE: u32 = 2u;
const STATUS_FIXUP_MOVED: u32 = 3u;
const STATUS_CG_ITERATIONS: u32 = 4u;
const STATUS_CG_STOPPED: u32 = 5u;
const STATUS_CG_MAX_ITERATIONS: u32 = 6u;
// Fix-up: stopped this step; the section holding its result; passes run;
// three rotating "this pass moved something" flags.
const STATUS_FIXUP_STOPPED: u32 = 7u;
const STATUS_FIXUP_RESULT: u32 = 8u;
const STATUS_FIXUP_PASSES: u32 = 9u;
const STATUS_FIXUP_FLAG: u32 = 10u;
// CG: the slots of cg_alpha and cg_beta last enabled (common/cg.wgsl).
const STATUS_ALPHA_SLOT: u32 = 13u;
const STATUS_BETA_SLOT: u32 = 14u;

// Filter kinds (w of W_Z).
const FILTER_FREE: f32 = 0.0;
const FILTER_FIXED: f32 = 1.0;
const FILTER_PLANE: f32 = 2.0;

// A length below which a spring or triangle has no direction. Twin:
// Real::TINY for f32.
const TINY: f32 = 1e-9;

fn wi(section: u32, p: u32) -> u32 {
    return section * params.particle_count + p;
}

fn si(section: u32, s: u32) -> u32 {
    return section * params.spring_count + s;
}

// Where the other-particle column of the spring adjacency starts.
fn spring_adj_others() -> u32 {
    return params.spring_adj_entries + topo[params.particle_count];
}
