//! Linear bending: Bergou, Wardetzky, Harmon, Zorin and Grinspun's
//! quadratic bending energy ("A quadratic bending model for inextensible
//! surfaces", SGP 2006), the bending of a cloth of a material with
//! `[material] bending` \[N·m\].
//!
//! Each interior edge `e = (x₀, x₁)` with opposite vertices `x₂` (in the
//! triangle `x₀ x₁ x₂`) and `x₃` (in `x₀ x₁ x₃`) has the discrete mean
//! curvature vector `K = Σ wᵢ xᵢ` with the rest state's cotangent weights
//!
//! `w = (cot a₁ + cot b₁, cot a₀ + cot b₀, −(cot a₀ + cot a₁), −(cot b₀ + cot b₁))`
//!
//! (`aᵢ`, `bᵢ` the angles at `xᵢ` of the two triangles), and the energy
//! `E = B / (2 (A₀ + A₁)) |K|²` (`A₀`, `A₁` the triangles' rest areas).
//! On a flat rest shape `K = 0`; a fold by `θ` about the edge gives
//! `|K| = 2 |e| sin(θ/2)`, so small folds store the dihedral energy
//! `B |e| θ² / (h₀ + h₁)` (`h` the triangles' heights over `e`): a hinge of
//! width `(h₀ + h₁)/2` bent to curvature `θ` over it, `½ B κ²` per area.
//! `docs/integrators.md` derives it and says what it assumes.
//!
//! The energy is quadratic in the positions, `E = ½ xᵀ (Q ⊗ I₃) x` with the
//! constant symmetric positive semi-definite `Q = Σₑ B/(A₀+A₁) w wᵀ`, so the
//! force `−Q x` is linear and its Jacobian `−Q` constant: it enters the
//! implicit integrator's product and Desbrun's constant filter exactly.
//! Each row of `Q` sums to zero (a translation stores nothing), so a row is
//! kept as its off-diagonal entries alone and applied to differences,
//! `(Q y)_p = Σ_{j≠p} Q_pj (y_j − y_p)`: no cancellation between large
//! absolute positions, and the same arithmetic on the GPU.
//!
//! Damping is the material's stiffness-proportional (Rayleigh) form: the
//! force is `−Q (x + β v)`.

use glam::DVec3;

use crate::budget::try_vec;
use crate::error::{Error, Result};
use crate::material::WarpWeft;
use crate::params::format_number;

/// The plane in which a fabric of bending stiffness `B₁` along the warp
/// and `B₂` along the weft bends as an isotropic one: warp coordinates
/// divided by `α = (B₁/B₂)^(1/8)`, weft coordinates multiplied by it (the
/// map keeps areas), and the isotropic stiffness `√(B₁ B₂)`.
///
/// With `u = α u'` and `v = v'/α`, `∂²/∂u'² = α² ∂²/∂u²` and
/// `∂²/∂v'² = α⁻² ∂²/∂v²`, so `√(B₁B₂) ∫ |∇'²x|² du' dv'` is
/// `∫ B₁ x_uu² + B₂ x_vv² + 2 √(B₁B₂) x_uv²  du dv`: a strip bent along
/// the warp stores `½ B₁ κ²`, along the weft `½ B₂ κ²`, and the twist
/// term is the geometric mean's (`docs/materials.md` gives a bias strip's
/// stiffness). Both operators are the isotropic ones on the mapped rest
/// shape, so they keep their order, symmetry and clamp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metric {
    /// `α`: 1 for an isotropic stiffness.
    pub stretch: f64,
    /// `√(B₁ B₂)` \[N·m\].
    pub stiffness: f64,
}

impl Metric {
    /// The plane of `stiffness` (both directions `> 0`, or isotropic).
    pub fn of(stiffness: WarpWeft) -> Metric {
        Metric {
            stretch: if stiffness.is_isotropic() {
                1.0
            } else {
                (stiffness.warp / stiffness.weft).powf(0.125)
            },
            stiffness: stiffness.geometric_mean(),
        }
    }
}

