//! Self-collision: particle–particle contact between parts of one cloth
//! that are not neighbours at rest, deterministic and gather-only.
//!
//! Each step, once the integrator has predicted the positions (explicit
//! and semi-implicit: after the fix-up; implicit: after `x += dt v`), and
//! before the colliders:
//!
//! 1. **Build** a uniform spatial hash grid of cells a little over two
//!    thicknesses wide ([`CELL_THICKNESSES`](crate::self_collision::CELL_THICKNESSES)): each particle's integer cell is hashed
//!    into a table of a power-of-two size at least the particle count; the
//!    particles are counted per bucket, the counts prefix-summed, and the
//!    particles scattered so that each bucket's run lists its particles in
//!    index order. The GPU (`self_collision_count`, `_scan`, `_scatter`,
//!    `_rank`) counts with integer atomics, scatters in whatever order
//!    they leave, then ranks each particle among its bucket's particles of
//!    lower index: the same runs, whatever the scheduling.
//! 2. **Respond**, `iterations` Jacobi passes: each free particle `p`
//!    visits the 2 × 2 × 2 cells that hold every point within a thickness
//!    of where it was at the build (along each axis its own cell and the
//!    neighbour on the side of the cell's nearer face: a cell two
//!    thicknesses wide has a particle at least a thickness from its
//!    farther face), in a fixed order, and, for every
//!    other particle `q` in that cell (index order; a hash collision that
//!    puts another cell's particles in the bucket is skipped by comparing
//!    cells), closer than `thickness` and not excluded, takes its share
//!    `w_p / (w_p + w_q)` (inverse masses) of the push
//!    `(thickness − d) n` that separates them, and of the Coulomb friction
//!    that removes their relative tangential displacement over the step,
//!    capped by `friction ×` its normal push. A particle moves by the sum
//!    of its contacts' pushes less the mean of their friction corrections,
//!    and writes only itself: no float atomics, no order that depends on
//!    scheduling. The sum of the pushes: a particle between layers pressed
//!    from both sides needs every push, where the average undoes part of
//!    each. The mean of the friction: each contact's takes at most its
//!    share of that pair's slide, so their mean never carries the particle
//!    past the particles it slides against — friction only ever removes
//!    relative motion, at any `friction` — where their sum over several
//!    contacts sliding alike would reverse the slide and add energy.
//! 3. **Exclusion**: a pair whose *rest* distance is below
//!    [`EXCLUDE_REST`](crate::self_collision::EXCLUDE_REST) `× thickness` never collides (the rest positions
//!    are kept in units of that radius, so the test is `|Δ|² < 1`). Rest distance rather
//!    than mesh rings because it needs no per-particle list (one rest
//!    position per particle) and is the same rule on grids and meshes; the
//!    factor 2 keeps a cloth's own in-plane neighbours (compressed as it
//!    buckles) from pushing one another apart unless it is compressed to
//!    half its rest size. A particle on a seam is also compared at its
//!    seam partner's rest position ([`excluded`]), so a seam's two sides,
//!    which the seam holds together, do not push each other apart.
//! 4. **Tunnelling guard**: at the end, each free particle's displacement
//!    over the step *relative to a reference particle's* (see
//!    [`reference_particle`](crate::self_collision::reference_particle)) is capped at
//!    [`STEP_CAP`](crate::self_collision::STEP_CAP) `× thickness`, so
//!    two free particles close the distance between them by at most one
//!    thickness per step (their displacements differ by at most twice the
//!    cap): a pair found at least a thickness apart can meet but not pass
//!    through each other. Relative, so that a cloth carried along (by a
//!    running character's pins, or falling as a whole) is not slowed: only
//!    its parts' motion against one another is limited, to
//!    `thickness / (2 dt)`.
//!
//! The explicit and semi-implicit steps rebuild `v = Δx / dt` after it (as
//! after the fix-up); the implicit one adds `Δx / dt` of the projection to
//! `v`.

use super::{State, System, Workspace};
use crate::budget::try_vec;
use crate::error::Result;
use crate::real::{Real, Vec3};
use crate::self_collision::SelfCollisionR;

const HASH: [u32; 3] = crate::kernel_config::SELF_COLLISION_HASH;

/// The grid and scratch of self-collision, allocated once per solver.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Grid<R> {
    /// Each particle's cell at the build.
    pub cell: Vec<[i32; 3]>,
    /// The lowest of the 2 × 2 × 2 cells each particle visits.
    pub corner: Vec<[i32; 3]>,
    /// Per bucket, the start of its run in `order`; `table + 1` entries.
    pub start: Vec<u32>,
    /// The particles, bucket by bucket, each run in index order.
    pub order: Vec<u32>,
    /// The positions a pass reads (its Jacobi snapshot).
    pub snapshot: Vec<Vec3<R>>,
    /// The implicit step's positions before the projection.
    pub before: Vec<Vec3<R>>,
}

