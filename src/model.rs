//! The cloth model: particles, springs, triangles and the per-particle
//! adjacency the solvers gather over. Built once; stepping never changes it.
//!
//! # Particle order
//!
//! Particles are numbered row-major: particle `row * nx + col`, with
//! `0 ≤ col < nx` along the cloth's width and `0 ≤ row < ny` along its
//! height. Row 0 is the **top** edge, column 0 the **left** edge, so the
//! `top-left` corner is particle 0 and `bottom-right` is `nx * ny - 1`.
//!
//! Rest positions are `origin + col·Δw·u + row·Δh·v` with `Δw = w/(nx−1)`,
//! `Δh = h/(ny−1)` and
//! - `horizontal`: `u = +x`, `v = +z` (a patch in the xz-plane at height
//!   `origin.y`, like a tablecloth held above the floor);
//! - `vertical`: `u = +x`, `v = −y` (a curtain hanging down from its top
//!   edge at `origin`).

use std::ops::Range;

use glam::DVec3;

use crate::bending::Bending;
use crate::budget::{self, try_collect, try_vec, try_with_capacity};
use crate::error::{Error, Result};
use crate::params::{check, check_finite, format_number, Params, SpringKind, SpringParams};

/// What a model's allocations are named in a memory error.
const MODEL: &str = "the cloth's model";

/// Largest particle count a cloth may have. Far above what fits in a GPU
/// storage buffer binding on common devices; the GPU solver checks the
/// device's real limits separately.
pub const MAX_PARTICLES: usize = 1 << 24;

/// Largest rest coordinate a cloth's particle, and a character's key, may
/// have \[m\]. The GPU and the `f32` mirror hold positions as `f32` and
/// take a spring's length from the squared difference of its ends: within
/// ±1e18 m that square (at most 12e36 m²) is a finite `f32` (up to
/// 3.4e38), with room for the cloth to move.
pub const MAX_COORDINATE: f64 = 1e18;

/// Shortest rest side (spring between neighbours) a cloth may have \[m\]:
/// its square, 1e-36 m², is still a normal `f32` (from 1.2e-38).
pub const MIN_SIDE: f64 = 1e-18;

/// Smallest rest triangle area a cloth may have \[m²\]: the smallest
/// normal `f32`, below which the wind's and the masses' areas lose their
/// precision or vanish.
pub const MIN_AREA: f64 = f32::MIN_POSITIVE as f64;

/// The distance between neighbouring `f32` numbers at magnitude `reach`
/// \[m\]: two particles closer than this are the same `f32` point.
pub(crate) fn f32_spacing(reach: f64) -> f64 {
    let x = reach.abs() as f32;
    let next = f32::from_bits(x.to_bits() + 1);
    f64::from(next) - f64::from(x)
}

/// Refuses a position with a coordinate beyond ±[`MAX_COORDINATE`],
/// naming `key[c]`.
pub(crate) fn check_position(key: &str, p: DVec3) -> Result<()> {
    for (c, x) in p.to_array().into_iter().enumerate() {
        check(
            &format!("{key}[{c}]"),
            x,
            x.abs() <= MAX_COORDINATE,
            "within ±1e18 m (the GPU holds positions as f32)",
        )?;
    }
    Ok(())
}

/// Cloth orientation at rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Orientation {
    /// In the xz-plane (normal +y).
    Horizontal,
    /// In the xy-plane, hanging down from the top edge (normal +z).
    Vertical,
}

/// A corner of the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corner {
    /// Row 0, column 0.
    TopLeft,
    /// Row 0, column nx−1.
    TopRight,
    /// Row ny−1, column 0.
    BottomLeft,
    /// Row ny−1, column nx−1.
    BottomRight,
}

/// An edge of the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// Row 0.
    Top,
    /// Row ny−1.
    Bottom,
    /// Column 0.
    Left,
    /// Column nx−1.
    Right,
}

/// Which particles are pinned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pin {
    /// One corner particle.
    Corner(Corner),
    /// Every particle of one edge.
    Edge(Edge),
    /// A particle by index (row-major, see the module docs; a mesh's
    /// vertex index, 0-based in file order).
    Index(usize),
    /// Every particle whose rest position lies in the box `[lo, hi]`
    /// (bounds included; world coordinates \[m\], after a mesh's `scale`
    /// and `origin`); it must hold at least one particle.
    Region([DVec3; 2]),
}

