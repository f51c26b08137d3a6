//! The CPU reference solver: all three integrators, generic over the scalar
//! ([`f64`] is the ground truth, [`f32`] mirrors the GPU's arithmetic).
//!
//! ```
//! use wgcloth::diagnostics::{Divergence, CHECK_EVERY};
//! use wgcloth::{cpu::CpuSolver, Scene};
//! # fn main() -> wgcloth::Result<()> {
//! let scene = Scene::builtin("hanging")?;
//! let model = scene.model()?;
//! let mut solver = CpuSolver::<f64>::new(&model, &scene.params)?;
//! // The blow-up rule every command applies, from the initial state.
//! let (x, v) = (solver.positions(), solver.velocities()); // glam::DVec3 [m], [m/s]
//! let rule = Divergence::new(&model, &scene.params, 0.0, &x, &v);
//! solver.step_n(CHECK_EVERY)?; // an error at once if the state stops being finite
//! solver.check_divergence(&rule)?; // an error if it is finite but past a bound
//! assert_eq!(solver.steps(), 10);
//! # Ok(()) }
//! ```

pub(crate) mod bvh;
pub(crate) mod cg;
pub(crate) mod coarse;
pub(crate) mod collide;
pub(crate) mod explicit;
// Reached by `tests/cpu_agreement.rs` (filter and fix-up against their
// dense references); not part of the embedding API.
#[doc(hidden)]
pub mod filter;
#[doc(hidden)]
pub mod fixup;
pub(crate) mod forces;
pub(crate) mod implicit;
pub(crate) mod mat3;
#[doc(hidden)]
pub mod motion;
#[doc(hidden)]
pub mod self_collision;
pub(crate) mod semi_implicit;
pub mod skin;
pub(crate) mod torque;
pub mod triangle_contact;
#[doc(hidden)]
pub mod twins;

use std::ops::Range;

use crate::budget::{self, try_collect, try_vec, Counts};
use crate::diagnostics;
use crate::error::{Error, Result};
use crate::model::{Adjacency, Model};
use crate::params::{Capsule, FilterMethod, FixupMethod, Integrator, Params, PinTarget, Sphere};
use crate::real::{Real, Vec3};
use crate::stats::StepStats;
use coarse::{Aggregation, Coarse};
use filter::{BandedFilter, ConstantFilter, DenseFilter, FilterSystem};
use implicit::{Filter, SpringBlock};
use mat3::Sym3;

pub use crate::kernel_config::REDUCTION_BLOCK;
pub use crate::params::DENSE_FILTER_MAX_PARTICLES;

/// Positions and velocities: what a step changes.
#[derive(Clone, Debug, PartialEq)]
pub struct State<R> {
    /// Positions \[m\], particle order.
    pub x: Vec<Vec3<R>>,
    /// Velocities [m/s], particle order.
    pub v: Vec<Vec3<R>>,
}

// Internals of the CPU solver, public only for the hidden `filter` and
// `fixup` modules and `tests/cpu_agreement.rs`; not part of the embedding API.
/// One spring in the solver's precision.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct SpringR<R> {
    /// First particle.
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Rest length \[m\].
    pub rest: R,
    /// Stiffness [N/m].
    pub k: R,
    /// Damping [N·s/m].
    pub kd: R,
}

/// The ground plane in the solver's precision.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct GroundR<R> {
    /// Height \[m\].
    pub height: R,
    /// Friction coefficient.
    pub friction: R,
}

/// A sphere in the solver's precision.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct SphereR<R> {
    /// Centre \[m\].
    pub center: Vec3<R>,
    /// Radius \[m\].
    pub radius: R,
    /// Friction coefficient.
    pub friction: R,
    /// Velocity [m/s].
    pub velocity: Vec3<R>,
}

/// A capsule collider in the solver's precision.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct CapsuleR<R> {
    /// Segment ends when set \[m\].
    pub a: Vec3<R>,
    /// The other end \[m\].
    pub b: Vec3<R>,
    /// Radius \[m\].
    pub radius: R,
    /// Friction coefficient.
    pub friction: R,
    /// Velocity [m/s].
    pub velocity: Vec3<R>,
}

/// The linear bending operator ([`crate::bending`]) in the solver's
/// precision.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct BendingR<R> {
    /// Row offsets, `particle_count + 1`.
    pub offsets: Vec<u32>,
    /// The other particle of each entry.
    pub columns: Vec<u32>,
    /// `Q_pj` [N/m] per entry.
    pub coefficients: Vec<R>,
    /// Rayleigh damping `β` \[s\].
    pub damping: R,
    /// `dt² + dt β` [s²]: the scale of `Q` in the implicit and
    /// semi-implicit system matrices.
    pub scale: R,
}

