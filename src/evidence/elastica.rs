//! The heavy elastica: a clamped, inextensible strip bending under its own
//! weight, the reference curve of [`mod@super::cantilever`].
//!
//! With arc length `s ∈ [0, 1]` in units of the length `L`, `θ(s)` the
//! angle of the strip below the horizontal, bending stiffness `B` per unit
//! width [N·m] and weight `ρ g` per unit area [N/m²], the bending moment at
//! `s` is `B θ'(s)` and equals the moment of the weight beyond `s`; its
//! derivative gives
//!
//! ```text
//! θ'' = −Γ (1 − s) cos θ,   θ(0) = 0 (clamped level),   θ'(1) = 0 (free tip),
//! Γ = ρ g L³ / B.
//! ```
//!
//! The solver shoots on the clamp curvature `a = θ'(0)`: [RK4](STEPS) from
//! `s = 0` to `1` gives the tip moment `θ'(1)`, non-negative at `a = Γ / 2`
//! (since `∫(1 − s) cos θ ds ≤ 1/2`). Below the physical root it is
//! negative, but far below (a strip that curls up and over for large `Γ`)
//! it can turn positive again, so the bracket is found by stepping down
//! from `Γ / 2` in [`SCAN`] steps to the first negative value, and the
//! largest root, the physical one (the shape bending monotonically down),
//! is then bisected. For small `Γ`, `θ ≈ Γ (1 − (1 − s)³) / 6` and the tip drops by
//! `Γ / 8` (`δ = ρ g L⁴ / (8 B)`).

use crate::error::{Error, Result};

/// RK4 steps over the strip's length. The solution is smooth (a cubic in
/// the small-deflection limit), so RK4's `O(h⁴)` error at 400 steps is
/// near `1e-12`, far below the cloth's deviations.
pub const STEPS: u32 = 400;

/// Steps of the scan for the bracket, each `Γ / 400`: fine enough not to
/// straddle two roots over the range solved (the tests check that the
/// shape found grows monotonically with `Γ` and never bends past
/// vertical).
pub const SCAN: u32 = 200;

/// Bisection halvings of the bracket (`Γ / 400` wide): 60 bring it to
/// below the `f64` resolution of the root.
pub const BISECTIONS: u32 = 60;

/// Largest `Γ` solved: ten times the bench's range. Past it the tip angle
/// is within `1e-6` rad of vertical and the clamp curvature so large that
/// [`STEPS`] resolves it less and less well.
pub const MAX_GAMMA: f64 = 1e3;

/// The shape of the strip's tip at rest, in units of its length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tip {
    /// Tip drop below the clamp over length, `δ / L`.
    pub drop: f64,
    /// Horizontal reach of the tip over length, `x(1) / L`.
    pub reach: f64,
    /// Tip angle below the horizontal \[rad\].
    pub angle: f64,
    /// Curvature at the clamp times `L`, `θ'(0)`.
    pub clamp_curvature: f64,
}

/// Integrates the strip from the clamp with clamp curvature `a`: the tip
/// state `(θ, θ', x, y)` (`y` positive downwards).
fn shoot(gamma: f64, a: f64) -> [f64; 4] {
    let rhs = |s: f64, u: [f64; 4]| -> [f64; 4] {
        [
            u[1],
            -gamma * (1.0 - s) * u[0].cos(),
            u[0].cos(),
            u[0].sin(),
        ]
    };
    let h = 1.0 / f64::from(STEPS);
    let mut u = [0.0, a, 0.0, 0.0];
    for k in 0..STEPS {
        let s = f64::from(k) * h;
        let add = |u: [f64; 4], d: [f64; 4], f: f64| std::array::from_fn(|i| u[i] + f * d[i]);
        let k1 = rhs(s, u);
        let k2 = rhs(s + h / 2.0, add(u, k1, h / 2.0));
        let k3 = rhs(s + h / 2.0, add(u, k2, h / 2.0));
        let k4 = rhs(s + h, add(u, k3, h));
        u = std::array::from_fn(|i| u[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    u
}

/// The rest shape's tip at `Γ = ρ g L³ / B`, `0 ≤ Γ ≤` [`MAX_GAMMA`].
pub fn tip(gamma: f64) -> Result<Tip> {
    if !(0.0..=MAX_GAMMA).contains(&gamma) {
        return Err(Error::InvalidParameter {
            key: "elastica.gamma".into(),
            allowed: format!("0 ≤ Γ ≤ {MAX_GAMMA} (ρ g L³ / B, dimensionless)"),
            got: crate::params::format_number(gamma),
        });
    }
    let top = gamma / 2.0;
    let mut hi = top;
    let mut lo = 0.0;
    for k in 1..=SCAN {
        let a = top * (1.0 - f64::from(k) / f64::from(SCAN));
        if shoot(gamma, a)[1] < 0.0 {
            lo = a;
            break;
        }
        hi = a;
    }
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if shoot(gamma, mid)[1] < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = 0.5 * (lo + hi);
    let [angle, _, reach, drop] = shoot(gamma, a);
    Ok(Tip {
        drop,
        reach,
        angle,
        clamp_curvature: a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative agreement with `Γ / 8` at `Γ = 10⁻⁴`: the first nonlinear
    /// correction is of relative order `Γ²` (`1e-8`), so only the solver's
    /// own error (near `1e-12`) remains; `1e-6` leaves room for it.
    const SMALL_LIMIT_TOLERANCE: f64 = 1e-6;

    #[test]
    fn small_deflection_limit() {
        let gamma = 1e-4;
        let t = tip(gamma).expect("solvable");
        let rel = (t.drop - gamma / 8.0).abs() / (gamma / 8.0);
        assert!(
            rel < SMALL_LIMIT_TOLERANCE,
            "δ/L {} vs Γ/8, rel {rel:e}",
            t.drop
        );
        // The small-deflection clamp curvature Γ / 2 and tip angle Γ / 6.
        assert!((t.clamp_curvature - gamma / 2.0).abs() / (gamma / 2.0) < SMALL_LIMIT_TOLERANCE);
        assert!((t.angle - gamma / 6.0).abs() / (gamma / 6.0) < SMALL_LIMIT_TOLERANCE);
    }

    #[test]
    fn drop_and_angle_grow_with_gamma_and_stay_physical() {
        let mut last = tip(0.0).expect("solvable");
        assert_eq!(last.drop, 0.0);
        // Γ = 10⁻² … 10² in steps of 10^0.1.
        for e in -20..=20 {
            let t = tip(10f64.powf(f64::from(e) / 10.0)).expect("solvable");
            assert!(
                t.drop > last.drop && t.angle > last.angle,
                "{t:?} after {last:?}"
            );
            assert!(
                t.reach < last.reach || last.drop == 0.0,
                "{t:?} after {last:?}"
            );
            // An inextensible strip: its tip stays within one length of the
            // clamp, and never bends past vertical.
            assert!(t.drop.hypot(t.reach) <= 1.0 + 1e-12, "{t:?}");
            assert!(t.angle < std::f64::consts::FRAC_PI_2, "{t:?}");
            last = t;
        }
    }

    #[test]
    fn refuses_gamma_out_of_range() {
        assert!(tip(-1.0).is_err());
        assert!(tip(f64::NAN).is_err());
        assert!(tip(2.0 * MAX_GAMMA).is_err());
    }
}
