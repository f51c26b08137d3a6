//! Pod twins of the WGSL structs in `shaders/common/bindings.wgsl`, and the
//! section layout of the scratch buffers. Each struct's size is asserted at
//! compile time; a test compares every field offset with what naga computes
//! for the WGSL twin.

use bytemuck::{Pod, Zeroable};

pub use crate::kernel_config::{
    status, work as section, MAX_CAPSULES, MAX_MESH_COLLIDERS, MAX_SPHERES,
};

/// Twin of WGSL `Sphere`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSphere {
    /// Centre \[m\] when set.
    pub center: [f32; 3],
    /// Radius \[m\].
    pub radius: f32,
    /// Velocity [m/s].
    pub velocity: [f32; 3],
    /// Friction coefficient.
    pub friction: f32,
}
const _: () = assert!(std::mem::size_of::<GpuSphere>() == 32);

/// Twin of WGSL `Capsule`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuCapsule {
    /// One end of the segment \[m\] when set.
    pub a: [f32; 3],
    /// Radius \[m\].
    pub radius: f32,
    /// The other end \[m\] when set.
    pub b: [f32; 3],
    /// Friction coefficient.
    pub friction: f32,
    /// Velocity [m/s].
    pub velocity: [f32; 3],
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: f32,
}
const _: () = assert!(std::mem::size_of::<GpuCapsule>() == 48);

/// Twin of WGSL `MeshCollider`: a mesh collider's pose as the kernels
/// take it; its grid is in `model` (see `ClothArrays::grids`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMeshCollider {
    /// World-to-body rotation, a unit quaternion `(x, y, z, w)`.
    pub rotation: [f32; 4],
    /// The body's origin \[m\] when set.
    pub position: [f32; 3],
    /// Friction coefficient.
    pub friction: f32,
    /// Velocity [m/s].
    pub velocity: [f32; 3],
    /// The distance the cloth keeps \[m\].
    pub thickness: f32,
    /// Angular velocity [rad/s] about the origin.
    pub angular_velocity: [f32; 3],
    /// The `vec4` index in `model` of its grid's header.
    pub grid: u32,
}
const _: () = assert!(std::mem::size_of::<GpuMeshCollider>() == 64);

