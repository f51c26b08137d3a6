//! What both backends decide alike of self-collision: the thickness a
//! model may take and its default, the constants of the method, and its
//! settings in a solver's precision ([`SelfCollisionR`]: the CPU
//! reference steps with them, the GPU uploads them). The method itself,
//! and the CPU twin of its kernels, is [`crate::cpu::self_collision`].

use crate::error::{Error, Result};
use crate::model::{Adjacency, Model};
use crate::params::{format_number, ContactMethod, Params, SelfCollision, SpringKind};
use crate::real::{Real, Vec3};

/// Pairs closer than this many thicknesses at rest never collide: see
/// [`crate::cpu::self_collision`]'s "Exclusion".
pub const EXCLUDE_REST: f64 = 2.0;

/// The largest displacement of a particle over a step, in thicknesses:
/// two particles approach by at most one thickness per step (see
/// [`crate::cpu::self_collision`]'s "Tunnelling guard").
pub const STEP_CAP: f64 = 0.5;

/// The largest thickness, in default thicknesses: beyond, the exclusion
/// radius ([`EXCLUDE_REST`] thicknesses) spans more than eight rest
/// spacings, so tight folds go unseen, and each grid cell holds tens of
/// particles of one layer (the cost grows with its square).
pub const MAX_THICKNESS_DEFAULTS: f64 = 4.0;

/// How far (relative) a `self_collision.thickness` may pass its bounds:
/// the bounds come from rest positions (a 0.3 m cloth of 4 × 4 particles
/// has its spacing computed as 0.09999999999999998 m, its largest
/// thickness 0.3999999999999999 m), a few ulps (1e-16) off the round
/// value a user reads in the docs and writes (0.4); 1e-9 admits that
/// rounding and no thickness anyone means differently.
pub const THICKNESS_BOUND_TOLERANCE: f64 = 1e-9;

/// The grid's cell size in thicknesses: a little over two, so that every
/// point within a thickness of a particle lies in the 2 × 2 × 2 cells its
/// respond visits however the cell's inverse size is rounded — 8 bucket
/// look-ups per particle and pass where cells one thickness wide need 27,
/// for about four times the particles per cell of a flat layer.
pub const CELL_THICKNESSES: f64 = 2.0 * (1.0 + 1e-4);

/// The thinnest `self_collision.thickness` the triangle method takes \[m\]:
/// half a millimetre, a thin shirting's two halves (a contact's thickness
/// is both layers' half-thickness together); `f32` positions a few metres
/// from the origin round to well under a micrometre, so a layer this thin
/// is still a thousand roundings wide.
pub const MIN_THICKNESS: f64 = 5e-4;

/// The triangle method's default thickness \[m\]: 2 mm, a medium woven
/// fabric's (a cotton twill or a light denim is 0.5–1 mm thick, and two
/// layers of it in contact keep their mid-surfaces that far apart,
/// give or take the hairiness of their faces).
pub const DEFAULT_TRIANGLE_THICKNESS: f64 = 2e-3;

/// The triangle method's bound, as a fraction of the distance from a
/// vertex's primitives to the nearest primitive they are not adjacent to
/// (see [`crate::cpu::triangle_contact`]'s "No crossing"): below one half,
/// so that two primitives whose vertices all move less than this fraction
/// of their distance close at most `2 × 0.45 = 0.9` of it and never meet;
/// the 0.05 left is what keeps the next step's pairs apart by a twentieth
/// of their distance.
pub const BOUND_FRACTION: f64 = 0.45;

/// Self-collision in the solver's precision, with what the model fixes.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct SelfCollisionR<R> {
    /// Distance two layers keep \[m\].
    pub thickness: R,
    /// Coulomb friction coefficient between layers.
    pub friction: R,
    /// Jacobi passes per step.
    pub iterations: u32,
    /// Largest displacement per step relative to the reference particle's
    /// \[m\]: `STEP_CAP × thickness`.
    pub cap: R,
    /// The reference particle of the cap ([`reference_particle`]).
    pub reference: usize,
    /// The inverse of the cell size \[1/m\]: `1 / (CELL_THICKNESSES ×
    /// thickness)`.
    pub inv_cell: R,
    /// Rest positions in units of the exclusion radius
    /// (`EXCLUDE_REST × thickness`), the cloths laid apart: a pair less
    /// than 1 apart never collides ([`crate::cpu::self_collision::excluded`]).
    pub rest: Vec<Vec3<R>>,
    /// Each particle's seam partner's `rest` (its own where it is on no
    /// seam; see [`crate::world::ExclusionRest`]).
    pub seam_rest: Vec<Vec3<R>>,
    /// Hash table size (a power of two ≥ particles, at least 2).
    pub table: usize,
    /// The triangle method's primitives, `None` for the particle method:
    /// the CPU solver sets them (the only solver with the method), so that
    /// their allocation's failure is its error.
    pub triangles: Option<TriangleTopology<R>>,
}

