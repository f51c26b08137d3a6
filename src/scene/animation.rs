//! A scripted character: capsules that walk and turn along keyed poses,
//! and the cloth's pins riding on it (pins that follow a bone).
//!
//! A scene's `[character]` gives capsules in the character's own frame
//! (x right, y up, z forward, at its position) and `[[character.key]]`
//! poses: a time, a position and a yaw (degrees about +y). Between keys
//! the pose is interpolated linearly; before the first key and after the
//! last it holds. Every pinned particle of the cloth is attached to the
//! character where it is at the first key.
//!
//! [`Animation::apply`] is the one call a host makes per frame: it sets
//! the capsules where the character is at the frame's start, each moving
//! at the velocity that takes its midpoint to where it is at the frame's
//! end (a turn within one frame is followed frame by frame), and the pins'
//! targets where they are at the frame's end.

use glam::{DQuat, DVec3};

use crate::cpu::CpuSolver;
use crate::error::Result;
use crate::gpu::GpuSolver;
use crate::model::{check_position, Model};
use crate::params::{check, check_finite, Capsule, PinTarget};
use crate::real::Real;
use crate::sdf::{MeshCollider, MeshPose};

/// One keyed pose of the character.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// Time \[s\] from the start.
    pub time: f64,
    /// Where the character's origin is \[m\].
    pub position: DVec3,
    /// Its heading \[deg\] about +y (0: facing +z; 90: facing +x).
    pub yaw: f64,
}

/// The scene's `[character]`: capsules in its frame and its keyed path.
#[derive(Clone, Debug, PartialEq)]
pub struct Character {
    /// Capsules in the character's frame (`velocity` unused).
    pub capsules: Vec<Capsule>,
    /// Mesh colliders in the character's frame (their pose relative to
    /// it; velocities unused).
    pub colliders: Vec<MeshCollider>,
    /// Poses, in increasing time.
    pub keys: Vec<Key>,
}

/// Where the character is at one time: its origin \[m\] and heading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// The origin \[m\].
    pub position: DVec3,
    /// The heading as a rotation about +y.
    pub rotation: DQuat,
}

impl Pose {
    /// A point of the character's frame in the world \[m\].
    pub fn world(&self, local: DVec3) -> DVec3 {
        self.position + self.rotation * local
    }

    /// A world point in the character's frame \[m\].
    pub fn local(&self, world: DVec3) -> DVec3 {
        self.rotation.inverse() * (world - self.position)
    }
}

impl Character {
    /// Refuses a character without keys, keys out of time order, and any
    /// non-finite or impossible value, naming the key as the scene file
    /// spells it.
    pub fn validate(&self) -> Result<()> {
        if self.keys.is_empty() {
            check(
                "character.key",
                0.0,
                false,
                "at least one `[[character.key]]` (time, position, yaw)",
            )?;
        }
        let mut previous: Option<f64> = None;
        for (n, k) in self.keys.iter().enumerate() {
            let key = format!("character.key[{n}].time");
            match previous {
                None => check(
                    &key,
                    k.time,
                    k.time >= 0.0 && k.time.is_finite(),
                    "a time ≥ 0 (s)",
                )?,
                Some(t) => check(
                    &key,
                    k.time,
                    k.time > t && k.time.is_finite(),
                    &format!("a time after the previous key's {t} s"),
                )?,
            }
            previous = Some(k.time);
            check_position(&format!("character.key[{n}].position"), k.position)?;
            check_finite(&format!("character.key[{n}].yaw"), k.yaw, "degrees")?;
        }
        for (n, c) in self.capsules.iter().enumerate() {
            let key = |k: &str| format!("character.capsule[{n}].{k}");
            check_position(&key("a"), c.a)?;
            check_position(&key("b"), c.b)?;
            check(&key("radius"), c.radius, c.radius > 0.0, "radius > 0 (m)")?;
            check(
                &key("friction"),
                c.friction,
                c.friction >= 0.0,
                "friction ≥ 0",
            )?;
        }
        Ok(())
    }

    /// The pose at time `t` \[s\].
    pub fn pose(&self, t: f64) -> Pose {
        let at = |k: &Key| (k.position, k.yaw);
        let (position, yaw) = match self.keys.iter().position(|k| k.time > t) {
            None => self.keys.last().map_or((DVec3::ZERO, 0.0), at),
            Some(0) => at(&self.keys[0]),
            Some(i) => {
                let (a, b) = (&self.keys[i - 1], &self.keys[i]);
                let s = (t - a.time) / (b.time - a.time);
                (a.position.lerp(b.position, s), a.yaw + (b.yaw - a.yaw) * s)
            }
        };
        Pose {
            position,
            rotation: DQuat::from_rotation_y(yaw.to_radians()),
        }
    }