impl<R: Real> BendingR<R> {
    fn new(b: &crate::bending::Bending, dt: f64) -> Self {
        BendingR {
            offsets: b.offsets.clone(),
            columns: b.columns.clone(),
            coefficients: b.coefficients.iter().map(|&q| R::from_f64(q)).collect(),
            damping: R::from_f64(b.damping),
            scale: R::from_f64(dt * dt + dt * b.damping),
        }
    }

    /// Particle `p`'s entries: the other particles and `Q_pj`.
    #[inline]
    pub fn row(&self, p: usize) -> (&[u32], &[R]) {
        let r = self.offsets[p] as usize..self.offsets[p + 1] as usize;
        (&self.columns[r.clone()], &self.coefficients[r])
    }
}

/// A mesh collider in the solver's precision: its pose as the kernels
/// hold it (twin: `layout::GpuMeshCollider`) and its grid.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct MeshColliderR<R> {
    /// World-to-body rotation, a unit quaternion `(x, y, z, w)`.
    pub rotation: [R; 4],
    /// The body's origin when set \[m\].
    pub position: Vec3<R>,
    /// Velocity [m/s].
    pub velocity: Vec3<R>,
    /// Angular velocity [rad/s] about the origin.
    pub angular_velocity: Vec3<R>,
    /// Friction coefficient.
    pub friction: R,
    /// The distance the cloth keeps \[m\].
    pub thickness: R,
    /// The baked grid.
    pub grid: std::sync::Arc<crate::sdf::DistanceGrid>,
}

/// Wind in the solver's precision.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct WindR<R> {
    /// Air velocity [m/s].
    pub velocity: Vec3<R>,
    /// Drag coefficient [kg/m³].
    pub drag: R,
    /// Lift coefficient [kg/m³].
    pub lift: R,
}

/// Everything a step reads but does not change: the model and parameters,
/// converted once to the solver's precision.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct System<R> {
    /// Springs.
    pub springs: Vec<SpringR<R>>,
    /// Maximum length per spring \[m\]; zero = not constrained.
    pub max_len: Vec<R>,
    /// Spring index ranges of the constrained kinds.
    pub constrained_ranges: Vec<Range<usize>>,
    /// Incident springs per particle.
    pub spring_adj: Adjacency,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Incident triangles per particle.
    pub triangle_adj: Adjacency,
    /// Mass per particle \[kg\].
    pub mass: Vec<R>,
    /// Inverse mass per particle [1/kg]; zero = pinned.
    pub inv_mass: Vec<R>,
    /// Number of pinned particles.
    pub pinned_count: usize,
    /// Grid shape `(nx, ny)` if the model is a grid.
    pub grid: Option<(usize, usize)>,
    /// Time step \[s\].
    pub dt: R,
    /// Gravity [m/s²].
    pub gravity: Vec3<R>,
    /// Ground plane.
    pub ground: Option<GroundR<R>>,
    /// Spheres.
    pub spheres: Vec<SphereR<R>>,
    /// The step count at which the spheres were set (their velocity moves
    /// them from there).
    pub sphere_base: u32,
    /// Capsule colliders.
    pub capsules: Vec<CapsuleR<R>>,
    /// The step count at which the capsules were set.
    pub capsule_base: u32,
    /// Mesh colliders.
    pub mesh_colliders: Vec<MeshColliderR<R>>,
    /// The step count at which the mesh colliders were set.
    pub mesh_base: u32,
    /// Wind.
    pub wind: Option<WindR<R>>,
    /// Fix-up passes (0 = off).
    pub fixup_iterations: u32,
    /// Fix-up order.
    pub fixup_method: FixupMethod,
    /// Jacobi over-relaxation.
    pub fixup_omega: R,
    /// CG relative tolerance.
    pub cg_tolerance: f64,
    /// CG iteration cap.
    pub cg_max_iterations: u32,
    /// Semi-implicit torque compensation on/off.
    pub torque_compensation: bool,
    /// Self-collision, `None` when off.
    pub self_collision: Option<crate::self_collision::SelfCollisionR<R>>,
    /// The linear bending operator, `None` without one.
    pub bending: Option<BendingR<R>>,
}