/// What the triangle method ([`crate::cpu::triangle_contact`]) knows of a
/// model: its edges and which end at each vertex, the seam partners and
/// the rest positions its exclusion compares.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct TriangleTopology<R> {
    /// The mesh edges (of the triangles), each `[low, high]`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// Per vertex, the edges it ends.
    pub vertex_edges: Adjacency,
    /// Each vertex's seam partner ([`crate::world::seam_partners`]): the two
    /// count as one vertex, so a seam's two sides are adjacent.
    pub partner: Vec<u32>,
    /// Rest positions \[m\], the cloths laid apart
    /// ([`crate::world::exclusion_rest`]): a pair nearer than a thickness
    /// there touches at rest and never collides.
    pub rest: Vec<Vec3<R>>,
    /// The query radius \[m\]: the thickness and the largest rest triangle
    /// gap ([`triangle_gap`]). Pairs within it at the step's start are the
    /// candidates, and it caps each vertex's bound.
    pub query: R,
    /// Each edge's box at rest \[m\] (in `rest`), lowest and highest
    /// corner: pairs whose boxes lie a thickness apart along an axis do not
    /// touch at rest, without measuring.
    pub edge_rest_boxes: Vec<(Vec3<R>, Vec3<R>)>,
    /// Each triangle's box at rest \[m\], as `edge_rest_boxes`.
    pub triangle_rest_boxes: Vec<(Vec3<R>, Vec3<R>)>,
}

/// The box of points `corners` of `x`: lowest and highest corner.
pub(crate) fn box_of<R: Real>(x: &[Vec3<R>], corners: &[u32]) -> (Vec3<R>, Vec3<R>) {
    let first = x[corners[0] as usize];
    corners[1..].iter().fold((first, first), |(lo, hi), &i| {
        (lo.min(x[i as usize]), hi.max(x[i as usize]))
    })
}

/// Whether boxes `a` and `b` lie at least `gap` apart along an axis (so
/// every two of their points do).
pub(crate) fn boxes_apart<R: Real>(a: (Vec3<R>, Vec3<R>), b: (Vec3<R>, Vec3<R>), gap: R) -> bool {
    (0..3).any(|k| b.0.get(k) - a.1.get(k) >= gap || a.0.get(k) - b.1.get(k) >= gap)
}

impl<R: Real> TriangleTopology<R> {
    /// The topology of `model`, its query radius for `thickness` \[m\].
    pub fn new(model: &Model, thickness: f64) -> Result<Self> {
        let n = model.particle_count();
        let mut edges: Vec<[u32; 2]> = model
            .triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let ends = edges
            .iter()
            .enumerate()
            .flat_map(|(e, &[a, b])| [(a as usize, e as u32), (b as usize, e as u32)]);
        let vertex_edges = Adjacency::build(n, ends)?;
        let rest: Vec<Vec3<R>> = crate::world::exclusion_rest(model, 1.0)
            .own
            .into_iter()
            .map(Vec3::from_f64)
            .collect();
        let edge_rest_boxes = edges.iter().map(|e| box_of(&rest, e)).collect();
        let triangle_rest_boxes = model.triangles.iter().map(|t| box_of(&rest, t)).collect();
        Ok(TriangleTopology {
            edge_rest_boxes,
            triangle_rest_boxes,
            edges,
            vertex_edges,
            partner: crate::world::seam_partners(model)
                .into_iter()
                .map(|p| p as u32)
                .collect(),
            rest,
            query: R::from_f64(thickness + triangle_gap(model)),
        })
    }
}

