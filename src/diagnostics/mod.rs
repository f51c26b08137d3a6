//! Energy and strain measures, the same for every backend: they take
//! positions and velocities in any precision (glam's `Vec3` or `DVec3`,
//! see [`Vector`]) and accumulate in `f64`; and
//! [`Divergence`], the one rule that says a simulation has blown up, with
//! the record of moving bodies it bounds the work of ([`Motion`]).

mod motion;

pub use motion::{Motion, Reach};

use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::Params;
use crate::real::Vector;

/// Energy of a state \[J\], split by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `Σ ½ m |v|²` over free particles.
    pub kinetic: f64,
    /// `−Σ m g·x` (zero at the origin).
    pub gravitational: f64,
    /// `Σ ½ k (l − L)²` over all springs.
    pub elastic: f64,
}

impl Energy {
    /// Total mechanical energy \[J\].
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravitational + self.elastic
    }
}

/// Energy of positions `x` and velocities `v`.
pub fn energy<V: Vector>(model: &Model, params: &Params, x: &[V], v: &[V]) -> Energy {
    let g = params.gravity;
    let mut e = Energy::default();
    for p in 0..model.particle_count() {
        let m = model.mass[p];
        let [px, py, pz] = x[p].to_f64();
        e.gravitational -= m * (g[0] * px + g[1] * py + g[2] * pz);
        if !model.pinned[p] {
            let [vx, vy, vz] = v[p].to_f64();
            e.kinetic += 0.5 * m * (vx * vx + vy * vy + vz * vz);
        }
    }
    for (n, s) in model.springs.iter().enumerate() {
        let k = model.spring_constants(n, params).k;
        let c = length(x, s.i, s.j) - s.rest;
        e.elastic += 0.5 * k * c * c;
    }
    e
}

fn length<V: Vector>(x: &[V], i: u32, j: u32) -> f64 {
    let [ax, ay, az] = x[i as usize].to_f64();
    let [bx, by, bz] = x[j as usize].to_f64();
    ((ax - bx).powi(2) + (ay - by).powi(2) + (az - bz).powi(2)).sqrt()
}

/// Largest strain `(l − L) / L` over the springs of the kinds selected by
/// `kinds` (indexed by [`crate::params::SpringKind::index`]); zero-length
/// rest springs are skipped. Negative when everything is compressed.
pub fn max_strain<V: Vector>(model: &Model, x: &[V], kinds: [bool; 3]) -> f64 {
    model
        .springs
        .iter()
        .filter(|s| kinds[s.kind.index()] && s.rest > 0.0)
        .map(|s| (length(x, s.i, s.j) - s.rest) / s.rest)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Largest stretch-spring strain: the number a user means by "how far did
/// the cloth stretch".
pub fn max_stretch_strain<V: Vector>(model: &Model, x: &[V]) -> f64 {
    max_strain(model, x, [true, false, false])
}

/// Steps between two divergence checks of a driver that checks
/// periodically (`wgcloth run`, `bench stability`): a check costs about one
/// step (the energy and strain walk every spring, and the GPU reads its
/// state back), so checking every step would double a run's time, while a
/// divergence grows geometrically and is still far from overflowing `f32`
/// ten steps after it crosses a bound.
pub const CHECK_EVERY: u64 = 10;

/// Fraction of the energy scale (see [`Divergence`]) the total energy may
/// exceed its bound by. Symplectic Euler's energy oscillates by `O(dt)`
/// around the exact value and the fix-up and collisions move particles by
/// small amounts; a divergence grows without bound, so it soon passes any
/// margin of this size. Half the work gravity does dropping the whole cloth
/// by its side is far above the oscillation of a stable run (the stability
/// sweep's rule, unchanged).
pub const ENERGY_MARGIN: f64 = 0.5;

/// Smallest energy margin \[J\]: only matters for a cloth with no gravity,
/// no wind and no initial motion or stretch, whose energy scale is zero.
/// Such a cloth cannot gain energy physically, but its springs' lengths
/// round differently from their rest lengths in `f32`; a microjoule is far
/// above that rounding and far below any cloth that moves (a gram dropped
/// by a millimetre is ten microjoules).
pub const ENERGY_FLOOR: f64 = 1e-6;

/// Largest stretch strain `(l − L) / L` of a cloth that has not diverged,
/// as `wgcloth run` and `wgcloth render` apply it: a spring at eleven
/// times its rest length. Soft cloths legitimately pass 100 %: the
/// `hanging` scene at 0.3 N/m (100× softer than the scene, implicit, no
/// fix-up, no floor) reaches 590 % under its own weight. A divergence
/// without fix-up grows geometrically and passes this bound a few steps
/// after it passes 100 %; with the fix-up holding the lengths, it is the
/// energy bound that catches it.
pub const DIVERGED_STRAIN: f64 = 10.0;

/// Which bound of [`Divergence`] a finite state crossed, with the numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crossed {
    /// Total energy above the energy bound.
    Energy {
        /// Total energy ([`Energy::total`]) \[J\].
        total: f64,
        /// The bound at that time \[J\].
        limit: f64,
    },
    /// A stretch spring strained past the strain bound.
    Strain {
        /// The largest stretch strain (`1.0` = 100 %).
        strain: f64,
        /// The bound (`1.0` = 100 %).
        limit: f64,
    },
}