impl<R: Real> System<R> {
    /// The model and parameters in precision `R`; self-collision (when
    /// `params` has it) at the thickness [`crate::self_collision::thickness`]
    /// gives, the default where that refuses (the solvers call it first).
    pub fn new(model: &Model, params: &Params) -> Self {
        let springs = model
            .springs
            .iter()
            .enumerate()
            .map(|(n, s)| {
                let c = model.spring_constants(n, params);
                SpringR {
                    i: s.i,
                    j: s.j,
                    rest: R::from_f64(s.rest),
                    k: R::from_f64(c.k),
                    kd: R::from_f64(c.kd),
                }
            })
            .collect();
        let max_len = (0..model.springs.len())
            .map(|s| R::from_f64(model.fixup_limit(s, params)))
            .collect();
        let constrained_ranges = model
            .kind_ranges
            .iter()
            .enumerate()
            .filter(|(k, r)| {
                !r.is_empty()
                    && params.springs[*k].max_stretch.is_some()
                    && params.fixup.iterations > 0
            })
            .map(|(_, r)| r.clone())
            .collect();
        let mass: Vec<R> = model.mass.iter().map(|&m| R::from_f64(m)).collect();
        let inv_mass = model
            .mass
            .iter()
            .zip(&model.pinned)
            .map(|(&m, &pinned)| {
                if pinned {
                    R::ZERO
                } else {
                    R::from_f64(1.0 / m)
                }
            })
            .collect();
        System {
            springs,
            max_len,
            constrained_ranges,
            spring_adj: model.particle_springs.clone(),
            triangles: model.triangles.clone(),
            triangle_adj: model.particle_triangles.clone(),
            mass,
            inv_mass,
            pinned_count: model.pinned_count(),
            grid: model.grid.as_ref().map(|g| (g.nx, g.ny)),
            dt: R::from_f64(params.dt),
            gravity: Vec3::from_f64(params.gravity),
            ground: params.ground.map(|g| GroundR {
                height: R::from_f64(g.height),
                friction: R::from_f64(g.friction),
            }),
            spheres: spheres_r(&params.spheres),
            sphere_base: 0,
            capsules: capsules_r(&params.capsules),
            capsule_base: 0,
            mesh_colliders: mesh_colliders_r(&params.mesh_colliders),
            mesh_base: 0,
            wind: params.wind.map(|w| WindR {
                velocity: Vec3::from_f64(w.velocity),
                drag: R::from_f64(w.drag),
                lift: R::from_f64(w.lift),
            }),
            fixup_iterations: params.fixup.iterations,
            fixup_method: params.fixup.method,
            fixup_omega: R::from_f64(params.fixup.omega),
            cg_tolerance: params.implicit.tolerance,
            cg_max_iterations: params.implicit.max_iterations,
            torque_compensation: params.semi_implicit.torque_compensation,
            self_collision: crate::self_collision::SelfCollisionR::of(model, params),
            bending: model.bending.as_ref().map(|b| BendingR::new(b, params.dt)),
        }
    }

    /// `true` when there is a ground plane or at least one sphere.
    pub fn has_colliders(&self) -> bool {
        self.ground.is_some()
            || !self.spheres.is_empty()
            || !self.capsules.is_empty()
            || !self.mesh_colliders.is_empty()
    }
}

/// Mesh colliders in the solver's precision: the rotation inverted
/// (world to body) as the kernels take it.
fn mesh_colliders_r<R: Real>(colliders: &[crate::sdf::MeshCollider]) -> Vec<MeshColliderR<R>> {
    colliders
        .iter()
        .map(|m| {
            let q = m.rotation.inverse().as_quat().to_array();
            MeshColliderR {
                rotation: q.map(|c| R::from_f64(f64::from(c))),
                position: Vec3::from_f64(m.position),
                velocity: Vec3::from_f64(m.velocity),
                angular_velocity: Vec3::from_f64(m.angular_velocity),
                friction: R::from_f64(m.friction),
                thickness: R::from_f64(m.thickness),
                grid: m.grid.clone(),
            }
        })
        .collect()
}

/// Spheres in the solver's precision.
fn spheres_r<R: Real>(spheres: &[Sphere]) -> Vec<SphereR<R>> {
    spheres
        .iter()
        .map(|s| SphereR {
            center: Vec3::from_f64(s.center),
            radius: R::from_f64(s.radius),
            friction: R::from_f64(s.friction),
            velocity: Vec3::from_f64(s.velocity),
        })
        .collect()
}

/// Capsules in the solver's precision.
fn capsules_r<R: Real>(capsules: &[Capsule]) -> Vec<CapsuleR<R>> {
    capsules
        .iter()
        .map(|c| CapsuleR {
            a: Vec3::from_f64(c.a),
            b: Vec3::from_f64(c.b),
            radius: R::from_f64(c.radius),
            friction: R::from_f64(c.friction),
            velocity: Vec3::from_f64(c.velocity),
        })
        .collect()
}

