//! Pod twins of the WGSL structs in `shaders/common/bindings.wgsl`, and the
//! section layout of the scratch buffers. Each struct's size is asserted at
//! compile time; a test compares every field offset with what naga computes
//! for the WGSL twin.

use bytemuck::{Pod, Zeroable};

/// Most spheres the GPU solver takes (they live in the uniform block).
pub const MAX_SPHERES: usize = 16;

/// Twin of WGSL `Sphere`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSphere {
    /// Centre \[m\].
    pub center: [f32; 3],
    /// Radius \[m\].
    pub radius: f32,
    /// Friction coefficient.
    pub friction: f32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: [f32; 3],
}
const _: () = assert!(std::mem::size_of::<GpuSphere>() == 32);

/// Twin of WGSL `Params` (the uniform block).
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
    /// 1 when the semi-implicit torque compensation applies.
    pub torque_compensation: u32,
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
    /// The implicit CG's coarse levels (`cpu/coarse.rs`): columns,
    /// rows, level-1 and level-2 aggregates; zero without them.
    pub coarse: [u32; 4],
    /// Sphere colliders; the first `sphere_count` are used.
    pub spheres: [GpuSphere; MAX_SPHERES],
}
const _: () = assert!(std::mem::size_of::<GpuParams>() == 240 + 32 * MAX_SPHERES);

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

/// Sections of the per-particle `work` buffer (twin of the `W_*` constants).
pub mod section {
    /// Predicted positions.
    pub const X_PRED: u32 = 0;
    /// Fix-up ping-pong.
    pub const X_ALT: u32 = 1;
    /// Velocity before the fix-up.
    pub const V_NEW: u32 = 2;
    /// CG unknown Δv.
    pub const DV: u32 = 3;
    /// Where single-pass explicit steps alternate the state (x, then v)
    /// with the x and v buffers: the CG sections R and C, which the
    /// explicit integrator does not use.
    pub const SNAPSHOT: u32 = 4;
    /// Number of sections (the last three: the coarse levels' aggregates).
    pub const COUNT: u32 = 17;
}

/// Sections of the per-spring buffer.
pub const SPRING_SECTIONS: u32 = 3;

/// Slots of the reduction partials (3 CG slots + 16 torque sums), followed
/// by 4 CG scalars (twin: `P_SLOTS` and `C_*`).
pub const PARTIAL_SLOTS: u32 = 19;
/// CG scalars after the partial slots.
pub const CG_SCALARS: u32 = 4;

/// Words of the status buffer (twin of the `STATUS_*` constants).
pub mod status {
    /// Steps taken on the device.
    pub const STEP: usize = 0;
    /// First step whose state was not finite (`u32::MAX`: none).
    pub const BAD_STEP: usize = 1;
    /// First non-finite particle at that step.
    pub const BAD_PARTICLE: usize = 2;
    /// The fix-up moved something this step.
    pub const FIXUP_MOVED: usize = 3;
    /// CG iterations of the last step.
    pub const CG_ITERATIONS: usize = 4;
    /// CG has stopped this step (converged or broke down).
    pub const CG_STOPPED: usize = 5;
    /// Largest CG iteration count of any step.
    pub const CG_MAX_ITERATIONS: usize = 6;
    /// The fix-up stopped early this step.
    pub const FIXUP_STOPPED: usize = 7;
    /// Section holding the fix-up's result.
    pub const FIXUP_RESULT: usize = 8;
    /// Fix-up passes run in the last step (the last one found nothing to
    /// move when it stopped early).
    pub const FIXUP_PASSES: usize = 9;
    /// The CG iteration whose `cg_alpha` was last enabled (its slot may
    /// still hold a workgroup; `cg_start` clears it).
    pub const ALPHA_SLOT: usize = 13;
    /// The same for `cg_beta`.
    pub const BETA_SLOT: usize = 14;
    /// Number of status words (three rotating fix-up flags follow 9).
    pub const COUNT: usize = 16;
}
