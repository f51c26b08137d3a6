//! The semi-implicit global torque compensation, for a cloth without pins
//! (see [`super::semi_implicit`]; the per-spring part is in its right-hand
//! side): removes from `Δv` the angular impulse about the centre of mass
//! that the external forces do not account for, by a rigid rotation
//! `Δv_p −= ω × r_p`, `ω = I⁻¹ ΔL`.
//!
//! Three passes, each the twin of a GPU kernel: [`centre`], [`moments`],
//! [`apply`]. Every sum goes through per-block partial sums kept as the
//! GPU keeps them (`partials`, slot-major, one value per block of
//! [`REDUCTION_BLOCK`](super::REDUCTION_BLOCK) particles per slot), added in sequence: the GPU's
//! reduction order.

use super::mat3::Sym3;
use super::System;
use super::REDUCTION_BLOCK;
use crate::real::{Real, Vec3};

/// Slots of the partial sums (twin: `T_*` in `shaders/common/torque.wgsl`):
/// `Σ m`, `Σ m x` (3), `Σ r × (m Δv − dt f_ext)` (3), the inertia tensor
/// `Σ m (|r|² I − r rᵀ)` (6, [`Sym3`] order).
pub const SLOTS: usize = 13;
const MASS: usize = 0;
const MX: usize = 1;
const EXCESS: usize = 4;
const INERTIA: usize = 7;

/// Blocks per slot of `partials`.
fn blocks<R>(partials: &[R]) -> usize {
    partials.len() / SLOTS
}

/// Each block's running sum of `terms(p)` over `n` particles into slot
/// `slot` (twin: `reduce_to_partial`, whose invocation 0 adds the block's
/// values in sequence).
fn reduce<R: Real>(partials: &mut [R], slot: usize, n: usize, mut terms: impl FnMut(usize) -> R) {
    let b = blocks(partials);
    for (k, start) in (0..n).step_by(REDUCTION_BLOCK).enumerate() {
        let mut block = R::ZERO;
        for p in start..(start + REDUCTION_BLOCK).min(n) {
            block += terms(p);
        }
        partials[slot * b + k] = block;
    }
}

/// Slot `slot`'s block sums added in sequence (twin: `sum_partials`).
fn sum<R: Real>(partials: &[R], slot: usize) -> R {
    let b = blocks(partials);
    let mut total = R::ZERO;
    for &v in &partials[slot * b..(slot + 1) * b] {
        total += v;
    }
    total
}

/// The centre of mass \[m\] from [`centre`]'s sums (twin: `centre_of_mass`
/// in `shaders/common/torque.wgsl`).
pub fn centre_of_mass<R: Real>(partials: &[R]) -> Vec3<R> {
    let total = sum(partials, MASS);
    Vec3::new(
        sum(partials, MX),
        sum(partials, MX + 1),
        sum(partials, MX + 2),
    ) / total
}

/// Twin of `shaders/torque_centre.wgsl`: the block sums of `m` and `m x`.
/// Reads `x` and the masses; writes their slots of `partials`.
pub fn centre<R: Real>(sys: &System<R>, x: &[Vec3<R>], partials: &mut [R]) {
    let (n, m) = (x.len(), &sys.mass);
    reduce(partials, MASS, n, |p| m[p]);
    for k in 0..3 {
        reduce(partials, MX + k, n, |p| (x[p] * m[p]).get(k));
    }
}

/// Twin of `shaders/torque_moments.wgsl`: with `r` measured from the
/// centre of mass, the block sums of the angular impulse not explained by
/// the external forces `f_ext` \[N\], `r × (m Δv − dt f_ext)`, and of the
/// inertia tensor. Reads `x`, `dv`, `f_ext` and [`centre`]'s slots; writes
/// the moments' and inertia's slots of `partials`.
pub fn moments<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    dv: &[Vec3<R>],
    f_ext: &[Vec3<R>],
    partials: &mut [R],
) {
    let (n, m) = (x.len(), &sys.mass);
    let c = centre_of_mass(partials);
    let r = |p: usize| x[p] - c;
    let moment = |p: usize| r(p).cross(dv[p] * m[p] - f_ext[p] * sys.dt);
    for k in 0..3 {
        reduce(partials, EXCESS + k, n, |p| moment(p).get(k));
    }
    // Σ m (|r|² I − r rᵀ), one sum per stored entry.
    let term = |p: usize, k: usize| {
        let mut t = Sym3::default();
        t.add_iso_aniso(m[p] * r(p).length_squared(), -m[p], r(p));
        t.m[k]
    };
    for k in 0..6 {
        reduce(partials, INERTIA + k, n, |p| term(p, k));
    }
}

/// Twin of `shaders/torque_apply.wgsl`: `Δv −= ω × r` with `ω = I⁻¹ ΔL`
/// from the sums. A cloth collapsed onto a line or point has a singular
/// inertia tensor: it has no well-defined rotation to remove, so `Δv`
/// stays. Reads `x` and `partials`; writes `dv`.
pub fn apply<R: Real>(x: &[Vec3<R>], partials: &[R], dv: &mut [Vec3<R>]) {
    let c = centre_of_mass(partials);
    let excess = Vec3::new(
        sum(partials, EXCESS),
        sum(partials, EXCESS + 1),
        sum(partials, EXCESS + 2),
    );
    let inertia = Sym3 {
        m: std::array::from_fn(|k| sum(partials, INERTIA + k)),
    };
    let Some(inv) = inertia.inverse() else {
        return;
    };
    let omega = inv.mul(excess);
    for (d, &xp) in dv.iter_mut().zip(x) {
        *d -= omega.cross(xp - c);
    }
}