impl std::fmt::Display for Crossed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Crossed::Energy { total, limit } => write!(
                f,
                "its total energy ({} J) passed the energy bound ({} J: the initial energy, \
                 the work external forces can have done and a margin)",
                Joules(total),
                Joules(limit)
            ),
            Crossed::Strain { strain, limit } => write!(
                f,
                "a stretch spring is at {:.1} % strain, past the strain bound of {:.0} %",
                strain * 100.0,
                limit * 100.0
            ),
        }
    }
}

/// An energy for a message: fixed-point where that reads well, else in
/// scientific notation (a blow-up reaches 10⁸⁰ J).
struct Joules(f64);

impl std::fmt::Display for Joules {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if (1e-3..1e6).contains(&self.0.abs()) {
            write!(f, "{:.4}", self.0)
        } else {
            write!(f, "{:.4e}", self.0)
        }
    }
}

/// The one rule that says a simulation has diverged (blown up), the same
/// for every backend and every command.
///
/// Built from the model, the parameters and the state at the time checking
/// starts (usually the initial state). A state has diverged when
/// 1. a position or velocity is not finite ([`Error::NonFinite`]); or
/// 2. its total energy ([`energy`]: kinetic + gravitational + elastic)
///    exceeds `E₀ + W_wind(t) + W_motion(t) + max(ENERGY_MARGIN · S,
///    ENERGY_FLOOR)` ([`Crossed::Energy`]); or
/// 3. its largest stretch strain exceeds the strain bound
///    ([`DIVERGED_STRAIN`] unless set by [`Divergence::with_max_strain`];
///    [`Crossed::Strain`]).
///
/// Gravity is inside the total, and damping, the ground and colliders at
/// rest only take energy out, so without wind or moving bodies a physical
/// run never exceeds `E₀`. Wind can feed energy in; its work since the
/// start is bounded by
/// `W_wind(t) = ½ M_free |w|² + (c_d + c_l) · A · |w|³ · t`: the kinetic
/// energy of the free particles carried along at the wind's speed, plus
/// the power of the whole rest area `A` facing the wind at full speed
/// (force `(c_d + c_l) A |w|²`) moving at the wind's speed. For drag the
/// power term is a strict bound while the cloth's area is under 27/4 of its
/// rest area: a triangle's drag power, `c_d A (|w_n| u_n² − |u_n|³)` for a
/// relative normal speed `u_n`, is at most `(4/27) c_d A |w|³` whatever the
/// cloth's velocity. Lift does no work against the relative flow; its
/// power on the wind's side, `c_l A |u_n| |u_t| |w|`, stays under
/// `c_l A |w|³` while the cloth's speed relative to the air is of the
/// wind's order. The energy scale `S = M·|g|·L + K₀ + U₀ + ½ M_free |w|²`
/// (`M` the cloth's mass, `L` the largest side of its rest bounding box,
/// `K₀` and `U₀` the initial kinetic and elastic energies) sizes the
/// margin to the cloth.
///
/// Moving bodies — spheres and capsules with a velocity or moved by a
/// host, pins moving to their targets — do work on the cloth, bounded from
/// the [`Reach`] of the bodies ([`Motion`]: the fastest speed `U` any of
/// them has had, the largest total change of velocity `V = Σ |Δu|` of any
/// one of them (its start from rest included), the highest point `h_top` a
/// moving collider has reached, the most `Δh` a pin has risen):
/// `W_motion = ½ M_free W² + M_free W v_S + M |g| H`, with `W = U + V`,
/// `v_S = √(2 S / M_free)` and `H = max(Δh, h_top − y₀, 0)` (`y₀` the
/// lowest particle at the start, heights along `−g`).
/// - Carrying and flinging: a contact never increases a particle's speed
///   relative to the body, and a pin moves its particle with it, so in the
///   frame of a body at constant velocity the cloth moves as by a body at
///   rest, at speeds of its own scale `v_S`; each change `Δu` of the
///   body's velocity shifts every relative velocity by `Δu` (a cape whose
///   pins jerk to `u` swings its hem to `2u`). World speeds stay under
///   `v_S + W`, and the kinetic energy above the cloth's own under the
///   first two terms.
/// - Lifting: a collider lifts the cloth no higher than its top, pins by
///   their rise.
/// - Stretching: pins that move relative to each other stretch the cloth
///   between them; a rigid motion (a character walking and turning) does
///   not. That energy is not in the bound: the strain bound caps it, and
///   pins dragged apart by more than the margin allows are a blow-up (see
///   `docs/integrators.md`).
///
/// The term grows with the bodies' speeds and heights, not with the
/// cloth's state, so a real blow-up next to a moving body, which grows
/// geometrically, still passes it within a few steps.
///
/// A driver checks every [`CHECK_EVERY`] steps and at its last step with
/// [`Divergence::check`] (moving bodies as the parameters set them from
/// time zero) or [`Divergence::check_with`] (the bodies as a solver moved
/// them), or lets the solver do it: [`crate::cpu::CpuSolver::check_divergence`],
/// [`crate::gpu::GpuSolver::check_divergence`] and
/// [`crate::gpu::GpuBatch::check_divergence`] keep their own [`Motion`],
/// told by every setter that moves a body. Build a new rule after changing
/// gravity, wind, masses or pins.
#[derive(Clone, Debug)]
pub struct Divergence {
    model: Model,
    params: Params,
    /// Time the rule starts from \[s\].
    start: f64,
    /// `E₀` \[J\].
    initial: f64,
    /// `E₀ + ½ M_free |w|² + margin` \[J\].
    base: f64,
    /// Bound on the wind's power `(c_d + c_l) A |w|³` \[W\].
    wind_power: f64,
    /// Mass of the free particles `M_free` \[kg\].
    free_mass: f64,
    /// Mass of the cloth `M` \[kg\].
    total_mass: f64,
    /// `|g|` [m/s²].
    gravity: f64,
    /// The cloth's own speed scale `v_S = √(2 S / M_free)` [m/s].
    own_speed: f64,
    /// The lowest particle at the start, along `−g` \[m\] (`y₀`).
    lowest: f64,
    /// The moving bodies as the parameters set them from time zero.
    motion: Motion,
    /// Strain bound (`1.0` = 100 %).
    max_strain: f64,
}

