//! Ground plane, sphere, capsule and mesh colliders.
//!
//! After a step, a free particle found inside a collider is moved to its
//! surface, loses its inward normal velocity relative to the collider, and
//! its tangential velocity relative to the collider is reduced by Coulomb
//! friction: by at most `μ` times the normal velocity it lost (so a particle
//! resting on the ground under gravity stops sliding once `μ g dt` exceeds
//! its tangential speed change per step, and one resting on a moving
//! collider is carried along).
//!
//! Spheres and capsules move at a constant velocity from where they were
//! set: at a particle's clock `c` (its finished steps, [`super::motion`])
//! a sphere set at step `base` is at `center + velocity × (c − base) dt`,
//! the same expression, in the same order, as the kernels'.
//!
//! The implicit integrator also asks [`contact`] at the start of a step which
//! particles are touching, to constrain them in the CG filter.

use super::{MeshColliderR, System};
use crate::real::{Real, Vec3};

/// A particle's distance to the surface within which it counts as touching
/// at the start of a step \[m\]. Collision projection puts particles exactly
/// on the surface up to rounding (≈1e-7 m in `f32` near 1 m), so a slop a
/// hundred times larger catches every resting particle and no free one.
pub const CONTACT_SLOP: f64 = 1e-5;

/// A collider surface point: outward unit normal and signed distance of the
/// particle from the surface (negative inside) \[m\].
#[derive(Clone, Copy, Debug)]
pub struct Contact<R> {
    /// Outward unit normal.
    pub normal: Vec3<R>,
    /// Signed distance (negative = penetrating) \[m\].
    pub distance: R,
    /// Coulomb friction coefficient of this collider.
    pub friction: R,
    /// The collider's velocity [m/s] (zero for the ground).
    pub velocity: Vec3<R>,
}

/// The time \[s\] since a collider set at step `base` at the step count
/// `clock` (twin: `collider_time` in `shaders/common/physics.wgsl`). The
/// count converts exactly below 2²⁴ steps since the collider was set.
pub fn collider_time<R: Real>(sys: &System<R>, clock: u32, base: u32) -> R {
    R::from_f64(f64::from(clock.wrapping_sub(base))) * sys.dt
}

