//! Simulation parameters: everything that is not topology or state.
//!
//! These are the validated, in-memory form of a scene file's
//! `[simulation]`, `[springs.*]`, `[fixup]`, `[implicit]`, `[semi_implicit]`,
//! `[ground]`, `[[sphere]]`, `[[capsule]]`, `[wind]` and `[self_collision]` tables. [`Params::validate`] is the
//! single place that decides what is physically admissible; the scene loader
//! and the library API both go through it, so a parameter that passes here
//! never needs re-checking inside a solver.

use std::fmt;

use glam::DVec3;

use crate::error::{Error, Result};

/// Which time integrator steps the cloth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Integrator {
    /// Symplectic Euler plus Provot deformation constraints.
    Explicit,
    /// Baraff–Witkin linearised backward Euler solved by filtered PCG.
    Implicit,
    /// Desbrun's constant-filter split with torque compensation and fix-up.
    SemiImplicit,
}

impl Integrator {
    /// All integrators, in a fixed order (for tables and sweeps).
    pub const ALL: [Integrator; 3] = [
        Integrator::Explicit,
        Integrator::Implicit,
        Integrator::SemiImplicit,
    ];

    /// The scene-file / CLI spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Integrator::Explicit => "explicit",
            Integrator::Implicit => "implicit",
            Integrator::SemiImplicit => "semi-implicit",
        }
    }

    /// Parses the scene-file / CLI spelling.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.as_str() == s)
    }
}

impl fmt::Display for Integrator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The three kinds of spring a grid cloth has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SpringKind {
    /// 4-neighbourhood (rows and columns).
    Stretch = 0,
    /// Diagonals of each grid cell.
    Shear = 1,
    /// Skip-one along rows and columns.
    Bend = 2,
}

impl SpringKind {
    /// All kinds, in index order.
    pub const ALL: [SpringKind; 3] = [SpringKind::Stretch, SpringKind::Shear, SpringKind::Bend];

    /// Index into per-kind tables.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The scene-file spelling (`[springs.<name>]`).
    pub fn as_str(self) -> &'static str {
        match self {
            SpringKind::Stretch => "stretch",
            SpringKind::Shear => "shear",
            SpringKind::Bend => "bend",
        }
    }
}

/// Material of one spring kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringParams {
    /// Stiffness `k` [N/m]. Zero means this kind has no springs at all.
    pub stiffness: f64,
    /// Damping `kd` [N·s/m] along the spring (Baraff–Witkin form).
    pub damping: f64,
    /// Largest allowed length as a multiple of the rest length (e.g. `1.1`
    /// for 10 % stretch). `None`: springs of this kind are not fixed up.
    pub max_stretch: Option<f64>,
}

impl SpringParams {
    /// No springs of this kind.
    pub const NONE: SpringParams = SpringParams {
        stiffness: 0.0,
        damping: 0.0,
        max_stretch: None,
    };
}

/// How the Provot fix-up visits the springs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FixupMethod {
    /// Springs in sequence, each seeing the previous one's corrections
    /// (the article's method; converges fastest, inherently serial).
    GaussSeidel,
    /// Every particle averages the corrections of its over-stretched springs
    /// computed from one snapshot (what the GPU does).
    Jacobi,
}

impl FixupMethod {
    /// The scene-file spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            FixupMethod::GaussSeidel => "gauss-seidel",
            FixupMethod::Jacobi => "jacobi",
        }
    }
}

/// What self-collision's contacts are between (`[self_collision] method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ContactMethod {
    /// Particle against particle, layers a thickness of at least the
    /// cloth's largest rest triangle gap apart (`src/cpu/self_collision.rs`).
    Particles,
    /// Vertex against triangle and edge against edge, at any thickness from
    /// [`crate::self_collision::MIN_THICKNESS`] up, no crossing
    /// (`src/cpu/triangle_contact.rs`); the CPU solvers only, so far.
    Triangles,
}

impl ContactMethod {
    /// The scene-file spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            ContactMethod::Particles => "particles",
            ContactMethod::Triangles => "triangles",
        }
    }
}

/// Deformation-constraint (fix-up) settings, used by the explicit and
/// semi-implicit integrators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixupParams {
    /// Maximum number of passes over the springs; the fix-up stops earlier
    /// once no constrained spring is over its limit. `0` disables it.
    pub iterations: u32,
    /// Gauss–Seidel or Jacobi.
    pub method: FixupMethod,
    /// Jacobi over-relaxation factor `ω` (dimensionless, `0 < ω < 2`);
    /// ignored by Gauss–Seidel.
    pub omega: f64,
}