/// Scratch buffers, allocated once per solver.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Workspace<R> {
    /// Per-spring vectors: spring forces on end `i`, or Jacobi fix-up
    /// corrections.
    pub per_spring: Vec<Vec3<R>>,
    /// Per spring: the implicit step's `K_s (v_i − v_j)` on end `i`.
    pub kv: Vec<Vec3<R>>,
    /// Per-spring flags (Jacobi fix-up).
    pub active: Vec<bool>,
    /// Per-triangle vectors.
    pub per_triangle: Vec<Vec3<R>>,
    /// Per-particle forces.
    pub force: Vec<Vec3<R>>,
    /// Right-hand side.
    pub rhs: Vec<Vec3<R>>,
    /// Velocity change (kept between steps: CG warm start).
    pub dv: Vec<Vec3<R>>,
    /// The velocity change of the step before the last (the warm start
    /// extrapolates linearly from the last two).
    pub dv_prev: Vec<Vec3<R>>,
    /// The contacts static friction held at the end of the last step
    /// (the implicit integrator's [`Filter::Held`]; the GPU
    /// keeps it in `W_DV_PREV`'s w).
    pub held: Vec<bool>,
    /// The friction impulse [N·s] a sliding contact takes in the next
    /// implicit step (see `implicit::contact_friction`; the GPU keeps it
    /// in `W_CLOCK`'s yzw).
    pub friction: Vec<Vec3<R>>,
    /// Positions before the step.
    pub x_old: Vec<Vec3<R>>,
    /// CG residual.
    pub r: Vec<Vec3<R>>,
    /// CG search direction.
    pub c: Vec<Vec3<R>>,
    /// CG `S A c`.
    pub q: Vec<Vec3<R>>,
    /// CG filtered preconditioned residual `S P r`.
    pub s: Vec<Vec3<R>>,
    /// CG `S A s`.
    pub t: Vec<Vec3<R>>,
    /// CG prescribed constrained velocity changes.
    pub z: Vec<Vec3<R>>,
    /// CG constraint filter.
    pub filter: Vec<Filter<R>>,
    /// Per particle: its term of CG's δ0 (the GPU keeps it in the w of
    /// `W_RHS`).
    pub delta0_terms: Vec<R>,
    /// Per particle: its term of CG's ρ (the w of `W_R`).
    pub rho_terms: Vec<R>,
    /// Per particle: its term of CG's cᵀq (the w of `W_Q`).
    pub cq_terms: Vec<R>,
    /// CG's scalars between its kernels.
    pub cg: cg::Scalars<R>,
    /// CG block-diagonal preconditioner.
    pub precond: Vec<Sym3<R>>,
    /// Per-spring linearisation.
    pub blocks: Vec<SpringBlock<R>>,
    /// The torque compensation's per-block partial sums, slot-major as the
    /// GPU's `partials` from `P_TORQUE` (see [`torque`]).
    pub torque: Vec<R>,
    /// The semi-implicit constant filter (built on demand).
    pub constant_filter: Option<ConstantFilter<R>>,
    /// Scratch for the constant filter.
    pub scratch: Vec<Vec3<R>>,
    /// The implicit CG's coarse levels (a grid cloth with
    /// [`crate::params::ImplicitParams::coarse_levels`]).
    pub coarse: Option<Coarse<R>>,
    /// Each pinned particle's goal (the GPU's `W_PIN_TARGET`).
    pub pin_goal: Vec<motion::PinGoal<R>>,
    /// Per particle: whether it touches a collider at the step's start
    /// (the semi-implicit right-hand side asks for both ends of every
    /// spring; the GPU works it out where it needs it).
    pub touching: Vec<bool>,
    /// The steps finished (the GPU's per-particle `W_CLOCK`).
    pub clock: u32,
    /// Self-collision's grid, `None` when it is off.
    pub self_grid: Option<self_collision::Grid<R>>,
    /// The triangle method's lists, `None` without it.
    pub contacts: Option<triangle_contact::Contacts<R>>,
}