impl<R: Real> Grid<R> {
    /// A grid for `particles` particles in a table of `table` buckets.
    pub fn new(particles: usize, table: usize) -> Result<Self> {
        const WHAT: &str = "the self-collision grid";
        Ok(Grid {
            cell: try_vec(particles, [0; 3], WHAT)?,
            corner: try_vec(particles, [0; 3], WHAT)?,
            start: try_vec(table.saturating_add(1), 0, WHAT)?,
            order: try_vec(particles, 0, WHAT)?,
            snapshot: try_vec(particles, Vec3::ZERO, WHAT)?,
            before: try_vec(particles, Vec3::ZERO, WHAT)?,
        })
    }
}

/// The cell of a point at `x` in a grid of inverse cell size `inv`, and
/// the lowest corner of the 2 × 2 × 2 cells its respond visits: per axis
/// its own cell less one where it lies in the cell's lower half (twin of
/// `sc_cell` and `sc_corner`: the product rounded in `R`, floored exactly,
/// the fraction `s − floor(s)` exact; saturating at `i32`'s range).
fn cell_of<R: Real>(x: Vec3<R>, inv: R) -> ([i32; 3], [i32; 3]) {
    let s = [0, 1, 2].map(|k| (x.get(k) * inv).to_f64());
    let cell = s.map(|s| s.floor() as i32);
    let corner = [0, 1, 2].map(|k| cell[k].wrapping_sub(i32::from(s[k] - s[k].floor() < 0.5)));
    (cell, corner)
}

/// The bucket of cell `c` in a table of `table` (a power of two) buckets
/// (twin: `sc_bucket`).
pub fn bucket(c: [i32; 3], table: usize) -> usize {
    let h = (c[0] as u32).wrapping_mul(HASH[0])
        ^ (c[1] as u32).wrapping_mul(HASH[1])
        ^ (c[2] as u32).wrapping_mul(HASH[2]);
    (h as usize) & (table - 1)
}

/// Twin of `self_collision_build`: counts the particles per bucket,
/// prefix-sums the counts into `start` and scatters the particles into
/// `order`, each bucket's run in index order.
pub fn build<R: Real>(c: &SelfCollisionR<R>, x: &[Vec3<R>], g: &mut Grid<R>) {
    g.start.fill(0);
    for (p, &xp) in x.iter().enumerate() {
        (g.cell[p], g.corner[p]) = cell_of(xp, c.inv_cell);
        g.start[bucket(g.cell[p], c.table) + 1] += 1;
    }
    for b in 0..c.table {
        g.start[b + 1] += g.start[b];
    }
    // Filled in particle order, so each run is in index order; `start[b]`
    // walks to the run's end and is then restored from its neighbour.
    for p in 0..x.len() {
        let b = bucket(g.cell[p], c.table);
        g.order[g.start[b] as usize] = p as u32;
        g.start[b] += 1;
    }
    for b in (1..=c.table).rev() {
        g.start[b] = g.start[b - 1];
    }
    g.start[0] = 0;
}

/// Whether particles `p` and `q` never collide (twin: `sc_excluded`):
/// their rest positions, or either's seam partner's and the other's, less
/// than an exclusion radius apart (see [`crate::world::ExclusionRest`]).
pub fn excluded<R: Real>(c: &SelfCollisionR<R>, p: usize, q: usize) -> bool {
    let near = |a: Vec3<R>, b: Vec3<R>| (a - b).length_squared() < R::ONE;
    near(c.rest[p], c.rest[q]) || near(c.seam_rest[p], c.rest[q]) || near(c.rest[p], c.seam_rest[q])
}

/// The 8 cell offsets from a particle's corner cell in the order every
/// particle visits them: x fastest, then y, then z.
const NEIGHBOUR_CELLS: [[i32; 3]; 8] = {
    let mut cells = [[0; 3]; 8];
    let mut k = 0;
    while k < 8 {
        cells[k] = [(k & 1) as i32, (k >> 1 & 1) as i32, (k >> 2) as i32];
        k += 1;
    }
    cells
};

