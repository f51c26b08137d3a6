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

use std::collections::HashMap;

use glam::DVec3;

use crate::bending::Bending;
use crate::error::{Error, Result};
use crate::model::{Model, SpringConstants};
use crate::params::{
    check, format_below, format_number, Integrator, Params, SpringKind, SpringParams,
};

/// A membrane material: what `[material]` gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Areal density \[kg/m²\], `> 0`.
    pub density: f64,
    /// Stretch stiffness \[N/m\]: force per unit width per unit strain of a
    /// strip pulled along either cloth axis (free to narrow), `> 0`.
    pub stretch: f64,
    /// In-plane shear stiffness \[N/m\]: shear force per unit width per
    /// radian of shear, `> 0`. A triangle mesh has no shear springs: its
    /// shear stiffness is its lattice's (see the module docs).
    pub shear: f64,
    /// Bending stiffness per unit width \[N·m\] (moment per unit width per
    /// unit curvature), `≥ 0`, acted on by the linear bending model of
    /// [`crate::bending`]; `0`: the cloth does not resist bending.
    pub bending: f64,
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
            stretch: 50.0,
            shear: 20.0,
            bending: 0.0,
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
    /// stiffness, a damping outside `0..=1` s, and a non-zero bending
    /// stiffness (not implemented yet), naming the `material.*` key.
    pub fn validate(&self) -> Result<()> {
        check(
            "material.density",
            self.density,
            self.density > 0.0,
            "> 0 (kg/m²)",
        )?;
        for (key, value) in [
            ("material.stretch", self.stretch),
            ("material.shear", self.shear),
        ] {
            check(
                key,
                value,
                value > 0.0 && value <= MAX_STIFFNESS,
                "0 < stiffness ≤ 1e6 (N/m, per unit width)",
            )?;
        }
        check(
            "material.bending",
            self.bending,
            (0.0..=MAX_BENDING).contains(&self.bending),
            "0 ≤ bending ≤ 1 (N·m, per unit width)",
        )?;
        check(
            "material.damping",
            self.damping,
            (0.0..=MAX_DAMPING).contains(&self.damping),
            "0 ≤ damping ≤ 1 (s, kd = damping × k per spring)",
        )
    }

    /// The spring kinds a cloth of this material has, for
    /// [`Params::springs`]: stretch and shear springs with the material's
    /// stiffnesses and damping `β ×` those as their kinds' nominal
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
                self.stretch,
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
        Err(invalid(
            "material.bending",
            format!(
                "at most {} N·m for the explicit integrator at dt = {} s on this cloth \
                 ({EXPLICIT_RULE}); give a smaller bending, a smaller dt, or the implicit or \
                 semi-implicit integrator, which are stable at any bending",
                format_below(self.bending * headroom),
                format_number(params.dt)
            ),
            format_number(self.bending),
        ))
    }

    /// `u = (Y + √(Y² + 4S²)) / 2` \[N/m\]: a rectangular cell's `C11` (and
    /// `C22`) for which the uniaxial stiffness is `Y` with shear springs of
    /// shear stiffness `S` (`docs/materials.md`).
    fn axial(&self) -> f64 {
        let (y, s) = (self.stretch, self.shear);
        0.5 * (y + (y * y + 4.0 * s * s).sqrt())
    }

    /// Gives `model` (built with [`Material::spring_params`]) this
    /// material's masses, per-spring constants and, with a bending
    /// stiffness, its bending operator ([`Bending::grid`] on a grid,
    /// [`Bending::new`] on a mesh's triangles). `faces` are its cells as
    /// cyclic corner lists: quads (a grid's cells, a mesh's quad faces)
    /// and triangles; the masses come from `model.triangles`. Refuses a
    /// shear stiffness too large for a cell's aspect ratio (a side would
    /// get a negative stiffness), naming `material.shear`.
    pub fn apply<'a>(
        &self,
        model: &mut Model,
        faces: impl Iterator<Item = &'a [u32]>,
    ) -> Result<()> {
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
        let k = self.edge_stiffness(x, faces)?;
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
                format_number(self.stretch),
            ));
        }
        model.mass = mass;
        model.own_constants = constants;
        model.bending = match (&model.grid, self.bending > 0.0) {
            (_, false) => None,
            (Some(spec), true) => {
                let hx = spec.size[0] / (spec.nx - 1) as f64;
                let hy = spec.size[1] / (spec.ny - 1) as f64;
                Some(Bending::grid(
                    spec.nx,
                    spec.ny,
                    hx,
                    hy,
                    self.bending,
                    self.damping,
                    &model.pinned,
                )?)
            }
            (None, true) => Some(Bending::new(
                &model.rest_positions,
                &model.triangles,
                self.bending,
                self.damping,
                &model.pinned,
            )?),
        };
        Ok(())
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
    /// rest positions `x`; refuses a shear stiffness too large for a quad.
    pub fn edge_stiffness<'a>(
        &self,
        x: &[DVec3],
        faces: impl Iterator<Item = &'a [u32]>,
    ) -> Result<HashMap<(u32, u32), f64>> {
        let mut k: HashMap<(u32, u32), f64> = HashMap::new();
        let mut add = |i: u32, j: u32, value: f64| {
            *k.entry((i.min(j), i.max(j))).or_insert(0.0) += value;
        };
        let l2 = |i: u32, j: u32| x[i as usize].distance_squared(x[j as usize]);
        for face in faces {
            match *face {
                [a, b, c] => {
                    let area = triangle_area(x[a as usize], x[b as usize], x[c as usize]);
                    for (i, j) in [(a, b), (b, c), (c, a)] {
                        add(i, j, self.stretch * area / l2(i, j));
                    }
                }
                [a, b, c, d] => {
                    let [pa, pb, pc, pd] = [a, b, c, d].map(|p| x[p as usize]);
                    let area = triangle_area(pa, pb, pc) + triangle_area(pa, pc, pd);
                    for (i, j) in [(a, b), (b, c), (c, d), (d, a)] {
                        add(i, j, self.quad_side(l2(i, j), area)?);
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

    /// The stiffness \[N/m\] a quad cell of area `area` \[m²\] gives a
    /// side of rest length `√l2` \[m\]: `(u − S L⁴/A²) · A / (2 L²)`,
    /// refused where it is not positive.
    pub fn quad_side(&self, l2: f64, area: f64) -> Result<f64> {
        let share = self.axial() - self.shear * l2 * l2 / (area * area);
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
                "a shear stiffness S with S × r² < (stretch + √(stretch² + 4 S²)) / 2 for the \
                 cloth's most elongated cell, whose side / height ratio is r = {} (else that \
                 side's spring would get a negative stiffness); give a smaller shear or cells \
                 closer to square",
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
