//! A world of several cloths as one model.
//!
//! The world, not the cloth, owns a step: its cloths share one index
//! space — cloth 0's particles first, then cloth 1's, and so on, each
//! cloth's springs and triangles renumbered to match — so every solver,
//! kernel and batch steps a world exactly as it steps one cloth (a spring
//! graph with several components is still a spring graph). What the
//! cloths do not share they carry per spring: each spring's own stiffness
//! and damping. A world of one cloth is that cloth's model, unchanged.
//!
//! A **seam** joins a particle of one cloth to a particle of another (or
//! of the same cloth: a tube) as a spring of zero rest length: a stretch
//! spring whose force `−k d` is linear in the ends' separation `d`, so the
//! implicit system holds it exactly, Desbrun's constant filter carries it
//! exactly as `k I`, and the explicit step treats it as any spring.
//!
//! Contact between cloths is self-collision over the world: the grid and
//! the Jacobi passes already see every particle. Only its exclusion rule
//! (pairs near each other at rest never collide) needs the cloths: the
//! rest positions it compares are laid out cloth by cloth, apart, so two
//! cloths that start close still collide, and a particle on a seam is
//! also compared at its partner's, so a seam's two sides, which touch
//! once sewn, do not ([`exclusion_rest`]).

use std::ops::Range;

use glam::DVec3;

use crate::bending::Bending;
use crate::budget::{self, try_vec, try_with_capacity};
use crate::error::{Error, Result};
use crate::model::{Model, Spring, SpringConstants};
use crate::params::{SpringKind, SpringParams};

/// What the world's allocations are named in a memory error.
const WORLD: &str = "the world's model";

/// A seam's spring: particles `a` and `b` of the world held together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeamSpring {
    /// One end, a world particle index.
    pub a: u32,
    /// The other end.
    pub b: u32,
    /// Stiffness \[N/m\]; `None`: the stiffest stretch spring at either end
    /// (the seam holds as firmly as the fabric it joins).
    pub stiffness: Option<f64>,
    /// Damping \[N·s/m\]; `None`: the largest of the same springs'.
    pub damping: Option<f64>,
}

/// The world of `cloths` (each model with the spring kinds its springs
/// take where it has no constants of its own) joined by `seams` (world
/// particle indices); `world`: the kinds a solver's parameters give. One
/// cloth without seams whose springs take the world's kinds (or their
/// own constants) is returned as it is.
/// Refuses materials of different bending damping (the operator has one)
/// and seams whose ends are out of range or the same particle.
pub fn join(
    mut cloths: Vec<(Model, [SpringParams; 3])>,
    world: &[SpringParams; 3],
    seams: &[SeamSpring],
) -> Result<Model> {
    let as_world = |kinds: &[SpringParams; 3]| {
        (0..3).all(|k| {
            (kinds[k].stiffness, kinds[k].damping) == (world[k].stiffness, world[k].damping)
        })
    };
    if let ([(model, kinds)], true) = (&cloths[..], seams.is_empty()) {
        if !model.own_constants.is_empty() || as_world(kinds) {
            if let Some((model, _)) = cloths.pop() {
                return Ok(model);
            }
        }
    }
    let total: usize = cloths.iter().map(|(m, _)| m.particle_count()).sum();
    let springs = cloths.iter().map(|(m, _)| m.springs.len()).sum::<usize>() + seams.len();
    let triangle_count: usize = cloths.iter().map(|(m, _)| m.triangles.len()).sum();
    budget::check_host(
        budget::model_bytes(total as u64, springs as u64, triangle_count as u64),
        || {
            format!(
                "the world's model ({} cloths, {total} particles)",
                cloths.len()
            )
        },
    )?;
    let mut starts = try_with_capacity(cloths.len(), WORLD)?;
    // Each cloth's grid (a world given as a cloth has none).
    let mut grids = try_with_capacity(cloths.len(), WORLD)?;
    let mut rest = try_with_capacity(total, WORLD)?;
    let mut mass = try_with_capacity(total, WORLD)?;
    let mut pinned = try_with_capacity(total, WORLD)?;
    let mut triangles = try_with_capacity(triangle_count, WORLD)?;
    // Springs in kind order, each with its constants.
    let mut by_kind: [Vec<(Spring, SpringConstants)>; 3] = Default::default();
    for (model, kinds) in &cloths {
        let base = rest.len() as u32;
        starts.push(base);
        grids.push(match &model.cloth_grids[..] {
            [grid] if model.cloth_starts.len() == 1 => *grid,
            _ => None,
        });
        rest.extend_from_slice(&model.rest_positions);
        mass.extend_from_slice(&model.mass);
        pinned.extend_from_slice(&model.pinned);
        triangles.extend(model.triangles.iter().map(|t| t.map(|p| p + base)));
        for (s, sp) in model.springs.iter().enumerate() {
            let constants = model.spring_constants_of(s, kinds);
            let moved = Spring {
                i: sp.i + base,
                j: sp.j + base,
                ..*sp
            };
            by_kind[sp.kind.index()].push((moved, constants));
        }
    }
    // Each particle's stiffest stretch constants, which a seam at it takes
    // by default: one pass over the springs, not one per seam.
    let mut fabric = try_vec(total, SpringConstants { k: 0.0, kd: 0.0 }, WORLD)?;
    for (sp, c) in &by_kind[SpringKind::Stretch.index()] {
        for p in [sp.i as usize, sp.j as usize] {
            let f = &mut fabric[p];
            (f.k, f.kd) = (f.k.max(c.k), f.kd.max(c.kd));
        }
    }
    for (n, seam) in seams.iter().enumerate() {
        let (a, b) = (seam.a as usize, seam.b as usize);
        if a >= total || b >= total || a == b {
            return Err(Error::InvalidParameter {
                key: format!("seam[{n}]"),
                allowed: format!("two distinct particles of the world's {total}"),
                got: format!("particles {a} and {b}"),
            });
        }
        let fabric = SpringConstants {
            k: fabric[a].k.max(fabric[b].k),
            kd: fabric[a].kd.max(fabric[b].kd),
        };
        let spring = Spring {
            i: seam.a,
            j: seam.b,
            rest: 0.0,
            kind: SpringKind::Stretch,
        };
        let constants = SpringConstants {
            k: seam.stiffness.unwrap_or(fabric.k),
            kd: seam.damping.unwrap_or(fabric.kd),
        };
        by_kind[SpringKind::Stretch.index()].push((spring, constants));
    }
    let bending = join_bending(&cloths, total)?;
    let (springs, constants): (Vec<Spring>, Vec<SpringConstants>) =
        by_kind.into_iter().flatten().unzip();
    let mut model = Model::from_parts(rest, mass, pinned, springs, triangles)?;
    // `from_parts` reorders springs by kind stably: they already are.
    model.own_constants = constants;
    model.bending = bending;
    model.cloth_starts = starts;
    model.cloth_grids = grids;
    Ok(model)
}