/// The hash table size for `particles`: the power of two at least the
/// count (and at least 2: the GPU keeps two buckets' runs per entry), so
/// that most buckets hold at most one cell. Which bucket a cell falls in
/// changes no result: a run's other cells are skipped.
pub fn table_size(particles: usize) -> usize {
    particles.max(2).next_power_of_two()
}

/// The shortest rest length \[m\] of a stretch spring (of any spring if
/// the model has no stretch springs); `None` without springs.
fn rest_spacing(model: &Model) -> Option<f64> {
    let stretch = &model.springs[model.kind_ranges[SpringKind::Stretch.index()].clone()];
    let springs = if stretch.is_empty() {
        &model.springs[..]
    } else {
        stretch
    };
    springs
        .iter()
        .map(|s| s.rest)
        .filter(|r| *r > 0.0)
        .min_by(f64::total_cmp)
}

/// The largest in-plane gap \[m\] of the rest triangles: the farthest a
/// point of a triangle lies from its nearest corner — the circumradius of
/// a triangle without an obtuse angle, half the longest edge (a lower
/// bound) of an obtuse one. A particle whose thickness is below it can
/// pass through the triangle's middle untouched.
pub fn triangle_gap(model: &Model) -> f64 {
    let x = &model.rest_positions;
    let mut gap: f64 = 0.0;
    for t in &model.triangles {
        let [a, b, c] = t.map(|i| x[i as usize]);
        let mut e2 = [
            (b - c).length_squared(),
            (c - a).length_squared(),
            (a - b).length_squared(),
        ];
        e2.sort_by(f64::total_cmp);
        let g = if e2[2] > e2[0] + e2[1] {
            0.5 * e2[2].sqrt()
        } else {
            let area2 = (b - a).cross(c - a).length();
            if area2 > 0.0 {
                (e2[0] * e2[1] * e2[2]).sqrt() / (2.0 * area2)
            } else {
                0.5 * e2[2].sqrt()
            }
        };
        gap = gap.max(g);
    }
    gap
}

/// The default thickness \[m\]: the cloth's rest spacing (the shortest
/// stretch spring), or the largest triangle gap where that is larger, so
/// that no particle slips through a rest triangle.
pub fn default_thickness(model: &Model) -> Option<f64> {
    rest_spacing(model).map(|h| h.max(triangle_gap(model)))
}

/// The thickness \[m\] `params` give `model`, checked against it: at least
/// the largest triangle gap ([`triangle_gap`]; a thinner one lets particles
/// through the cloth) and at most [`MAX_THICKNESS_DEFAULTS`] default
/// thicknesses. `Ok(None)` without self-collision. The error names
/// `self_collision.thickness` and what this model allows.
pub fn thickness(model: &Model, params: &Params) -> Result<Option<f64>> {
    let Some(c) = &params.self_collision else {
        return Ok(None);
    };
    let key = "self_collision.thickness";
    let Some(default) = default_thickness(model) else {
        return Err(Error::InvalidParameter {
            key: "self_collision".into(),
            allowed: "a cloth with springs (the thickness derives from their rest lengths)".into(),
            got: "a cloth without springs".into(),
        });
    };
    if c.method == ContactMethod::Triangles {
        return triangle_thickness(model, c, default).map(Some);
    }
    let Some(t) = c.thickness else {
        return Ok(Some(default));
    };
    let (low, high) = (triangle_gap(model), MAX_THICKNESS_DEFAULTS * default);
    let slack = 1.0 + THICKNESS_BOUND_TOLERANCE;
    if t * slack < low || t > high * slack {
        return Err(Error::InvalidParameter {
            key: key.into(),
            allowed: format!(
                "{} ≤ thickness ≤ {} (m, each to {} relative) for this cloth: at least its \
                 largest rest triangle's gap (a particle slips through a thinner one), at most \
                 {} × the default {} (the rest spacing)",
                format_number(low),
                format_number(high),
                format_number(THICKNESS_BOUND_TOLERANCE),
                MAX_THICKNESS_DEFAULTS,
                format_number(default)
            ),
            got: format_number(t),
        });
    }
    Ok(Some(t))
}

