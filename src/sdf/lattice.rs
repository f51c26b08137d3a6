//! How large a collider's grid is, and what a refusal of it advises.
//!
//! The lattice is counted in `f64` from the mesh's extent: each axis's
//! count is a whole number below 2⁵³ or `+∞`, and their product is
//! compared with [`MAX_GRID_CELLS`] as a float, so no `thickness`, `scale`
//! or `resolution` can wrap a count into one that passes. Only a grid
//! within the limit is turned into `u32` counts.

use glam::DVec3;

use super::bake::{MAX_GRID_CELLS, MIN_RESOLUTION};
use crate::model::{MAX_COORDINATE, MIN_SIDE};
use crate::params::{format_below, format_number, format_short};

/// Lattice points of padding around the mesh (beyond `thickness`): two
/// cells, so the field is sampled outside the body before a particle
/// within `thickness` of it is reached.
const PAD_CELLS: f64 = 2.0;

/// Halvings of the thickness interval when the refusal looks for the
/// largest `thickness` that fits, once it has one that fits and its double
/// that does not: 64 halvings of that interval leave one part in 2⁶⁴ of
/// it, finer than an `f64` resolves, so the answer is the bound to the
/// printed digits.
const THICKNESS_HALVINGS: u32 = 64;

/// A grid's size in the body's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Lattice {
    /// The lattice spacing \[m\], as the kernels hold it.
    pub cell: f32,
    /// The padding beyond the mesh on every side \[m\].
    pub pad: f64,
    /// Lattice points per axis: whole numbers, or `+∞`.
    pub dims: [f64; 3],
}

impl Lattice {
    /// The lattice of a mesh whose bounding box is `extent` \[m\] at
    /// `resolution` cells along its longest side, padded for `thickness`
    /// \[m\].
    pub fn new(extent: DVec3, resolution: u32, thickness: f64) -> Lattice {
        let cell = (extent.max_element() / f64::from(resolution)) as f32;
        let pad = thickness + PAD_CELLS * f64::from(cell);
        let dims = (extent + DVec3::splat(2.0 * pad))
            .to_array()
            .map(|s| (s / f64::from(cell)).ceil() + 1.0);
        Lattice { cell, pad, dims }
    }

    /// Lattice points in all (`+∞` beyond `f64`).
    pub fn points(&self) -> f64 {
        self.dims.iter().product()
    }

    /// Whether the grid may be baked: at most [`MAX_GRID_CELLS`] points.
    pub fn fits(&self) -> bool {
        self.points() <= MAX_GRID_CELLS as f64
    }

    /// The counts as `u32`, for a lattice that [`fits`](Self::fits).
    pub fn dims_u32(&self) -> [u32; 3] {
        self.dims.map(|d| d as u32)
    }
}

/// What is wrong with a `scale` for the `f32` solvers, if anything: cells
/// below [`MIN_SIDE`] (a sample's position in cells would overflow, or
/// the cell round to zero), or a mesh from `lo` to `hi` \[m\] beyond
/// ±[`MAX_COORDINATE`] (the grid's origin would be `±∞` or lose every digit
/// of the cell in `f32`). Checked before the count: a scale of 1e-40 is
/// not a grid too fine, and a scale of 1e39 can give a small count.
pub(super) fn scale_problem(lo: DVec3, hi: DVec3, lattice: &Lattice) -> Option<String> {
    let cell = f64::from(lattice.cell);
    if cell.is_nan() || cell < MIN_SIDE {
        return Some(format!(
            "a factor that makes the grid's cells (the mesh's longest side ÷ `resolution`) at \
             least 1e-18 m, the smallest whose square is a normal f32; they would be {} m",
            format_short(cell)
        ));
    }
    let reach = lo.abs().max(hi.abs()).max_element();
    if reach.is_nan() || reach > MAX_COORDINATE {
        return Some(format!(
            "a factor that keeps the mesh within ±1e18 m of the body's origin, as the GPU \
             holds its grid in f32; it would reach {} m",
            format_short(reach)
        ));
    }
    None
}

/// What is wrong with a `thickness` whose grid (fitting the count) the
/// `f32` solvers cannot place: its padding takes the grid from `lo` and
/// `hi` \[m\] beyond ±[`MAX_COORDINATE`].
pub(super) fn reach_problem(lo: DVec3, hi: DVec3, lattice: &Lattice) -> Option<String> {
    let pad = DVec3::splat(lattice.pad);
    let reach = (lo - pad).abs().max((hi + pad).abs()).max_element();
    (reach.is_nan() || reach > MAX_COORDINATE).then(|| {
        format!(
            "a thickness that keeps the collider's grid (the mesh, the thickness and two \
             cells around it) within ±1e18 m of the body's origin, as the GPU holds it in \
             f32; it would reach {} m",
            format_short(reach)
        )
    })
}

