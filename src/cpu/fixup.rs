//! Provot's deformation constraints ("fix-up"): pull every over-stretched
//! spring back to its maximum length, moving its ends along the spring in
//! proportion to their inverse masses. Pinned ends (inverse mass 0) never
//! move; a spring with both ends pinned is skipped.
//!
//! Two orders of visiting the springs:
//! - [`gauss_seidel`]: one spring after another, each seeing the previous
//!   corrections — the article's method;
//! - [`jacobi`]: every correction computed from one snapshot, then every
//!   particle applies the average of its springs' corrections, optionally
//!   over-relaxed by `ω` — what the GPU does (no write conflicts).
//!
//! Both stop early once a pass finds no spring over its limit, and return
//! the number of passes that moved something.

use super::{System, Workspace};
use crate::params::FixupMethod;
use crate::real::{Real, Vec3};

/// Relative amount, in units of the scalar's epsilon, by which a spring may
/// exceed its limit and still count as satisfied. A corrected spring lands
/// on its limit only up to rounding (a few ulps of its length); without this
/// slack that rounding would count as "over-stretched" forever and the early
/// exit would never fire.
const SLACK_ULPS: f64 = 64.0;

/// The correction for spring `s` at positions `x`: the vector `c` such that
/// end `i` moves by `−w_i c` and end `j` by `+w_j c`. `None` when the spring
/// is unconstrained, within its limit, degenerate or fully pinned.
#[inline]
fn correction<R: Real>(sys: &System<R>, s: usize, x: &[Vec3<R>]) -> Option<Vec3<R>> {
    let sp = &sys.springs[s];
    let max_len = sys.max_len[s];
    if max_len <= R::ZERO {
        return None;
    }
    let (i, j) = (sp.i as usize, sp.j as usize);
    let d = x[i] - x[j];
    let l = d.length();
    let w = sys.inv_mass[i] + sys.inv_mass[j];
    let slack = R::ONE + R::EPSILON * R::from_f64(SLACK_ULPS);
    if l > max_len * slack && w > R::ZERO {
        Some(d * ((l - max_len) / (l * w)))
    } else {
        None
    }
}

/// The fix-up `sys` asks for on `x` in place (none without a constrained
/// spring kind); `w.per_spring` and `w.active` are scratch. Returns the
/// passes that corrected at least one spring.
pub(crate) fn run<R: Real>(sys: &System<R>, x: &mut [Vec3<R>], w: &mut Workspace<R>) -> u32 {
    match sys.fixup_method {
        _ if sys.constrained_ranges.is_empty() => 0,
        FixupMethod::GaussSeidel => gauss_seidel(sys, x, sys.fixup_iterations),
        FixupMethod::Jacobi => jacobi(
            sys,
            x,
            sys.fixup_iterations,
            sys.fixup_omega,
            &mut w.per_spring,
            &mut w.active,
        ),
    }
}

/// Gauss–Seidel fix-up of `x` in place: at most `iterations` passes over the
/// constrained springs. Returns the passes that corrected at least one
/// spring.
pub fn gauss_seidel<R: Real>(sys: &System<R>, x: &mut [Vec3<R>], iterations: u32) -> u32 {
    let mut passes = 0;
    for _ in 0..iterations {
        let mut moved = false;
        for range in &sys.constrained_ranges {
            for s in range.clone() {
                if let Some(c) = correction(sys, s, x) {
                    let sp = &sys.springs[s];
                    let (i, j) = (sp.i as usize, sp.j as usize);
                    x[i] -= c * sys.inv_mass[i];
                    x[j] += c * sys.inv_mass[j];
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
        passes += 1;
    }
    passes
}

/// Jacobi fix-up of `x` in place: each pass computes every spring's
/// correction from the same snapshot, then moves each particle by `ω` times
/// the mean of its over-stretched springs' corrections. `per_spring` and
/// `active` are scratch (one entry per spring). Returns the passes that
/// corrected at least one spring.
///
/// Twin of `shaders/fixup_jacobi.wgsl`, one dispatch per pass: it reads
/// the positions from one `work` section and writes them to another, and
/// stops on the device once a pass moved nothing (the `break` here), the
/// passes counted in a status word. `iterations = 1` is one dispatch.
pub fn jacobi<R: Real>(
    sys: &System<R>,
    x: &mut [Vec3<R>],
    iterations: u32,
    omega: R,
    per_spring: &mut [Vec3<R>],
    active: &mut [bool],
) -> u32 {
    let mut passes = 0;
    for _ in 0..iterations {
        let mut moved = false;
        for range in &sys.constrained_ranges {
            for s in range.clone() {
                match correction(sys, s, x) {
                    Some(c) => {
                        per_spring[s] = c;
                        active[s] = true;
                        moved = true;
                    }
                    None => active[s] = false,
                }
            }
        }
        if !moved {
            break;
        }
        passes += 1;
        for (p, xp) in x.iter_mut().enumerate() {
            let w = sys.inv_mass[p];
            if w <= R::ZERO {
                continue;
            }
            let mut sum = Vec3::ZERO;
            let mut count = 0usize;
            for &e in sys.spring_adj.of(p) {
                let s = (e >> 1) as usize;
                if sys.max_len[s] <= R::ZERO || !active[s] {
                    continue;
                }
                // End i moves by −w c, end j by +w c.
                if e & 1 == 0 {
                    sum -= per_spring[s];
                } else {
                    sum += per_spring[s];
                }
                count += 1;
            }
            if count > 0 {
                *xp += sum * (w * omega / R::from_usize(count));
            }
        }
    }
    passes
}
