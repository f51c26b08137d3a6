//! Configuration the GPU kernels and the CPU reference share: the
//! workgroup size (which is the block size of every reduction, so both sum
//! in the same order), the sections of the scratch buffers, the slots of
//! the reduction partials and the status words.
//!
//! This module is the one source of these numbers: [`wgsl`] writes them as
//! the WGSL constants `shaders/common/bindings.wgsl` includes (as
//! `generated/config.wgsl`), so the kernels and the host cannot disagree.

use std::fmt::Write;

/// Invocations per workgroup of every per-particle and per-spring kernel,
/// and so the block size of every reduction (the CPU reference reduces in
/// blocks of the same size to sum in the same order). 64 is a multiple of
/// every GPU's SIMD width and, on lavapipe, keeps both CPU cores busy down
/// to a 33 × 33 cloth (17 workgroups).
pub const WORKGROUP: u32 = 64;

/// Particles per block of the torque compensation's reductions:
/// [`WORKGROUP`], so the CPU sums in the GPU's order (CG's reductions
/// take blocks of [`CG_BLOCK`]).
pub const REDUCTION_BLOCK: usize = WORKGROUP as usize;

/// Invocations per workgroup of the CG kernels (`cg_init`, `cg_apply`,
/// `cg_update`), and so the block size of CG's reductions: each
/// workgroup writes a partial sum of its [`CG_GROUP`] particles' terms,
/// and every workgroup of the next kernel adds all the partials itself,
/// so a dispatch reads (particles / [`CG_GROUP`])² partials in all. 256
/// keeps that to about a million 16-byte loads from cache at 513² (every
/// WebGPU device grants 256 invocations) while a 33² cloth still spreads
/// over five workgroups.
pub const CG_GROUP: u32 = 256;
/// Particles per block of CG's reductions: [`CG_GROUP`], so the CPU sums
/// in the GPU's order.
pub const CG_BLOCK: usize = CG_GROUP as usize;
// The workgroup path's lane l takes particle l of each CG block, and a
// CG tree is 16 runs of 16 lanes (`tree_reduce` in shaders/common/cg.wgsl),
// a run a level-2 aggregate's slots.
const _: () = assert!(CG_GROUP == SUM_GROUP && CG_GROUP == 16 * 16);

/// Invocations of the one-workgroup kernels (the workgroup path's
/// `cloth_*`, self-collision's scan) on devices that allow it (the solver
/// takes less where the device's limits are lower).
pub const SUM_GROUP: u32 = 256;

/// The most particles a cloth may have to be stepped by one workgroup
/// (the workgroup path: `shaders/cloth_*.wgsl`), which the solver then
/// chooses: 64² = 4096, the range of game cloths (16² to 64²).
/// Every phase of a step loops over the cloth's particles with
/// [`SUM_GROUP`] invocations, so the step's time grows with the cloth
/// while a multi-dispatch step spreads it over every core or compute
/// unit; at 4096 particles each invocation takes 16 particles a phase and
/// the reductions 64 blocks (one per invocation, a quarter of the
/// workgroup), beyond which the dispatches saved no longer pay for the
/// lost parallelism on a GPU.
pub const WORKGROUP_STEP_MAX_PARTICLES: u32 = 4096;

/// Workgroup memory the workgroup kernels need at most \[bytes\]: the
/// cloth's parameters (`Params`, 1 920 bytes with the mesh colliders'
/// poses), self-collision's scan (`SUM_GROUP` words), the torque's
/// reduction scratch (`WORKGROUP` words), the CG reductions' tree
/// (`WORKGROUP` vec4s) and a few shared words, within 8 KiB — half of the
/// 16 KiB every WebGPU device allows.
pub const WORKGROUP_STEP_SHARED_BYTES: u32 = 8192;