/// The larger of two values, written as the kernels write it
/// (`select(b, a, a > b)`).
fn larger<R: Real>(a: R, b: R) -> R {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of two values (`select(b, a, a < b)`).
fn smaller<R: Real>(a: R, b: R) -> R {
    if a < b {
        a
    } else {
        b
    }
}

/// The point of the segment `a`–`b` closest to `x` (`a` when the segment
/// has no length; a length that rounds to almost nothing still clamps
/// to the segment).
fn closest_on_segment<R: Real>(a: Vec3<R>, b: Vec3<R>, x: Vec3<R>) -> Vec3<R> {
    let d = b - a;
    let dd = d.dot(d);
    let mut t = R::ZERO;
    if dd > R::ZERO {
        t = smaller(larger((x - a).dot(d) / dd, R::ZERO), R::ONE);
    }
    a + d * t
}

/// The contact of `x` with a ball of `radius` around `centre`.
fn ball<R: Real>(
    x: Vec3<R>,
    centre: Vec3<R>,
    radius: R,
    friction: R,
    velocity: Vec3<R>,
) -> Contact<R> {
    let d = x - centre;
    let len = d.length();
    // At the exact centre the direction is undefined: push up.
    let normal = if len > R::TINY {
        d / len
    } else {
        Vec3::new(R::ZERO, R::ONE, R::ZERO)
    };
    Contact {
        normal,
        distance: len - radius,
        friction,
        velocity,
    }
}

/// The deepest collider contact of a particle at `x`, if any collider is
/// closer than `slop` (pass zero to find only penetrations), with the
/// colliders where they are at the particle clock `clock`.
pub fn contact<R: Real>(sys: &System<R>, x: Vec3<R>, slop: R, clock: u32) -> Option<Contact<R>> {
    let mut best: Option<Contact<R>> = None;
    let mut consider = |c: Contact<R>| {
        if c.distance < slop && best.is_none_or(|b| c.distance < b.distance) {
            best = Some(c);
        }
    };
    if let Some(g) = &sys.ground {
        consider(Contact {
            normal: Vec3::new(R::ZERO, R::ONE, R::ZERO),
            distance: x.y - g.height,
            friction: g.friction,
            velocity: Vec3::ZERO,
        });
    }
    let t = collider_time(sys, clock, sys.sphere_base);
    for s in &sys.spheres {
        let centre = s.center + s.velocity * t;
        consider(ball(x, centre, s.radius, s.friction, s.velocity));
    }
    let t = collider_time(sys, clock, sys.capsule_base);
    for c in &sys.capsules {
        let shift = c.velocity * t;
        let q = closest_on_segment(c.a + shift, c.b + shift, x);
        consider(ball(x, q, c.radius, c.friction, c.velocity));
    }
    let t = collider_time(sys, clock, sys.mesh_base);
    for m in &sys.mesh_colliders {
        if let Some(c) = mesh_contact(m, x, t) {
            consider(c);
        }
    }
    best
}

/// `v` rotated by the unit quaternion `q` `(x, y, z, w)`: `v + w t + u × t`
/// with `t = 2 u × v` (twin: `rotate` in `shaders/common/physics.wgsl`).
fn rotate<R: Real>(q: [R; 4], v: Vec3<R>) -> Vec3<R> {
    let u = Vec3::new(q[0], q[1], q[2]);
    let t = u.cross(v) * R::from_f64(2.0);
    v + t * q[3] + u.cross(t)
}

/// `a + (b − a) t`.
fn lerp<R: Real>(a: R, b: R, t: R) -> R {
    a + (b - a) * t
}

/// The bilinear blend of `a` (0, 0), `b` (1, 0), `c` (0, 1), `d` (1, 1) at
/// `(u, v)`.
fn bilerp<R: Real>(a: R, b: R, c: R, d: R, u: R, v: R) -> R {
    lerp(lerp(a, b, u), lerp(c, d, u), v)
}

/// The contact of `x` with mesh collider `m` `t` seconds after it was set,
/// if `x` is inside its grid: the trilinear distance less the thickness,
/// the normal along the gradient of the same trilinear field in `x`'s cell
/// (exact for the interpolant, so the normal and the distance agree), the
/// surface velocity `v + ω × r` (twin: `mesh_contact` in
/// `shaders/common/physics.wgsl`). Outside the grid, which reaches two
/// cells beyond `thickness` around the mesh, there is no contact.
fn mesh_contact<R: Real>(m: &MeshColliderR<R>, x: Vec3<R>, t: R) -> Option<Contact<R>> {
    let g = &m.grid;
    let r = x - (m.position + m.velocity * t);
    let local = rotate(m.rotation, r);
    let origin = Vec3::from_f64(g.origin.map(f64::from));
    let at = (local - origin) / R::from_f64(f64::from(g.cell));
    let mut corner = [0u32; 3];
    let mut f = [R::ZERO; 3];
    for k in 0..3 {
        let c = at.get(k);
        // Written so that NaN is outside too.
        if !(c >= R::ZERO && c < R::from_f64(f64::from(g.dims[k] - 1))) {
            return None;
        }
        corner[k] = c.to_f64() as u32;
        f[k] = c - R::from_f64(f64::from(corner[k]));
    }
    let s = |i: u32, j: u32, k: u32| {
        R::from_f64(f64::from(g.at(corner[0] + i, corner[1] + j, corner[2] + k)))
    };
    let (s000, s100, s010, s110) = (s(0, 0, 0), s(1, 0, 0), s(0, 1, 0), s(1, 1, 0));
    let (s001, s101, s011, s111) = (s(0, 0, 1), s(1, 0, 1), s(0, 1, 1), s(1, 1, 1));
    let x0 = bilerp(s000, s010, s001, s011, f[1], f[2]);
    let x1 = bilerp(s100, s110, s101, s111, f[1], f[2]);
    let gy = bilerp(
        s010 - s000,
        s110 - s100,
        s011 - s001,
        s111 - s101,
        f[0],
        f[2],
    );
    let gz = bilerp(
        s001 - s000,
        s101 - s100,
        s011 - s010,
        s111 - s110,
        f[0],
        f[1],
    );
    let grad = Vec3::new(x1 - x0, gy, gz);
    let len = grad.length();
    // A flat spot of the field (a cell at a medial sheet): push up.
    let outward = if len > R::TINY {
        grad / len
    } else {
        Vec3::new(R::ZERO, R::ONE, R::ZERO)
    };
    let q = m.rotation;
    Some(Contact {
        normal: rotate([-q[0], -q[1], -q[2], q[3]], outward),
        distance: lerp(x0, x1, f[0]) - m.thickness,
        friction: m.friction,
        velocity: m.velocity + m.angular_velocity.cross(r),
    })
}

/// The velocity [m/s] after a contact that removed the normal velocity
/// `vn` (< 0) relative to the collider: the collider's velocity plus the
/// relative tangential velocity `tangential`, reduced by friction.
pub(crate) fn after_contact<R: Real>(c: &Contact<R>, tangential: Vec3<R>, vn: R) -> Vec3<R> {
    let speed = tangential.length();
    let loss = c.friction * (-vn);
    let kept = if speed > loss && speed > R::TINY {
        (speed - loss) / speed
    } else {
        R::ZERO
    };
    c.velocity + tangential * kept
}

/// Bisection steps that locate where a particle's path entered a mesh
/// collider: 2⁻²⁰ of the step's path, under a micrometre for any path
/// shorter than a metre.
const ENTRY_BISECTIONS: u32 = 20;

/// Where a particle that moved from `start` to `x` in the step entered
/// mesh collider `m` (where it is `t` seconds after it was set), when it
/// started outside and ended inside: the contact at the entry point, its
/// `distance` that of `x` from the plane of the face the path crossed
/// (negative). A nearest-face projection would push a particle that went
/// past the middle of a thin part — a table top crossed in one step —
/// out through the far face; the entry face is the side it came from.
/// `None` when the particle started inside (resting on or in the surface:
/// the nearest face is right) or ended outside (twin: `mesh_entry` in
/// `shaders/common/physics.wgsl`).
fn mesh_entry<R: Real>(
    m: &MeshColliderR<R>,
    start: Vec3<R>,
    x: Vec3<R>,
    t: R,
) -> Option<Contact<R>> {
    let inside = |q: Vec3<R>| mesh_contact(m, q, t).is_some_and(|c| c.distance < R::ZERO);
    if !inside(x) || inside(start) {
        return None;
    }
    let (mut outside, mut within) = (R::ZERO, R::ONE);
    for _ in 0..ENTRY_BISECTIONS {
        let mid = (outside + within) * R::from_f64(0.5);
        if inside(start + (x - start) * mid) {
            within = mid;
        } else {
            outside = mid;
        }
    }
    let entry = start + (x - start) * outside;
    let c = mesh_contact(m, entry, t)?;
    Some(Contact {
        distance: (x - entry).dot(c.normal),
        ..c
    })
}

/// Particle `x`, `v` moved out of contact `c` onto its surface, losing its
/// velocity into the surface and, by friction, some of its sliding.
fn resolve<R: Real>(c: &Contact<R>, x: &mut Vec3<R>, v: &mut Vec3<R>) {
    *x -= c.normal * c.distance;
    let relative = *v - c.velocity;
    let vn = relative.dot(c.normal);
    if vn < R::ZERO {
        *v = after_contact(c, relative - c.normal * vn, vn);
    }
}

/// Resolves every free particle's penetration of the colliders in place,
/// with the colliders where they are at the end of the step whose start
/// clock is `clock`; `start` holds the positions at the step's start (a
/// particle that crossed into a mesh collider leaves by the face it came
/// through, see `mesh_entry`). Returns the number of particles that were
/// moved.
pub fn collide<R: Real>(
    sys: &System<R>,
    start: &[Vec3<R>],
    x: &mut [Vec3<R>],
    v: &mut [Vec3<R>],
    clock: u32,
) -> usize {
    if !sys.has_colliders() {
        return 0;
    }
    let end = clock.wrapping_add(1);
    let t = collider_time(sys, end, sys.mesh_base);
    let mut moved = 0;
    for p in 0..x.len() {
        if sys.inv_mass[p] <= R::ZERO {
            continue;
        }
        let mut hit = false;
        for m in &sys.mesh_colliders {
            if let Some(c) = mesh_entry(m, start[p], x[p], t) {
                resolve(&c, &mut x[p], &mut v[p]);
                hit = true;
            }
        }
        // Resolve against each collider in turn (a particle can touch the
        // ground and a sphere at once); two passes settle a corner contact.
        for _ in 0..2 {
            let Some(c) = contact(sys, x[p], R::ZERO, end) else {
                break;
            };
            resolve(&c, &mut x[p], &mut v[p]);
            hit = true;
        }
        moved += usize::from(hit);
    }
    moved
}