    /// The mesh colliders in the world at time `t` \[s\] (at rest).
    pub fn colliders_at(&self, t: f64) -> Vec<MeshCollider> {
        let pose = self.pose(t);
        self.colliders
            .iter()
            .map(|m| MeshCollider {
                position: pose.world(m.position),
                rotation: pose.rotation * m.rotation,
                velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
                ..m.clone()
            })
            .collect()
    }

    /// The capsules in the world at time `t` \[s\] (at rest).
    pub fn capsules_at(&self, t: f64) -> Vec<Capsule> {
        let pose = self.pose(t);
        self.capsules
            .iter()
            .map(|c| Capsule {
                a: pose.world(c.a),
                b: pose.world(c.b),
                velocity: DVec3::ZERO,
                ..*c
            })
            .collect()
    }
}

/// What [`Animation::apply`] sets on a solver: both backends take it.
pub trait Animated {
    /// See [`GpuSolver::set_capsules`].
    fn set_capsules(&mut self, capsules: &[Capsule]) -> Result<()>;
    /// See [`GpuSolver::set_pin_targets`].
    fn set_pin_targets(&mut self, targets: &[PinTarget], frame_seconds: f64) -> Result<()>;
    /// See [`GpuSolver::set_mesh_colliders`].
    fn set_mesh_colliders(&mut self, poses: &[MeshPose]) -> Result<()>;
}

impl Animated for GpuSolver {
    fn set_capsules(&mut self, capsules: &[Capsule]) -> Result<()> {
        GpuSolver::set_capsules(self, capsules)
    }
    fn set_mesh_colliders(&mut self, poses: &[MeshPose]) -> Result<()> {
        GpuSolver::set_mesh_colliders(self, poses)
    }
    fn set_pin_targets(&mut self, targets: &[PinTarget], frame_seconds: f64) -> Result<()> {
        GpuSolver::set_pin_targets(self, targets, frame_seconds)
    }
}

impl<R: Real> Animated for CpuSolver<R> {
    fn set_capsules(&mut self, capsules: &[Capsule]) -> Result<()> {
        CpuSolver::set_capsules(self, capsules)
    }
    fn set_mesh_colliders(&mut self, poses: &[MeshPose]) -> Result<()> {
        CpuSolver::set_mesh_colliders(self, poses)
    }
    fn set_pin_targets(&mut self, targets: &[PinTarget], frame_seconds: f64) -> Result<()> {
        CpuSolver::set_pin_targets(self, targets, frame_seconds)
    }
}

/// A character driving one cloth: its capsules, the scene's other
/// capsules, and the pinned particles in the character's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    character: Character,
    /// The scene's own `[[capsule]]`s, as set at the start.
    others: Vec<Capsule>,
    /// The scene's own `[[collider]]`s, as set at the start.
    other_meshes: Vec<MeshCollider>,
    /// Each pinned particle and where it sits in the character's frame.
    pins: Vec<(usize, DVec3)>,
}

impl Animation {
    /// The animation of `character` with the scene's other capsules
    /// `others` and mesh colliders `other_meshes` (which keep their own
    /// constant velocities) on the cloth `model`, whose pinned particles
    /// ride on the character from where they rest at its first key.
    pub fn new(
        character: &Character,
        others: &[Capsule],
        other_meshes: &[MeshCollider],
        model: &Model,
    ) -> Animation {
        let start = character.pose(character.keys.first().map_or(0.0, |k| k.time));
        let pins = (0..model.particle_count())
            .filter(|&p| model.pinned[p])
            .map(|p| (p, start.local(model.rest_positions[p])))
            .collect();
        Animation {
            character: character.clone(),
            others: others.to_vec(),
            other_meshes: other_meshes.to_vec(),
            pins,
        }
    }

    /// The character.
    pub fn character(&self) -> &Character {
        &self.character
    }

