//! Forces: springs (elastic + damping), gravity and wind on triangles.
//!
//! Every per-particle sum is a *gather* in a fixed order — gravity first,
//! then the particle's incident springs in ascending spring index, then its
//! incident triangles in ascending index — exactly as the GPU kernels sum.
//! Per-spring and per-triangle quantities are computed once, in their own
//! pass, and then gathered with a sign.

use super::System;
use crate::model::Adjacency;
use crate::real::{Real, Vec3};

/// Unit direction from `j` to `i` and the distance, for a spring between
/// positions `xi` and `xj`. A degenerate spring (both ends within
/// [`Real::TINY`]) has no direction: `n = 0`, so it exerts no force and
/// contributes only its isotropic part to Jacobians — never NaN.
#[inline]
pub fn spring_frame<R: Real>(xi: Vec3<R>, xj: Vec3<R>) -> (Vec3<R>, R) {
    let d = xi - xj;
    let l = d.length();
    if l > R::TINY {
        (d / l, l)
    } else {
        (Vec3::ZERO, l)
    }
}

/// Force on end `i` of spring `s` (end `j` receives the negative):
/// `−(k (l − L) + kd (v_i − v_j)·n) n`.
#[inline]
pub fn spring_force<R: Real>(sys: &System<R>, s: usize, x: &[Vec3<R>], v: &[Vec3<R>]) -> Vec3<R> {
    let sp = &sys.springs[s];
    let (i, j) = (sp.i as usize, sp.j as usize);
    let (n, l) = spring_frame(x[i], x[j]);
    let stretch = l - sp.rest;
    let rate = (v[i] - v[j]).dot(n);
    n * (-(sp.k * stretch + sp.kd * rate))
}

/// Sums `±per_spring\[s\]` over the incident springs of particle `p` in the
/// adjacency's order (`+` where `p` is end `i`, `−` where it is end `j`).
#[inline]
pub fn gather_signed<R: Real>(adj: &Adjacency, per_spring: &[Vec3<R>], p: usize) -> Vec3<R> {
    let mut acc = Vec3::ZERO;
    for &e in adj.of(p) {
        let value = per_spring[(e >> 1) as usize];
        if e & 1 == 0 {
            acc += value;
        } else {
            acc -= value;
        }
    }
    acc
}

/// Wind force on one triangle, already divided by three (each vertex gets
/// this share). Drag along the normal, `−c_d A (u·n)|u·n| n`, and lift
/// perpendicular to the relative flow `u`, `−c_l A (u·n)|u| (n − (n·û)û)`,
/// with `u` the triangle's mean velocity minus the wind velocity. A
/// degenerate triangle (no normal) gets no force.
#[inline]
pub fn wind_triangle_force<R: Real>(
    sys: &System<R>,
    t: usize,
    x: &[Vec3<R>],
    v: &[Vec3<R>],
) -> Vec3<R> {
    let Some(wind) = &sys.wind else {
        return Vec3::ZERO;
    };
    let [a, b, c] = sys.triangles[t].map(|p| p as usize);
    let cross = (x[b] - x[a]).cross(x[c] - x[a]);
    let twice_area = cross.length();
    if !(twice_area.is_finite() && twice_area > R::TINY) {
        return Vec3::ZERO;
    }
    let third = R::ONE / R::from_f64(3.0);
    let half = R::from_f64(0.5);
    let normal = cross / twice_area;
    let area = twice_area * half;
    let u = (v[a] + v[b] + v[c]) * third - wind.velocity;
    let un = u.dot(normal);
    let mut f = normal * (-wind.drag * area * un * un.abs());
    let speed = u.length();
    if wind.lift > R::ZERO && speed > R::TINY {
        let dir = u / speed;
        let perp = normal - dir * normal.dot(dir);
        f += perp * (-wind.lift * area * un * speed);
    }
    f * third
}

/// Twin of `shaders/spring_forces.wgsl`: every spring's force on its end
/// `i` \[N\] (end `j` receives the negative). Reads `x`, `v`; writes
/// `per_spring` (the GPU's `S_FORCE` section, whose w is 0).
pub fn spring_forces<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    v: &[Vec3<R>],
    per_spring: &mut [Vec3<R>],
) {
    for (s, out) in per_spring.iter_mut().enumerate() {
        *out = spring_force(sys, s, x, v);
    }
}