/// Refuses what the GPU solvers cannot run yet: the triangle method
/// (`method = "triangles"`), which only the CPU solvers have, so far.
pub fn check_gpu(params: &Params) -> Result<()> {
    match &params.self_collision {
        Some(c) if c.method == ContactMethod::Triangles => Err(Error::InvalidParameter {
            key: "self_collision.method".into(),
            allowed: "\"particles\" on the GPU backends (\"triangles\" runs on the CPU \
                      backend, `--backend cpu` in either `--precision`, so far)"
                .into(),
            got: "\"triangles\"".into(),
        }),
        _ => Ok(()),
    }
}

/// The triangle method's thickness \[m\] (`c.thickness` or
/// [`DEFAULT_TRIANGLE_THICKNESS`], at most `high`): any from
/// [`MIN_THICKNESS`] up to [`MAX_THICKNESS_DEFAULTS`] × the particle
/// method's default `default` (beyond, the search reaches over more than a
/// few rest spacings); the model needs triangles.
fn triangle_thickness(model: &Model, c: &SelfCollision, default: f64) -> Result<f64> {
    if model.triangles.is_empty() {
        return Err(Error::InvalidParameter {
            key: "self_collision.method".into(),
            allowed: "\"particles\" for a cloth without triangles (\"triangles\" contacts them)"
                .into(),
            got: "\"triangles\"".into(),
        });
    }
    let high = MAX_THICKNESS_DEFAULTS * default;
    let Some(t) = c.thickness else {
        return Ok(DEFAULT_TRIANGLE_THICKNESS.min(high));
    };
    let slack = 1.0 + THICKNESS_BOUND_TOLERANCE;
    if t * slack < MIN_THICKNESS || t > high * slack {
        return Err(Error::InvalidParameter {
            key: "self_collision.thickness".into(),
            allowed: format!(
                "{} ≤ thickness ≤ {} (m) for this cloth with method = \"triangles\": at least \
                 half a millimetre, at most {} × its rest spacing {}",
                format_number(MIN_THICKNESS),
                format_number(high),
                MAX_THICKNESS_DEFAULTS,
                format_number(default)
            ),
            got: format_number(t),
        });
    }
    Ok(t)
}

impl<R: Real> SelfCollisionR<R> {
    /// Self-collision of `model` under `params`, at the thickness they give
    /// it (the default where theirs is out of range: a solver refuses that
    /// first, see [`thickness`]); `None` without self-collision or springs.
    pub fn of(model: &Model, params: &Params) -> Option<Self> {
        let c = params.self_collision.as_ref()?;
        let t = thickness(model, params)
            .ok()
            .flatten()
            .or_else(|| default_thickness(model))?;
        Some(SelfCollisionR::new(model, c, t))
    }

    /// Self-collision of `model` with `c` at `thickness` \[m\].
    pub fn new(model: &Model, c: &SelfCollision, thickness: f64) -> Self {
        let exclusion = crate::world::exclusion_rest(model, EXCLUDE_REST * thickness);
        let convert = |v: Vec<glam::DVec3>| v.into_iter().map(Vec3::from_f64).collect();
        SelfCollisionR {
            thickness: R::from_f64(thickness),
            friction: R::from_f64(c.friction),
            iterations: c.iterations,
            cap: R::from_f64(STEP_CAP * thickness),
            reference: reference_particle(model),
            inv_cell: R::from_f64(1.0 / (CELL_THICKNESSES * thickness)),
            rest: convert(exclusion.own),
            seam_rest: convert(exclusion.seam),
            table: table_size(model.particle_count()),
            triangles: None,
        }
    }
}

/// The particle whose displacement the cap is relative to: the free
/// particle nearest the rest positions' centroid, which moves with the
/// cloth as a whole (falling, or carried by its pins: a pinned particle
/// would not do, as the explicit and semi-implicit steps move the pins
/// after self-collision); 0 for a cloth without a free particle.
pub fn reference_particle(model: &Model) -> usize {
    let x = &model.rest_positions;
    let centroid = x.iter().copied().sum::<glam::DVec3>() / (x.len().max(1) as f64);
    (0..x.len())
        .filter(|&p| !model.pinned[p])
        .min_by(|&a, &b| {
            (x[a] - centroid)
                .length_squared()
                .total_cmp(&(x[b] - centroid).length_squared())
        })
        .unwrap_or(0)
}