/// The scene features as the kernels read them at run time
/// (`params.features`, WGSL: `FEATURE_*`): a feature's code runs where its
/// pipeline has it compiled in (`HAS_*`) and the cloth's bit is set, so one
/// pipeline with every feature compiled in steps any cloth at the cost of a
/// uniform branch per absent feature.
pub mod feature {
    /// Wind on triangles.
    pub const WIND: u32 = 1;
    /// A ground plane.
    pub const GROUND: u32 = 2;
    /// At least one sphere or capsule.
    pub const SPHERES: u32 = 4;
    /// Some particle can be constrained in CG (pins or colliders).
    pub const FILTER: u32 = 8;
    /// Some spring is damped.
    pub const DAMPING: u32 = 16;
    /// Self-collision (`[self_collision]`).
    pub const SELF_COLLISION: u32 = 32;
    /// At least one mesh collider (`[[collider]]`); a cloth with one has
    /// [`SPHERES`] too, which gates every collider's contact code.
    pub const MESH_COLLIDERS: u32 = 64;
    /// The linear bending model (`[material] bending`,
    /// [`crate::bending`]).
    pub const BENDING: u32 = 128;
}

/// The integrators as the kernels know them (`params.integrator`,
/// WGSL: `INTEGRATOR_*`): each workgroup kernel steps the cloths of its
/// own.
pub mod integrator {
    /// Symplectic Euler.
    pub const EXPLICIT: u32 = 0;
    /// Backward Euler with CG.
    pub const IMPLICIT: u32 = 1;
    /// The semi-implicit filter.
    pub const SEMI_IMPLICIT: u32 = 2;
}

/// Multipliers of the self-collision cell hash (Teschner et al. 2003,
/// "Optimized Spatial Hashing for Collision Detection of Deformable
/// Objects"), in wrapping `u32` arithmetic on both sides (WGSL:
/// `SC_HASH_*`).
pub const SELF_COLLISION_HASH: [u32; 3] = [73_856_093, 19_349_663, 83_492_791];

/// Most spheres the GPU solver takes (they live in the uniform block).
pub const MAX_SPHERES: usize = 16;

/// Most capsules the GPU solver takes (they live in the uniform block too).
pub const MAX_CAPSULES: usize = 16;

/// Most mesh colliders (`[[collider]]`) the GPU solver takes: their poses
/// live in the uniform block (64 bytes each), their grids in `model`.
pub const MAX_MESH_COLLIDERS: usize = 4;

/// The most steps one frame of pin motion may span: a pin moves while
/// its goal's step count is 1 to this many steps ahead of its clock, so a
/// count that wrapped past 2³² never reads as a move.
pub const MAX_FRAME_STEPS: u32 = 1 << 30;

/// Sections of the per-particle `work` buffer: section `s` of particle `p`
/// is `vec4<f32>` number `s × particles + p` (WGSL: `W_*`, `wi`).
pub mod work {
    /// Predicted positions \[m\] (explicit and semi-implicit fix-up input).
    pub const X_PRED: u32 = 0;
    /// Fix-up ping-pong positions \[m\].
    pub const X_ALT: u32 = 1;
    /// Velocity before the fix-up [m/s].
    pub const V_NEW: u32 = 2;
    /// CG unknown Δv [m/s]; w: the particle's filter kind from the CG
    /// set-up (implicit_prepare or semi_cg_prepare) to the step's end.
    pub const DV: u32 = 3;
    /// CG residual r; w: the particle's term of ρ.
    pub const R: u32 = 4;
    /// CG search direction c.
    pub const C: u32 = 5;
    /// CG product q = A c; w: the particle's term of cᵀq.
    pub const Q: u32 = 6;
    /// CG preconditioned residual s; w: the filter kind (from cg_init and
    /// cg_update).
    pub const S: u32 = 7;
    /// CG right-hand side; w: the particle's term of δ0.
    pub const RHS: u32 = 8;
    /// The filter's constraint direction (w: filter kind).
    pub const Z: u32 = 9;
    /// The filter of each particle.
    pub const FILTER: u32 = 10;
    /// Block-Jacobi preconditioner: diagonal.
    pub const PRE_DIAG: u32 = 11;
    /// Block-Jacobi preconditioner: off-diagonal.
    pub const PRE_OFF: u32 = 12;
    /// Δv of the step before the last (CG warm start: 2 Δv − Δv_prev).
    pub const DV_PREV: u32 = 13;
    /// Coarse levels (`cpu/coarse.rs`), by aggregate: D⁻¹'s diagonal.
    pub const COARSE_INV_D: u32 = 14;
    /// Coarse levels: D⁻¹'s off-diagonal.
    pub const COARSE_INV_O: u32 = 15;
    /// Coarse levels: the correction z = D⁻¹ Πᵀr (w: the coarse terms of
    /// δ, level-2 aggregates only).
    pub const COARSE_Z: u32 = 16;
    /// A pinned particle's target (`cpu::motion`): xyz where it is to be
    /// \[m\], w (as `u32` bits) the particle's step count at which it is
    /// there; written by the host, read by the steps' last kernels.
    pub const PIN_TARGET: u32 = 17;
    /// x (as `u32` bits): the steps this particle has finished, counted by
    /// the steps' last kernels (a per-particle clock, so no kernel reads a
    /// count another invocation of its own dispatch is changing); the
    /// moving colliders' and pins' time. yzw: the friction impulse \[N·s\]
    /// the particle takes in the next implicit step if it slides on a
    /// contact (the CPU's `Workspace::friction`).
    pub const CLOCK: u32 = 18;
    /// Number of sections.
    pub const COUNT: u32 = 19;

