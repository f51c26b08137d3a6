//! Symmetric 3×3 matrices: the block-diagonal preconditioner of the implicit
//! CG and the inertia tensor of the semi-implicit torque compensation.

use crate::real::{Real, Vec3};

/// A symmetric 3×3 matrix stored as its upper triangle
/// `[xx, yy, zz, xy, xz, yz]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym3<R> {
    /// `[xx, yy, zz, xy, xz, yz]`.
    pub m: [R; 6],
}

impl<R: Real> Sym3<R> {
    /// `s · I`.
    #[inline]
    pub fn scaled_identity(s: R) -> Self {
        Self {
            m: [s, s, s, R::ZERO, R::ZERO, R::ZERO],
        }
    }

    /// Adds `a · I + b · n nᵀ`.
    #[inline]
    pub fn add_iso_aniso(&mut self, a: R, b: R, n: Vec3<R>) {
        let m = &mut self.m;
        m[0] += a + b * n.x * n.x;
        m[1] += a + b * n.y * n.y;
        m[2] += a + b * n.z * n.z;
        m[3] += b * n.x * n.y;
        m[4] += b * n.x * n.z;
        m[5] += b * n.y * n.z;
    }

    /// Adds `s · r rᵀ` (negative `s` subtracts).
    #[inline]
    pub fn add_outer(&mut self, s: R, r: Vec3<R>) {
        self.add_iso_aniso(R::ZERO, s, r);
    }

    /// Matrix-vector product.
    #[inline]
    pub fn mul(&self, v: Vec3<R>) -> Vec3<R> {
        let [xx, yy, zz, xy, xz, yz] = self.m;
        Vec3::new(
            xx * v.x + xy * v.y + xz * v.z,
            xy * v.x + yy * v.y + yz * v.z,
            xz * v.x + yz * v.y + zz * v.z,
        )
    }

    /// The inverse by cofactors, or `None` when the determinant is not
    /// safely positive relative to the matrix's scale (the callers only
    /// invert positive-definite matrices, so a tiny determinant means a
    /// degenerate input, not a legitimate value).
    pub fn inverse(&self) -> Option<Self> {
        let [xx, yy, zz, xy, xz, yz] = self.m;
        let c_xx = yy * zz - yz * yz;
        let c_xy = xz * yz - xy * zz;
        let c_xz = xy * yz - xz * yy;
        let det = xx * c_xx + xy * c_xy + xz * c_xz;
        let scale = xx.abs().max(yy.abs()).max(zz.abs());
        let floor = R::TINY * scale * scale * scale;
        if !(det.is_finite() && det > floor) {
            return None;
        }
        let inv = R::ONE / det;
        Some(Self {
            m: [
                c_xx * inv,
                (xx * zz - xz * xz) * inv,
                (xx * yy - xy * xy) * inv,
                c_xy * inv,
                c_xz * inv,
                (xy * xz - xx * yz) * inv,
            ],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let mut a = Sym3::<f64>::scaled_identity(2.0);
        a.add_iso_aniso(0.5, 3.0, Vec3::new(0.6, 0.0, 0.8));
        a.add_outer(1.0, Vec3::new(0.1, 0.7, -0.2));
        let inv = a.inverse().expect("positive definite");
        for e in [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ] {
            let back = a.mul(inv.mul(e));
            assert!((back - e).length() < 1e-12, "{back:?} vs {e:?}");
        }
    }

    #[test]
    fn singular_matrix_has_no_inverse() {
        let mut a = Sym3::<f64>::default();
        a.add_outer(1.0, Vec3::new(1.0, 2.0, 3.0));
        assert!(a.inverse().is_none());
    }
}