/// The largest fold \[rad\] of the rest shape about any interior edge that
/// still counts as flat: the quadratic model's energy is measured from a
/// flat rest state, and a rest fold of `θ` would store `B|e|θ²/(h₀+h₁)` at
/// rest. 1e-6 rad leaves only rounding of the rest positions.
pub const FLAT_REST_ANGLE: f64 = 1e-6;

/// The bending operator of a cloth: `Q`'s off-diagonal entries by row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bending {
    /// `particle_count + 1` offsets into `columns` and `coefficients`.
    pub offsets: Vec<u32>,
    /// The other particle of each entry, ascending within a row.
    pub columns: Vec<u32>,
    /// `Q_pj` \[N/m\] for each entry (off-diagonal only: `Q_pp = −Σ_j Q_pj`).
    pub coefficients: Vec<f64>,
    /// The Rayleigh damping time constant `β` \[s\]: the force is
    /// `−Q (x + β v)`.
    pub damping: f64,
}

const WHAT: &str = "the bending operator";

/// Cotangent of the angle at `a` in the triangle `a b c`.
fn cot(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (u, v) = (b - a, c - a);
    u.dot(v) / u.cross(v).length()
}

/// Twice the area of the triangle `a b c` \[m²\].
fn twice_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    (b - a).cross(c - a).length()
}

/// One interior edge's stencil: its four particles and their weights.
struct Stencil {
    particles: [u32; 4],
    weights: [f64; 4],
    /// `B / (A₀ + A₁)` \[N/m³\].
    scale: f64,
}

impl Bending {
    /// Bergou et al.'s operator (module docs) of bending stiffness
    /// `stiffness` \[N·m\] and damping `damping` \[s\] for the rest
    /// positions `rest` and the triangles `triangles` (whose interior edges
    /// carry it; an edge shared by more than two triangles is left out, as
    /// a boundary edge is). An edge on a clamp (both ends `pinned`, one
    /// opposite vertex pinned and the other free) weighs [`CLAMP_WEIGHT`].
    /// A stiffness that differs between warp and weft takes each
    /// triangle's warp direction from `warps` (unit, in its plane; unused,
    /// and may be empty, for an isotropic one) and computes each hinge's
    /// weights in [`Metric`]'s plane. Refuses a rest shape that is not flat
    /// (`material.bending`, naming the edge).
    pub fn new(
        rest: &[DVec3],
        triangles: &[[u32; 3]],
        stiffness: impl Into<WarpWeft>,
        warps: &[DVec3],
        damping: f64,
        pinned: &[bool],
    ) -> Result<Bending> {
        let terms = stencils(rest, triangles, stiffness.into(), warps)?
            .into_iter()
            .map(|s| {
                let entries = std::array::from_fn::<_, 4, _>(|k| (s.particles[k], s.weights[k]));
                let [a, b, c, d] = s.particles;
                let scale = s.scale * clamp_scale(&[a, b], [c, d], pinned);
                (entries.to_vec(), scale)
            });
        Bending::assemble(rest.len(), terms, damping)
    }

