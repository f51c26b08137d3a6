//! The scalar type the CPU solver is generic over, the small 3-vector its
//! internals compute with, and the glam vectors at the API boundary.
//!
//! Why a generic scalar rather than two copies or a macro: the CPU reference
//! has two jobs. In `f64` it is the ground truth every accuracy claim is
//! measured against; in `f32` it mirrors the arithmetic the GPU performs so a
//! GPU result can be compared tightly. Both must be *the same algorithm* —
//! same operations, same summation order — or the comparison proves nothing.
//! One generic implementation guarantees that by construction, and the
//! monomorphised code is as fast as hand-written `f64` code.
//!
//! The internals do not compute in `glam`: `glam::Vec3` and `glam::DVec3`
//! are distinct types with no common trait, which is exactly the split we
//! want to avoid. The API speaks glam all the same ([`Real::Vector`] is
//! `DVec3` for `f64` and `Vec3` for `f32`, what a Bevy or wgpu host holds);
//! the conversions both ways copy the three components and round nothing.

use std::fmt::{Debug, Display};
use std::iter::Sum;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar: implemented for `f32` and `f64` only.
pub trait Real:
    Copy
    + Debug
    + Display
    + Default
    + PartialOrd
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + Sum
{
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// Smallest positive length below which a spring or triangle is treated
    /// as degenerate (its direction is undefined). Chosen far below any
    /// physical cloth feature and far above the type's underflow.
    const TINY: Self;
    /// Machine epsilon (spacing of representable numbers at 1).
    const EPSILON: Self;
    /// Name used in reports (`"f32"` / `"f64"`).
    const NAME: &'static str;
    /// The glam vector of this precision, the form positions and
    /// velocities take at the API boundary: `glam::DVec3` for `f64`,
    /// `glam::Vec3` for `f32`.
    type Vector: Vector + From<Vec3<Self>> + Into<Vec3<Self>>;

    /// Converts from `f64` (rounding to nearest for `f32`).
    fn from_f64(v: f64) -> Self;
    /// Widens to `f64` (exact).
    fn to_f64(self) -> f64;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// `true` unless NaN or infinite.
    fn is_finite(self) -> bool;

    /// The larger of two values (NaN-propagation is not relied upon).
    #[inline]
    fn max(self, other: Self) -> Self {
        if self > other {
            self
        } else {
            other
        }
    }

    /// The smaller of two values.
    #[inline]
    fn min(self, other: Self) -> Self {
        if self < other {
            self
        } else {
            other
        }
    }

    /// Converts a count (particle number, iteration) to the scalar.
    #[inline]
    fn from_usize(n: usize) -> Self {
        Self::from_f64(n as f64)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TINY: Self = 1e-12;
    const EPSILON: Self = f64::EPSILON;
    const NAME: &'static str = "f64";
    type Vector = glam::DVec3;
    #[inline]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const TINY: Self = 1e-9;
    const EPSILON: Self = f32::EPSILON;
    const NAME: &'static str = "f32";
    type Vector = glam::Vec3;
    #[inline]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

/// A 3-vector of [`Real`]s. Plain data; the operators are component-wise.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3<R> {
    /// x component.
    pub x: R,
    /// y component (up).
    pub y: R,
    /// z component.
    pub z: R,
}

impl<R: Real> Vec3<R> {
    /// The zero vector.
    pub const ZERO: Self = Self {
        x: R::ZERO,
        y: R::ZERO,
        z: R::ZERO,
    };

    /// Builds a vector from components.
    #[inline]
    pub const fn new(x: R, y: R, z: R) -> Self {
        Self { x, y, z }
    }

    /// Converts an `[f64; 3]` or a `glam::DVec3` (the parameters' form)
    /// to this precision.
    #[inline]
    pub fn from_f64(a: impl Into<[f64; 3]>) -> Self {
        let a = a.into();
        Self::new(R::from_f64(a[0]), R::from_f64(a[1]), R::from_f64(a[2]))
    }

    /// Widens to `[f64; 3]`.
    #[inline]
    pub fn to_f64(self) -> [f64; 3] {
        [self.x.to_f64(), self.y.to_f64(), self.z.to_f64()]
    }

    /// Dot product.
    #[inline]
    pub fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product.
    #[inline]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Squared Euclidean length.
    #[inline]
    pub fn length_squared(self) -> R {
        self.dot(self)
    }

    /// Euclidean length.
    #[inline]
    pub fn length(self) -> R {
        self.length_squared().sqrt()
    }

    /// `true` when every component is finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    /// The smaller of each component.
    #[inline]
    pub fn min(self, o: Self) -> Self {
        Self::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }

    /// The larger of each component.
    #[inline]
    pub fn max(self, o: Self) -> Self {
        Self::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }

    /// Component `k` (0 = x, 1 = y, 2 = z).
    #[inline]
    pub fn get(self, k: usize) -> R {
        match k {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }
}

impl<R: Real> Add for Vec3<R> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<R: Real> Sub for Vec3<R> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<R: Real> Neg for Vec3<R> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

impl<R: Real> Mul<R> for Vec3<R> {
    type Output = Self;
    #[inline]
    fn mul(self, s: R) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}

impl<R: Real> Div<R> for Vec3<R> {
    type Output = Self;
    #[inline]
    fn div(self, s: R) -> Self {
        Self::new(self.x / s, self.y / s, self.z / s)
    }
}

impl<R: Real> AddAssign for Vec3<R> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        self.x += o.x;
        self.y += o.y;
        self.z += o.z;
    }
}

