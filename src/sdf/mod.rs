//! Mesh colliders: a closed triangle mesh baked once, on the CPU, into a
//! grid of signed distances ([`DistanceGrid`]), which the kernels and the
//! CPU twin (`cpu::collide::mesh_contact`) sample trilinearly with the
//! gradient of the same trilinear field for the normal.
//!
//! A grid lives in the body's own frame: the mesh's coordinates times the
//! collider's `scale`, before its rotation and position. The body is placed
//! by a pose — position \[m\] and rotation — and moves at a linear velocity
//! \[m/s\] from where it was set, as a capsule does; its angular velocity
//! \[rad/s\] about its position adds `ω × r` to the surface velocity that
//! contact and friction act relative to, while its orientation is the one
//! last set (a host turning a body sets its pose each frame, see
//! [`MeshPose`]).
//!
//! What the bake refuses, and what it does not see, is in [`bake`].

mod bake;
mod lattice;
mod parts;

use std::path::PathBuf;
use std::sync::Arc;

use glam::{DQuat, DVec3};

pub use bake::{bake, bake_until, MAX_GRID_CELLS, MAX_RESOLUTION, MIN_RESOLUTION};
pub(crate) use bake::{check_resolution, closest_on_triangle};

/// The default `resolution`: 64 cells along the mesh's longest side puts a
/// cell of 1.6 cm on a 1 m table, finer than the few-centimetre cells of
/// the built-in cloths, at 1 MiB of samples for a cube-shaped grid.
pub const DEFAULT_RESOLUTION: u32 = 64;

/// A signed-distance grid: the distance \[m\] from each lattice point to the
/// mesh surface, negative inside, in the body's frame. The lattice point
/// `(i, j, k)` is at `origin + cell × (i, j, k)`; its sample is number
/// `i + nx (j + ny k)`. The origin and cell are `f32` values (kept as `f32`
/// so the GPU, the `f32` mirror and the `f64` reference place the lattice
/// identically).
#[derive(Clone, Debug, PartialEq)]
pub struct DistanceGrid {
    /// The lattice point `(0, 0, 0)` in the body's frame \[m\].
    pub origin: [f32; 3],
    /// The lattice spacing \[m\].
    pub cell: f32,
    /// Lattice points along x, y and z (each ≥ 2).
    pub dims: [u32; 3],
    /// Signed distances \[m\], x fastest.
    pub samples: Vec<f32>,
    /// The mesh's triangles in the body's frame, outward (for drawing).
    pub triangles: Vec<[glam::Vec3; 3]>,
}

impl DistanceGrid {
    /// The sample at lattice point `(i, j, k)` \[m\].
    pub fn at(&self, i: u32, j: u32, k: u32) -> f32 {
        let [nx, ny, _] = self.dims;
        self.samples[(i + nx * (j + ny * k)) as usize]
    }
}

