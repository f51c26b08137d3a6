//! A cloth material in physical units (`[material]`): areal density and
//! membrane stiffnesses per unit width, from which every particle's mass
//! and every spring's constants follow from the rest geometry, so that the
//! same material is the same cloth at every resolution.
//!
//! `docs/materials.md` derives the constants; in short, with `Y` the
//! stretch stiffness and `S` the shear stiffness \[N/m\]:
//!
//! - mass: `density ×` a third of the rest area of each triangle a
//!   particle is a corner of;
//! - a quad cell (a grid cell, a mesh's quad face) of area `A` adds to each
//!   of its sides, of rest length `L`, `k = (u − S L⁴/A²) · A / (2 L²)` and
//!   gives each of its two diagonals, of rest length `D`, `k = S D² / (2A)`,
//!   where `u = (Y + √(Y² + 4S²)) / 2`: on a rectangular cell this makes
//!   the uniaxial stiffness along either side `Y` and the shear stiffness
//!   `S` exactly;
//! - a triangle face adds `k = Y A / L²` to each of its sides (Van Gelder
//!   1998): an equilateral lattice's uniaxial stiffness is `Y`, its shear
//!   stiffness `3Y/8` whatever `S` is;
//! - damping is stiffness-proportional (Rayleigh): `kd = β k`.
//!
//! A woven fabric's stretch and bending differ along its warp and weft
//! ([`WarpWeft`]): the warp runs along a grid's rows (its first axis) or a
//! mesh's texture coordinate `u`. A rectangular cell's sides then take
//! `C11 = p` along the warp and `C22 = q` along the weft in place of `u`,
//! with `p = (Y₁ + √(Y₁² + 4S² Y₁/Y₂)) / 2` and `q = p Y₂/Y₁`, which make
//! the uniaxial stiffnesses `Y₁` and `Y₂` and the shear stiffness `S`
//! exactly; a side at `θ` to the warp takes `q + (p − q) cos²θ`, and a
//! triangle's side `Y₂ + (Y₁ − Y₂) cos²θ` in place of `Y`.

use std::collections::HashMap;

use glam::DVec3;

use crate::bending::Bending;
use crate::error::{Error, Result};
use crate::model::{Model, SpringConstants};
use crate::params::{
    check, format_below, format_number, Integrator, Params, SpringKind, SpringParams,
};

/// A property of a woven fabric along its two thread directions: the warp
/// (a grid's rows, a mesh's `u`) and the weft (a grid's columns, a mesh's
/// `v`). The same value along both is an isotropic fabric's one number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpWeft {
    /// Along the warp.
    pub warp: f64,
    /// Along the weft.
    pub weft: f64,
}

impl WarpWeft {
    /// The same value along both directions.
    pub const fn both(value: f64) -> WarpWeft {
        WarpWeft {
            warp: value,
            weft: value,
        }
    }

    /// Whether both directions have the same value.
    pub fn is_isotropic(&self) -> bool {
        self.warp == self.weft
    }

    /// The value along a direction at `θ` to the warp, given `cos²θ`:
    /// `weft + (warp − weft) cos²θ`, each direction's own value on its
    /// axis, and exactly the one value of an isotropic fabric whatever
    /// `cos2` is.
    pub fn along(&self, cos2: f64) -> f64 {
        if self.is_isotropic() {
            self.warp
        } else {
            self.weft + (self.warp - self.weft) * cos2
        }
    }

    /// The greater of the two.
    pub fn max(&self) -> f64 {
        self.warp.max(self.weft)
    }

    /// `√(warp · weft)`: exactly the one value of an isotropic fabric.
    pub fn geometric_mean(&self) -> f64 {
        if self.is_isotropic() {
            self.warp
        } else {
            (self.warp * self.weft).sqrt()
        }
    }

    /// The key and value of each direction for messages: `key` alone for
    /// an isotropic value, else `key.warp` and `key.weft`.
    fn keyed(&self, key: &str) -> Vec<(String, f64)> {
        if self.is_isotropic() {
            vec![(key.to_string(), self.warp)]
        } else {
            vec![
                (format!("{key}.warp"), self.warp),
                (format!("{key}.weft"), self.weft),
            ]
        }
    }
}

impl From<f64> for WarpWeft {
    fn from(value: f64) -> WarpWeft {
        WarpWeft::both(value)
    }
}