impl<R: Real> Workspace<R> {
    fn new(particles: usize, springs: usize, triangles: usize) -> Result<Self> {
        const WHAT: &str = "the CPU solver's workspace";
        let pv = || try_vec(particles, Vec3::ZERO, WHAT);
        Ok(Workspace {
            per_spring: try_vec(springs, Vec3::ZERO, WHAT)?,
            kv: try_vec(springs, Vec3::ZERO, WHAT)?,
            active: try_vec(springs, false, WHAT)?,
            per_triangle: try_vec(triangles, Vec3::ZERO, WHAT)?,
            force: pv()?,
            rhs: pv()?,
            dv: pv()?,
            dv_prev: pv()?,
            held: try_vec(particles, false, WHAT)?,
            friction: pv()?,
            x_old: pv()?,
            r: pv()?,
            c: pv()?,
            q: pv()?,
            s: pv()?,
            t: pv()?,
            z: pv()?,
            filter: try_vec(particles, Filter::Free, WHAT)?,
            delta0_terms: try_vec(particles, R::ZERO, WHAT)?,
            rho_terms: try_vec(particles, R::ZERO, WHAT)?,
            cq_terms: try_vec(particles, R::ZERO, WHAT)?,
            cg: cg::Scalars::default(),
            precond: try_vec(particles, Sym3::default(), WHAT)?,
            blocks: try_vec(springs, SpringBlock::default(), WHAT)?,
            torque: try_vec(
                torque::SLOTS * particles.div_ceil(REDUCTION_BLOCK),
                R::ZERO,
                WHAT,
            )?,
            constant_filter: None,
            scratch: Vec::new(),
            coarse: None,
            pin_goal: try_vec(particles, motion::PinGoal::default(), WHAT)?,
            touching: try_vec(particles, false, WHAT)?,
            clock: 0,
            self_grid: None,
            contacts: None,
        })
    }
}

/// The prediction of the explicit and semi-implicit steps, after their
/// velocity update: `x* = x + dt v` for free particles, `v = 0` for pinned
/// ones, with the start of the step kept in `w.x_old` (the end of the
/// twins of `explicit_integrate` and `semi_integrate`).
pub(crate) fn predict<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    w.x_old.copy_from_slice(&st.x);
    for p in 0..st.x.len() {
        if sys.inv_mass[p] > R::ZERO {
            st.x[p] += st.v[p] * sys.dt;
        } else {
            st.v[p] = Vec3::ZERO;
        }
    }
}

/// Twin of `shaders/finish_step.wgsl`, the end of an explicit or
/// semi-implicit step after the fix-up: where the fix-up `moved`
/// something, every free particle's velocity rebuilt from its
/// displacement, `v = (x* − x) / dt`; then collisions. Reads `x_old` (the
/// GPU's `x`), `x*` and `v*` in `st` (the fix-up's result section and
/// `W_V_NEW`); writes `st`. Pinned particles move towards their goals
/// (`motion::move_pins`); the colliders are where they are at the step's
/// end; the clock advances.
pub fn finish_step<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>, moved: bool) {
    if moved {
        let inv_dt = R::ONE / sys.dt;
        for p in 0..st.x.len() {
            if sys.inv_mass[p] > R::ZERO {
                st.v[p] = (st.x[p] - w.x_old[p]) * inv_dt;
            }
        }
    }
    motion::move_pins(sys, &mut st.x, &mut st.v, w);
    collide::collide(sys, &w.x_old, &mut st.x, &mut st.v, w.clock);
    unsigned_zeros(st);
    w.clock = w.clock.wrapping_add(1);
}

/// The state with every zero made +0 (`−0 + 0 = +0`; every other value
/// unchanged), as the GPU stores it (twin: `unsigned_zero3` in
/// `store_state`, `shaders/common/physics.wgsl`). A GPU compiler may drop
/// an addition of a zero it can see, or fold a product by a constant,
/// which leaves −0 where IEEE arithmetic gives +0; a state stored without
/// signed zeros is the same bits on every path and on the CPU.
pub(crate) fn unsigned_zeros<R: Real>(st: &mut State<R>) {
    for a in st.x.iter_mut().chain(st.v.iter_mut()) {
        *a += Vec3::ZERO;
    }
}

/// The shared tail of the explicit and semi-implicit steps, after their
/// prediction: the fix-up passes (`fixup_jacobi`), self-collision
/// ([`self_collision::apply`]), then [`finish_step`].
pub(crate) fn fixup_and_finish<R: Real>(
    sys: &System<R>,
    st: &mut State<R>,
    w: &mut Workspace<R>,
) -> StepStats {
    let passes = fixup::run(sys, &mut st.x, w);
    let contact = self_collision::apply(sys, &mut st.x, w);
    finish_step(sys, st, w, passes > 0 || contact);
    StepStats {
        fixup_passes: passes,
        ..StepStats::default()
    }
}

/// The semi-implicit filter in a memory error: the dense one's size and
/// the way out.
fn filter_name(dense: bool, free: u64) -> String {
    if dense {
        format!(
            "the dense semi-implicit filter ({free} × {free} entries; \
             `filter = \"banded\"` needs far less)"
        )
    } else {
        "the banded semi-implicit filter".into()
    }
}