/// A closed triangle mesh as a collider (`[[collider]]`).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshCollider {
    /// The mesh file as the scene names it (for messages and display).
    pub path: PathBuf,
    /// The baked grid, shared by clones.
    pub grid: Arc<DistanceGrid>,
    /// Where the body's frame origin is \[m\] when set.
    pub position: DVec3,
    /// The body's orientation (body frame to world), a unit quaternion.
    pub rotation: DQuat,
    /// Velocity [m/s] (zero: static).
    pub velocity: DVec3,
    /// Angular velocity [rad/s] about `position`: the surface moves at
    /// `velocity + angular_velocity × r`.
    pub angular_velocity: DVec3,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`), acting on the
    /// particle's velocity relative to the surface's.
    pub friction: f64,
    /// The distance the cloth keeps from the surface \[m\], `≥ 0`.
    pub thickness: f64,
}

impl MeshCollider {
    /// This collider moved to `pose`.
    pub fn with_pose(&self, pose: &MeshPose) -> MeshCollider {
        MeshCollider {
            position: pose.position,
            rotation: pose.rotation,
            velocity: pose.velocity,
            angular_velocity: pose.angular_velocity,
            ..self.clone()
        }
    }

    /// Its pose and velocities.
    pub fn pose(&self) -> MeshPose {
        MeshPose {
            position: self.position,
            rotation: self.rotation,
            velocity: self.velocity,
            angular_velocity: self.angular_velocity,
        }
    }

    /// A sphere that holds the body \[m\] (centre, radius) where it is set:
    /// what the diagnostics' record of moving bodies and the camera use.
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        let g = &self.grid;
        let lo = DVec3::from(g.origin.map(f64::from));
        let size = DVec3::from(g.dims.map(|n| f64::from(n - 1))) * f64::from(g.cell);
        let centre = self.position + self.rotation * (lo + size * 0.5);
        (centre, size.length() * 0.5)
    }
}

/// The most a body that keeps its orientation may move along its own
/// normal as it turns, as a share of its rim speed (`|ω| ×` the farthest
/// a vertex is from the axis): a prism of 16 or more sides about the
/// axis, whose facets' corners move along their normals by `sin(π/16)`
/// = 0.195 of the rim speed, passes as round; a box turned about its
/// middle (a table: 0.8) does not.
pub const MAX_TURNING_NORMAL_SHARE: f64 = 0.2;

impl MeshCollider {
    /// Where this body's turning, with its orientation kept, would move
    /// its surface along the normal by more than
    /// [`MAX_TURNING_NORMAL_SHARE`] of its rim speed: that speed \[m/s\]
    /// and the rim speed. A body that keeps its orientation while `ω × r`
    /// drives its surface is consistent only where `ω × r` runs along the
    /// surface (a turntable, a roller); elsewhere the surface would push
    /// the cloth along its normal without moving, and slide along its
    /// faces like a conveyor, winding the cloth round a body that does
    /// not turn until it blows up.
    pub fn turning_off_axis(&self) -> Option<(f64, f64)> {
        let omega = self.rotation.inverse() * self.angular_velocity;
        if omega == DVec3::ZERO {
            return None;
        }
        let (mut normal, mut rim) = (0.0f64, 0.0f64);
        for t in &self.grid.triangles {
            let [a, b, c] = t.map(|v| v.as_dvec3());
            let n = (b - a).cross(c - a).normalize_or_zero();
            for v in [a, b, c] {
                let spin = omega.cross(v);
                normal = normal.max(spin.dot(n).abs());
                rim = rim.max(spin.length());
            }
        }
        (normal > MAX_TURNING_NORMAL_SHARE * rim).then_some((normal, rim))
    }
}

/// `colliders` moved to `poses` (one each, in order), refusing a count
/// that differs (a collider's mesh is baked once: the count is the
/// scene's) and a pose that is not finite or not a unit rotation.
pub(crate) fn posed(
    colliders: &[MeshCollider],
    poses: &[MeshPose],
) -> crate::Result<Vec<MeshCollider>> {
    if poses.len() != colliders.len() {
        return Err(crate::Error::InvalidParameter {
            key: "collider".into(),
            allowed: format!(
                "one pose per mesh collider of the scene ({})",
                colliders.len()
            ),
            got: format!("{} poses", poses.len()),
        });
    }
    for (n, p) in poses.iter().enumerate() {
        crate::params::check_mesh_pose(&format!("collider[{n}]"), p)?;
    }
    Ok(colliders
        .iter()
        .zip(poses)
        .map(|(c, p)| c.with_pose(p))
        .collect())
}

/// Where a mesh collider is and how it moves, as a host sets it each frame
/// (`set_mesh_colliders` on the solvers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshPose {
    /// The body's frame origin \[m\].
    pub position: DVec3,
    /// Its orientation (body frame to world), a unit quaternion.
    pub rotation: DQuat,
    /// Velocity [m/s]: the body moves so from this pose until set again.
    pub velocity: DVec3,
    /// Angular velocity [rad/s] about `position` (the surface's velocity;
    /// the orientation stays until set again).
    pub angular_velocity: DVec3,
}