impl Divergence {
    /// The rule for `model` with `params`, starting at `time` \[s\] from the
    /// state `x` \[m\], `v` [m/s] (particle order).
    pub fn new<V: Vector>(model: &Model, params: &Params, time: f64, x: &[V], v: &[V]) -> Self {
        let e0 = energy(model, params, x, v);
        let g = params.gravity.length();
        let total_mass: f64 = model.mass.iter().sum();
        let free_mass: f64 = (0..model.particle_count())
            .filter(|&p| !model.pinned[p])
            .map(|p| model.mass[p])
            .sum();
        let (wind_kinetic, wind_power) = match &params.wind {
            Some(w) => {
                let speed = w.velocity.length();
                (
                    0.5 * free_mass * speed * speed,
                    (w.drag + w.lift) * rest_area(model) * speed.powi(3),
                )
            }
            None => (0.0, 0.0),
        };
        let scale = total_mass * g * rest_side(model) + e0.kinetic + e0.elastic + wind_kinetic;
        let margin = (ENERGY_MARGIN * scale).max(ENERGY_FLOOR);
        let own_speed = if free_mass > 0.0 {
            (2.0 * scale / free_mass).sqrt()
        } else {
            0.0
        };
        let up = if g > 0.0 {
            -params.gravity / g
        } else {
            glam::DVec3::ZERO
        };
        let lowest = x
            .iter()
            .map(|p| glam::DVec3::from_array(p.to_f64()).dot(up))
            .fold(f64::INFINITY, f64::min);
        Divergence {
            model: model.clone(),
            params: params.clone(),
            start: time,
            initial: e0.total(),
            base: e0.total() + wind_kinetic + margin,
            wind_power,
            free_mass,
            total_mass,
            gravity: g,
            own_speed,
            lowest,
            motion: Motion::new(model, params),
            max_strain: DIVERGED_STRAIN,
        }
    }