/// The CPU reference solver for one cloth.
#[derive(Clone, Debug)]
pub struct CpuSolver<R: Real> {
    integrator: Integrator,
    filter_method: FilterMethod,
    sys: System<R>,
    state: State<R>,
    work: Workspace<R>,
    steps: u64,
    time: f64,
    last: StepStats,
    /// The moving bodies, for [`CpuSolver::check_divergence`].
    motion: diagnostics::Motion,
    /// The mesh colliders as last set.
    mesh_colliders: Vec<crate::sdf::MeshCollider>,
}

impl<R: Real> CpuSolver<R> {
    /// A solver for `model` with `params`, starting at rest in the model's
    /// rest positions. Refuses invalid parameters, and a solver that needs
    /// more memory than the host has ([`Error::OutOfMemory`]; see
    /// [`crate::budget`]), before anything runs.
    pub fn new(model: &Model, params: &Params) -> Result<Self> {
        params.validate()?;
        crate::material::check_explicit_bending(model, params)?;
        let thickness = crate::self_collision::thickness(model, params)?;
        let triangles = params
            .self_collision
            .as_ref()
            .is_some_and(|c| c.method == crate::params::ContactMethod::Triangles);
        let counts = Counts::of_model(model);
        let semi = params.integrator == Integrator::SemiImplicit;
        let dense = params.semi_implicit.filter.is_dense(counts.free as usize);
        let filter = if semi {
            budget::filter_bytes::<R>(counts, budget::filter_bandwidth(model), dense)
        } else {
            0
        };
        budget::check_host(
            budget::cpu_solver_bytes::<R>(counts).saturating_add(filter),
            || {
                let with = if semi {
                    format!(" with {}", filter_name(dense, counts.free))
                } else {
                    String::new()
                };
                format!(
                    "the {} CPU solver for {} particles{with}",
                    R::NAME,
                    counts.particles
                )
            },
        )?;
        let mut sys = System::new(model, params);
        let n = model.particle_count();
        let state = State {
            x: try_collect(
                model.rest_positions.iter().map(|&p| Vec3::from_f64(p)),
                "the CPU solver's state",
            )?,
            v: try_vec(n, Vec3::ZERO, "the CPU solver's state")?,
        };
        let mut work = Workspace::new(n, model.springs.len(), model.triangles.len())?;
        // The CPU's semi-implicit filter is a factorisation, not a CG.
        work.coarse = Aggregation::for_scene(model, params)
            .filter(|_| params.integrator == Integrator::Implicit)
            .map(Coarse::new);
        work.self_grid = match &sys.self_collision {
            Some(c) => Some(self_collision::Grid::new(n, c.table)?),
            None => None,
        };
        if let (Some(c), Some(t), true) = (&mut sys.self_collision, thickness, triangles) {
            let topo = crate::self_collision::TriangleTopology::new(model, t)?;
            work.contacts = Some(triangle_contact::Contacts::new(&sys.triangles, &topo)?);
            c.triangles = Some(topo);
        }
        let mut solver = CpuSolver {
            integrator: params.integrator,
            filter_method: params.semi_implicit.filter,
            sys,
            state,
            work,
            steps: 0,
            time: 0.0,
            last: StepStats::default(),
            motion: diagnostics::Motion::new(model, params),
            mesh_colliders: params.mesh_colliders.clone(),
        };
        if solver.integrator == Integrator::SemiImplicit {
            solver.build_filter()?;
        }
        Ok(solver)
    }

    /// (Re)builds the semi-implicit filter for the current `dt`, stiffness,
    /// masses and pins. Called by [`CpuSolver::new`] and by every setter that
    /// changes one of those — never per step.
    fn build_filter(&mut self) -> Result<()> {
        let fs = FilterSystem::new(&self.sys, self.sys.grid);
        let dense = self.filter_method.is_dense(fs.len());
        let counts = Counts {
            particles: self.sys.mass.len() as u64,
            springs: self.sys.springs.len() as u64,
            triangles: self.sys.triangles.len() as u64,
            free: fs.len() as u64,
            bending: self
                .sys
                .bending
                .as_ref()
                .map_or(0, |b| b.columns.len() as u64),
        };
        budget::check_host(
            budget::filter_bytes::<R>(counts, fs.bandwidth() as u64, dense),
            || filter_name(dense, counts.free),
        )?;
        self.work.constant_filter = Some(if dense {
            ConstantFilter::Dense(DenseFilter::new(&fs)?)
        } else {
            ConstantFilter::Banded(BandedFilter::new(&fs)?)
        });
        Ok(())
    }

