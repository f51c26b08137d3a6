//! Ground plane and sphere colliders.
//!
//! After a step, a free particle found inside a collider is moved to its
//! surface, loses its inward normal velocity, and its tangential velocity is
//! reduced by Coulomb friction: by at most `μ` times the normal velocity it
//! lost (so a particle resting on the ground under gravity stops sliding
//! once `μ g dt` exceeds its tangential speed change per step).
//!
//! The implicit integrator also asks [`contact`] at the start of a step which
//! particles are touching, to constrain them in the CG filter.

use super::System;
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
}

/// The deepest collider contact of a particle at `x`, if any collider is
/// closer than `slop` (pass zero to find only penetrations).
pub fn contact<R: Real>(sys: &System<R>, x: Vec3<R>, slop: R) -> Option<Contact<R>> {
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
        });
    }
    for s in &sys.spheres {
        let d = x - s.center;
        let len = d.length();
        // At the exact centre the direction is undefined: push up.
        let normal = if len > R::TINY {
            d / len
        } else {
            Vec3::new(R::ZERO, R::ONE, R::ZERO)
        };
        consider(Contact {
            normal,
            distance: len - s.radius,
            friction: s.friction,
        });
    }
    best
}

/// Resolves every free particle's penetration of the colliders in place.
/// Returns the number of particles that were moved.
pub fn collide<R: Real>(sys: &System<R>, x: &mut [Vec3<R>], v: &mut [Vec3<R>]) -> usize {
    if !sys.has_colliders() {
        return 0;
    }
    let mut moved = 0;
    for p in 0..x.len() {
        if sys.inv_mass[p] <= R::ZERO {
            continue;
        }
        // Resolve against each collider in turn (a particle can touch the
        // ground and a sphere at once); two passes settle a corner contact.
        let mut hit = false;
        for _ in 0..2 {
            let Some(c) = contact(sys, x[p], R::ZERO) else {
                break;
            };
            x[p] -= c.normal * c.distance;
            let vn = v[p].dot(c.normal);
            if vn < R::ZERO {
                let tangential = v[p] - c.normal * vn;
                let speed = tangential.length();
                let loss = c.friction * (-vn);
                let kept = if speed > loss && speed > R::TINY {
                    (speed - loss) / speed
                } else {
                    R::ZERO
                };
                v[p] = tangential * kept;
            }
            hit = true;
        }
        moved += usize::from(hit);
    }
    moved
}