/// Conjugate-gradient settings of the implicit integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImplicitParams {
    /// Relative tolerance on the preconditioned residual norm
    /// (`sqrt(rᵀP⁻¹r / r₀ᵀP⁻¹r₀)`), dimensionless.
    pub tolerance: f64,
    /// Hard cap on CG iterations per step.
    pub max_iterations: u32,
    /// Add the coarse levels (`cpu/coarse.rs`) to the block-Jacobi
    /// preconditioner on a grid cloth: fewer CG iterations to the same
    /// tolerance (the stopping test stays the block-Jacobi residual norm
    /// above). No effect on a cloth that is not a grid. The GPU's
    /// CG-solved semi-implicit filter takes them too.
    pub coarse_levels: bool,
}

/// Largest free-particle count for which [`FilterMethod::Auto`] picks the
/// dense filter, on either backend: a dense `W` of this size is 16 MiB in
/// `f32` (32 MiB in `f64`). This is the GPU's crossover — there a dense
/// product is one fully parallel pass and a triangular solve is sequential
/// — and the CPU follows it so its `f32` mirror applies the filter as the
/// GPU does. On the CPU alone the banded factor is faster at every size
/// (`docs/performance.md`, "Dense or banded filter"). The article's sizes
/// (15², 25², 33²) all stay dense.
pub const DENSE_FILTER_MAX_PARTICLES: usize = 1 << 11;

/// How the semi-implicit integrator applies its constant filter `W`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterMethod {
    /// Dense when the free particle count is at most
    /// [`DENSE_FILTER_MAX_PARTICLES`], banded otherwise.
    Auto,
    /// The explicit inverse `W`, `N²` numbers: the article's method.
    Dense,
    /// A banded Cholesky factor of `W⁻¹`, `O(N·bandwidth)` numbers.
    Banded,
}

impl FilterMethod {
    /// Whether the filter is dense for this many free particles, on either
    /// backend (`Auto`: up to [`DENSE_FILTER_MAX_PARTICLES`]; the GPU also
    /// needs the matrix to fit its buffers, else it solves by CG).
    pub fn is_dense(self, free: usize) -> bool {
        match self {
            FilterMethod::Dense => true,
            FilterMethod::Banded => false,
            FilterMethod::Auto => free <= DENSE_FILTER_MAX_PARTICLES,
        }
    }

    /// The scene-file spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            FilterMethod::Auto => "auto",
            FilterMethod::Dense => "dense",
            FilterMethod::Banded => "banded",
        }
    }
}

/// Semi-implicit (Desbrun) settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SemiImplicitParams {
    /// How the filter is stored and applied.
    pub filter: FilterMethod,
    /// Remove the spurious torque the linear split adds: per spring for
    /// every cloth, and the net torque of a cloth without pins.
    pub torque_compensation: bool,
}

/// A horizontal ground plane `y = height`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// Height of the plane \[m\].
    pub height: f64,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`).
    pub friction: f64,
}

/// A sphere collider, moving at a constant velocity from `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre \[m\] when the sphere was set (the solver's start, or the
    /// last `set_spheres`).
    pub center: DVec3,
    /// Radius \[m\], `> 0`.
    pub radius: f64,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`), acting on the
    /// particle's velocity relative to the sphere's.
    pub friction: f64,
    /// Velocity [m/s] (zero: static).
    pub velocity: DVec3,
}

/// A capsule collider: the points within `radius` of the segment `a`–`b`,
/// moving at a constant velocity from where it was set. `a == b` is a
/// sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// One end of the segment \[m\] when the capsule was set.
    pub a: DVec3,
    /// The other end \[m\].
    pub b: DVec3,
    /// Radius \[m\], `> 0`.
    pub radius: f64,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`), acting on the
    /// particle's velocity relative to the capsule's.
    pub friction: f64,
    /// Velocity [m/s] of the whole capsule (zero: static).
    pub velocity: DVec3,
}

/// Where a pinned particle is to be at the end of a frame
/// (`set_pin_targets` on [`crate::GpuSolver`] and [`crate::CpuSolver`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinTarget {
    /// The pinned particle's index.
    pub particle: usize,
    /// Its position \[m\] after the frame's simulated time.
    pub position: glam::Vec3,
}