    /// Every capsule as the solver is to take it for the frame from `t`
    /// to `t + frame_seconds` \[s\]: where it is at `t`, moving at the
    /// velocity that takes the character's capsules' midpoints to where
    /// they are at the frame's end.
    pub fn capsules(&self, t: f64, frame_seconds: f64) -> Vec<Capsule> {
        let (now, next) = (
            self.character.pose(t),
            self.character.pose(t + frame_seconds),
        );
        let others = self.others.iter().map(|c| Capsule {
            a: c.a + c.velocity * t,
            b: c.b + c.velocity * t,
            ..*c
        });
        let own = self.character.capsules.iter().map(|c| {
            let mid = (c.a + c.b) * 0.5;
            Capsule {
                a: now.world(c.a),
                b: now.world(c.b),
                velocity: (next.world(mid) - now.world(mid)) / frame_seconds,
                ..*c
            }
        });
        others.chain(own).collect()
    }

    /// Every mesh collider's pose for the frame from `t` to
    /// `t + frame_seconds` \[s\], as [`Animation::capsules`] the capsules:
    /// the character's where they are at `t`, moving to where they are at
    /// the frame's end and turning at the character's rate about y.
    pub fn mesh_poses(&self, t: f64, frame_seconds: f64) -> Vec<MeshPose> {
        let (now, next) = (
            self.character.pose(t),
            self.character.pose(t + frame_seconds),
        );
        let (axis, angle) = (next.rotation * now.rotation.inverse()).to_axis_angle();
        let spin = axis * (angle / frame_seconds);
        let others = self.other_meshes.iter().map(|m| MeshPose {
            position: m.position + m.velocity * t,
            ..m.pose()
        });
        let own = self.character.colliders.iter().map(|m| MeshPose {
            position: now.world(m.position),
            rotation: now.rotation * m.rotation,
            velocity: (next.world(m.position) - now.world(m.position)) / frame_seconds,
            angular_velocity: spin,
        });
        others.chain(own).collect()
    }

    /// Where the pinned particles are to be at `t` \[s\].
    pub fn pin_targets(&self, t: f64) -> Vec<PinTarget> {
        let pose = self.character.pose(t);
        self.pins
            .iter()
            .map(|&(particle, local)| PinTarget {
                particle,
                position: pose.world(local).as_vec3(),
            })
            .collect()
    }

    /// The one call per frame: sets `solver`'s capsules for the frame from
    /// `t` \[s\] and its pins' targets at `t + frame_seconds`. Then the
    /// host steps `frame_seconds` of simulated time.
    pub fn apply(&self, solver: &mut impl Animated, t: f64, frame_seconds: f64) -> Result<()> {
        solver.set_capsules(&self.capsules(t, frame_seconds))?;
        if !self.character.colliders.is_empty() {
            solver.set_mesh_colliders(&self.mesh_poses(t, frame_seconds))?;
        }
        solver.set_pin_targets(&self.pin_targets(t + frame_seconds), frame_seconds)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walker() -> Character {
        Character {
            capsules: vec![],
            colliders: vec![],
            keys: vec![
                Key {
                    time: 0.0,
                    position: DVec3::ZERO,
                    yaw: 0.0,
                },
                Key {
                    time: 2.0,
                    position: DVec3::new(0.0, 0.0, 2.0),
                    yaw: 90.0,
                },
            ],
        }
    }

    /// Why `validate` refuses `c` (empty if it does not).
    fn refusal(c: &Character) -> String {
        c.validate()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    }

    #[test]
    fn poses_interpolate_between_keys_and_hold_outside() {
        let c = walker();
        let mid = c.pose(1.0);
        assert!((mid.position - DVec3::new(0.0, 0.0, 1.0)).length() < 1e-12);
        // Facing +z turned 45°: forward is between +z and +x.
        let f = mid.rotation * DVec3::Z;
        assert!(
            (f - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12,
            "{f}"
        );
        assert_eq!(c.pose(5.0).position, DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(c.pose(-1.0).position, DVec3::ZERO);
        let p = DVec3::new(0.3, 1.0, -0.2);
        assert!((mid.local(mid.world(p)) - p).length() < 1e-12);
    }

    #[test]
    fn keys_out_of_order_are_refused_naming_the_key() {
        let mut c = walker();
        c.keys[1].time = 0.0;
        let e = refusal(&c);
        assert!(e.contains("character.key[1].time"), "{e}");
        c.keys.clear();
        assert!(c.validate().is_err());
    }

    #[test]
    fn a_key_beyond_what_the_gpu_holds_is_refused_naming_it() {
        let mut c = walker();
        c.keys[1].position.y = -1e300;
        let e = refusal(&c);
        assert!(e.contains("`character.key[1].position[1]`"), "{e}");
        assert!(
            e.contains("within ±1e18 m") && e.contains("got -1e300"),
            "{e}"
        );
        c.keys[1].position.y = -1e18;
        assert!(c.validate().is_ok());
    }
}