/// Every triangle's wind force share \[N\] into `per_triangle` (nothing
/// without wind). The GPU keeps no per-triangle array: each particle
/// recomputes its triangles' shares where it sums them (`add_wind` in
/// `shaders/common/physics.wgsl`), with the same arithmetic.
pub fn wind_forces<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    v: &[Vec3<R>],
    per_triangle: &mut [Vec3<R>],
) {
    if sys.wind.is_some() {
        for (t, out) in per_triangle.iter_mut().enumerate() {
            *out = wind_triangle_force(sys, t, x, v);
        }
    }
}

/// `f` plus the wind shares of particle `p`'s triangles, in adjacency
/// order (twin: `add_wind` in `shaders/common/physics.wgsl`).
#[inline]
fn add_wind<R: Real>(sys: &System<R>, per_triangle: &[Vec3<R>], p: usize, f: Vec3<R>) -> Vec3<R> {
    let mut acc = f;
    if sys.wind.is_some() {
        for &t in sys.triangle_adj.of(p) {
            acc += per_triangle[t as usize];
        }
    }
    acc
}

/// `(Q y)_p = Σ_j Q_pj (y_j − y_p)` over particle `p`'s bending row in
/// ascending column order (`Q` the linear bending operator,
/// [`crate::bending`]; zero without one). Twin: `bending_product` in
/// `shaders/common/bending.wgsl`.
#[inline]
pub fn bending_product<R: Real>(sys: &System<R>, y: &[Vec3<R>], p: usize) -> Vec3<R> {
    let mut acc = Vec3::ZERO;
    if let Some(b) = &sys.bending {
        let (cols, q) = b.row(p);
        for (&j, &q) in cols.iter().zip(q) {
            acc += (y[j as usize] - y[p]) * q;
        }
    }
    acc
}

/// `Q_pp = −Σ_j Q_pj` of particle `p`'s bending row, summed in column
/// order (twin: `bending_diagonal` in `shaders/common/bending.wgsl`).
#[inline]
pub fn bending_diagonal<R: Real>(b: &super::BendingR<R>, p: usize) -> R {
    let mut acc = R::ZERO;
    for &q in b.row(p).1 {
        acc -= q;
    }
    acc
}

/// The linear bending force on particle `p` \[N\], `−(Q (x + β v))_p`
/// summed per entry as `Q_pj ((x_j − x_p) + β (v_j − v_p))` (zero without
/// a bending operator). Twin: `bending_force` in
/// `shaders/common/bending.wgsl`.
#[inline]
pub fn bending_force<R: Real>(sys: &System<R>, x: &[Vec3<R>], v: &[Vec3<R>], p: usize) -> Vec3<R> {
    let mut acc = Vec3::ZERO;
    if let Some(b) = &sys.bending {
        let (cols, q) = b.row(p);
        for (&j, &q) in cols.iter().zip(q) {
            let (j, beta) = (j as usize, b.damping);
            acc -= ((x[j] - x[p]) + (v[j] - v[p]) * beta) * q;
        }
    }
    acc
}

/// Particle `p`'s total force \[N\] from the spring and triangle passes:
/// `m g`, then its springs, then the linear bending force, then its
/// triangles' wind (twin: `total_force` in
/// `shaders/common/physics.wgsl`).
#[inline]
pub fn total_force<R: Real>(
    sys: &System<R>,
    per_spring: &[Vec3<R>],
    per_triangle: &[Vec3<R>],
    x: &[Vec3<R>],
    v: &[Vec3<R>],
    p: usize,
) -> Vec3<R> {
    let mut acc = sys.gravity * sys.mass[p];
    acc += gather_signed(&sys.spring_adj, per_spring, p);
    if sys.bending.is_some() {
        acc += bending_force(sys, x, v, p);
    }
    add_wind(sys, per_triangle, p, acc)
}

/// External (non-spring) force on each particle \[N\]: gravity and wind
/// (twin: `external_force` in `shaders/common/physics.wgsl`). Used by the
/// semi-implicit torque compensation, which must not remove the torque
/// that external forces legitimately apply.
pub fn external_forces<R: Real>(
    sys: &System<R>,
    x: &[Vec3<R>],
    v: &[Vec3<R>],
    per_triangle: &mut [Vec3<R>],
    f: &mut [Vec3<R>],
) {
    wind_forces(sys, x, v, per_triangle);
    for (p, out) in f.iter_mut().enumerate() {
        *out = add_wind(sys, per_triangle, p, sys.gravity * sys.mass[p]);
    }
}