    /// The same rule with another strain bound (`1.0` = 100 %): `bench
    /// stability` holds a cloth to 100 %, stricter than a run.
    pub fn with_max_strain(mut self, max_strain: f64) -> Self {
        self.max_strain = max_strain;
        self
    }

    /// Total energy at the start \[J\].
    pub fn initial_energy(&self) -> f64 {
        self.initial
    }

    /// The energy bound at `time` \[s\] \[J\], with the bodies moving as
    /// the parameters set them from time zero.
    pub fn energy_limit(&self, time: f64) -> f64 {
        self.energy_limit_with(time, &self.motion)
    }

    /// The energy bound at `time` \[s\] \[J\] with the bodies as `motion`
    /// has them.
    pub fn energy_limit_with(&self, time: f64, motion: &Motion) -> f64 {
        self.base + self.wind_power * (time - self.start).max(0.0) + self.motion_work(time, motion)
    }

    /// `W_motion` \[J\]: the bound on the work the bodies as `motion` has
    /// them can have done by `time` \[s\] (zero when nothing moves).
    pub fn motion_work(&self, time: f64, motion: &Motion) -> f64 {
        let Reach {
            speed,
            change,
            top,
            rise,
        } = motion.reach(time);
        let w = speed + change;
        let lift = rise.max(top - self.lowest).max(0.0);
        0.5 * self.free_mass * w * w
            + self.free_mass * w * self.own_speed
            + self.total_mass * self.gravity * lift
    }

    /// The strain bound (`1.0` = 100 %).
    pub fn max_strain(&self) -> f64 {
        self.max_strain
    }

    /// The bound a finite state `x`, `v` at `time` \[s\] crosses (energy
    /// first), if any, with the bodies moving as the parameters set them.
    pub fn crossed<V: Vector>(&self, time: f64, x: &[V], v: &[V]) -> Option<Crossed> {
        self.crossed_with(time, x, v, &self.motion)
    }

    /// [`Divergence::crossed`] with the bodies as `motion` has them.
    pub fn crossed_with<V: Vector>(
        &self,
        time: f64,
        x: &[V],
        v: &[V],
        motion: &Motion,
    ) -> Option<Crossed> {
        let total = energy(&self.model, &self.params, x, v).total();
        let limit = self.energy_limit_with(time, motion);
        // A finite state's energy can still overflow (+∞ kinetic, −∞
        // gravitational: NaN); that is past the bound too.
        if total > limit || total.is_nan() {
            return Some(Crossed::Energy { total, limit });
        }
        let strain = max_stretch_strain(&self.model, x);
        if strain > self.max_strain || strain.is_nan() {
            return Some(Crossed::Strain {
                strain,
                limit: self.max_strain,
            });
        }
        None
    }

    /// Applies the rule to the state after `step` (1-based) at `time` \[s\]:
    /// [`Error::NonFinite`] naming the first non-finite particle, or
    /// [`Error::Diverged`] naming the bound crossed. The bodies move as the
    /// parameters set them from time zero: a driver that moves them
    /// ([`crate::scene::animation::Animation`], `set_spheres`, pin targets)
    /// checks with the solver's record instead ([`Divergence::check_with`]
    /// or the solver's `check_divergence`).
    pub fn check<V: Vector>(&self, step: u64, time: f64, x: &[V], v: &[V]) -> Result<()> {
        self.check_with(step, time, x, v, &self.motion)
    }