impl Pin {
    /// Parses the scene-file names `top-left`, `top`, … .
    pub fn parse(name: &str) -> Option<Pin> {
        use {Corner::*, Edge::*};
        [TopLeft, TopRight, BottomLeft, BottomRight]
            .map(Pin::Corner)
            .into_iter()
            .chain([Top, Bottom, Left, Right].map(Pin::Edge))
            .find(|pin| pin.name() == Some(name))
    }

    /// The names [`Pin::parse`] accepts.
    pub const NAMES: &'static str =
        "top-left, top-right, bottom-left, bottom-right, top, bottom, left, right";

    /// The scene-file name of a corner or edge pin (`top-left`, `top`).
    pub fn name(&self) -> Option<&'static str> {
        Some(match self {
            Pin::Corner(Corner::TopLeft) => "top-left",
            Pin::Corner(Corner::TopRight) => "top-right",
            Pin::Corner(Corner::BottomLeft) => "bottom-left",
            Pin::Corner(Corner::BottomRight) => "bottom-right",
            Pin::Edge(Edge::Top) => "top",
            Pin::Edge(Edge::Bottom) => "bottom",
            Pin::Edge(Edge::Left) => "left",
            Pin::Edge(Edge::Right) => "right",
            Pin::Index(_) | Pin::Region(_) => return None,
        })
    }

    /// Whether `p` lies in a [`Pin::Region`]'s box (`false` for other pins).
    pub fn contains(&self, p: DVec3) -> bool {
        match self {
            Pin::Region([lo, hi]) => (0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k]),
            _ => false,
        }
    }

    /// Refuses a [`Pin::Region`] whose box is not finite or has a lower
    /// corner above its upper one; `key` is its scene-file key.
    pub(crate) fn check_region(&self, key: &str) -> Result<()> {
        let Pin::Region([lo, hi]) = self else {
            return Ok(());
        };
        for k in 0..3 {
            check_finite(&format!("{key}.box[0][{k}]"), lo[k], "m")?;
            check_finite(&format!("{key}.box[1][{k}]"), hi[k], "m")?;
            if lo[k] > hi[k] {
                return Err(invalid(
                    &format!("{key}.box"),
                    "[[x0, y0, z0], [x1, y1, z1]] with x0 ≤ x1, y0 ≤ y1 and z0 ≤ z1 (m)",
                    format!("[{}, {}]", point(*lo), point(*hi)),
                ));
            }
        }
        Ok(())
    }

    /// The error for a [`Pin::Region`] at `key` that holds no particle.
    pub(crate) fn empty_region(&self, key: &str) -> Error {
        invalid(
            key,
            "a box holding at least one particle's rest position (world coordinates, m)",
            format!("{self}, which holds none"),
        )
    }
}

/// A pin as the scene file writes it: `"top-left"`, `5`,
/// `{ box = [[0, 1, 0], [0.1, 1, 0.1]] }`.
impl std::fmt::Display for Pin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pin::Index(i) => write!(f, "{i}"),
            Pin::Region([lo, hi]) => write!(f, "{{ box = [{}, {}] }}", point(*lo), point(*hi)),
            named => write!(f, "\"{}\"", named.name().unwrap_or_default()),
        }
    }
}

/// `[x, y, z]`, each number as messages write it.
pub(crate) fn point(p: DVec3) -> String {
    let [x, y, z] = p.to_array().map(format_number);
    format!("[{x}, {y}, {z}]")
}

/// The geometry and mass of a rectangular cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothSpec {
    /// Particles along the width (columns), `≥ 2`.
    pub nx: usize,
    /// Particles along the height (rows), `≥ 2`.
    pub ny: usize,
    /// Width and height \[m\], both `> 0`.
    pub size: [f64; 2],
    /// Position of the top-left particle \[m\].
    pub origin: DVec3,
    /// Rest orientation.
    pub orientation: Orientation,
    /// Total mass \[kg\], `> 0`, shared equally by all particles (pinned ones
    /// included).
    pub mass: f64,
    /// Pinned particles.
    pub pins: Vec<Pin>,
}

impl Default for ClothSpec {
    fn default() -> Self {
        ClothSpec {
            nx: 33,
            ny: 33,
            size: [1.0, 1.0],
            origin: DVec3::new(-0.5, 1.0, -0.5),
            orientation: Orientation::Horizontal,
            mass: 0.3,
            pins: vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)],
        }
    }
}

fn invalid(key: &str, allowed: &str, got: impl std::fmt::Display) -> Error {
    Error::InvalidParameter {
        key: key.to_string(),
        allowed: allowed.to_string(),
        got: got.to_string(),
    }
}