    /// The start-of-step positions of an implicit step on a grid with
    /// colliders, from which implicit_finish computes the spring blocks
    /// of its contact particles while x is being overwritten (the explicit
    /// integrator's predicted positions, unused by the implicit one).
    pub const X_START: u32 = X_PRED;
    /// Where single-pass explicit steps alternate the state (x, then v)
    /// with the x and v buffers: the CG sections R and C, which the
    /// explicit integrator does not use.
    pub const SNAPSHOT: u32 = R;
    /// Each particle's contribution to its level-1 aggregate's D
    /// (diagonal), from implicit_prepare to coarse_setup: a CG section
    /// cg_init writes afterwards.
    pub const LEVEL1_D: u32 = R;
    /// The same, off-diagonal (w: the trace of the particle's
    /// block-Jacobi block).
    pub const LEVEL1_O: u32 = C;
    /// The same for the level-2 aggregate (diagonal).
    pub const LEVEL2_D: u32 = Q;
    /// The same for the level-2 aggregate (off-diagonal).
    pub const LEVEL2_O: u32 = S;

    // Self-collision (`shaders/common/self_collision.wgsl`) runs after the
    // integrator's solve, when the CG sections are free in every
    // integrator (the explicit one has no CG; the others set them up
    // afresh each step); the single-pass explicit step, whose snapshot
    // is in R and C, is not used with it.
    /// Self-collision: the positions its passes start from \[m\] (the
    /// implicit step's `v += Δx / dt` reads them at the end).
    pub const SC_A: u32 = R;
    /// Self-collision: a pass's positions \[m\] (ping-pong with
    /// [`SC_C`]).
    pub const SC_B: u32 = C;
    /// Self-collision: a pass's positions \[m\] (ping-pong with
    /// [`SC_B`]).
    pub const SC_C: u32 = PRE_DIAG;
    /// Self-collision: each particle's cell (xyz, `i32` bits) and bucket
    /// (w, `u32` bits) at the build.
    pub const SC_CELL: u32 = Q;
    /// Self-collision, by position in the grid: the particle index (x,
    /// `u32` bits), each bucket's run in scatter order.
    pub const SC_UNORDERED: u32 = Z;
    /// Self-collision, by position in the grid: the particle index and its
    /// cell (`u32` bits), each bucket's run in index order.
    pub const SC_ORDER: u32 = S;
    /// Self-collision, two buckets per entry: each one's run in the grid
    /// (`u32` bits: start, end of the even bucket, then of the odd one).
    pub const SC_BUCKETS: u32 = RHS;