    /// The Hessian operator of a grid of `nx × ny` particles (row-major,
    /// spacing `hx` along a row and `hy` across rows \[m\]): the energy
    /// `½ B ∫ |∇²x|²` (`∇²x` the second derivatives of the positions over
    /// the rest plane) by finite differences — `∂²/∂u²` at every particle
    /// not at the end of its row, `∂²/∂v²` at every particle not at the end
    /// of its column, each weighted by its share of the area (half at the
    /// cloth's edge), and `∂²/∂u∂v` at every cell's centre, counted twice.
    /// For an isometric deformation `|∇²x|² = κ₁² + κ₂²`: the plate energy
    /// with no Poisson coupling, isotropic for every quadratic shape, and
    /// its free edges are a free plate's (`docs/integrators.md`). A second
    /// difference on a clamp (its middle particle `pinned` with one
    /// neighbour, the other free) weighs [`CLAMP_WEIGHT`]. The warp runs
    /// along the rows; a stiffness that differs between warp and weft is
    /// the isotropic operator in [`Metric`]'s plane.
    pub fn grid(
        nx: usize,
        ny: usize,
        hx: f64,
        hy: f64,
        stiffness: impl Into<WarpWeft>,
        damping: f64,
        pinned: &[bool],
    ) -> Result<Bending> {
        let metric = Metric::of(stiffness.into());
        let (hx, hy, stiffness) = (hx / metric.stretch, hy * metric.stretch, metric.stiffness);
        let idx = |r: usize, c: usize| (r * nx + c) as u32;
        let share = |k: usize, n: usize, h: f64| if k == 0 || k + 1 == n { h / 2.0 } else { h };
        let mut terms: Vec<(Vec<(u32, f64)>, f64)> = Vec::new();
        let second = |a: u32, b: u32, c: u32, h: f64| {
            let k = 1.0 / (h * h);
            vec![(a, k), (b, -2.0 * k), (c, k)]
        };
        for r in 0..ny {
            for c in 1..nx.saturating_sub(1) {
                let (a, p, b) = (idx(r, c - 1), idx(r, c), idx(r, c + 1));
                let w = hx * share(r, ny, hy) * clamp_scale(&[p], [a, b], pinned);
                terms.push((second(a, p, b, hx), stiffness * w));
            }
        }
        for c in 0..nx {
            for r in 1..ny.saturating_sub(1) {
                let (a, p, b) = (idx(r - 1, c), idx(r, c), idx(r + 1, c));
                let w = hy * share(c, nx, hx) * clamp_scale(&[p], [a, b], pinned);
                terms.push((second(a, p, b, hy), stiffness * w));
            }
        }
        let k = 1.0 / (hx * hy);
        for r in 0..ny.saturating_sub(1) {
            for c in 0..nx.saturating_sub(1) {
                let entries = vec![
                    (idx(r, c), k),
                    (idx(r, c + 1), -k),
                    (idx(r + 1, c), -k),
                    (idx(r + 1, c + 1), k),
                ];
                terms.push((entries, stiffness * 2.0 * hx * hy));
            }
        }
        Bending::assemble(nx * ny, terms.into_iter(), damping)
    }

    /// `Q = Σ scale · a aᵀ` over `terms` (each the sparse vector `a` as
    /// `(particle, coefficient)` pairs and its `scale`), kept by rows of
    /// off-diagonal entries.
    fn assemble(
        n: usize,
        terms: impl Iterator<Item = (Vec<(u32, f64)>, f64)>,
        damping: f64,
    ) -> Result<Bending> {
        let mut rows: Vec<Vec<(u32, f64)>> = try_vec(n, Vec::new(), WHAT)?;
        for (entries, scale) in terms {
            for &(i, a) in &entries {
                for &(j, b) in &entries {
                    if i != j {
                        rows[i as usize].push((j, scale * a * b));
                    }
                }
            }
        }
        let mut offsets = try_vec(n + 1, 0u32, WHAT)?;
        let mut columns = Vec::new();
        let mut coefficients = Vec::new();
        for (p, row) in rows.iter_mut().enumerate() {
            row.sort_by_key(|&(j, _)| j);
            let mut k = 0;
            while k < row.len() {
                let j = row[k].0;
                let mut sum = 0.0;
                while k < row.len() && row[k].0 == j {
                    sum += row[k].1;
                    k += 1;
                }
                columns.push(j);
                coefficients.push(sum);
            }
            offsets[p + 1] = columns.len() as u32;
        }
        Ok(Bending {
            offsets,
            columns,
            coefficients,
            damping,
        })
    }

    /// The entries of particle `p`'s row: the other particles and `Q_pj`.
    pub fn row(&self, p: usize) -> (&[u32], &[f64]) {
        let r = self.offsets[p] as usize..self.offsets[p + 1] as usize;
        (&self.columns[r.clone()], &self.coefficients[r])
    }