impl<R: Real> SubAssign for Vec3<R> {
    #[inline]
    fn sub_assign(&mut self, o: Self) {
        self.x -= o.x;
        self.y -= o.y;
        self.z -= o.z;
    }
}

impl<R: Real> MulAssign<R> for Vec3<R> {
    #[inline]
    fn mul_assign(&mut self, s: R) {
        self.x *= s;
        self.y *= s;
        self.z *= s;
    }
}

/// A 3-vector the diagnostics accept: a position \[m\] or velocity \[m/s\]
/// as `glam::Vec3`, `glam::DVec3` or the CPU internals' own vector. The
/// measures widen it to `f64` (exactly) before they compute.
pub trait Vector: Copy + Debug + Send + Sync + 'static {
    /// The components widened to `f64` (exact).
    fn to_f64(self) -> [f64; 3];
    /// `true` when every component is finite.
    fn is_finite(self) -> bool;
}

impl<R: Real> Vector for Vec3<R> {
    #[inline]
    fn to_f64(self) -> [f64; 3] {
        Vec3::to_f64(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        Vec3::is_finite(self)
    }
}

impl Vector for glam::Vec3 {
    #[inline]
    fn to_f64(self) -> [f64; 3] {
        self.as_dvec3().to_array()
    }
    #[inline]
    fn is_finite(self) -> bool {
        glam::Vec3::is_finite(self)
    }
}

impl Vector for glam::DVec3 {
    #[inline]
    fn to_f64(self) -> [f64; 3] {
        self.to_array()
    }
    #[inline]
    fn is_finite(self) -> bool {
        glam::DVec3::is_finite(self)
    }
}

impl From<glam::Vec3> for Vec3<f32> {
    #[inline]
    fn from(v: glam::Vec3) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<Vec3<f32>> for glam::Vec3 {
    #[inline]
    fn from(v: Vec3<f32>) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<glam::DVec3> for Vec3<f64> {
    #[inline]
    fn from(v: glam::DVec3) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<Vec3<f64>> for glam::DVec3 {
    #[inline]
    fn from(v: Vec3<f64>) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_follows_right_hand_rule() {
        let x = Vec3::<f64>::new(1.0, 0.0, 0.0);
        let y = Vec3::<f64>::new(0.0, 1.0, 0.0);
        assert_eq!(x.cross(y), Vec3::new(0.0, 0.0, 1.0));
    }

    /// The conversions to glam and back keep every bit, NaN payloads and
    /// signed zeros included: the API boundary must not perturb the f32
    /// mirror of the GPU.
    #[test]
    fn glam_round_trip_keeps_every_bit() {
        let odd = [f32::from_bits(0x7fc0_1234), -0.0, f32::MIN_POSITIVE / 2.0];
        let v = Vec3::new(odd[0], odd[1], odd[2]);
        let back: Vec3<f32> = glam::Vec3::from(v).into();
        assert_eq!(
            [back.x, back.y, back.z].map(f32::to_bits),
            odd.map(f32::to_bits)
        );
        let d = Vec3::new(f64::from_bits(0x7ff8_0000_dead_beef), -0.0, 1e-310);
        let back: Vec3<f64> = glam::DVec3::from(d).into();
        assert_eq!(
            [back.x, back.y, back.z].map(f64::to_bits),
            [d.x, d.y, d.z].map(f64::to_bits)
        );
        assert_eq!(Vector::to_f64(glam::Vec3::from(v))[2], f64::from(odd[2]));
    }

    #[test]
    fn f32_round_trip_is_nearest() {
        assert_eq!(f32::from_f64(0.1).to_f64(), f64::from(0.1f32));
    }
}
