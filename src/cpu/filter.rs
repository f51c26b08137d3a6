//! Desbrun's constant filter `W = (M − dt² H)⁻¹` restricted to the free
//! particles, stored two ways.
//!
//! `H` is the `k`-weighted graph Laplacian of the springs (`H_pq = k` for a
//! spring `p–q`, `H_pp = −Σ k`), so `A = M − dt² H` is symmetric positive
//! definite and one scalar per particle pair serves all three coordinates.
//! Pinned particles are removed from `A` (their rows and columns), but the
//! springs that tie a free particle to a pin still add to its diagonal —
//! that is what makes the filter hold the cloth up by its pins instead of
//! leaking motion into them.
//!
//! - [`DenseFilter`]: the explicit inverse, `N_free²` numbers; applying it
//!   is one dense matrix-vector product per coordinate. The article's method.
//! - [`BandedFilter`]: a Cholesky factor of `A` in band storage,
//!   `N_free · (bw + 1)` numbers where `bw` is the bandwidth of the particle
//!   ordering (about `2 · min(nx, ny)` with bend springs: the grid is
//!   numbered along its shorter side); applying it is a forward and a back
//!   substitution. No `N²` memory, so a 257 × 257 cloth fits.
//!
//! Both are factored in `f64` whatever the solver's precision — as a GPU
//! host would build them before uploading — and applied in the solver's
//! precision.

use super::System;
use crate::budget::{try_collect, try_vec};
use crate::error::{Error, Result};
use crate::real::{Real, Vec3};

/// The free particles in filter order and the matrix `A` in sparse form.
#[derive(Clone, Debug)]
pub struct FilterSystem {
    /// Free particle indices, in filter order.
    pub order: Vec<u32>,
    /// `A_pp` for each position in `order`.
    pub diag: Vec<f64>,
    /// Off-diagonal entries `(row, col, value)` with `row > col`, positions
    /// in `order`.
    pub off: Vec<(u32, u32, f64)>,
}

impl FilterSystem {
    /// Assembles `A = M − dt² H` over the free particles of `sys`, ordered
    /// row-major when the grid is at least as tall as it is wide and
    /// column-major otherwise (the smaller bandwidth).
    pub fn new<R: Real>(sys: &System<R>, grid: Option<(usize, usize)>) -> FilterSystem {
        let n = sys.mass.len();
        let mut particles: Vec<u32> = (0..n as u32).collect();
        particles.sort_by_key(|&p| FilterSystem::rank(p as usize, grid));
        let order: Vec<u32> = particles
            .into_iter()
            .filter(|&p| sys.inv_mass[p as usize] > R::ZERO)
            .collect();
        let mut position = vec![u32::MAX; n];
        for (k, &p) in order.iter().enumerate() {
            position[p as usize] = k as u32;
        }
        let dt2 = sys.dt.to_f64() * sys.dt.to_f64();
        let mut diag: Vec<f64> = order
            .iter()
            .map(|&p| sys.mass[p as usize].to_f64())
            .collect();
        let mut off = Vec::new();
        for sp in &sys.springs {
            let k = sp.k.to_f64() * dt2;
            let (pi, pj) = (position[sp.i as usize], position[sp.j as usize]);
            if pi != u32::MAX {
                diag[pi as usize] += k;
            }
            if pj != u32::MAX {
                diag[pj as usize] += k;
            }
            if pi != u32::MAX && pj != u32::MAX {
                off.push((pi.max(pj), pi.min(pj), -k));
            }
        }
        // The linear bending operator enters exactly, scaled by dt² + dt β.
        if let Some(b) = &sys.bending {
            let scale = b.scale.to_f64();
            for (p, &pi) in position.iter().enumerate() {
                if pi == u32::MAX {
                    continue;
                }
                let (cols, q) = b.row(p);
                for (&j, &q) in cols.iter().zip(q) {
                    let q = q.to_f64() * scale;
                    diag[pi as usize] -= q;
                    let pj = position[j as usize];
                    if pj != u32::MAX && pj < pi {
                        off.push((pi, pj, q));
                    }
                }
            }
        }
        FilterSystem { order, diag, off }
    }

    /// Particle `p`'s place in filter order before pinned particles are
    /// left out: row-major, or column-major when the grid is wider than
    /// tall.
    pub fn rank(p: usize, grid: Option<(usize, usize)>) -> usize {
        match grid {
            Some((nx, ny)) if nx > ny => (p % nx) * ny + p / nx,
            _ => p,
        }
    }

