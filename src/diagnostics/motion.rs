//! The bodies that move the cloth — moving spheres and capsules, moving
//! pins — as [`Divergence`](super::Divergence) needs them: the fastest
//! speed any of them has had, the most any one of them has changed its
//! velocity, the highest a moving collider has reached and the most a pin
//! has risen. Every solver keeps one ([`Motion`]), updated by the setters
//! that move its bodies (`set_spheres`, `set_capsules`, `set_pin_targets`,
//! `set_position`, `set_pinned`), so its `check_divergence` bounds the
//! work they did without the caller keeping accounts.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::model::Model;
use crate::params::{Capsule, Params, PinTarget, Sphere};

/// How far the moving bodies have gone since a solver started, up to one
/// time: what [`Divergence`](super::Divergence) needs to bound their work.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reach {
    /// The largest speed any body has had [m/s].
    pub speed: f64,
    /// The largest total change of velocity of any one body, counting its
    /// start from rest: `Σ |Δu|` along its history [m/s].
    pub change: f64,
    /// The highest point, along `−g`, any moving collider has reached \[m\]
    /// (`−∞`: none has moved).
    pub top: f64,
    /// The most any pin has risen, along `−g`, above where it was pinned
    /// \[m\] (zero: none has risen).
    pub rise: f64,
}

/// A pinned particle's straight path (see [`crate::cpu::motion`]): from
/// `from` at `start` to `to` at `end` \[s\], still before and after.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PinPath {
    /// Where it was when its last target was set \[m\].
    from: DVec3,
    /// Its target \[m\].
    to: DVec3,
    /// When the target was set \[s\].
    start: f64,
    /// When it is on its target \[s\].
    end: f64,
    /// Its height along `up` where it was pinned \[m\] (NaN: not known
    /// until its first target).
    origin: f64,
    /// The total change of its velocity so far [m/s].
    change: f64,
}

impl PinPath {
    /// A pin standing at `x` \[m\] since `time` \[s\], pinned at height
    /// `origin` \[m\], its velocity having changed by `change` [m/s].
    fn still(x: DVec3, time: f64, origin: f64, change: f64) -> Self {
        PinPath {
            from: x,
            to: x,
            start: time,
            end: time,
            origin,
            change,
        }
    }

    /// Where it is at `time` \[s\].
    fn at(&self, time: f64) -> DVec3 {
        if time >= self.end {
            self.to
        } else if time <= self.start {
            self.from
        } else {
            self.from
                .lerp(self.to, (time - self.start) / (self.end - self.start))
        }
    }

    /// Its velocity up to its end [m/s] (zero when still).
    fn velocity(&self) -> DVec3 {
        if self.end > self.start {
            (self.to - self.from) / (self.end - self.start)
        } else {
            DVec3::ZERO
        }
    }

    /// Whether it has stood still on its target for some time before
    /// `time` \[s\] (a new target set at its end continues its motion).
    fn stopped_before(&self, time: f64) -> bool {
        time - self.end > STILL_TOLERANCE * (self.end - self.start)
    }
}

/// Relative part of a frame by which the next frame's target may come after
/// the pin reached its last one and still continue its motion: the
/// frames' times, accumulated in `f64`, round apart by far less; a pin that
/// stood still a step of the frame's many steps is past it.
const STILL_TOLERANCE: f64 = 1e-6;

/// Colliders of one kind as last set: each with its total change of
/// velocity [m/s], and when they were set \[s\].
#[derive(Clone, Debug, PartialEq)]
struct Set<T> {
    bodies: Vec<(T, f64)>,
    time: f64,
}

/// A collider as [`Motion`] needs it: its points \[m\] (a sphere's centre,
/// a capsule's ends), radius \[m\] and velocity [m/s].
trait Body: Copy {
    fn points(&self) -> [DVec3; 2];
    fn radius(&self) -> f64;
    fn velocity(&self) -> DVec3;
    /// The fastest its surface moves [m/s].
    fn surface_speed(&self) -> f64 {
        self.velocity().length()
    }
}

/// A mesh collider as [`Motion`] sees it: the sphere that holds it
/// (centre, radius \[m\]), its velocity [m/s] and its angular velocity
/// [rad/s], whose surface speed is at most `|ω| × radius` more.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MeshBody {
    centre: DVec3,
    radius: f64,
    velocity: DVec3,
    angular_velocity: DVec3,
}

impl MeshBody {
    fn of(m: &crate::sdf::MeshCollider) -> Self {
        let (centre, radius) = m.bounding_sphere();
        MeshBody {
            centre,
            radius,
            velocity: m.velocity,
            angular_velocity: m.angular_velocity,
        }
    }
}