    /// The name of each of the [`COUNT`] sections, by index (without the
    /// WGSL prefix `W_`).
    pub const NAMES: [&str; COUNT as usize] = [
        "X_PRED",
        "X_ALT",
        "V_NEW",
        "DV",
        "R",
        "C",
        "Q",
        "S",
        "RHS",
        "Z",
        "FILTER",
        "PRE_DIAG",
        "PRE_OFF",
        "DV_PREV",
        "COARSE_INV_D",
        "COARSE_INV_O",
        "COARSE_Z",
        "PIN_TARGET",
        "CLOCK",
    ];
}

/// Per-spring sections, after the per-particle ones in the `work`
/// buffer: section `s` of spring slot `k` is `vec4<f32>` number
/// `s × spring slots + k` from there (WGSL: `S_*`, `si`).
pub mod spring_work {
    /// The implicit block (m, a) with B = a I + m mᵀ.
    pub const BLOCK: u32 = 0;
    /// K_s u.
    pub const KV: u32 = 1;
    /// The spring force on end i \[N\].
    pub const FORCE: u32 = 2;
    /// Number of sections.
    pub const COUNT: u32 = 3;
}

/// The reduction partials, after the per-spring sections of the `work`
/// buffer, a `vec4` each: slot `k` holds one per reduction block (`k ×
/// blocks + block`; blocks = ⌈particles / WORKGROUP⌉), then the
/// [`CG_SCALARS`](partials::CG_SCALARS) CG scalars (WGSL: `P_*`, `C_*`,
/// `pi`, `scalar_index`, `partial`). The torque's sums keep one `f32` per
/// `vec4` (in x); CG's sums one `vec4` per block of
/// [`CG_GROUP`](crate::kernel_config::CG_GROUP): cᵀq in [`CQ`](partials::CQ)'s x, the
/// residual's three sums in [`RES`](partials::RES), so the kernel that
/// adds them loads each block once. No CG kernel reads a slot it writes.
pub mod partials {
    /// CG's cᵀq (in x), per CG block: written by `cg_apply`, read by
    /// `cg_update`.
    pub const CQ: u32 = 0;
    /// CG's residual sums, per CG block (with coarse levels ρ and δ's
    /// coarse terms per workgroup of the per-slot update): written by
    /// `cg_init` and `cg_update`, read by `cg_apply`.
    pub const RES: u32 = 1;
    /// Component of [`RES`]: ρ = rᵀs.
    pub const RS: u32 = 0;
    /// Component of [`RES`]: δ's coarse-level terms.
    pub const DC: u32 = 1;
    /// Component of [`RES`]: δ0.
    pub const D0: u32 = 2;
    /// The first of the [`TORQUE_SLOTS`] torque-compensation sums.
    pub const TORQUE: u32 = 2;
    /// Torque-compensation sums (`shaders/common/torque.wgsl`).
    pub const TORQUE_SLOTS: u32 = 16;
    /// Number of per-block slots.
    pub const SLOTS: u32 = TORQUE + TORQUE_SLOTS;
    /// CG scalar: δ0, after the slots.
    pub const DELTA0: u32 = 0;
    /// CG scalar: δ, the current rᵀM⁻¹r.
    pub const DELTA: u32 = 1;
    /// CG scalar: α.
    pub const ALPHA: u32 = 2;
    /// CG scalar: β.
    pub const BETA: u32 = 3;
    /// CG scalar: δ at the start of the last completed iteration, for the
    /// next β.
    pub const DELTA_PREV: u32 = 4;
    /// Number of CG scalars after the slots.
    pub const CG_SCALARS: u32 = 5;
}

/// Words of the `status` buffer.
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
    /// The first of three rotating "this fix-up pass moved something"
    /// flags.
    pub const FIXUP_FLAG: usize = 10;
    /// The CG iteration whose `apply_args` slot was last enabled (it may
    /// still hold workgroups; `cg_init` clears it).
    pub const APPLY_SLOT: usize = 13;
    /// The same for `update_args`, which is also the iteration a
    /// `cg_update` runs.
    pub const UPDATE_SLOT: usize = 14;
    /// Number of status words.
    pub const COUNT: usize = 16;
}