    /// [`Divergence::check`] with the bodies as `motion` has them (a
    /// solver's record: `motion()` on [`crate::cpu::CpuSolver`],
    /// [`crate::gpu::GpuSolver`], [`crate::gpu::GpuBatch`]).
    pub fn check_with<V: Vector>(
        &self,
        step: u64,
        time: f64,
        x: &[V],
        v: &[V],
        motion: &Motion,
    ) -> Result<()> {
        if let Some(particle) = first_non_finite(x, v) {
            return Err(Error::NonFinite {
                step,
                time,
                particle,
            });
        }
        match self.crossed_with(time, x, v, motion) {
            Some(crossed) => Err(Error::Diverged {
                step,
                time,
                crossed,
            }),
            None => Ok(()),
        }
    }
}

/// The first particle whose position or velocity is not finite.
pub fn first_non_finite<V: Vector>(x: &[V], v: &[V]) -> Option<usize> {
    (0..x.len()).find(|&p| !(x[p].is_finite() && v[p].is_finite()))
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Total rest area of the triangles \[m²\].
fn rest_area(model: &Model) -> f64 {
    let x = &model.rest_positions;
    model
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|p| x[p as usize]);
            let (u, w) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            0.5 * norm([
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ])
        })
        .sum()
}

/// Largest side of the rest positions' bounding box \[m\].
fn rest_side(model: &Model) -> f64 {
    (0..3)
        .map(|k| {
            let (lo, hi) = model
                .rest_positions
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p[k]), hi.max(p[k]))
                });
            (hi - lo).max(0.0)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ClothSpec;
    use crate::params::Wind;
    use crate::real::Vec3;

    /// The default 33 × 33 cloth (1 m, 0.3 kg, two pins) at rest, in `f64`.
    fn at_rest(params: &Params) -> (Model, Vec<Vec3<f64>>, Vec<Vec3<f64>>) {
        let model = Model::new(&ClothSpec::default(), &params.springs).expect("valid cloth");
        let x = model
            .rest_positions
            .iter()
            .map(|&p| Vec3::from_f64(p))
            .collect();
        let v = vec![Vec3::ZERO; model.particle_count()];
        (model, x, v)
    }

    /// Relative room for the bound's own rounding in the comparisons below.
    const ROUNDING: f64 = 1e-12;

    /// Stiffness [N/m] of a cloth whose springs store next to nothing when
    /// stretched (a spring of 1/32 m at 1100 % strain: 6·10⁻⁸ J).
    const SOFT: f64 = 1e-6;

    #[test]
    fn a_non_finite_state_names_its_first_particle() {
        let params = Params::default();
        let (model, x, mut v) = at_rest(&params);
        let rule = Divergence::new(&model, &params, 0.0, &x, &v);
        v[40] = Vec3::new(0.0, f64::NAN, 0.0);
        v[41] = Vec3::new(f64::INFINITY, 0.0, 0.0);
        match rule.check(12, 0.12, &x, &v) {
            Err(Error::NonFinite {
                step: 12,
                particle: 40,
                ..
            }) => {}
            other => panic!("expected particle 40, got {other:?}"),
        }
    }

    #[test]
    fn wind_raises_the_energy_bound_by_the_work_it_can_do() {
        let mut params = Params::default();
        let wind = Wind {
            velocity: glam::DVec3::new(3.0, 0.0, 4.0),
            drag: 0.6,
            lift: 0.1,
        };
        let (model, x, v) = at_rest(&params);
        let calm = Divergence::new(&model, &params, 0.0, &x, &v);
        params.wind = Some(wind);
        let windy = Divergence::new(&model, &params, 2.0, &x, &v);
        // |w| = 5 m/s: the 1087 free particles of 0.3/1089 kg each carried
        // at the wind's speed, counted once as work and again, times the
        // margin, in the energy scale.
        let free_mass = 0.3 * (1087.0 / 1089.0);
        let carried = 0.5 * free_mass * 25.0;
        let at_start = calm.energy_limit(0.0) + carried * (1.0 + ENERGY_MARGIN);
        assert!((windy.energy_limit(2.0) - at_start).abs() <= ROUNDING * at_start);
        // Then (c_d + c_l) · 1 m² · (5 m/s)³ = 87.5 W from the rule's start.
        let power = 0.7 * 125.0;
        let later = windy.energy_limit(5.0) - windy.energy_limit(2.0);
        assert!((later - 3.0 * power).abs() <= ROUNDING * later, "{later} J");
    }

    #[test]
    fn the_message_names_the_bound_and_its_numbers() {
        let e = Error::Diverged {
            step: 30,
            time: 0.3,
            crossed: Crossed::Energy {
                total: 681.25,
                limit: 4.4145,
            },
        }
        .to_string();
        assert!(e.contains("step 30") && e.contains("energy bound"), "{e}");
        assert!(e.contains("681.2500 J") && e.contains("4.4145 J"), "{e}");
        let e = Crossed::Energy {
            total: 1.5e81,
            limit: 4.0,
        }
        .to_string();
        assert!(e.contains("1.5000e81 J"), "{e}");
        let e = Crossed::Strain {
            strain: 12.5,
            limit: DIVERGED_STRAIN,
        }
        .to_string();
        assert!(
            e.contains("1250.0 %") && e.contains("strain bound of 1000 %"),
            "{e}"
        );
    }

    #[test]
    fn the_energy_bound_is_the_initial_energy_plus_half_the_drop_of_the_cloth() {
        let params = Params::default();
        let (model, x, v) = at_rest(&params);
        let rule = Divergence::new(&model, &params, 0.0, &x, &v);
        let e0 = energy(&model, &params, &x, &v).total();
        // 0.3 kg · 9.81 m/s² · 1 m: the cloth dropped by its side.
        let drop = 0.3 * 9.81 * 1.0;
        let expected = e0 + ENERGY_MARGIN * drop;
        assert!((rule.energy_limit(0.0) - expected).abs() <= ROUNDING * expected);
        // Without wind the bound does not grow with time.
        assert_eq!(rule.energy_limit(100.0), rule.energy_limit(0.0));
        assert_eq!(rule.check(0, 0.0, &x, &v).ok(), Some(()));
    }

    #[test]
    fn a_finite_state_past_each_bound_is_named() {
        let params = Params::default();
        let (model, x, v) = at_rest(&params);
        let rule = Divergence::new(&model, &params, 0.0, &x, &v);
        let limit = rule.energy_limit(0.0);
        let free = (0..model.particle_count())
            .find(|&p| !model.pinned[p])
            .expect("a free particle");

        // One free particle moving fast enough to carry the whole margin.
        let mut fast = v.clone();
        let speed = (2.0 * (limit - rule.initial_energy()) / model.mass[free]).sqrt() * 1.01;
        fast[free] = Vec3::new(speed, 0.0, 0.0);
        match rule.check(7, 0.07, &x, &fast) {
            Err(Error::Diverged {
                step: 7,
                crossed: Crossed::Energy { total, limit: l },
                ..
            }) => assert!(total > l && l == limit, "{total} J against {l} J"),
            other => panic!("expected the energy bound, got {other:?}"),
        }

        // One stretch spring pulled past the strain bound, on a cloth so
        // soft that its elastic energy stays far under the energy bound.
        let mut soft = params.clone();
        for kind in &mut soft.springs {
            kind.stiffness = SOFT;
        }
        let (model, x, v) = at_rest(&soft);
        let rule = Divergence::new(&model, &soft, 0.0, &x, &v);
        let s = model
            .springs
            .iter()
            .find(|s| s.kind.index() == 0 && !model.pinned[s.j as usize])
            .expect("a stretch spring");
        let mut stretched = x.clone();
        let far = s.rest * (1.0 + DIVERGED_STRAIN * 1.01);
        stretched[s.j as usize] = x[s.i as usize] + Vec3::new(0.0, -far, 0.0);
        match rule.check(3, 0.03, &stretched, &v) {
            Err(Error::Diverged {
                crossed: Crossed::Strain { strain, limit },
                ..
            }) => assert!(strain > limit && limit == DIVERGED_STRAIN, "{strain}"),
            other => panic!("expected the strain bound, got {other:?}"),
        }
        // The bench's stricter bound is the same rule with another number.
        let mut sagging = x.clone();
        sagging[s.j as usize] = x[s.i as usize] + Vec3::new(0.0, -s.rest * 2.5, 0.0);
        assert_eq!(rule.crossed(0.0, &sagging, &v), None);
        assert!(matches!(
            rule.clone().with_max_strain(1.0).crossed(0.0, &sagging, &v),
            Some(Crossed::Strain { .. })
        ));
    }
}