/// How many steps of `dt` \[s\] a frame of `frame_seconds` \[s\] spans
/// (the nearest whole number, at least one): the steps after which the
/// pins are on their targets. Both solvers' `set_pin_targets` take it.
pub fn frame_steps(frame_seconds: f64, dt: f64) -> Result<u32> {
    let steps = (frame_seconds / dt).round();
    if frame_seconds.is_finite()
        && frame_seconds > 0.0
        && steps < f64::from(crate::kernel_config::MAX_FRAME_STEPS)
    {
        Ok(steps.max(1.0) as u32)
    } else {
        Err(Error::InvalidParameter {
            key: "frame_seconds".into(),
            allowed: format!(
                "a time > 0 s of fewer than {} steps of {dt} s",
                crate::kernel_config::MAX_FRAME_STEPS
            ),
            got: frame_seconds.to_string(),
        })
    }
}

/// Checks pin targets against the particles: each index below `count`,
/// each particle pinned, each position finite. Nothing is changed when
/// one is refused.
pub fn check_pin_targets(
    targets: &[PinTarget],
    pinned: impl Fn(usize) -> bool,
    count: usize,
) -> Result<()> {
    for t in targets {
        let got = t.particle.to_string();
        if t.particle >= count {
            return Err(Error::InvalidParameter {
                key: "pin target particle".into(),
                allowed: format!("an index below {count}"),
                got,
            });
        }
        if !pinned(t.particle) {
            return Err(Error::InvalidParameter {
                key: "pin target particle".into(),
                allowed: "a pinned particle (set_pinned(p, true) first)".into(),
                got,
            });
        }
        if !t.position.is_finite() {
            return Err(Error::InvalidParameter {
                key: format!("pin target position of particle {}", t.particle),
                allowed: "finite coordinates (m)".into(),
                got: format!("{:?}", t.position.to_array()),
            });
        }
    }
    Ok(())
}

/// A uniform wind acting on the cloth's triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wind {
    /// Air velocity [m/s].
    pub velocity: DVec3,
    /// Drag coefficient along the triangle normal [kg/m³]
    /// (`½ ρ_air C_d`; air is about 1.2 kg/m³).
    pub drag: f64,
    /// Lift coefficient [kg/m³], perpendicular to the relative flow.
    pub lift: f64,
}

/// Self-collision: particle–particle contact between parts of the cloth
/// that are not neighbours at rest (`src/cpu/self_collision.rs` describes
/// the method).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfCollision {
    /// The distance \[m\] two layers keep, `> 0`; `None`: the shortest
    /// rest length of a stretch spring (the cloth's rest spacing), see
    /// `self_collision::thickness`.
    pub thickness: Option<f64>,
    /// Coulomb friction coefficient between layers (dimensionless, `≥ 0`).
    pub friction: f64,
    /// Jacobi passes over the contacts per step, `1..=100`.
    pub iterations: u32,
    /// What the contacts are between.
    pub method: ContactMethod,
}

impl Default for SelfCollision {
    /// The thickness from the rest spacing, cloth-on-cloth friction, two
    /// passes.
    fn default() -> Self {
        SelfCollision {
            thickness: None,
            friction: 0.3,
            iterations: 2,
            method: ContactMethod::Particles,
        }
    }
}

/// Every parameter of a simulation that is not the cloth's topology.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Time integrator.
    pub integrator: Integrator,
    /// Time step \[s\], `> 0`.
    pub dt: f64,
    /// Gravitational acceleration [m/s²].
    pub gravity: DVec3,
    /// Per spring kind, indexed by [`SpringKind::index`].
    pub springs: [SpringParams; 3],
    /// Deformation constraints.
    pub fixup: FixupParams,
    /// Implicit CG settings.
    pub implicit: ImplicitParams,
    /// Semi-implicit filter settings.
    pub semi_implicit: SemiImplicitParams,
    /// Optional ground plane.
    pub ground: Option<Ground>,
    /// Sphere colliders, any number.
    pub spheres: Vec<Sphere>,
    /// Capsule colliders, any number.
    pub capsules: Vec<Capsule>,
    /// Mesh colliders (`[[collider]]`), baked; at most
    /// [`MAX_MESH_COLLIDERS`](crate::kernel_config::MAX_MESH_COLLIDERS) on
    /// the GPU.
    pub mesh_colliders: Vec<crate::sdf::MeshCollider>,
    /// Optional wind.
    pub wind: Option<Wind>,
    /// Self-collision; `None`: off, and nothing of it runs.
    pub self_collision: Option<SelfCollision>,
}