/// The refusal of a lattice that does not [`fit`](Lattice::fits), for the
/// mesh's `extent` at `resolution` and `thickness`: its counts, and which
/// change brings it within — a lower `resolution` where one does, else a
/// smaller `thickness` (whose padding, not the mesh, fills the grid; at
/// the largest resolution without padding that fits, when even that needs
/// lowering).
pub(super) fn too_many_points(key: &str, extent: DVec3, resolution: u32, thickness: f64) -> String {
    let at = Lattice::new(extent, resolution, thickness);
    // Whole counts below 1e9 in full; larger ones (up to +∞) shortened.
    let [nx, ny, nz] = at.dims.map(|d| {
        if d < 1e9 {
            format_number(d)
        } else {
            format_short(d)
        }
    });
    let fitting = |t: f64| {
        (MIN_RESOLUTION..resolution)
            .rev()
            .find(|&r| Lattice::new(extent, r, t).fits())
    };
    let advice = if let Some(r) = fitting(thickness) {
        format!("give `{key}.resolution` at most {r}")
    } else {
        let r = if Lattice::new(extent, resolution, 0.0).fits() {
            resolution
        } else {
            fitting(0.0).unwrap_or(MIN_RESOLUTION)
        };
        // Halve to the first thickness that fits (at most ~1100 halvings
        // across f64's range; thickness 0 fits at `r`), then bisect.
        let (mut ok, mut over) = (0.0, thickness);
        while over > 0.0 {
            if Lattice::new(extent, r, over / 2.0).fits() {
                ok = over / 2.0;
                break;
            }
            over /= 2.0;
        }
        for _ in 0..THICKNESS_HALVINGS {
            let mid = 0.5 * (ok + over);
            if Lattice::new(extent, r, mid).fits() {
                ok = mid;
            } else {
                over = mid;
            }
        }
        let thinner = format!(
            "`{key}.thickness` at most {} m (the grid reaches the thickness and two cells \
             beyond the mesh on every side, and a cell is the mesh's longest side ÷ \
             `resolution`, so here the padding, not the mesh, fills the grid)",
            format_below(ok)
        );
        if r == resolution {
            format!("give {thinner}")
        } else {
            format!("give `{key}.resolution` at most {r} and {thinner}")
        }
    };
    format!(
        "`{key}`: a grid of {nx} × {ny} × {nz} lattice points (resolution {resolution}, cells \
         of {} m, thickness {} m) is more than the {MAX_GRID_CELLS} a collider may have; \
         {advice}",
        format_short(f64::from(at.cell)),
        format_number(thickness)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_past_any_integer_stay_too_many_and_never_wrap() {
        // 1e30 m of padding on a 1 m mesh: about 6e31 cells a side, whose
        // product is beyond u64 (it once wrapped to a count that passed).
        let huge = Lattice::new(DVec3::ONE, 64, 1e30);
        assert!(!huge.fits() && huge.points() > 1e90, "{huge:?}");
        let e = too_many_points("collider[0]", DVec3::ONE, 64, 1e30);
        assert!(
            e.contains("`collider[0].thickness` at most") && e.contains("16777216"),
            "{e}"
        );
    }

    #[test]
    fn the_advice_is_a_lattice_that_fits() {
        // A 1 µm cube under 5 mm: only the thickness can help.
        let tiny = DVec3::splat(1e-6);
        let e = too_many_points("collider[0]", tiny, 64, 0.005);
        assert!(!e.contains("resolution` at most"), "{e}");
        let said: f64 = e
            .split("thickness` at most ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("no thickness in {e}"));
        assert!(Lattice::new(tiny, 64, said).fits(), "{e}");
        assert!(!Lattice::new(tiny, 64, said * 1.01).fits(), "{e}");
        // A cube at 512 cells without padding: a lower resolution fits.
        let e = too_many_points("collider[0]", DVec3::ONE, 512, 0.0);
        assert!(e.contains("`collider[0].resolution` at most 251"), "{e}");
        assert!(Lattice::new(DVec3::ONE, 251, 0.0).fits());
    }
}
