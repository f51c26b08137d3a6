//! What each kernel must read and write, per item: the table behind the
//! bytes and bandwidth `wgcloth run --profile` prints (see
//! [`super::profile`]).
//!
//! The counts are logical: every buffer element a kernel needs is counted
//! once per item that owns it (a particle's position once, however many
//! springs read it), at its size in the buffer (a `vec4<f32>` is 16 bytes,
//! a [`GpuSpring`](super::layout::GpuSpring) 32, an adjacency entry 4). So
//! they are a lower bound on the memory traffic: re-reads that a cache
//! serves are not counted, and a kernel that misses its cache moves more.
//! The uniform block, the reduction partials (a `vec4` per block of 64
//! particles and slot, in `work`) and the handful of CG scalars are left
//! out, and so are the pin goals (`W_PIN_TARGET`), which only pinned
//! particles read.
//! The particle clock (`W_CLOCK`, one `vec4` per particle) is counted
//! where a kernel reads or advances it.

use super::kernel::Kernel;

/// What an item of a [`Term`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// A particle.
    Particle,
    /// A spring whose data is in the springs buffer and its adjacency
    /// (general layout; on a grid the kernels compute springs from the
    /// uniform block and move none).
    Spring,
    /// A particle's row of the spring adjacency, its offset (general
    /// layout; a grid has none).
    AdjacencyRow,
    /// A coarse aggregate, level 1 or 2 (implicit CG's coarse levels).
    Aggregate,
    /// A free particle of the dense semi-implicit filter.
    FilterRow,
    /// An entry of the dense semi-implicit filter (rows × rows).
    FilterEntry,
    /// A triangle.
    Triangle,
    /// A vertex of a render mesh (`skin`; never in a step plan, so no
    /// solver counts any: see [`UnitCounts::of`]).
    RenderVertex,
}

/// Bytes a kernel reads and writes per item of one [`Unit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Term {
    /// What the item is.
    pub unit: Unit,
    /// Bytes read per item.
    pub read: u32,
    /// Bytes written per item.
    pub written: u32,
}

/// A `vec4<f32>` \[bytes\].
const VEC4: u32 = 16;
/// A [`GpuSpring`](super::layout::GpuSpring) \[bytes\].
const SPRING: u32 = 32;
/// A spring's two adjacency entries, one at each end \[bytes\].
const ADJACENCY: u32 = 8;
/// A particle's adjacency offset \[bytes\].
const OFFSET: u32 = 4;
/// The `w` component a reduction sums \[bytes\].
const W: u32 = 4;

const fn term(unit: Unit, read: u32, written: u32) -> Term {
    Term {
        unit,
        read,
        written,
    }
}