impl Body for MeshBody {
    fn points(&self) -> [DVec3; 2] {
        [self.centre; 2]
    }
    fn radius(&self) -> f64 {
        self.radius
    }
    fn velocity(&self) -> DVec3 {
        self.velocity
    }
    fn surface_speed(&self) -> f64 {
        self.velocity.length() + self.angular_velocity.length() * self.radius
    }
}

impl Body for Sphere {
    fn points(&self) -> [DVec3; 2] {
        [self.center; 2]
    }
    fn radius(&self) -> f64 {
        self.radius
    }
    fn velocity(&self) -> DVec3 {
        self.velocity
    }
}

impl Body for Capsule {
    fn points(&self) -> [DVec3; 2] {
        [self.a, self.b]
    }
    fn radius(&self) -> f64 {
        self.radius
    }
    fn velocity(&self) -> DVec3 {
        self.velocity
    }
}

impl<T: Body> Set<T> {
    /// None, at time zero.
    fn empty() -> Self {
        Set {
            bodies: Vec::new(),
            time: 0.0,
        }
    }

    /// The tops of the moving ones at `time` \[s\] along `up` \[m\].
    fn tops(&self, time: f64, up: DVec3) -> impl Iterator<Item = f64> + '_ {
        self.bodies
            .iter()
            .filter(|(b, _)| b.surface_speed() > 0.0)
            .map(move |(b, _)| top(b, b.velocity() * (time - self.time), up))
    }
}

/// The highest point of `body` shifted by `shift` \[m\], along `up`.
fn top<T: Body>(body: &T, shift: DVec3, up: DVec3) -> f64 {
    let [a, b] = body.points();
    (a + shift).dot(up).max((b + shift).dot(up)) + body.radius()
}

/// The moving bodies of one solver and how far they have gone (see the
/// module's doc). Built from the model and parameters the solver starts
/// from; the solver tells it every change of its bodies, with the
/// simulated time of the change.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// The unit vector against gravity (zero without gravity).
    up: DVec3,
    /// What the bodies replaced or stopped so far reached.
    past: Reach,
    /// The spheres as last set.
    spheres: Set<Sphere>,
    /// The capsules as last set.
    capsules: Set<Capsule>,
    /// The mesh colliders as last set.
    meshes: Set<MeshBody>,
    /// Every pinned particle's path.
    pins: BTreeMap<usize, PinPath>,
}

impl Motion {
    /// The bodies of `model` with `params` at time zero: the parameters'
    /// colliders at their velocities (each a change from rest), the
    /// model's pins standing where they rest.
    pub fn new(model: &Model, params: &Params) -> Self {
        let g = params.gravity;
        let up = if g.length() > 0.0 {
            -g / g.length()
        } else {
            DVec3::ZERO
        };
        let mut motion = Motion {
            up,
            past: Reach {
                top: f64::NEG_INFINITY,
                ..Reach::default()
            },
            spheres: Set::empty(),
            capsules: Set::empty(),
            meshes: Set::empty(),
            pins: BTreeMap::new(),
        };
        motion.set_spheres(0.0, &params.spheres);
        motion.set_capsules(0.0, &params.capsules);
        motion.set_mesh_colliders(0.0, &params.mesh_colliders);
        for p in (0..model.particle_count()).filter(|&p| model.pinned[p]) {
            let x = model.rest_positions[p];
            motion
                .pins
                .insert(p, PinPath::still(x, 0.0, x.dot(up), 0.0));
        }
        motion
    }

    /// How far the bodies have gone by `time` \[s\] (not before the last
    /// change they were told).
    pub fn reach(&self, time: f64) -> Reach {
        let top = self
            .spheres
            .tops(time, self.up)
            .chain(self.capsules.tops(time, self.up))
            .chain(self.meshes.tops(time, self.up))
            .fold(self.past.top, f64::max);
        // A pin still moving to its target stops there if no new target
        // comes: that change is already possible.
        let change = self
            .pins
            .values()
            .map(|p| p.change + p.velocity().length())
            .fold(self.past.change, f64::max);
        Reach {
            top,
            change,
            ..self.past
        }
    }

    /// The spheres are now `spheres`, set at `time` \[s\]: each moves at
    /// its velocity from its centre. A sphere whose centre is not where the
    /// one at its index had moved to has jumped: its top counts, and the
    /// jump as a speed over the time since that one was set.
    pub fn set_spheres(&mut self, time: f64, spheres: &[Sphere]) {
        self.spheres = self.replace(&self.spheres.clone(), time, spheres);
    }