    /// Advances one step. A state that becomes non-finite is an error naming
    /// the step; the state is left as it was computed (for inspection).
    pub fn step(&mut self) -> Result<StepStats> {
        let mut stats = match self.integrator {
            Integrator::Explicit => explicit::step(&self.sys, &mut self.state, &mut self.work),
            Integrator::Implicit => implicit::step(&self.sys, &mut self.state, &mut self.work),
            Integrator::SemiImplicit => {
                semi_implicit::step(&self.sys, &mut self.state, &mut self.work)
            }
        };
        self.steps += 1;
        self.time += self.sys.dt.to_f64();
        stats.steps = self.steps;
        stats.cg_max_iterations = stats.cg_iterations;
        self.last = stats;
        if let Some(p) = diagnostics::first_non_finite(&self.state.x, &self.state.v) {
            return Err(Error::NonFinite {
                step: self.steps,
                time: self.time,
                particle: p,
            });
        }
        Ok(stats)
    }

    /// Advances `n` steps; returns the last step's stats, with
    /// [`StepStats::cg_max_iterations`] the most of the `n` steps.
    pub fn step_n(&mut self, n: u64) -> Result<StepStats> {
        let mut most = 0;
        for _ in 0..n {
            most = most.max(self.step()?.cg_iterations);
        }
        Ok(StepStats {
            cg_max_iterations: most,
            ..self.last
        })
    }

    /// Applies `rule` to the current state (see
    /// [`Divergence`](diagnostics::Divergence)), bounding the work of the
    /// bodies as this solver moved them ([`CpuSolver::motion`]): an
    /// embedder calls this every [`CHECK_EVERY`](diagnostics::CHECK_EVERY)
    /// steps and at its last step, after [`CpuSolver::step`] (which reports
    /// a non-finite state at once by itself).
    pub fn check_divergence(&self, rule: &diagnostics::Divergence) -> Result<()> {
        rule.check_with(
            self.steps,
            self.time,
            &self.state.x,
            &self.state.v,
            &self.motion,
        )
    }

    /// The moving bodies (colliders, pins) as this solver has moved them
    /// since it started, told by every setter that moves one.
    pub fn motion(&self) -> &diagnostics::Motion {
        &self.motion
    }

    /// The current state in the internals' vectors (for the CLI and the
    /// tests; an embedder reads [`CpuSolver::positions`] and
    /// [`CpuSolver::velocities`]).
    #[doc(hidden)]
    pub fn state(&self) -> &State<R> {
        &self.state
    }

    /// Replaces the state (positions and velocities, particle order). The
    /// lengths must match the model.
    #[doc(hidden)]
    pub fn set_state(&mut self, state: State<R>) -> Result<()> {
        let n = self.state.x.len();
        if state.x.len() != n || state.v.len() != n {
            return Err(Error::InvalidParameter {
                key: "state".into(),
                allowed: format!("{n} positions and {n} velocities"),
                got: format!("{} and {}", state.x.len(), state.v.len()),
            });
        }
        self.state = state;
        for p in (0..n).filter(|&p| self.sys.inv_mass[p] <= R::ZERO) {
            let x = glam::DVec3::from_array(self.state.x[p].to_f64());
            self.motion.place(p, x, self.time);
        }
        Ok(())
    }

    /// Positions \[m\], particle order: `glam::DVec3` for `CpuSolver<f64>`,
    /// `glam::Vec3` for `CpuSolver<f32>` (a copy; the solver computes in
    /// its own vector type, generic over the precision).
    pub fn positions(&self) -> Vec<R::Vector> {
        self.state.x.iter().map(|&p| p.into()).collect()
    }

    /// Velocities [m/s], particle order, as [`CpuSolver::positions`].
    pub fn velocities(&self) -> Vec<R::Vector> {
        self.state.v.iter().map(|&v| v.into()).collect()
    }

    /// Sets positions \[m\] and velocities [m/s] (particle order, one of
    /// each per particle), as [`CpuSolver::positions`] returns them.
    pub fn set_positions_and_velocities(&mut self, x: &[R::Vector], v: &[R::Vector]) -> Result<()> {
        self.set_state(State {
            x: x.iter().map(|&p| p.into()).collect(),
            v: v.iter().map(|&p| p.into()).collect(),
        })
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Simulated time \[s\] (accumulated in `f64`).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The integrator in use.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }

    /// Stats of the last step.
    pub fn last_stats(&self) -> StepStats {
        self.last
    }