/// Filter kinds, in the w of the CG vectors `work::DV` and `work::S`.
pub mod filter_kind {
    /// The particle is free.
    pub const FREE: f32 = 0.0;
    /// The particle is fixed (pinned).
    pub const FIXED: f32 = 1.0;
    /// The particle may only move in a plane (a contact).
    pub const PLANE: f32 = 2.0;
    /// The particle is held by static friction at a contact: fixed at
    /// the collider's velocity (the CPU's `Filter::Held`).
    pub const HELD: f32 = 3.0;
    /// `W_DV_PREV`'s w for a contact that static friction holds in the
    /// next step (the CPU's `Workspace::held`); every other particle's
    /// is 0.
    pub const HELD_NEXT: f32 = 1.0;
}

// The slots fit their buffers, and the fix-up's three flags the words
// between their first and the CG slots.
const _: () = assert!(status::UPDATE_SLOT < status::COUNT);
const _: () = assert!(status::FIXUP_FLAG + 3 <= status::APPLY_SLOT);
const _: () = assert!(work::CLOCK < work::COUNT);

/// `(WGSL name, value)` of every unsigned constant.
fn wgsl_u32() -> Vec<(String, u32)> {
    let mut out = vec![
        ("MAX_SPHERES".to_string(), MAX_SPHERES as u32),
        ("MAX_CAPSULES".to_string(), MAX_CAPSULES as u32),
        ("MAX_MESH_COLLIDERS".to_string(), MAX_MESH_COLLIDERS as u32),
        ("MAX_FRAME_STEPS".to_string(), MAX_FRAME_STEPS),
        (
            "COARSE_PIECE_WORDS".to_string(),
            2 * crate::aggregation::MAX_PIECES as u32,
        ),
    ];
    out.extend(
        work::NAMES
            .iter()
            .zip(0u32..)
            .map(|(n, k)| (format!("W_{n}"), k)),
    );
    let named: [(&str, u32); 56] = [
        ("INTEGRATOR_EXPLICIT", integrator::EXPLICIT),
        ("INTEGRATOR_IMPLICIT", integrator::IMPLICIT),
        ("INTEGRATOR_SEMI_IMPLICIT", integrator::SEMI_IMPLICIT),
        ("W_X_START", work::X_START),
        ("W_LEVEL1_D", work::LEVEL1_D),
        ("W_LEVEL1_O", work::LEVEL1_O),
        ("W_LEVEL2_D", work::LEVEL2_D),
        ("W_LEVEL2_O", work::LEVEL2_O),
        ("W_SC_A", work::SC_A),
        ("W_SC_B", work::SC_B),
        ("W_SC_C", work::SC_C),
        ("W_SC_CELL", work::SC_CELL),
        ("W_SC_UNORDERED", work::SC_UNORDERED),
        ("W_SC_ORDER", work::SC_ORDER),
        ("W_SC_BUCKETS", work::SC_BUCKETS),
        ("SC_HASH_X", SELF_COLLISION_HASH[0]),
        ("SC_HASH_Y", SELF_COLLISION_HASH[1]),
        ("SC_HASH_Z", SELF_COLLISION_HASH[2]),
        ("STATUS_WORDS", status::COUNT as u32),
        ("S_BLOCK", spring_work::BLOCK),
        ("S_KV", spring_work::KV),
        ("S_FORCE", spring_work::FORCE),
        ("P_CQ", partials::CQ),
        ("P_RES", partials::RES),
        ("P_RS", partials::RS),
        ("P_D0", partials::D0),
        ("P_DC", partials::DC),
        ("CG_GROUP", CG_GROUP),
        ("P_TORQUE", partials::TORQUE),
        ("P_SLOTS", partials::SLOTS),
        ("C_DELTA0", partials::DELTA0),
        ("C_DELTA", partials::DELTA),
        ("C_ALPHA", partials::ALPHA),
        ("C_BETA", partials::BETA),
        ("C_DELTA_PREV", partials::DELTA_PREV),
        ("STATUS_STEP", status::STEP as u32),
        ("STATUS_BAD_STEP", status::BAD_STEP as u32),
        ("STATUS_BAD_PARTICLE", status::BAD_PARTICLE as u32),
        ("STATUS_FIXUP_MOVED", status::FIXUP_MOVED as u32),
        ("STATUS_CG_ITERATIONS", status::CG_ITERATIONS as u32),
        ("STATUS_CG_STOPPED", status::CG_STOPPED as u32),
        ("STATUS_CG_MAX_ITERATIONS", status::CG_MAX_ITERATIONS as u32),
        ("STATUS_FIXUP_STOPPED", status::FIXUP_STOPPED as u32),
        ("STATUS_FIXUP_RESULT", status::FIXUP_RESULT as u32),
        ("STATUS_FIXUP_PASSES", status::FIXUP_PASSES as u32),
        ("STATUS_FIXUP_FLAG", status::FIXUP_FLAG as u32),
        ("STATUS_APPLY_SLOT", status::APPLY_SLOT as u32),
        ("STATUS_UPDATE_SLOT", status::UPDATE_SLOT as u32),
        ("FEATURE_WIND", feature::WIND),
        ("FEATURE_GROUND", feature::GROUND),
        ("FEATURE_SPHERES", feature::SPHERES),
        ("FEATURE_FILTER", feature::FILTER),
        ("FEATURE_DAMPING", feature::DAMPING),
        ("FEATURE_MESH_COLLIDERS", feature::MESH_COLLIDERS),
        ("FEATURE_SELF_COLLISION", feature::SELF_COLLISION),
        ("FEATURE_BENDING", feature::BENDING),
    ];
    out.extend(named.iter().map(|&(n, v)| (n.to_string(), v)));
    out
}