    /// Number of free particles.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// `true` when every particle is pinned.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Largest `row − col` among the off-diagonal entries.
    pub fn bandwidth(&self) -> usize {
        self.off
            .iter()
            .map(|&(r, c, _)| (r - c) as usize)
            .max()
            .unwrap_or(0)
    }
}

/// Banded Cholesky factor `A = L Lᵀ`; row `i` stores `L[i][i−bw..=i]`.
#[derive(Clone, Debug)]
pub struct BandedFilter<R> {
    order: Vec<u32>,
    bw: usize,
    band: Vec<R>,
}

/// The error of a failed factorisation: `A` was not positive definite
/// (cannot happen for positive masses and non-negative stiffness, but a
/// NaN can).
fn not_positive_definite() -> Error {
    Error::InvalidParameter {
        key: "semi_implicit".into(),
        allowed: "a filter matrix M − dt²H that is positive definite".into(),
        got: "a matrix that is not (non-finite stiffness or mass?)".into(),
    }
}

fn banded_cholesky(sys: &FilterSystem) -> Result<(usize, Vec<f64>)> {
    let n = sys.len();
    let bw = sys.bandwidth();
    let w = bw + 1;
    let mut band = try_vec(
        n.saturating_mul(w),
        0.0f64,
        "the semi-implicit filter's banded factor",
    )?;
    for (i, &d) in sys.diag.iter().enumerate() {
        band[i * w + bw] = d;
    }
    for &(r, c, v) in &sys.off {
        let (r, c) = (r as usize, c as usize);
        band[r * w + (c + bw - r)] += v;
    }
    if !crate::band::cholesky_in_place(n, bw, &mut band) {
        return Err(not_positive_definite());
    }
    Ok((bw, band))
}

impl<R: Real> BandedFilter<R> {
    /// Factors `A`; an `A` that is not positive definite is an invalid
    /// parameter.
    pub fn new(sys: &FilterSystem) -> Result<Self> {
        let (bw, band) = banded_cholesky(sys)?;
        Ok(BandedFilter {
            order: sys.order.clone(),
            bw,
            band: try_collect(
                band.into_iter().map(R::from_f64),
                "the semi-implicit filter's banded factor",
            )?,
        })
    }

    /// Solves `A y = b` for all three coordinates; `b` and `out` are indexed
    /// by particle, `scratch` by filter position.
    pub fn apply(&self, b: &[Vec3<R>], out: &mut [Vec3<R>], scratch: &mut Vec<Vec3<R>>) {
        scratch.clear();
        scratch.extend(self.order.iter().map(|&p| b[p as usize]));
        let y = scratch;
        crate::band::solve_in_place(self.bw, &self.band, y);
        for (k, &p) in self.order.iter().enumerate() {
            out[p as usize] = y[k];
        }
    }

    /// Numbers stored.
    pub fn stored(&self) -> usize {
        self.band.len()
    }
}

/// The explicit inverse `W = A⁻¹`, row-major over filter positions.
#[derive(Clone, Debug)]
pub struct DenseFilter<R> {
    order: Vec<u32>,
    w: Vec<R>,
}

impl<R: Real> DenseFilter<R> {
    /// Inverts `A` through its (banded) Cholesky factor, one column at a
    /// time; `W` is symmetric so column `j` is also row `j`.
    pub fn new(sys: &FilterSystem) -> Result<Self> {
        let factor = BandedFilter::<f64>::new(sys)?;
        let n = sys.len();
        let mut w = try_vec(
            n.saturating_mul(n),
            R::ZERO,
            "the semi-implicit dense filter",
        )?;
        let mut e = vec![Vec3::<f64>::ZERO; n];
        let mut col = vec![Vec3::<f64>::ZERO; n];
        let mut scratch = Vec::new();
        // `apply` works in particle indices; use an identity order copy so
        // positions and indices coincide while building.
        let by_position = BandedFilter {
            order: (0..n as u32).collect(),
            bw: factor.bw,
            band: factor.band,
        };
        for j in 0..n {
            e[j] = Vec3::new(1.0, 0.0, 0.0);
            by_position.apply(&e, &mut col, &mut scratch);
            e[j] = Vec3::ZERO;
            for (i, c) in col.iter().enumerate() {
                w[j * n + i] = R::from_f64(c.x);
            }
        }
        Ok(DenseFilter {
            order: sys.order.clone(),
            w,
        })
    }

    /// `W`, row-major over filter positions.
    pub fn matrix(&self) -> &[R] {
        &self.w
    }