    /// `"dense"` / `"banded"` for a semi-implicit solver, else `None`.
    pub fn filter_name(&self) -> Option<&'static str> {
        self.work.constant_filter.as_ref().map(ConstantFilter::name)
    }

    /// The system the solver steps (read-only; for diagnostics and tests).
    #[doc(hidden)]
    pub fn system(&self) -> &System<R> {
        &self.sys
    }

    /// Replaces the sphere colliders; each moves at its velocity from its
    /// `center` from now on (a game moving a ball calls this every frame
    /// with the ball's position and velocity).
    pub fn set_spheres(&mut self, spheres: &[Sphere]) -> Result<()> {
        self.check_colliders(spheres, &[])?;
        self.sys.spheres = spheres_r(spheres);
        self.sys.sphere_base = self.work.clock;
        self.motion.set_spheres(self.time, spheres);
        Ok(())
    }

    /// Replaces the capsule colliders, as [`CpuSolver::set_spheres`] the
    /// spheres.
    pub fn set_capsules(&mut self, capsules: &[Capsule]) -> Result<()> {
        self.check_colliders(&[], capsules)?;
        self.sys.capsules = capsules_r(capsules);
        self.sys.capsule_base = self.work.clock;
        self.motion.set_capsules(self.time, capsules);
        Ok(())
    }

    /// Moves the mesh colliders to `poses`, one per collider in the order
    /// the scene gives them (their meshes stay); each moves at its velocity
    /// from its pose from now on, as [`CpuSolver::set_spheres`] a sphere.
    pub fn set_mesh_colliders(&mut self, poses: &[crate::sdf::MeshPose]) -> Result<()> {
        let moved = crate::sdf::posed(&self.mesh_colliders, poses)?;
        self.sys.mesh_colliders = mesh_colliders_r(&moved);
        self.sys.mesh_base = self.work.clock;
        self.motion.set_mesh_colliders(self.time, &moved);
        self.mesh_colliders = moved;
        Ok(())
    }

    /// Validates colliders as [`Params::validate`] does.
    fn check_colliders(&self, spheres: &[Sphere], capsules: &[Capsule]) -> Result<()> {
        Params {
            spheres: spheres.to_vec(),
            capsules: capsules.to_vec(),
            ..Params::default()
        }
        .validate()
    }

    /// Pins (`true`) or releases (`false`) particle `p`. A newly pinned
    /// particle stops where it is; a released one keeps its velocity (a
    /// flick). A semi-implicit solver rebuilds its filter.
    pub fn set_pinned(&mut self, p: usize, pinned: bool) -> Result<()> {
        let n = self.sys.mass.len();
        if p >= n {
            return Err(Error::InvalidParameter {
                key: "particle".into(),
                allowed: format!("an index below {n}"),
                got: p.to_string(),
            });
        }
        if (self.sys.inv_mass[p] <= R::ZERO) == pinned {
            return Ok(());
        }
        let before = (self.sys.inv_mass[p], self.sys.pinned_count);
        if pinned {
            self.sys.inv_mass[p] = R::ZERO;
            self.sys.pinned_count += 1;
            self.state.v[p] = Vec3::ZERO;
        } else {
            self.sys.inv_mass[p] = R::ONE / self.sys.mass[p];
            self.sys.pinned_count -= 1;
        }
        self.work.pin_goal[p] = motion::PinGoal::default();
        if self.integrator == Integrator::SemiImplicit {
            if let Err(e) = self.build_filter() {
                (self.sys.inv_mass[p], self.sys.pinned_count) = before;
                return Err(e);
            }
        }
        if pinned {
            let x = glam::DVec3::from_array(self.state.x[p].to_f64());
            self.motion.pin(p, Some(x), self.time);
        } else {
            self.motion.release(p);
        }
        Ok(())
    }

    /// Sets where pinned particles are to be after `frame_seconds` \[s\] of
    /// simulated time: each moves at constant velocity over the frame's
    /// steps (the nearest whole number of steps, at least one) and lands on
    /// its target at the last of them (see [`motion`]). An index out of
    /// range, an unpinned particle or a non-finite position is an error
    /// naming it, and then nothing is changed.
    pub fn set_pin_targets(&mut self, targets: &[PinTarget], frame_seconds: f64) -> Result<()> {
        let steps = crate::params::frame_steps(frame_seconds, self.sys.dt.to_f64())?;
        let inv_mass = &self.sys.inv_mass;
        crate::params::check_pin_targets(targets, |p| inv_mass[p] <= R::ZERO, inv_mass.len())?;
        let end = self.work.clock.wrapping_add(steps);
        for t in targets {
            self.work.pin_goal[t.particle] = motion::PinGoal {
                position: Vec3::from_f64(t.position.as_dvec3()),
                end,
            };
        }
        let duration = f64::from(steps) * self.sys.dt.to_f64();
        self.motion.set_pin_targets(self.time, targets, duration);
        Ok(())
    }

    /// Changes the time step \[s\]; a semi-implicit solver rebuilds its filter.
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        crate::params::check_dt(dt)?;
        self.sys.dt = R::from_f64(dt);
        if self.integrator == Integrator::SemiImplicit {
            self.build_filter()?;
        }
        Ok(())
    }
}