impl Default for Params {
    /// A modest cloth material under standard gravity, explicit integration,
    /// no colliders and no wind.
    fn default() -> Self {
        Params {
            integrator: Integrator::Explicit,
            dt: 1.0 / 600.0,
            gravity: DVec3::new(0.0, -9.81, 0.0),
            springs: [
                SpringParams {
                    stiffness: 50.0,
                    damping: 0.05,
                    max_stretch: Some(1.1),
                },
                SpringParams {
                    stiffness: 20.0,
                    damping: 0.02,
                    max_stretch: None,
                },
                SpringParams {
                    stiffness: 5.0,
                    damping: 0.005,
                    max_stretch: None,
                },
            ],
            fixup: FixupParams {
                iterations: 10,
                method: FixupMethod::GaussSeidel,
                omega: 1.0,
            },
            implicit: ImplicitParams {
                tolerance: 1e-4,
                max_iterations: 200,
                coarse_levels: true,
            },
            semi_implicit: SemiImplicitParams {
                filter: FilterMethod::Auto,
                torque_compensation: true,
            },
            ground: None,
            spheres: Vec::new(),
            capsules: Vec::new(),
            mesh_colliders: Vec::new(),
            wind: None,
            self_collision: None,
        }
    }
}

/// Below this magnitude a number in a message is written with an exponent:
/// `0.0001` still reads at a glance, `1e-5` reads better than `0.00001`.
const PLAIN_MIN: f64 = 1e-4;
/// From this magnitude on a number in a message is written with an
/// exponent: seven digits before the point still read at a glance, and a
/// refusal of `1e300` must not print 301 digits.
const PLAIN_MAX: f64 = 1e7;

/// A number as every message shows it: the shortest text that reads back
/// as the same `f64`, with an exponent (`1e-300`, `2.5e9`) for magnitudes
/// outside `1e-4..1e7`, plainly (`0.01`, `-9.81`) otherwise; `inf`, `-inf`
/// and `NaN` as Rust spells them.
pub fn format_number(x: f64) -> String {
    let magnitude = x.abs();
    if x == 0.0 || !x.is_finite() || (PLAIN_MIN..PLAIN_MAX).contains(&magnitude) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// `x` to three significant digits, as [`format_number`] shows it: for a
/// derived quantity a message reports (a speed, a cell size), whose
/// last digits are rounding.
pub(crate) fn format_short(x: f64) -> String {
    format_number(format!("{x:.2e}").parse().unwrap_or(x))
}

/// `x > 0` rounded down to three significant digits, as
/// [`format_short`]: a bound a message advises, which must itself hold.
pub(crate) fn format_below(x: f64) -> String {
    if !(x > 0.0 && x.is_finite()) {
        return format_number(x);
    }
    let unit = 10f64.powf(x.log10().floor() - 2.0);
    format_short((x / unit).floor() * unit)
}

/// Checks that `value` is finite and `ok` holds, else the standard error:
/// "must be finite and {allowed}" for a non-finite value, so that `inf`
/// and `NaN` are told apart from a number out of range. Shared by every
/// validation of the crate, so each says it the same way.
pub(crate) fn check(key: &str, value: f64, ok: bool, allowed: &str) -> Result<()> {
    if !value.is_finite() {
        Err(invalid(key, &format!("finite and {allowed}"), value))
    } else if !ok {
        Err(invalid(key, allowed, value))
    } else {
        Ok(())
    }
}

/// Checks a time step \[s\]: `simulation.dt`'s rule, for the scene and for
/// a solver whose step changes later.
pub(crate) fn check_dt(dt: f64) -> Result<()> {
    check(
        "simulation.dt",
        dt,
        dt > 0.0 && dt <= 1.0,
        "0 < dt ≤ 1 (seconds)",
    )
}

/// Checks that `value` is finite (any finite value is allowed); `unit` is
/// the unit the message names.
pub(crate) fn check_finite(key: &str, value: f64, unit: &str) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(invalid(key, &format!("a finite number ({unit})"), value))
    }
}