impl std::fmt::Display for WarpWeft {
    /// `5`, or `{ warp = 5, weft = 2 }` as a scene file writes it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_isotropic() {
            write!(f, "{}", format_number(self.warp))
        } else {
            write!(
                f,
                "{{ warp = {}, weft = {} }}",
                format_number(self.warp),
                format_number(self.weft)
            )
        }
    }
}

/// A membrane material: what `[material]` gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Areal density \[kg/m²\], `> 0`.
    pub density: f64,
    /// Stretch stiffness \[N/m\] along the warp and the weft: force per
    /// unit width per unit strain of a strip pulled along that direction
    /// (free to narrow), `> 0`.
    pub stretch: WarpWeft,
    /// In-plane shear stiffness \[N/m\]: shear force per unit width per
    /// radian of shear, `> 0`. A triangle mesh has no shear springs: its
    /// shear stiffness is its lattice's (see the module docs).
    pub shear: f64,
    /// Bending stiffness per unit width \[N·m\] (moment per unit width per
    /// unit curvature) of a strip bent along the warp and along the weft,
    /// `≥ 0` (both `0` or both positive), acted on by the linear bending
    /// model of [`crate::bending`]; `0`: the cloth does not resist bending.
    pub bending: WarpWeft,
    /// Stiffness-proportional damping time constant `β` \[s\]: each spring's
    /// damping is `kd = β k`, `≥ 0`.
    pub damping: f64,
}

/// The largest `stretch` and `shear` \[N/m\]: stiffer than any fabric
/// (woven cotton is ~1e3–1e5 N/m), and with `damping` ≤ 1 s it keeps the
/// springs' nominal constants within `[springs.*]`'s ranges.
pub const MAX_STIFFNESS: f64 = 1e6;

/// The largest `bending` \[N·m\]: a thousand times the stiffest
/// fabrics' (heavy canvas is ~1e-3 N·m); beyond it a sheet is a plate.
pub const MAX_BENDING: f64 = 1.0;

/// The largest `damping` \[s\]: a time constant of a second damps every
/// motion of a cloth-sized sheet completely.
pub const MAX_DAMPING: f64 = 1.0;

impl Default for Material {
    /// The default cloth's material: its 0.3 kg over 1 m², springs near the
    /// default `[springs.*]` at the default 33² resolution, and the
    /// default springs' damping ratio `kd / k = 1e-3 s`.
    fn default() -> Self {
        Material {
            density: 0.3,
            stretch: WarpWeft::both(50.0),
            shear: 20.0,
            bending: WarpWeft::both(0.0),
            damping: 1e-3,
        }
    }
}

fn invalid(key: &str, allowed: String, got: impl std::fmt::Display) -> Error {
    Error::InvalidParameter {
        key: key.to_string(),
        allowed,
        got: got.to_string(),
    }
}

/// Where the explicit integrator at `params.dt` cannot step `model`
/// stably with its bending, the factor `h < 1` (`≥ 0`) its bending
/// stiffness must shrink by; `None` where it can, and without a bending
/// operator or with another integrator, which are stable at any bending.
///
/// Symplectic Euler steps a vibration of `ω²` \[1/s²\] damped at rate
/// `γ` \[1/s\] (`ẍ = −ω² x − γ ẋ`) stably while `dt² ω² + 2 dt γ < 4`
/// (the roots of `z² − (2 − dt γ − dt² ω²) z + 1 − dt γ` inside the unit
/// circle). Every vibration of the cloth has `dt² ω² + 2 dt γ` an
/// eigenvalue of `M⁻¹ (dt² K + 2 dt D)`, exactly where the damping is
/// Rayleigh (`D = β K`, a material's), with `K` the springs' and the
/// bending's stiffness and `D` their damping; Gershgorin's bound on each
/// free particle's row bounds it from above: the bending's
/// `(dt² + 2 dt β) (|Q_pp| + Σ_j |Q_pj|)` ([`Bending::row_bound`]) plus
/// each of its springs' `2 (dt² k + 2 dt kd)` (a spring's 3 × 3 blocks,
/// `k n nᵀ` and its transverse part `k (1 − L/l) (I − n nᵀ)`, have norm at
/// most `k`), over `m_p`. Both the springs' and the bending's damping
/// count: at the material's default `β = 1 ms` and `dt = 1 ms` the bound
/// is a third of the undamped one.
fn explicit_headroom(model: &Model, params: &Params) -> Option<f64> {
    let bending = model.bending.as_ref()?;
    if params.integrator != Integrator::Explicit {
        return None;
    }
    let dt = params.dt;
    let mut springs = vec![0.0; model.particle_count()];
    for (s, sp) in model.springs.iter().enumerate() {
        let c = model.spring_constants(s, params);
        let row = 2.0 * (dt * dt * c.k + 2.0 * dt * c.kd);
        springs[sp.i as usize] += row;
        springs[sp.j as usize] += row;
    }
    let per_bending = dt * dt + 2.0 * dt * bending.damping;
    let headroom = (0..model.particle_count())
        .filter(|&p| !model.pinned[p])
        .map(|p| {
            let b = per_bending * bending.row_bound(p);
            if b > 0.0 {
                ((4.0 * model.mass[p] - springs[p]) / b).max(0.0)
            } else {
                f64::INFINITY
            }
        })
        .fold(f64::INFINITY, f64::min);
    (headroom <= 1.0).then_some(headroom)
}