/// The cloths' bending operators as one (empty rows for a cloth without
/// one); `None` where no cloth has one.
fn join_bending(cloths: &[(Model, [SpringParams; 3])], total: usize) -> Result<Option<Bending>> {
    let mut damping = None;
    for (model, _) in cloths {
        if let Some(b) = &model.bending {
            match damping {
                Some(d) if d != b.damping => {
                    return Err(Error::InvalidParameter {
                        key: "material.damping".into(),
                        allowed: "one value for every cloth of the world that has a bending \
                                  stiffness (the bending operator has one damping time)"
                            .into(),
                        got: format!("{d} and {}", b.damping),
                    })
                }
                _ => damping = Some(b.damping),
            }
        }
    }
    let Some(damping) = damping else {
        return Ok(None);
    };
    let mut offsets = Vec::with_capacity(total + 1);
    offsets.push(0u32);
    let (mut columns, mut coefficients) = (Vec::new(), Vec::new());
    let mut base = 0u32;
    for (model, _) in cloths {
        let n = model.particle_count();
        for p in 0..n {
            if let Some(b) = &model.bending {
                let (cols, q) = b.row(p);
                columns.extend(cols.iter().map(|&j| j + base));
                coefficients.extend_from_slice(q);
            }
            offsets.push(columns.len() as u32);
        }
        base += n as u32;
    }
    Ok(Some(Bending {
        offsets,
        columns,
        coefficients,
        damping,
    }))
}

/// The particle range of each cloth of `model`, in order.
pub fn cloth_ranges(model: &Model) -> Vec<Range<usize>> {
    let n = model.particle_count();
    let starts = &model.cloth_starts;
    (0..starts.len())
        .map(|c| starts[c] as usize..starts.get(c + 1).map_or(n, |&e| e as usize))
        .collect()
}

/// The positions self-collision's exclusion compares, in units of the
/// exclusion radius: particles `p` and `q` never collide where `own[p]`
/// and `own[q]`, `seam[p]` and `own[q]`, or `own[p]` and `seam[q]` lie
/// less than 1 apart (`cpu::self_collision::excluded`; the same three
/// tests from either end, as the differences negate exactly, so both of a
/// pair agree).
#[derive(Clone, Debug, PartialEq)]
pub struct ExclusionRest {
    /// Each particle's rest position, the cloths laid side by side along x
    /// two units apart (the first where it is), so that particles of
    /// different cloths are never excluded however close they start.
    pub own: Vec<DVec3>,
    /// Each particle's seam partner's `own` (the other end of the first
    /// seam it is on), its own `own` where it is on no seam: a seam's two
    /// sides, and each side's neighbours within the radius of the other,
    /// touch when sewn, so they are excluded as a cloth's neighbours are.
    pub seam: Vec<DVec3>,
}

/// Self-collision's exclusion positions of `model` in units of `radius`
/// \[m\] (see [`ExclusionRest`]). A seam is a stretch spring of zero rest
/// length (see the module's "seam").
pub fn exclusion_rest(model: &Model, radius: f64) -> ExclusionRest {
    let x = &model.rest_positions;
    let ranges = cloth_ranges(model);
    let mut own = Vec::with_capacity(x.len());
    // Where the next cloth's lowest x goes (the first stays where it is).
    let mut at = None;
    for r in ranges {
        let cloth = &x[r];
        let low = cloth.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let high = cloth.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        let shift = at.map_or(0.0, |a| a - low);
        own.extend(cloth.iter().map(|&p| (p + DVec3::X * shift) / radius));
        // Two units past this cloth's far side.
        at = Some(high + shift + 2.0 * radius);
    }
    let partner = seam_partners(model);
    let seam = (0..x.len()).map(|p| own[partner[p]]).collect();
    ExclusionRest { own, seam }
}

/// Each particle's seam partner: the other end of the first seam it is on,
/// itself where it is on no seam.
pub fn seam_partners(model: &Model) -> Vec<usize> {
    let mut partner: Vec<usize> = (0..model.particle_count()).collect();
    let stretch = &model.springs[model.kind_ranges[SpringKind::Stretch.index()].clone()];
    for s in stretch.iter().filter(|s| s.is_seam()) {
        let (i, j) = (s.i as usize, s.j as usize);
        if partner[i] == i {
            partner[i] = j;
        }
        if partner[j] == j {
            partner[j] = i;
        }
    }
    partner
}
