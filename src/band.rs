//! Symmetric positive definite matrices in band storage: the Cholesky
//! factor `A = L Lᵀ` and its solve, shared by the semi-implicit filter
//! ([`crate::cpu::filter`]) and the static equilibrium of the `wgcloth
//! bench` harness (`evidence::equilibrium`).
//!
//! Row `i` of an `n × n` matrix of half-bandwidth `bw` is stored as its
//! `bw + 1` entries `A[i][i − bw ..= i]` (entries before column 0 unused),
//! `n · (bw + 1)` numbers in all; the factor overwrites it in the same
//! layout.

use std::ops::{Div, Mul, Sub};

/// Factors the band `band` (layout: module docs) into `L` in place,
/// row-oriented (Cholesky–Crout): `L[i][j]` for `j ≤ i` from the dot
/// product of rows `i` and `j` over their common band. `false` where the
/// matrix is not positive definite (or not finite); `band` is then left
/// part-factored.
pub(crate) fn cholesky_in_place(n: usize, bw: usize, band: &mut [f64]) -> bool {
    let w = bw + 1;
    for i in 0..n {
        let i0 = i.saturating_sub(bw);
        for j in i0..=i {
            let j0 = j.saturating_sub(bw).max(i0);
            let mut s = band[i * w + (j + bw - i)];
            let row_i = &band[i * w + (j0 + bw - i)..i * w + (j + bw - i)];
            let row_j = &band[j * w + (j0 + bw - j)..j * w + bw];
            for (a, b) in row_i.iter().zip(row_j) {
                s -= a * b;
            }
            if j == i {
                if !(s.is_finite() && s > 0.0) {
                    return false;
                }
                band[i * w + bw] = s.sqrt();
            } else {
                band[i * w + (j + bw - i)] = s / band[j * w + bw];
            }
        }
    }
    true
}

/// Solves `L Lᵀ x = y` in place for the factor `band` of
/// [`cholesky_in_place`] (in precision `R`), `y` a vector of scalars or of
/// 3-vectors (one right-hand side per coordinate).
pub(crate) fn solve_in_place<R, T>(bw: usize, band: &[R], y: &mut [T])
where
    R: Copy,
    T: Copy + Sub<Output = T> + Mul<R, Output = T> + Div<R, Output = T>,
{
    let (n, w) = (y.len(), bw + 1);
    // Forward: L z = y.
    for i in 0..n {
        let i0 = i.saturating_sub(bw);
        let row = &band[i * w + (i0 + bw - i)..i * w + bw];
        let mut s = y[i];
        for (l, yj) in row.iter().zip(&y[i0..i]) {
            s = s - *yj * *l;
        }
        y[i] = s / band[i * w + bw];
    }
    // Backward: Lᵀ x = z, column-oriented so rows stay contiguous.
    for i in (0..n).rev() {
        let xi = y[i] / band[i * w + bw];
        y[i] = xi;
        let i0 = i.saturating_sub(bw);
        let row = &band[i * w + (i0 + bw - i)..i * w + bw];
        for (l, yj) in row.iter().zip(&mut y[i0..i]) {
            *yj = *yj - xi * *l;
        }
    }
}