/// What the explicit integrator's bending limit asks of every vibration,
/// for the refusals.
const EXPLICIT_RULE: &str = "its stiffest vibration, springs and bending \
     together with their damping, must satisfy dt² ω² + 2 dt γ < 4";

/// Refuses a model whose linear bending operator the explicit integrator
/// cannot step stably at `params.dt` ([`Material::check_explicit`] for a
/// model built without its material: a solver made through the API), as
/// `material.bending`, naming the factor it must shrink by.
pub fn check_explicit_bending(model: &Model, params: &Params) -> Result<()> {
    let Some(headroom) = explicit_headroom(model, params) else {
        return Ok(());
    };
    Err(invalid(
        "material.bending",
        format!(
            "for the explicit integrator at dt = {} s, at most {} times this cloth's bending \
             stiffness ({EXPLICIT_RULE}); give a smaller bending, a smaller dt, or the \
             implicit or semi-implicit integrator, which are stable at any bending",
            format_number(params.dt),
            format_below(headroom)
        ),
        "a bending operator too stiff for the explicit integrator",
    ))
}

impl Material {
    /// Refuses a non-positive or non-finite density, stretch or shear
    /// stiffness, a bending stiffness outside `0..=1` N·m or zero along one
    /// direction only, and a damping outside `0..=1` s, naming the
    /// `material.*` key (`material.stretch.warp` for one direction).
    pub fn validate(&self) -> Result<()> {
        check(
            "material.density",
            self.density,
            self.density > 0.0,
            "> 0 (kg/m²)",
        )?;
        let stiffness = self
            .stretch
            .keyed("material.stretch")
            .into_iter()
            .chain([("material.shear".to_string(), self.shear)]);
        for (key, value) in stiffness {
            check(
                &key,
                value,
                value > 0.0 && value <= MAX_STIFFNESS,
                "0 < stiffness ≤ 1e6 (N/m, per unit width)",
            )?;
        }
        for (key, value) in self.bending.keyed("material.bending") {
            check(
                &key,
                value,
                (0.0..=MAX_BENDING).contains(&value),
                "0 ≤ bending ≤ 1 (N·m, per unit width)",
            )?;
        }
        if (self.bending.warp > 0.0) != (self.bending.weft > 0.0) {
            return Err(invalid(
                "material.bending",
                "a bending stiffness along both the warp and the weft, or 0 along both (a \
                 fabric that resists bending one way resists it every way)"
                    .to_string(),
                self.bending,
            ));
        }
        check(
            "material.damping",
            self.damping,
            (0.0..=MAX_DAMPING).contains(&self.damping),
            "0 ≤ damping ≤ 1 (s, kd = damping × k per spring)",
        )
    }

    /// Whether the stretch or the bending differs between warp and weft,
    /// so that the cloth needs to know where its warp runs.
    pub fn is_anisotropic(&self) -> bool {
        !(self.stretch.is_isotropic() && self.bending.is_isotropic())
    }

    /// The spring kinds a cloth of this material has, for
    /// [`Params::springs`]: stretch and shear springs with the material's
    /// stiffnesses (the stiffer direction's stretch) and damping `β ×`
    /// those as their kinds' nominal
    /// constants (each spring's own follow from the geometry, see
    /// [`Material::apply`]), the stretch springs' default fix-up limit, no
    /// bend springs.
    pub fn spring_params(&self) -> [SpringParams; 3] {
        let defaults = Params::default().springs;
        let kind = |stiffness: f64, max_stretch| SpringParams {
            stiffness,
            damping: self.damping * stiffness,
            max_stretch,
        };
        [
            kind(
                self.stretch.max(),
                defaults[SpringKind::Stretch.index()].max_stretch,
            ),
            kind(self.shear, None),
            SpringParams::NONE,
        ]
    }

