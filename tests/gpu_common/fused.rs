//! A CPU mirror that fuses: `f32` arithmetic in which every product that
//! feeds an addition or a subtraction is not rounded but fused into it
//! (`mul_add`), as a hardware GPU's compiler may do to any `a·b + c` in a
//! kernel (WGSL allows it). The CPU solver runs on it unchanged, being
//! generic over its scalar; `tests/agreement.rs` shows that it passes the
//! bounded tier against the unfused mirror, so that tier admits what real
//! hardware does.

use std::fmt;
use std::iter::Sum;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

use wgcloth::real::{Real, Vec3};

/// An `f32`, or a product of two `f32`s not yet rounded (which the next
/// addition fuses).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fused {
    /// The value (a pending product's rounded value).
    v: f32,
    /// A pending product's factors.
    a: f32,
    b: f32,
    pending: bool,
}

impl Fused {
    /// A rounded value.
    const fn of(v: f32) -> Fused {
        Fused {
            v,
            a: 0.0,
            b: 0.0,
            pending: false,
        }
    }

    /// The value as an `f32` (a pending product rounded).
    pub fn value(self) -> f32 {
        self.v
    }

    /// `self + c·sign` where `self` is a pending product, rounded once.
    fn fused_with(self, c: f32) -> Fused {
        Fused::of(self.a.mul_add(self.b, c))
    }
}

impl From<f32> for Fused {
    fn from(v: f32) -> Fused {
        Fused::of(v)
    }
}

impl PartialEq for Fused {
    fn eq(&self, o: &Fused) -> bool {
        self.v == o.v
    }
}

impl PartialOrd for Fused {
    fn partial_cmp(&self, o: &Fused) -> Option<std::cmp::Ordering> {
        self.v.partial_cmp(&o.v)
    }
}

impl fmt::Display for Fused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.v, f)
    }
}

impl Mul for Fused {
    type Output = Fused;
    fn mul(self, o: Fused) -> Fused {
        Fused {
            v: self.v * o.v,
            a: self.v,
            b: o.v,
            pending: true,
        }
    }
}

impl Add for Fused {
    type Output = Fused;
    fn add(self, o: Fused) -> Fused {
        match (self.pending, o.pending) {
            (true, _) => self.fused_with(o.v),
            (false, true) => o.fused_with(self.v),
            (false, false) => Fused::of(self.v + o.v),
        }
    }
}

impl Sub for Fused {
    type Output = Fused;
    fn sub(self, o: Fused) -> Fused {
        match (self.pending, o.pending) {
            (true, _) => self.fused_with(-o.v),
            (false, true) => (-o).fused_with(self.v),
            (false, false) => Fused::of(self.v - o.v),
        }
    }
}

impl Neg for Fused {
    type Output = Fused;
    fn neg(self) -> Fused {
        Fused {
            v: -self.v,
            a: -self.a,
            b: self.b,
            pending: self.pending,
        }
    }
}

impl Div for Fused {
    type Output = Fused;
    fn div(self, o: Fused) -> Fused {
        Fused::of(self.v / o.v)
    }
}

impl AddAssign for Fused {
    fn add_assign(&mut self, o: Fused) {
        *self = *self + o;
    }
}

impl SubAssign for Fused {
    fn sub_assign(&mut self, o: Fused) {
        *self = *self - o;
    }
}

impl MulAssign for Fused {
    fn mul_assign(&mut self, o: Fused) {
        *self = *self * o;
    }
}

impl Sum for Fused {
    fn sum<I: Iterator<Item = Fused>>(iter: I) -> Fused {
        iter.fold(Fused::of(0.0), |s, x| s + x)
    }
}

impl Real for Fused {
    const ZERO: Self = Fused::of(0.0);
    const ONE: Self = Fused::of(1.0);
    const TINY: Self = Fused::of(<f32 as Real>::TINY);
    const EPSILON: Self = Fused::of(f32::EPSILON);
    const NAME: &'static str = "f32 (fused)";
    type Vector = Vec3<Fused>;

    fn from_f64(v: f64) -> Self {
        Fused::of(v as f32)
    }
    fn to_f64(self) -> f64 {
        f64::from(self.v)
    }
    fn sqrt(self) -> Self {
        Fused::of(self.v.sqrt())
    }
    fn abs(self) -> Self {
        Fused::of(self.v.abs())
    }
    fn is_finite(self) -> bool {
        self.v.is_finite()
    }
}

/// A fused vector as glam's.
pub fn to_glam(v: Vec3<Fused>) -> wgcloth::glam::Vec3 {
    wgcloth::glam::Vec3::new(v.x.value(), v.y.value(), v.z.value())
}