impl Kernel {
    /// What the kernel reads and writes per item (see the module's
    /// comment for what is counted). A new kernel must add its row here:
    /// the match is exhaustive, and `tests/profile.rs` checks that every
    /// kernel of [`Kernel::ALL`] writes something.
    pub const fn traffic(self) -> &'static [Term] {
        use Unit::{
            AdjacencyRow, Aggregate, FilterEntry, FilterRow, Particle, RenderVertex, Spring,
            Triangle,
        };
        match self {
            // x, v of both ends; the force.
            Kernel::SpringForces => {
                const { &[term(Particle, 2 * VEC4, 0), term(Spring, SPRING, VEC4)] }
            }
            // x, v (or the snapshot); the predicted x and new v (or the
            // next state); the incident springs' forces. (The variant fused
            // with finish_step also reads and advances the clock, one vec4
            // each way, not counted here.)
            Kernel::ExplicitIntegrate => {
                const {
                    &[
                        term(Particle, 2 * VEC4, 2 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, VEC4 + ADJACENCY, 0),
                    ]
                }
            }
            // x, v into the snapshot.
            Kernel::ExplicitSeed => const { &[term(Particle, 2 * VEC4, 2 * VEC4)] },
            // The source positions; the destination; the springs.
            Kernel::FixupJacobi => {
                const {
                    &[
                        term(Particle, VEC4, VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, SPRING + ADJACENCY, 0),
                    ]
                }
            }
            // x, v, the fix-up's result, the new v, the clock; x, v, the
            // clock.
            Kernel::FinishStep => const { &[term(Particle, 5 * VEC4, 3 * VEC4)] },
            // x and the triangle adjacency; the normal; each triangle's
            // three indices and three adjacency entries.
            Kernel::Normals => {
                const {
                    &[
                        term(Particle, VEC4 + OFFSET, VEC4),
                        term(Triangle, 6 * 4, 0),
                    ]
                }
            }
            // Its place, the triangle's three indices, positions and
            // normals; the position and normal written.
            Kernel::Skin => const { &[term(RenderVertex, 32 + 12 + 6 * VEC4, 6 * 4)] },
            // x, v of both ends; the block, K·v and the force.
            Kernel::ImplicitSprings => {
                const { &[term(Particle, 2 * VEC4, 0), term(Spring, SPRING, 3 * VEC4)] }
            }
            // x, v, the warm start, the clock; the right-hand side, z, the
            // filter, the preconditioner's two blocks, the start
            // positions, Δv; the incident springs' block and K·v.
            Kernel::ImplicitPrepare => {
                const {
                    &[
                        term(Particle, 4 * VEC4, 7 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, 2 * VEC4 + ADJACENCY, 0),
                    ]
                }
            }
            // Each particle's level blocks and mass; each aggregate's
            // inverse blocks.
            Kernel::CoarseSetup => {
                const { &[term(Particle, 4 * VEC4, 0), term(Aggregate, 0, 2 * VEC4)] }
            }
            // The right-hand side, Δv; r, c, q, s; A Δv's spring blocks.
            Kernel::CgInit => {
                const {
                    &[
                        term(Particle, 2 * VEC4, 4 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, 2 * VEC4 + ADJACENCY, 0),
                    ]
                }
            }
            // s, c, q; c, q; the spring blocks; with coarse levels the
            // level-2 corrections.
            Kernel::CgApply => {
                const {
                    &[
                        term(Particle, 3 * VEC4, 2 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, 2 * VEC4 + ADJACENCY, 0),
                        term(Aggregate, VEC4, 0),
                    ]
                }
            }
            // Δv, r, c, q, the preconditioner's two blocks; Δv, r, s;
            // with coarse levels each aggregate's inverse and sums.
            Kernel::CgUpdate => {
                const {
                    &[
                        term(Particle, 6 * VEC4, 3 * VEC4),
                        term(Aggregate, 2 * VEC4, VEC4),
                    ]
                }
            }
            // x, v, Δv, the filter, the right-hand side, z, the clock; x,
            // v, the clock.
            Kernel::ImplicitFinish => const { &[term(Particle, 7 * VEC4, 3 * VEC4)] },
            // x, v, the clock; the right-hand side (and Δv); the incident
            // springs' forces and data (the per-spring compensation's
            // rest length and stiffness).
            Kernel::SemiRhs => {
                const {
                    &[
                        term(Particle, 3 * VEC4, 2 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, SPRING + VEC4 + ADJACENCY, 0),
                    ]
                }
            }
            // The right-hand side and index of each free particle; its Δv;
            // the matrix.
            Kernel::FilterDense => {
                const { &[term(FilterRow, VEC4 + 4, VEC4), term(FilterEntry, 4, 0)] }
            }
            // x, v (the mass).
            Kernel::TorqueCentre => const { &[term(Particle, 2 * VEC4, 0)] },
            // x, v, Δv.
            Kernel::TorqueMoments => const { &[term(Particle, 3 * VEC4, 0)] },
            // x, Δv; Δv.
            Kernel::TorqueApply => const { &[term(Particle, 2 * VEC4, VEC4)] },
            // Self-collision, per particle. The predicted x; its copy, its
            // cell and bucket, and its bucket's count.
            Kernel::SelfCollisionCount => const { &[term(Particle, VEC4, 2 * VEC4 + W)] },
            // Up to two counts per particle (the table has at most twice
            // as many buckets as particles), read twice; a half entry of
            // runs written.
            Kernel::SelfCollisionScan => const { &[term(Particle, 4 * W, VEC4 / 2)] },
            // The cell and the bucket's run, the count; the grid entry.
            Kernel::SelfCollisionScatter => const { &[term(Particle, 2 * VEC4 + W, VEC4)] },
            // The cell, the run and at least its own unordered entry; the
            // ordered entry.
            Kernel::SelfCollisionRank => const { &[term(Particle, 3 * VEC4, VEC4)] },
            // Its position, x, build position and rest position and the
            // runs of the 8 cells around it (the entries and positions of the
            // particles found there, which depend on the folds, are not
            // counted); its new position.
            Kernel::SelfCollisionRespond => const { &[term(Particle, 12 * VEC4, VEC4)] },
            // x, v, Δv; the predicted x and new v.
            Kernel::SemiIntegrate => const { &[term(Particle, 3 * VEC4, 2 * VEC4)] },
            // The whole explicit step of spring_forces, explicit_integrate
            // and finish_step in one dispatch, their rows added up: x, v
            // of the springs' ends, then of the particle, its predicted x
            // and new v, and finish_step's reads; the predicted x and new
            // v, then x, v and the clock; each spring's data and force,
            // and its force gathered again with its adjacency entries.
            // The fix-up passes, whose number the device decides each
            // step, are not counted (each moves a fixup_jacobi row).
            Kernel::ClothExplicit => {
                const {
                    &[
                        term(Particle, 9 * VEC4, 5 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, SPRING + VEC4 + ADJACENCY, VEC4),
                    ]
                }
            }
            // The implicit step's fixed phases in one dispatch, the rows
            // of implicit_springs, implicit_prepare, coarse_setup,
            // cg_init and implicit_finish added up: per particle
            // 2 + 4 + 4 + 2 + 7 vec4 and two terms read, 7 + 4 + 3
            // written; two adjacency offsets; per spring its data, then
            // its block and K·v and its block again, and three vec4
            // written; per aggregate its inverse blocks. CG's iterations,
            // whose number the device decides each step, are not counted
            // (each moves a cg_apply and a cg_update row).
            Kernel::ClothImplicit => {
                const {
                    &[
                        term(Particle, 19 * VEC4 + 2 * W, 14 * VEC4),
                        term(AdjacencyRow, 2 * OFFSET, 0),
                        term(Spring, SPRING + 4 * VEC4 + 2 * ADJACENCY, 3 * VEC4),
                        term(Aggregate, 0, 2 * VEC4),
                    ]
                }
            }
            // The whole semi-implicit step with the dense filter in one
            // dispatch: spring_forces, semi_rhs, filter_dense,
            // semi_integrate and finish_step's rows added up (x, v of the
            // springs' ends; x, v, the clock, then x, v, Δv, then
            // finish_step's reads; the right-hand side and Δv, the
            // predicted x and new v, then x, v and the clock; each spring's
            // data and force, gathered with its data again). The torque
            // passes (a pin-free cloth) and the fix-up passes, which the
            // cloth decides, are not counted; each moves its kernel's row.
            Kernel::ClothSemiImplicit => {
                const {
                    &[
                        term(Particle, 13 * VEC4, 7 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, 2 * SPRING + VEC4 + ADJACENCY, VEC4),
                        term(FilterRow, VEC4 + 4, VEC4),
                        term(FilterEntry, 4, 0),
                    ]
                }
            }
            // x, v, Δv, the right-hand side; the filter, z, the
            // preconditioner's blocks, the right-hand side; the spring
            // blocks.
            Kernel::SemiCgPrepare => {
                const {
                    &[
                        term(Particle, 4 * VEC4, 5 * VEC4),
                        term(AdjacencyRow, OFFSET, 0),
                        term(Spring, VEC4 + ADJACENCY, 0),
                    ]
                }
            }
        }
    }
}