    /// Refuses a bending stiffness that the explicit integrator cannot
    /// step stably at the scene's `dt` (see `explicit_headroom`), naming
    /// the largest that it can.
    pub fn check_explicit(&self, model: &Model, params: &Params) -> Result<()> {
        let Some(headroom) = explicit_headroom(model, params) else {
            return Ok(());
        };
        let most = if self.bending.is_isotropic() {
            format!("{} N·m", format_below(self.bending.warp * headroom))
        } else {
            format!(
                "{} N·m along the warp and {} N·m along the weft",
                format_below(self.bending.warp * headroom),
                format_below(self.bending.weft * headroom)
            )
        };
        Err(invalid(
            "material.bending",
            format!(
                "at most {most} for the explicit integrator at dt = {} s on this cloth \
                 ({EXPLICIT_RULE}); give a smaller bending, a smaller dt, or the implicit or \
                 semi-implicit integrator, which are stable at any bending",
                format_number(params.dt)
            ),
            self.bending,
        ))
    }

    /// A rectangular cell's `C11 = p` along the warp and `C22 = q` along
    /// the weft \[N/m\] for which the uniaxial stiffnesses are `Y₁` and
    /// `Y₂` with shear springs of shear stiffness `S` (`C12 = C66 = S`):
    /// `p − S²/q = Y₁` and `q − S²/p = Y₂` give
    /// `p = (Y₁ + √(Y₁² + 4S² Y₁/Y₂)) / 2` and `q = p Y₂/Y₁`; an isotropic
    /// fabric's `u = (Y + √(Y² + 4S²)) / 2` along both (`docs/materials.md`).
    fn axial(&self) -> WarpWeft {
        let (y1, y2, s) = (self.stretch.warp, self.stretch.weft, self.shear);
        let p = 0.5 * (y1 + (y1 * y1 + 4.0 * s * s * (y1 / y2)).sqrt());
        WarpWeft {
            warp: p,
            weft: p * (y2 / y1),
        }
    }

    /// Gives `model` (built with [`Material::spring_params`]) this
    /// material's masses, per-spring constants and, with a bending
    /// stiffness, its bending operator ([`Bending::grid`] on a grid,
    /// [`Bending::new`] on a mesh's triangles). `faces` are its cells as
    /// cyclic corner lists, each with the unit direction of its warp in its
    /// plane (ignored by an isotropic material): quads (a grid's cells, a
    /// mesh's quad faces) and triangles, in the order whose drawing
    /// triangles (a quad `a b c d` as `a b c` and `a c d`) are
    /// `model.triangles` on a mesh; the masses come from
    /// `model.triangles`. Refuses a shear stiffness too large for a cell's
    /// aspect ratio (a side would get a negative stiffness), naming
    /// `material.shear`.
    pub fn apply<'a>(
        &self,
        model: &mut Model,
        faces: impl Iterator<Item = (&'a [u32], DVec3)>,
    ) -> Result<()> {
        let faces: Vec<(&[u32], DVec3)> = faces.collect();
        let x = &model.rest_positions;
        let mut mass = vec![0.0; model.particle_count()];
        for t in &model.triangles {
            let [a, b, c] = t.map(|p| x[p as usize]);
            let third = self.density * triangle_area(a, b, c) / 3.0;
            for &p in t {
                mass[p as usize] += third;
            }
        }
        self.check_f32_masses(&mass)?;
        let k = self.edge_stiffness(x, faces.iter().copied())?;
        let constants = model
            .springs
            .iter()
            .map(|sp| {
                let k = k
                    .get(&(sp.i.min(sp.j), sp.i.max(sp.j)))
                    .copied()
                    .unwrap_or(0.0);
                SpringConstants {
                    k,
                    kd: self.damping * k,
                }
            })
            .collect::<Vec<_>>();
        if let Some(s) = constants.iter().position(|c| !((c.k as f32).is_finite())) {
            let sp = &model.springs[s];
            return Err(invalid(
                "material.stretch",
                format!(
                    "a stretch stiffness whose springs' constants (it times a cell's area over \
                     a side's length squared) are finite f32 numbers, as the GPU holds them; \
                     the spring between particles {} and {} would have {} N/m (a cell far \
                     from square: give cells closer to square)",
                    sp.i,
                    sp.j,
                    format_number(constants[s].k)
                ),
                self.stretch,
            ));
        }
        model.mass = mass;
        model.own_constants = constants;
        model.bending = if self.bending.warp > 0.0 {
            Some(self.bending_operator(model, &faces)?)
        } else {
            None
        };
        Ok(())
    }