    /// `Q_pp = −Σ_{j≠p} Q_pj` \[N/m\].
    pub fn diagonal(&self, p: usize) -> f64 {
        -self.row(p).1.iter().sum::<f64>()
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// `(Q y)_p = Σ_j Q_pj (y_j − y_p)`.
    pub fn apply_row(&self, y: &[DVec3], p: usize) -> DVec3 {
        let (cols, q) = self.row(p);
        cols.iter().zip(q).fold(DVec3::ZERO, |acc, (&j, &q)| {
            acc + (y[j as usize] - y[p]) * q
        })
    }

    /// The bending energy `½ xᵀ Q x` \[J\] of the positions `x`.
    pub fn energy(&self, x: &[DVec3]) -> f64 {
        // ½ Σ_p x_p · (Q x)_p, with (Q x)_p from differences; the sum over
        // p of (Q x)_p is zero, so each x_p may be taken about any origin:
        // the first particle's, which keeps the products small.
        let origin = x.first().copied().unwrap_or(DVec3::ZERO);
        0.5 * (0..self.particle_count())
            .map(|p| (x[p] - origin).dot(self.apply_row(x, p)))
            .sum::<f64>()
    }

    /// Gershgorin's bound on row `p` of `Q`, `|Q_pp| + Σ_j |Q_pj|`
    /// \[N/m\]: over the particle's mass, an upper bound on the `ω²` of
    /// the bending vibrations it takes part in (tight for the grid's
    /// checkerboard mode), which the explicit integrator's limit adds to
    /// the springs' (`material::explicit_headroom`).
    pub fn row_bound(&self, p: usize) -> f64 {
        let off: f64 = self.row(p).1.iter().map(|q| q.abs()).sum();
        self.diagonal(p).abs() + off
    }

    /// An upper bound on the largest `ω²` \[1/s²\] of the undamped bending
    /// vibrations alone, `max_p` [`row_bound`](Self::row_bound)`(p) / m_p`
    /// over the free particles (Gershgorin's bound on `M⁻¹ Q`).
    pub fn omega_squared_bound(&self, mass: &[f64], pinned: &[bool]) -> f64 {
        (0..self.particle_count())
            .filter(|&p| !pinned[p])
            .map(|p| self.row_bound(p) / mass[p])
            .fold(0.0, f64::max)
    }
}

/// How much more a bending term on a clamp weighs than elsewhere.
///
/// A clamp is where pinned particles hold the cloth's slope: a term whose
/// `inner` particles (a second difference's middle, a hinge's edge) are all
/// pinned with exactly one of its `outer` ones (the neighbours across)
/// pinned and the other free. Such a term measures the curvature at the
/// clamp from a pinned neighbour that lies where the clamped cloth would
/// continue straight, which halves it: for a beam clamped at `x₀` with
/// `y(x) ≈ ½ κ x²`, `(y₋₁ − 2y₀ + y₁)/h² = κ/2`. The second-order clamp
/// treatment mirrors the free neighbour instead (the ghost point
/// `y₋₁ = y₁` of a clamped beam's finite differences), doubling the
/// curvature and so quadrupling the term's energy; and the term's share of
/// the cloth is the half cell on the free side of the clamp, not a whole
/// cell. Together: twice the weight. Its Euler–Lagrange equation at the
/// first free particle is then the clamped beam's second-order
/// `B (7y₁ − 4y₂ + y₃)/h⁴`, where the plain weight gives
/// `B (6y₁ − 4y₂ + y₃)/h⁴`, a clamp half a cell behind the pins (first
/// order). The operator stays constant: it depends on which particles the
/// model pins, not on where they are.
pub const CLAMP_WEIGHT: f64 = 2.0;

/// [`CLAMP_WEIGHT`] for a term on a clamp, else 1 (`pinned` shorter than
/// a particle's index counts it free).
fn clamp_scale<const N: usize>(inner: &[u32; N], outer: [u32; 2], pinned: &[bool]) -> f64 {
    let held = |p: u32| pinned.get(p as usize).copied().unwrap_or(false);
    if inner.iter().all(|&p| held(p)) && (held(outer[0]) != held(outer[1])) {
        CLAMP_WEIGHT
    } else {
        1.0
    }
}

/// The stencil of every interior edge of `triangles`, in the order of the
/// edges' first appearance; refuses a rest fold above [`FLAT_REST_ANGLE`].
/// An anisotropic `stiffness` computes each hinge's weights and areas in
/// [`Metric`]'s plane, its warp the mean of its two triangles' `warps`.
fn stencils(
    rest: &[DVec3],
    triangles: &[[u32; 3]],
    stiffness: WarpWeft,
    warps: &[DVec3],
) -> Result<Vec<Stencil>> {
    use std::collections::HashMap;
    // Each edge (ends ascending) → (its first triangle's opposite vertex,
    // the other's, how many triangles share it, the two triangles).
    type Sides = (u32, u32, u32, [usize; 2]);
    let mut edges: HashMap<(u32, u32), Sides> = HashMap::new();
    let mut order = Vec::new();
    for (n, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let key = (a.min(b), a.max(b));
            let entry = edges.entry(key).or_insert_with(|| {
                order.push(key);
                (c, u32::MAX, 0, [n, n])
            });
            if entry.2 == 1 {
                entry.1 = c;
                entry.3[1] = n;
            }
            entry.2 += 1;
        }
    }
    let metric = Metric::of(stiffness);
    let x = |p: u32| rest[p as usize];
    let mut out = Vec::new();
    for key in order {
        let (c, d, count, pair) = edges[&key];
        if count != 2 {
            continue;
        }
        let (a, b) = key;
        let (x0, x1, x2, x3) = (x(a), x(b), x(c), x(d));
        let (area0, area1) = (0.5 * twice_area(x0, x1, x2), 0.5 * twice_area(x0, x1, x3));
        if !(area0 > 0.0 && area1 > 0.0) {
            continue;
        }
        // The rest fold: |K| = 2|e| sin(θ/2), with the rest shape's own
        // weights.
        let weights = cot_weights(x0, x1, x2, x3);
        let k = x0 * weights[0] + x1 * weights[1] + x2 * weights[2] + x3 * weights[3];
        let edge = (x1 - x0).length();
        let fold = 2.0 * (k.length() / (2.0 * edge)).min(1.0).asin();
        if fold > FLAT_REST_ANGLE {
            return Err(Error::InvalidParameter {
                key: "material.bending".to_string(),
                allowed: format!(
                    "0 for a cloth whose rest shape is not flat: the quadratic bending model \
                     measures bending from a flat rest state, and this cloth's rest shape folds \
                     by {} rad (more than {}) about the edge between particles {a} and {b}",
                    format_number(fold),
                    format_number(FLAT_REST_ANGLE)
                ),
                got: stiffness.to_string(),
            });
        }
        let (weights, areas) = if metric.stretch == 1.0 {
            (weights, area0 + area1)
        } else {
            let [w0, w1] = pair.map(|t| warps.get(t).copied().unwrap_or(DVec3::ZERO));
            // The warp is an axis: a face whose `u` runs the other way
            // (across a texture seam) gives the same one.
            let warp = w0 + w1 * w0.dot(w1).signum();
            let [y0, y1, y2, y3] = in_metric([x0, x1, x2, x3], warp, metric);
            let areas = 0.5 * (twice_area(y0, y1, y2) + twice_area(y0, y1, y3));
            (cot_weights(y0, y1, y2, y3), areas)
        };
        out.push(Stencil {
            particles: [a, b, c, d],
            weights,
            scale: metric.stiffness / areas,
        });
    }
    Ok(out)
}