/// How many items of each [`Unit`] a cloth has on the device.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitCounts {
    /// Particles.
    pub particles: u64,
    /// Springs in the springs buffer (0 on a grid; see [`Unit::Spring`]).
    pub springs: u64,
    /// Rows of the spring adjacency: the particles, 0 on a grid.
    pub adjacency_rows: u64,
    /// Coarse aggregates, both levels.
    pub aggregates: u64,
    /// Free particles of the dense filter (0: none).
    pub filter_rows: u64,
    /// Triangles.
    pub triangles: u64,
}

impl UnitCounts {
    /// Items of `unit`.
    pub const fn of(&self, unit: Unit) -> u64 {
        match unit {
            Unit::Particle => self.particles,
            Unit::Spring => self.springs,
            Unit::AdjacencyRow => self.adjacency_rows,
            Unit::Aggregate => self.aggregates,
            Unit::FilterRow => self.filter_rows,
            Unit::FilterEntry => self.filter_rows * self.filter_rows,
            Unit::Triangle => self.triangles,
            Unit::RenderVertex => 0,
        }
    }

    /// `(read, written)` bytes of one dispatch of `kernel`.
    pub fn bytes(&self, kernel: Kernel) -> (u64, u64) {
        kernel.traffic().iter().fold((0, 0), |(r, w), t| {
            let n = self.of(t.unit);
            (r + n * u64::from(t.read), w + n * u64::from(t.written))
        })
    }
}