/// `(WGSL name, value)` of every `f32` constant.
const WGSL_F32: [(&str, f32); 5] = [
    ("FILTER_FREE", filter_kind::FREE),
    ("FILTER_FIXED", filter_kind::FIXED),
    ("FILTER_PLANE", filter_kind::PLANE),
    ("FILTER_HELD", filter_kind::HELD),
    ("HELD_NEXT", filter_kind::HELD_NEXT),
];

/// Every constant of this module as WGSL (`generated/config.wgsl`): the
/// workgroup sizes as `override` defaults (the solver sets them per
/// pipeline), the rest as `const`.
pub fn wgsl() -> String {
    let mut s = String::from(
        "// Generated by wgcloth::kernel_config::wgsl (src/kernel_config.rs, \
         where each constant is documented).\n",
    );
    // Writing to a String cannot fail; `let _` keeps no unwrap here.
    let _ = writeln!(s, "override WORKGROUP: u32 = {WORKGROUP}u;");
    let _ = writeln!(s, "override SUM_GROUP: u32 = {SUM_GROUP}u;");
    for (name, value) in wgsl_u32() {
        let _ = writeln!(s, "const {name}: u32 = {value}u;");
    }
    for (name, value) in WGSL_F32 {
        let _ = writeln!(s, "const {name}: f32 = {value:?};");
    }
    s
}

/// Every `(WGSL name, value as f64)` that [`wgsl`] writes, for the test
/// that reads them back through naga.
#[doc(hidden)]
pub fn wgsl_values() -> Vec<(String, f64)> {
    let mut out = vec![
        ("WORKGROUP".to_string(), f64::from(WORKGROUP)),
        ("SUM_GROUP".to_string(), f64::from(SUM_GROUP)),
    ];
    out.extend(wgsl_u32().into_iter().map(|(n, v)| (n, f64::from(v))));
    out.extend(WGSL_F32.iter().map(|&(n, v)| (n.to_string(), f64::from(v))));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_wgsl_name_is_written_once() {
        let values = wgsl_values();
        for (k, (name, _)) in values.iter().enumerate() {
            assert!(
                values[..k].iter().all(|(n, _)| n != name),
                "{name} written twice"
            );
        }
        assert_eq!(work::NAMES.len(), work::COUNT as usize);
    }
}