    /// The particle at each filter position.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// `out = W b` for all three coordinates; `b` and `out` by particle.
    pub fn apply(&self, b: &[Vec3<R>], out: &mut [Vec3<R>], scratch: &mut Vec<Vec3<R>>) {
        let n = self.order.len();
        scratch.clear();
        scratch.extend(self.order.iter().map(|&p| b[p as usize]));
        for (k, &p) in self.order.iter().enumerate() {
            let row = &self.w[k * n..(k + 1) * n];
            let mut acc = Vec3::ZERO;
            for (wv, bv) in row.iter().zip(scratch.iter()) {
                acc += *bv * *wv;
            }
            out[p as usize] = acc;
        }
    }

    /// Numbers stored.
    pub fn stored(&self) -> usize {
        self.w.len()
    }
}

/// The filter a semi-implicit solver holds.
#[derive(Clone, Debug)]
pub enum ConstantFilter<R> {
    /// Explicit inverse.
    Dense(DenseFilter<R>),
    /// Banded Cholesky factor.
    Banded(BandedFilter<R>),
}

impl<R: Real> ConstantFilter<R> {
    /// `out = W b` on the free particles (others untouched).
    pub fn apply(&self, b: &[Vec3<R>], out: &mut [Vec3<R>], scratch: &mut Vec<Vec3<R>>) {
        match self {
            ConstantFilter::Dense(f) => f.apply(b, out, scratch),
            ConstantFilter::Banded(f) => f.apply(b, out, scratch),
        }
    }

    /// `"dense"` or `"banded"`.
    pub fn name(&self) -> &'static str {
        match self {
            ConstantFilter::Dense(_) => "dense",
            ConstantFilter::Banded(_) => "banded",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::forces::bending_product;
    use crate::material::Material;
    use crate::model::{ClothSpec, Model, Pin};
    use crate::params::Params;

    /// Rounding of `f64` sums of a few dozen terms up to ~1e3.
    const ROUNDING: f64 = 1e-9;

    /// `A = M − dt² H` carries the linear bending operator as
    /// `(dt² + dt β) Q`: its product with a vector is the mass, the
    /// springs' Laplacian and the bending rows applied one by one.
    #[test]
    fn filter_matrix_carries_the_bending_operator() {
        let material = Material {
            bending: 1e-3.into(),
            damping: 0.01,
            ..Material::default()
        };
        let spec = ClothSpec {
            nx: 6,
            ny: 5,
            pins: vec![Pin::Index(0)],
            ..ClothSpec::default()
        };
        let params = Params {
            springs: material.spring_params(),
            ..Params::default()
        };
        let mut model = Model::new(&spec, &params.springs).unwrap();
        let cells = model.grid_cells();
        material
            .apply(
                &mut model,
                cells.iter().map(|c| (&c[..], glam::DVec3::ZERO)),
            )
            .unwrap();
        let sys = System::<f64>::new(&model, &params);
        let fs = FilterSystem::new(&sys, None);
        let n = sys.mass.len();
        let y: Vec<Vec3<f64>> = (0..n)
            .map(|p| Vec3::new((p as f64 * 0.37).sin(), 0.0, 0.0))
            .collect();
        // A y by the assembled entries (free particles only).
        let mut ay = vec![0.0; fs.len()];
        for (k, &p) in fs.order.iter().enumerate() {
            ay[k] += fs.diag[k] * y[p as usize].x;
        }
        for &(r, c, v) in &fs.off {
            ay[r as usize] += v * y[fs.order[c as usize] as usize].x;
            ay[c as usize] += v * y[fs.order[r as usize] as usize].x;
        }
        // A y by its definition, with pinned particles' y taken as zero.
        let free = |p: usize| sys.inv_mass[p] > 0.0;
        let z: Vec<Vec3<f64>> = (0..n)
            .map(|p| if free(p) { y[p] } else { Vec3::ZERO })
            .collect();
        let dt2 = sys.dt * sys.dt;
        let b = sys.bending.as_ref().unwrap();
        for (k, &p) in fs.order.iter().enumerate() {
            let p = p as usize;
            let mut expect = sys.mass[p] * z[p].x;
            for sp in &sys.springs {
                let (i, j) = (sp.i as usize, sp.j as usize);
                if i == p || j == p {
                    let other = if i == p { j } else { i };
                    expect += dt2 * sp.k * (z[p].x - z[other].x);
                }
            }
            expect += b.scale * bending_product(&sys, &z, p).x;
            assert!(
                (ay[k] - expect).abs() < ROUNDING,
                "particle {p}: {} against {expect}",
                ay[k]
            );
        }
    }
}