    /// The bending operator of `model` (its rest shape and pins) with this
    /// material's bending: [`Bending::grid`] on a grid (the warp along its
    /// rows), [`Bending::new`] on a mesh's triangles, each with the warp of
    /// the face it is drawn from.
    fn bending_operator(&self, model: &Model, faces: &[(&[u32], DVec3)]) -> Result<Bending> {
        if let Some(spec) = &model.grid {
            let hx = spec.size[0] / (spec.nx - 1) as f64;
            let hy = spec.size[1] / (spec.ny - 1) as f64;
            return Bending::grid(
                spec.nx,
                spec.ny,
                hx,
                hy,
                self.bending,
                self.damping,
                &model.pinned,
            );
        }
        let warps: Vec<DVec3> = faces
            .iter()
            .flat_map(|&(corners, warp)| {
                std::iter::repeat_n(warp, if corners.len() == 4 { 2 } else { 1 })
            })
            .collect();
        Bending::new(
            &model.rest_positions,
            &model.triangles,
            self.bending,
            &warps,
            self.damping,
            &model.pinned,
        )
    }

    /// Refuses a density whose particle masses (`mass`, from the rest
    /// areas) the `f32` solvers cannot hold: each must be a normal `f32`,
    /// so that it and its inverse are finite and non-zero there (a density
    /// of 1e300 kg/m² gives infinite masses in `f32`, and a cloth that
    /// never moves, while `f64` falls).
    fn check_f32_masses(&self, mass: &[f64]) -> Result<()> {
        let normal = |m: f64| (m as f32).is_normal() && m > 0.0;
        let Some(p) = mass.iter().position(|&m| !normal(m)) else {
            return Ok(());
        };
        Err(invalid(
            "material.density",
            format!(
                "a density whose particle masses (density × a third of the area of each \
                 triangle a particle is a corner of) are normal f32 numbers, from {} to {} kg, \
                 as the GPU holds them; particle {p} would have {} kg",
                format_number(f64::from(f32::MIN_POSITIVE)),
                format_number(f64::from(f32::MAX)),
                format_number(mass[p])
            ),
            format_number(self.density),
        ))
    }

    /// The stiffness \[N/m\] each face gives its sides and diagonals
    /// (module docs), summed per edge (ends in ascending order), for the
    /// rest positions `x` and each face's warp direction (unit, in its
    /// plane); refuses a shear stiffness too large for a quad.
    pub fn edge_stiffness<'a>(
        &self,
        x: &[DVec3],
        faces: impl Iterator<Item = (&'a [u32], DVec3)>,
    ) -> Result<HashMap<(u32, u32), f64>> {
        let mut k: HashMap<(u32, u32), f64> = HashMap::new();
        let mut add = |i: u32, j: u32, value: f64| {
            *k.entry((i.min(j), i.max(j))).or_insert(0.0) += value;
        };
        let l2 = |i: u32, j: u32| x[i as usize].distance_squared(x[j as usize]);
        // cos² of the angle between the side i j and the warp.
        let cos2 = |i: u32, j: u32, warp: DVec3| {
            let side = x[j as usize] - x[i as usize];
            side.dot(warp).powi(2) / side.length_squared()
        };
        let axial = self.axial();
        for (face, warp) in faces {
            match *face {
                [a, b, c] => {
                    let area = triangle_area(x[a as usize], x[b as usize], x[c as usize]);
                    for (i, j) in [(a, b), (b, c), (c, a)] {
                        let stretch = self.stretch.along(cos2(i, j, warp));
                        add(i, j, stretch * area / l2(i, j));
                    }
                }
                [a, b, c, d] => {
                    let [pa, pb, pc, pd] = [a, b, c, d].map(|p| x[p as usize]);
                    let area = triangle_area(pa, pb, pc) + triangle_area(pa, pc, pd);
                    for (i, j) in [(a, b), (b, c), (c, d), (d, a)] {
                        let along = axial.along(cos2(i, j, warp));
                        add(i, j, self.quad_side(along, l2(i, j), area)?);
                    }
                    for (i, j) in [(a, c), (b, d)] {
                        add(i, j, self.shear * l2(i, j) / (2.0 * area));
                    }
                }
                _ => {}
            }
        }
        Ok(k)
    }