/// The standard error for `key`, with `got` formatted by [`format_number`].
fn invalid(key: &str, allowed: &str, got: f64) -> Error {
    Error::InvalidParameter {
        key: key.to_string(),
        allowed: allowed.to_string(),
        got: format_number(got),
    }
}

/// Checks the three components of a vector; `unit` is their unit.
pub(crate) fn check_vec(key: &str, v: DVec3, unit: &str) -> Result<()> {
    for (c, value) in v.to_array().iter().enumerate() {
        check_finite(&format!("{key}[{c}]"), *value, unit)?;
    }
    Ok(())
}

/// Refuses a mesh collider pose (`key`: `collider[0]`) with a non-finite
/// number or a rotation that is not a unit quaternion (to 1e-6: a host's
/// `f32` quaternion is normalised to about 1e-7).
pub(crate) fn check_mesh_pose(key: &str, pose: &crate::sdf::MeshPose) -> Result<()> {
    check_vec(&format!("{key}.position"), pose.position, "m")?;
    check_vec(&format!("{key}.velocity"), pose.velocity, "m/s")?;
    check_vec(
        &format!("{key}.angular_velocity"),
        pose.angular_velocity,
        "rad/s",
    )?;
    let q = pose.rotation;
    check(
        &format!("{key}.rotation"),
        q.length(),
        q.is_finite() && (q.length() - 1.0).abs() < 1e-6,
        "a unit quaternion (a finite axis and angle)",
    )
}

/// Refuses spring kinds a solver could not run (negative or huge
/// stiffness or damping, a `max_stretch` below 1), naming each key
/// `{prefix}.<kind>.<key>` (`springs.stretch.stiffness`).
pub fn check_springs(prefix: &str, springs: &[SpringParams; 3]) -> Result<()> {
    for kind in SpringKind::ALL {
        let s = &springs[kind.index()];
        let name = kind.as_str();
        check(
            &format!("{prefix}.{name}.stiffness"),
            s.stiffness,
            (0.0..=1e9).contains(&s.stiffness),
            "0 ≤ stiffness ≤ 1e9 (N/m)",
        )?;
        check(
            &format!("{prefix}.{name}.damping"),
            s.damping,
            (0.0..=1e6).contains(&s.damping),
            "0 ≤ damping ≤ 1e6 (N·s/m)",
        )?;
        if let Some(m) = s.max_stretch {
            check(
                &format!("{prefix}.{name}.max_stretch"),
                m,
                (1.0..=10.0).contains(&m),
                "1 ≤ max_stretch ≤ 10 (multiple of the rest length)",
            )?;
        }
    }
    Ok(())
}