/// The contacts of particle `p` in a pass ([`pass`] without the cap): its
/// new position from the snapshot `g.snapshot`, the step's start `x_old`
/// and the grid. `None` when it has no contact.
pub fn respond<R: Real>(
    sys: &System<R>,
    c: &SelfCollisionR<R>,
    g: &Grid<R>,
    x_old: &[Vec3<R>],
    p: usize,
) -> Option<Vec3<R>> {
    let wp = sys.inv_mass[p];
    if wp <= R::ZERO {
        return None;
    }
    let xp = g.snapshot[p];
    let t2 = c.thickness * c.thickness;
    let mut sum = Vec3::ZERO;
    let mut slip = Vec3::ZERO;
    let mut contacts = 0u32;
    let home = g.corner[p];
    for d in NEIGHBOUR_CELLS {
        // Wrapping, as the GPU's `i32` sum: only a cell at the edge of the
        // range (a blown-up position) wraps, and the distance test then
        // rejects what it finds.
        let cell = [0, 1, 2].map(|k| home[k].wrapping_add(d[k]));
        let b = bucket(cell, c.table);
        for &q in &g.order[g.start[b] as usize..g.start[b + 1] as usize] {
            let q = q as usize;
            if q == p || g.cell[q] != cell {
                continue;
            }
            let diff = xp - g.snapshot[q];
            let d2 = diff.length_squared();
            if d2 >= t2 || d2 <= R::ZERO || excluded(c, p, q) {
                continue;
            }
            let dist = d2.sqrt();
            let n = diff / dist;
            let share = wp / (wp + sys.inv_mass[q]);
            let push = (c.thickness - dist) * share;
            sum += n * push;
            let rel = (xp - x_old[p]) - (g.snapshot[q] - x_old[q]);
            let tangent = rel - n * rel.dot(n);
            let slide = tangent.length();
            if slide > R::ZERO {
                slip += tangent * share.min(c.friction * push / slide);
            }
            contacts += 1;
        }
    }
    // The friction corrections are averaged where the pushes are summed:
    // each takes at most its share of one pair's slide, and a sum of them
    // over many contacts sliding alike would move the particle past the
    // others (the slide reversed, energy added at every pass); their mean
    // keeps the new relative slide between zero and the old.
    (contacts > 0).then(|| xp + (sum - slip / R::from_f64(f64::from(contacts))))
}

/// Self-collision on the predicted positions `x`, the step having started
/// at `w.x_old`: the build, the Jacobi passes and the cap. Returns whether
/// it moved any particle (`false` without self-collision).
pub fn apply<R: Real>(sys: &System<R>, x: &mut [Vec3<R>], w: &mut Workspace<R>) -> bool {
    if w.contacts.is_some() {
        return super::triangle_contact::apply(sys, x, w);
    }
    let (Some(c), Some(g)) = (&sys.self_collision, &mut w.self_grid) else {
        return false;
    };
    build(c, x, g);
    let mut moved = false;
    for k in 0..c.iterations {
        g.snapshot.copy_from_slice(x);
        let last = k + 1 == c.iterations;
        for (p, xp) in x.iter_mut().enumerate() {
            let (new, m) = pass(sys, c, g, &w.x_old, p, last);
            *xp = new;
            moved |= m;
        }
    }
    moved
}

/// Twin of `self_collision_respond` (one pass) for particle `p`: its
/// position after the pass from the snapshot `g.snapshot` ([`respond`]),
/// on the `last` pass with its displacement since `x_old`, less the
/// reference particle's in the snapshot, capped at `c.cap`; and whether
/// the pass moved it (a contact or the cap).
pub fn pass<R: Real>(
    sys: &System<R>,
    c: &SelfCollisionR<R>,
    g: &Grid<R>,
    x_old: &[Vec3<R>],
    p: usize,
    last: bool,
) -> (Vec3<R>, bool) {
    let (mut x, mut moved) = match respond(sys, c, g, x_old, p) {
        Some(new) => (new, true),
        None => (g.snapshot[p], false),
    };
    if last && sys.inv_mass[p] > R::ZERO {
        let r = c.reference;
        let carried = g.snapshot[r] - x_old[r];
        let dx = (x - x_old[p]) - carried;
        let l2 = dx.length_squared();
        if l2 > c.cap * c.cap {
            x = (x_old[p] + carried) + dx * (c.cap / l2.sqrt());
            moved = true;
        }
    }
    (x, moved)
}

/// The implicit step's projection: [`apply`] to `st.x`, which the step
/// moved from `w.x_old`, and `v += Δx / dt` of what it moved.
pub(crate) fn project<R: Real>(sys: &System<R>, st: &mut State<R>, w: &mut Workspace<R>) {
    match &mut w.self_grid {
        Some(g) => g.before.copy_from_slice(&st.x),
        None => return,
    }
    if apply(sys, &mut st.x, w) {
        if let Some(g) = &w.self_grid {
            let inv_dt = R::ONE / sys.dt;
            for p in 0..st.x.len() {
                if sys.inv_mass[p] > R::ZERO {
                    st.v[p] += (st.x[p] - g.before[p]) * inv_dt;
                }
            }
        }
    }
}