/// Twin of WGSL `Params` (the uniform block of the multi-dispatch
/// kernels; an element of the cloth table of the workgroup kernels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuParams {
    /// Gravity [m/s²].
    pub gravity: [f32; 3],
    /// Time step \[s\].
    pub dt: f32,
    /// Wind velocity [m/s].
    pub wind_velocity: [f32; 3],
    /// Wind drag [kg/m³].
    pub wind_drag: f32,
    /// Wind lift [kg/m³].
    pub wind_lift: f32,
    /// Ground height \[m\].
    pub ground_height: f32,
    /// Ground friction.
    pub ground_friction: f32,
    /// Jacobi over-relaxation.
    pub fixup_omega: f32,
    /// Particles.
    pub particle_count: u32,
    /// Springs.
    pub spring_count: u32,
    /// Triangles.
    pub triangle_count: u32,
    /// Spheres in use.
    pub sphere_count: u32,
    /// Word offset of the spring adjacency entries in `topo`.
    pub spring_adj_entries: u32,
    /// Word offset of the triangle adjacency offsets in `topo`.
    pub tri_adj_offsets: u32,
    /// Word offset of the triangle adjacency entries in `topo`.
    pub tri_adj_entries: u32,
    /// Word offset of the triangles in `topo`.
    pub triangles: u32,
    /// Square of the CG relative tolerance.
    pub cg_tolerance_sq: f32,
    /// Workgroups of a per-particle dispatch (reduction partials).
    pub partial_count: u32,
    /// Free particles in the dense filter.
    pub filter_count: u32,
    /// Which parts of the semi-implicit torque compensation apply:
    /// [`TORQUE_LOCAL`] and [`TORQUE_GLOBAL`] bits (see [`torque_bits`]).
    pub torque_compensation: u32,
    /// The cloth's first particle in `x`, `v` and the normals (the
    /// cloth's place in shared buffers: each `*_base` is an element index;
    /// all zero for a lone cloth).
    pub particle_base: u32,
    /// Its first spring in `springs`.
    pub spring_base: u32,
    /// Its spring adjacency offsets in `topo`.
    pub topo_base: u32,
    /// Its first `work` entry.
    pub work_base: u32,
    /// Its first `spring_work` entry.
    pub spring_work_base: u32,
    /// Its first reduction partial.
    pub partial_base: u32,
    /// Its first status word.
    pub status_base: u32,
    /// Its first word of the dense filter.
    pub dense_base: u32,
    /// Its integrator ([`crate::kernel_config::integrator`]).
    pub integrator: u32,
    /// Fix-up passes per step (0: no constrained spring kind).
    pub fixup_iterations: u32,
    /// Most CG iterations per step (`implicit.max_iterations`, or the
    /// scalable semi-implicit filter's): the workgroup kernels' loop.
    pub cg_max_iterations: u32,
    /// The cloth's scene features: [`crate::kernel_config::feature`] bits
    /// (what runs; the pipeline's `Features` say what is compiled in).
    pub features: u32,
    /// Grid layout (see `gpu/grid.rs`): columns, rows, a bit per spring
    /// kind present, unused; zero for the general kernels.
    pub grid: [u32; 4],
    /// Rest length of grid directions 0–3 \[m\].
    pub grid_rest_a: [f32; 4],
    /// Rest length of grid directions 4–5 \[m\] (two unused).
    pub grid_rest_b: [f32; 4],
    /// Fix-up length limit of grid directions 0–3 \[m\] (0: none).
    pub grid_max_a: [f32; 4],
    /// Fix-up length limit of grid directions 4–5 \[m\] (two unused).
    pub grid_max_b: [f32; 4],
    /// Stiffness of each spring kind [N/m]; the fourth is 0, the kernels'
    /// opaque zero (`unseen4` in `shaders/common/cg.wgsl`).
    pub kind_k: [f32; 4],
    /// Damping of each spring kind [N·s/m] (one unused).
    pub kind_kd: [f32; 4],
    /// Semi-implicit CG: the constant block `a = dt² k` of each spring
    /// kind \[kg\] (zero otherwise; one unused).
    pub kind_a: [f32; 4],
    /// The implicit CG's coarse levels (`cpu/coarse.rs`): the first
    /// cloth's columns and rows, level-1 and level-2 aggregates; zero
    /// without them.
    pub coarse: [u32; 4],
    /// The coarse levels' pieces (grid cloths, `aggregation::Piece`),
    /// three unused.
    pub coarse_world: [u32; 4],
    /// Two `vec4` a piece: columns, rows, first particle (within the
    /// cloth's range), first level-1 aggregate; first level-2 aggregate,
    /// three unused.
    pub coarse_pieces: [[u32; 4]; 2 * crate::aggregation::MAX_PIECES],
    /// Moving colliders: capsules in use, the step counts at which the
    /// spheres and the capsules were set (their time origin), unused.
    pub motion: [u32; 4],
    /// Self-collision (`cpu::self_collision`): thickness \[m\], Coulomb
    /// friction, the largest displacement per step \[m\], the grid's
    /// inverse cell size \[1/m\]; zero without it.
    pub self_collision: [f32; 4],
    /// Self-collision: passes per step, buckets (a power of two), the cap's
    /// reference particle (within the cloth), and the `vec4` index in
    /// `model` of the rest positions (in exclusion radii); zero without it.
    pub self_grid: [u32; 4],
    /// Sphere colliders; the first `sphere_count` are used.
    pub spheres: [GpuSphere; MAX_SPHERES],
    /// Capsule colliders; the first `motion[0]` are used.
    pub capsules: [GpuCapsule; MAX_CAPSULES],
    /// Mesh colliders: in use, the step count at which they were set
    /// (their time origin), two unused.
    pub mesh: [u32; 4],
    /// Mesh colliders; the first `mesh[0]` are used.
    pub meshes: [GpuMeshCollider; MAX_MESH_COLLIDERS],
    /// The linear bending model ([`crate::bending`]): its Rayleigh damping
    /// `β` \[s\], the scale `dt² + dt β` \[s²\] of its operator in the CG
    /// matrices, two unused; zero without it.
    pub bending: [f32; 4],
    /// The `u32` word indices in `model` of the bending operator's row
    /// offsets, columns and coefficients, one unused; zero without it.
    pub bending_rows: [u32; 4],
}
const _: () = assert!(
    std::mem::size_of::<GpuParams>()
        == 400
            + 32 * crate::aggregation::MAX_PIECES
            + 32 * MAX_SPHERES
            + 48 * MAX_CAPSULES
            + 64 * MAX_MESH_COLLIDERS
);
// A workgroup kernel's copy of its cloth's parameters, its self-collision
// scan, the torque's reduction words, the CG reductions' tree (a vec4 per
// lane, per run of 16 lanes, and its total) and its shared words fit the
// memory it is chosen for.
const _: () = assert!(
    std::mem::size_of::<GpuParams>()
        + 4 * (crate::kernel_config::SUM_GROUP + crate::kernel_config::WORKGROUP) as usize
        + 16 * (crate::kernel_config::CG_GROUP + crate::kernel_config::CG_GROUP / 16 + 1) as usize
        + 64
        <= crate::kernel_config::WORKGROUP_STEP_SHARED_BYTES as usize
);

/// Twin of WGSL `Spring`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSpring {
    /// First particle.
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Rest length \[m\].
    pub rest: f32,
    /// Stiffness [N/m].
    pub k: f32,
    /// Damping [N·s/m].
    pub kd: f32,
    /// Largest allowed length \[m\]; 0 = not constrained.
    pub max_len: f32,
    /// Padding to 32 bytes.
    pub _pad: [u32; 2],
}
const _: () = assert!(std::mem::size_of::<GpuSpring>() == 32);

/// Sections of the per-spring buffer.
pub const SPRING_SECTIONS: u32 = crate::kernel_config::spring_work::COUNT;

/// Slots of the reduction partials (3 CG slots + 16 torque sums).
pub const PARTIAL_SLOTS: u32 = crate::kernel_config::partials::SLOTS;
/// CG scalars after the partial slots.
pub const CG_SCALARS: u32 = crate::kernel_config::partials::CG_SCALARS;

/// [`GpuParams::torque_compensation`] bit: the per-spring compensation in
/// `semi_rhs` (twin: `TORQUE_LOCAL` in `shaders/semi_rhs.wgsl`).
pub const TORQUE_LOCAL: u32 = 1;

/// [`GpuParams::torque_compensation`] bit: the global rigid-rotation passes
/// (`torque_*`), for a cloth without pins only.
pub const TORQUE_GLOBAL: u32 = 2;

/// The torque compensation bits for a cloth with `pinned` pinned particles:
/// the scene's switch turns on the per-spring part for every cloth, and the
/// global part where no pin exerts a real torque (as
/// `cpu::semi_implicit::step` decides).
pub fn torque_bits(compensation: bool, pinned: usize) -> u32 {
    match (compensation, pinned) {
        (false, _) => 0,
        (true, 0) => TORQUE_LOCAL | TORQUE_GLOBAL,
        (true, _) => TORQUE_LOCAL,
    }
}