    /// The capsules are now `capsules`, set at `time` \[s\], as
    /// [`Motion::set_spheres`] the spheres (a capsule's ends are compared).
    pub fn set_capsules(&mut self, time: f64, capsules: &[Capsule]) {
        self.capsules = self.replace(&self.capsules.clone(), time, capsules);
    }

    /// The mesh colliders are now `meshes`, set at `time` \[s\], as
    /// [`Motion::set_spheres`] the spheres (each as the sphere that holds
    /// it, its surface as fast as its spin makes it).
    pub fn set_mesh_colliders(&mut self, time: f64, meshes: &[crate::sdf::MeshCollider]) {
        let bodies: Vec<MeshBody> = meshes.iter().map(MeshBody::of).collect();
        self.meshes = self.replace(&self.meshes.clone(), time, &bodies);
    }

    /// The colliders `old` replaced at `time` \[s\] by `new`: notes what
    /// they reached and returns the new set.
    fn replace<T: Body>(&mut self, old: &Set<T>, time: f64, new: &[T]) -> Set<T> {
        let elapsed = time - old.time;
        for t in old.tops(time, self.up) {
            self.past.top = self.past.top.max(t);
        }
        let bodies = new
            .iter()
            .enumerate()
            .map(|(n, body)| {
                let (was, change) = match old.bodies.get(n) {
                    Some((o, change)) => {
                        let shift = o.velocity() * elapsed;
                        (
                            Some(o.points().map(|p| p + shift)),
                            *change + (body.velocity() - o.velocity()).length(),
                        )
                    }
                    None => (None, body.surface_speed()),
                };
                let jumped = was.is_some_and(|w| w != body.points());
                let jump = match was {
                    Some(w) if elapsed > 0.0 => {
                        let [a, b] = body.points();
                        ((a - w[0]).length().max((b - w[1]).length())) / elapsed
                    }
                    _ => 0.0,
                };
                // A jump starts and stops: two changes of its speed.
                let change = change + 2.0 * jump;
                let speed = body.surface_speed().max(jump);
                self.past.speed = self.past.speed.max(speed);
                self.past.change = self.past.change.max(change);
                if speed > 0.0 || jumped {
                    self.past.top = self.past.top.max(top(body, DVec3::ZERO, self.up));
                }
                (*body, change)
            })
            .collect();
        Set { bodies, time }
    }

    /// Pinned particles move from where they are at `time` \[s\] to
    /// `targets`, reaching them `duration` \[s\] later (the frame's whole
    /// steps, as the solver moves them). A target for a particle this
    /// record does not know as pinned is ignored (the solver refuses it).
    pub fn set_pin_targets(&mut self, time: f64, targets: &[PinTarget], duration: f64) {
        let up = self.up;
        for t in targets {
            let Some(path) = self.pins.get_mut(&t.particle) else {
                continue;
            };
            let to = t.position.as_dvec3();
            if path.origin.is_nan() {
                *path = PinPath::still(to, time, to.dot(up), path.change);
                continue;
            }
            let here = path.at(time);
            // Set before or at its end, it goes on from its velocity; set
            // after it stood still, it had stopped (a change too).
            let before = if path.stopped_before(time) {
                path.change += path.velocity().length();
                DVec3::ZERO
            } else {
                path.velocity()
            };
            let velocity = (to - here) / duration;
            *path = PinPath {
                from: here,
                to,
                start: time,
                end: time + duration,
                origin: path.origin,
                change: path.change + (velocity - before).length(),
            };
            self.past.speed = self.past.speed.max(velocity.length());
            self.past.change = self.past.change.max(path.change);
            self.past.rise = self.past.rise.max(to.dot(up) - path.origin);
        }
    }

    /// Particle `p` is pinned at `time` \[s\] where it is, at `x` \[m\]
    /// (`None` where the solver does not know without reading the device
    /// back: then its first target is taken as where it was pinned). A
    /// particle already pinned keeps its path.
    pub fn pin(&mut self, p: usize, x: Option<DVec3>, time: f64) {
        if self.pins.contains_key(&p) {
            return;
        }
        let path = match x {
            Some(x) => PinPath::still(x, time, x.dot(self.up), 0.0),
            None => PinPath::still(DVec3::NAN, time, f64::NAN, 0.0),
        };
        self.pins.insert(p, path);
    }

    /// Particle `p` is released: it no longer moves with a pin (what it
    /// reached stays counted).
    pub fn release(&mut self, p: usize) {
        if let Some(path) = self.pins.remove(&p) {
            self.past.change = self.past.change.max(path.change + path.velocity().length());
        }
    }