impl Params {
    /// Refuses anything a solver could not run: non-positive or non-finite
    /// time step, negative stiffness, NaN anywhere, a `max_stretch` below 1,
    /// a zero CG tolerance, and so on. The error names the key (scene-file
    /// spelling), what is allowed and what was given.
    pub fn validate(&self) -> Result<()> {
        check_dt(self.dt)?;
        check_vec("simulation.gravity", self.gravity, "m/s²")?;
        check_springs("springs", &self.springs)?;
        check(
            "fixup.iterations",
            f64::from(self.fixup.iterations),
            self.fixup.iterations <= 10_000,
            "0 ≤ iterations ≤ 10000",
        )?;
        check(
            "fixup.omega",
            self.fixup.omega,
            self.fixup.omega > 0.0 && self.fixup.omega < 2.0,
            "0 < omega < 2",
        )?;
        check(
            "implicit.tolerance",
            self.implicit.tolerance,
            self.implicit.tolerance > 0.0 && self.implicit.tolerance < 1.0,
            "0 < tolerance < 1 (relative)",
        )?;
        check(
            "implicit.max_iterations",
            f64::from(self.implicit.max_iterations),
            (1..=100_000).contains(&self.implicit.max_iterations),
            "1 ≤ max_iterations ≤ 100000",
        )?;
        if let Some(g) = &self.ground {
            check_finite("ground.height", g.height, "m")?;
            check(
                "ground.friction",
                g.friction,
                g.friction >= 0.0,
                "friction ≥ 0",
            )?;
        }
        for (n, s) in self.spheres.iter().enumerate() {
            check_vec(&format!("sphere[{n}].center"), s.center, "m")?;
            check(
                &format!("sphere[{n}].radius"),
                s.radius,
                s.radius > 0.0,
                "radius > 0 (m)",
            )?;
            check(
                &format!("sphere[{n}].friction"),
                s.friction,
                s.friction >= 0.0,
                "friction ≥ 0",
            )?;
            check_vec(&format!("sphere[{n}].velocity"), s.velocity, "m/s")?;
        }
        for (n, c) in self.capsules.iter().enumerate() {
            check_vec(&format!("capsule[{n}].a"), c.a, "m")?;
            check_vec(&format!("capsule[{n}].b"), c.b, "m")?;
            check(
                &format!("capsule[{n}].radius"),
                c.radius,
                c.radius > 0.0,
                "radius > 0 (m)",
            )?;
            check(
                &format!("capsule[{n}].friction"),
                c.friction,
                c.friction >= 0.0,
                "friction ≥ 0",
            )?;
            check_vec(&format!("capsule[{n}].velocity"), c.velocity, "m/s")?;
        }
        for (n, m) in self.mesh_colliders.iter().enumerate() {
            check_mesh_pose(&format!("collider[{n}]"), &m.pose())?;
            check(
                &format!("collider[{n}].friction"),
                m.friction,
                m.friction >= 0.0,
                "friction ≥ 0",
            )?;
            check(
                &format!("collider[{n}].thickness"),
                m.thickness,
                m.thickness >= 0.0,
                "thickness ≥ 0 (m)",
            )?;
        }
        if let Some(w) = &self.wind {
            check_vec("wind.velocity", w.velocity, "m/s")?;
            check("wind.drag", w.drag, w.drag >= 0.0, "drag ≥ 0 (kg/m³)")?;
            check("wind.lift", w.lift, w.lift >= 0.0, "lift ≥ 0 (kg/m³)")?;
        }
        if let Some(c) = &self.self_collision {
            if let Some(t) = c.thickness {
                check("self_collision.thickness", t, t > 0.0, "thickness > 0 (m)")?;
            }
            check(
                "self_collision.friction",
                c.friction,
                c.friction >= 0.0,
                "friction ≥ 0",
            )?;
            check(
                "self_collision.iterations",
                f64::from(c.iterations),
                (1..=100).contains(&c.iterations),
                "1 ≤ iterations ≤ 100",
            )?;
        }
        Ok(())
    }

    /// The parameters of one spring kind.
    pub fn spring(&self, kind: SpringKind) -> &SpringParams {
        &self.springs[kind.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_are_short_and_read_back_exactly() {
        for (x, text) in [
            (0.0, "0"),
            (-9.81, "-9.81"),
            (0.0001, "0.0001"),
            (1e-5, "1e-5"),
            (1e-300, "1e-300"),
            (-1e-300, "-1e-300"),
            (1234567.5, "1234567.5"),
            (1e7, "1e7"),
            (1e300, "1e300"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(format_number(x), text, "{x:e}");
            assert_eq!(text.parse::<f64>().ok(), Some(x), "{text} reads back");
        }
        assert_eq!(format_number(f64::NAN), "NaN");
        // The longest a finite f64 can print: 17 significant digits, a
        // sign, a point and a three-digit exponent.
        const LONGEST: usize = 24;
        for x in [
            f64::MAX,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE / 3.0,
            1.0 / 3.0,
        ] {
            assert!(format_number(x).len() <= LONGEST, "{}", format_number(x));
        }
    }

    #[test]
    fn a_non_finite_value_is_told_it_must_be_finite() {
        let mut p = Params::default();
        p.springs[0].stiffness = f64::INFINITY;
        let message = p.validate().expect_err("inf stiffness").to_string();
        assert!(
            message.contains("must be finite and 0 ≤ stiffness") && message.contains("got inf"),
            "{message}"
        );
        let p = Params {
            dt: -1e-300,
            ..Params::default()
        };
        let message = p.validate().expect_err("negative dt").to_string();
        assert!(message.ends_with("got -1e-300"), "{message}");
        assert!(!message.contains("finite"), "{message}");
    }

    #[test]
    fn a_frame_spans_the_nearest_whole_number_of_steps() {
        assert_eq!(frame_steps(1.0 / 60.0, 1.0 / 600.0).ok(), Some(10));
        assert_eq!(frame_steps(1e-9, 1.0 / 600.0).ok(), Some(1));
        assert!(frame_steps(0.0, 0.01).is_err());
        assert!(frame_steps(f64::NAN, 0.01).is_err());
        assert!(frame_steps(1e30, 0.01).is_err());
    }
}