/// The cotangent weights of the hinge `x₀ x₁` between the triangles
/// `x₀ x₁ x₂` and `x₀ x₁ x₃` (module docs).
fn cot_weights(x0: DVec3, x1: DVec3, x2: DVec3, x3: DVec3) -> [f64; 4] {
    let (ca0, ca1) = (cot(x0, x1, x2), cot(x1, x0, x2));
    let (cb0, cb1) = (cot(x0, x1, x3), cot(x1, x0, x3));
    [ca1 + cb1, ca0 + cb0, -(ca0 + ca1), -(cb0 + cb1)]
}

/// A flat hinge's four points in `metric`'s plane: coordinates about the
/// first point along the warp (`warp` projected into the hinge's plane)
/// divided by `α`, across it multiplied by `α`.
fn in_metric(points: [DVec3; 4], warp: DVec3, metric: Metric) -> [DVec3; 4] {
    let [x0, x1, x2, _] = points;
    let normal = (x1 - x0).cross(x2 - x0).normalize_or_zero();
    let along = (warp - normal * normal.dot(warp)).normalize_or_zero();
    let across = normal.cross(along);
    points.map(|p| {
        let d = p - x0;
        DVec3::new(
            d.dot(along) / metric.stretch,
            d.dot(across) * metric.stretch,
            0.0,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bergou's triangles for a grid of `columns` particles per row: each cell
    /// `[a, b, c, d]` (corners counter-clockwise from its lowest index, as
    /// [`crate::model::Model::grid_cells`] lists them) split along `a c` or
    /// `b d` alternately, like a checkerboard. One diagonal everywhere would
    /// make bending about the other diagonal about 2.9 times stiffer than about
    /// an axis; the alternating split leaves both diagonals at about 1.5 times
    /// (`docs/integrators.md`).
    fn alternating_split(cells: &[[u32; 4]], columns: usize) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(2 * cells.len());
        for (k, &[a, b, c, d]) in cells.iter().enumerate() {
            let cols = columns.saturating_sub(1).max(1);
            let (row, col) = (k / cols, k % cols);
            if (row + col) % 2 == 0 {
                out.push([a, b, c]);
                out.push([a, c, d]);
            } else {
                out.push([a, b, d]);
                out.push([b, c, d]);
            }
        }
        out
    }

    /// Rounding of `f64` sums over a few dozen terms of size ~1.
    const ROUNDING: f64 = 1e-9;

    fn square(n: usize) -> (Vec<DVec3>, Vec<[u32; 4]>) {
        let h = 1.0 / n as f64;
        let x = (0..=n)
            .flat_map(|r| (0..=n).map(move |c| DVec3::new(c as f64 * h, 0.0, r as f64 * h)))
            .collect();
        let idx = |r: usize, c: usize| (r * (n + 1) + c) as u32;
        let cells = (0..n)
            .flat_map(|r| {
                (0..n).map(move |c| [idx(r, c), idx(r, c + 1), idx(r + 1, c + 1), idx(r + 1, c)])
            })
            .collect();
        (x, cells)
    }

    #[test]
    fn flat_sheet_stores_nothing_and_rows_sum_to_zero() {
        let (x, cells) = square(6);
        let b = Bending::new(&x, &alternating_split(&cells, 7), 1e-3, &[], 0.0, &[]).unwrap();
        assert!(b.energy(&x).abs() < ROUNDING * 1e-3);
        for p in 0..x.len() {
            assert!(b.apply_row(&x, p).length() < ROUNDING);
            assert!(b.diagonal(p) >= 0.0);
        }
    }

    /// A woven mesh operator is the isotropic one of `√(B₁B₂)` on the rest
    /// shape mapped into [`Metric`]'s plane, hinge by hinge.
    #[test]
    fn a_woven_mesh_operator_is_the_isotropic_one_in_the_metric_plane() {
        let (x, cells) = square(6);
        let triangles = alternating_split(&cells, 7);
        let woven = WarpWeft {
            warp: 4e-3,
            weft: 1e-3,
        };
        let warps = vec![DVec3::X; triangles.len()];
        let b = Bending::new(&x, &triangles, woven, &warps, 0.0, &[]).unwrap();
        let alpha = 4f64.powf(0.125);
        let mapped: Vec<DVec3> = x
            .iter()
            .map(|p| DVec3::new(p.x / alpha, 0.0, p.z * alpha))
            .collect();
        let iso = Bending::new(&mapped, &triangles, 2e-3, &[], 0.0, &[]).unwrap();
        assert_eq!(b.columns, iso.columns);
        for (a, e) in b.coefficients.iter().zip(&iso.coefficients) {
            assert!((a - e).abs() <= ROUNDING * e.abs().max(1.0), "{a} vs {e}");
        }
        let plain = Bending::new(&x, &triangles, 2e-3, &[], 0.0, &[]).unwrap();
        assert_ne!(b.coefficients, plain.coefficients);
    }

    #[test]
    fn curved_rest_shape_is_refused() {
        let (mut x, cells) = square(4);
        x[12].y = 0.05;
        let err = Bending::new(&x, &alternating_split(&cells, 5), 1e-3, &[], 0.0, &[]).unwrap_err();
        assert!(err.to_string().contains("material.bending"), "{err}");
    }
}