    /// Pinned particle `p` is put at `x` \[m\] at `time` \[s\] (a jump:
    /// counted as a rise, not as a speed). Ignored for a free particle.
    pub fn place(&mut self, p: usize, x: DVec3, time: f64) {
        let up = self.up;
        if let Some(path) = self.pins.get_mut(&p) {
            let origin = if path.origin.is_nan() {
                x.dot(up)
            } else {
                path.origin
            };
            let change = path.change + path.velocity().length();
            *path = PinPath::still(x, time, origin, change);
            self.past.rise = self.past.rise.max(x.dot(up) - origin);
            self.past.change = self.past.change.max(change);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ClothSpec;

    /// Room for rounding \[m/s\]: a pin target is an `f32` position
    /// (rounded by ~6·10⁻⁸ m near 1 m), a velocity that divided by a
    /// 10 ms frame (~6·10⁻⁶ m/s), summed over 20 frames: ~10⁻⁴ m/s.
    const ROUNDING: f64 = 1e-4;

    /// The default cloth (two pins) and its record.
    fn pinned() -> (Model, Motion) {
        let params = Params::default();
        let model = Model::new(&ClothSpec::default(), &params.springs).expect("valid cloth");
        let motion = Motion::new(&model, &params);
        (model, motion)
    }

    /// Every pin of `model` at `shift` from where it rests.
    fn targets(model: &Model, shift: DVec3) -> Vec<PinTarget> {
        (0..model.particle_count())
            .filter(|&p| model.pinned[p])
            .map(|p| PinTarget {
                particle: p,
                position: (model.rest_positions[p] + shift).as_vec3(),
            })
            .collect()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= ROUNDING
    }

    #[test]
    fn pins_moved_frame_by_frame_at_one_velocity_change_it_once() {
        let (model, mut motion) = pinned();
        let u = DVec3::new(0.0, 0.0, 2.0);
        let frame = 0.01;
        for k in 0..20 {
            let t = f64::from(k) * frame;
            motion.set_pin_targets(t, &targets(&model, u * (t + frame)), frame);
        }
        let reach = motion.reach(0.2);
        // The start from rest, and the stop still to come.
        assert!(close(reach.speed, 2.0), "{reach:?}");
        assert!(close(reach.change, 4.0), "{reach:?}");
        assert_eq!(reach.rise, 0.0);
    }

    #[test]
    fn a_pin_that_stood_still_starts_again_and_a_reversal_counts_twice() {
        let (model, mut motion) = pinned();
        let frame = 0.01;
        let up = DVec3::new(0.0, 1.0, 0.0);
        // Up 1 cm at 1 m/s, stand still a frame, then back down.
        motion.set_pin_targets(0.0, &targets(&model, up * 0.01), frame);
        motion.set_pin_targets(2.0 * frame, &targets(&model, DVec3::ZERO), frame);
        let reach = motion.reach(1.0);
        // Start, stop, start, stop: 1 m/s each.
        assert!(close(reach.change, 4.0), "{reach:?}");
        assert!(close(reach.rise, 0.01), "{reach:?}");
        // Straight back at once instead: start, reversal (2 m/s), stop.
        let (model, mut motion) = pinned();
        motion.set_pin_targets(0.0, &targets(&model, up * 0.01), frame);
        motion.set_pin_targets(frame, &targets(&model, DVec3::ZERO), frame);
        assert!(close(motion.reach(1.0).change, 4.0));
    }

    #[test]
    fn a_sphere_moved_every_frame_along_its_velocity_changes_it_only_when_it_turns() {
        let (_, mut motion) = pinned();
        let ball = |t: f64, v: DVec3| Sphere {
            center: DVec3::new(0.0, 0.5, 0.0) + DVec3::new(3.0, 0.0, 0.0) * t.min(0.5)
                - DVec3::new(3.0, 0.0, 0.0) * (t - 0.5).max(0.0),
            radius: 0.25,
            friction: 0.5,
            velocity: v,
        };
        let (right, left) = (DVec3::new(3.0, 0.0, 0.0), DVec3::new(-3.0, 0.0, 0.0));
        for k in 0..100 {
            let t = f64::from(k) * 0.01;
            motion.set_spheres(t, &[ball(t, if t < 0.5 { right } else { left })]);
        }
        let reach = motion.reach(1.0);
        // Started at 3 m/s, reversed once (6 m/s).
        assert!(close(reach.speed, 3.0), "{reach:?}");
        assert!(close(reach.change, 9.0), "{reach:?}");
        // Its top reached 0.75 m (it moved level).
        assert!(close(reach.top, 0.75), "{reach:?}");
    }
}