    /// Refuses a shear stiffness too large for a grid's cells, `w` \[m\]
    /// along the warp by `h` \[m\] along the weft (what [`Material::apply`]
    /// would refuse).
    pub fn check_grid_cell(&self, w: f64, h: f64) -> Result<()> {
        let axial = self.axial();
        self.quad_side(axial.warp, w * w, w * h)?;
        self.quad_side(axial.weft, h * h, w * h).map(|_| ())
    }

    /// The stiffness \[N/m\] a quad cell of area `area` \[m²\] gives a
    /// side of rest length `√l2` \[m\] whose `C11` along it is `axial`
    /// \[N/m\] ([`Material::axial`]): `(axial − S L⁴/A²) · A / (2 L²)`,
    /// refused where it is not positive.
    fn quad_side(&self, axial: f64, l2: f64, area: f64) -> Result<f64> {
        let share = axial - self.shear * l2 * l2 / (area * area);
        if share > 0.0 {
            Ok(share * area / (2.0 * l2))
        } else {
            Err(self.too_much_shear(l2.sqrt(), area / l2.sqrt()))
        }
    }

    /// The refusal of a shear stiffness that would give a cell's side of
    /// rest length `side` \[m\] (the cell `height` \[m\] across it) a
    /// negative stiffness.
    fn too_much_shear(&self, side: f64, height: f64) -> Error {
        let ratio = side / height;
        invalid(
            "material.shear",
            format!(
                "a shear stiffness S with S × r² < C for the cloth's most elongated cell, \
                 whose side / height ratio is r = {} and C = (Y + √(Y² + 4 S² Y / Y')) / 2 along \
                 that side (Y the stretch along it, Y' across it; else that side's spring would \
                 get a negative stiffness); give a smaller shear or cells closer to square",
                format_number(ratio)
            ),
            format_number(self.shear),
        )
    }
}

/// Area of the triangle `a b c` \[m²\].
fn triangle_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    0.5 * (b - a).cross(c - a).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rounding of a few dozen `f64` operations on numbers of order 1e3.
    const ROUNDING: f64 = 1e-12;

    /// A periodic lattice of `w × h` cells of a woven material, its warp
    /// along `x`: the in-plane stiffness its springs homogenise to
    /// (`C = Σ k L² n⊗n⊗n⊗n / A` per cell, each side shared by two cells)
    /// has the uniaxial stiffnesses `C11 − C12²/C22` along the warp and
    /// `C22 − C12²/C11` along the weft the material gives, and the shear
    /// stiffness `C66` its `shear`.
    #[test]
    fn a_woven_cell_has_each_directions_stretch_and_the_shear() {
        for (w, h) in [(1.0, 1.0), (0.5, 0.8)] {
            let material = Material {
                stretch: WarpWeft {
                    warp: 900.0,
                    weft: 150.0,
                },
                shear: 30.0,
                ..Material::default()
            };
            let x = [
                DVec3::ZERO,
                DVec3::new(w, 0.0, 0.0),
                DVec3::new(w, 0.0, h),
                DVec3::new(0.0, 0.0, h),
            ];
            let cell: &[u32] = &[0, 1, 2, 3];
            let k = material
                .edge_stiffness(&x, std::iter::once((cell, DVec3::X)))
                .expect("a cell");
            let (kx, ky, kd) = (k[&(0, 1)], k[&(1, 2)], k[&(0, 2)]);
            let (area, d2) = (w * h, w * w + h * h);
            // A side is shared by two cells: per cell, one side of twice
            // the cell's share; both diagonals are the cell's own.
            let c11 = (2.0 * kx * w * w + 2.0 * kd * w.powi(4) / d2) / area;
            let c22 = (2.0 * ky * h * h + 2.0 * kd * h.powi(4) / d2) / area;
            let c12 = 2.0 * kd * w * w * h * h / d2 / area;
            let close = |a: f64, b: f64| (a - b).abs() <= ROUNDING * b;
            assert!(close(c11 - c12 * c12 / c22, 900.0), "{w} × {h}: warp");
            assert!(close(c22 - c12 * c12 / c11, 150.0), "{w} × {h}: weft");
            assert!(close(c12, 30.0), "{w} × {h}: shear");
        }
    }
}