impl ClothSpec {
    /// Refuses a cloth that cannot be built: fewer than 2 × 2 particles, more
    /// than [`MAX_PARTICLES`], a non-positive or non-finite size or mass, a
    /// pin index out of range.
    pub fn validate(&self) -> Result<()> {
        for (key, n) in [
            ("cloth.resolution[0]", self.nx),
            ("cloth.resolution[1]", self.ny),
        ] {
            if n < 2 {
                return Err(invalid(key, "≥ 2 particles", n));
            }
        }
        let count = self.nx.saturating_mul(self.ny);
        if count > MAX_PARTICLES {
            return Err(invalid(
                "cloth.resolution",
                &format!("at most {MAX_PARTICLES} particles in all"),
                format!("{} × {}", self.nx, self.ny),
            ));
        }
        for (key, s) in [
            ("cloth.size[0]", self.size[0]),
            ("cloth.size[1]", self.size[1]),
        ] {
            check(key, s, s > 0.0, "> 0 (m)")?;
        }
        check_position("cloth.origin", self.origin)?;
        self.check_scale()?;
        check("cloth.mass", self.mass, self.mass > 0.0, "> 0 (kg, total)")?;
        for (k, pin) in self.pins.iter().enumerate() {
            let key = format!("cloth.pins[{k}]");
            match *pin {
                Pin::Index(i) if i >= count => {
                    return Err(invalid(
                        &key,
                        &format!("a particle index below {count} or one of {}", Pin::NAMES),
                        i,
                    ));
                }
                Pin::Region(_) => {
                    pin.check_region(&key)?;
                    if self.pin_indices(*pin).is_empty() {
                        return Err(pin.empty_region(&key));
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Refuses a size whose rest geometry the solvers cannot hold (the
    /// size and origin themselves already checked): a particle beyond
    /// ±[`MAX_COORDINATE`], a cell side below [`MIN_SIDE`] or below the
    /// `f32` spacing at the cloth's coordinates (neighbours would be one
    /// point on the GPU).
    fn check_scale(&self) -> Result<()> {
        let size = format!(
            "[{}, {}]",
            format_number(self.size[0]),
            format_number(self.size[1])
        );
        let (nx, ny) = (self.nx, self.ny);
        // Positions are affine in the row and column, so the corners
        // reach farthest.
        let reach = [0, nx - 1, (ny - 1) * nx, ny * nx - 1]
            .map(|p| self.rest_position(p).abs().max_element())
            .into_iter()
            .fold(0.0, f64::max);
        // Written so that a NaN reach (an overflow times a zero axis) fails.
        let within = reach <= MAX_COORDINATE;
        if !within {
            return Err(invalid(
                "cloth.size",
                &format!(
                    "a size that keeps the cloth within ±1e18 m of the world's origin (from \
                     `cloth.origin` = {}; the GPU holds positions as f32)",
                    point(self.origin)
                ),
                size,
            ));
        }
        let cell = [
            self.size[0] / (nx - 1) as f64,
            self.size[1] / (ny - 1) as f64,
        ];
        let shortest = f32_spacing(reach).max(MIN_SIDE);
        if cell[0].min(cell[1]) < shortest {
            return Err(invalid(
                "cloth.size",
                &format!(
                    "a size whose cells (size / (resolution − 1), here {} × {} m) are at least \
                     {:.2e} m: the f32 spacing at the cloth's coordinates (up to {} m), below \
                     which neighbouring particles are one point on the GPU, and at least \
                     1e-18 m, below which a length squared is no normal f32",
                    format_number(cell[0]),
                    format_number(cell[1]),
                    shortest,
                    format_number(reach)
                ),
                size,
            ));
        }
        // A grid's triangles are half cells, so sides of at least
        // MIN_SIDE give them at least MIN_SIDE² / 2 = 5e-37 m² > MIN_AREA.
        Ok(())
    }

    /// Rest position of particle `p` \[m\] (see the module docs).
    pub fn rest_position(&self, p: usize) -> DVec3 {
        let (nx, ny) = (self.nx, self.ny);
        let dw = self.size[0] / (nx - 1) as f64;
        let dh = self.size[1] / (ny - 1) as f64;
        let (u, v) = match self.orientation {
            Orientation::Horizontal => ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            Orientation::Vertical => ([1.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        };
        let o = self.origin;
        let (a, b) = ((p % nx) as f64 * dw, (p / nx) as f64 * dh);
        DVec3::new(
            o[0] + a * u[0] + b * v[0],
            o[1] + a * u[1] + b * v[1],
            o[2] + a * u[2] + b * v[2],
        )
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.nx * self.ny
    }

    /// Springs [`Model::new`] makes with `materials` (none of a kind whose
    /// stiffness is zero).
    pub fn spring_count(&self, materials: &[SpringParams; 3]) -> usize {
        let (nx, ny) = (self.nx, self.ny);
        SpringKind::ALL
            .iter()
            .filter(|kind| materials[kind.index()].stiffness > 0.0)
            .map(|kind| match kind {
                SpringKind::Stretch => (nx - 1) * ny + nx * (ny - 1),
                SpringKind::Shear => 2 * (nx - 1) * (ny - 1),
                SpringKind::Bend => nx.saturating_sub(2) * ny + nx * ny.saturating_sub(2),
            })
            .sum()
    }

    /// Triangles [`Model::new`] makes: two per grid cell.
    pub fn triangle_count(&self) -> usize {
        2 * (self.nx - 1) * (self.ny - 1)
    }

    /// The particle indices a pin selects.
    pub fn pin_indices(&self, pin: Pin) -> Vec<usize> {
        let (nx, ny) = (self.nx, self.ny);
        match pin {
            Pin::Corner(Corner::TopLeft) => vec![0],
            Pin::Corner(Corner::TopRight) => vec![nx - 1],
            Pin::Corner(Corner::BottomLeft) => vec![(ny - 1) * nx],
            Pin::Corner(Corner::BottomRight) => vec![ny * nx - 1],
            Pin::Edge(Edge::Top) => (0..nx).collect(),
            Pin::Edge(Edge::Bottom) => ((ny - 1) * nx..ny * nx).collect(),
            Pin::Edge(Edge::Left) => (0..ny).map(|r| r * nx).collect(),
            Pin::Edge(Edge::Right) => (0..ny).map(|r| r * nx + nx - 1).collect(),
            Pin::Index(i) => vec![i],
            Pin::Region(_) => (0..nx * ny)
                .filter(|&p| pin.contains(self.rest_position(p)))
                .collect(),
        }
    }
}

/// One spring between particles `i` and `j`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    /// First particle.
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Rest length \[m\].
    pub rest: f64,
    /// Which kind (selects stiffness, damping and max stretch).
    pub kind: SpringKind,
}

/// How far the fix-up lets a seam (a spring of zero rest length, see
/// [`crate::world`]) open \[m\], where its kind has a `max_stretch` — or
/// as far as its two sides rest apart, where that is wider: a millimetre,
/// the "closed" (a multiple of zero would be no limit at all). A
/// seam laid out open is closed by its spring, not snapped shut by the
/// fix-up, whose velocity rebuild would throw its sides at each other.
pub const SEAM_FIXUP_LIMIT: f64 = 1e-3;

impl Spring {
    /// Whether it is a seam: a spring of zero rest length (see
    /// [`crate::world`]).
    pub fn is_seam(&self) -> bool {
        self.rest == 0.0
    }

    /// The spring `i–j` of `kind` at rest in `positions`: its rest length
    /// is their distance \[m\].
    pub fn at_rest(positions: &[DVec3], i: u32, j: u32, kind: SpringKind) -> Spring {
        let (a, b) = (positions[i as usize], positions[j as usize]);
        let rest = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        Spring { i, j, rest, kind }
    }
}

/// A spring's own constants, where its cloth is of a material
/// ([`crate::material::Material`]) rather than of spring kinds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringConstants {
    /// Stiffness `k` \[N/m\].
    pub k: f64,
    /// Damping `kd` \[N·s/m\] along the spring.
    pub kd: f64,
}

/// A compressed per-particle list (CSR): the entries of particle `p` are
/// `entries[offsets[p]..offsets[p + 1]]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Adjacency {
    /// `particle_count + 1` offsets into `entries`.
    pub offsets: Vec<u32>,
    /// The entries, grouped by particle, in ascending order within a group.
    pub entries: Vec<u32>,
}

impl Adjacency {
    /// The entries of particle `p`.
    #[inline]
    pub fn of(&self, p: usize) -> &[u32] {
        &self.entries[self.offsets[p] as usize..self.offsets[p + 1] as usize]
    }

    /// Builds the list from `(particle, entry)` pairs, keeping each
    /// particle's entries in ascending order so every consumer (CPU twin and
    /// GPU kernel) sums in the same, fixed order.
    pub(crate) fn build(
        particles: usize,
        pairs: impl Iterator<Item = (usize, u32)> + Clone,
    ) -> Result<Self> {
        let mut counts = try_vec(particles + 1, 0u32, MODEL)?;
        for (p, _) in pairs.clone() {
            counts[p + 1] += 1;
        }
        for p in 0..particles {
            counts[p + 1] += counts[p];
        }
        let offsets = try_collect(counts.iter().copied(), MODEL)?;
        let mut entries = try_vec(offsets[particles] as usize, 0u32, MODEL)?;
        let mut cursor = counts;
        for (p, e) in pairs {
            entries[cursor[p] as usize] = e;
            cursor[p] += 1;
        }
        for p in 0..particles {
            entries[offsets[p] as usize..offsets[p + 1] as usize].sort_unstable();
        }
        Ok(Adjacency { offsets, entries })
    }
}

/// An incident-spring entry encodes the spring index and which end the
/// particle is: `spring << 1 | end`, `end = 0` for `i` (the force `f_i` acts
/// on it) and `1` for `j` (it receives `−f_i`). The same encoding is used by
/// the GPU buffers.
#[inline]
pub fn decode_incidence(entry: u32) -> (usize, bool) {
    ((entry >> 1) as usize, entry & 1 == 1)
}

/// The cloth: built once from a [`ClothSpec`] and the spring materials.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The grid spec it was built from (`None` for a model built with
    /// [`Model::from_parts`]).
    pub grid: Option<ClothSpec>,
    /// Rest (and initial) positions \[m\], particle order.
    pub rest_positions: Vec<DVec3>,
    /// Mass of each particle \[kg\] (equal for all on a grid; by area on a
    /// mesh and for a material, see [`crate::material`]).
    pub mass: Vec<f64>,
    /// Whether each particle is pinned.
    pub pinned: Vec<bool>,
    /// Springs, grouped by kind (stretch, shear, bend).
    pub springs: Vec<Spring>,
    /// The index range of each kind in `springs`, by [`SpringKind::index`].
    pub kind_ranges: [Range<usize>; 3],
    /// Triangles (counter-clockwise seen from the normal side: +y for a
    /// horizontal cloth, +z for a vertical one).
    pub triangles: Vec<[u32; 3]>,
    /// For each particle, its incident springs (see [`decode_incidence`]).
    pub particle_springs: Adjacency,
    /// For each particle, the indices of its incident triangles.
    pub particle_triangles: Adjacency,
    /// Each spring's own constants, in `springs` order, for a cloth of a
    /// material ([`crate::material::Material::apply`]); empty: every
    /// spring takes its kind's from the parameters
    /// ([`Model::spring_constants`]).
    pub own_constants: Vec<SpringConstants>,
    /// The linear bending operator of a cloth of a material with a bending
    /// stiffness ([`crate::bending`]); `None`: bending is the bend springs'.
    pub bending: Option<Bending>,
    /// The first particle of each cloth of a world ([`crate::world`]), in
    /// order: `[0]` for one cloth.
    pub cloth_starts: Vec<u32>,
    /// Each cloth's grid, `[columns, rows]`, in `cloth_starts` order
    /// (`None` for a cloth of another shape): what the implicit CG's
    /// coarse levels aggregate (`src/aggregation.rs`).
    pub cloth_grids: Vec<Option<[usize; 2]>>,
}

impl Model {
    /// Builds the cloth. A spring kind whose stiffness is zero gets no
    /// springs. A cloth whose model needs more memory than the host has is
    /// refused before it is built ([`Error::OutOfMemory`]).
    pub fn new(spec: &ClothSpec, materials: &[SpringParams; 3]) -> Result<Model> {
        spec.validate()?;
        let (nx, ny) = (spec.nx, spec.ny);
        let n = nx * ny;
        let (springs, triangles) = (spec.spring_count(materials), spec.triangle_count());
        budget::check_host(
            budget::model_bytes(n as u64, springs as u64, triangles as u64),
            || format!("the {nx} × {ny} cloth's model ({n} particles, {springs} springs)"),
        )?;
        let mut rest_positions = try_with_capacity(n, MODEL)?;
        rest_positions.extend((0..n).map(|p| spec.rest_position(p)));
        let idx = |row: usize, col: usize| (row * nx + col) as u32;
        let mut springs = try_with_capacity(springs, MODEL)?;
        for kind in SpringKind::ALL {
            if materials[kind.index()].stiffness > 0.0 {
                let mut pairs = Vec::new();
                for row in 0..ny {
                    for col in 0..nx {
                        match kind {
                            SpringKind::Stretch => {
                                if col + 1 < nx {
                                    pairs.push((idx(row, col), idx(row, col + 1)));
                                }
                                if row + 1 < ny {
                                    pairs.push((idx(row, col), idx(row + 1, col)));
                                }
                            }
                            SpringKind::Shear => {
                                if col + 1 < nx && row + 1 < ny {
                                    pairs.push((idx(row, col), idx(row + 1, col + 1)));
                                    pairs.push((idx(row, col + 1), idx(row + 1, col)));
                                }
                            }
                            SpringKind::Bend => {
                                if col + 2 < nx {
                                    pairs.push((idx(row, col), idx(row, col + 2)));
                                }
                                if row + 2 < ny {
                                    pairs.push((idx(row, col), idx(row + 2, col)));
                                }
                            }
                        }
                    }
                }
                for (i, j) in pairs {
                    springs.push(Spring::at_rest(&rest_positions, i, j, kind));
                }
            }
        }
        let mut triangles = try_with_capacity(triangles, MODEL)?;
        for row in 0..ny - 1 {
            for col in 0..nx - 1 {
                let (a, b) = (idx(row, col), idx(row, col + 1));
                let (c, d) = (idx(row + 1, col), idx(row + 1, col + 1));
                triangles.push([a, c, b]);
                triangles.push([b, c, d]);
            }
        }
        let mut pinned = try_vec(n, false, MODEL)?;
        for &pin in &spec.pins {
            for p in spec.pin_indices(pin) {
                pinned[p] = true;
            }
        }
        let mut model = Model::from_parts(
            rest_positions,
            try_vec(n, spec.mass / n as f64, MODEL)?,
            pinned,
            springs,
            triangles,
        )?;
        model.grid = Some(spec.clone());
        model.cloth_grids = vec![Some([nx, ny])];
        Ok(model)
    }

    /// Builds a model from explicit parts: any particle set, any springs and
    /// any triangles. Used for non-grid tests such as a single spring.
    /// Springs are stably reordered by kind.
    pub fn from_parts(
        rest_positions: Vec<DVec3>,
        mass: Vec<f64>,
        pinned: Vec<bool>,
        mut springs: Vec<Spring>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Model> {
        let n = rest_positions.len();
        if n == 0 || n > MAX_PARTICLES || mass.len() != n || pinned.len() != n {
            return Err(invalid(
                "particles",
                &format!("1..={MAX_PARTICLES} particles with one mass and pin flag each"),
                format!(
                    "{n} positions, {} masses, {} pin flags",
                    mass.len(),
                    pinned.len()
                ),
            ));
        }
        if let Some(m) = mass.iter().find(|m| !(m.is_finite() && **m > 0.0)) {
            return Err(invalid("mass", "> 0 (kg) for every particle", m));
        }
        let in_range = |p: u32| (p as usize) < n;
        let bad_spring = springs.iter().any(|s| {
            !in_range(s.i) || !in_range(s.j) || s.i == s.j || s.rest.is_nan() || s.rest < 0.0
        });
        let bad_triangle = triangles.iter().any(|t| !t.iter().all(|&p| in_range(p)));
        if bad_spring || bad_triangle {
            return Err(invalid(
                "springs",
                "distinct particle indices below the particle count and rest ≥ 0",
                "an out-of-range spring or triangle",
            ));
        }
        springs.sort_by_key(|s| s.kind.index());
        let kind_ranges = SpringKind::ALL.map(|kind| {
            let start = springs.partition_point(|s| s.kind.index() < kind.index());
            let end = springs.partition_point(|s| s.kind.index() <= kind.index());
            start..end
        });
        let particle_springs = Adjacency::build(
            n,
            springs.iter().enumerate().flat_map(|(s, sp)| {
                [
                    (sp.i as usize, (s as u32) << 1),
                    (sp.j as usize, (s as u32) << 1 | 1),
                ]
            }),
        )?;
        let particle_triangles = Adjacency::build(
            n,
            triangles
                .iter()
                .enumerate()
                .flat_map(|(t, tri)| tri.map(|p| (p as usize, t as u32))),
        )?;
        Ok(Model {
            grid: None,
            rest_positions,
            mass,
            pinned,
            springs,
            kind_ranges,
            triangles,
            particle_springs,
            particle_triangles,
            own_constants: Vec::new(),
            bending: None,
            cloth_starts: vec![0],
            cloth_grids: vec![None],
        })
    }

    /// A copy, failing with [`Error::OutOfMemory`] instead of aborting
    /// when the memory is not there.
    pub fn try_clone(&self) -> Result<Model> {
        let copy = |v: &[u32]| try_collect(v.iter().copied(), MODEL);
        let adjacency = |a: &Adjacency| -> Result<Adjacency> {
            Ok(Adjacency {
                offsets: copy(&a.offsets)?,
                entries: copy(&a.entries)?,
            })
        };
        Ok(Model {
            grid: self.grid.clone(),
            rest_positions: try_collect(self.rest_positions.iter().copied(), MODEL)?,
            mass: try_collect(self.mass.iter().copied(), MODEL)?,
            pinned: try_collect(self.pinned.iter().copied(), MODEL)?,
            springs: try_collect(self.springs.iter().copied(), MODEL)?,
            kind_ranges: self.kind_ranges.clone(),
            triangles: try_collect(self.triangles.iter().copied(), MODEL)?,
            particle_springs: adjacency(&self.particle_springs)?,
            particle_triangles: adjacency(&self.particle_triangles)?,
            own_constants: try_collect(self.own_constants.iter().copied(), MODEL)?,
            bending: self.bending.clone(),
            cloth_starts: self.cloth_starts.clone(),
            cloth_grids: self.cloth_grids.clone(),
        })
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.rest_positions.len()
    }

    /// Number of pinned particles.
    pub fn pinned_count(&self) -> usize {
        self.pinned.iter().filter(|&&p| p).count()
    }

    /// The fix-up's length limit of spring `s` under `params` \[m\]: its
    /// kind's `max_stretch` times its rest length; for a seam the wider of
    /// [`SEAM_FIXUP_LIMIT`] and its sides' distance at rest; 0 (not
    /// constrained) without a `max_stretch` or without fix-up passes. Both
    /// backends take it from here.
    pub fn fixup_limit(&self, s: usize, params: &Params) -> f64 {
        let sp = &self.springs[s];
        match params.spring(sp.kind).max_stretch {
            Some(_) if params.fixup.iterations > 0 && sp.is_seam() => {
                let apart = self.rest_positions[sp.i as usize] - self.rest_positions[sp.j as usize];
                SEAM_FIXUP_LIMIT.max(apart.length())
            }
            Some(f) if params.fixup.iterations > 0 => f * sp.rest,
            _ => 0.0,
        }
    }

    /// The stiffness and damping of spring `s` under `params`: its own
    /// where the cloth is of a material, else its kind's.
    pub fn spring_constants(&self, s: usize, params: &Params) -> SpringConstants {
        self.spring_constants_of(s, &params.springs)
    }

    /// The stiffness and damping of spring `s` where the spring kinds'
    /// constants are `kinds`: its own where the cloth is of a material,
    /// else its kind's.
    pub fn spring_constants_of(&self, s: usize, kinds: &[SpringParams; 3]) -> SpringConstants {
        match self.own_constants.get(s) {
            Some(&own) => own,
            None => {
                let kind = &kinds[self.springs[s].kind.index()];
                SpringConstants {
                    k: kind.stiffness,
                    kd: kind.damping,
                }
            }
        }
    }

    /// The quad cells of a grid cloth, corners in cyclic order (none for a
    /// model that is not a grid).
    pub fn grid_cells(&self) -> Vec<[u32; 4]> {
        let Some(spec) = &self.grid else {
            return Vec::new();
        };
        let (nx, ny) = (spec.nx, spec.ny);
        let idx = |row: usize, col: usize| (row * nx + col) as u32;
        (0..ny - 1)
            .flat_map(|row| {
                (0..nx - 1).map(move |col| {
                    [
                        idx(row, col),
                        idx(row, col + 1),
                        idx(row + 1, col + 1),
                        idx(row + 1, col),
                    ]
                })
            })
            .collect()
    }

    /// The warp of a grid cloth: the unit direction along its rows (from
    /// its first particle to the second), a mesh's or a one-column grid's
    /// none.
    pub fn grid_warp(&self) -> DVec3 {
        match (&self.grid, self.rest_positions.get(..2)) {
            (Some(_), Some(&[a, b])) => (b - a).normalize_or_zero(),
            _ => DVec3::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(nx: usize, ny: usize) -> Model {
        let spec = ClothSpec {
            nx,
            ny,
            ..ClothSpec::default()
        };
        Model::new(&spec, &Params::default().springs).expect("valid spec")
    }

    #[test]
    fn spring_counts_match_the_grid_formulas() {
        let (nx, ny) = (5, 4);
        let m = model(nx, ny);
        let stretch = (nx - 1) * ny + nx * (ny - 1);
        let shear = 2 * (nx - 1) * (ny - 1);
        let bend = (nx - 2) * ny + nx * (ny - 2);
        assert_eq!(m.kind_ranges[0].len(), stretch);
        assert_eq!(m.kind_ranges[1].len(), shear);
        assert_eq!(m.kind_ranges[2].len(), bend);
        assert_eq!(m.triangles.len(), 2 * (nx - 1) * (ny - 1));
    }

    #[test]
    fn every_spring_appears_once_at_each_end() {
        let m = model(4, 6);
        let mut seen = vec![[false; 2]; m.springs.len()];
        for p in 0..m.particle_count() {
            for &e in m.particle_springs.of(p) {
                let (s, is_j) = decode_incidence(e);
                let sp = m.springs[s];
                assert_eq!(if is_j { sp.j } else { sp.i } as usize, p);
                assert!(!seen[s][is_j as usize]);
                seen[s][is_j as usize] = true;
            }
        }
        assert!(seen.iter().all(|s| s[0] && s[1]));
    }

    #[test]
    fn horizontal_triangles_face_up() {
        let m = model(3, 3);
        for t in &m.triangles {
            let [a, b, c] = t.map(|p| m.rest_positions[p as usize]);
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let ny = e1[2] * e2[0] - e1[0] * e2[2];
            assert!(ny > 0.0, "triangle {t:?} normal y = {ny}");
        }
    }

    #[test]
    fn zero_stiffness_kind_has_no_springs() {
        let mut materials = Params::default().springs;
        materials[SpringKind::Bend.index()].stiffness = 0.0;
        let m = Model::new(&ClothSpec::default(), &materials).expect("valid spec");
        assert!(m.kind_ranges[SpringKind::Bend.index()].is_empty());
        assert!(m.springs.iter().all(|s| s.kind != SpringKind::Bend));
    }

    #[test]
    fn pins_are_shown_as_the_scene_file_writes_them() {
        for name in Pin::NAMES.split(", ") {
            let pin = Pin::parse(name).expect("a documented name");
            assert_eq!(pin.to_string(), format!("\"{name}\""));
        }
        assert_eq!(Pin::Index(7).to_string(), "7");
        let region = Pin::Region([DVec3::new(-1.0, 0.5, 0.0), DVec3::new(1e300, 2.0, 1e-5)]);
        assert_eq!(
            region.to_string(),
            "{ box = [[-1, 0.5, 0], [1e300, 2, 1e-5]] }"
        );
    }

    #[test]
    fn grid_sizes_the_solvers_cannot_hold_are_refused_naming_the_size() {
        let error = |size: [f64; 2], origin: DVec3| {
            let spec = ClothSpec {
                nx: 5,
                ny: 5,
                size,
                origin,
                ..ClothSpec::default()
            };
            spec.validate().err().map(|e| e.to_string())
        };
        // The bounds themselves are allowed: 1e18 m from the origin, cells
        // of 1e-18 m where f32 numbers are that close (near 0).
        assert_eq!(error([1e18, 1e18], DVec3::ZERO), None);
        assert_eq!(error([4e-18, 4e-18], DVec3::ZERO), None);
        for (size, origin, says) in [
            ([2e18, 1.0], DVec3::ZERO, "within ±1e18 m"),
            ([1.0, 1e3], DVec3::new(0.0, 0.0, 1e18), "within ±1e18 m"),
            ([1e308, 1e308], DVec3::ZERO, "within ±1e18 m"),
            ([3.9e-18, 3.9e-18], DVec3::ZERO, "at least 1.00e-18 m"),
            // 1 m from the origin, f32 numbers are 1.2e-7 m apart.
            ([1e-7, 1.0], DVec3::new(1.0, 0.0, 0.0), "f32 spacing"),
        ] {
            let e = error(size, origin).unwrap_or_default();
            assert!(
                e.contains("`cloth.size`") && e.contains(says),
                "{size:?}: {e}"
            );
        }
        let e = error([1.0, 1.0], DVec3::new(1e300, 0.0, 0.0)).unwrap_or_default();
        assert!(e.contains("`cloth.origin[0]`"), "{e}");
    }

    #[test]
    fn corner_and_edge_pins_select_the_documented_particles() {
        let spec = ClothSpec {
            nx: 4,
            ny: 3,
            ..ClothSpec::default()
        };
        assert_eq!(spec.pin_indices(Pin::Corner(Corner::BottomRight)), vec![11]);
        assert_eq!(spec.pin_indices(Pin::Edge(Edge::Left)), vec![0, 4, 8]);
        assert_eq!(
            spec.pin_indices(Pin::Edge(Edge::Bottom)),
            vec![8, 9, 10, 11]
        );
    }
}
